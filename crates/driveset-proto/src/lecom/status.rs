//! What went wrong, in the field's words: the C0068 operating status bit word
//! (Table 1 C0068; section 8.J c: "After a transmission fault, the master can
//! read C0068 and evaluate the communication error in bit 4...7"), the C1962
//! extended error code (Table 1 C1962), and the classification of a failed
//! exchange for a transaction engine. Owns [`OperatingStatus`],
//! [`CommunicationError`], [`ExtendedError`], [`ExchangeFailure`] and
//! [`Advice`].

use core::fmt;

use super::error::ValueError;
use super::frame::Response;
use super::value::{Hex, Value};

/// What an engine should do about an outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Advice {
    /// Nothing went wrong.
    Proceed,
    /// A transient transmission problem: repeat the telegram (a bounded
    /// number of times, 8.J b: "the number of repetitions is limited").
    Repeat,
    /// The controller refused without saying why: read C0068 bits 4..7 (or
    /// C1962) to learn the cause, then follow that cause's advice (8.J c).
    ReadCause,
    /// A permanent refusal: repeating will not help; fail with the cause.
    Fail,
}

/// The last communication error, C0068 bits 4..7 (Table 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CommunicationError {
    /// 0.
    NoFault,
    /// 1.
    ChecksumError,
    /// 2.
    ProtocolFrameError,
    /// 3: documented as reserved.
    Reserved,
    /// 4.
    InvalidCodeNumber,
    /// 5.
    InvalidVariable,
    /// 6.
    NoAccessPermission,
    /// 7.
    InterruptedByNewTelegram,
    /// 15.
    GeneralFault,
    /// 8..=14: not documented.
    Undocumented(u8),
}

impl CommunicationError {
    /// From the nibble value 0..=15 (higher bits are ignored).
    pub const fn from_nibble(n: u8) -> Self {
        match n & 0xF {
            0 => Self::NoFault,
            1 => Self::ChecksumError,
            2 => Self::ProtocolFrameError,
            3 => Self::Reserved,
            4 => Self::InvalidCodeNumber,
            5 => Self::InvalidVariable,
            6 => Self::NoAccessPermission,
            7 => Self::InterruptedByNewTelegram,
            15 => Self::GeneralFault,
            n => Self::Undocumented(n),
        }
    }

    /// The nibble value.
    pub const fn nibble(self) -> u8 {
        match self {
            Self::NoFault => 0,
            Self::ChecksumError => 1,
            Self::ProtocolFrameError => 2,
            Self::Reserved => 3,
            Self::InvalidCodeNumber => 4,
            Self::InvalidVariable => 5,
            Self::NoAccessPermission => 6,
            Self::InterruptedByNewTelegram => 7,
            Self::GeneralFault => 15,
            Self::Undocumented(n) => n,
        }
    }

    /// The manual's text.
    pub const fn text(self) -> &'static str {
        match self {
            Self::NoFault => "no fault",
            Self::ChecksumError => "check sum error",
            Self::ProtocolFrameError => "protocol frame error",
            Self::Reserved => "reserved",
            Self::InvalidCodeNumber => "invalid code number",
            Self::InvalidVariable => "invalid variable",
            Self::NoAccessPermission => "no access permission",
            Self::InterruptedByNewTelegram => "telegram processing interrupted by a new telegram",
            Self::GeneralFault => "general fault",
            Self::Undocumented(_) => "undocumented communication error",
        }
    }

    /// What to do: checksum and frame errors and interrupted processing are
    /// transmission problems (repeat, after letting the drive finish: one
    /// telegram at a time); invalid code / variable and no access permission
    /// will fail again; general, reserved and undocumented faults fail too
    /// rather than loop.
    pub const fn advice(self) -> Advice {
        match self {
            Self::NoFault => Advice::Proceed,
            Self::ChecksumError | Self::ProtocolFrameError | Self::InterruptedByNewTelegram => {
                Advice::Repeat
            }
            Self::Reserved
            | Self::InvalidCodeNumber
            | Self::InvalidVariable
            | Self::NoAccessPermission
            | Self::GeneralFault
            | Self::Undocumented(_) => Advice::Fail,
        }
    }
}

impl fmt::Display for CommunicationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.text(), self.nibble())
    }
}

/// Direction of rotation, C0068 bit 10.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rotation {
    Cw,
    Ccw,
}

/// The C0068 operating status bit word (Table 1 C0068, LECOM format VH).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct OperatingStatus(pub u16);

impl OperatingStatus {
    /// From the value of a C0068 reply: VH byte / word, a dword up to
    /// 0xFFFF, or an integral VD 0..=65535.
    ///
    /// # Errors
    /// [`ValueError::WrongFormat`] for anything else.
    pub fn from_value(value: &Value) -> Result<Self, ValueError> {
        let n = match value {
            Value::Hex(Hex::Byte(b)) => Some(u32::from(*b)),
            Value::Hex(Hex::Word(w)) => Some(u32::from(*w)),
            Value::Hex(Hex::Dword(d)) => Some(*d),
            Value::Decimal(d) => d.as_integer().and_then(|n| u32::try_from(n).ok()),
            _ => None,
        };
        n.and_then(|n| u16::try_from(n).ok())
            .map(Self)
            .ok_or(ValueError::WrongFormat {
                expected: "16-bit VH (C0068)",
            })
    }

    /// Bits 0..3: the tens digit of the LECOM fault number of the active
    /// fault (Table 2; e.g. TRIP OH = 50 -> 5). 0 = no fault.
    pub const fn fault_tens_digit(self) -> u8 {
        (self.0 & 0xF) as u8
    }

    /// Bits 4..7: the last communication error.
    pub const fn last_communication_error(self) -> CommunicationError {
        CommunicationError::from_nibble((self.0 >> 4) as u8)
    }

    const fn bit(self, n: u8) -> bool {
        self.0 & (1 << n) != 0
    }

    /// Bit 8: control via LECOM enabled.
    pub const fn control_via_lecom(self) -> bool {
        self.bit(8)
    }

    /// Bit 9: actual frequency above the threshold C17.
    pub const fn above_threshold(self) -> bool {
        self.bit(9)
    }

    /// Bit 10: direction of rotation, 0 = CW, 1 = CCW.
    pub const fn rotation(self) -> Rotation {
        if self.bit(10) {
            Rotation::Ccw
        } else {
            Rotation::Cw
        }
    }

    /// Bit 11: power stage transistors energized (pulses enabled, i.e. no
    /// pulse inhibit).
    pub const fn power_stage_energized(self) -> bool {
        self.bit(11)
    }

    /// Bit 12: quick stop active.
    pub const fn quick_stop(self) -> bool {
        self.bit(12)
    }

    /// Bit 13: current limit reached.
    pub const fn current_limit(self) -> bool {
        self.bit(13)
    }

    /// Bit 14: setpoint frequency reached.
    pub const fn setpoint_reached(self) -> bool {
        self.bit(14)
    }

    /// Bit 15: a fault occurred (TRIP).
    pub const fn fault_occurred(self) -> bool {
        self.bit(15)
    }

    /// One line per field: (Table 1 name, state), in bit order.
    pub fn describe(self) -> [(&'static str, &'static str); 10] {
        let yes_no = |b: bool| if b { "yes" } else { "no" };
        [
            (
                "fault (tens digit of LECOM fault number)",
                digit_text(self.fault_tens_digit()),
            ),
            (
                "last communication error",
                self.last_communication_error().text(),
            ),
            (
                "control via LECOM enabled",
                yes_no(self.control_via_lecom()),
            ),
            (
                "actual frequency above threshold C17",
                yes_no(self.above_threshold()),
            ),
            (
                "direction of rotation",
                match self.rotation() {
                    Rotation::Cw => "CW",
                    Rotation::Ccw => "CCW",
                },
            ),
            (
                "power stage transistors energized",
                yes_no(self.power_stage_energized()),
            ),
            ("quick stop active", yes_no(self.quick_stop())),
            ("current limit", yes_no(self.current_limit())),
            (
                "setpoint frequency reached",
                yes_no(self.setpoint_reached()),
            ),
            ("fault occurred", yes_no(self.fault_occurred())),
        ]
    }
}

const fn digit_text(d: u8) -> &'static str {
    match d {
        0 => "0 (no fault)",
        1 => "1",
        2 => "2",
        3 => "3",
        4 => "4",
        5 => "5",
        6 => "6",
        7 => "7",
        8 => "8",
        9 => "9",
        10 => "10",
        11 => "11",
        12 => "12",
        13 => "13",
        14 => "14",
        _ => "15",
    }
}

impl fmt::Display for OperatingStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "C0068 = H{:04X}", self.0)?;
        for (name, state) in self.describe() {
            write!(f, "; {name}: {state}")?;
        }
        Ok(())
    }
}

/// The C1962 error code (Table 1 C1962).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExtendedError {
    /// 0.
    NoFault,
    /// 3.
    InvalidDataType,
    /// 4.
    InvalidSubcode,
    /// 5.
    InvalidCode,
    /// 8.
    NoAccessPermission,
    /// 9.
    ReadOnly,
    /// 11.
    DataBlockTooLong,
    /// 14.
    InvalidVariable,
    /// 17.
    GeneralFault,
    /// 210.
    ChecksumError,
    /// 211.
    TelegramInterruption,
    /// 212.
    InvalidEntry,
    /// 214.
    ParityError,
    /// Any other number.
    Undocumented(u32),
}

impl ExtendedError {
    /// From the C1962 value.
    pub const fn from_code(n: u32) -> Self {
        match n {
            0 => Self::NoFault,
            3 => Self::InvalidDataType,
            4 => Self::InvalidSubcode,
            5 => Self::InvalidCode,
            8 => Self::NoAccessPermission,
            9 => Self::ReadOnly,
            11 => Self::DataBlockTooLong,
            14 => Self::InvalidVariable,
            17 => Self::GeneralFault,
            210 => Self::ChecksumError,
            211 => Self::TelegramInterruption,
            212 => Self::InvalidEntry,
            214 => Self::ParityError,
            n => Self::Undocumented(n),
        }
    }

    /// From the value of a C1962 reply (VD integer or VH).
    ///
    /// # Errors
    /// [`ValueError::WrongFormat`] for a fraction, a negative number, VS or VO.
    pub fn from_value(value: &Value) -> Result<Self, ValueError> {
        let n = match value {
            Value::Decimal(d) => d.as_integer().and_then(|n| u32::try_from(n).ok()),
            Value::Hex(h) => Some(h.get()),
            _ => None,
        };
        n.map(Self::from_code).ok_or(ValueError::WrongFormat {
            expected: "non-negative integer (C1962)",
        })
    }

    /// The number.
    pub const fn code(self) -> u32 {
        match self {
            Self::NoFault => 0,
            Self::InvalidDataType => 3,
            Self::InvalidSubcode => 4,
            Self::InvalidCode => 5,
            Self::NoAccessPermission => 8,
            Self::ReadOnly => 9,
            Self::DataBlockTooLong => 11,
            Self::InvalidVariable => 14,
            Self::GeneralFault => 17,
            Self::ChecksumError => 210,
            Self::TelegramInterruption => 211,
            Self::InvalidEntry => 212,
            Self::ParityError => 214,
            Self::Undocumented(n) => n,
        }
    }

    /// The manual's text.
    pub const fn text(self) -> &'static str {
        match self {
            Self::NoFault => "no fault",
            Self::InvalidDataType => "invalid data type",
            Self::InvalidSubcode => "invalid subcode value",
            Self::InvalidCode => "invalid code value",
            Self::NoAccessPermission => "no access permission",
            Self::ReadOnly => "read only parameter",
            Self::DataBlockTooLong => "data block too long",
            Self::InvalidVariable => "invalid variable",
            Self::GeneralFault => "general fault",
            Self::ChecksumError => "checksum error",
            Self::TelegramInterruption => "telegram interruption",
            Self::InvalidEntry => "invalid entry",
            Self::ParityError => "parity error",
            Self::Undocumented(_) => "undocumented error",
        }
    }

    /// What to do: checksum, parity and interruption are transmission
    /// problems (repeat); everything else is a refusal of this telegram by
    /// this drive (fail with the cause).
    pub const fn advice(self) -> Advice {
        match self {
            Self::NoFault => Advice::Proceed,
            Self::ChecksumError | Self::TelegramInterruption | Self::ParityError => Advice::Repeat,
            _ => Advice::Fail,
        }
    }
}

impl fmt::Display for ExtendedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.text(), self.code())
    }
}

/// How an exchange with a controller failed, as a transaction engine sees
/// it (8.H a, 8.I a, 8.J b).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExchangeFailure {
    /// NAK to a SEND: the value was not changed; the reason is in C0068
    /// bits 4..7 / C1962.
    Nak,
    /// `STX C1 C2 ? ETX BCC` to a RECEIVE: the request arrived with a
    /// checksum (parity) fault.
    ChecksumFaultReply,
    /// `STX C1 C2 EOT` to a RECEIVE: the code does not exist in this
    /// controller.
    NoSuchCode,
    /// No answer within the monitoring time: wrong address, a fault in a
    /// character (including ENQ), a faulty line, or a broadcast (8.J b).
    NoAnswer,
    /// An answer that could not be decoded (bad BCC, garbage, an echo of
    /// another code).
    Garbled,
}

impl ExchangeFailure {
    /// The failure a response stands for; `None` for a value reply and ACK.
    /// (Whether a value reply echoes the requested code is for the caller to
    /// check: a mismatch is [`ExchangeFailure::Garbled`].)
    pub const fn of(response: &Response) -> Option<Self> {
        match response {
            Response::Value { .. } | Response::Ack => None,
            Response::Nak => Some(Self::Nak),
            Response::ChecksumFault { .. } => Some(Self::ChecksumFaultReply),
            Response::NoSuchCode { .. } => Some(Self::NoSuchCode),
        }
    }

    /// What to do about it.
    pub const fn advice(self) -> Advice {
        match self {
            Self::Nak => Advice::ReadCause,
            Self::ChecksumFaultReply | Self::NoAnswer | Self::Garbled => Advice::Repeat,
            Self::NoSuchCode => Advice::Fail,
        }
    }

    /// A sentence for an operator.
    pub const fn text(self) -> &'static str {
        match self {
            Self::Nak => {
                "the controller refused the value (NAK); read C0068 bits 4..7 or C1962 for the reason"
            }
            Self::ChecksumFaultReply => {
                "the controller saw a checksum (parity) fault in the request; repeat it"
            }
            Self::NoSuchCode => {
                "the code does not exist in this controller (wrong device family or firmware?)"
            }
            Self::NoAnswer => {
                "no answer within the monitoring time; check address, baud rate and line, then repeat"
            }
            Self::Garbled => "the answer could not be decoded; repeat",
        }
    }
}

impl fmt::Display for ExchangeFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.text())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lecom::value::Decimal;

    #[test]
    fn spec_8h_example_2_c68_h0900_bit_by_bit() {
        let s = OperatingStatus::from_value(&Value::Hex(Hex::Word(0x0900))).unwrap();
        assert_eq!(s, OperatingStatus(0x0900));
        // The manual's interpretation list, in its order:
        assert!(!s.fault_occurred(), "TRIP status: not active (bit 15)");
        assert!(!s.current_limit(), "maximum current: not reached (bit 13)");
        assert!(!s.quick_stop(), "quick stop: not active (bit 12)");
        assert!(
            s.power_stage_energized(),
            "pulse inhibit status: free (bit 11)"
        );
        assert_eq!(
            s.rotation(),
            Rotation::Cw,
            "direction of rotation: CW (bit 10)"
        );
        assert!(!s.above_threshold(), "Qmin status: not active (bit 9)");
        assert!(s.control_via_lecom(), "controller enable: enabled (bit 8)");
        assert_eq!(
            s.fault_tens_digit(),
            0,
            "operating fault: did not occur (bits 0..3)"
        );
        assert_eq!(
            s.last_communication_error(),
            CommunicationError::NoFault,
            "communication error: did not occur (bits 4..7)"
        );
        assert!(!s.setpoint_reached());
        assert_eq!(
            s.to_string(),
            "C0068 = H0900; fault (tens digit of LECOM fault number): 0 (no fault); \
             last communication error: no fault; control via LECOM enabled: yes; \
             actual frequency above threshold C17: no; direction of rotation: CW; \
             power stage transistors energized: yes; quick stop active: no; \
             current limit: no; setpoint frequency reached: no; fault occurred: no"
        );
    }

    #[test]
    fn c0068_fields() {
        let s = OperatingStatus(0xF415);
        assert_eq!(s.fault_tens_digit(), 5);
        assert_eq!(
            s.last_communication_error(),
            CommunicationError::ChecksumError
        );
        assert_eq!(s.rotation(), Rotation::Ccw);
        assert!(s.fault_occurred() && s.setpoint_reached() && s.current_limit() && s.quick_stop());
        assert!(!s.control_via_lecom() && !s.above_threshold() && !s.power_stage_energized());
        assert_eq!(
            OperatingStatus::from_value(&Value::Decimal(Decimal::from_int(2304).unwrap())).unwrap(),
            OperatingStatus(0x0900)
        );
        assert!(OperatingStatus::from_value(&Value::Hex(Hex::Dword(0x1_0000))).is_err());
        assert!(
            OperatingStatus::from_value(&Value::Decimal(Decimal::from_raw(5).unwrap())).is_err()
        );
    }

    #[test]
    fn c0068_communication_errors() {
        let table = [
            (0, CommunicationError::NoFault, Advice::Proceed),
            (1, CommunicationError::ChecksumError, Advice::Repeat),
            (2, CommunicationError::ProtocolFrameError, Advice::Repeat),
            (3, CommunicationError::Reserved, Advice::Fail),
            (4, CommunicationError::InvalidCodeNumber, Advice::Fail),
            (5, CommunicationError::InvalidVariable, Advice::Fail),
            (6, CommunicationError::NoAccessPermission, Advice::Fail),
            (
                7,
                CommunicationError::InterruptedByNewTelegram,
                Advice::Repeat,
            ),
            (15, CommunicationError::GeneralFault, Advice::Fail),
            (9, CommunicationError::Undocumented(9), Advice::Fail),
        ];
        for (n, e, a) in table {
            assert_eq!(CommunicationError::from_nibble(n), e);
            assert_eq!(e.nibble(), n);
            assert_eq!(e.advice(), a);
            assert_eq!(
                OperatingStatus(u16::from(n) << 4).last_communication_error(),
                e
            );
        }
        assert_eq!(
            CommunicationError::ChecksumError.to_string(),
            "check sum error (1)"
        );
    }

    #[test]
    fn c1962_codes() {
        let table = [
            (0, "no fault", Advice::Proceed),
            (3, "invalid data type", Advice::Fail),
            (4, "invalid subcode value", Advice::Fail),
            (5, "invalid code value", Advice::Fail),
            (8, "no access permission", Advice::Fail),
            (9, "read only parameter", Advice::Fail),
            (11, "data block too long", Advice::Fail),
            (14, "invalid variable", Advice::Fail),
            (17, "general fault", Advice::Fail),
            (210, "checksum error", Advice::Repeat),
            (211, "telegram interruption", Advice::Repeat),
            (212, "invalid entry", Advice::Fail),
            (214, "parity error", Advice::Repeat),
        ];
        for (n, text, advice) in table {
            let e = ExtendedError::from_code(n);
            assert!(!matches!(e, ExtendedError::Undocumented(_)), "{n}");
            assert_eq!(e.code(), n);
            assert_eq!(e.text(), text);
            assert_eq!(e.advice(), advice);
        }
        assert_eq!(
            ExtendedError::from_code(213),
            ExtendedError::Undocumented(213)
        );
        assert_eq!(ExtendedError::from_code(213).advice(), Advice::Fail);
        assert_eq!(
            ExtendedError::from_value(&Value::Decimal(Decimal::from_int(210).unwrap())).unwrap(),
            ExtendedError::ChecksumError
        );
        assert!(
            ExtendedError::from_value(&Value::Decimal(Decimal::from_int(-1).unwrap())).is_err()
        );
        assert_eq!(
            ExtendedError::ReadOnly.to_string(),
            "read only parameter (9)"
        );
    }

    #[test]
    fn exchange_failures() {
        assert_eq!(ExchangeFailure::Nak.advice(), Advice::ReadCause);
        assert_eq!(ExchangeFailure::ChecksumFaultReply.advice(), Advice::Repeat);
        assert_eq!(ExchangeFailure::NoSuchCode.advice(), Advice::Fail);
        assert_eq!(ExchangeFailure::NoAnswer.advice(), Advice::Repeat);
        assert_eq!(ExchangeFailure::Garbled.advice(), Advice::Repeat);
        assert_eq!(ExchangeFailure::of(&Response::Ack), None);
        assert_eq!(
            ExchangeFailure::of(&Response::Nak),
            Some(ExchangeFailure::Nak)
        );
        let code = crate::lecom::code::CodeAddress::select(46, 0);
        assert_eq!(
            ExchangeFailure::of(&Response::ChecksumFault { code }),
            Some(ExchangeFailure::ChecksumFaultReply)
        );
        assert_eq!(
            ExchangeFailure::of(&Response::NoSuchCode { code }),
            Some(ExchangeFailure::NoSuchCode)
        );
    }
}
