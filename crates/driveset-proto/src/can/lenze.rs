//! Lenze addressing and value formats on the system bus: owns the mapping
//! code number -> CANopen [`Index`], the [`Fix32`] fixed-point format and the
//! bit-coded format of C0135/C0150.
//!
//! Source: ECS manual (EDBCSXA064 EN 3.2) page 454, "Addressing by index and
//! subindex": `Index = 24575 - (Lenze code number)`, and the note "Lenze
//! parameters are mainly represented as data type FIX32 (32bit value with
//! sign, decimally with four decimal positions) ... The parameters C0135 and
//! C0150 must be transmitted bit-coded and without a factor."

use core::fmt;
use core::str::FromStr;

/// The index that code number 0 maps to (page 454: `Index = 24575 - code`).
pub const INDEX_BASE: u16 = 24575;

/// A Lenze code number (the `1234` of "C1234"), 0..=24575.
///
/// Codes above 24575 have no index under the page 454 formula (the result
/// would be negative) and are rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CodeNumber(u16);

/// A CANopen object dictionary index (16 bits, little-endian in bytes 2-3 of
/// an SDO frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Index(pub u16);

/// A CANopen subindex (byte 4 of an SDO frame). Lenze codes without
/// subcodes use subindex 0; a code's subcode `n` is subindex `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Subindex(pub u8);

/// Why a code number or index is not a valid Lenze address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MappingError {
    /// The code number is above 24575 (page 454: the index would be negative).
    #[error("code number {0} is out of range 0..=24575 (page 454: index = 24575 - code)")]
    CodeOutOfRange(u32),
    /// The index is above 0x5FFF (24575): it is not a Lenze code.
    #[error("index 0x{0:04X} is above 0x5FFF and addresses no Lenze code")]
    IndexNotACode(u16),
}

impl CodeNumber {
    /// The highest code number (index 0x0000).
    pub const MAX: CodeNumber = CodeNumber(INDEX_BASE);

    /// A code number, 0..=24575.
    pub const fn new(code: u32) -> Result<Self, MappingError> {
        if code <= INDEX_BASE as u32 {
            Ok(CodeNumber(code as u16))
        } else {
            Err(MappingError::CodeOutOfRange(code))
        }
    }

    /// The number itself.
    pub const fn get(self) -> u16 {
        self.0
    }

    /// `Index = 24575 - code` (page 454). C0011 -> 24564 = 0x5FF4.
    pub const fn index(self) -> Index {
        Index(INDEX_BASE - self.0)
    }

    /// The code an index addresses, the inverse of [`CodeNumber::index`].
    pub const fn from_index(index: Index) -> Result<Self, MappingError> {
        if index.0 <= INDEX_BASE {
            Ok(CodeNumber(INDEX_BASE - index.0))
        } else {
            Err(MappingError::IndexNotACode(index.0))
        }
    }

    /// The wire format page 454 gives for this code: bit-coded for C0135 and
    /// C0150, FIX32 otherwise. ("mainly" FIX32: a schema may know better for
    /// a particular code, e.g. a string; it overrides this default.)
    pub const fn value_format(self) -> ValueFormat {
        match self.0 {
            135 | 150 => ValueFormat::BitCoded,
            _ => ValueFormat::Fix32,
        }
    }
}

impl TryFrom<u32> for CodeNumber {
    type Error = MappingError;
    fn try_from(code: u32) -> Result<Self, Self::Error> {
        CodeNumber::new(code)
    }
}

impl From<CodeNumber> for Index {
    fn from(code: CodeNumber) -> Index {
        code.index()
    }
}

impl fmt::Display for CodeNumber {
    /// Lenze's spelling: `C0011`, `C1234`, `C24575`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "C{:04}", self.0)
    }
}

impl fmt::Display for Index {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "0x{:04X}", self.0)
    }
}

impl fmt::Display for Subindex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// How a code's value is carried in the 4 data bytes (page 454 note).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ValueFormat {
    /// Signed 32 bit, value x 10000.
    Fix32,
    /// Unsigned 32 bit bit field, no factor (C0135, C0150).
    BitCoded,
}

/// FIX32: a signed 32-bit integer holding the value times 10000 (page 454:
/// "decimally with four decimal positions ... multiplied by 10,000").
///
/// The raw integer is kept; conversion from and to decimal text is exact
/// (no floating point): `"50.0"` <-> raw `500000`. The range is
/// -214748.3648 ..= 214748.3647.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Fix32(pub i32);

/// Why a decimal text is not a FIX32 value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Fix32Error {
    /// Empty, a stray character, no digits, or a second point.
    #[error("not a decimal number (expected e.g. `50`, `-0.5`, `12.3456`)")]
    Syntax,
    /// More than four decimals: FIX32 cannot hold it exactly.
    #[error("more than 4 decimals: FIX32 holds 4 decimal places exactly")]
    TooManyDecimals,
    /// Outside -214748.3648 ..= 214748.3647.
    #[error("out of the FIX32 range -214748.3648..=214748.3647")]
    OutOfRange,
}

impl Fix32 {
    /// The factor between the value and the raw integer.
    pub const SCALE: i32 = 10_000;
    /// The smallest value, -214748.3648.
    pub const MIN: Fix32 = Fix32(i32::MIN);
    /// The largest value, 214748.3647.
    pub const MAX: Fix32 = Fix32(i32::MAX);

    /// The raw integer (value x 10000).
    pub const fn raw(self) -> i32 {
        self.0
    }

    /// A whole number, or `None` if `n * 10000` does not fit.
    pub const fn from_integer(n: i32) -> Option<Fix32> {
        match n.checked_mul(Self::SCALE) {
            Some(raw) => Some(Fix32(raw)),
            None => None,
        }
    }

    /// The four data bytes, little-endian (bytes 5-8 of the SDO frame).
    pub const fn to_le_bytes(self) -> [u8; 4] {
        self.0.to_le_bytes()
    }

    /// From the four data bytes, little-endian.
    pub const fn from_le_bytes(b: [u8; 4]) -> Fix32 {
        Fix32(i32::from_le_bytes(b))
    }

    /// Parses decimal text: optional sign, digits, optional point and up to
    /// four decimals (`50`, `50.`, `.5`, `-0.0001`, `+12.3456`). Exact; a
    /// fifth decimal is rejected even if it is zero.
    pub fn from_decimal_str(s: &str) -> Result<Fix32, Fix32Error> {
        let b = s.as_bytes();
        let (neg, rest) = match b.first() {
            Some(b'-') => (true, &b[1..]),
            Some(b'+') => (false, &b[1..]),
            _ => (false, b),
        };
        let (int_part, frac_part) = match rest.iter().position(|&c| c == b'.') {
            Some(p) => (&rest[..p], &rest[p + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        if int_part.is_empty() && frac_part.is_empty() {
            return Err(Fix32Error::Syntax);
        }
        if !int_part.iter().chain(frac_part).all(u8::is_ascii_digit) {
            return Err(Fix32Error::Syntax);
        }
        if frac_part.len() > 4 {
            return Err(Fix32Error::TooManyDecimals);
        }
        // Accumulate the magnitude in i64 with checks: leading zeros may be
        // arbitrarily many, anything past 2^31 * 10^4 is out of range anyway.
        let mut mag: i64 = 0;
        for &c in int_part {
            mag = mag
                .checked_mul(10)
                .and_then(|m| m.checked_add(i64::from(c - b'0')))
                .filter(|&m| m <= 1 << 32)
                .ok_or(Fix32Error::OutOfRange)?;
        }
        mag = mag
            .checked_mul(i64::from(Self::SCALE))
            .ok_or(Fix32Error::OutOfRange)?;
        let mut frac: i64 = 0;
        for i in 0..4 {
            let d = frac_part.get(i).map_or(0, |&c| i64::from(c - b'0'));
            frac = frac * 10 + d;
        }
        let mag = mag + frac;
        let raw = if neg { -mag } else { mag };
        i32::try_from(raw)
            .map(Fix32)
            .map_err(|_| Fix32Error::OutOfRange)
    }

    /// The exact decimal text, trailing zeros dropped: raw 500000 -> `50`,
    /// 123456 -> `12.3456`, -5 -> `-0.0005`. Same as `Display`.
    pub fn to_decimal_string(self) -> String {
        self.to_string()
    }
}

impl fmt::Display for Fix32 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let raw = i64::from(self.0);
        let mag = raw.unsigned_abs();
        let int = mag / 10_000;
        let mut frac = mag % 10_000;
        let sign = if raw < 0 { "-" } else { "" };
        if frac == 0 {
            return write!(f, "{sign}{int}");
        }
        let mut width = 4;
        while frac % 10 == 0 {
            frac /= 10;
            width -= 1;
        }
        write!(f, "{sign}{int}.{frac:0width$}")
    }
}

impl FromStr for Fix32 {
    type Err = Fix32Error;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Fix32::from_decimal_str(s)
    }
}

/// A Lenze parameter value as it travels in the 4 data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LenzeValue {
    /// Value x 10000, signed.
    Fix32(Fix32),
    /// Bit field without factor (C0135, C0150).
    BitCoded(u32),
}

impl LenzeValue {
    /// The four data bytes, little-endian (bytes 5-8 of the SDO frame).
    pub const fn to_le_bytes(self) -> [u8; 4] {
        match self {
            LenzeValue::Fix32(v) => v.to_le_bytes(),
            LenzeValue::BitCoded(v) => v.to_le_bytes(),
        }
    }

    /// Interprets four data bytes in the given format.
    pub const fn from_le_bytes(format: ValueFormat, b: [u8; 4]) -> LenzeValue {
        match format {
            ValueFormat::Fix32 => LenzeValue::Fix32(Fix32::from_le_bytes(b)),
            ValueFormat::BitCoded => LenzeValue::BitCoded(u32::from_le_bytes(b)),
        }
    }

    /// The format of this value.
    pub const fn format(self) -> ValueFormat {
        match self {
            LenzeValue::Fix32(_) => ValueFormat::Fix32,
            LenzeValue::BitCoded(_) => ValueFormat::BitCoded,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_formula_page_454() {
        assert_eq!(CodeNumber::new(11).unwrap().index(), Index(24564));
        assert_eq!(CodeNumber::new(11).unwrap().index(), Index(0x5FF4));
        assert_eq!(CodeNumber::new(0).unwrap().index(), Index(0x5FFF));
        assert_eq!(CodeNumber::new(24575).unwrap().index(), Index(0x0000));
        assert_eq!(
            CodeNumber::new(24576),
            Err(MappingError::CodeOutOfRange(24576))
        );
        assert_eq!(
            CodeNumber::new(u32::MAX),
            Err(MappingError::CodeOutOfRange(u32::MAX))
        );
        assert_eq!(CodeNumber::from_index(Index(0x5FF4)).unwrap().get(), 11);
        assert_eq!(CodeNumber::from_index(Index(0)).unwrap().get(), 24575);
        assert_eq!(
            CodeNumber::from_index(Index(0x6000)),
            Err(MappingError::IndexNotACode(0x6000))
        );
        assert_eq!(
            CodeNumber::from_index(Index(0xFFFF)),
            Err(MappingError::IndexNotACode(0xFFFF))
        );
        assert_eq!(CodeNumber::new(11).unwrap().to_string(), "C0011");
        assert_eq!(CodeNumber::new(24575).unwrap().to_string(), "C24575");
    }

    #[test]
    fn value_format_of_bit_coded_codes() {
        assert_eq!(
            CodeNumber::new(135).unwrap().value_format(),
            ValueFormat::BitCoded
        );
        assert_eq!(
            CodeNumber::new(150).unwrap().value_format(),
            ValueFormat::BitCoded
        );
        assert_eq!(
            CodeNumber::new(11).unwrap().value_format(),
            ValueFormat::Fix32
        );
    }

    #[test]
    fn fix32_parse_exact() {
        let p = |s| Fix32::from_decimal_str(s);
        assert_eq!(p("50.0"), Ok(Fix32(500_000)));
        assert_eq!(p("50"), Ok(Fix32(500_000)));
        assert_eq!(p("50."), Ok(Fix32(500_000)));
        assert_eq!(p(".5"), Ok(Fix32(5_000)));
        assert_eq!(p("-0.0001"), Ok(Fix32(-1)));
        assert_eq!(p("+12.3456"), Ok(Fix32(123_456)));
        assert_eq!(p("0"), Ok(Fix32(0)));
        assert_eq!(p("-0"), Ok(Fix32(0)));
        assert_eq!(p("0000000000000000000001.5"), Ok(Fix32(15_000)));
        assert_eq!(p("214748.3647"), Ok(Fix32(i32::MAX)));
        assert_eq!(p("-214748.3648"), Ok(Fix32(i32::MIN)));
        assert_eq!(p("214748.3648"), Err(Fix32Error::OutOfRange));
        assert_eq!(p("-214748.3649"), Err(Fix32Error::OutOfRange));
        assert_eq!(p("99999999999999999999999"), Err(Fix32Error::OutOfRange));
        assert_eq!(p("1.23456"), Err(Fix32Error::TooManyDecimals));
        assert_eq!(p("1.00000"), Err(Fix32Error::TooManyDecimals));
        for bad in [
            "", "-", "+", ".", "-.", "1.2.3", "1e3", " 1", "1 ", "--1", "0x10", "１",
        ] {
            assert_eq!(p(bad), Err(Fix32Error::Syntax), "{bad:?}");
        }
    }

    #[test]
    fn fix32_display_exact() {
        assert_eq!(Fix32(500_000).to_string(), "50");
        assert_eq!(Fix32(505_000).to_string(), "50.5");
        assert_eq!(Fix32(123_456).to_string(), "12.3456");
        assert_eq!(Fix32(-5).to_string(), "-0.0005");
        assert_eq!(Fix32(-10_000).to_string(), "-1");
        assert_eq!(Fix32(0).to_string(), "0");
        assert_eq!(Fix32(i32::MAX).to_string(), "214748.3647");
        assert_eq!(Fix32(i32::MIN).to_string(), "-214748.3648");
        assert_eq!(Fix32::from_integer(50), Some(Fix32(500_000)));
        assert_eq!(Fix32::from_integer(214_749), None);
    }

    #[test]
    fn fix32_bytes_little_endian() {
        assert_eq!(Fix32(500_000).to_le_bytes(), [0x20, 0xA1, 0x07, 0x00]);
        assert_eq!(Fix32(-1).to_le_bytes(), [0xFF; 4]);
        assert_eq!(
            Fix32::from_le_bytes([0x20, 0xA1, 0x07, 0x00]),
            Fix32(500_000)
        );
        assert_eq!(
            LenzeValue::BitCoded(0x8000_0001).to_le_bytes(),
            [0x01, 0x00, 0x00, 0x80]
        );
        assert_eq!(
            LenzeValue::from_le_bytes(ValueFormat::BitCoded, [0x01, 0, 0, 0x80]),
            LenzeValue::BitCoded(0x8000_0001)
        );
    }
}
