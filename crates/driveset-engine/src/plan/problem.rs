//! The refusals of an upload ([`Problem`], each with its message and what
//! to do) and the checks that need no bus ([`check_set`]): see the parent
//! module's "Refusals".

use driveset_schema::schema::{Access, StorageKind};
use driveset_schema::{ResolvedSet, Schema};

use super::{PlanOptions, Running, code_label, protocol_name};
use crate::client::IdentValue;
use crate::overrides::Override;

/// The dataset handshake code of `schema`'s family (MC6000/7000 80-SLOAD).
fn dataset_code(schema: &Schema) -> Option<u32> {
    schema.family.descriptor().dataset.map(|d| d.code)
}

/// Why the running state of a drive of `schema` cannot be known.
pub(crate) fn running_unknown_why(schema: &Schema) -> String {
    running_unknown_text(&schema.id)
}

fn running_unknown_text(schema: &str) -> String {
    format!(
        "schema `{schema}` names no status bit (role `running`) or control word start bit that says whether the motor runs"
    )
}

/// One reason the planner (or the set check) refuses an upload: a
/// [`crate::error::Refusal::Plan`] holds every one found. Codes are named
/// as [`super::code_label`] spells them, values as [`super::value_text`] shows them.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Problem {
    /// The set is for another schema (unless [`Override::AllowFamily`]).
    SetSchema {
        /// The set's schema.
        set: String,
        /// The client's schema.
        schema: String,
    },
    /// The drive identifies as another protocol family.
    ProtocolFamily {
        /// What the drive said.
        found: String,
        /// Schema id.
        schema: String,
        /// The schema's protocol family.
        want: String,
    },
    /// The drive's 91-TYPE is not one of the schema's.
    DriveType {
        /// The TYPE read.
        found: i64,
        /// Schema id.
        schema: String,
        /// The schema's TYPE values.
        expected: Vec<i64>,
    },
    /// A code the schema does not know.
    NotInSchema {
        /// The code.
        code: String,
        /// Schema id.
        schema: String,
    },
    /// A subcode out of the code's range.
    SubcodeRange {
        /// The code with its subcode.
        code: String,
        /// Its number.
        number: u32,
        /// How many subcodes it has.
        subcodes: u32,
    },
    /// A subcode of a code that has none.
    NoSubcodes {
        /// The code with its subcode.
        code: String,
        /// Its number.
        number: u32,
        /// Schema id.
        schema: String,
    },
    /// A read-only code (an actual value).
    ReadOnly {
        /// The code.
        code: String,
    },
    /// A status code that reading clears.
    ReadClears {
        /// The code.
        code: String,
    },
    /// The dataset handshake code (SLOAD).
    DatasetCode {
        /// The code.
        code: String,
    },
    /// A role's rule (a command, a control word that starts the motor ...):
    /// no override.
    Role {
        /// What the rule found.
        message: String,
        /// What to do.
        help: String,
    },
    /// The drive reports a running motor (unless [`Override::AllowRunning`]).
    Running,
    /// The running state cannot be known (unless
    /// [`Override::AllowRunningUnknown`]).
    RunningUnknown {
        /// Schema id.
        schema: String,
    },
    /// The drive's current value of a code was not read.
    NotRead {
        /// The code.
        code: String,
    },
    /// A write that changes the bus address of the drive being talked to
    /// (unless [`Override::AllowAddressChange`]).
    AddressChange {
        /// The code.
        code: String,
        /// The value it holds.
        old: String,
        /// The value the set gives.
        new: String,
    },
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Problem::SetSchema { set, schema } => write!(
                f,
                "the set is for schema `{set}` but the drive is handled with schema `{schema}`; upload a set for this drive family, or pass {} if they are compatible",
                Override::AllowFamily
            ),
            Problem::ProtocolFamily {
                found,
                schema,
                want,
            } => write!(
                f,
                "the drive identifies as protocol family `{found}`, schema `{schema}` is for `{want}`; check the address, or pass {}",
                Override::AllowFamily
            ),
            Problem::DriveType {
                found,
                schema,
                expected,
            } => write!(
                f,
                "the drive reports 91-TYPE {found}, schema `{schema}` is for TYPE {expected:?}; check the address, or pass {}",
                Override::AllowFamily
            ),
            Problem::NotInSchema { code, schema } => write!(
                f,
                "code {code} is not in schema `{schema}`; remove it from the set (or fix the number)"
            ),
            Problem::SubcodeRange {
                code,
                number,
                subcodes,
            } => write!(
                f,
                "{code}: code {number} has subcodes 1..={subcodes} only; fix the subcode"
            ),
            Problem::NoSubcodes {
                code,
                number,
                schema,
            } => write!(
                f,
                "{code}: code {number} has no subcodes in schema `{schema}`; drop the /subcode"
            ),
            Problem::ReadOnly { code } => {
                write!(
                    f,
                    "{code}: read-only (an actual value); remove it from the set"
                )
            }
            Problem::ReadClears { code } => write!(
                f,
                "{code}: a status code that reading clears; it cannot be part of a set, remove it"
            ),
            Problem::DatasetCode { code } => write!(
                f,
                "{code}: the dataset handshake code is driven by the upload itself; remove it from the set"
            ),
            Problem::Role { message, help } => write!(f, "{message}; {help}"),
            Problem::Running => write!(
                f,
                "the drive reports a running motor; stop it (standstill) before uploading, or pass {}",
                Override::AllowRunning
            ),
            Problem::RunningUnknown { schema } => write!(
                f,
                "running state unknown: {}; make sure the drive is at standstill, then pass {}",
                running_unknown_text(schema),
                Override::AllowRunningUnknown
            ),
            Problem::NotRead { code } => write!(
                f,
                "{code}: the drive's current value was not read; it cannot be backed up"
            ),
            Problem::AddressChange { code, old, new } => write!(
                f,
                "{code}: {old} -> {new} changes the bus address of the drive being talked to; it would stop answering mid-transaction. Upload the set to the drive at its new address after changing the address on its own (or pass {})",
                Override::AllowAddressChange
            ),
        }
    }
}

/// Checks that need no bus: every code known, writable, not a handshake or
/// status code, no command, no control word in a start / enable state; the
/// set is for this schema (unless [`Override::AllowFamily`]); and, once the
/// drive was asked ([`PlanOptions::running`]), not running (unless
/// [`Override::AllowRunning`]) and not of unknown running state (unless
/// [`Override::AllowRunningUnknown`]).
/// Returns every problem found (one line each), not just the first.
pub fn check_set(schema: &Schema, set: &ResolvedSet, opts: &PlanOptions) -> Vec<Problem> {
    let mut out = Vec::new();
    let family = !opts.overrides.allows(Override::AllowFamily);
    if set.schema != schema.id && family {
        out.push(Problem::SetSchema {
            set: set.schema.clone(),
            schema: schema.id.clone(),
        });
    }
    if let Some(id) = &opts.identity {
        let want = protocol_name(schema.family);
        let found = id.protocol.name();
        if !found.is_empty() && found != want && family {
            out.push(Problem::ProtocolFamily {
                found: found.to_string(),
                schema: schema.id.clone(),
                want: want.to_string(),
            });
        }
        if let Some(ident) = &schema.identify
            && !ident.type_values.is_empty()
            && family
            && let Some(ty) = id
                .value_of(schema.family.descriptor().device_type_code())
                .and_then(IdentValue::as_int)
            && !ident.type_values.contains(&ty)
        {
            out.push(Problem::DriveType {
                found: ty,
                schema: schema.id.clone(),
                expected: ident.type_values.clone(),
            });
        }
    }
    for key in set.values.keys() {
        let shown = schema.display_code(key.number, key.subcode);
        let Some(code) = schema.code(key.number) else {
            out.push(Problem::NotInSchema {
                code: shown,
                schema: schema.id.clone(),
            });
            continue;
        };
        match (key.subcode, code.subcodes) {
            (Some(s), Some(n)) if s == 0 || s > n => out.push(Problem::SubcodeRange {
                code: shown,
                number: key.number,
                subcodes: n,
            }),
            (Some(_), None) => out.push(Problem::NoSubcodes {
                code: shown,
                number: key.number,
                schema: schema.id.clone(),
            }),
            _ => {}
        }
        if code.access == Some(Access::Ro) || code.kind == Some(StorageKind::RamActual) {
            out.push(Problem::ReadOnly {
                code: code_label(schema, *key),
            });
        } else if code.read_clears == Some(true) {
            out.push(Problem::ReadClears {
                code: code_label(schema, *key),
            });
        } else if opts.dataset && dataset_code(schema) == Some(key.number) {
            out.push(Problem::DatasetCode {
                code: code_label(schema, *key),
            });
        } else if let Some(value) = set.values.get(key)
            && let Some((_, message, help)) =
                driveset_schema::role::refusal(schema, code, *key, value)
        {
            // no override: a set never starts a motor or runs a command
            out.push(Problem::Role { message, help });
        }
    }
    match opts.running {
        Running::Known(true) if !opts.overrides.allows(Override::AllowRunning) => {
            out.push(Problem::Running)
        }
        Running::Unknown if !opts.overrides.allows(Override::AllowRunningUnknown) => {
            out.push(Problem::RunningUnknown {
                schema: schema.id.clone(),
            })
        }
        _ => {}
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_problem_renders_its_message() {
        let s = |x: &str| x.to_string();
        let cases = vec![
            (
                Problem::SetSchema {
                    set: s("a"),
                    schema: s("b"),
                },
                "the set is for schema `a` but the drive is handled with schema `b`; upload a set for this drive family, or pass --allow-family if they are compatible",
            ),
            (
                Problem::ProtocolFamily {
                    found: s("lecom"),
                    schema: s("b"),
                    want: s("lustbus-mc"),
                },
                "the drive identifies as protocol family `lecom`, schema `b` is for `lustbus-mc`; check the address, or pass --allow-family",
            ),
            (
                Problem::DriveType {
                    found: 9999,
                    schema: s("b"),
                    expected: vec![1234],
                },
                "the drive reports 91-TYPE 9999, schema `b` is for TYPE [1234]; check the address, or pass --allow-family",
            ),
            (
                Problem::NotInSchema {
                    code: s("999"),
                    schema: s("b"),
                },
                "code 999 is not in schema `b`; remove it from the set (or fix the number)",
            ),
            (
                Problem::SubcodeRange {
                    code: s("C0039/9"),
                    number: 39,
                    subcodes: 8,
                },
                "C0039/9: code 39 has subcodes 1..=8 only; fix the subcode",
            ),
            (
                Problem::NoSubcodes {
                    code: s("C0011/1"),
                    number: 11,
                    schema: s("b"),
                },
                "C0011/1: code 11 has no subcodes in schema `b`; drop the /subcode",
            ),
            (
                Problem::ReadOnly { code: s("140-ACT") },
                "140-ACT: read-only (an actual value); remove it from the set",
            ),
            (
                Problem::ReadClears { code: s("85-SERR") },
                "85-SERR: a status code that reading clears; it cannot be part of a set, remove it",
            ),
            (
                Problem::DatasetCode {
                    code: s("80-SLOAD"),
                },
                "80-SLOAD: the dataset handshake code is driven by the upload itself; remove it from the set",
            ),
            (
                Problem::Role {
                    message: s("C0002 = 1 is a command"),
                    help: s("run it on the drive"),
                },
                "C0002 = 1 is a command; run it on the drive",
            ),
            (
                Problem::Running,
                "the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running",
            ),
            (
                Problem::RunningUnknown { schema: s("b") },
                "running state unknown: schema `b` names no status bit (role `running`) or control word start bit that says whether the motor runs; make sure the drive is at standstill, then pass --allow-running-unknown",
            ),
            (
                Problem::NotRead {
                    code: s("C0011 nmax"),
                },
                "C0011 nmax: the drive's current value was not read; it cannot be backed up",
            ),
            (
                Problem::AddressChange {
                    code: s("82-SADDR"),
                    old: s("1"),
                    new: s("4"),
                },
                "82-SADDR: 1 -> 4 changes the bus address of the drive being talked to; it would stop answering mid-transaction. Upload the set to the drive at its new address after changing the address on its own (or pass --allow-address-change)",
            ),
        ];
        for (p, want) in cases {
            assert_eq!(p.to_string(), want, "{p:?}");
        }
    }
}
