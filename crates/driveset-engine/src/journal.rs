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
//! the bus as [`DriveClient::bus_id`] names it (independent of how the port
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
//! operation on them is in the private `store` functions at the end of this
//! module: read, the durable write, listing a directory, creating it.

use std::path::{Path, PathBuf};

use driveset_schema::{CodeKey, RawValue};
use serde::{Deserialize, Serialize};

use crate::client::{DriveClient, Identity, Target};
use crate::error::{DeviceCause, EngineError, ErrorKind, Mismatch, Refusal};

/// The journal format version this crate writes.
pub const JOURNAL_VERSION: u32 = 2;
/// The oldest journal version this crate reads (module docs, "Versions").
pub const OLDEST_JOURNAL_VERSION: u32 = 1;
/// The journal file name's ending.
pub const JOURNAL_SUFFIX: &str = ".journal.json";

/// Where a transaction stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TxnState {
    /// Journal written, nothing sent to the drive yet.
    Planned,
    /// Writes in progress (on MC6000/7000: the dataset download is staged).
    Writing,
    /// MC6000/7000: the drive accepted the dataset (SLOAD = 0); the
    /// non-CardWriteable writes follow.
    Committed,
    /// Every write acknowledged; the last verification reads run.
    Verifying,
    /// The old values are being restored.
    RollingBack,
    /// Final: the drive holds the new set (verified).
    Complete,
    /// Final: the drive holds its old values again (verified).
    RolledBack,
    /// Final until recovered: the drive holds a mix; `holding` says what.
    Failed,
}

impl TxnState {
    /// Name as written in the journal.
    pub fn as_str(self) -> &'static str {
        match self {
            TxnState::Planned => "planned",
            TxnState::Writing => "writing",
            TxnState::Committed => "committed",
            TxnState::Verifying => "verifying",
            TxnState::RollingBack => "rolling-back",
            TxnState::Complete => "complete",
            TxnState::RolledBack => "rolled-back",
            TxnState::Failed => "failed",
        }
    }

    /// Whether nothing is left to do (`complete` or `rolled-back`).
    pub fn is_settled(self) -> bool {
        matches!(self, TxnState::Complete | TxnState::RolledBack)
    }
}

/// A raw value in the journal: `{"int": 5}`, `{"text": "abc"}`, `{"octets": "0aff"}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JournalValue {
    /// [`RawValue::Int`].
    Int(i64),
    /// [`RawValue::Text`].
    Text(String),
    /// [`RawValue::Octets`], lowercase hex.
    Octets(String),
}

impl From<&RawValue> for JournalValue {
    fn from(v: &RawValue) -> Self {
        match v {
            RawValue::Int(i) => JournalValue::Int(*i),
            RawValue::Text(t) => JournalValue::Text(t.clone()),
            RawValue::Octets(o) => {
                JournalValue::Octets(o.iter().map(|b| format!("{b:02x}")).collect())
            }
        }
    }
}

impl JournalValue {
    /// The raw value, or `None` for malformed octets.
    pub fn to_raw(&self) -> Option<RawValue> {
        Some(match self {
            JournalValue::Int(i) => RawValue::Int(*i),
            JournalValue::Text(t) => RawValue::Text(t.clone()),
            JournalValue::Octets(h) => {
                if h.len() % 2 != 0 || !h.is_ascii() {
                    return None;
                }
                let mut out = Vec::with_capacity(h.len() / 2);
                for i in (0..h.len()).step_by(2) {
                    out.push(u8::from_str_radix(h.get(i..i + 2)?, 16).ok()?);
                }
                RawValue::Octets(out)
            }
        })
    }
}

/// Port, address and bus as recorded.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct JournalTarget {
    /// Port as the user wrote it.
    pub port: String,
    /// Bus address / node id.
    pub address: u8,
    /// The bus ([`DriveClient::bus_id`]); `None` in version 1 journals.
    #[serde(default)]
    pub bus: Option<String>,
}

impl JournalTarget {
    /// The target of `client`: its port, address and bus.
    pub fn of(client: &dyn DriveClient) -> Self {
        let t: &Target = client.target();
        JournalTarget {
            port: t.port.clone(),
            address: t.address,
            bus: Some(client.bus_id()),
        }
    }

    /// Whether this is the drive at `address` on bus `bus` (reached through
    /// `port`): same bus id and address; a version 1 journal (no bus id)
    /// by the port string as written.
    pub fn is_drive(&self, bus: &str, port: &str, address: u8) -> bool {
        self.address == address
            && match &self.bus {
                Some(b) => b == bus,
                None => self.port == port,
            }
    }
}

/// Where the journal's schema came from ([`Journal::schema_source`]), so
/// that `recover` converts with the very schema the upload used, without
/// `--schema`: its file (absolute) when it was read from one, and its
/// fingerprint ([`driveset_schema::Schema::fingerprint`]).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SchemaSource {
    /// The schema file, absolute; absent for a built-in schema (and in
    /// journals of releases before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema_path: Option<String>,
    /// `sha256:` of the schema's text (chained over its base's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema_fingerprint: Option<String>,
}

impl SchemaSource {
    /// The source of `schema`: its file, absolute, when
    /// [`driveset_schema::Schema::path`] names a file on disk (a built-in's
    /// `schemas/x.toml` names none outside a checkout; `recover` looks the
    /// id up among the known schemas first and takes the file only when
    /// none of them has the fingerprint), and its fingerprint.
    pub fn of(schema: &driveset_schema::Schema) -> Self {
        let file = Path::new(&schema.path);
        let schema_path = file
            .is_file()
            .then(|| std::fs::canonicalize(file).ok())
            .flatten()
            .map(|p| p.display().to_string());
        SchemaSource {
            schema_path,
            schema_fingerprint: Some(schema.fingerprint.clone()),
        }
    }
}

/// The drive's identity as recorded ([`Identity`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct JournalIdentity {
    /// Family family.
    pub protocol: String,
    /// Identification codes and their values as text.
    pub codes: Vec<(String, String)>,
    /// Software version, where known.
    pub software: Option<String>,
}

impl From<&Identity> for JournalIdentity {
    fn from(i: &Identity) -> Self {
        JournalIdentity {
            protocol: i.protocol.name().to_string(),
            codes: i.pairs(),
            software: i.software.clone(),
        }
    }
}

impl JournalIdentity {
    /// Whether a freshly read identity is the same drive kind.
    pub fn matches(&self, other: &Identity) -> bool {
        self.protocol == other.protocol.name()
            && self.codes == other.pairs()
            && self.software == other.software
    }
}

/// One backed-up value: a planned code's value before the transaction.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BackupEntry {
    /// Code number.
    pub number: u32,
    /// Subcode.
    pub subcode: Option<u32>,
    /// Code as humans spell it (`C0011`, `428-RSIO`).
    pub code: String,
    /// A password: redact when showing.
    pub secret: bool,
    /// The old raw value.
    pub old: JournalValue,
}

/// One planned write, in write order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlanEntryRecord {
    /// Code number.
    pub number: u32,
    /// Subcode.
    pub subcode: Option<u32>,
    /// Code as humans spell it.
    pub code: String,
    /// A password: redact when showing.
    pub secret: bool,
    /// `ram`, `eeprom`, `card-writeable`, `unspecified`.
    pub storage: String,
    /// Byte width, where the schema gives it.
    pub width: Option<u8>,
    /// `dataset`, `stored`, `control`, `mode`.
    pub phase: String,
    /// The new raw value.
    pub new: JournalValue,
}

/// A state transition.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Transition {
    /// The state entered.
    pub state: TxnState,
    /// The client clock's instant, nanoseconds since its epoch.
    pub at_ns: u64,
    /// Why (failure cause, dataset outcome ...).
    pub note: Option<String>,
}

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

/// Why a transaction failed, typed ([`Journal::failure_cause`]): the
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
            ErrorKind::Link(source) => FailureCause::Link {
                detail: source.to_string(),
            },
            ErrorKind::NoAnswer { what, tries } => FailureCause::NoAnswer {
                what: what.clone(),
                tries: *tries,
            },
            ErrorKind::Device { what, cause } => FailureCause::Device {
                what: what.clone(),
                cause: cause.clone(),
            },
            ErrorKind::Restarted { what } => FailureCause::Restarted { what: what.clone() },
            ErrorKind::Refused(refusal) => FailureCause::Refused {
                refusal: refusal.clone(),
            },
            ErrorKind::Journal { path, detail } => FailureCause::Journal {
                path: path.clone(),
                detail: detail.clone(),
            },
            ErrorKind::Protocol { what, detail } => FailureCause::Protocol {
                what: what.clone(),
                detail: detail.clone(),
            },
            ErrorKind::RolledBack { detail, cause, .. } => FailureCause::RolledBack {
                detail: detail.clone(),
                cause: Box::new(FailureCause::of(cause)),
            },
            ErrorKind::Inconsistent { detail, .. } => FailureCause::Inconsistent {
                detail: detail.clone(),
            },
            ErrorKind::NotJournalDrive { detail, .. } => FailureCause::NotJournalDrive {
                detail: detail.clone(),
            },
        }
    }
}

/// The journal file's content.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Journal {
    /// [`JOURNAL_VERSION`].
    pub journal_version: u32,
    /// Current state.
    pub state: TxnState,
    /// Port and address.
    pub target: JournalTarget,
    /// What the drive said it is.
    pub identity: JournalIdentity,
    /// Schema id.
    pub schema: String,
    /// The schema's file and fingerprint (absent in journals of releases
    /// before they were recorded): `recover` finds the schema from them.
    #[serde(flatten)]
    pub schema_source: SchemaSource,
    /// Fingerprint of the set being uploaded.
    pub set_fingerprint: String,
    /// Fingerprint of the drive's values of the set's codes before the upload.
    pub fingerprint_before: String,
    /// Whether the MC6000/7000 SLOAD dataset handshake is used.
    pub dataset: bool,
    /// Attempt number (a drive restart voids an attempt; it is redone once).
    pub attempt: u32,
    /// Old values of every planned code (the first attempt's values are kept).
    pub backup: Vec<BackupEntry>,
    /// The planned writes, in write order.
    pub plan: Vec<PlanEntryRecord>,
    /// The set's other codes, which the drive already held (value = old =
    /// new); recovery reads them too to fingerprint the whole set.
    #[serde(default)]
    pub unchanged: Vec<BackupEntry>,
    /// Codes written (acknowledged) so far, canonical spelling; advisory:
    /// recovery reads the drive rather than trusting this list.
    pub written: Vec<String>,
    /// Codes whose new value a LUSTBUS broadcast (SELECT to address 31,
    /// section 4.2; `commission --broadcast-common`) sends into this
    /// drive's dataset download instead of a SELECT of its own, canonical
    /// spelling. No receipt says whether they landed, so they may be in
    /// the drive's dataset though `written` does not list them; recovery
    /// reads the drive anyway (a dataset download left open is rolled
    /// back).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub broadcast: Vec<String>,
    /// State transitions.
    pub transitions: Vec<Transition>,
    /// Why the transaction failed, if it did (the message, as shown).
    pub failure: Option<String>,
    /// The same, typed (absent in journals of releases before it was
    /// added, and while nothing failed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_cause: Option<FailureCause>,
    /// For `failed`: what each planned code holds.
    #[serde(default)]
    pub holding: Vec<CodeHolding>,
    /// A transfer-rate switch (`--transfer-baud`, [`crate::transfer`]):
    /// the drive may run at another rate than its port's until the record
    /// says `back`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transfer: Option<TransferRecord>,
    /// An address change (`driveset address`, [`crate::assign`]): the
    /// drive may answer at its old or its new address, at the old or the
    /// new rate, until the change is complete.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assign: Option<crate::assign::AssignRecord>,
}

/// Where a transfer-rate switch stands ([`TransferRecord::state`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TransferState {
    /// Recorded before the first telegram of the switch: the drive's rate
    /// code may hold the transfer rate (in EEPROM) and it may be active.
    Switching,
    /// The drive runs at the transfer rate; its rate code holds its own
    /// value again (not active).
    AtTransferRate,
    /// Switching back: the drive may run at either rate.
    SwitchingBack,
    /// Final: the drive runs at the old rate again and its rate code holds
    /// [`TransferRecord::stored`].
    Back,
}

impl TransferState {
    /// Name as written in the journal.
    pub fn as_str(self) -> &'static str {
        match self {
            TransferState::Switching => "switching",
            TransferState::AtTransferRate => "at-transfer-rate",
            TransferState::SwitchingBack => "switching-back",
            TransferState::Back => "back",
        }
    }
}

/// A transfer-rate switch (LUSTBUS 11.5: 81-SBAUD, then 4-PROG = 111).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TransferRecord {
    /// The rate code as humans spell it (`81-SBAUD`).
    pub code: String,
    /// The rate the port (and the drive) ran at before the switch.
    pub old_rate: u32,
    /// The transfer rate.
    pub transfer_rate: u32,
    /// The rate code's value before the switch (what it holds in EEPROM;
    /// not necessarily the active rate).
    pub before: JournalValue,
    /// Where the switch stands.
    pub state: TransferState,
    /// When the drive was told to switch (client clock, ns).
    pub switched_at_ns: Option<u64>,
    /// When it ran at the old rate again.
    pub back_at_ns: Option<u64>,
    /// What the rate code holds at the end (the set's value, or `before`).
    pub stored: Option<JournalValue>,
    /// What the rate code is to hold once the drive runs at the old rate
    /// again: decided once, at the first telegram of the switch back
    /// (`before` when the switch-over itself failed, else what the
    /// transaction left in it), so that a switch back cut anywhere and
    /// resumed by `recover` writes the same value, never the transfer
    /// rate nor the old rate it wrote on the way. Absent in journals of
    /// releases before it was added, and before the switch back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keep: Option<JournalValue>,
}

impl TransferRecord {
    /// Whether the drive is known to run at the old rate again.
    pub fn is_back(&self) -> bool {
        self.state == TransferState::Back
    }
}

impl Journal {
    /// Backup values by code.
    pub fn backup_values(&self) -> Result<Vec<(CodeKey, RawValue)>, String> {
        self.backup
            .iter()
            .map(|b| {
                let key = CodeKey {
                    number: b.number,
                    subcode: b.subcode,
                };
                b.old
                    .to_raw()
                    .map(|v| (key, v))
                    .ok_or_else(|| format!("backup value of {} is malformed", b.code))
            })
            .collect()
    }

    /// Planned new values by code, in write order.
    pub fn new_values(&self) -> Result<Vec<(CodeKey, RawValue)>, String> {
        self.plan
            .iter()
            .map(|p| {
                let key = CodeKey {
                    number: p.number,
                    subcode: p.subcode,
                };
                p.new
                    .to_raw()
                    .map(|v| (key, v))
                    .ok_or_else(|| format!("planned value of {} is malformed", p.code))
            })
            .collect()
    }

    /// Values of the set's codes the upload did not need to write.
    pub fn unchanged_values(&self) -> Result<Vec<(CodeKey, RawValue)>, String> {
        self.unchanged
            .iter()
            .map(|b| {
                let key = CodeKey {
                    number: b.number,
                    subcode: b.subcode,
                };
                b.old
                    .to_raw()
                    .map(|v| (key, v))
                    .ok_or_else(|| format!("value of {} is malformed", b.code))
            })
            .collect()
    }

    /// Whether nothing is left to do: the transaction is settled and no
    /// transfer-rate switch is left open ([`TransferRecord::is_back`]).
    pub fn is_finished(&self) -> bool {
        self.state.is_settled() && self.transfer.as_ref().is_none_or(TransferRecord::is_back)
    }

    /// Enter a state, recording the instant and a note.
    pub fn transition(&mut self, state: TxnState, at_ns: u64, note: Option<String>) {
        self.state = state;
        self.transitions.push(Transition { state, at_ns, note });
    }
}

/// A journal on disk: the content and where it lives.
#[derive(Debug)]
pub struct JournalFile {
    path: PathBuf,
    /// The content last written.
    pub journal: Journal,
}

fn jerr(path: &Path, detail: impl Into<String>) -> EngineError {
    EngineError::journal(path.display().to_string(), detail.into())
}

impl JournalFile {
    /// Create a new journal at `path` and make it durable. Refuses to
    /// replace a journal of an unfinished transaction.
    pub fn create(path: &Path, journal: Journal) -> Result<Self, EngineError> {
        if store::exists(path) {
            match JournalFile::open(path) {
                Ok(existing) if !existing.journal.is_finished() => {
                    return Err(jerr(
                        path,
                        format!(
                            "holds an unfinished transaction (state {}); nothing was sent to the drive. Run `driveset recover {}` first",
                            existing.journal.state.as_str(),
                            path.display()
                        ),
                    ));
                }
                Ok(_) => {}
                Err(_) => {
                    return Err(jerr(
                        path,
                        "exists and is not a readable journal; nothing was sent to the drive. Move it away or choose another journal path",
                    ));
                }
            }
        }
        let f = JournalFile {
            path: path.to_path_buf(),
            journal,
        };
        f.persist()?;
        Ok(f)
    }

    /// Replace the journal at `path` with `journal` (the caller's own
    /// journal of this transaction: [`crate::transfer`] records a rate
    /// switch before the upload plans) and make it durable.
    pub fn replace(path: &Path, journal: Journal) -> Result<Self, EngineError> {
        let f = JournalFile {
            path: path.to_path_buf(),
            journal,
        };
        f.persist()?;
        Ok(f)
    }

    /// Read a journal (versions [`OLDEST_JOURNAL_VERSION`]..=[`JOURNAL_VERSION`]).
    pub fn open(path: &Path) -> Result<Self, EngineError> {
        let text = store::read(path).map_err(|e| jerr(path, e))?;
        let journal: Journal = serde_json::from_str(&text).map_err(|e| {
            jerr(
                path,
                format!("is not a driveset journal ({e}); pass the file `driveset upload` wrote"),
            )
        })?;
        if !(OLDEST_JOURNAL_VERSION..=JOURNAL_VERSION).contains(&journal.journal_version) {
            return Err(jerr(
                path,
                format!(
                    "has journal version {}, this driveset reads versions {OLDEST_JOURNAL_VERSION} to {JOURNAL_VERSION}; use the driveset release that wrote it",
                    journal.journal_version
                ),
            ));
        }
        Ok(JournalFile {
            path: path.to_path_buf(),
            journal,
        })
    }

    /// Where the journal lives.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Write the current content atomically and durably: temp file (0600),
    /// fsync, rename over the journal, fsync the directory.
    pub fn persist(&self) -> Result<(), EngineError> {
        let path = &self.path;
        let text = serde_json::to_string_pretty(&self.journal)
            .map_err(|e| jerr(path, format!("cannot encode it: {e}")))?;
        store::write_durable(path, &text).map_err(|(what, e)| {
            jerr(
                path,
                format!(
                    "cannot {what}: {e}; check the directory exists, is writable and has space"
                ),
            )
        })
    }
}

/// The journal file name of the drive at `address` on bus `bus_id`
/// (module docs, "One naming scheme"): the bus id's file stem
/// ([`driveset_link::bus_id::file_stem`]: every character but
/// `[A-Za-z0-9]` replaced by `_`, long ids cut with a hash), then
/// `-ADDRESS` and [`JOURNAL_SUFFIX`]. `tcp:127.0.0.1:4001` at 3 ->
/// `tcp_127_0_0_1_4001-3.journal.json`.
pub fn journal_file_name(bus_id: &str, address: u8) -> String {
    format!(
        "{}-{address}{JOURNAL_SUFFIX}",
        driveset_link::bus_id::file_stem(bus_id)
    )
}

/// `dir` joined with [`journal_file_name`].
pub fn journal_path(dir: &Path, bus_id: &str, address: u8) -> PathBuf {
    dir.join(journal_file_name(bus_id, address))
}

/// An unfinished journal of a drive, found by [`unfinished_for`].
#[derive(Debug, Clone)]
pub struct Unfinished {
    /// The file.
    pub path: PathBuf,
    /// Its content.
    pub journal: Journal,
}

/// Every journal in `dir` (not in subdirectories) of an unfinished
/// transaction of the drive at `address` on bus `bus` (reached through
/// `port`), found by content, not by file name (module docs), sorted by
/// path. A missing directory holds none; files that are not journals are
/// passed over.
pub fn unfinished_for(
    dir: &Path,
    bus: &str,
    port: &str,
    address: u8,
) -> Result<Vec<Unfinished>, EngineError> {
    let files = match store::json_files(dir) {
        Ok(Some(f)) => f,
        Ok(None) => return Ok(Vec::new()),
        Err(e) => {
            return Err(jerr(
                dir,
                format!(
                    "cannot list the journal directory: {e}; nothing was sent. Check it is readable"
                ),
            ));
        }
    };
    let mut out = Vec::new();
    for path in files {
        let Ok(jf) = JournalFile::open(&path) else {
            continue;
        };
        if !jf.journal.is_finished() && jf.journal.target.is_drive(bus, port, address) {
            out.push(Unfinished {
                path,
                journal: jf.journal,
            });
        }
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// The refusal for a drive with unfinished journals (nothing was sent).
pub fn unfinished_error(target: &Target, found: &[Unfinished]) -> EngineError {
    let list: Vec<String> = found
        .iter()
        .map(|u| format!("{} (state {})", u.path.display(), u.journal.state.as_str()))
        .collect();
    let first = found
        .first()
        .map(|u| u.path.display().to_string())
        .unwrap_or_default();
    EngineError::journal(
        first.clone(),
        format!(
            "the drive at {target} has an unfinished transaction ({}); nothing was sent. Run `driveset recover {first}` first",
            list.join(", ")
        ),
    )
}

/// Create the journal directory `dir` if it is missing; the topmost
/// directory this creates gets a `.gitignore` holding `*` (module docs).
/// An existing directory is left as it is.
pub fn ensure_dir(dir: &Path) -> Result<(), EngineError> {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    store::create_dir_ignored(dir).map_err(|(what, e)| {
        jerr(
            dir,
            format!("cannot {what}: {e}; nothing was sent. Check the directory can be created"),
        )
    })
}

/// Every file operation on journals (module docs, "The one place of file
/// IO"). Errors name what failed, for the caller's message.
mod store {
    use std::fs::{self, File, OpenOptions};
    use std::io::{self, Write};
    use std::path::{Path, PathBuf};

    pub(super) fn exists(path: &Path) -> bool {
        path.exists()
    }

    /// The journal's text, through the schema crate's one file reader
    /// (regular files only, at most 16 MiB, never a blocking open).
    pub(super) fn read(path: &Path) -> Result<String, String> {
        use driveset_schema::input::{InputKind, read_input};
        let bytes = read_input(path, InputKind::JOURNAL).map_err(|e| e.detail())?;
        String::from_utf8(bytes).map_err(|e| {
            format!(
                "is not text (invalid UTF-8 at byte {}); pass the file `driveset upload` wrote",
                e.utf8_error().valid_up_to()
            )
        })
    }

    /// Write `text` and a newline to `path` atomically and durably: temp
    /// file `<path>.tmp` (mode 0600), fsync, rename over `path`, fsync the
    /// directory.
    pub(super) fn write_durable(path: &Path, text: &str) -> Result<(), (&'static str, io::Error)> {
        let mut tmp_name = path.as_os_str().to_owned();
        tmp_name.push(".tmp");
        let tmp = PathBuf::from(tmp_name);
        {
            let mut opts = OpenOptions::new();
            opts.write(true).create(true).truncate(true);
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt;
                opts.mode(0o600);
            }
            let mut f = opts
                .open(&tmp)
                .map_err(|e| ("create the temporary file", e))?;
            // An existing temp file keeps its old mode: force 0600.
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                f.set_permissions(fs::Permissions::from_mode(0o600))
                    .map_err(|e| ("restrict the temporary file to mode 0600", e))?;
            }
            f.write_all(text.as_bytes())
                .and_then(|()| f.write_all(b"\n"))
                .map_err(|e| ("write the temporary file", e))?;
            f.sync_all()
                .map_err(|e| ("flush the temporary file to disk", e))?;
        }
        fs::rename(&tmp, path).map_err(|e| ("rename the temporary file over the journal", e))?;
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        // Directory fsync makes the rename durable (Unix; a no-op elsewhere).
        #[cfg(unix)]
        File::open(&dir)
            .and_then(|d| d.sync_all())
            .map_err(|e| ("flush the journal's directory to disk", e))?;
        #[cfg(not(unix))]
        let _ = (&dir, File::open);
        Ok(())
    }

    /// The regular files named `*.json` directly in `dir`; `None` when
    /// `dir` does not exist.
    pub(super) fn json_files(dir: &Path) -> io::Result<Option<Vec<PathBuf>>> {
        let entries = match fs::read_dir(dir) {
            Ok(e) => e,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e),
        };
        Ok(Some(
            entries
                .flatten()
                .filter(|e| {
                    e.file_name().to_string_lossy().ends_with(".json")
                        && e.file_type().is_ok_and(|t| t.is_file())
                })
                .map(|e| e.path())
                .collect(),
        ))
    }

    /// Create `dir` if it is missing; the topmost directory this creates
    /// gets a `.gitignore` holding `*`. An existing directory is left as it
    /// is.
    pub(super) fn create_dir_ignored(dir: &Path) -> Result<(), (&'static str, io::Error)> {
        if dir.is_dir() {
            return Ok(());
        }
        // the topmost missing ancestor
        let mut top = dir.to_path_buf();
        while let Some(parent) = top.parent() {
            if parent.as_os_str().is_empty() || parent.exists() {
                break;
            }
            top = parent.to_path_buf();
        }
        fs::create_dir_all(dir).map_err(|e| ("create the journal directory", e))?;
        fs::write(
            top.join(".gitignore"),
            "# written by driveset: journals hold old values, passwords included\n*\n",
        )
        .map_err(|e| ("write its .gitignore", e))
    }
}

/// [`Mismatch::Version`] for a journal that records no bus (version 1).
pub(crate) fn version_refusal(target: &Target, path: &Path, version: u32) -> EngineError {
    EngineError::not_journal_drive(
        target.clone(),
        path.display().to_string(),
        Mismatch::Version,
        format!(
            "it has journal version {version}, which does not record the drive's bus, so driveset cannot check that it reaches the drive the journal was written for; nothing was sent. Finish it with the driveset release that wrote it, or restore the drive by hand from the journal's backup"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    /// A `failed` journal as the release before typed causes wrote it
    /// (version 2, `failure` text only, `holding` names as strings).
    const V2_FAILED: &str = r#"{
  "journal_version": 2,
  "state": "failed",
  "target": { "port": "sim://demo", "address": 1, "bus": "sim:demo" },
  "identity": { "protocol": "lustbus-mc", "codes": [["91-TYPE", "1234"]], "software": null },
  "schema": "fictional-mc6000-demo",
  "set_fingerprint": "sha256:5c1e",
  "fingerprint_before": "sha256:09ab",
  "dataset": false,
  "attempt": 1,
  "backup": [
    { "number": 100, "subcode": null, "code": "100-KPSC1", "secret": false, "old": { "int": 1310 } },
    { "number": 101, "subcode": null, "code": "101-TNSC1", "secret": false, "old": { "int": 200 } },
    { "number": 102, "subcode": null, "code": "102-X", "secret": false, "old": { "int": 1 } },
    { "number": 103, "subcode": null, "code": "103-Y", "secret": false, "old": { "int": 2 } }
  ],
  "plan": [],
  "written": ["100"],
  "transitions": [{ "state": "planned", "at_ns": 1, "note": null }],
  "failure": "sim://demo address 1: no answer to write 101-TNSC1 after 3 tries",
  "holding": [
    { "code": "100-KPSC1", "holds": "new" },
    { "code": "101-TNSC1", "holds": "unknown" },
    { "code": "102-X", "holds": "other" },
    { "code": "103-Y", "holds": "old" }
  ]
}"#;

    #[test]
    fn a_version_2_journal_without_typed_causes_is_read() {
        let j: Journal = serde_json::from_str(V2_FAILED).expect("v2 journal");
        assert_eq!(j.journal_version, 2);
        assert_eq!(j.state, TxnState::Failed);
        assert_eq!(j.failure_cause, None);
        assert_eq!(
            j.failure.as_deref(),
            Some("sim://demo address 1: no answer to write 101-TNSC1 after 3 tries")
        );
        let holds: Vec<(&str, Holding)> = j
            .holding
            .iter()
            .map(|h| (h.code.as_str(), h.holds))
            .collect();
        assert_eq!(
            holds,
            [
                ("100-KPSC1", Holding::New),
                ("101-TNSC1", Holding::Unknown),
                ("102-X", Holding::Other),
                ("103-Y", Holding::Old)
            ]
        );
        // written back, the holding names are the same strings
        let back = serde_json::to_value(&j).expect("json");
        assert_eq!(back["holding"][2]["holds"], "other");
        assert!(back.get("failure_cause").is_none(), "{back}");
        // a journal of a release before the schema's file and fingerprint
        // were recorded: read, and written back without them
        assert_eq!(j.schema_source, SchemaSource::default());
        assert!(back.get("schema_path").is_none(), "{back}");
        assert!(back.get("schema_fingerprint").is_none(), "{back}");
        assert_eq!(back["schema"], "fictional-mc6000-demo");
        let mut with = j.clone();
        with.schema_source = SchemaSource {
            schema_path: Some("/plant/schemas/demo.toml".into()),
            schema_fingerprint: Some("sha256:00".into()),
        };
        let v = serde_json::to_value(&with).expect("json");
        assert_eq!(v["schema_path"], "/plant/schemas/demo.toml");
        assert_eq!(v["schema_fingerprint"], "sha256:00");
        let again: Journal = serde_json::from_value(v).expect("read back");
        assert_eq!(again.schema_source, with.schema_source);
        // and through the file reader
        let dir = tempfile::tempdir().expect("tmp");
        let path = dir.path().join("sim_demo-1.journal.json");
        fs::write(&path, V2_FAILED).expect("write");
        let jf = JournalFile::open(&path).expect("open v2");
        assert_eq!(jf.journal, j);
    }

    #[test]
    fn the_failure_cause_is_stored_typed() {
        let mut j: Journal = serde_json::from_str(V2_FAILED).expect("v2 journal");
        let target = Target {
            port: "sim://demo".into(),
            address: 1,
        };
        let e = EngineError::device(
            target.clone(),
            "write 101-TNSC1 (raw 9)",
            DeviceCause::Siof {
                register: crate::error::SiofRegister::Serr,
                bits: driveset_proto::lustbus::Siof(0x80),
                verdict: crate::error::SiofVerdict::Failed,
            },
        );
        let rolled = EngineError::rolled_back(target.clone(), "j", "it failed", e);
        j.failure_cause = Some(FailureCause::of(&rolled));
        let v = serde_json::to_value(&j).expect("json");
        assert_eq!(
            v["failure_cause"].to_string(),
            r#"{"cause":{"cause":{"bits":128,"kind":"siof","register":"serr","verdict":{"kind":"failed"}},"kind":"device","what":"write 101-TNSC1 (raw 9)"},"detail":"it failed","kind":"rolled_back"}"#
        );
        let back: Journal = serde_json::from_value(v).expect("back");
        assert_eq!(back, j);
        let refused = EngineError::refused(target, Refusal::NoDatasetOpen);
        assert_eq!(
            serde_json::to_string(&FailureCause::of(&refused)).expect("json"),
            r#"{"kind":"refused","refusal":{"kind":"no_dataset_open"}}"#
        );
    }

    #[test]
    fn file_names_come_from_bus_id_and_address() {
        assert_eq!(
            journal_file_name("tcp:127.0.0.1:4001", 3),
            "tcp_127_0_0_1_4001-3.journal.json"
        );
        assert_eq!(
            journal_file_name("serial:/dev/ttyUSB0", 12),
            "serial__dev_ttyUSB0-12.journal.json"
        );
        let long = format!("sim:mc6000@/{}", "d/".repeat(80));
        let name = journal_file_name(&long, 1);
        assert_eq!(name.len(), 96 + 1 + 16 + "-1.journal.json".len());
        assert!(name.ends_with("-1.journal.json"), "{name}");
        assert_ne!(name, journal_file_name(&format!("{long}x"), 1));
    }

    #[test]
    fn ensure_dir_writes_a_gitignore_into_the_topmost_directory_it_creates() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join(".driveset/journal");
        ensure_dir(&dir).unwrap();
        assert!(dir.is_dir());
        assert_eq!(
            fs::read_to_string(d.path().join(".driveset/.gitignore")).unwrap(),
            "# written by driveset: journals hold old values, passwords included\n*\n"
        );
        assert!(!dir.join(".gitignore").exists());
        // an existing directory is left alone
        let other = d.path().join("mine");
        fs::create_dir(&other).unwrap();
        ensure_dir(&other).unwrap();
        assert!(!other.join(".gitignore").exists());
    }
}
