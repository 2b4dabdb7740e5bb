//! LUSTBUS parameter values: the PT_* data types of both device families and
//! their VALUE strings (section 2.3).
//!
//! - VF1000 (2.3.1): VALUE is always exactly four uppercase hex digits,
//!   leading zeros transmitted (`sprintf("%04X")`).
//! - MC6000/7000 (2.3.2): VALUE is 1..8 uppercase hex digits, leading zeros
//!   optional (`sprintf("%X")`); [`ParameterValue::encode`] writes none,
//!   [`ParameterValue::decode`] accepts any length 1..=8 (the spec's own
//!   example "04FA4000" has one).
//!
//! Scaled types keep the raw integer the wire carries ([`Fixpoint16`] x0.05,
//! [`Int32Q16`] x1/65536, [`FloatIeee`] bit pattern); exact decimal display
//! and parsing helpers convert without floating point.

use core::fmt;

use thiserror::Error;

use super::frame::ValueText;

/// The LUSTBUS dialect of a device family: VALUE syntax, CODE form and
/// description layout differ between the two (sections 2.3, 2.4, 11.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// SMARTDRIVE VF1000 inverter: 4 hex digits, always.
    Vf1000,
    /// MASTERCONTROL MC6000/7000 servocontroller: 1..8 hex digits.
    Mc,
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Dialect::Vf1000 => "VF1000",
            Dialect::Mc => "MC6000/7000",
        })
    }
}

/// A LUSTBUS parameter data type (tables of 2.3.1 and 2.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParameterType {
    /// PT_BINARY8 (VF1000 only): 0..255, a bit field shown in hex.
    Binary8,
    /// PT_FIXPOINT16: unsigned 16-bit, scale 0.05.
    Fixpoint16,
    /// PT_USIGN16: 0..65535.
    Usign16,
    /// PT_USIGN8: 0..255.
    Usign8,
    /// PT_VF_ERROR (VF1000 only): error number (high byte) and time (low byte).
    VfError,
    /// PT_PASSWORD: unsigned 16-bit.
    Password,
    /// PT_INTEGER16 (MC only): 16-bit two's complement.
    Integer16,
    /// PT_INT32Q16 (MC only): 32-bit two's complement, scale 1/65536.
    Int32Q16,
    /// PT_FLOAT_IEEE (MC only): IEEE 754 single, bit pattern in hex.
    FloatIeee,
    /// PT_MC_ERROR (MC only): error number, location and 16-bit time.
    McError,
}

impl ParameterType {
    /// Every type, in the order of this enum.
    pub const ALL: [ParameterType; 10] = [
        Self::Binary8,
        Self::Fixpoint16,
        Self::Usign16,
        Self::Usign8,
        Self::VfError,
        Self::Password,
        Self::Integer16,
        Self::Int32Q16,
        Self::FloatIeee,
        Self::McError,
    ];

    /// The spec's name, e.g. `"PT_FIXPOINT16"`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Binary8 => "PT_BINARY8",
            Self::Fixpoint16 => "PT_FIXPOINT16",
            Self::Usign16 => "PT_USIGN16",
            Self::Usign8 => "PT_USIGN8",
            Self::VfError => "PT_VF_ERROR",
            Self::Password => "PT_PASSWORD",
            Self::Integer16 => "PT_INTEGER16",
            Self::Int32Q16 => "PT_INT32Q16",
            Self::FloatIeee => "PT_FLOAT_IEEE",
            Self::McError => "PT_MC_ERROR",
        }
    }

    /// The type a spec name (`"PT_FIXPOINT16"`, as a schema's `type =`
    /// writes it) names: the inverse of [`ParameterType::name`] and the one
    /// table from a schema's LUSTBUS types to the codec's.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The type driveset reads an untyped value of `width` bytes as (a
    /// driveset choice, the spec types nothing by width): 1 PT_USIGN8, 2
    /// PT_USIGN16, 4 PT_INT32Q16; `None` for other widths.
    pub const fn of_width(width: u8) -> Option<Self> {
        match width {
            1 => Some(Self::Usign8),
            2 => Some(Self::Usign16),
            4 => Some(Self::Int32Q16),
            _ => None,
        }
    }

    /// The type a schema's code travels as, from the schema's `type =`
    /// name and `width`: a PT_* name its type ([`ParameterType::from_name`];
    /// a name of another protocol's type: `None`), a code without a type
    /// name by its width ([`ParameterType::of_width`]). The one table from
    /// a schema code to the codec's type, for the client and the simulator.
    pub fn of_code(type_name: Option<&str>, width: Option<u8>) -> Option<Self> {
        match type_name {
            Some(name) => Self::from_name(name),
            None => Self::of_width(width?),
        }
    }

    /// Whether `family` has this type (2.3.1 for VF1000, 2.3.2 for MC).
    pub const fn in_family(self, family: Dialect) -> bool {
        match family {
            Dialect::Vf1000 => matches!(
                self,
                Self::Binary8
                    | Self::Fixpoint16
                    | Self::Usign16
                    | Self::Usign8
                    | Self::VfError
                    | Self::Password
            ),
            Dialect::Mc => !matches!(self, Self::Binary8 | Self::VfError),
        }
    }

    /// The type character of a parameter description.
    ///
    /// `'1'..='6'` are the VF1000 codes of section 11.1. Section 11.2 gives
    /// no table for MC6000/7000; driveset extends the VF1000 numbering
    /// (the MC protocol is "downward compatible", section 1): the shared types
    /// keep their VF1000 character and the MC-only ones continue in hex,
    /// `'7'` PT_INTEGER16, `'8'` PT_INT32Q16, `'9'` PT_FLOAT_IEEE,
    /// `'A'` PT_MC_ERROR (errata: "MC type codes").
    pub const fn code(self) -> u8 {
        match self {
            Self::Binary8 => b'1',
            Self::Fixpoint16 => b'2',
            Self::Usign16 => b'3',
            Self::Usign8 => b'4',
            Self::VfError => b'5',
            Self::Password => b'6',
            Self::Integer16 => b'7',
            Self::Int32Q16 => b'8',
            Self::FloatIeee => b'9',
            Self::McError => b'A',
        }
    }

    /// The inverse of [`ParameterType::code`].
    pub const fn from_code(c: u8) -> Option<Self> {
        Some(match c {
            b'1' => Self::Binary8,
            b'2' => Self::Fixpoint16,
            b'3' => Self::Usign16,
            b'4' => Self::Usign8,
            b'5' => Self::VfError,
            b'6' => Self::Password,
            b'7' => Self::Integer16,
            b'8' => Self::Int32Q16,
            b'9' => Self::FloatIeee,
            b'A' => Self::McError,
            _ => return None,
        })
    }

    /// The largest raw value the type carries (as the unsigned wire integer).
    const fn max_raw(self) -> u32 {
        match self {
            Self::Binary8 | Self::Usign8 => 0xFF,
            Self::Fixpoint16 | Self::Usign16 | Self::VfError | Self::Password | Self::Integer16 => {
                0xFFFF
            }
            Self::Int32Q16 | Self::FloatIeee | Self::McError => u32::MAX,
        }
    }
}

impl fmt::Display for ParameterType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What is wrong with a VALUE string or a value.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum ValueError {
    /// VALUE has the wrong number of characters for the family.
    #[error("VALUE has {found} characters; {family} {ty} needs {expected}")]
    Length {
        /// Characters received.
        found: usize,
        /// What the family requires, e.g. "exactly 4" or "1 to 8".
        expected: &'static str,
        /// The family.
        family: Dialect,
        /// The type being decoded.
        ty: ParameterType,
    },
    /// A VALUE character is not an uppercase hex digit.
    #[error(
        "VALUE character {offset} is {found:#04x} ({shown}), not an uppercase hex digit 0-9/A-F{hint}",
        shown = crate::lustbus::frame::Shown(*found),
        hint = if found.is_ascii_hexdigit() { " (lowercase is not allowed, section 2.3)" } else { "" }
    )]
    NotHex {
        /// Index of the character in VALUE.
        offset: usize,
        /// The character.
        found: u8,
    },
    /// The hex number does not fit the type.
    #[error("VALUE {raw:#X} is out of range for {ty} (max {max:#X})", max = ty.max_raw())]
    OutOfRange {
        /// The decoded number.
        raw: u32,
        /// The type.
        ty: ParameterType,
    },
    /// The type does not exist on that family.
    #[error("{ty} does not exist on {family} (section 2.3)")]
    TypeNotInFamily {
        /// The type.
        ty: ParameterType,
        /// The family.
        family: Dialect,
    },
    /// A decimal string could not be parsed.
    #[error("not a decimal number: {0}")]
    Decimal(&'static str),
    /// A decimal is outside the type's range.
    #[error("decimal value out of range for {0}")]
    DecimalOutOfRange(ParameterType),
    /// A decimal is not an exact multiple of the type's scale.
    #[error("decimal value is not an exact multiple of the {0} scale; it would have to be rounded")]
    NotExact(ParameterType),
}

/// Value of an uppercase hex digit (section 2.3: "A-F valid only as capital letters").
pub(crate) const fn hex_digit(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

/// Parses 1..=8 uppercase hex digits (length already checked by the caller).
pub(crate) fn parse_hex(text: &[u8]) -> Result<u32, ValueError> {
    let mut v: u32 = 0;
    for (offset, &c) in text.iter().enumerate() {
        let d = hex_digit(c).ok_or(ValueError::NotHex { offset, found: c })?;
        v = (v << 4) | u32::from(d);
    }
    Ok(v)
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

/// Writes `v` in uppercase hex: `width` digits with leading zeros, or the
/// minimal number of digits (at least one) if `width` is `None`.
pub(crate) fn hex_into(v: u32, width: Option<usize>, out: &mut [u8; 8]) -> usize {
    let minimal = (8 - (v.leading_zeros() / 4) as usize).max(1);
    let n = width.unwrap_or(minimal).clamp(1, 8);
    for (i, slot) in out[..n].iter_mut().enumerate() {
        let shift = 4 * (n - 1 - i);
        *slot = HEX[((v >> shift) & 0xF) as usize];
    }
    n
}

pub(crate) fn hex_text(v: u32, width: Option<usize>) -> ValueText {
    let mut buf = [0u8; 8];
    let n = hex_into(v, width, &mut buf);
    ValueText::from_valid(&buf[..n])
}

/// A PT_FIXPOINT16 value: the raw unsigned 16-bit integer; the quantity is
/// `raw * 0.05` (2.3.1/2.3.2). 50.00 Hz is raw 1000 = `03E8`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Fixpoint16(pub u16);

impl Fixpoint16 {
    /// The quantity in hundredths (raw x 5): 1000 -> 5000 (= 50.00).
    pub const fn hundredths(self) -> u32 {
        self.0 as u32 * 5
    }

    /// Parses a decimal such as `"50.00"` or `"23.15"`; the value must be an
    /// exact multiple of 0.05 in 0.00..=3276.75, otherwise an error (no
    /// silent rounding).
    pub fn from_decimal(s: &str) -> Result<Self, ValueError> {
        let d = Decimal::parse(s)?;
        if d.negative && d.mantissa != 0 {
            return Err(ValueError::DecimalOutOfRange(ParameterType::Fixpoint16));
        }
        // raw = value * 20 = mantissa * 20 / 10^scale
        let num = d
            .mantissa
            .checked_mul(20)
            .ok_or(ValueError::DecimalOutOfRange(ParameterType::Fixpoint16))?;
        let den = pow10(d.scale);
        if num % den != 0 {
            return Err(ValueError::NotExact(ParameterType::Fixpoint16));
        }
        u16::try_from(num / den)
            .map(Self)
            .map_err(|_| ValueError::DecimalOutOfRange(ParameterType::Fixpoint16))
    }
}

impl fmt::Display for Fixpoint16 {
    /// Exact, two decimals: raw 463 -> `23.15`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let h = self.hundredths();
        write!(f, "{}.{:02}", h / 100, h % 100)
    }
}

/// A PT_INT32Q16 value: the raw signed 32-bit integer; the quantity is
/// `raw / 65536` (2.3.2). `04FA4000` = 83509248 = 1274.25.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Int32Q16(pub i32);

impl Int32Q16 {
    /// Nearest f64 (exact: every Q16.16 value is a binary fraction).
    pub fn to_f64(self) -> f64 {
        f64::from(self.0) / 65536.0
    }

    /// Parses a decimal and rounds `value * 65536` to the nearest integer,
    /// ties away from zero. The spec's own examples round this way:
    /// 132.15 -> 8660582.4 -> 8660582 = `842666` (7.2.1), 333.254 ->
    /// 21840134.1 -> 21840134 = `14D4106` (6.2.3). At most 20 fraction digits.
    pub fn from_decimal_rounded(s: &str) -> Result<Self, ValueError> {
        Self::from_decimal_inner(s, false)
    }

    /// Like [`Int32Q16::from_decimal_rounded`] but refuses a value that is
    /// not an exact multiple of 1/65536.
    pub fn from_decimal_exact(s: &str) -> Result<Self, ValueError> {
        Self::from_decimal_inner(s, true)
    }

    fn from_decimal_inner(s: &str, exact: bool) -> Result<Self, ValueError> {
        let d = Decimal::parse(s)?;
        let oor = ValueError::DecimalOutOfRange(ParameterType::Int32Q16);
        let num = d.mantissa.checked_mul(65536).ok_or(oor.clone())?;
        let den = pow10(d.scale);
        let (q, r) = (num / den, num % den);
        if exact && r != 0 {
            return Err(ValueError::NotExact(ParameterType::Int32Q16));
        }
        let mag = if r * 2 >= den { q + 1 } else { q };
        let v: i128 = if d.negative {
            -(mag as i128)
        } else {
            mag as i128
        };
        i32::try_from(v).map(Self).map_err(|_| oor)
    }
}

impl fmt::Display for Int32Q16 {
    /// Exact decimal, trailing zeros trimmed: `1274.25`, `-0.5`, `3`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let raw = i64::from(self.0);
        let mag = raw.unsigned_abs();
        let int = mag >> 16;
        // fraction in units of 1/65536 -> decimal: frac * 10^16 / 65536 is exact.
        let mut frac = (mag & 0xFFFF) * 152_587_890_625; // 10^16 / 65536
        let sign = if raw < 0 { "-" } else { "" };
        if frac == 0 {
            return write!(f, "{sign}{int}");
        }
        let mut digits = 16;
        while frac % 10 == 0 {
            frac /= 10;
            digits -= 1;
        }
        write!(f, "{sign}{int}.{frac:0digits$}")
    }
}

/// A PT_FLOAT_IEEE value, kept as its IEEE 754 single bit pattern (2.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FloatIeee(pub u32);

impl FloatIeee {
    /// Wraps an `f32`.
    pub fn from_f32(v: f32) -> Self {
        Self(v.to_bits())
    }
    /// The `f32` this pattern encodes.
    pub fn to_f32(self) -> f32 {
        f32::from_bits(self.0)
    }
}

/// A PT_VF_ERROR value (2.3.1): per the text, the **high byte** is the error
/// number and the **low byte** the time of error (hour counter, 1/10 h).
///
/// The C union the spec prints next to it would, on the little-endian PCs it
/// targets, put `ErrorCode` in the low byte; driveset follows the text
/// (errata: "PT_VF_ERROR byte order").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VfError {
    /// Error number; 15 means "no error" (2.3.1 note).
    pub number: u8,
    /// Time of error (hour counter, 1/10 h per the table).
    pub time: u8,
}

impl VfError {
    /// Splits the 16-bit raw value: number = high byte, time = low byte.
    pub const fn from_raw(raw: u16) -> Self {
        Self {
            number: (raw >> 8) as u8,
            time: raw as u8,
        }
    }
    /// The 16-bit raw value.
    pub const fn raw(self) -> u16 {
        ((self.number as u16) << 8) | self.time as u16
    }
    /// "No error": number 15 per the note in 2.3.1, or 0xFF (an erased EEPROM
    /// reads FFh, which the note gives as the reason; errata).
    pub const fn is_no_error(self) -> bool {
        self.number == 15 || self.number == 0xFF
    }
}

/// A PT_MC_ERROR value (2.3.2): 32 bits, error number, error location,
/// 16-bit error time, in that order **from the most significant end**:
/// `raw = number << 24 | location << 16 | time`.
///
/// This reads the structure table left to right like the hex VALUE string
/// and matches the PT_VF_ERROR text (number in the high byte). The spec's C
/// union on a little-endian host would give the reverse (`EType` in bits
/// 0..7); see errata "PT_MC_ERROR byte order".
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct McError {
    /// Error number ("type of error").
    pub number: u8,
    /// Module that registered the error.
    pub location: u8,
    /// Time-in-operation hour counter at the error.
    pub time: u16,
}

impl McError {
    /// Splits the raw 32-bit value (see the type docs for the order).
    pub const fn from_raw(raw: u32) -> Self {
        Self {
            number: (raw >> 24) as u8,
            location: (raw >> 16) as u8,
            time: raw as u16,
        }
    }
    /// The raw 32-bit value.
    pub const fn raw(self) -> u32 {
        ((self.number as u32) << 24) | ((self.location as u32) << 16) | self.time as u32
    }
}

/// A typed parameter value of either family.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParameterValue {
    /// PT_BINARY8.
    Binary8(u8),
    /// PT_FIXPOINT16.
    Fixpoint16(Fixpoint16),
    /// PT_USIGN16.
    Usign16(u16),
    /// PT_USIGN8.
    Usign8(u8),
    /// PT_VF_ERROR.
    VfError(VfError),
    /// PT_PASSWORD.
    Password(u16),
    /// PT_INTEGER16.
    Integer16(i16),
    /// PT_INT32Q16.
    Int32Q16(Int32Q16),
    /// PT_FLOAT_IEEE.
    FloatIeee(FloatIeee),
    /// PT_MC_ERROR.
    McError(McError),
}

impl ParameterValue {
    /// The value's type.
    pub const fn ty(&self) -> ParameterType {
        match self {
            Self::Binary8(_) => ParameterType::Binary8,
            Self::Fixpoint16(_) => ParameterType::Fixpoint16,
            Self::Usign16(_) => ParameterType::Usign16,
            Self::Usign8(_) => ParameterType::Usign8,
            Self::VfError(_) => ParameterType::VfError,
            Self::Password(_) => ParameterType::Password,
            Self::Integer16(_) => ParameterType::Integer16,
            Self::Int32Q16(_) => ParameterType::Int32Q16,
            Self::FloatIeee(_) => ParameterType::FloatIeee,
            Self::McError(_) => ParameterType::McError,
        }
    }

    /// The unsigned integer the wire carries (two's complement for the
    /// signed types: PT_INTEGER16 in 16 bits, PT_INT32Q16 in 32 bits).
    pub const fn raw(&self) -> u32 {
        match *self {
            Self::Binary8(v) | Self::Usign8(v) => v as u32,
            Self::Fixpoint16(v) => v.0 as u32,
            Self::Usign16(v) | Self::Password(v) => v as u32,
            Self::VfError(v) => v.raw() as u32,
            Self::Integer16(v) => v as u16 as u32,
            Self::Int32Q16(v) => v.0 as u32,
            Self::FloatIeee(v) => v.0,
            Self::McError(v) => v.raw(),
        }
    }

    /// Builds a value of type `ty` from the wire integer; `None` if it does
    /// not fit (e.g. 0x100 for PT_USIGN8).
    pub const fn from_raw(ty: ParameterType, raw: u32) -> Option<Self> {
        if raw > ty.max_raw() {
            return None;
        }
        Some(match ty {
            ParameterType::Binary8 => Self::Binary8(raw as u8),
            ParameterType::Fixpoint16 => Self::Fixpoint16(Fixpoint16(raw as u16)),
            ParameterType::Usign16 => Self::Usign16(raw as u16),
            ParameterType::Usign8 => Self::Usign8(raw as u8),
            ParameterType::VfError => Self::VfError(VfError::from_raw(raw as u16)),
            ParameterType::Password => Self::Password(raw as u16),
            ParameterType::Integer16 => Self::Integer16(raw as u16 as i16),
            ParameterType::Int32Q16 => Self::Int32Q16(Int32Q16(raw as i32)),
            ParameterType::FloatIeee => Self::FloatIeee(FloatIeee(raw)),
            ParameterType::McError => Self::McError(McError::from_raw(raw)),
        })
    }

    /// The value as a signed integer: PT_INTEGER16 and PT_INT32Q16
    /// sign-extended, every other type its unsigned wire integer. The raw
    /// value schemas and sets count in.
    pub const fn raw_signed(&self) -> i64 {
        match *self {
            Self::Integer16(v) => v as i64,
            Self::Int32Q16(v) => v.0 as i64,
            _ => self.raw() as i64,
        }
    }

    /// The inverse of [`ParameterValue::raw_signed`]: a value of type `ty`
    /// from a signed raw integer (two's complement on the wire for the
    /// signed types); `None` if the type cannot carry it.
    pub const fn from_raw_signed(ty: ParameterType, raw: i64) -> Option<Self> {
        let wire = match ty {
            ParameterType::Integer16 => {
                if raw < i16::MIN as i64 || raw > i16::MAX as i64 {
                    return None;
                }
                raw as i16 as u16 as u32
            }
            ParameterType::Int32Q16 => {
                if raw < i32::MIN as i64 || raw > i32::MAX as i64 {
                    return None;
                }
                raw as i32 as u32
            }
            _ => {
                if raw < 0 || raw > u32::MAX as i64 {
                    return None;
                }
                raw as u32
            }
        };
        Self::from_raw(ty, wire)
    }

    /// Encodes the VALUE string: VF1000 always 4 digits with leading zeros
    /// (`%04X`), MC without leading zeros (`%X`).
    pub fn encode(&self, family: Dialect) -> Result<ValueText, ValueError> {
        let ty = self.ty();
        if !ty.in_family(family) {
            return Err(ValueError::TypeNotInFamily { ty, family });
        }
        let width = match family {
            Dialect::Vf1000 => Some(4),
            Dialect::Mc => None,
        };
        Ok(hex_text(self.raw(), width))
    }

    /// Decodes a VALUE string as type `ty` of `family`.
    ///
    /// VF1000: exactly 4 uppercase hex digits. MC: 1..=8, leading zeros
    /// allowed. PT_INTEGER16 on MC also accepts the 32-bit sign extension a
    /// 32-bit `sprintf("%X", (int)v)` would produce (`FFFFFF85` = -123); any
    /// other value above 0xFFFF is out of range.
    pub fn decode(ty: ParameterType, family: Dialect, text: &[u8]) -> Result<Self, ValueError> {
        if !ty.in_family(family) {
            return Err(ValueError::TypeNotInFamily { ty, family });
        }
        let (ok, expected) = match family {
            Dialect::Vf1000 => (text.len() == 4, "exactly 4"),
            Dialect::Mc => ((1..=8).contains(&text.len()), "1 to 8"),
        };
        if !ok {
            return Err(ValueError::Length {
                found: text.len(),
                expected,
                family,
                ty,
            });
        }
        let mut raw = parse_hex(text)?;
        if ty == ParameterType::Integer16 && raw >= 0xFFFF_8000 {
            raw &= 0xFFFF;
        }
        Self::from_raw(ty, raw).ok_or(ValueError::OutOfRange { raw, ty })
    }
}

/// A parsed decimal: `mantissa / 10^scale`, with a sign.
struct Decimal {
    negative: bool,
    mantissa: u128,
    scale: u32,
}

impl Decimal {
    fn parse(s: &str) -> Result<Self, ValueError> {
        let s = s.trim();
        let (negative, body) = match s.as_bytes().first() {
            Some(b'-') => (true, &s[1..]),
            Some(b'+') => (false, &s[1..]),
            _ => (false, s),
        };
        let (int, frac) = match body.split_once('.') {
            Some((i, f)) => (i, f),
            None => (body, ""),
        };
        if int.is_empty() && frac.is_empty() {
            return Err(ValueError::Decimal("no digits"));
        }
        if !int.bytes().chain(frac.bytes()).all(|b| b.is_ascii_digit()) {
            return Err(ValueError::Decimal(
                "only digits, one '.' and a sign are allowed",
            ));
        }
        if frac.len() > 20 || int.len() > 12 {
            return Err(ValueError::Decimal("too many digits"));
        }
        let mut mantissa: u128 = 0;
        for b in int.bytes().chain(frac.bytes()) {
            mantissa = mantissa * 10 + u128::from(b - b'0');
        }
        Ok(Self {
            negative,
            mantissa,
            scale: frac.len() as u32,
        })
    }
}

fn pow10(n: u32) -> u128 {
    10u128.pow(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_widths_and_signed_raws() {
        for t in ParameterType::ALL {
            assert_eq!(ParameterType::from_name(t.name()), Some(t));
        }
        assert_eq!(ParameterType::from_name("VD"), None);
        assert_eq!(ParameterType::of_width(1), Some(ParameterType::Usign8));
        assert_eq!(ParameterType::of_width(2), Some(ParameterType::Usign16));
        assert_eq!(ParameterType::of_width(4), Some(ParameterType::Int32Q16));
        assert_eq!(ParameterType::of_width(3), None);
        let of = ParameterType::of_code;
        assert_eq!(
            of(Some("PT_FIXPOINT16"), Some(4)),
            Some(ParameterType::Fixpoint16)
        );
        assert_eq!((of(Some("VD"), Some(2)), of(None, None)), (None, None));
        assert_eq!(of(None, Some(2)), Some(ParameterType::Usign16));
        let v = ParameterValue::from_raw_signed(ParameterType::Integer16, -2).expect("fits");
        assert_eq!((v.raw(), v.raw_signed()), (0xFFFE, -2));
        let v = ParameterValue::from_raw_signed(ParameterType::Int32Q16, -65536).expect("fits");
        assert_eq!((v.raw(), v.raw_signed()), (0xFFFF_0000, -65536));
        assert_eq!(
            ParameterValue::from_raw_signed(ParameterType::Usign8, 255).map(|v| v.raw_signed()),
            Some(255)
        );
        assert_eq!(
            ParameterValue::from_raw_signed(ParameterType::Usign8, 256),
            None
        );
        assert_eq!(
            ParameterValue::from_raw_signed(ParameterType::Usign16, -1),
            None
        );
        assert_eq!(
            ParameterValue::from_raw_signed(ParameterType::Integer16, 32768),
            None
        );
        assert_eq!(
            ParameterValue::from_raw_signed(ParameterType::Int32Q16, i64::from(i32::MAX) + 1),
            None
        );
    }

    fn enc(v: ParameterValue, f: Dialect) -> String {
        String::from_utf8(v.encode(f).unwrap().as_bytes().to_vec()).unwrap()
    }

    #[test]
    fn vf_always_four_digits() {
        assert_eq!(enc(ParameterValue::Usign8(3), Dialect::Vf1000), "0003");
        assert_eq!(enc(ParameterValue::Binary8(0x80), Dialect::Vf1000), "0080");
        assert_eq!(
            enc(
                ParameterValue::Fixpoint16(Fixpoint16(1000)),
                Dialect::Vf1000
            ),
            "03E8"
        );
        assert_eq!(
            enc(ParameterValue::Usign16(0xFFFF), Dialect::Vf1000),
            "FFFF"
        );
    }

    #[test]
    fn mc_no_leading_zeros() {
        assert_eq!(enc(ParameterValue::Usign8(0), Dialect::Mc), "0");
        assert_eq!(enc(ParameterValue::Usign16(2), Dialect::Mc), "2");
        assert_eq!(enc(ParameterValue::Integer16(-1), Dialect::Mc), "FFFF");
        assert_eq!(enc(ParameterValue::Integer16(-32768), Dialect::Mc), "8000");
        assert_eq!(
            enc(ParameterValue::Int32Q16(Int32Q16(-1)), Dialect::Mc),
            "FFFFFFFF"
        );
        assert_eq!(
            enc(ParameterValue::Int32Q16(Int32Q16(83_509_248)), Dialect::Mc),
            "4FA4000"
        );
        assert_eq!(
            enc(
                ParameterValue::FloatIeee(FloatIeee::from_f32(1.0)),
                Dialect::Mc
            ),
            "3F800000"
        );
    }

    #[test]
    fn type_family_mismatch() {
        assert_eq!(
            ParameterValue::Int32Q16(Int32Q16(1)).encode(Dialect::Vf1000),
            Err(ValueError::TypeNotInFamily {
                ty: ParameterType::Int32Q16,
                family: Dialect::Vf1000
            })
        );
        assert!(ParameterValue::decode(ParameterType::Binary8, Dialect::Mc, b"1").is_err());
    }

    #[test]
    fn decode_rules() {
        use ParameterType as T;
        assert_eq!(
            ParameterValue::decode(T::Usign16, Dialect::Vf1000, b"3E8"),
            Err(ValueError::Length {
                found: 3,
                expected: "exactly 4",
                family: Dialect::Vf1000,
                ty: T::Usign16
            })
        );
        assert_eq!(
            ParameterValue::decode(T::Usign16, Dialect::Vf1000, b"03e8"),
            Err(ValueError::NotHex {
                offset: 2,
                found: b'e'
            })
        );
        assert_eq!(
            ParameterValue::decode(T::Usign8, Dialect::Vf1000, b"0100"),
            Err(ValueError::OutOfRange {
                raw: 0x100,
                ty: T::Usign8
            })
        );
        assert_eq!(
            ParameterValue::decode(T::Int32Q16, Dialect::Mc, b"04FA4000"),
            Ok(ParameterValue::Int32Q16(Int32Q16(83_509_248)))
        );
        assert_eq!(
            ParameterValue::decode(T::Integer16, Dialect::Mc, b"FFFFFF85"),
            Ok(ParameterValue::Integer16(-123))
        );
        assert_eq!(
            ParameterValue::decode(T::Integer16, Dialect::Mc, b"10000"),
            Err(ValueError::OutOfRange {
                raw: 0x10000,
                ty: T::Integer16
            })
        );
        assert!(ParameterValue::decode(T::Usign16, Dialect::Mc, b"").is_err());
        assert!(ParameterValue::decode(T::McError, Dialect::Mc, b"123456789").is_err());
    }

    #[test]
    fn int32q16_decimal() {
        assert_eq!(Int32Q16(83_509_248).to_string(), "1274.25");
        assert_eq!(Int32Q16(-32768).to_string(), "-0.5");
        assert_eq!(Int32Q16(65536 * 3).to_string(), "3");
        assert_eq!(Int32Q16(1).to_string(), "0.0000152587890625");
        assert_eq!(Int32Q16(i32::MIN).to_string(), "-32768");
        assert_eq!(
            Int32Q16::from_decimal_rounded("132.15"),
            Ok(Int32Q16(8_660_582))
        );
        assert_eq!(
            Int32Q16::from_decimal_rounded("333.254"),
            Ok(Int32Q16(21_840_134))
        );
        assert_eq!(
            Int32Q16::from_decimal_exact("132.15"),
            Err(ValueError::NotExact(ParameterType::Int32Q16))
        );
        assert_eq!(
            Int32Q16::from_decimal_exact("-1274.25"),
            Ok(Int32Q16(-83_509_248))
        );
        assert!(Int32Q16::from_decimal_rounded("32768").is_err());
        assert_eq!(
            Int32Q16::from_decimal_rounded("-32768"),
            Ok(Int32Q16(i32::MIN))
        );
        assert!(Int32Q16::from_decimal_rounded("1.2.3").is_err());
        assert!(Int32Q16::from_decimal_rounded("").is_err());
    }

    #[test]
    fn fixpoint16_decimal() {
        assert_eq!(Fixpoint16::from_decimal("50.00"), Ok(Fixpoint16(1000)));
        assert_eq!(Fixpoint16::from_decimal("23.15"), Ok(Fixpoint16(463)));
        assert_eq!(Fixpoint16(463).to_string(), "23.15");
        assert_eq!(Fixpoint16(65535).to_string(), "3276.75");
        assert_eq!(
            Fixpoint16::from_decimal("0.01"),
            Err(ValueError::NotExact(ParameterType::Fixpoint16))
        );
        assert!(Fixpoint16::from_decimal("3276.80").is_err());
        assert!(Fixpoint16::from_decimal("-1").is_err());
    }

    #[test]
    fn error_structs() {
        let e = VfError::from_raw(0x0F12);
        assert_eq!((e.number, e.time), (15, 0x12));
        assert!(e.is_no_error());
        assert_eq!(e.raw(), 0x0F12);
        let m = McError::from_raw(0x0503_1234);
        assert_eq!((m.number, m.location, m.time), (5, 3, 0x1234));
        assert_eq!(m.raw(), 0x0503_1234);
    }

    #[test]
    fn type_codes_round_trip() {
        for t in ParameterType::ALL {
            assert_eq!(ParameterType::from_code(t.code()), Some(t));
        }
        assert_eq!(ParameterType::from_code(b'0'), None);
    }
}
