//! The one identify loop of the protocol clients
//! ([`super::DriveClient::identify`]): which codes are read (the schema's
//! `[schema.identify] codes`, else the family descriptor's
//! [`IdentifyRules::without_schema`]), whether a code the drive lacks is
//! left out ([`IdentifyRules::skips_missing`]), which one is the software
//! version ([`IdentifyRules::software`]), and how a value shows. Each
//! client only reads one code its own way.
//!
//! [`IdentifyRules::without_schema`]: driveset_schema::family::IdentifyRules::without_schema
//! [`IdentifyRules::skips_missing`]: driveset_schema::family::IdentifyRules::skips_missing
//! [`IdentifyRules::software`]: driveset_schema::family::IdentifyRules::software

use driveset_schema::{CodeKey, RawValue, Schema};

use super::{IdentCode, IdentProtocol, IdentValue, Identity, code_name};
use crate::error::{DeviceFailure, EngineError, ErrorKind};

/// The codes identification reads from a drive of `schema`'s family, in
/// order: the schema's own, else the descriptor's
/// [`driveset_schema::family::IdentifyRules::without_schema`].
pub(crate) fn identify_codes(schema: &Schema) -> Vec<u32> {
    schema
        .identify
        .as_ref()
        .map(|i| i.codes.clone())
        .filter(|c| !c.is_empty())
        .unwrap_or_else(|| {
            schema
                .family
                .descriptor()
                .identify_rules
                .without_schema
                .to_vec()
        })
}

/// Identifies the drive of `schema`: reads each of [`identify_codes`]
/// with `read` (`what`: `identify: read C0093`), shows its value with
/// `show`, and follows the family's identify rules (module docs).
pub(crate) fn identify(
    schema: &Schema,
    mut read: impl FnMut(CodeKey, &str) -> Result<RawValue, EngineError>,
    show: fn(&Schema, CodeKey, RawValue) -> IdentValue,
) -> Result<Identity, EngineError> {
    let rules = schema.family.descriptor().identify_rules;
    let mut out = Identity::of(IdentProtocol::Family(schema.family));
    for n in identify_codes(schema) {
        let key = CodeKey::new(n);
        let name = code_name(schema, key);
        let raw = match read(key, &format!("identify: read {name}")) {
            Ok(r) => r,
            // A code this drive lacks does not stop identification where
            // the family's drives differ in the codes they hold.
            Err(e)
                if rules.skips_missing
                    && matches!(*e.kind, ErrorKind::Device(DeviceFailure::Refused { .. })) =>
            {
                continue;
            }
            Err(e) => return Err(e),
        };
        let value = show(schema, key, raw);
        if rules.software == Some(n) {
            out.software = Some(value.to_string());
        }
        out.codes.push(IdentCode::new(key, name, value));
    }
    Ok(out)
}

/// How an identification value shows, whatever the protocol: an integer
/// as the integer, text as the text, octets in hex (`01A2`).
pub(crate) fn shown(_schema: &Schema, _key: CodeKey, raw: RawValue) -> IdentValue {
    match raw {
        RawValue::Int(v) => IdentValue::Int(v),
        RawValue::Text(t) => IdentValue::Text(t),
        RawValue::Octets(o) => IdentValue::Text(o.iter().map(|b| format!("{b:02X}")).collect()),
    }
}
