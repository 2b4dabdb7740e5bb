//! Owns a description's type and bounds (LUSTBUS sections 11.1, 11.2):
//! which values a type holds, sign extension, the raw integer an unknown
//! type character is kept as, and the downgrades where a description
//! contradicts itself (module docs of [`super`]).

use driveset_proto::lustbus::ParameterType;
use driveset_schema::ValueType;
use driveset_schema::schema::StorageKind;
use driveset_schema::value::raw_to_engineering;

use super::model::{LearnFinding, LearnedCode};

/// Whether `raw` (32 bits as sent) is a value of `ty`.
pub(super) fn fits(ty: ParameterType, raw: u32) -> bool {
    match ty {
        ParameterType::Usign8 | ParameterType::Binary8 => raw <= 0xFF,
        ParameterType::Integer16 => raw <= 0xFFFF || raw >= 0xFFFF_8000,
        ParameterType::Usign16
        | ParameterType::Fixpoint16
        | ParameterType::Password
        | ParameterType::VfError => raw <= 0xFFFF,
        ParameterType::Int32Q16 | ParameterType::FloatIeee | ParameterType::McError => true,
    }
}

/// The raw integer of a bound in `ty` (signed types sign-extended).
pub(super) fn signed(ty: ParameterType, raw: u32) -> i64 {
    match ty {
        ParameterType::Integer16 => i64::from(raw as u16 as i16),
        ParameterType::Int32Q16 => i64::from(raw as i32),
        _ => i64::from(raw),
    }
}

/// The raw integer type the bounds need (an unknown type character).
fn raw_type(bounds: [u32; 3], mc: bool) -> Option<ParameterType> {
    if bounds.iter().all(|&b| b <= 0xFF) {
        Some(ParameterType::Usign8)
    } else if bounds.iter().all(|&b| b <= 0xFFFF) {
        Some(ParameterType::Usign16)
    } else if mc && bounds.iter().all(|&b| fits(ParameterType::Integer16, b)) {
        Some(ParameterType::Integer16)
    } else {
        None
    }
}

pub(super) fn width_of(ty: ParameterType) -> u8 {
    match ty {
        ParameterType::Usign8 | ParameterType::Binary8 => 1,
        ParameterType::Int32Q16 | ParameterType::FloatIeee | ParameterType::McError => 4,
        _ => 2,
    }
}

pub(super) fn ordered(ty: ParameterType, min: u32, max: u32) -> bool {
    if ty == ParameterType::FloatIeee {
        let (a, b) = (f32::from_bits(min), f32::from_bits(max));
        return a <= b;
    }
    signed(ty, min) <= signed(ty, max)
}

/// Fills `c`'s type and bounds from a description, downgrading what
/// contradicts itself (module docs).
pub(super) fn set_bounds(
    c: &mut LearnedCode,
    ty: Option<ParameterType>,
    bounds: [u32; 3],
    mc: bool,
    findings: &mut Vec<LearnFinding>,
    type_char: u8,
) {
    let mut ty = ty;
    if ty.is_none() {
        ty = raw_type(bounds, mc);
        let what = match ty {
            Some(t) => format!(
                "kept as a raw integer {} (the width its min/max/default need)",
                t.name()
            ),
            None => "kept without a type (its min/max/default need 32 bits; LUSTBUS has no raw 32-bit type), so it is not read".to_string(),
        };
        let msg = format!(
            "type character {} is not one driveset knows; {what}",
            show_char(type_char)
        );
        c.downgrade(findings, msg);
    } else if let Some(t) = ty
        && !bounds.iter().all(|&b| fits(t, b))
    {
        let down = raw_type(bounds, mc);
        let msg = format!(
            "its min/max/default ({:#X}, {:#X}, {:#X}) do not fit its type {}; {}",
            bounds[0],
            bounds[1],
            bounds[2],
            t.name(),
            match down {
                Some(d) => format!("type downgraded to the raw integer {}", d.name()),
                None => "kept without a type, so it is not read".into(),
            }
        );
        c.downgrade(findings, msg);
        ty = down;
    }
    c.ty = ty;
    let Some(t) = ty else { return };
    if matches!(
        t,
        ParameterType::Password | ParameterType::VfError | ParameterType::McError
    ) {
        return;
    }
    if !ordered(t, bounds[0], bounds[1]) {
        let msg = format!(
            "its minimum {} is above its maximum {}; range and default left out",
            raw_to_engineering(value_type(t), signed(t, bounds[0])),
            raw_to_engineering(value_type(t), signed(t, bounds[1]))
        );
        c.downgrade(findings, msg);
        return;
    }
    if t == ParameterType::FloatIeee
        && [bounds[0], bounds[1], bounds[2]]
            .iter()
            .any(|b| !f32::from_bits(*b).is_finite())
    {
        return;
    }
    let (min, max, def) = (
        signed(t, bounds[0]),
        signed(t, bounds[1]),
        signed(t, bounds[2]),
    );
    if (min, max) != (0, 0) {
        c.min = Some(min);
        c.max = Some(max);
    }
    let inside = if t == ParameterType::FloatIeee {
        let d = f32::from_bits(bounds[2]);
        f32::from_bits(bounds[0]) <= d && d <= f32::from_bits(bounds[1])
    } else {
        (min..=max).contains(&def)
    };
    if c.kind == StorageKind::RamActual {
        return;
    }
    if inside || (min, max) == (0, 0) {
        c.default = Some(def);
    } else {
        let msg = format!(
            "its default {} is outside its range {}..{}; default left out",
            raw_to_engineering(value_type(t), def),
            raw_to_engineering(value_type(t), min),
            raw_to_engineering(value_type(t), max)
        );
        c.downgrade(findings, msg);
    }
}

pub(super) fn show_char(c: u8) -> String {
    if (0x21..=0x7E).contains(&c) {
        format!("'{}'", c as char)
    } else {
        format!("{c:#04x}")
    }
}

pub(super) fn value_type(t: ParameterType) -> ValueType {
    ValueType::from_name(t.name()).unwrap_or(ValueType::PT_USIGN16)
}
