//! Owns [`Decimal`], the exact decimal number used for every engineering
//! value (docs/file-formats.md, "Types and raw values": no floating point).

use std::cmp::Ordering;
use std::fmt;

/// Most significant digits a [`Decimal`] holds (10^36 < i128::MAX).
pub const MAX_DIGITS: u32 = 36;

/// An exact decimal: `mantissa / 10^scale`, normalized (no trailing zero
/// digits after the point, `-0` is `0`), so equal values compare and hash equal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Decimal {
    mantissa: i128,
    scale: u32,
}

/// Why a text is not a decimal number.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecimalError {
    /// Nothing to parse.
    #[error("empty number")]
    Empty,
    /// A character that does not belong in a decimal number.
    #[error("`{text}` is not a decimal number")]
    Invalid {
        /// The text as given.
        text: String,
    },
    /// More significant digits or decimals than [`MAX_DIGITS`].
    #[error("`{text}` has more than {MAX_DIGITS} significant digits")]
    TooManyDigits {
        /// The text as given.
        text: String,
    },
}

pub(crate) fn pow10(n: u32) -> Option<i128> {
    10i128.checked_pow(n)
}

impl Decimal {
    /// Zero.
    pub const ZERO: Decimal = Decimal {
        mantissa: 0,
        scale: 0,
    };

    /// An integer.
    pub fn from_int(v: i128) -> Self {
        Decimal {
            mantissa: v,
            scale: 0,
        }
    }

    /// `mantissa / 10^scale`, or `None` when `scale` exceeds [`MAX_DIGITS`].
    pub fn new(mantissa: i128, scale: u32) -> Option<Self> {
        if scale > MAX_DIGITS {
            return None;
        }
        Some(Decimal { mantissa, scale }.normalized())
    }

    /// The mantissa (normalized).
    pub fn mantissa(&self) -> i128 {
        self.mantissa
    }

    /// The number of decimals (normalized).
    pub fn scale(&self) -> u32 {
        self.scale
    }

    fn normalized(mut self) -> Self {
        while self.scale > 0 && self.mantissa % 10 == 0 {
            self.mantissa /= 10;
            self.scale -= 1;
        }
        if self.mantissa == 0 {
            self.scale = 0;
        }
        self
    }

    /// Whether the value is negative (not zero).
    pub fn is_negative(&self) -> bool {
        self.mantissa < 0
    }

    /// `k / denominator` exactly, where `denominator` is `2^a * 5^b` (every
    /// scale of docs/file-formats.md is); `None` otherwise or on overflow.
    pub fn from_ratio(k: i128, denominator: u32) -> Option<Self> {
        if denominator == 0 {
            return None;
        }
        let (mut d, mut twos, mut fives) = (denominator, 0u32, 0u32);
        while d % 2 == 0 {
            d /= 2;
            twos += 1;
        }
        while d % 5 == 0 {
            d /= 5;
            fives += 1;
        }
        if d != 1 {
            return None;
        }
        let n = twos.max(fives);
        let mult = pow10(n)?.checked_div(i128::from(denominator))?;
        Decimal::new(k.checked_mul(mult)?, n)
    }

    /// Parse a plain decimal: optional sign, digits with optional `_`
    /// between digits (as in TOML), optional `.` fraction, optional exponent
    /// `e`/`E` (so `1e3` and `2.5E-2` are exact too).
    pub fn parse(text: &str) -> Result<Self, DecimalError> {
        let invalid = || DecimalError::Invalid {
            text: text.to_string(),
        };
        let too_many = || DecimalError::TooManyDigits {
            text: text.to_string(),
        };
        let s = text.trim();
        if s.is_empty() {
            return Err(DecimalError::Empty);
        }
        let (neg, s) = match s.as_bytes().first() {
            Some(b'-') => (true, &s[1..]),
            Some(b'+') => (false, &s[1..]),
            _ => (false, s),
        };
        let (body, exp) = match s.find(['e', 'E']) {
            Some(i) => (&s[..i], Some(&s[i + 1..])),
            None => (s, None),
        };
        let (int_part, frac_part) = match body.find('.') {
            Some(i) => (&body[..i], Some(&body[i + 1..])),
            None => (body, None),
        };
        if int_part.is_empty() && frac_part.is_none_or(str::is_empty) {
            return Err(invalid());
        }
        let mut mantissa: i128 = 0;
        let mut digits: u32 = 0;
        let mut scale: u32 = 0;
        let mut push_digits = |part: &str, is_frac: bool| -> Result<(), DecimalError> {
            let bytes = part.as_bytes();
            for (i, &b) in bytes.iter().enumerate() {
                if b == b'_' {
                    let ok = i > 0
                        && bytes.get(i - 1).is_some_and(u8::is_ascii_digit)
                        && bytes.get(i + 1).is_some_and(u8::is_ascii_digit);
                    if !ok {
                        return Err(invalid());
                    }
                    continue;
                }
                if !b.is_ascii_digit() {
                    return Err(invalid());
                }
                let d = i128::from(b - b'0');
                if mantissa == 0 && d == 0 {
                    if is_frac {
                        scale = scale.checked_add(1).ok_or_else(too_many)?;
                    }
                    continue; // leading zeros are not significant
                }
                digits += 1;
                if digits > MAX_DIGITS {
                    return Err(too_many());
                }
                mantissa = mantissa
                    .checked_mul(10)
                    .and_then(|m| m.checked_add(d))
                    .ok_or_else(too_many)?;
                if is_frac {
                    scale = scale.checked_add(1).ok_or_else(too_many)?;
                }
            }
            Ok(())
        };
        push_digits(int_part, false)?;
        if let Some(f) = frac_part {
            push_digits(f, true)?;
        }
        let mut scale = i64::from(scale);
        if let Some(e) = exp {
            let (eneg, edigits) = match e.as_bytes().first() {
                Some(b'-') => (true, &e[1..]),
                Some(b'+') => (false, &e[1..]),
                _ => (false, e),
            };
            if edigits.is_empty()
                || edigits.len() > 6
                || !edigits.bytes().all(|b| b.is_ascii_digit() || b == b'_')
            {
                return Err(invalid());
            }
            let ev: i64 = edigits.replace('_', "").parse().map_err(|_| invalid())?;
            scale = if eneg { scale + ev } else { scale - ev };
        }
        if mantissa == 0 {
            return Ok(Decimal::ZERO);
        }
        // strip trailing zeros before applying a negative scale
        while scale > 0 && mantissa % 10 == 0 {
            mantissa /= 10;
            scale -= 1;
        }
        if scale < 0 {
            let up = u32::try_from(-scale).map_err(|_| too_many())?;
            mantissa = pow10(up)
                .and_then(|p| mantissa.checked_mul(p))
                .ok_or_else(too_many)?;
            if mantissa.unsigned_abs() >= 10u128.pow(MAX_DIGITS) {
                return Err(too_many());
            }
            scale = 0;
        }
        let scale = u32::try_from(scale).map_err(|_| too_many())?;
        if scale > MAX_DIGITS {
            return Err(too_many());
        }
        if neg {
            mantissa = -mantissa;
        }
        Ok(Decimal { mantissa, scale }.normalized())
    }

    /// Exact conversion to an integer raw value `self x factor`.
    /// `Err(None)` on overflow; `Err(Some((lower, upper)))` when the product is
    /// not an integer, with the two nearest representable raw integers.
    pub fn times_factor(&self, factor: i128) -> Result<i128, Option<(i128, i128)>> {
        let num = self.mantissa.checked_mul(factor).ok_or(None)?;
        let den = pow10(self.scale).ok_or(None)?;
        let q = num.div_euclid(den);
        if num.rem_euclid(den) == 0 {
            Ok(q)
        } else {
            Err(Some((q, q.checked_add(1).ok_or(None)?)))
        }
    }

    /// The integer value, if the decimal is an integer.
    pub fn to_integer(&self) -> Option<i128> {
        if self.scale == 0 {
            Some(self.mantissa)
        } else {
            None
        }
    }
}

impl Ord for Decimal {
    fn cmp(&self, other: &Self) -> Ordering {
        if self.scale == other.scale {
            return self.mantissa.cmp(&other.mantissa);
        }
        let (a, b, flipped) = if self.scale < other.scale {
            (self, other, false)
        } else {
            (other, self, true)
        };
        // a has fewer decimals: scale a up to b's decimals
        let ord = match pow10(b.scale - a.scale).and_then(|p| a.mantissa.checked_mul(p)) {
            Some(am) => am.cmp(&b.mantissa),
            // |a x 10^d| exceeds i128, hence exceeds |b|: a's sign decides
            None => {
                if a.mantissa < 0 {
                    Ordering::Less
                } else {
                    Ordering::Greater
                }
            }
        };
        if flipped { ord.reverse() } else { ord }
    }
}

impl PartialOrd for Decimal {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl fmt::Display for Decimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let digits = self.mantissa.unsigned_abs().to_string();
        let sign = if self.mantissa < 0 { "-" } else { "" };
        let scale = self.scale as usize;
        if scale == 0 {
            return write!(f, "{sign}{digits}");
        }
        if digits.len() > scale {
            let (i, fr) = digits.split_at(digits.len() - scale);
            write!(f, "{sign}{i}.{fr}")
        } else {
            write!(f, "{sign}0.{}{digits}", "0".repeat(scale - digits.len()))
        }
    }
}

impl std::str::FromStr for Decimal {
    type Err = DecimalError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Decimal::parse(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(s: &str) -> Decimal {
        Decimal::parse(s).unwrap()
    }

    #[test]
    fn parse_and_display_exact() {
        assert_eq!(d("-12.3400").to_string(), "-12.34");
        assert_eq!(d("0.1").to_string(), "0.1");
        assert_eq!(d("-0").to_string(), "0");
        assert_eq!(d("-0.000").to_string(), "0");
        assert_eq!(d("1_000.5").to_string(), "1000.5");
        assert_eq!(d("1e3").to_string(), "1000");
        assert_eq!(d("2.5E-2").to_string(), "0.025");
        assert_eq!(d("+7.50").to_string(), "7.5");
        assert_eq!(d(".5").to_string(), "0.5");
        assert_eq!(d("0.000001").to_string(), "0.000001");
        assert_eq!(
            d("123456789012345678901234567890.123456").to_string(),
            "123456789012345678901234567890.123456"
        );
    }

    #[test]
    fn parse_rejects() {
        for bad in [
            "",
            "-",
            ".",
            "1_",
            "_1",
            "1__0",
            "1.2.3",
            "abc",
            "1e",
            "0x10",
            "1e99999999",
            "nan",
            "inf",
            "1 2",
        ] {
            assert!(Decimal::parse(bad).is_err(), "{bad:?} should not parse");
        }
        assert_eq!(
            Decimal::parse("1234567890123456789012345678901234567").unwrap_err(),
            DecimalError::TooManyDigits {
                text: "1234567890123456789012345678901234567".into()
            }
        );
        assert!(Decimal::parse("1e40").is_err());
    }

    #[test]
    fn ordering() {
        assert!(d("7.5") < d("240"));
        assert!(d("-0.05") < d("0"));
        assert_eq!(d("1.50").cmp(&d("1.5")), Ordering::Equal);
        assert!(
            d("100000000000000000000000000000000000") > d("0.000000000000000000000000000000000001")
        );
        assert!(
            d("-100000000000000000000000000000000000")
                < d("0.000000000000000000000000000000000001")
        );
    }

    #[test]
    fn ratios_terminate() {
        assert_eq!(
            Decimal::from_ratio(21_840_117, 65536).unwrap().to_string(),
            "333.2537384033203125"
        );
        assert_eq!(
            Decimal::from_ratio(1, 65536).unwrap().to_string(),
            "0.0000152587890625"
        );
        assert_eq!(Decimal::from_ratio(-3, 20).unwrap().to_string(), "-0.15");
        assert_eq!(Decimal::from_ratio(1, 3), None);
    }

    #[test]
    fn times_factor_exact_and_nearest() {
        assert_eq!(d("12.3456").times_factor(10000), Ok(123456));
        assert_eq!(
            d("12.34567").times_factor(10000),
            Err(Some((123456, 123457)))
        );
        assert_eq!(
            d("-12.34567").times_factor(10000),
            Err(Some((-123457, -123456)))
        );
        assert_eq!(d("0.05").times_factor(20), Ok(1));
        assert_eq!(
            d("99999999999999999999999999999999999").times_factor(65536),
            Err(None)
        );
    }
}
