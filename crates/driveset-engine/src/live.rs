//! Live diff: a set against what a drive holds for the set's codes, and
//! the refusals it raises ([`LiveRefusal`]).

use driveset_schema::{Diff, ResolvedSet, diff};
use serde::{Deserialize, Serialize};

use crate::client::DriveClient;
use crate::error::EngineError;

/// Why a live diff was refused before anything was read (gathered into
/// [`crate::error::Refusal`] as `Refusal::Live`, each with the JSON kind
/// journals hold: `set_schema`, `codes_not_in_schema`, `diff`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LiveRefusal {
    /// A set of another schema than the client's.
    #[error(
        "the set is for schema `{set}`, the drive is read with schema `{schema}`; compare a set of this drive family"
    )]
    SetSchema {
        /// The set's schema.
        set: String,
        /// The client's schema.
        schema: String,
    },
    /// Codes the schema does not know.
    #[error("codes not in schema `{schema}`: {}; remove them from the set", .codes.join(", "))]
    CodesNotInSchema {
        /// Schema id.
        schema: String,
        /// The codes.
        codes: Vec<String>,
    },
    /// The diff itself refused (schemas differ).
    #[error("{detail}")]
    Diff {
        /// What the diff said.
        detail: String,
    },
}

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
            LiveRefusal::SetSchema {
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
            LiveRefusal::CodesNotInSchema {
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
            LiveRefusal::Diff {
                detail: e.to_string(),
            },
        )
    })
}

#[cfg(test)]
mod tests {
    use super::LiveRefusal;
    use crate::error::assert_refusal_json;

    /// Each refusal is a `Refusal` whose JSON is the flat kind journals
    /// have always held, and reads back to the same refusal.
    #[test]
    fn live_refusals_keep_their_json_kinds_and_read_back() {
        let cases = [
            (
                LiveRefusal::SetSchema {
                    set: "lust-vf1000".to_string(),
                    schema: "lust-mc6000".to_string(),
                },
                r#"{"kind":"set_schema","set":"lust-vf1000","schema":"lust-mc6000"}"#,
            ),
            (
                LiveRefusal::CodesNotInSchema {
                    schema: "lust-mc6000".to_string(),
                    codes: vec!["1000".to_string(), "1001".to_string()],
                },
                r#"{"kind":"codes_not_in_schema","schema":"lust-mc6000","codes":["1000","1001"]}"#,
            ),
            (
                LiveRefusal::Diff {
                    detail: "schemas differ".to_string(),
                },
                r#"{"kind":"diff","detail":"schemas differ"}"#,
            ),
        ];
        for (refusal, json) in cases {
            assert_refusal_json(&refusal, json);
        }
    }
}
