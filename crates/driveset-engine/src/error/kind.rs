//! The layers as types: [`ErrorKind`] is one variant per layer of the
//! stack, each holding that layer's own enum: the command's input
//! ([`InputFailure`]), a refusal before anything was written ([`Refused`]:
//! a typed [`Refusal`] rule, or `recover`'s [`NotJournalDrive`]), the link
//! ([`LinkFailure`]), the drive itself ([`DeviceFailure`], with its typed
//! [`DeviceCause`]) and a transaction's outcome ([`TransactionOutcome`]).
//! Each renders its part of the message the CLI prints (`Display`; the
//! target is [`EngineError`]'s); [`ErrorKind::layer`] (`layer.rs`) is the
//! outer variant (docs/architecture.md, "The data path of an upload").

use std::fmt;

use driveset_link::LinkError;

use super::{DeviceCause, EngineError, Refusal};
use crate::journal::NotJournalDrive;

/// What failed ([`EngineError::kind`]): the layer, and what in it.
#[derive(Debug)]
pub enum ErrorKind {
    /// The command's input could not be read or written (a journal file).
    Input(InputFailure),
    /// Refused before anything was written: a rule, or `recover` for a
    /// drive that is not the journal's.
    Refusal(Refused),
    /// The link: the transport, no answer, an answer not understood.
    Link(LinkFailure),
    /// The drive itself: it refused with its own cause, or restarted.
    Device(DeviceFailure),
    /// A transaction's outcome: rolled back, or left as a mix.
    Transaction(TransactionOutcome),
}

/// The command's input failed ([`ErrorKind::Input`]): nothing reached a
/// drive because of it.
#[derive(Debug)]
pub enum InputFailure {
    /// A transaction journal could not be written or read (nothing further
    /// is sent to the drive while its backup is not safely on disk).
    Journal {
        /// The journal file.
        path: String,
        /// What failed and what to do.
        detail: String,
    },
}

/// Refused before anything was written ([`ErrorKind::Refusal`]).
#[derive(Debug)]
pub enum Refused {
    /// A safety or input rule refused the operation before anything was
    /// sent (typed: [`Refusal`] and the sub-enums beside their rooms).
    Rule(Refusal),
    /// `recover` refused a journal: the drive it reaches is not the drive
    /// the journal was written for, or the journal is stale (the journal's
    /// room: [`crate::journal::NotJournalDrive`]).
    NotJournalDrive(NotJournalDrive),
}

/// The link failed ([`ErrorKind::Link`]).
#[derive(Debug)]
pub enum LinkFailure {
    /// The transport failed (port gone, connection reset ...).
    Transport(LinkError),
    /// No (valid) answer after every retry.
    NoAnswer {
        /// The operation (`read C0011`, `write 428-RSIO` ...).
        what: String,
        /// How many times it was sent.
        tries: u32,
    },
    /// The drive's answer could not be understood.
    Protocol {
        /// The operation.
        what: String,
        /// What was wrong with the answer.
        detail: String,
    },
}

/// The drive itself failed the operation ([`ErrorKind::Device`]).
#[derive(Debug)]
pub enum DeviceFailure {
    /// The drive refused an operation and said why.
    Refused {
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
}

/// How a transaction ended when it did not land ([`ErrorKind::Transaction`]).
#[derive(Debug)]
pub enum TransactionOutcome {
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
}

impl fmt::Display for ErrorKind {
    /// The message without the drive (the target is [`EngineError`]'s).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ErrorKind::Input(e) => write!(f, "{e}"),
            ErrorKind::Refusal(e) => write!(f, "{e}"),
            ErrorKind::Link(e) => write!(f, "{e}"),
            ErrorKind::Device(e) => write!(f, "{e}"),
            ErrorKind::Transaction(e) => write!(f, "{e}"),
        }
    }
}

impl fmt::Display for InputFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InputFailure::Journal { path, detail } => write!(f, "journal {path}: {detail}"),
        }
    }
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refused::Rule(reason) => write!(f, "refused: {reason}"),
            Refused::NotJournalDrive(refused) => write!(f, "{refused}"),
        }
    }
}

impl fmt::Display for LinkFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkFailure::Transport(source) => write!(f, "{source}"),
            LinkFailure::NoAnswer { what, tries } => write!(
                f,
                "no answer to {what} after {tries} tries; check wiring, address and baud rate"
            ),
            LinkFailure::Protocol { what, detail } => {
                write!(f, "unexpected answer to {what}: {detail}")
            }
        }
    }
}

impl fmt::Display for DeviceFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceFailure::Refused { what, cause } => write!(
                f,
                "{what} refused: {} ({}); {}",
                cause.cause(),
                cause.raw(),
                cause.remedy()
            ),
            DeviceFailure::Restarted { what } => write!(
                f,
                "the drive restarted during {what} (power-on flag set); the transaction is void and must be redone"
            ),
        }
    }
}

impl fmt::Display for TransactionOutcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TransactionOutcome::RolledBack {
                journal, detail, ..
            } => write!(
                f,
                "the upload did not land and was rolled back: {detail}; the drive holds its old values again (verified); journal {journal}"
            ),
            TransactionOutcome::Inconsistent { journal, detail } => write!(
                f,
                "the drive holds a mix of old and new values: {detail}; the backup is in {journal}: run `driveset recover {journal}` once the drive answers again"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::client::Target;

    fn t() -> Target {
        Target {
            port: "sim://demo".into(),
            address: 1,
        }
    }

    fn s(x: &str) -> String {
        x.to_string()
    }

    /// Every layer's kinds render their whole message, the drive first where
    /// one is named (a journal file names none, even given a target).
    #[test]
    fn every_kind_renders_its_whole_message() {
        let closed = driveset_link::LinkError::ConnectionClosed {
            port: "tcp://x:1".into(),
        };
        let closed_text = closed.to_string();
        let at = |m: &str| format!("sim://demo address 1: {m}");
        let cases: Vec<(EngineError, String)> = vec![
            (
                EngineError::journal("j.json", "cannot write"),
                s("journal j.json: cannot write"),
            ),
            (
                EngineError::new(
                    t(),
                    ErrorKind::Input(InputFailure::Journal {
                        path: s("j.json"),
                        detail: s("cannot write"),
                    }),
                ),
                s("journal j.json: cannot write"),
            ),
            (
                EngineError::refused(t(), Refusal::NoDatasetHandshake),
                at("refused: this drive family has no dataset download handshake"),
            ),
            (
                EngineError::not_journal_drive(
                    t(),
                    "j.json",
                    crate::journal::Mismatch::Bus,
                    "another bus",
                ),
                at("refused to recover journal j.json: another bus"),
            ),
            (EngineError::link(t(), closed), at(&closed_text)),
            (
                EngineError::no_answer(t(), "read C0011", 3),
                at("no answer to read C0011 after 3 tries; check wiring, address and baud rate"),
            ),
            (
                EngineError::protocol(t(), "read C0011", "short frame"),
                at("unexpected answer to read C0011: short frame"),
            ),
            (
                EngineError::device(t(), "write C0011", DeviceCause::SiofUnreadable),
                at(
                    "write C0011 refused: SIOF/SERR cannot be read (NAK to ENQUIRY 00085); the drive does not answer its error word: check it is a LUSTBUS drive",
                ),
            ),
            (
                EngineError::restarted(t(), "write C0011"),
                at(
                    "the drive restarted during write C0011 (power-on flag set); the transaction is void and must be redone",
                ),
            ),
            (
                EngineError::rolled_back(
                    t(),
                    "j.json",
                    "C0011",
                    EngineError::restarted(t(), "write C0011"),
                ),
                at(
                    "the upload did not land and was rolled back: C0011; the drive holds its old values again (verified); journal j.json",
                ),
            ),
            (
                EngineError::inconsistent(t(), "j.json", "C0011 new"),
                at(
                    "the drive holds a mix of old and new values: C0011 new; the backup is in j.json: run `driveset recover j.json` once the drive answers again",
                ),
            ),
            (
                EngineError {
                    target: None,
                    kind: Box::new(ErrorKind::Link(LinkFailure::NoAnswer {
                        what: s("read C0011"),
                        tries: 3,
                    })),
                },
                s("no answer to read C0011 after 3 tries; check wiring, address and baud rate"),
            ),
        ];
        for (e, want) in cases {
            assert_eq!(e.to_string(), want);
        }
    }
}
