//! The refusals the LUSTBUS client raises itself (`lustbus-protocol.txt`),
//! beside it: a code or value a telegram cannot carry (CODE fields,
//! sections 2.4.1 and 2.4.2; the PT_* types), a broadcast it will not send
//! (section 4.2), and the MC dataset download out of order or on a drive
//! without one (80-SLOAD, section 11.4; 108-STEXT, section 11.3). Found
//! before anything is sent; gathered into [`Refusal`](crate::error::Refusal) (`Refusal::Lustbus`)
//! by `From`, each with the JSON kind journals hold (`broadcast`,
//! `lustbus_code`, `no_wire_type` ...).

use std::fmt;

use serde::{Deserialize, Serialize};

/// What the LUSTBUS client cannot send, or will not send now.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LustbusRefusal {
    /// A LUSTBUS broadcast (address 31, section 4.2) the client will not send.
    #[error("broadcast (address 31) of {code}: {why}")]
    Broadcast {
        /// The code.
        code: String,
        /// Why not.
        why: String,
    },
    /// A code LUSTBUS cannot address (sections 2.4.1 and 2.4.2).
    #[error("{code} {problem}")]
    #[serde(rename = "lustbus_code")]
    Code {
        /// The code.
        code: String,
        /// Why.
        problem: LustbusCodeProblem,
    },
    /// The schema gives no LUSTBUS type or width for a written code.
    #[error(
        "{code}: schema `{schema}` gives no {family} type or width, so the value cannot be encoded; add `type` to the schema"
    )]
    NoWireType {
        /// The code.
        code: String,
        /// Schema id.
        schema: String,
        /// The family.
        family: String,
    },
    /// A LUSTBUS value that is not an integer.
    #[error("{code}: LUSTBUS parameters hold integers, not {value}")]
    NotInteger {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
    },
    /// A value that does not fit the code's LUSTBUS type.
    #[error("{code}: {value} does not fit {ty}")]
    DoesNotFit {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
        /// The type's name.
        ty: String,
    },
    /// A code that is not CardWriteable, written during a dataset download
    /// (section 11.4).
    #[error(
        "{code} is not CardWriteable: during a dataset download the drive ACKs it but does not take the value (section 11.4); write it after dataset_commit"
    )]
    NotCardWriteable {
        /// The code.
        code: String,
    },
    /// The VF1000 has no SLOAD handshake (section 11.4).
    #[error(
        "the VF1000 has no dataset download handshake (SLOAD is MC6000/7000 only, section 11.4)"
    )]
    Vf1000NoDataset,
    /// A dataset write or commit without an open download.
    #[error("no dataset download is open; call dataset_begin first")]
    NoDatasetOpen,
    /// 108-STEXT on a drive other than an MC6000/7000 (section 11.3).
    #[error("108-STEXT substitution texts are MC6000/7000 only (section 11.3)")]
    StextMcOnly,
    /// The schema lacks 80-SLOAD.
    #[error("schema `{schema}` has no 80-SLOAD; the dataset download needs it")]
    NoSload {
        /// Schema id.
        schema: String,
    },
}

/// Why a LUSTBUS code has no CODE field ([`LustbusRefusal::Code`],
/// sections 2.4.1 and 2.4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LustbusCodeProblem {
    /// A subcode: LUSTBUS parameters have none.
    HasSubcode,
    /// A compatible parameter number the codec cannot address.
    NotAddressable,
    /// Above 99 on a VF1000.
    AboveVf1000Range,
    /// Above 999 on an MC6000/7000.
    AboveMcRange,
}

impl fmt::Display for LustbusCodeProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LustbusCodeProblem::HasSubcode => {
                "has a subcode; LUSTBUS parameters have none (check the schema)"
            }
            LustbusCodeProblem::NotAddressable => "cannot be addressed",
            LustbusCodeProblem::AboveVf1000Range => "is above 99, the VF1000 range (section 2.4.1)",
            LustbusCodeProblem::AboveMcRange => {
                "is above 999, the MC6000/7000 range (section 2.4.2)"
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::assert_refusal_json;

    fn s(x: &str) -> String {
        x.to_string()
    }

    /// Each refusal is a `Refusal` whose JSON is the flat kind journals
    /// have always held, and reads back to the same refusal.
    #[test]
    fn lustbus_refusals_keep_their_json_kinds_and_read_back() {
        let cases = [
            (
                LustbusRefusal::Broadcast {
                    code: s("80-SLOAD"),
                    why: s("a command"),
                },
                r#"{"kind":"broadcast","code":"80-SLOAD","why":"a command"}"#,
            ),
            (
                LustbusRefusal::Code {
                    code: s("1000"),
                    problem: LustbusCodeProblem::AboveMcRange,
                },
                r#"{"kind":"lustbus_code","code":"1000","problem":"above_mc_range"}"#,
            ),
            (
                LustbusRefusal::NoWireType {
                    code: s("7-X"),
                    schema: s("s"),
                    family: s("MC"),
                },
                r#"{"kind":"no_wire_type","code":"7-X","schema":"s","family":"MC"}"#,
            ),
            (
                LustbusRefusal::NotInteger {
                    code: s("7-X"),
                    value: s("1.5"),
                },
                r#"{"kind":"not_integer","code":"7-X","value":"1.5"}"#,
            ),
            (
                LustbusRefusal::DoesNotFit {
                    code: s("7-X"),
                    value: s("300"),
                    ty: s("PT_USIGN8"),
                },
                r#"{"kind":"does_not_fit","code":"7-X","value":"300","ty":"PT_USIGN8"}"#,
            ),
            (
                LustbusRefusal::NotCardWriteable { code: s("7-X") },
                r#"{"kind":"not_card_writeable","code":"7-X"}"#,
            ),
            (
                LustbusRefusal::Vf1000NoDataset,
                r#"{"kind":"vf1000_no_dataset"}"#,
            ),
            (
                LustbusRefusal::NoDatasetOpen,
                r#"{"kind":"no_dataset_open"}"#,
            ),
            (LustbusRefusal::StextMcOnly, r#"{"kind":"stext_mc_only"}"#),
            (
                LustbusRefusal::NoSload { schema: s("s") },
                r#"{"kind":"no_sload","schema":"s"}"#,
            ),
        ];
        for (refusal, json) in cases {
            assert_refusal_json(&refusal, json);
        }
    }
}
