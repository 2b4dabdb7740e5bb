//! Owns the `describe=` option of a simulated LUSTBUS drive: parameters
//! whose own description (VF1000 section 11.1, MC6000/7000 section 11.2)
//! says something other than the fixture the drive is built from, the way
//! a real drive's firmware may disagree with the spec (issue 18). Only the
//! description changes; the parameter keeps its fixture behaviour (a
//! parameter described as an actual value still accepts a SELECT).
//!
//! # Grammar
//!
//! `describe=N:ITEM[:ITEM...][;N:ITEM...]`, `N` the parameter number, each
//! `ITEM` one of
//!
//! | item | the description says |
//! | --- | --- |
//! | `actual`, `control`, `eeprom`, `fsel` | that storage kind (RAM actual value, RAM control value, EEPROM value, VF1000 FSEL/ISEL variable; the MC has no `fsel`) |
//! | a type name (`binary8`, `usign8`, `usign16`, `integer16`, `fixpoint16`, `int32q16`, `float_ieee`, `password`, `vf_error`, `mc_error`, with or without `PT_`, any case) | that type (sent as the type character of the drive's reading) |
//! | `min=R`, `max=R`, `default=R` | that raw bound (a decimal integer in the described type's raw units, e.g. PT_FIXPOINT16 1000 = 50.00; negative for signed types) |
//! | `unit=TEXT` | that unit string (VF1000: the description's unit field, at most 6 characters; MC: a 107-UNIT text the drive then has) |
//!
//! e.g. `sim://vf1000?describe=11:actual:binary8` (11-STAT described as a
//! read-only BINARY8 actual value) or
//! `sim://mc6000?describe=100:min=2:max=5;134:unit=rpm`.

use std::collections::BTreeMap;

use driveset_proto::lustbus::ParameterType;
use driveset_schema::schema::StorageKind;

/// What a drive's description of one parameter says instead of its
/// fixture (each `None`: as the fixture says).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DescribeAs {
    /// Storage kind.
    pub kind: Option<StorageKind>,
    /// Type.
    pub ty: Option<ParameterType>,
    /// Raw minimum.
    pub min: Option<i64>,
    /// Raw maximum.
    pub max: Option<i64>,
    /// Raw factory default.
    pub default: Option<i64>,
    /// Unit string.
    pub unit: Option<String>,
}

/// Parses a `describe=` value (module docs). The error says which item is
/// wrong and what the grammar takes.
pub fn parse(value: &str) -> Result<BTreeMap<u32, DescribeAs>, String> {
    let mut out = BTreeMap::new();
    for part in value.split(';').map(str::trim).filter(|p| !p.is_empty()) {
        let mut items = part.split(':');
        let n = items.next().unwrap_or_default().trim();
        let number: u32 = n.parse().ok().filter(|n| (1..=999).contains(n)).ok_or_else(|| {
            format!("`{part}`: `{n}` is not a parameter number 1..=999 (use N:ITEM[:ITEM...], e.g. 11:actual:binary8)")
        })?;
        let mut d = DescribeAs::default();
        let mut any = false;
        for item in items {
            any = true;
            let item = item.trim();
            let raw = |v: &str, what: &str| {
                v.trim().parse::<i64>().map_err(|_| {
                    format!("`{part}`: {what}=`{v}` is not a whole number (raw units of the type)")
                })
            };
            match item.split_once('=') {
                Some(("min", v)) => d.min = Some(raw(v, "min")?),
                Some(("max", v)) => d.max = Some(raw(v, "max")?),
                Some(("default", v)) => d.default = Some(raw(v, "default")?),
                Some(("unit", v)) => d.unit = Some(v.to_string()),
                Some((k, _)) => {
                    return Err(format!(
                        "`{part}`: unknown item `{k}=`; use min=, max=, default= or unit="
                    ));
                }
                None => match item.to_ascii_lowercase().as_str() {
                    "actual" => d.kind = Some(StorageKind::RamActual),
                    "control" => d.kind = Some(StorageKind::RamControl),
                    "eeprom" => d.kind = Some(StorageKind::Eeprom),
                    "fsel" => d.kind = Some(StorageKind::FselIsel),
                    t => {
                        let name = format!("PT_{}", t.trim_start_matches("pt_").to_uppercase());
                        d.ty = Some(ParameterType::ALL.into_iter().find(|ty| ty.name() == name).ok_or_else(
                            || {
                                format!(
                                    "`{part}`: `{item}` is neither a kind (actual, control, eeprom, fsel) nor a type ({})",
                                    ParameterType::ALL.map(|t| t.name().trim_start_matches("PT_").to_lowercase()).join(", ")
                                )
                            },
                        )?);
                    }
                },
            }
        }
        if !any {
            return Err(format!(
                "`{part}`: parameter {number} without an item (use N:ITEM[:ITEM...], e.g. 11:actual:binary8)"
            ));
        }
        if out.insert(number, d).is_some() {
            return Err(format!("parameter {number} is described twice"));
        }
    }
    if out.is_empty() {
        return Err("names no parameter (use N:ITEM[:ITEM...], e.g. 11:actual:binary8)".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_kinds_types_bounds_units() {
        let m =
            parse("11:actual:binary8; 100:min=-2:max=5:default=3:unit=1/min:PT_INTEGER16").unwrap();
        assert_eq!(
            m[&11],
            DescribeAs {
                kind: Some(StorageKind::RamActual),
                ty: Some(ParameterType::Binary8),
                ..DescribeAs::default()
            }
        );
        assert_eq!(
            m[&100],
            DescribeAs {
                kind: None,
                ty: Some(ParameterType::Integer16),
                min: Some(-2),
                max: Some(5),
                default: Some(3),
                unit: Some("1/min".into()),
            }
        );
    }

    #[test]
    fn bad_items_say_what() {
        assert_eq!(
            parse("11:running").unwrap_err(),
            "`11:running`: `running` is neither a kind (actual, control, eeprom, fsel) nor a type (binary8, fixpoint16, usign16, usign8, vf_error, password, integer16, int32q16, float_ieee, mc_error)"
        );
        assert_eq!(
            parse("x:actual").unwrap_err(),
            "`x:actual`: `x` is not a parameter number 1..=999 (use N:ITEM[:ITEM...], e.g. 11:actual:binary8)"
        );
        assert_eq!(
            parse("5:min=a").unwrap_err(),
            "`5:min=a`: min=`a` is not a whole number (raw units of the type)"
        );
        assert_eq!(
            parse("5:eeprom;5:actual").unwrap_err(),
            "parameter 5 is described twice"
        );
        assert_eq!(
            parse("5").unwrap_err(),
            "`5`: parameter 5 without an item (use N:ITEM[:ITEM...], e.g. 11:actual:binary8)"
        );
    }
}
