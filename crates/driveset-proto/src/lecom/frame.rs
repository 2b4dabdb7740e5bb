//! The plain request and response types of LECOM-A/B: what the host sends
//! (RECEIVE 8.H, SEND 8.I, BROADCAST / MULTICAST 8.J) and what a controller
//! answers (8.H a, 8.I a). Owns [`Telegram`], [`Receive`], [`Send`],
//! [`Broadcast`] and [`Response`]; the bytes are in [`super::codec`].

use core::fmt;

use super::address::ControllerAddress;
use super::code::CodeAddress;
use super::error::EncodeError;
use super::value::Value;

/// RECEIVE (8.H): `EOT AD1 AD2 C1 C2 ENQ`, read a parameter of one
/// controller. Answered by [`Response::Value`], [`Response::ChecksumFault`]
/// or [`Response::NoSuchCode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Receive {
    pub address: ControllerAddress,
    pub code: CodeAddress,
}

impl Receive {
    /// # Errors
    /// [`EncodeError::ReceiveFromBroadcast`] for 00 / x0.
    pub const fn new(address: ControllerAddress, code: CodeAddress) -> Result<Self, EncodeError> {
        if address.is_broadcast() {
            Err(EncodeError::ReceiveFromBroadcast { address })
        } else {
            Ok(Self { address, code })
        }
    }
}

/// SEND (8.I): `EOT AD1 AD2 STX C1 C2 V1..Vn ETX BCC`, write a parameter of
/// one controller. Answered by [`Response::Ack`] or [`Response::Nak`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Send {
    pub address: ControllerAddress,
    pub code: CodeAddress,
    pub value: Value,
}

impl Send {
    /// # Errors
    /// [`EncodeError::SendToBroadcast`] for 00 / x0: use [`Broadcast`].
    pub const fn new(
        address: ControllerAddress,
        code: CodeAddress,
        value: Value,
    ) -> Result<Self, EncodeError> {
        if address.is_broadcast() {
            Err(EncodeError::SendToBroadcast { address })
        } else {
            Ok(Self {
                address,
                code,
                value,
            })
        }
    }
}

/// BROADCAST / MULTICAST (8.J): a SEND to 00 (all controllers) or x0 (the
/// group x1..x9). Nobody answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Broadcast {
    pub address: ControllerAddress,
    pub code: CodeAddress,
    pub value: Value,
}

impl Broadcast {
    /// # Errors
    /// [`EncodeError::BroadcastToStation`] unless the address is 00 or x0.
    pub const fn new(
        address: ControllerAddress,
        code: CodeAddress,
        value: Value,
    ) -> Result<Self, EncodeError> {
        if address.is_broadcast() {
            Ok(Self {
                address,
                code,
                value,
            })
        } else {
            Err(EncodeError::BroadcastToStation { address })
        }
    }
}

/// A host telegram (section 8: the three modes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Telegram {
    Receive(Receive),
    Send(Send),
    Broadcast(Broadcast),
}

impl Telegram {
    /// The controller address the telegram is sent to.
    pub const fn address(&self) -> ControllerAddress {
        match self {
            Self::Receive(t) => t.address,
            Self::Send(t) => t.address,
            Self::Broadcast(t) => t.address,
        }
    }

    /// The code field.
    pub const fn code(&self) -> CodeAddress {
        match self {
            Self::Receive(t) => t.code,
            Self::Send(t) => t.code,
            Self::Broadcast(t) => t.code,
        }
    }

    /// Whether the controller answers: RECEIVE and SEND yes, BROADCAST no
    /// (8.I a, 8.J).
    pub const fn expects_response(&self) -> bool {
        !matches!(self, Self::Broadcast(_))
    }
}

impl From<Receive> for Telegram {
    fn from(t: Receive) -> Self {
        Self::Receive(t)
    }
}

impl From<Send> for Telegram {
    fn from(t: Send) -> Self {
        Self::Send(t)
    }
}

impl From<Broadcast> for Telegram {
    fn from(t: Broadcast) -> Self {
        Self::Broadcast(t)
    }
}

impl fmt::Display for Telegram {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Receive(t) => write!(f, "RECEIVE {} @{}", t.code, t.address),
            Self::Send(t) => write!(f, "SEND {} = {} @{}", t.code, t.value, t.address),
            Self::Broadcast(t) => write!(f, "BROADCAST {} = {} @{}", t.code, t.value, t.address),
        }
    }
}

/// A controller's answer (8.H a for RECEIVE, 8.I a for SEND).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Response {
    /// `STX C1 C2 V1..Vn ETX BCC`: the requested value.
    Value { code: CodeAddress, value: Value },
    /// `STX C1 C2 ? ETX BCC`: the controller understood the request but saw
    /// a checksum (parity) fault in it.
    ChecksumFault { code: CodeAddress },
    /// `STX C1 C2 EOT`: the code number does not exist in this controller.
    NoSuchCode { code: CodeAddress },
    /// ACK (06 hex): the SEND was carried out.
    Ack,
    /// NAK (15 hex): the SEND was not carried out; the value is unchanged.
    Nak,
}

impl Response {
    /// The code field echoed by a RECEIVE answer; `None` for ACK / NAK.
    pub const fn code(&self) -> Option<CodeAddress> {
        match self {
            Self::Value { code, .. } | Self::ChecksumFault { code } | Self::NoSuchCode { code } => {
                Some(*code)
            }
            Self::Ack | Self::Nak => None,
        }
    }
}

impl fmt::Display for Response {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Value { code, value } => write!(f, "{code} = {value}"),
            Self::ChecksumFault { code } => write!(f, "{code}: checksum (parity) fault"),
            Self::NoSuchCode { code } => write!(f, "{code}: no such code"),
            Self::Ack => f.write_str("ACK"),
            Self::Nak => f.write_str("NAK"),
        }
    }
}
