//! The engine's errors: what failed, on which bus, address and code, and
//! what to do. Device-reported causes (LUSTBUS SIOF/SERR, LECOM C0068 /
//! C1962, SDO aborts) are kept apart from transport failures.

use driveset_link::LinkError;

use crate::client::Target;

/// What a drive itself said was wrong (as opposed to a transport failure).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceCause {
    /// Short cause as the spec names it (e.g. `"EEPROM busy"`, `"invalid value"`,
    /// `"no access permission"`, `"attempt to write a read only object"`).
    pub cause: String,
    /// The raw indication (`SERR 0x80`, `C0068 bits 4..7 = 5`, `abort 0x06010002`).
    pub raw: String,
    /// What to do about it (the spec's remedy where it gives one).
    pub remedy: String,
}

/// Why `recover` refused a journal ([`EngineError::NotJournalDrive`]).
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

/// Every way an engine operation fails.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// The transport failed (port gone, connection reset ...).
    #[error("{target}: {source}")]
    Link {
        /// Where.
        target: Target,
        /// The transport error.
        #[source]
        source: LinkError,
    },
    /// No (valid) answer after every retry.
    #[error(
        "{target}: no answer to {what} after {tries} tries; check wiring, address and baud rate"
    )]
    NoAnswer {
        /// Where.
        target: Target,
        /// The operation (`read C0011`, `write 428-RSIO` ...).
        what: String,
        /// How many times it was sent.
        tries: u32,
    },
    /// The drive refused an operation and said why.
    #[error("{target}: {what} refused: {} ({}); {}", cause.cause, cause.raw, cause.remedy)]
    Device {
        /// Where.
        target: Target,
        /// The operation.
        what: String,
        /// The drive's own cause.
        cause: DeviceCause,
    },
    /// The drive restarted (power-on indication) in the middle of the work:
    /// whatever was written since the last verified point is void.
    #[error(
        "{target}: the drive restarted during {what} (power-on flag set); the transaction is void and must be redone"
    )]
    Restarted {
        /// Where.
        target: Target,
        /// The operation during which it was noticed.
        what: String,
    },
    /// A safety rule refused the operation before anything was sent.
    #[error("{target}: refused: {reason}")]
    Refused {
        /// Where.
        target: Target,
        /// Why, and what to do (`--force` ...).
        reason: String,
    },
    /// A transaction journal could not be written or read (nothing further
    /// is sent to the drive while its backup is not safely on disk).
    #[error("journal {path}: {detail}")]
    Journal {
        /// The journal file.
        path: String,
        /// What failed and what to do.
        detail: String,
    },
    /// An upload did not land and was rolled back: the drive holds its old
    /// values again (read back and compared).
    #[error(
        "{target}: the upload did not land and was rolled back: {detail}; the drive holds its old values again (verified); journal {journal}"
    )]
    RolledBack {
        /// Where.
        target: Target,
        /// The journal file.
        journal: String,
        /// Why it did not land (code, cause; passwords never shown).
        detail: String,
        /// The failure that started the roll back.
        #[source]
        cause: Box<EngineError>,
    },
    /// An upload (or a recovery) failed and the drive could not be brought
    /// back to either the old or the new set: it holds a mix. The backup is
    /// in the journal.
    #[error(
        "{target}: the drive holds a mix of old and new values: {detail}; the backup is in {journal}: run `driveset recover {journal}` once the drive answers again"
    )]
    Inconsistent {
        /// Where.
        target: Target,
        /// The journal file.
        journal: String,
        /// Which codes hold what, and the failure.
        detail: String,
    },
    /// `recover` refused a journal: the drive it reaches is not the drive
    /// the journal was written for, or a planned code holds neither its old
    /// nor its new value. Nothing was written (for `Version`, `Schema`,
    /// `Bus` and `Address` nothing was sent at all).
    #[error("{target}: refused to recover journal {journal}: {detail}")]
    NotJournalDrive {
        /// Where recover was pointed.
        target: Target,
        /// The journal file.
        journal: String,
        /// What did not match.
        mismatch: Mismatch,
        /// What differs and what to do.
        detail: String,
    },
    /// The drive's answer could not be understood.
    #[error("{target}: unexpected answer to {what}: {detail}")]
    Protocol {
        /// Where.
        target: Target,
        /// The operation.
        what: String,
        /// What was wrong with the answer.
        detail: String,
    },
}
