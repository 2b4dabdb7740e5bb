//! LUSTBUS telegram types: addresses (section 4.2), CODE strings (section
//! 2.4), the VALUE string (section 2.3) and the host/device telegrams
//! (sections 6.1, 6.2). Plain data; bytes are made and read in
//! [`super::codec`] and [`super::stream`].

use core::fmt;

use crate::ascii::{ACK, ENQ, EOT, ETX, NAK, STX};

use super::value::{Dialect, ParameterValue, ValueError};

/// Longest VALUE string (section 2.3: "between 1 and 100 characters").
pub const MAX_VALUE_LEN: usize = 100;

/// A device address (section 2.2 ADR, section 4.2).
///
/// Number 0 is `'@'` (0x40, every device answers), 1..=30 are `'A'..='^'`
/// (0x41..=0x5E), 31 is the broadcast address `'_'` (0x5F): every device
/// acts on a SELECT, none replies.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Address(u8);

impl Address {
    /// Address 0, `'@'`: answered by every device whatever its own address.
    pub const ALL: Self = Self(0);
    /// Address 31, `'_'` (0x5F): broadcast, no device replies.
    pub const BROADCAST: Self = Self(31);

    /// Address number 0..=31.
    pub const fn new(number: u8) -> Option<Self> {
        if number <= 31 {
            Some(Self(number))
        } else {
            None
        }
    }

    /// The address number 0..=31.
    pub const fn number(self) -> u8 {
        self.0
    }

    /// The ADR character, 0x40 + number.
    pub const fn to_byte(self) -> u8 {
        0x40 + self.0
    }

    /// Reads an ADR character (0x40..=0x5F; the parity bit must already be
    /// masked).
    pub const fn from_byte(b: u8) -> Option<Self> {
        if b >= 0x40 && b <= 0x5F {
            Some(Self(b - 0x40))
        } else {
            None
        }
    }

    /// Whether a device replies to a telegram sent to this address: every
    /// address but broadcast (31). (Address 0 gets a reply from every
    /// connected device at once, section 9.1.)
    pub const fn expects_reply(self) -> bool {
        self.0 != 31
    }

    /// A device's own address (1..=30).
    pub const fn is_individual(self) -> bool {
        self.0 >= 1 && self.0 <= 30
    }
}

impl fmt::Debug for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Address({} '{}')", self.0, self.to_byte() as char)
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The numerically compatible parameters that both families serve under
/// CODE `000xx` (section 5.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompatibleParameter {
    /// 81: SIOC (VF1000) / SBAUD (MC): baud rate.
    Baud = 81,
    /// 82: SIOA / SADDR: device address.
    Address = 82,
    /// 83: SIOW / SDMMY: watchdog dummy / scratch.
    Dummy = 83,
    /// 84: SIOT / SWDGT: watchdog time.
    Watchdog = 84,
    /// 85: SIOF / SERR: serial interface error status (see [`super::Siof`]).
    Siof = 85,
    /// 91: TYPE: device type.
    Type = 91,
}

impl CompatibleParameter {
    /// Every numerically compatible parameter, in number order (section
    /// 5.2). The one table of them: the clients, the simulator and the
    /// family descriptor (`driveset_schema::Descriptor::compatible`) ask it.
    pub const ALL: [Self; 6] = [
        Self::Baud,
        Self::Address,
        Self::Dummy,
        Self::Watchdog,
        Self::Siof,
        Self::Type,
    ];

    /// The numbers of [`CompatibleParameter::ALL`] (81, 82, 83, 84, 85, 91).
    pub const NUMBERS: [u32; 6] = {
        let mut n = [0; 6];
        let mut i = 0;
        while i < n.len() {
            n[i] = Self::ALL[i].number() as u32;
            i += 1;
        }
        n
    };

    /// Whether parameter `n` is numerically compatible (81..=85, 91;
    /// section 5.2).
    pub const fn contains(n: u32) -> bool {
        n <= u16::MAX as u32 && Self::from_number(n as u16).is_some()
    }

    /// The parameter number.
    pub const fn number(self) -> u8 {
        self as u8
    }
    /// The parameter for a number, if it is one of 81..=85, 91.
    pub const fn from_number(n: u16) -> Option<Self> {
        Some(match n {
            81 => Self::Baud,
            82 => Self::Address,
            83 => Self::Dummy,
            84 => Self::Watchdog,
            85 => Self::Siof,
            91 => Self::Type,
            _ => return None,
        })
    }
}

/// A CODE string: five ASCII decimal digits, most significant first
/// (section 2.4). Stored as its number 0..=99999.
///
/// Any five digits are a syntactically valid CODE (a device answers an
/// improper one with NAK, section 3); [`ParameterCode::meaning`] says what a
/// code addresses.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParameterCode(u32);

impl ParameterCode {
    /// PosMOD1 channel of the MC6000, CODE 49999 (section 11.6).
    pub const POSMOD: Self = Self(49999);

    /// Any code 0..=99999.
    pub const fn new(number: u32) -> Option<Self> {
        if number <= 99_999 {
            Some(Self(number))
        } else {
            None
        }
    }

    /// The code as a number, e.g. 112 for `"00112"`.
    pub const fn number(self) -> u32 {
        self.0
    }

    /// Reads five ASCII digits.
    pub const fn from_digits(d: [u8; 5]) -> Option<Self> {
        let mut n = 0u32;
        let mut i = 0;
        while i < 5 {
            if !d[i].is_ascii_digit() {
                return None;
            }
            n = n * 10 + (d[i] - b'0') as u32;
            i += 1;
        }
        Some(Self(n))
    }

    /// The five ASCII digits.
    pub const fn digits(self) -> [u8; 5] {
        let mut d = [b'0'; 5];
        let mut n = self.0;
        let mut i = 5;
        while i > 0 {
            i -= 1;
            d[i] = b'0' + (n % 10) as u8;
            n /= 10;
        }
        d
    }

    const fn vf(specifier: u32, device: u8, parameter: u8) -> Option<Self> {
        if device > 9 || parameter > 99 {
            return None;
        }
        Some(Self(
            specifier * 10_000 + device as u32 * 100 + parameter as u32,
        ))
    }

    /// VF1000 value access, `0 0 d pp` (section 2.4.1): specifier 0, data set
    /// 0, device number `device` (0 = basis parameter, 1 = VF1000, section
    /// 11.1), 2-digit parameter. The examples use device 1 (`00112`, 6.1.1.1)
    /// and device 0 (`00001`, 7.1.1).
    pub const fn vf_value(device: u8, parameter: u8) -> Option<Self> {
        Self::vf(0, device, parameter)
    }

    /// VF1000 parameter description, `1 0 d pp` (sections 2.4.1, 11.1).
    pub const fn vf_description(device: u8, parameter: u8) -> Option<Self> {
        Self::vf(1, device, parameter)
    }

    /// A numerically compatible parameter, `000xx` on both families
    /// (section 5.2).
    pub const fn compatible(parameter: CompatibleParameter) -> Self {
        Self(parameter as u32)
    }

    /// MC6000/7000 value access, `2 0 ppp` (section 2.4.2).
    pub const fn mc_value(parameter: u16) -> Option<Self> {
        if parameter > 999 {
            return None;
        }
        Some(Self(20_000 + parameter as u32))
    }

    /// MC6000/7000 parameter description, `3 0 ppp` (sections 2.4.2, 11.2).
    pub const fn mc_description(parameter: u16) -> Option<Self> {
        if parameter > 999 {
            return None;
        }
        Some(Self(30_000 + parameter as u32))
    }

    /// MC6000/7000 value substitution text of a parameter, `6 1 ppp`
    /// (section 11.3; specifier 6 "special functions"), the text index being
    /// the value of 108-STEXT.
    pub const fn substitution_text(parameter: u16) -> Option<Self> {
        if parameter > 999 {
            return None;
        }
        Some(Self(61_000 + parameter as u32))
    }

    /// What this code addresses.
    pub const fn meaning(self) -> CodeMeaning {
        let spec = self.0 / 10_000;
        let set = (self.0 / 1000) % 10;
        let device = ((self.0 / 100) % 10) as u8;
        let p2 = (self.0 % 100) as u8;
        let p3 = (self.0 % 1000) as u16;
        match (spec, set) {
            (0, 0) => CodeMeaning::VfValue {
                device,
                parameter: p2,
            },
            (1, 0) => CodeMeaning::VfDescription {
                device,
                parameter: p2,
            },
            (2, 0) => CodeMeaning::McValue { parameter: p3 },
            (3, 0) => CodeMeaning::McDescription { parameter: p3 },
            (6, 1) => CodeMeaning::SubstitutionText { parameter: p3 },
            _ if self.0 == 49_999 => CodeMeaning::PosMod,
            _ => CodeMeaning::Other,
        }
    }

    /// The compatible parameter if this is a `000xx` code of one.
    pub const fn compatible_parameter(self) -> Option<CompatibleParameter> {
        if self.0 < 100 {
            CompatibleParameter::from_number(self.0 as u16)
        } else {
            None
        }
    }
}

impl fmt::Debug for ParameterCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ParameterCode({self})")
    }
}

impl fmt::Display for ParameterCode {
    /// The five digits, e.g. `00112`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:05}", self.0)
    }
}

/// What a [`ParameterCode`] addresses (sections 2.4, 5.2, 11.1-11.3, 11.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CodeMeaning {
    /// `0 0 d pp`: a VF1000 value, or with device 0 and 81..=85/91 a
    /// compatible parameter of either family.
    VfValue {
        /// Device number digit (0 basis, 1 VF1000).
        device: u8,
        /// Parameter 0..=99.
        parameter: u8,
    },
    /// `1 0 d pp`: a VF1000 parameter description.
    VfDescription {
        /// Device number digit.
        device: u8,
        /// Parameter 0..=99.
        parameter: u8,
    },
    /// `2 0 ppp`: an MC value.
    McValue {
        /// Parameter 0..=999.
        parameter: u16,
    },
    /// `3 0 ppp`: an MC parameter description.
    McDescription {
        /// Parameter 0..=999.
        parameter: u16,
    },
    /// `6 1 ppp`: an MC value substitution text.
    SubstitutionText {
        /// Parameter 0..=999.
        parameter: u16,
    },
    /// `49999`: PosMOD1.
    PosMod,
    /// Any other five digits (the device answers NAK).
    Other,
}

/// Shows a byte for error messages: printable ASCII as itself, control
/// characters by name.
pub(crate) struct Shown(pub u8);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self.0 {
            STX => "STX",
            ETX => "ETX",
            EOT => "EOT",
            ENQ => "ENQ",
            ACK => "ACK",
            NAK => "NAK",
            0 => "NUL",
            b if b.is_ascii_graphic() || b == b' ' => return write!(f, "'{}'", b as char),
            _ => "non-printing",
        };
        f.write_str(name)
    }
}

/// Whether `b` may appear inside VALUE: any 7-bit character but the six
/// framing controls STX, ETX, EOT, ENQ, ACK, NAK (which would end or
/// corrupt the telegram).
pub const fn is_value_byte(b: u8) -> bool {
    b <= 0x7F && !matches!(b, STX | ETX | EOT | ENQ | ACK | NAK)
}

/// Why bytes are not a valid VALUE string.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ValueTextError {
    /// Empty (section 2.3: 1..100 characters).
    #[error("VALUE is empty; it needs 1 to 100 characters (section 2.3)")]
    Empty,
    /// Longer than 100 characters.
    #[error("VALUE has {0} characters, more than 100 (section 2.3)")]
    TooLong(usize),
    /// Contains a framing control character or an 8-bit byte.
    #[error("VALUE character {offset} is {found:#04x}, which cannot be sent inside a telegram")]
    BadByte {
        /// Index in VALUE.
        offset: usize,
        /// The byte.
        found: u8,
    },
}

/// The VALUE string of a telegram: 1..=100 7-bit characters, none of them a
/// framing control character. Inline, no allocation.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct ValueText {
    len: u8,
    bytes: [u8; MAX_VALUE_LEN],
}

impl ValueText {
    /// Checks and copies a VALUE string.
    pub fn new(bytes: &[u8]) -> Result<Self, ValueTextError> {
        if bytes.is_empty() {
            return Err(ValueTextError::Empty);
        }
        if bytes.len() > MAX_VALUE_LEN {
            return Err(ValueTextError::TooLong(bytes.len()));
        }
        if let Some(offset) = bytes.iter().position(|&b| !is_value_byte(b)) {
            return Err(ValueTextError::BadByte {
                offset,
                found: bytes[offset],
            });
        }
        Ok(Self::from_valid(bytes))
    }

    /// Copies bytes already known to be valid (at most 100 are kept).
    pub(crate) fn from_valid(bytes: &[u8]) -> Self {
        let n = bytes.len().min(MAX_VALUE_LEN);
        let mut out = Self::empty();
        out.bytes[..n].copy_from_slice(&bytes[..n]);
        out.len = n as u8;
        out
    }

    pub(crate) const fn empty() -> Self {
        Self {
            len: 0,
            bytes: [0; MAX_VALUE_LEN],
        }
    }

    /// Appends one byte; false if full.
    pub(crate) fn push(&mut self, b: u8) -> bool {
        let n = self.len as usize;
        if n >= MAX_VALUE_LEN {
            return false;
        }
        self.bytes[n] = b;
        self.len += 1;
        true
    }

    /// The characters.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }

    /// Number of characters.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Never true for a checked VALUE; kept for API completeness.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl fmt::Debug for ValueText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ValueText(\"{}\")", self.as_bytes().escape_ascii())
    }
}

impl fmt::Display for ValueText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.as_bytes().escape_ascii())
    }
}

impl AsRef<[u8]> for ValueText {
    fn as_ref(&self) -> &[u8] {
        self.as_bytes()
    }
}

/// ENQUIRY telegram, host to device: `EOT ADR CODE ENQ` (section 6.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Enquiry {
    /// Addressed device.
    pub address: Address,
    /// Requested parameter.
    pub code: ParameterCode,
}

impl Enquiry {
    /// An ENQUIRY for `code` at `address`.
    pub const fn new(address: Address, code: ParameterCode) -> Self {
        Self { address, code }
    }
}

/// SELECT telegram, host to device: `EOT ADR STX CODE = VALUE ETX BCC`
/// (section 6.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Select {
    /// Addressed device (31 = broadcast, no reply).
    pub address: Address,
    /// Written parameter.
    pub code: ParameterCode,
    /// New value.
    pub value: ValueText,
}

impl Select {
    /// A SELECT of a raw VALUE string.
    pub const fn new(address: Address, code: ParameterCode, value: ValueText) -> Self {
        Self {
            address,
            code,
            value,
        }
    }

    /// A SELECT of a typed value, encoded for `family`.
    pub fn with_value(
        address: Address,
        code: ParameterCode,
        value: &ParameterValue,
        family: Dialect,
    ) -> Result<Self, ValueError> {
        Ok(Self::new(address, code, value.encode(family)?))
    }
}

/// ENQUIRY answer, device to host: `ADR STX CODE = VALUE ETX BCC`
/// (section 6.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ValueReply {
    /// Answering device's address as sent (the address it was asked under).
    pub address: Address,
    /// Parameter.
    pub code: ParameterCode,
    /// Value.
    pub value: ValueText,
}

impl ValueReply {
    /// Decodes the VALUE as a typed value.
    pub fn typed(
        &self,
        ty: super::value::ParameterType,
        family: Dialect,
    ) -> Result<ParameterValue, ValueError> {
        ParameterValue::decode(ty, family, self.value.as_bytes())
    }
}

/// A host telegram (master to slave).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Request {
    /// A lone EOT: ends a transaction, resets every receiver (section 3).
    Eot,
    /// ENQUIRY.
    Enquiry(Enquiry),
    /// SELECT.
    Select(Select),
}

/// A device telegram (slave to master).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reply {
    /// `ADR STX CODE = VALUE ETX BCC`: answer to an ENQUIRY.
    Value(ValueReply),
    /// `ADR ACK`: SELECT accepted.
    Ack(Address),
    /// `ADR NAK`: SELECT refused, or ENQUIRY of an unknown/read-protected
    /// parameter.
    Nak(Address),
}

impl Reply {
    /// The replying device's address.
    pub const fn address(&self) -> Address {
        match self {
            Reply::Value(v) => v.address,
            Reply::Ack(a) | Reply::Nak(a) => *a,
        }
    }
}

/// Who sent a telegram.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Host computer (master): telegrams begin with EOT.
    Host,
    /// Device (slave): replies begin with ADR.
    Device,
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Direction::Host => "host",
            Direction::Device => "device",
        })
    }
}

/// A telegram of either direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Telegram {
    /// Host to device.
    Request(Request),
    /// Device to host.
    Reply(Reply),
}

impl Telegram {
    /// Who sends this kind of telegram.
    pub const fn direction(&self) -> Direction {
        match self {
            Telegram::Request(_) => Direction::Host,
            Telegram::Reply(_) => Direction::Device,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_compatible_parameters_are_one_table() {
        assert_eq!(CompatibleParameter::NUMBERS, [81, 82, 83, 84, 85, 91]);
        for p in CompatibleParameter::ALL {
            let n = u32::from(p.number());
            assert_eq!(CompatibleParameter::from_number(p.number().into()), Some(p));
            assert!(CompatibleParameter::contains(n));
        }
        for n in [0, 80, 86, 90, 92, 181, 65_536 + 81] {
            assert!(!CompatibleParameter::contains(n), "{n}");
        }
    }

    #[test]
    fn addresses() {
        assert_eq!(Address::ALL.to_byte(), b'@');
        assert_eq!(Address::new(1).unwrap().to_byte(), 0x41);
        assert_eq!(Address::new(30).unwrap().to_byte(), 0x5E);
        assert_eq!(Address::BROADCAST.to_byte(), 0x5F);
        assert!(!Address::BROADCAST.expects_reply());
        assert!(Address::ALL.expects_reply());
        assert_eq!(Address::new(32), None);
        assert_eq!(Address::from_byte(0x3F), None);
        assert_eq!(Address::from_byte(0x60), None);
        assert_eq!(Address::from_byte(b'^'), Address::new(30));
    }

    #[test]
    fn codes() {
        let c = ParameterCode::vf_value(1, 12).unwrap();
        assert_eq!(&c.digits(), b"00112");
        assert_eq!(
            c.meaning(),
            CodeMeaning::VfValue {
                device: 1,
                parameter: 12
            }
        );
        assert_eq!(
            &ParameterCode::vf_description(1, 5).unwrap().digits(),
            b"10105"
        );
        assert_eq!(&ParameterCode::mc_value(77).unwrap().digits(), b"20077");
        assert_eq!(
            &ParameterCode::mc_description(428).unwrap().digits(),
            b"30428"
        );
        assert_eq!(
            &ParameterCode::substitution_text(107).unwrap().digits(),
            b"61107"
        );
        assert_eq!(
            ParameterCode::substitution_text(107).unwrap().meaning(),
            CodeMeaning::SubstitutionText { parameter: 107 }
        );
        let siof = ParameterCode::compatible(CompatibleParameter::Siof);
        assert_eq!(&siof.digits(), b"00085");
        assert_eq!(siof.compatible_parameter(), Some(CompatibleParameter::Siof));
        assert_eq!(&ParameterCode::POSMOD.digits(), b"49999");
        assert_eq!(ParameterCode::POSMOD.meaning(), CodeMeaning::PosMod);
        assert_eq!(
            ParameterCode::new(12345).unwrap().meaning(),
            CodeMeaning::Other
        );
        assert_eq!(ParameterCode::from_digits(*b"0011a"), None);
        assert_eq!(ParameterCode::new(100_000), None);
        assert_eq!(ParameterCode::mc_value(1000), None);
        assert_eq!(ParameterCode::vf_value(10, 1), None);
        assert_eq!(ParameterCode::vf_value(0, 100), None);
    }

    #[test]
    fn value_text_rules() {
        assert_eq!(ValueText::new(b""), Err(ValueTextError::Empty));
        assert_eq!(
            ValueText::new(&[b'0'; 101]),
            Err(ValueTextError::TooLong(101))
        );
        assert_eq!(
            ValueText::new(b"0\x031"),
            Err(ValueTextError::BadByte {
                offset: 1,
                found: ETX
            })
        );
        assert_eq!(
            ValueText::new(b"\x80"),
            Err(ValueTextError::BadByte {
                offset: 0,
                found: 0x80
            })
        );
        assert_eq!(ValueText::new(b"MODE\0\0").unwrap().len(), 6);
        assert_eq!(ValueText::new(&[b'A'; 100]).unwrap().len(), 100);
    }
}
