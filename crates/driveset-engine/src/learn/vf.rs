//! Owns reading VF1000 descriptions (specifier 1, LUSTBUS section 11.1):
//! name, unit, kind (with the basis flag), type and bounds.

use driveset_proto::lustbus::ParameterType;
use driveset_proto::lustbus::description::{DescriptionError, VfDescription, VfStorage};
use driveset_schema::schema::StorageKind;

use super::bounds::set_bounds;
use super::interpret::Reading;
use super::model::{LearnFinding, RawDescription, new_code};

/// Reads VF1000 descriptions (pure). A description whose type character
/// is unknown is read with a placeholder type and kept as a raw integer
/// ([`set_bounds`]).
pub(super) fn interpret(raws: &[RawDescription]) -> Reading {
    let mut findings = Vec::new();
    let mut codes = Vec::new();
    for r in raws {
        let (d, unknown_type) = match VfDescription::decode(&r.text) {
            Ok(d) => (Ok(d), None),
            Err(DescriptionError::Type { offset, found, .. }) => {
                // Read the rest with a placeholder type; the character
                // is unknown (not '1'..'6').
                let mut t = r.text.clone();
                t[offset] = b'3';
                (VfDescription::decode(&t), Some(found))
            }
            Err(e) => (Err(e), None),
        };
        let d = match d {
            Ok(d) => d,
            Err(e) => {
                findings.push(LearnFinding {
                    code: String::new(),
                    number: r.number,
                    action: "left out",
                    reason: format!("its description does not decode: {e}"),
                });
                continue;
            }
        };
        let kind = match d.kind.storage {
            VfStorage::RamActual => StorageKind::RamActual,
            VfStorage::RamControl => StorageKind::RamControl,
            VfStorage::Eeprom => StorageKind::Eeprom,
            VfStorage::FselIsel => StorageKind::FselIsel,
        };
        let mut c = new_code(r.number, d.name.as_str().trim(), kind);
        c.kind_char = d.kind.code();
        let unit = d.unit.as_str().trim().to_string();
        c.unit = (!unit.is_empty()).then_some(unit);
        c.basis = Some(!d.kind.inverter_specific);
        let ty = if unknown_type.is_some() {
            None
        } else {
            Some(d.ty)
        };
        set_bounds(
            &mut c,
            ty,
            [u32::from(d.min), u32::from(d.max), u32::from(d.default)],
            false,
            &mut findings,
            unknown_type.unwrap_or(d.ty.code()),
        );
        if c.ty == Some(ParameterType::Password) {
            c.password = true;
        }
        codes.push(c);
    }
    Reading {
        codes,
        findings,
        ..Reading::default()
    }
}
