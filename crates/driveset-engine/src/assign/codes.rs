//! Owns the bus codes of `driveset address`: which code holds a family's
//! bus address and line rate (its descriptor's role floor and line rates:
//! LUSTBUS 82-SADDR and 81-SBAUD, `lustbus-protocol.txt` §5.2; Tmd C0009
//! and C0125, `lecom-ab-tmd-manual.txt` §4c, §4d, Table 1), and the raw
//! values that mean an address or a rate in a schema's type of them.

use driveset_schema::value::{decimal_to_raw, raw_to_decimal};
use driveset_schema::{CodeKey, Decimal, Family, RawValue, Role, Schema};

use super::AssignRefusal;
use super::refusal::refuse;
use crate::error::EngineError;

/// The family's bus-address code (its floor role `bus-address`).
pub fn address_code(family: Family) -> Option<CodeKey> {
    family
        .descriptor()
        .floor
        .iter()
        .find(|f| f.role == Role::BusAddress)
        .map(|f| CodeKey::new(f.code))
}

/// The family's rate code.
pub fn rate_code(family: Family) -> Option<CodeKey> {
    family.descriptor().line_rates.code.map(CodeKey::new)
}

/// The family's address and rate codes (its descriptor's role floor and
/// line rates): refused, not guessed, for a family that has none.
pub(super) fn bus_codes(
    family: Family,
    schema: &Schema,
    port: &str,
) -> Result<(CodeKey, CodeKey), EngineError> {
    let lacks = |what: &str| {
        refuse(
            port,
            0,
            AssignRefusal::SchemaLacks {
                schema: schema.id.clone(),
                code: format!("the {what} code of {}", family.descriptor().title),
            },
        )
    };
    let address = address_code(family).ok_or_else(|| lacks("bus-address"))?;
    let rate = rate_code(family).ok_or_else(|| lacks("line-rate"))?;
    Ok((address, rate))
}

/// The raw value of the address code meaning address `a` (a scaled
/// type's raw, e.g. Tmd C0009 VD: a x 10000).
pub fn address_raw(schema: &Schema, key: CodeKey, a: u8) -> Option<RawValue> {
    let code = schema.code(key.number)?;
    let ty = schema.type_of(code)?;
    decimal_to_raw(ty, code.width, &Decimal::from_int(i128::from(a)))
        .ok()
        .map(RawValue::Int)
}

/// The address a raw value of the address code means (`None`: not a
/// whole number, or the code has no scaled type).
pub fn address_of_raw(schema: &Schema, key: CodeKey, raw: &RawValue) -> Option<i64> {
    let code = schema.code(key.number)?;
    let RawValue::Int(r) = raw else {
        return None;
    };
    match schema.type_of(code) {
        Some(ty) => {
            let d = raw_to_decimal(ty, *r)?;
            let text = d.to_string();
            text.parse::<i64>().ok()
        }
        None => Some(*r),
    }
}

/// The raw value of the rate code meaning `baud`: an enumerated code
/// (Tmd C0125: `1 = "4800 bps ..."`) by the label that starts with the
/// figure, else the figure itself (LUSTBUS 81, unit Baud).
pub fn rate_raw(schema: &Schema, key: CodeKey, baud: u32) -> Option<RawValue> {
    let code = schema.code(key.number)?;
    if let Some(src) = &code.values {
        let e = schema.enum_of(src)?;
        let label = e
            .entries
            .iter()
            .find(|(_, label, _)| label_rate(label) == Some(baud))
            .map(|(_, l, _)| l.clone())?;
        return schema.enum_value(code, &label).map(RawValue::Int);
    }
    Some(RawValue::Int(i64::from(baud)))
}

/// The rate a raw value of the rate code means ([`rate_raw`] backwards).
pub fn rate_of_raw(schema: &Schema, key: CodeKey, raw: &RawValue) -> Option<u32> {
    let code = schema.code(key.number)?;
    let RawValue::Int(v) = raw else {
        return None;
    };
    if code.values.is_some() {
        return label_rate(schema.enum_label(code, *v)?);
    }
    u32::try_from(*v).ok()
}

pub(super) fn label_rate(label: &str) -> Option<u32> {
    label
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .and_then(|d| d.parse().ok())
}

pub(super) fn shown(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => driveset_schema::validate::display_value(schema, c, raw),
        None => format!("{raw:?}"),
    }
}
