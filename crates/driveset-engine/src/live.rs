//! Live diff: a set against what a drive holds for the set's codes.

use driveset_schema::{Diff, ResolvedSet, diff};

use crate::client::DriveClient;
use crate::error::{EngineError, Refusal};

/// The drive's values of the codes `set` names (a set of the client's schema).
pub fn live_values(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
) -> Result<ResolvedSet, EngineError> {
    let schema = client.schema().clone();
    let target = client.target().clone();
    if set.schema != schema.id {
        return Err(EngineError::refused(
            target,
            Refusal::SetSchema {
                set: set.schema.clone(),
                schema: schema.id.clone(),
            },
        ));
    }
    let unknown: Vec<String> = set
        .values
        .keys()
        .filter(|k| schema.code(k.number).is_none())
        .map(|k| schema.display_code(k.number, k.subcode))
        .collect();
    if !unknown.is_empty() {
        return Err(EngineError::refused(
            target,
            Refusal::CodesNotInSchema {
                schema: schema.id.clone(),
                codes: unknown,
            },
        ));
    }
    crate::upload::read_values(client, set.values.keys().copied())
}

/// What differs between the drive and `set`: old = the drive, new = the set
/// (so the entries read as what an upload would change). Passwords are
/// redacted in the entries' text.
pub fn live_diff(client: &mut dyn DriveClient, set: &ResolvedSet) -> Result<Diff, EngineError> {
    let drive = live_values(client, set)?;
    let schema = client.schema().clone();
    diff(&drive, set, &schema).map_err(|e| {
        EngineError::refused(
            client.target().clone(),
            Refusal::Diff {
                detail: e.to_string(),
            },
        )
    })
}
