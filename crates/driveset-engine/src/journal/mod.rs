//! The transaction journal: a JSON file that holds everything needed to
//! finish or undo an upload after a crash or a pulled cable
//! (docs/journals.md; `driveset recover JOURNAL`).
//!
//! It is written and fsynced (file and directory) **before the first write**
//! to the drive, and rewritten atomically (write `<journal>.tmp`, fsync,
//! rename over the journal, fsync the directory) at every state transition
//! and every few writes with the list of codes written so far. A reader
//! therefore always sees one complete version, never a torn file.
//!
//! **The journal holds the old and new raw values of every planned code,
//! passwords included** (it must, to restore them). It is created with mode
//! 0600 (owner read/write only) on Unix; keep it out of version control and
//! delete it once the transaction is complete. Entries of password codes are
//! marked `"secret": true` so tools that show a journal can redact them.
//!
//! **A journal is bound to its drive.** It records the drive's identity:
//! the bus as [`crate::client::DriveClient::bus_id`] names it (independent of how the port
//! was spelled: resolved TCP peer, canonical device path, the simulator's
//! bus id), the bus address, the identify codes' values, the schema (id,
//! file and fingerprint: [`SchemaSource`]), and
//! the plan (old values in `backup`, new ones in `plan`). `recover` refuses a
//! drive that is not that drive ([`crate::recover`]).
//!
//! **One naming scheme** ([`journal_path`]): `DIR/<bus id>-<address>.journal.json`,
//! the bus id sanitised to `[A-Za-z0-9_]` (long ids cut, with a hash of the
//! whole id). `upload` and `commission` both use it; the guard against a
//! second transaction ([`unfinished_for`]) does not trust names: it reads
//! every journal in the directory and compares the recorded bus and address.
//!
//! **The directory keeps itself out of git**: [`ensure_dir`] writes a
//! `.gitignore` holding `*` into the topmost directory it creates (as the
//! cache directories of other tools do), so `.driveset/` never shows in
//! `git status` of the repository the sets live in.
//!
//! **Versions.** This crate writes version 2. Version 1 journals (no bus
//! id) are still read: the guard matches them by port string and address;
//! `recover` refuses them with [`Mismatch::Version`] (it cannot check the
//! bus), telling to finish them with the release that wrote them.
//!
//! Example (an MC6000 upload interrupted after its dataset was accepted):
//!
//! ```json
//! {
//!   "journal_version": 2,
//!   "state": "committed",
//!   "target": { "port": "/dev/ttyUSB0", "address": 1, "bus": "serial:/dev/ttyUSB0" },
//!   "identity": { "protocol": "lustbus-mc", "codes": [["91 TYPE", "1234"]], "software": null },
//!   "schema": "fictional-mc6000-demo",
//!   "set_fingerprint": "sha256:5c1e...",
//!   "fingerprint_before": "sha256:09ab...",
//!   "dataset": true,
//!   "attempt": 1,
//!   "backup": [
//!     { "number": 100, "subcode": null, "code": "100-KPSC1", "secret": false, "old": { "int": 1310 } },
//!     { "number": 428, "subcode": null, "code": "428-RSIO", "secret": false, "old": { "int": 0 } }
//!   ],
//!   "plan": [
//!     { "number": 100, "subcode": null, "code": "100-KPSC1", "secret": false,
//!       "storage": "card-writeable", "width": 4, "phase": "dataset", "new": { "int": 2097 } },
//!     { "number": 428, "subcode": null, "code": "428-RSIO", "secret": false,
//!       "storage": "ram", "width": 4, "phase": "control", "new": { "int": 8667136 } }
//!   ],
//!   "unchanged": [
//!     { "number": 101, "subcode": null, "code": "101-TNSC1", "secret": false, "old": { "int": 200 } }
//!   ],
//!   "written": ["100"],
//!   "transitions": [
//!     { "state": "planned", "at_ns": 412000000, "note": null },
//!     { "state": "writing", "at_ns": 412000000, "note": null },
//!     { "state": "committed", "at_ns": 498000000, "note": "SLOAD accepted the dataset" }
//!   ],
//!   "failure": null,
//!   "holding": []
//! }
//! ```
//!
//! `at_ns` is the client clock's instant (nanoseconds since that clock's
//! epoch), not wall time: it orders the transitions of one run.
//!
//! **The one place of file IO.** Journals are the engine's durable store,
//! the one kind of file the engine reads and writes itself (everything else
//! a run keeps goes through [`crate::env::Environment`]). Every file
//! operation on them is in the private `store` module (`journal/store.rs`):
//! read, the durable write, listing a directory, creating it.
//!
//! The rooms: `records` (the file's content, [`Journal`] and its parts),
//! `failure` (why a transaction failed and what its codes hold), `value`
//! (the raw values' JSON form, [`JournalValue`]), `file` (a journal on
//! disk, [`JournalFile`]: naming, the guard's scan, the directory) and
//! `store` (the file operations).

mod failure;
mod file;
mod records;
mod refused;
mod store;
#[cfg(test)]
mod tests;
mod value;

pub use failure::{CodeHolding, FailureCause, Holding};
pub(crate) use file::version_refusal;
pub use file::{
    JournalAt, JournalFile, Unfinished, ensure_dir, journal_dir_or_default, journal_file_name,
    journal_path, unfinished_error, unfinished_for,
};
pub use records::{
    BackupEntry, Journal, JournalIdentity, JournalTarget, PlanEntryRecord, SchemaSource,
    TransferRecord, TransferState, Transition, TxnState,
};
pub use refused::{Mismatch, NotJournalDrive};
pub use value::JournalValue;

/// The journal format version this crate writes.
pub const JOURNAL_VERSION: u32 = 2;
/// The oldest journal version this crate reads (module docs, "Versions").
pub const OLDEST_JOURNAL_VERSION: u32 = 1;
/// The journal file name's ending.
pub const JOURNAL_SUFFIX: &str = ".journal.json";
/// The journal directory the CLI's commands use when neither `--journal`,
/// `--journal-dir` nor a line manifest's `journal_dir` gives one (relative
/// to the current directory; docs/journals.md).
pub const DEFAULT_JOURNAL_DIR: &str = ".driveset/journal";
