//! Parameter value formats V1..Vn (section 8.E): ASCII decimal (VD), ASCII
//! hexadecimal (VH), string (VS) and octet string (VO). Owns [`Value`],
//! [`Decimal`], [`Hex`], [`VisibleString`] and [`OctetString`]. Values live
//! inline (no heap); encoding appends to a caller's buffer.

use core::fmt;

use super::code::{hex_digit, hex_value};
use super::error::ValueError;

/// A parameter value in one of the four formats of section 8.E. The format
/// is chosen by the first character: '-' or a digit VD, 'H' VH, 'S' VS,
/// 'O' VO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Value {
    /// VD, ASCII decimal.
    Decimal(Decimal),
    /// VH, 'H' + 2 / 4 / 8 hex characters.
    Hex(Hex),
    /// VS, 'S' + visible ASCII.
    String(VisibleString),
    /// VO, 'O' + hex nibbles of a data block.
    Octets(OctetString),
}

impl Value {
    /// Longest value field on the wire: 'O' + 240 nibbles.
    pub const MAX_WIRE_LEN: usize = 1 + OctetString::MAX_NIBBLES;

    /// Appends V1..Vn to `out`.
    pub fn write(&self, out: &mut Vec<u8>) {
        match self {
            Self::Decimal(d) => d.write(out),
            Self::Hex(h) => h.write(out),
            Self::String(s) => s.write(out),
            Self::Octets(o) => o.write(out),
        }
    }

    /// Parses V1..Vn (parity-masked), dispatching on the first character.
    ///
    /// # Errors
    /// [`ValueError`] naming the offending byte and its offset in `field`.
    pub fn parse(field: &[u8]) -> Result<Self, ValueError> {
        match field.first() {
            None => Err(ValueError::Empty),
            Some(b'-' | b'0'..=b'9') => Decimal::parse(field).map(Self::Decimal),
            Some(b'H') => Hex::parse(field).map(Self::Hex),
            Some(b'S') => VisibleString::parse(field).map(Self::String),
            Some(b'O') => OctetString::parse(field).map(Self::Octets),
            Some(&byte) => Err(ValueError::UnknownFormat { byte }),
        }
    }
}

impl From<Decimal> for Value {
    fn from(d: Decimal) -> Self {
        Self::Decimal(d)
    }
}

impl From<Hex> for Value {
    fn from(h: Hex) -> Self {
        Self::Hex(h)
    }
}

impl From<VisibleString> for Value {
    fn from(s: VisibleString) -> Self {
        Self::String(s)
    }
}

impl From<OctetString> for Value {
    fn from(o: OctetString) -> Self {
        Self::Octets(o)
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Decimal(d) => d.fmt(f),
            Self::Hex(h) => h.fmt(f),
            Self::String(s) => s.fmt(f),
            Self::Octets(o) => o.fmt(f),
        }
    }
}

/// A VD value (section 8.E) as an exact fixed-point number: `raw` is the
/// value times 10000, so 35.4 is 354000. Range -214748.3648..=214748.3647,
/// i.e. exactly the `i32` range of raw values.
///
/// Encoding is canonical: the shortest form, i.e. trailing zeros of the
/// fraction are dropped and there is no decimal point when the fraction is
/// zero (8.E tip: "the decimal point must not be transmitted if the value
/// does not have digits after the decimal point"), so 354000 -> "35.4" and
/// 950000 -> "95", never "35.4000" or "95.". Decoding accepts any form the
/// section allows (1..=6 integer digits, leading zeros, 1..=4 decimals,
/// "-0"), so "35.4", "35.40" and "035.4000" all give 354000. The number of
/// decimals a drive sent is not kept: it is not part of the value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Decimal(i64);

impl Decimal {
    /// Raw units per 1.
    pub const SCALE: i64 = 10_000;
    /// -214748.3648.
    pub const MIN_RAW: i64 = i32::MIN as i64;
    /// 214748.3647.
    pub const MAX_RAW: i64 = i32::MAX as i64;

    /// The value `raw / 10000`.
    ///
    /// # Errors
    /// [`ValueError::DecimalOutOfRange`] outside the VD range.
    pub const fn from_raw(raw: i64) -> Result<Self, ValueError> {
        if raw >= Self::MIN_RAW && raw <= Self::MAX_RAW {
            Ok(Self(raw))
        } else {
            Err(ValueError::DecimalOutOfRange { raw })
        }
    }

    /// The integer `n` (no fraction).
    ///
    /// # Errors
    /// [`ValueError::DecimalOutOfRange`] outside -214748..=214748.
    pub const fn from_int(n: i64) -> Result<Self, ValueError> {
        match n.checked_mul(Self::SCALE) {
            Some(raw) => Self::from_raw(raw),
            None => Err(ValueError::DecimalOutOfRange { raw: i64::MAX }),
        }
    }

    /// The value times 10000.
    pub const fn raw(self) -> i64 {
        self.0
    }

    /// The integer value, if the fraction is zero.
    pub const fn as_integer(self) -> Option<i64> {
        if self.0 % Self::SCALE == 0 {
            Some(self.0 / Self::SCALE)
        } else {
            None
        }
    }

    /// Appends the canonical VD form to `out`.
    pub fn write(self, out: &mut Vec<u8>) {
        let mut buf = [0u8; 12];
        let n = self.format(&mut buf);
        out.extend_from_slice(&buf[..n]);
    }

    /// Writes the canonical form into `buf` and returns its length (at most
    /// 12: "-214748.3648").
    fn format(self, buf: &mut [u8; 12]) -> usize {
        let mut n = 0;
        if self.0 < 0 {
            buf[n] = b'-';
            n += 1;
        }
        let abs = self.0.unsigned_abs();
        let int = abs / Self::SCALE as u64;
        let mut frac = abs % Self::SCALE as u64;
        let mut digits = [0u8; 6];
        let mut len = 0;
        let mut v = int;
        loop {
            digits[len] = b'0' + (v % 10) as u8;
            len += 1;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        for i in (0..len).rev() {
            buf[n] = digits[i];
            n += 1;
        }
        if frac != 0 {
            buf[n] = b'.';
            n += 1;
            let mut places = 4;
            while frac.is_multiple_of(10) {
                frac /= 10;
                places -= 1;
            }
            let mut div = 10u64.pow(places - 1);
            for _ in 0..places {
                buf[n] = b'0' + (frac / div % 10) as u8;
                n += 1;
                div /= 10;
            }
        }
        n
    }

    /// Parses a VD field (parity-masked).
    ///
    /// # Errors
    /// [`ValueError`] for a syntax error (with its offset), too many digits
    /// or a value outside the range.
    pub fn parse(field: &[u8]) -> Result<Self, ValueError> {
        if field.is_empty() {
            return Err(ValueError::Empty);
        }
        let (negative, body, base) = match field {
            [b'-', rest @ ..] => (true, rest, 1),
            _ => (false, field, 0),
        };
        let mut int_digits = 0usize;
        let mut frac_digits: Option<usize> = None;
        let mut magnitude: i64 = 0;
        for (i, &b) in body.iter().enumerate() {
            match (b, frac_digits) {
                (b'0'..=b'9', None) => {
                    int_digits += 1;
                    if int_digits > 6 {
                        return Err(ValueError::DecimalTooManyIntegerDigits {
                            count: body.iter().take_while(|c| c.is_ascii_digit()).count(),
                        });
                    }
                    magnitude = magnitude * 10 + i64::from(b - b'0');
                }
                (b'0'..=b'9', Some(k)) => {
                    if k == 4 {
                        return Err(ValueError::DecimalFractionDigits {
                            count: body[i - 4..]
                                .iter()
                                .take_while(|c| c.is_ascii_digit())
                                .count(),
                        });
                    }
                    magnitude = magnitude * 10 + i64::from(b - b'0');
                    frac_digits = Some(k + 1);
                }
                (b'.', None) => {
                    if int_digits == 0 {
                        return Err(ValueError::DecimalNoIntegerDigits);
                    }
                    frac_digits = Some(0);
                }
                _ => {
                    return Err(ValueError::DecimalSyntax {
                        at: base + i,
                        byte: b,
                    });
                }
            }
        }
        if int_digits == 0 {
            return Err(ValueError::DecimalNoIntegerDigits);
        }
        let frac = match frac_digits {
            None => 0,
            Some(0) => return Err(ValueError::DecimalFractionDigits { count: 0 }),
            Some(k) => k,
        };
        let raw = magnitude * 10i64.pow(4 - frac as u32);
        Self::from_raw(if negative { -raw } else { raw })
    }
}

impl fmt::Display for Decimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut buf = [0u8; 12];
        let n = self.format(&mut buf);
        // Only ASCII digits, '-' and '.'.
        f.write_str(core::str::from_utf8(&buf[..n]).unwrap_or("?"))
    }
}

/// A VH value (section 8.E): 'H' and 2, 4 or 8 uppercase hex characters,
/// most significant first. The width is part of the value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Hex {
    /// 2 characters.
    Byte(u8),
    /// 4 characters.
    Word(u16),
    /// 8 characters.
    Dword(u32),
}

impl Hex {
    /// The value, zero-extended.
    pub const fn get(self) -> u32 {
        match self {
            Self::Byte(v) => v as u32,
            Self::Word(v) => v as u32,
            Self::Dword(v) => v,
        }
    }

    /// Number of hex characters: 2, 4 or 8.
    pub const fn digits(self) -> usize {
        match self {
            Self::Byte(_) => 2,
            Self::Word(_) => 4,
            Self::Dword(_) => 8,
        }
    }

    /// Appends 'H' and the hex characters to `out`.
    pub fn write(self, out: &mut Vec<u8>) {
        out.push(b'H');
        let v = self.get();
        for i in (0..self.digits()).rev() {
            out.push(hex_digit((v >> (4 * i)) as u16));
        }
    }

    /// Parses 'H' + 2 / 4 / 8 uppercase hex characters.
    ///
    /// # Errors
    /// [`ValueError::HexLength`], [`ValueError::HexDigit`].
    pub fn parse(field: &[u8]) -> Result<Self, ValueError> {
        let Some((&b'H', digits)) = field.split_first() else {
            return Err(field.first().map_or(ValueError::Empty, |&byte| {
                ValueError::UnknownFormat { byte }
            }));
        };
        if !matches!(digits.len(), 2 | 4 | 8) {
            return Err(ValueError::HexLength { len: digits.len() });
        }
        let mut v: u32 = 0;
        for (i, &b) in digits.iter().enumerate() {
            let d = hex_value(b).ok_or(ValueError::HexDigit {
                format: "VH",
                at: i + 1,
                byte: b,
            })?;
            v = (v << 4) | u32::from(d);
        }
        Ok(match digits.len() {
            2 => Self::Byte(v as u8),
            4 => Self::Word(v as u16),
            _ => Self::Dword(v),
        })
    }
}

impl fmt::Display for Hex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "H{:0width$X}", self.get(), width = self.digits())
    }
}

/// A VS value (section 8.E): 'S' and at most 20 visible ASCII characters
/// (0x20..=0x7E, no control characters). The section's other lengths
/// ("VS1..VS240", "1 to 12 ... characters") contradict the "max. 20" of the
/// VS paragraph; see docs/errata/lecom.md. An empty string is accepted.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct VisibleString {
    len: u8,
    bytes: [u8; Self::MAX_LEN],
}

impl VisibleString {
    /// "strings with max. 20 characters" (8.E).
    pub const MAX_LEN: usize = 20;

    /// # Errors
    /// [`ValueError::StringTooLong`], [`ValueError::StringChar`] (offset in
    /// `s`).
    pub fn new(s: &[u8]) -> Result<Self, ValueError> {
        if s.len() > Self::MAX_LEN {
            return Err(ValueError::StringTooLong { len: s.len() });
        }
        if let Some(at) = s.iter().position(|b| !(0x20..=0x7E).contains(b)) {
            return Err(ValueError::StringChar { at, byte: s[at] });
        }
        let mut bytes = [0u8; Self::MAX_LEN];
        bytes[..s.len()].copy_from_slice(s);
        Ok(Self {
            len: s.len() as u8,
            bytes,
        })
    }

    /// The characters.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// The characters as text (always ASCII).
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.as_bytes()).unwrap_or_default()
    }

    /// Appends 'S' and the characters.
    pub fn write(&self, out: &mut Vec<u8>) {
        out.push(b'S');
        out.extend_from_slice(self.as_bytes());
    }

    /// Parses 'S' + characters.
    ///
    /// # Errors
    /// As [`new`](Self::new), offsets counted in the field (the 'S' is 0).
    pub fn parse(field: &[u8]) -> Result<Self, ValueError> {
        let Some((&b'S', s)) = field.split_first() else {
            return Err(field.first().map_or(ValueError::Empty, |&byte| {
                ValueError::UnknownFormat { byte }
            }));
        };
        Self::new(s).map_err(|e| match e {
            ValueError::StringChar { at, byte } => ValueError::StringChar { at: at + 1, byte },
            e => e,
        })
    }
}

impl fmt::Debug for VisibleString {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("VisibleString")
            .field(&self.as_str())
            .finish()
    }
}

impl fmt::Display for VisibleString {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "S{}", self.as_str())
    }
}

/// A VO value (section 8.E): 'O' and the data block as hex nibbles, the
/// byte at the lowest address first, high nibble before low nibble. At most
/// 240 characters (the manual's "VO1 to VO240"), i.e. 120 bytes; an odd
/// number of characters is rejected since every byte is two nibbles.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct OctetString {
    len: u8,
    bytes: [u8; Self::MAX_LEN],
}

impl OctetString {
    /// 240 nibbles.
    pub const MAX_NIBBLES: usize = 240;
    /// 120 bytes.
    pub const MAX_LEN: usize = Self::MAX_NIBBLES / 2;

    /// # Errors
    /// [`ValueError::OctetsTooLong`] above 120 bytes.
    pub fn new(data: &[u8]) -> Result<Self, ValueError> {
        if data.len() > Self::MAX_LEN {
            return Err(ValueError::OctetsTooLong {
                nibbles: data.len() * 2,
            });
        }
        let mut bytes = [0u8; Self::MAX_LEN];
        bytes[..data.len()].copy_from_slice(data);
        Ok(Self {
            len: data.len() as u8,
            bytes,
        })
    }

    /// The data block.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// Appends 'O' and two uppercase hex characters per byte.
    pub fn write(&self, out: &mut Vec<u8>) {
        out.push(b'O');
        for &b in self.as_bytes() {
            out.push(hex_digit(u16::from(b) >> 4));
            out.push(hex_digit(u16::from(b)));
        }
    }

    /// Parses 'O' + nibbles.
    ///
    /// # Errors
    /// [`ValueError::OctetsTooLong`], [`ValueError::OctetsOddLength`],
    /// [`ValueError::HexDigit`].
    pub fn parse(field: &[u8]) -> Result<Self, ValueError> {
        let Some((&b'O', nibbles)) = field.split_first() else {
            return Err(field.first().map_or(ValueError::Empty, |&byte| {
                ValueError::UnknownFormat { byte }
            }));
        };
        if nibbles.len() > Self::MAX_NIBBLES {
            return Err(ValueError::OctetsTooLong {
                nibbles: nibbles.len(),
            });
        }
        if nibbles.len() % 2 != 0 {
            return Err(ValueError::OctetsOddLength {
                nibbles: nibbles.len(),
            });
        }
        let mut bytes = [0u8; Self::MAX_LEN];
        for (i, pair) in nibbles.chunks_exact(2).enumerate() {
            let digit = |k: usize| {
                hex_value(pair[k]).ok_or(ValueError::HexDigit {
                    format: "VO",
                    at: 1 + 2 * i + k,
                    byte: pair[k],
                })
            };
            bytes[i] = (digit(0)? << 4) | digit(1)?;
        }
        Ok(Self {
            len: (nibbles.len() / 2) as u8,
            bytes,
        })
    }
}

impl fmt::Debug for OctetString {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("OctetString")
            .field(&self.as_bytes())
            .finish()
    }
}

impl fmt::Display for OctetString {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("O")?;
        self.as_bytes()
            .iter()
            .try_for_each(|b| write!(f, "{b:02X}"))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    fn enc(v: impl Into<Value>) -> Vec<u8> {
        let mut out = Vec::new();
        v.into().write(&mut out);
        out
    }

    #[test]
    fn decimal_examples_from_section_8() {
        assert_eq!(Decimal::parse(b"35.4").unwrap().raw(), 354_000);
        assert_eq!(Decimal::parse(b"95.2").unwrap().raw(), 952_000);
        assert_eq!(Decimal::parse(b"0").unwrap().raw(), 0);
        assert_eq!(enc(Decimal::from_raw(354_000).unwrap()), b"35.4");
        assert_eq!(enc(Decimal::from_raw(952_000).unwrap()), b"95.2");
        assert_eq!(enc(Decimal::from_raw(0).unwrap()), b"0");
    }

    #[test]
    fn decimal_canonical_encoding() {
        for (raw, text) in [
            (950_000, &b"95"[..]),
            (1, b"0.0001"),
            (-1, b"-0.0001"),
            (12_340, b"1.234"),
            (-5000, b"-0.5"),
            (Decimal::MAX_RAW, b"214748.3647"),
            (Decimal::MIN_RAW, b"-214748.3648"),
        ] {
            assert_eq!(enc(Decimal::from_raw(raw).unwrap()), text, "raw {raw}");
            assert_eq!(Decimal::parse(text).unwrap().raw(), raw);
        }
        assert_eq!(Decimal::from_raw(-354_000).unwrap().to_string(), "-35.4");
    }

    #[test]
    fn decimal_accepts_every_allowed_form() {
        for text in [&b"35.4"[..], b"35.40", b"35.4000", b"035.4", b"000035.4"] {
            assert_eq!(Decimal::parse(text).unwrap().raw(), 354_000);
        }
        assert_eq!(Decimal::parse(b"-0").unwrap().raw(), 0);
    }

    #[test]
    fn decimal_rejects() {
        assert_eq!(Decimal::parse(b""), Err(ValueError::Empty));
        assert_eq!(
            Decimal::parse(b"-"),
            Err(ValueError::DecimalNoIntegerDigits)
        );
        assert_eq!(
            Decimal::parse(b".5"),
            Err(ValueError::DecimalNoIntegerDigits)
        );
        assert_eq!(
            Decimal::parse(b"5."),
            Err(ValueError::DecimalFractionDigits { count: 0 })
        );
        assert_eq!(
            Decimal::parse(b"1.23456"),
            Err(ValueError::DecimalFractionDigits { count: 5 })
        );
        assert_eq!(
            Decimal::parse(b"1234567"),
            Err(ValueError::DecimalTooManyIntegerDigits { count: 7 })
        );
        assert_eq!(
            Decimal::parse(b"214748.3648"),
            Err(ValueError::DecimalOutOfRange { raw: 2_147_483_648 })
        );
        assert_eq!(
            Decimal::parse(b"-999999"),
            Err(ValueError::DecimalOutOfRange {
                raw: -9_999_990_000
            })
        );
        assert_eq!(
            Decimal::parse(b"+1"),
            Err(ValueError::DecimalSyntax { at: 0, byte: b'+' })
        );
        assert_eq!(
            Decimal::parse(b"1.2.3"),
            Err(ValueError::DecimalSyntax { at: 3, byte: b'.' })
        );
        assert_eq!(
            Decimal::parse(b"--1"),
            Err(ValueError::DecimalSyntax { at: 1, byte: b'-' })
        );
        assert_eq!(
            Decimal::parse(b"1 "),
            Err(ValueError::DecimalSyntax { at: 1, byte: b' ' })
        );
        assert_eq!(
            Decimal::from_raw(Decimal::MAX_RAW + 1),
            Err(ValueError::DecimalOutOfRange { raw: 2_147_483_648 })
        );
        assert_eq!(Decimal::from_int(214_748).unwrap().raw(), 2_147_480_000);
        assert!(Decimal::from_int(214_749).is_err());
        assert!(Decimal::from_int(i64::MAX).is_err());
    }

    #[test]
    fn hex_widths() {
        assert_eq!(enc(Hex::Byte(0x0A)), b"H0A");
        assert_eq!(enc(Hex::Word(0x0900)), b"H0900");
        assert_eq!(enc(Hex::Dword(0xDEAD_BEEF)), b"HDEADBEEF");
        assert_eq!(Hex::parse(b"H0900").unwrap(), Hex::Word(0x0900));
        assert_eq!(Hex::parse(b"HFF").unwrap(), Hex::Byte(0xFF));
        assert_eq!(Hex::parse(b"H0000FFFF").unwrap(), Hex::Dword(0xFFFF));
        assert_eq!(Hex::parse(b"H123"), Err(ValueError::HexLength { len: 3 }));
        assert_eq!(Hex::parse(b"H"), Err(ValueError::HexLength { len: 0 }));
        assert_eq!(
            Hex::parse(b"H09a0"),
            Err(ValueError::HexDigit {
                format: "VH",
                at: 3,
                byte: b'a'
            })
        );
        assert_eq!(Hex::Word(0x0900).to_string(), "H0900");
    }

    #[test]
    fn visible_strings() {
        let s = VisibleString::new(b"S33SLECOMM_10000").unwrap();
        assert_eq!(enc(s), b"SS33SLECOMM_10000");
        assert_eq!(
            Value::parse(b"S2005-01-15").unwrap(),
            Value::String(VisibleString::new(b"2005-01-15").unwrap())
        );
        assert_eq!(VisibleString::parse(b"S").unwrap().as_bytes(), b"");
        assert!(VisibleString::new(&[b'x'; 20]).is_ok());
        assert_eq!(
            VisibleString::new(&[b'x'; 21]),
            Err(ValueError::StringTooLong { len: 21 })
        );
        assert_eq!(
            VisibleString::parse(b"Sa\x7Fb"),
            Err(ValueError::StringChar { at: 2, byte: 0x7F })
        );
        assert_eq!(
            VisibleString::parse(b"Sa\x03"),
            Err(ValueError::StringChar { at: 2, byte: 0x03 })
        );
    }

    #[test]
    fn octet_strings() {
        let o = OctetString::new(&[0x12, 0xAB, 0x00]).unwrap();
        assert_eq!(enc(o), b"O12AB00");
        assert_eq!(OctetString::parse(b"O12AB00").unwrap(), o);
        assert_eq!(OctetString::parse(b"O").unwrap().as_bytes(), b"");
        assert_eq!(
            OctetString::parse(b"O123"),
            Err(ValueError::OctetsOddLength { nibbles: 3 })
        );
        assert_eq!(
            OctetString::parse(b"O12G4"),
            Err(ValueError::HexDigit {
                format: "VO",
                at: 3,
                byte: b'G'
            })
        );
        let mut long = vec![b'O'];
        long.extend_from_slice(&[b'0'; 242]);
        assert_eq!(
            OctetString::parse(&long),
            Err(ValueError::OctetsTooLong { nibbles: 242 })
        );
        assert!(OctetString::new(&[0; 120]).is_ok());
        assert_eq!(
            OctetString::new(&[0; 121]),
            Err(ValueError::OctetsTooLong { nibbles: 242 })
        );
    }

    #[test]
    fn format_dispatch() {
        assert_eq!(Value::parse(b""), Err(ValueError::Empty));
        assert_eq!(
            Value::parse(b"X1"),
            Err(ValueError::UnknownFormat { byte: b'X' })
        );
        assert_eq!(
            Value::parse(b"?"),
            Err(ValueError::UnknownFormat { byte: b'?' })
        );
        assert!(matches!(Value::parse(b"-1").unwrap(), Value::Decimal(_)));
    }

    pub(crate) fn any_value() -> impl Strategy<Value = Value> {
        prop_oneof![
            (Decimal::MIN_RAW..=Decimal::MAX_RAW)
                .prop_map(|r| Value::Decimal(Decimal::from_raw(r).unwrap())),
            any::<u8>().prop_map(|v| Value::Hex(Hex::Byte(v))),
            any::<u16>().prop_map(|v| Value::Hex(Hex::Word(v))),
            any::<u32>().prop_map(|v| Value::Hex(Hex::Dword(v))),
            proptest::collection::vec(0x20u8..=0x7E, 0..=20)
                .prop_map(|s| Value::String(VisibleString::new(&s).unwrap())),
            proptest::collection::vec(any::<u8>(), 0..=120)
                .prop_map(|d| Value::Octets(OctetString::new(&d).unwrap())),
        ]
    }

    proptest! {
        #[test]
        fn every_value_round_trips(v in any_value()) {
            let bytes = enc(v);
            prop_assert!(bytes.len() <= Value::MAX_WIRE_LEN);
            prop_assert_eq!(Value::parse(&bytes).unwrap(), v);
        }

        #[test]
        fn decimal_round_trips_and_is_canonical(raw in Decimal::MIN_RAW..=Decimal::MAX_RAW) {
            let d = Decimal::from_raw(raw).unwrap();
            let bytes = enc(d);
            prop_assert_eq!(Decimal::parse(&bytes).unwrap(), d);
            prop_assert!(!bytes.ends_with(b"0") || !bytes.contains(&b'.'));
            prop_assert!(!bytes.ends_with(b"."));
        }

        #[test]
        fn value_parse_never_panics(field in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = Value::parse(&field);
        }
    }
}
