//! The engine's errors: what failed, on which bus, address and code, and
//! what to do. Owns [`EngineError`] (a target and a boxed [`ErrorKind`], so
//! a `Result<_, EngineError>` stays small). Its kind is one variant per
//! layer of the stack (`kind.rs`; [`Layer`], `layer.rs`: input, refusal,
//! link, device, transaction outcome), each holding that layer's own enum,
//! which a front end maps to an exit code in one place. The typed
//! [`Refusal`]s (a safety or input rule said no before anything was sent)
//! are gathered in `refusal.rs` from the sub-enums beside the rooms that
//! raise them (their one JSON form in `form.rs`; `recover`'s refusal of a
//! journal, [`crate::journal::NotJournalDrive`], beside the journal); the
//! typed [`DeviceCause`]s (what a drive itself said: LUSTBUS SIOF/SERR
//! bits, section 9.2; LECOM C0068 bits 4..7 and C1962, Table 1 and
//! section 8.J c; SDO abort codes, DS301 table 22) in `device.rs`, kept
//! apart from transport failures. Every kind renders the message the CLI
//! prints through `Display` (docs/architecture.md, "The data path of an
//! upload").

use std::fmt;

use driveset_link::LinkError;

use crate::client::Target;
use crate::journal::{Mismatch, NotJournalDrive};

mod address;
mod device;
mod form;
mod kind;
mod layer;
mod refusal;
#[cfg(test)]
mod tests;

/// For the sub-enums' tests: `refusal`, gathered into [`Refusal`], renders
/// its own message, writes exactly `json` (the flat kind journals hold)
/// and reads back as itself.
#[cfg(test)]
pub(crate) fn assert_refusal_json<R>(refusal: &R, json: &str)
where
    R: Clone + fmt::Display + Into<Refusal>,
{
    let r: Refusal = refusal.clone().into();
    assert_eq!(r.to_string(), refusal.to_string());
    assert_eq!(serde_json::to_string(&r).expect("json"), json);
    assert_eq!(serde_json::from_str::<Refusal>(json).expect("back"), r);
}

pub use address::{AddressRefused, AddressUse};
pub use device::{DeviceCause, LECOM_PROGRAMMING_ADVICE, SiofRegister, SiofVerdict};
pub use kind::{DeviceFailure, ErrorKind, InputFailure, LinkFailure, Refused, TransactionOutcome};
pub use layer::Layer;
pub use refusal::{LinkKind, Refusal};

/// Every way an engine operation fails: where ([`EngineError::target`]) and
/// what ([`EngineError::kind`], boxed).
#[derive(Debug)]
pub struct EngineError {
    /// The drive (port and bus address); `None` for a failure that is not
    /// about one drive (a journal file that cannot be read).
    pub target: Option<Target>,
    /// What failed.
    pub kind: Box<ErrorKind>,
}

impl EngineError {
    /// An error about the drive at `target`.
    pub fn new(target: Target, kind: ErrorKind) -> Self {
        EngineError {
            target: Some(target),
            kind: Box::new(kind),
        }
    }

    /// [`Refused::Rule`]: a [`Refusal`] or one of the sub-enums gathered
    /// into it.
    pub fn refused(target: Target, refusal: impl Into<Refusal>) -> Self {
        Self::new(target, ErrorKind::Refusal(Refused::Rule(refusal.into())))
    }

    /// [`LinkFailure::Transport`].
    pub fn link(target: Target, source: LinkError) -> Self {
        Self::new(target, ErrorKind::Link(LinkFailure::Transport(source)))
    }

    /// [`DeviceFailure::Refused`].
    pub fn device(target: Target, what: impl Into<String>, cause: DeviceCause) -> Self {
        Self::new(
            target,
            ErrorKind::Device(DeviceFailure::Refused {
                what: what.into(),
                cause,
            }),
        )
    }

    /// [`LinkFailure::NoAnswer`].
    pub fn no_answer(target: Target, what: impl Into<String>, tries: u32) -> Self {
        Self::new(
            target,
            ErrorKind::Link(LinkFailure::NoAnswer {
                what: what.into(),
                tries,
            }),
        )
    }

    /// [`DeviceFailure::Restarted`].
    pub fn restarted(target: Target, what: impl Into<String>) -> Self {
        Self::new(
            target,
            ErrorKind::Device(DeviceFailure::Restarted { what: what.into() }),
        )
    }

    /// [`LinkFailure::Protocol`].
    pub fn protocol(target: Target, what: impl Into<String>, detail: impl Into<String>) -> Self {
        Self::new(
            target,
            ErrorKind::Link(LinkFailure::Protocol {
                what: what.into(),
                detail: detail.into(),
            }),
        )
    }

    /// [`InputFailure::Journal`]: no drive is named.
    pub fn journal(path: impl Into<String>, detail: impl Into<String>) -> Self {
        EngineError {
            target: None,
            kind: Box::new(ErrorKind::Input(InputFailure::Journal {
                path: path.into(),
                detail: detail.into(),
            })),
        }
    }

    /// [`TransactionOutcome::RolledBack`].
    pub fn rolled_back(
        target: Target,
        journal: impl Into<String>,
        detail: impl Into<String>,
        cause: EngineError,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::Transaction(TransactionOutcome::RolledBack {
                journal: journal.into(),
                detail: detail.into(),
                cause,
            }),
        )
    }

    /// [`TransactionOutcome::Inconsistent`].
    pub fn inconsistent(
        target: Target,
        journal: impl Into<String>,
        detail: impl Into<String>,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::Transaction(TransactionOutcome::Inconsistent {
                journal: journal.into(),
                detail: detail.into(),
            }),
        )
    }

    /// [`Refused::NotJournalDrive`].
    pub fn not_journal_drive(
        target: Target,
        journal: impl Into<String>,
        mismatch: Mismatch,
        detail: impl Into<String>,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::Refusal(Refused::NotJournalDrive(NotJournalDrive {
                journal: journal.into(),
                mismatch,
                detail: detail.into(),
            })),
        )
    }

    /// What failed.
    pub fn kind(&self) -> &ErrorKind {
        &self.kind
    }

    /// The rule's refusal, for [`Refused::Rule`].
    pub fn refusal(&self) -> Option<&Refusal> {
        match &*self.kind {
            ErrorKind::Refusal(Refused::Rule(r)) => Some(r),
            _ => None,
        }
    }

    /// `recover`'s refusal of a journal, for [`Refused::NotJournalDrive`].
    pub fn not_journal_drive_refusal(&self) -> Option<&NotJournalDrive> {
        match &*self.kind {
            ErrorKind::Refusal(Refused::NotJournalDrive(r)) => Some(r),
            _ => None,
        }
    }

    /// The link's failure, for [`ErrorKind::Link`].
    pub fn link_failure(&self) -> Option<&LinkFailure> {
        match &*self.kind {
            ErrorKind::Link(failure) => Some(failure),
            _ => None,
        }
    }

    /// The drive's cause, for [`DeviceFailure::Refused`].
    pub fn device_cause(&self) -> Option<&DeviceCause> {
        match &*self.kind {
            ErrorKind::Device(DeviceFailure::Refused { cause, .. }) => Some(cause),
            _ => None,
        }
    }

    /// Whether a rule refused ([`Refused::Rule`]; not `recover`'s refusal
    /// of a journal).
    pub fn is_refused(&self) -> bool {
        self.refusal().is_some()
    }

    /// Whether the transaction was rolled back
    /// ([`TransactionOutcome::RolledBack`]).
    pub fn is_rolled_back(&self) -> bool {
        matches!(
            *self.kind,
            ErrorKind::Transaction(TransactionOutcome::RolledBack { .. })
        )
    }
}

impl fmt::Display for EngineError {
    /// The drive (`PORT address N: `), where named, and the kind's message;
    /// a journal that cannot be read or written names its file, not a
    /// drive.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (&*self.kind, &self.target) {
            (ErrorKind::Input(_), _) | (_, None) => write!(f, "{}", self.kind),
            (kind, Some(t)) => write!(f, "{t}: {kind}"),
        }
    }
}

impl std::error::Error for EngineError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &*self.kind {
            ErrorKind::Link(LinkFailure::Transport(source)) => Some(source),
            ErrorKind::Transaction(TransactionOutcome::RolledBack { cause, .. }) => Some(cause),
            _ => None,
        }
    }
}
