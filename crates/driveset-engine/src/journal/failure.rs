//! Why a transaction failed and what its codes hold afterwards
//! (docs/journals.md, "The file": `failure_cause`, `holding`):
//! [`FailureCause`], the typed engine error kept as data, and [`Holding`]
//! per code.

use serde::{Deserialize, Serialize};

use crate::error::{
    DeviceCause, DeviceFailure, EngineError, ErrorKind, InputFailure, LinkFailure, Refusal,
    Refused, TransactionOutcome,
};

/// What a planned code holds, read back after a failed roll back
/// (`"old"`, `"new"`, `"other"`, `"unknown"` in the journal).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Holding {
    /// Its value before the transaction (the backup).
    Old,
    /// The set's value.
    New,
    /// Neither.
    Other,
    /// It could not be read.
    Unknown,
}

impl Holding {
    /// The name the journal writes.
    pub fn as_str(self) -> &'static str {
        match self {
            Holding::Old => "old",
            Holding::New => "new",
            Holding::Other => "other",
            Holding::Unknown => "unknown",
        }
    }

    /// How a report says it of a list of codes (`C0011 hold the new value`).
    pub fn describe(self) -> &'static str {
        match self {
            Holding::Old => "hold the old value",
            Holding::New => "hold the new value",
            Holding::Other => "hold neither the old nor the new value",
            Holding::Unknown => "could not be read",
        }
    }
}

impl std::fmt::Display for Holding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What a code held when a transaction ended `failed`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CodeHolding {
    /// Code as humans spell it.
    pub code: String,
    /// What it holds.
    pub holds: Holding,
}

/// Why a transaction failed, typed ([`Journal::failure_cause`](super::Journal::failure_cause)): the
/// engine error that started the roll back (or ended a recovery), with the
/// drive's own indication or the refusal kept as data.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FailureCause {
    /// The transport failed.
    Link {
        /// The transport error's text.
        detail: String,
    },
    /// No answer after every retry.
    NoAnswer {
        /// The operation.
        what: String,
        /// How many times it was sent.
        tries: u32,
    },
    /// The drive refused and said why.
    Device {
        /// The operation.
        what: String,
        /// The drive's indication.
        cause: DeviceCause,
    },
    /// The drive restarted (power-on flag).
    Restarted {
        /// The operation.
        what: String,
    },
    /// A rule refused (a replan found a problem).
    Refused {
        /// The refusal.
        refusal: Refusal,
    },
    /// A journal file could not be written or read.
    Journal {
        /// The file.
        path: String,
        /// What failed.
        detail: String,
    },
    /// The drive's answer could not be understood.
    Protocol {
        /// The operation.
        what: String,
        /// What was wrong.
        detail: String,
    },
    /// An earlier upload was rolled back, for this cause.
    RolledBack {
        /// Its text.
        detail: String,
        /// The failure that started it.
        cause: Box<FailureCause>,
    },
    /// The drive holds a mix.
    Inconsistent {
        /// Which codes hold what.
        detail: String,
    },
    /// `recover` refused the drive.
    NotJournalDrive {
        /// What did not match.
        detail: String,
    },
    /// After restoring, these codes still differ from the backup.
    StillDiffer {
        /// The codes.
        codes: Vec<String>,
    },
}

impl FailureCause {
    /// The typed cause of `e`.
    pub fn of(e: &EngineError) -> Self {
        match e.kind() {
            ErrorKind::Link(LinkFailure::Transport(source)) => FailureCause::Link {
                detail: source.to_string(),
            },
            ErrorKind::Link(LinkFailure::NoAnswer { what, tries }) => FailureCause::NoAnswer {
                what: what.clone(),
                tries: *tries,
            },
            ErrorKind::Device(DeviceFailure::Refused { what, cause }) => FailureCause::Device {
                what: what.clone(),
                cause: cause.clone(),
            },
            ErrorKind::Device(DeviceFailure::Restarted { what }) => {
                FailureCause::Restarted { what: what.clone() }
            }
            ErrorKind::Refusal(Refused::Rule(refusal)) => FailureCause::Refused {
                refusal: refusal.clone(),
            },
            ErrorKind::Input(InputFailure::Journal { path, detail }) => FailureCause::Journal {
                path: path.clone(),
                detail: detail.clone(),
            },
            ErrorKind::Link(LinkFailure::Protocol { what, detail }) => FailureCause::Protocol {
                what: what.clone(),
                detail: detail.clone(),
            },
            ErrorKind::Transaction(TransactionOutcome::RolledBack { detail, cause, .. }) => {
                FailureCause::RolledBack {
                    detail: detail.clone(),
                    cause: Box::new(FailureCause::of(cause)),
                }
            }
            ErrorKind::Transaction(TransactionOutcome::Inconsistent { detail, .. }) => {
                FailureCause::Inconsistent {
                    detail: detail.clone(),
                }
            }
            ErrorKind::Refusal(Refused::NotJournalDrive(refused)) => {
                FailureCause::NotJournalDrive {
                    detail: refused.detail.clone(),
                }
            }
        }
    }
}
