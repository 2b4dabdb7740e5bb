//! How a schema code travels on LUSTBUS (`lustbus-protocol.txt` sections
//! 2.3, 2.4, 5.2): the family's wire dialect, the CODE of a parameter
//! (`000pp` for the numerically compatible ones, VF1000 `0dspp`, MC
//! `20ppp`), the PT_* type a code's value is encoded with and the raw
//! integer of a typed value.

use driveset_proto::lustbus::{
    CompatibleParameter, Dialect, ParameterCode, ParameterType, ParameterValue,
};
use driveset_schema::{Code, CodeKey, Family, Schema, ValueType};

use super::{LustbusClient, LustbusOptions};
use super::{LustbusCodeProblem, LustbusRefusal};
use crate::client::code_name;
use crate::error::EngineError;

/// Wire family of a LUSTBUS schema.
pub(super) fn family_of(schema: &Schema) -> Option<Dialect> {
    dialect_of(schema.family)
}

/// The LUSTBUS dialect a family speaks (sections 2.3, 2.4): `None` for
/// the families on other buses. The family descriptor's
/// [`driveset_schema::family::Descriptor::dialect`].
pub fn dialect_of(family: Family) -> Option<Dialect> {
    family.descriptor().dialect
}

/// The codec type of a code (see the module docs for untyped codes):
/// proto's [`ParameterType::of_code`], where the family has the type.
pub(super) fn wire_type(schema: &Schema, code: &Code, family: Dialect) -> Option<ParameterType> {
    ParameterType::of_code(schema.type_of(code).map(ValueType::name), code.width)
        .filter(|t| t.in_family(family))
}

/// The raw integer of a typed value (signed types sign-extended).
pub(super) fn raw_of(v: &ParameterValue) -> i64 {
    match *v {
        ParameterValue::Integer16(i) => i64::from(i),
        ParameterValue::Int32Q16(q) => i64::from(q.0),
        other => i64::from(other.raw()),
    }
}

/// The typed value of a raw integer, if the type can carry it.
pub(super) fn value_of(ty: ParameterType, raw: i64) -> Option<ParameterValue> {
    let wire = match ty {
        ParameterType::Integer16 => i16::try_from(raw).ok()? as u16 as u32,
        ParameterType::Int32Q16 => i32::try_from(raw).ok()? as u32,
        _ => u32::try_from(raw).ok()?,
    };
    ParameterValue::from_raw(ty, wire)
}

/// Plain hex of an untyped reply.
pub(super) fn parse_hex(text: &[u8]) -> Option<i64> {
    if text.is_empty() || text.len() > 8 {
        return None;
    }
    let s = std::str::from_utf8(text).ok()?;
    u32::from_str_radix(s, 16).ok().map(i64::from)
}

/// The CODE a code of `schema` goes out with (for a dry run's listing):
/// the numerically compatible parameters `000xx` (§5.2), else the family's
/// form.
pub(crate) fn wire_code_text(schema: &Schema, key: CodeKey) -> String {
    let compatible = schema.code(key.number).and_then(|c| c.compatible) == Some(true)
        || CompatibleParameter::contains(key.number);
    let code = if compatible && key.number < 100 {
        ParameterCode::new(key.number)
    } else if dialect_of(schema.family) == Some(Dialect::Mc) {
        u16::try_from(key.number)
            .ok()
            .and_then(ParameterCode::mc_value)
    } else {
        u8::try_from(key.number)
            .ok()
            .and_then(|p| ParameterCode::vf_value(LustbusOptions::default().vf_device, p))
    };
    code.map_or_else(|| key.number.to_string(), |c| c.to_string())
}

impl<L: driveset_link::ByteLink> LustbusClient<L> {
    /// CODE of a parameter number.
    pub(super) fn code_for(
        &self,
        key: CodeKey,
        code: Option<&Code>,
    ) -> Result<ParameterCode, EngineError> {
        let refuse = |problem: LustbusCodeProblem| {
            EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::Code {
                    code: code_name(&self.drive.schema, key),
                    problem,
                },
            )
        };
        if key.subcode.is_some() {
            return Err(refuse(LustbusCodeProblem::HasSubcode));
        }
        let compatible = code.and_then(|c| c.compatible) == Some(true)
            || CompatibleParameter::contains(key.number);
        if compatible && key.number < 100 {
            return ParameterCode::new(key.number)
                .ok_or_else(|| refuse(LustbusCodeProblem::NotAddressable));
        }
        match self.family {
            Dialect::Vf1000 => u8::try_from(key.number)
                .ok()
                .and_then(|p| ParameterCode::vf_value(self.opts.vf_device, p))
                .ok_or_else(|| refuse(LustbusCodeProblem::AboveVf1000Range)),
            Dialect::Mc => u16::try_from(key.number)
                .ok()
                .and_then(ParameterCode::mc_value)
                .ok_or_else(|| refuse(LustbusCodeProblem::AboveMcRange)),
        }
    }

    /// Hex digits of a value reply of `code`: VF1000 4, MC 2 per byte of
    /// width (8 if unknown; `max`: the longest the codec allows, 8).
    pub(super) fn value_len(&self, code: Option<&Code>, max: bool) -> usize {
        match self.family {
            Dialect::Vf1000 => 4,
            Dialect::Mc if max => 8,
            Dialect::Mc => code
                .and_then(|c| c.width)
                .map_or(8, |w| usize::from(w).clamp(1, 4) * 2),
        }
    }
}
