//! The engine's errors: what failed, on which bus, address and code, and
//! what to do. Owns [`EngineError`] (a target and a boxed [`ErrorKind`], so
//! a `Result<_, EngineError>` stays small) and [`Mismatch`]; the typed
//! [`Refusal`]s (a safety or input rule said no before anything was sent)
//! are in `refusal.rs`, the typed [`DeviceCause`]s (what a drive itself
//! said: LUSTBUS SIOF/SERR bits, section 9.2; LECOM C0068 bits 4..7 and
//! C1962, Table 1 and section 8.J c; SDO abort codes, DS301 table 22) in
//! `device.rs`, kept apart from transport failures. Every variant renders
//! the message the CLI prints through `Display` and says its [`Layer`]
//! (`layer.rs`: input, refusal, link, device, transaction outcome), which a
//! front end maps to an exit code in one place.

use std::fmt;

use driveset_link::LinkError;

use crate::client::Target;

mod address;
mod device;
mod form;
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

/// What failed ([`EngineError::kind`]).
#[derive(Debug)]
pub enum ErrorKind {
    /// The transport failed (port gone, connection reset ...).
    Link(LinkError),
    /// No (valid) answer after every retry.
    NoAnswer {
        /// The operation (`read C0011`, `write 428-RSIO` ...).
        what: String,
        /// How many times it was sent.
        tries: u32,
    },
    /// The drive refused an operation and said why.
    Device {
        /// The operation.
        what: String,
        /// The drive's own cause.
        cause: DeviceCause,
    },
    /// The drive restarted (power-on indication) in the middle of the work:
    /// whatever was written since the last verified point is void.
    Restarted {
        /// The operation during which it was noticed.
        what: String,
    },
    /// A safety or input rule refused the operation before anything was sent.
    Refused(Refusal),
    /// A transaction journal could not be written or read (nothing further
    /// is sent to the drive while its backup is not safely on disk).
    Journal {
        /// The journal file.
        path: String,
        /// What failed and what to do.
        detail: String,
    },
    /// An upload did not land and was rolled back: the drive holds its old
    /// values again (read back and compared).
    RolledBack {
        /// The journal file.
        journal: String,
        /// Why it did not land (code, cause; passwords never shown).
        detail: String,
        /// The failure that started the roll back.
        cause: EngineError,
    },
    /// An upload (or a recovery) failed and the drive could not be brought
    /// back to either the old or the new set: it holds a mix. The backup is
    /// in the journal.
    Inconsistent {
        /// The journal file.
        journal: String,
        /// Which codes hold what, and the failure.
        detail: String,
    },
    /// `recover` refused a journal: the drive it reaches is not the drive
    /// the journal was written for, or a planned code holds neither its old
    /// nor its new value. Nothing was written (for `Version`, `Schema`,
    /// `Bus` and `Address` nothing was sent at all).
    NotJournalDrive {
        /// The journal file.
        journal: String,
        /// What did not match.
        mismatch: Mismatch,
        /// What differs and what to do.
        detail: String,
    },
    /// The drive's answer could not be understood.
    Protocol {
        /// The operation.
        what: String,
        /// What was wrong with the answer.
        detail: String,
    },
}

impl EngineError {
    /// An error about the drive at `target`.
    pub fn new(target: Target, kind: ErrorKind) -> Self {
        EngineError {
            target: Some(target),
            kind: Box::new(kind),
        }
    }

    /// [`ErrorKind::Refused`]: a [`Refusal`] or one of the sub-enums
    /// gathered into it.
    pub fn refused(target: Target, refusal: impl Into<Refusal>) -> Self {
        Self::new(target, ErrorKind::Refused(refusal.into()))
    }

    /// [`ErrorKind::Link`].
    pub fn link(target: Target, source: LinkError) -> Self {
        Self::new(target, ErrorKind::Link(source))
    }

    /// [`ErrorKind::Device`].
    pub fn device(target: Target, what: impl Into<String>, cause: DeviceCause) -> Self {
        Self::new(
            target,
            ErrorKind::Device {
                what: what.into(),
                cause,
            },
        )
    }

    /// [`ErrorKind::NoAnswer`].
    pub fn no_answer(target: Target, what: impl Into<String>, tries: u32) -> Self {
        Self::new(
            target,
            ErrorKind::NoAnswer {
                what: what.into(),
                tries,
            },
        )
    }

    /// [`ErrorKind::Restarted`].
    pub fn restarted(target: Target, what: impl Into<String>) -> Self {
        Self::new(target, ErrorKind::Restarted { what: what.into() })
    }

    /// [`ErrorKind::Protocol`].
    pub fn protocol(target: Target, what: impl Into<String>, detail: impl Into<String>) -> Self {
        Self::new(
            target,
            ErrorKind::Protocol {
                what: what.into(),
                detail: detail.into(),
            },
        )
    }

    /// [`ErrorKind::Journal`]: no drive is named.
    pub fn journal(path: impl Into<String>, detail: impl Into<String>) -> Self {
        EngineError {
            target: None,
            kind: Box::new(ErrorKind::Journal {
                path: path.into(),
                detail: detail.into(),
            }),
        }
    }

    /// [`ErrorKind::RolledBack`].
    pub fn rolled_back(
        target: Target,
        journal: impl Into<String>,
        detail: impl Into<String>,
        cause: EngineError,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::RolledBack {
                journal: journal.into(),
                detail: detail.into(),
                cause,
            },
        )
    }

    /// [`ErrorKind::Inconsistent`].
    pub fn inconsistent(
        target: Target,
        journal: impl Into<String>,
        detail: impl Into<String>,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::Inconsistent {
                journal: journal.into(),
                detail: detail.into(),
            },
        )
    }

    /// [`ErrorKind::NotJournalDrive`].
    pub fn not_journal_drive(
        target: Target,
        journal: impl Into<String>,
        mismatch: Mismatch,
        detail: impl Into<String>,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::NotJournalDrive {
                journal: journal.into(),
                mismatch,
                detail: detail.into(),
            },
        )
    }

    /// What failed.
    pub fn kind(&self) -> &ErrorKind {
        &self.kind
    }

    /// The refusal, for [`ErrorKind::Refused`].
    pub fn refusal(&self) -> Option<&Refusal> {
        match &*self.kind {
            ErrorKind::Refused(r) => Some(r),
            _ => None,
        }
    }

    /// The drive's cause, for [`ErrorKind::Device`].
    pub fn device_cause(&self) -> Option<&DeviceCause> {
        match &*self.kind {
            ErrorKind::Device { cause, .. } => Some(cause),
            _ => None,
        }
    }

    /// Whether this is [`ErrorKind::Refused`].
    pub fn is_refused(&self) -> bool {
        matches!(*self.kind, ErrorKind::Refused(_))
    }
}

impl fmt::Display for EngineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = self.target.as_ref();
        let at = |f: &mut fmt::Formatter<'_>| match t {
            Some(t) => write!(f, "{t}: "),
            None => Ok(()),
        };
        match &*self.kind {
            ErrorKind::Journal { path, detail } => write!(f, "journal {path}: {detail}"),
            kind => {
                at(f)?;
                match kind {
                    ErrorKind::Link(source) => write!(f, "{source}"),
                    ErrorKind::NoAnswer { what, tries } => write!(
                        f,
                        "no answer to {what} after {tries} tries; check wiring, address and baud rate"
                    ),
                    ErrorKind::Device { what, cause } => write!(
                        f,
                        "{what} refused: {} ({}); {}",
                        cause.cause(),
                        cause.raw(),
                        cause.remedy()
                    ),
                    ErrorKind::Restarted { what } => write!(
                        f,
                        "the drive restarted during {what} (power-on flag set); the transaction is void and must be redone"
                    ),
                    ErrorKind::Refused(reason) => write!(f, "refused: {reason}"),
                    ErrorKind::RolledBack {
                        journal, detail, ..
                    } => write!(
                        f,
                        "the upload did not land and was rolled back: {detail}; the drive holds its old values again (verified); journal {journal}"
                    ),
                    ErrorKind::Inconsistent { journal, detail } => write!(
                        f,
                        "the drive holds a mix of old and new values: {detail}; the backup is in {journal}: run `driveset recover {journal}` once the drive answers again"
                    ),
                    ErrorKind::NotJournalDrive {
                        journal, detail, ..
                    } => write!(f, "refused to recover journal {journal}: {detail}"),
                    ErrorKind::Protocol { what, detail } => {
                        write!(f, "unexpected answer to {what}: {detail}")
                    }
                    ErrorKind::Journal { .. } => Ok(()),
                }
            }
        }
    }
}

impl std::error::Error for EngineError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &*self.kind {
            ErrorKind::Link(source) => Some(source),
            ErrorKind::RolledBack { cause, .. } => Some(cause),
            _ => None,
        }
    }
}

/// Why `recover` refused a journal ([`ErrorKind::NotJournalDrive`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Mismatch {
    /// A journal version that does not record the drive's bus (1).
    Version,
    /// The client's schema is not the journal's.
    Schema,
    /// The port reaches another bus.
    Bus,
    /// Another bus address.
    Address,
    /// The drive identifies differently (identify codes, family, software).
    Identity,
    /// These planned codes hold neither their old nor their new value.
    Stale {
        /// The codes, as humans spell them.
        codes: Vec<String>,
    },
}
