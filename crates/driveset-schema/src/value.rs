//! Owns the value types of docs/file-formats.md ("Types and raw values") and
//! the exact conversion engineering value <-> raw value, with raw ranges.

use crate::decimal::Decimal;

/// A wire type from the table in docs/file-formats.md, "Types and raw values".
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ValueType {
    /// LECOM VD: i32 raw = value x 10000.
    VD,
    /// LECOM VH: unsigned, `width` 1/2/4 bytes (2 if unset).
    VH,
    /// LECOM VS: visible ASCII text, at most 20 characters.
    VS,
    /// LECOM VO: octets.
    VO,
    /// CAN FIX32: i32 raw = value x 10000.
    FIX32,
    /// CAN bit-coded: u32, no factor.
    BITCODED,
    /// LUSTBUS u8.
    PT_USIGN8,
    /// LUSTBUS u8 bit field.
    PT_BINARY8,
    /// LUSTBUS u16.
    PT_USIGN16,
    /// LUSTBUS u16 password.
    PT_PASSWORD,
    /// LUSTBUS i16.
    PT_INTEGER16,
    /// LUSTBUS u16 raw = value x 20 (steps of 0.05).
    PT_FIXPOINT16,
    /// LUSTBUS i32 raw = value x 65536.
    PT_INT32Q16,
    /// LUSTBUS f32 (raw = bit pattern).
    PT_FLOAT_IEEE,
    /// LUSTBUS u16 error record.
    PT_VF_ERROR,
    /// LUSTBUS u32 error record.
    PT_MC_ERROR,
    /// CAN (CiA 301 §7.1.4.4) UNSIGNED8: CiA 301 objects kept by index.
    UNSIGNED8,
    /// CAN (CiA 301) UNSIGNED16.
    UNSIGNED16,
    /// CAN (CiA 301) UNSIGNED32.
    UNSIGNED32,
    /// CAN (CiA 301 §7.1.4.5) INTEGER8.
    INTEGER8,
    /// CAN (CiA 301) INTEGER16.
    INTEGER16,
    /// CAN (CiA 301) INTEGER32.
    INTEGER32,
}

/// Every type, in table order.
pub const ALL_TYPES: [ValueType; 22] = [
    ValueType::VD,
    ValueType::VH,
    ValueType::VS,
    ValueType::VO,
    ValueType::FIX32,
    ValueType::BITCODED,
    ValueType::PT_USIGN8,
    ValueType::PT_BINARY8,
    ValueType::PT_USIGN16,
    ValueType::PT_PASSWORD,
    ValueType::PT_INTEGER16,
    ValueType::PT_FIXPOINT16,
    ValueType::PT_INT32Q16,
    ValueType::PT_FLOAT_IEEE,
    ValueType::PT_VF_ERROR,
    ValueType::PT_MC_ERROR,
    ValueType::UNSIGNED8,
    ValueType::UNSIGNED16,
    ValueType::UNSIGNED32,
    ValueType::INTEGER8,
    ValueType::INTEGER16,
    ValueType::INTEGER32,
];

/// How a type's raw value relates to its engineering value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Repr {
    /// raw integer = engineering value x factor.
    Scaled(u32),
    /// raw = f32 bit pattern.
    Float,
    /// raw = text.
    Text,
    /// raw = octets.
    Octets,
}

/// Why an engineering value has no raw form.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ConvError {
    /// Not a multiple of the type's step; the nearest representable values.
    Unrepresentable {
        /// The step, e.g. `1/65536`.
        step: &'static str,
        /// Nearest value below.
        lower: String,
        /// Nearest value above.
        upper: String,
    },
    /// Outside the type's raw range; the engineering range.
    OutOfRange {
        /// Smallest engineering value.
        min: String,
        /// Largest engineering value.
        max: String,
    },
}

impl ValueType {
    /// The type for a schema `type = "..."` name.
    pub fn from_name(name: &str) -> Option<Self> {
        ALL_TYPES.iter().copied().find(|t| t.name() == name)
    }

    /// The name as written in schemas.
    pub fn name(self) -> &'static str {
        match self {
            ValueType::VD => "VD",
            ValueType::VH => "VH",
            ValueType::VS => "VS",
            ValueType::VO => "VO",
            ValueType::FIX32 => "FIX32",
            ValueType::BITCODED => "BITCODED",
            ValueType::PT_USIGN8 => "PT_USIGN8",
            ValueType::PT_BINARY8 => "PT_BINARY8",
            ValueType::PT_USIGN16 => "PT_USIGN16",
            ValueType::PT_PASSWORD => "PT_PASSWORD",
            ValueType::PT_INTEGER16 => "PT_INTEGER16",
            ValueType::PT_FIXPOINT16 => "PT_FIXPOINT16",
            ValueType::PT_INT32Q16 => "PT_INT32Q16",
            ValueType::PT_FLOAT_IEEE => "PT_FLOAT_IEEE",
            ValueType::PT_VF_ERROR => "PT_VF_ERROR",
            ValueType::PT_MC_ERROR => "PT_MC_ERROR",
            ValueType::UNSIGNED8 => "UNSIGNED8",
            ValueType::UNSIGNED16 => "UNSIGNED16",
            ValueType::UNSIGNED32 => "UNSIGNED32",
            ValueType::INTEGER8 => "INTEGER8",
            ValueType::INTEGER16 => "INTEGER16",
            ValueType::INTEGER32 => "INTEGER32",
        }
    }

    /// How raw and engineering values relate.
    pub fn repr(self) -> Repr {
        match self {
            ValueType::VD | ValueType::FIX32 => Repr::Scaled(10000),
            ValueType::PT_FIXPOINT16 => Repr::Scaled(20),
            ValueType::PT_INT32Q16 => Repr::Scaled(65536),
            ValueType::PT_FLOAT_IEEE => Repr::Float,
            ValueType::VS => Repr::Text,
            ValueType::VO => Repr::Octets,
            _ => Repr::Scaled(1),
        }
    }

    /// Whether sets may give the value as hex `0x..` (integer, VH and bit-coded types).
    pub fn accepts_hex(self) -> bool {
        self.repr() == Repr::Scaled(1)
    }

    /// The step as shown in messages.
    pub fn step_text(self) -> &'static str {
        match self.repr() {
            Repr::Scaled(10000) => "0.0001",
            Repr::Scaled(20) => "0.05",
            Repr::Scaled(65536) => "1/65536",
            _ => "1",
        }
    }

    /// Inclusive raw range for integer-raw types (`width` only matters for VH:
    /// 1, 2 or 4 bytes, 2 when unset; any other width gives `None`).
    /// For PT_FLOAT_IEEE the range of the u32 bit pattern.
    pub fn raw_range(self, width: Option<u8>) -> Option<(i64, i64)> {
        const I32: (i64, i64) = (i32::MIN as i64, i32::MAX as i64);
        Some(match self {
            ValueType::VD | ValueType::FIX32 | ValueType::PT_INT32Q16 => I32,
            ValueType::VH => match width.unwrap_or(2) {
                1 => (0, 0xFF),
                2 => (0, 0xFFFF),
                4 => (0, 0xFFFF_FFFF),
                _ => return None,
            },
            ValueType::BITCODED | ValueType::PT_MC_ERROR | ValueType::PT_FLOAT_IEEE => {
                (0, 0xFFFF_FFFF)
            }
            ValueType::PT_USIGN8 | ValueType::PT_BINARY8 => (0, 0xFF),
            ValueType::PT_USIGN16
            | ValueType::PT_PASSWORD
            | ValueType::PT_FIXPOINT16
            | ValueType::PT_VF_ERROR => (0, 0xFFFF),
            ValueType::PT_INTEGER16 | ValueType::INTEGER16 => (i16::MIN as i64, i16::MAX as i64),
            ValueType::UNSIGNED8 => (0, 0xFF),
            ValueType::UNSIGNED16 => (0, 0xFFFF),
            ValueType::UNSIGNED32 => (0, 0xFFFF_FFFF),
            ValueType::INTEGER8 => (i8::MIN as i64, i8::MAX as i64),
            ValueType::INTEGER32 => I32,
            ValueType::VS | ValueType::VO => return None,
        })
    }

    /// Bit width of the raw value for bit-field checks.
    pub fn bit_width(self, width: Option<u8>) -> Option<u32> {
        let (_, max) = self.raw_range(width)?;
        if self.repr() != Repr::Scaled(1) || max <= 0 {
            return None;
        }
        Some(64 - (max as u64).leading_zeros())
    }
}

/// The fields of a PT_VF_ERROR / PT_MC_ERROR raw value as shown to people:
/// `{ number = 3, time = 12 }` (VF1000, §2.3.1: number = high byte, time =
/// low byte; errata L17), `{ number = 3, location = 2, time = 1234 }`
/// (MC, §2.3.2: `number << 24 | location << 16 | time`; errata L19). A VF
/// number of 15 or FFh adds `(no error)` (§2.3.1 note; errata L18). The
/// same layout as `driveset_proto::lustbus::{VfError, McError}` (a test in
/// driveset-cli's `decode::lustbus` checks that they agree). `None` for other types or a raw
/// value outside the type.
pub fn error_fields(ty: ValueType, raw: i64) -> Option<String> {
    match ty {
        ValueType::PT_VF_ERROR => {
            let r = u16::try_from(raw).ok()?;
            let (number, time) = (r >> 8, r & 0xFF);
            let none = if number == 15 || number == 0xFF {
                " (no error)"
            } else {
                ""
            };
            Some(format!("{{ number = {number}, time = {time} }}{none}"))
        }
        ValueType::PT_MC_ERROR => {
            let r = u32::try_from(raw).ok()?;
            Some(format!(
                "{{ number = {}, location = {}, time = {} }}",
                r >> 24,
                (r >> 16) & 0xFF,
                r & 0xFFFF
            ))
        }
        _ => None,
    }
}

/// Engineering text of a raw integer value (exact; PT_FLOAT_IEEE shows the
/// shortest decimal that reads back to the same f32).
pub fn raw_to_engineering(ty: ValueType, raw: i64) -> String {
    match ty.repr() {
        Repr::Scaled(f) => match Decimal::from_ratio(i128::from(raw), f) {
            Some(d) => d.to_string(),
            None => raw.to_string(),
        },
        Repr::Float => match u32::try_from(raw) {
            Ok(bits) => format_f32(f32::from_bits(bits)),
            Err(_) => raw.to_string(),
        },
        Repr::Text | Repr::Octets => raw.to_string(),
    }
}

fn format_f32(v: f32) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v.is_infinite() {
        if v < 0.0 { "-inf".into() } else { "inf".into() }
    } else {
        format!("{v}")
    }
}

/// Engineering decimal of a raw integer (scaled types only).
pub fn raw_to_decimal(ty: ValueType, raw: i64) -> Option<Decimal> {
    match ty.repr() {
        Repr::Scaled(f) => Decimal::from_ratio(i128::from(raw), f),
        _ => None,
    }
}

/// Convert an exact engineering decimal to the raw integer of a scaled type,
/// checking representability and the type's raw range.
pub fn decimal_to_raw(ty: ValueType, width: Option<u8>, value: &Decimal) -> Result<i64, ConvError> {
    let Repr::Scaled(factor) = ty.repr() else {
        return Err(out_of_range(ty, width));
    };
    let raw = match value.times_factor(i128::from(factor)) {
        Ok(r) => r,
        Err(Some((lo, hi))) => {
            let show = |k: i128| {
                Decimal::from_ratio(k, factor)
                    .map(|d| d.to_string())
                    .unwrap_or_default()
            };
            return Err(ConvError::Unrepresentable {
                step: ty.step_text(),
                lower: show(lo),
                upper: show(hi),
            });
        }
        Err(None) => return Err(out_of_range(ty, width)),
    };
    let Some((min, max)) = ty.raw_range(width) else {
        return Err(out_of_range(ty, width));
    };
    if raw < i128::from(min) || raw > i128::from(max) {
        return Err(out_of_range(ty, width));
    }
    i64::try_from(raw).map_err(|_| out_of_range(ty, width))
}

/// The engineering range of a type as texts (for messages).
pub fn engineering_range(ty: ValueType, width: Option<u8>) -> (String, String) {
    if ty == ValueType::PT_FLOAT_IEEE {
        // the f32 range, in the exponent form sets accept (f32::MAX)
        return ("-3.4028235e38".into(), "3.4028235e38".into());
    }
    match ty.raw_range(width) {
        Some((lo, hi)) => (raw_to_engineering(ty, lo), raw_to_engineering(ty, hi)),
        None => (String::new(), String::new()),
    }
}

fn out_of_range(ty: ValueType, width: Option<u8>) -> ConvError {
    let (min, max) = engineering_range(ty, width);
    ConvError::OutOfRange { min, max }
}

/// Parse an integer written in hex (`0x`), octal (`0o`) or binary (`0b`),
/// with optional `_` separators; `None` when the text is not such a literal.
pub fn parse_radix_int(text: &str) -> Option<Result<i128, ()>> {
    let t = text.trim();
    let (neg, body) = match t.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, t.strip_prefix('+').unwrap_or(t)),
    };
    let (radix, digits) =
        if let Some(d) = body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
            (16, d)
        } else if let Some(d) = body.strip_prefix("0o") {
            (8, d)
        } else if let Some(d) = body.strip_prefix("0b") {
            (2, d)
        } else {
            return None;
        };
    // `_` separators: only then build a cleaned copy
    let clean: std::borrow::Cow<'_, str> = if digits.contains('_') {
        std::borrow::Cow::Owned(digits.chars().filter(|c| *c != '_').collect())
    } else {
        std::borrow::Cow::Borrowed(digits)
    };
    if clean.is_empty()
        || clean.len() > 32
        || digits.starts_with('_')
        || digits.ends_with('_')
        || clean.starts_with(['+', '-'])
    {
        return Some(Err(()));
    }
    Some(match i128::from_str_radix(&clean, radix) {
        Ok(v) if neg => Ok(-v),
        Ok(v) => Ok(v),
        Err(_) => Err(()),
    })
}

/// Convert a decimal text to the bit pattern of the nearest f32 (IEEE round
/// to nearest, via the correctly rounded standard parser). Refuses NaN, inf
/// and anything that is not a plain decimal; a finite text beyond the f32
/// range is out of range.
pub fn float_text_to_raw(text: &str) -> Result<i64, Option<ConvError>> {
    let t: String = text.trim().chars().filter(|c| *c != '_').collect();
    let plain = !t.is_empty()
        && t.len() <= 400
        && t.chars()
            .all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-'))
        && t.chars().any(|c| c.is_ascii_digit());
    if !plain {
        return Err(None);
    }
    let v: f32 = t.parse().map_err(|_| None)?;
    if !v.is_finite() {
        return Err(Some(out_of_range(ValueType::PT_FLOAT_IEEE, None)));
    }
    Ok(i64::from(v.to_bits()))
}

/// Check a VS text: visible ASCII (space to `~`), at most 20 characters.
pub fn check_vs_text(text: &str) -> Result<(), String> {
    if let Some(c) = text.chars().find(|c| !(' '..='~').contains(c)) {
        return Err(format!("character {c:?} is not visible ASCII"));
    }
    let n = text.chars().count();
    if n > 20 {
        return Err(format!("{n} characters, at most 20 allowed"));
    }
    Ok(())
}

/// Parse a VO hex string (optional `0x`, even number of hex digits).
pub fn parse_octets(text: &str) -> Option<Vec<u8>> {
    let t = text.trim();
    let t = t.strip_prefix("0x").unwrap_or(t);
    if !t.len().is_multiple_of(2) || !t.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    (0..t.len() / 2)
        .map(|i| {
            t.get(2 * i..2 * i + 2)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(ty: ValueType, s: &str) -> Result<i64, ConvError> {
        decimal_to_raw(ty, None, &Decimal::parse(s).unwrap())
    }

    #[test]
    fn vd_four_decimals_and_fifth_unrepresentable() {
        assert_eq!(raw(ValueType::VD, "50.0"), Ok(500_000));
        assert_eq!(raw(ValueType::VD, "-214748.3648"), Ok(-2_147_483_648));
        assert_eq!(raw(ValueType::VD, "214748.3647"), Ok(2_147_483_647));
        assert_eq!(raw(ValueType::VD, "1.2345"), Ok(12345));
        assert_eq!(
            raw(ValueType::VD, "1.23456"),
            Err(ConvError::Unrepresentable {
                step: "0.0001",
                lower: "1.2345".into(),
                upper: "1.2346".into()
            })
        );
        assert_eq!(
            raw(ValueType::VD, "214748.3648"),
            Err(ConvError::OutOfRange {
                min: "-214748.3648".into(),
                max: "214748.3647".into()
            })
        );
        assert_eq!(
            raw_to_engineering(ValueType::VD, -2_147_483_648),
            "-214748.3648"
        );
        assert_eq!(raw_to_engineering(ValueType::VD, 500_000), "50");
    }

    #[test]
    fn fix32_same_as_vd() {
        assert_eq!(raw(ValueType::FIX32, "-0.0001"), Ok(-1));
        assert_eq!(raw(ValueType::FIX32, "-0"), Ok(0));
        assert_eq!(
            raw_to_engineering(ValueType::FIX32, 2_147_483_647),
            "214748.3647"
        );
    }

    #[test]
    fn fixpoint16_steps_of_005() {
        assert_eq!(raw(ValueType::PT_FIXPOINT16, "0.05"), Ok(1));
        assert_eq!(raw(ValueType::PT_FIXPOINT16, "3276.75"), Ok(65535));
        assert_eq!(raw(ValueType::PT_FIXPOINT16, "0"), Ok(0));
        assert_eq!(
            raw(ValueType::PT_FIXPOINT16, "0.07"),
            Err(ConvError::Unrepresentable {
                step: "0.05",
                lower: "0.05".into(),
                upper: "0.1".into()
            })
        );
        assert_eq!(
            raw(ValueType::PT_FIXPOINT16, "-0.05"),
            Err(ConvError::OutOfRange {
                min: "0".into(),
                max: "3276.75".into()
            })
        );
        assert_eq!(
            raw_to_engineering(ValueType::PT_FIXPOINT16, 65535),
            "3276.75"
        );
        assert_eq!(raw_to_engineering(ValueType::PT_FIXPOINT16, 3), "0.15");
    }

    #[test]
    fn int32q16_exact_nearest() {
        assert_eq!(raw(ValueType::PT_INT32Q16, "1"), Ok(65536));
        assert_eq!(raw(ValueType::PT_INT32Q16, "0.0000152587890625"), Ok(1));
        assert_eq!(
            raw(ValueType::PT_INT32Q16, "-32768"),
            Ok(i64::from(i32::MIN))
        );
        assert_eq!(
            raw(ValueType::PT_INT32Q16, "333.254"),
            Err(ConvError::Unrepresentable {
                step: "1/65536",
                lower: "333.253997802734375".into(),
                upper: "333.2540130615234375".into(),
            })
        );
        assert_eq!(
            raw_to_engineering(ValueType::PT_INT32Q16, i64::from(i32::MAX)),
            "32767.9999847412109375"
        );
    }

    #[test]
    fn integer_types_ranges() {
        use ValueType::*;
        let cases: [(ValueType, &str, &str); 9] = [
            (PT_USIGN8, "0", "255"),
            (PT_BINARY8, "0", "255"),
            (PT_USIGN16, "0", "65535"),
            (PT_PASSWORD, "0", "65535"),
            (PT_INTEGER16, "-32768", "32767"),
            (PT_VF_ERROR, "0", "65535"),
            (PT_MC_ERROR, "0", "4294967295"),
            (BITCODED, "0", "4294967295"),
            (VH, "0", "65535"),
        ];
        for (ty, lo, hi) in cases {
            assert_eq!(
                raw(ty, lo).map(|r| r.to_string()),
                Ok(lo.to_string()),
                "{ty:?}"
            );
            assert_eq!(
                raw(ty, hi).map(|r| r.to_string()),
                Ok(hi.to_string()),
                "{ty:?}"
            );
            let below = (Decimal::parse(lo).unwrap().mantissa() - 1).to_string();
            assert_eq!(
                raw(ty, &below),
                Err(ConvError::OutOfRange {
                    min: lo.into(),
                    max: hi.into()
                }),
                "{ty:?}"
            );
        }
        assert_eq!(
            raw(PT_USIGN8, "1.5"),
            Err(ConvError::Unrepresentable {
                step: "1",
                lower: "1".into(),
                upper: "2".into()
            })
        );
        assert_eq!(raw(PT_USIGN8, "2.000"), Ok(2));
        assert_eq!(
            decimal_to_raw(VH, Some(1), &Decimal::from_int(256)),
            Err(ConvError::OutOfRange {
                min: "0".into(),
                max: "255".into()
            })
        );
        assert_eq!(
            decimal_to_raw(VH, Some(4), &Decimal::from_int(0xFFFF_FFFF)),
            Ok(0xFFFF_FFFF)
        );
        assert_eq!(ValueType::VH.raw_range(Some(3)), None);
    }

    #[test]
    fn float_ieee() {
        assert_eq!(float_text_to_raw("1.5"), Ok(0x3FC0_0000));
        assert_eq!(float_text_to_raw("-0"), Ok(0x8000_0000));
        assert_eq!(float_text_to_raw("0.1"), Ok(0x3DCC_CCCD));
        assert_eq!(
            raw_to_engineering(ValueType::PT_FLOAT_IEEE, 0x3DCC_CCCD),
            "0.1"
        );
        assert_eq!(
            raw_to_engineering(ValueType::PT_FLOAT_IEEE, 0x8000_0000),
            "-0"
        );
        assert_eq!(float_text_to_raw("nan"), Err(None));
        assert_eq!(float_text_to_raw("inf"), Err(None));
        assert!(matches!(
            float_text_to_raw("1e39"),
            Err(Some(ConvError::OutOfRange { .. }))
        ));
        assert_eq!(float_text_to_raw("3.4028235e38"), Ok(0x7F7F_FFFF));
    }

    #[test]
    fn text_and_octets() {
        assert_eq!(check_vs_text("33STMD-M_12000"), Ok(()));
        assert_eq!(
            check_vs_text("abcdefghijklmnopqrstu"),
            Err("21 characters, at most 20 allowed".into())
        );
        assert_eq!(
            check_vs_text("\u{e9}"),
            Err("character 'é' is not visible ASCII".into())
        );
        assert_eq!(parse_octets("0x0aFF"), Some(vec![0x0a, 0xff]));
        assert_eq!(parse_octets("abc"), None);
        assert_eq!(parse_radix_int("0x03_41"), Some(Ok(0x341)));
        assert_eq!(parse_radix_int("12"), None);
        assert_eq!(parse_radix_int("0xZZ"), Some(Err(())));
    }
}
