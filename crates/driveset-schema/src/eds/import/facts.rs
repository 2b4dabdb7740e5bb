//! Converting one variable's facts for the import: its type, access,
//! DefaultValue / LowLimit / HighLimit in engineering units, exactly
//! (FIX32 raw / 10000 as a decimal), with a lint for every value left unset
//! (`lenze-system-bus-can-sdo.txt`, ECS manual p. 454).

use crate::decimal::Decimal;
use crate::eds::reader::{IntValue, parse_int, parse_octets};
use crate::value::{ValueType, check_vs_text};

use super::{Acc, Area, Ctx, Var, data_type_name, value_type};

/// The facts one variable gives, converted.
pub(super) struct Facts {
    pub(super) dt: u16,
    pub(super) acc: Acc,
    pub(super) min: Option<String>,
    pub(super) max: Option<String>,
    pub(super) default: Option<String>,
}

/// The facts of one variable, or `None` (with a lint) when it is skipped.
pub(super) fn var_facts(
    cx: &mut Ctx,
    v: &Var<'_>,
    obj: &str,
    ar: Area,
    bitcoded: bool,
    ot: i128,
) -> Option<Facts> {
    let line = v.line();
    let obj = obj.to_string();
    let dt_entry = v.key("DataType");
    let dt = match dt_entry.map(|e| (e, parse_int(&e.value))) {
        None => {
            cx.lint(line, obj, "no DataType; skipped");
            return None;
        }
        Some((
            _,
            Some(IntValue {
                value,
                plus_node_id: false,
                ..
            }),
        )) if (0..=0xFFFF).contains(&value) => value as u16,
        Some((e, _)) => {
            cx.lint(
                e.line,
                obj,
                format!("DataType `{}` is not a type number; skipped", e.value),
            );
            return None;
        }
    };
    let acc = match v.key("AccessType") {
        None => {
            cx.lint(line, obj, "no AccessType; skipped");
            return None;
        }
        Some(e) => match e.value.to_ascii_lowercase().as_str() {
            "ro" => Acc::Ro,
            "const" => Acc::Const,
            "wo" => Acc::Wo,
            "rw" | "rwr" | "rww" => Acc::Rw,
            _ => {
                cx.lint(
                    e.line,
                    obj,
                    format!(
                        "AccessType `{}` is not ro, wo, rw, rwr, rww or const; skipped",
                        e.value
                    ),
                );
                return None;
            }
        },
    };
    // sub 0 of an ARRAY / RECORD: the number of entries
    if (ot == 8 || ot == 9) && v.sub == 0 {
        if dt == 0x0005 && matches!(acc, Acc::Ro | Acc::Const) {
            return None;
        }
        cx.lint(
            line,
            obj,
            format!(
                "number of entries is {} {}; it is the structure, not a setting; skipped",
                data_type_name(dt),
                if matches!(acc, Acc::Ro | Acc::Const) {
                    "read-only"
                } else {
                    "writable"
                }
            ),
        );
        return None;
    }
    if dt == 0x000F || ot == 2 {
        cx.lint(line, obj, "DOMAIN object (no fixed size or type); skipped");
        return None;
    }
    let Some(ty) = value_type(ar, bitcoded, dt) else {
        let why = match ar {
            Area::Lenze(c) if bitcoded => format!(
                "DataType {} for C{c:04}, which page 454 says is bit-coded (an integer type); skipped",
                data_type_name(dt)
            ),
            Area::Lenze(_) => format!(
                "DataType {} in the Lenze code range: page 454 transmits Lenze codes as FIX32 (4 bytes); skipped",
                data_type_name(dt)
            ),
            _ => format!(
                "DataType {} is not a type driveset carries; skipped",
                data_type_name(dt)
            ),
        };
        cx.lint(line, obj, why);
        return None;
    };
    if acc == Acc::Wo {
        cx.lint(
            v.key("AccessType").map_or(line, |e| e.line),
            obj,
            "write-only (wo): driveset reads back every value it writes; skipped",
        );
        return None;
    }
    let mut acc = acc;
    if let Some(e) = v.key("ObjFlags")
        && !e.value.is_empty()
    {
        match parse_int(&e.value) {
            Some(f) if f.value & 2 != 0 => {
                cx.lint(e.line, obj, "ObjFlags bit 1 (refuse read on scan): driveset reads every code it holds; skipped");
                return None;
            }
            Some(f) if f.value & 1 != 0 && acc == Acc::Rw => {
                cx.lint(
                    e.line,
                    obj.clone(),
                    "ObjFlags bit 0 (refuse write on download): kept read-only",
                );
                acc = Acc::Ro;
            }
            Some(_) => {}
            None => cx.lint(
                e.line,
                obj.clone(),
                format!("ObjFlags `{}` is not a number; ignored", e.value),
            ),
        }
    }
    if ty == ValueType::BITCODED && dt != 0x0007 {
        cx.lint(
            line,
            obj.clone(),
            format!(
                "DataType {}: typed BITCODED (u32) as page 454 says of C0135 / C0150",
                data_type_name(dt)
            ),
        );
    }
    if ty == ValueType::FIX32 && dt == 0x0007 {
        cx.lint(line, obj.clone(), "DataType UNSIGNED32 (0x0007) read as FIX32 (page 454: Lenze codes are FIX32, value x 10000)");
    }
    if dt == 0x0001 {
        cx.lint(
            line,
            obj.clone(),
            "BOOLEAN kept as UNSIGNED8 (one byte, 0 or 1)",
        );
    }
    let mut fact = |key: &str| -> Option<String> {
        let e = v.key(key)?;
        convert(cx, e.line, &obj, key, &e.value, ty)
    };
    let mut min = fact("LowLimit");
    let mut max = fact("HighLimit");
    let default = fact("DefaultValue");
    if dt == 0x0001 {
        min.get_or_insert_with(|| "0".into());
        max.get_or_insert_with(|| "1".into());
    }
    Some(Facts {
        dt,
        acc,
        min,
        max,
        default,
    })
}

/// An EDS value text -> engineering text for `ty`, or `None` with a lint.
pub(super) fn convert(
    cx: &mut Ctx,
    line: usize,
    obj: &str,
    key: &str,
    text: &str,
    ty: ValueType,
) -> Option<String> {
    let obj = obj.to_string();
    if text.trim().is_empty() {
        cx.lint(line, obj, format!("empty {key}; left unset"));
        return None;
    }
    match ty {
        ValueType::VS => {
            if key != "DefaultValue" {
                return None;
            }
            match check_vs_text(text) {
                Ok(()) => Some(text.to_string()),
                Err(m) => {
                    cx.lint(
                        line,
                        obj,
                        format!("{key} {text:?} is not VS text ({m}); left unset"),
                    );
                    None
                }
            }
        }
        ValueType::VO => {
            if key != "DefaultValue" {
                return None;
            }
            match parse_octets(text) {
                Some(_) => Some(text.trim().to_ascii_lowercase()),
                None => {
                    cx.lint(
                        line,
                        obj,
                        format!("{key} `{text}` is not hex octets; left unset"),
                    );
                    None
                }
            }
        }
        _ => {
            let Some(v) = parse_int(text) else {
                cx.lint(
                    line,
                    obj,
                    format!("{key} `{text}` is not an integer; left unset"),
                );
                return None;
            };
            if v.plus_node_id {
                cx.lint(
                    line,
                    obj,
                    format!("{key} `{text}` depends on the node id; left unset"),
                );
                return None;
            }
            if let Some(o) = v.octal_differs {
                cx.lint(
                    line,
                    obj.clone(),
                    format!("{key} `{text}` read as decimal {} (a leading 0 means octal in C, giving {o})", v.value),
                );
            }
            let (lo, hi) = ty.raw_range(None).unwrap_or((0, 0));
            let mut raw = v.value;
            // a hex pattern for a signed type is two's complement
            if v.hex && lo < 0 && raw > i128::from(hi) && raw <= 2 * i128::from(hi) + 1 {
                raw -= 2 * i128::from(hi) + 2;
            }
            if raw < i128::from(lo) || raw > i128::from(hi) {
                cx.lint(
                    line,
                    obj,
                    format!(
                        "{key} `{text}` is outside {} ({lo}..={hi}); left unset",
                        ty.name()
                    ),
                );
                return None;
            }
            let factor = match ty.repr() {
                crate::value::Repr::Scaled(f) => f,
                _ => 1,
            };
            Decimal::from_ratio(raw, factor).map(|d| d.to_string())
        }
    }
}

pub(super) fn order_facts(
    cx: &mut Ctx,
    line: usize,
    obj: &str,
    ty: ValueType,
    min: &mut Option<String>,
    max: &mut Option<String>,
    default: &mut Option<String>,
) {
    if matches!(ty, ValueType::VS | ValueType::VO) {
        return;
    }
    let d = |s: &Option<String>| s.as_deref().and_then(|t| Decimal::parse(t).ok());
    if let (Some(a), Some(b)) = (d(min), d(max))
        && a > b
    {
        cx.lint(
            line,
            obj.to_string(),
            format!(
                "LowLimit {} is above HighLimit {}; both left unset",
                min.as_deref().unwrap_or(""),
                max.as_deref().unwrap_or("")
            ),
        );
        *min = None;
        *max = None;
    }
    if let Some(v) = d(default) {
        let below = d(min).is_some_and(|m| v < m);
        let above = d(max).is_some_and(|m| v > m);
        if below || above {
            cx.lint(
                line,
                obj.to_string(),
                format!(
                    "DefaultValue {} is outside LowLimit..HighLimit; left unset",
                    default.as_deref().unwrap_or("")
                ),
            );
            *default = None;
        }
    }
}
