//! Live diff: a set against what a drive holds for the set's codes.

// EngineError (the crate's contract type) is large; it is built on the
// failure path only, so its size is no concern.
#![allow(clippy::result_large_err)]

use driveset_schema::{Diff, ResolvedSet, diff};

use crate::client::DriveClient;
use crate::error::EngineError;

/// The drive's values of the codes `set` names (a set of the client's schema).
pub fn live_values(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
) -> Result<ResolvedSet, EngineError> {
    let schema = client.schema().clone();
    let target = client.target().clone();
    if set.schema != schema.id {
        return Err(EngineError::Refused {
            target,
            reason: format!(
                "the set is for schema `{}`, the drive is read with schema `{}`; compare a set of this drive family",
                set.schema, schema.id
            ),
        });
    }
    let unknown: Vec<String> = set
        .values
        .keys()
        .filter(|k| schema.code(k.number).is_none())
        .map(|k| schema.display_code(k.number, k.subcode))
        .collect();
    if !unknown.is_empty() {
        return Err(EngineError::Refused {
            target,
            reason: format!(
                "codes not in schema `{}`: {}; remove them from the set",
                schema.id,
                unknown.join(", ")
            ),
        });
    }
    crate::upload::read_values(client, set.values.keys().copied())
}

/// What differs between the drive and `set`: old = the drive, new = the set
/// (so the entries read as what an upload would change). Passwords are
/// redacted in the entries' text.
pub fn live_diff(client: &mut dyn DriveClient, set: &ResolvedSet) -> Result<Diff, EngineError> {
    let drive = live_values(client, set)?;
    let schema = client.schema().clone();
    diff(&drive, set, &schema).map_err(|e| EngineError::Refused {
        target: client.target().clone(),
        reason: e.to_string(),
    })
}
