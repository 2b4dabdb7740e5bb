//! Owns the transaction's own refusals ([`UploadRefusal`]): a step called
//! out of order, and broadcast values a drive's dataset does not stage.

use serde::{Deserialize, Serialize};

/// Why the transaction refused a step before anything was sent (gathered
/// into [`crate::error::Refusal`] as `Refusal::Upload`, each with the JSON
/// kind journals hold: `broadcast_not_staged`, `step_out_of_order`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum UploadRefusal {
    /// Broadcast values a drive's dataset does not stage (LUSTBUS §4.2,
    /// §11.4: a broadcast lands inside each drive's dataset download).
    #[error(
        "broadcast of {} refused: not a value this drive's dataset stages",
        .codes.join(", ")
    )]
    BroadcastNotStaged {
        /// The codes.
        codes: Vec<String>,
    },
    /// A transaction step called out of order (a caller's mistake).
    #[error("transaction step `{step}` called before `{before}`")]
    StepOutOfOrder {
        /// The step called.
        step: String,
        /// The step that must come first.
        before: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::assert_refusal_json;

    /// Each refusal is a `Refusal` whose JSON is the flat kind journals
    /// have always held, and reads back to the same refusal.
    #[test]
    fn upload_refusals_keep_their_json_kinds_and_read_back() {
        let cases = [
            (
                UploadRefusal::BroadcastNotStaged {
                    codes: vec!["416-A".to_string(), "417-B".to_string()],
                },
                r#"{"kind":"broadcast_not_staged","codes":["416-A","417-B"]}"#,
            ),
            (
                UploadRefusal::StepOutOfOrder {
                    step: "commit".to_string(),
                    before: "open_dataset".to_string(),
                },
                r#"{"kind":"step_out_of_order","step":"commit","before":"open_dataset"}"#,
            ),
        ];
        for (refusal, json) in cases {
            assert_refusal_json(&refusal, json);
        }
    }
}
