//! The commissioning report of a machine line: what `driveset commission`
//! (and `driveset status`) did on every bus and drive, and what each drive
//! holds afterwards. One serde model; the JSON form is the machine-readable
//! report, and the CLI renders the self-contained HTML page from the same
//! value. Times on a bus are milliseconds on that bus's clock since the bus
//! started (virtual on `sim://` buses, real on ports); `started` /
//! `finished` are wall-clock RFC 3339 instants (UTC, milliseconds) taken
//! from the run's [`crate::env::Environment`]. Timeline phases are the
//! runners' own ([`crate::observe::Phase`]).

use driveset_schema::{BusProtocol, DiffKind};
use serde::{Deserialize, Serialize};

use crate::observe::Phase;

/// The report format version written into every report.
pub const REPORT_VERSION: u32 = 1;

/// A whole line run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LineReport {
    /// [`REPORT_VERSION`].
    pub report_version: u32,
    /// What produced it: `commission`, `status` or `replace`.
    pub command: String,
    /// The line's name (manifest `name`, else the manifest file stem).
    pub line: String,
    /// The manifest path as given.
    pub manifest: String,
    /// Operator-supplied label (`--label`), if any.
    pub label: Option<String>,
    /// Wall-clock start, RFC 3339 UTC.
    pub started: String,
    /// Wall-clock end, RFC 3339 UTC.
    pub finished: String,
    /// The git commit of the sets, when the manifest is inside a git work tree.
    pub git: Option<GitInfo>,
    /// Overall result.
    pub result: LineResult,
    /// One entry per bus, in manifest order.
    pub buses: Vec<BusReport>,
    /// One entry per drive, in manifest order.
    pub drives: Vec<DriveReport>,
    /// The plant history's session of this run (docs/history.md), when
    /// it was recorded; absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<HistoryLink>,
}

/// Where a run is on record in the plant history (docs/history.md).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct HistoryLink {
    /// The store as shown (a URL's password masked): `sqlite:PATH`,
    /// `postgresql://...`.
    pub store: String,
    /// The session's id.
    pub session: String,
    /// The command that lists the line's state as built by the history
    /// (`driveset history as-built MANIFEST ...`).
    pub as_built: String,
}

/// Where one drive of a run is on record in the plant history.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveHistoryLink {
    /// The drive record's place in the store's chain (`seq` of
    /// `history log --format json`).
    pub record: i64,
    /// The command that lists the drive's history
    /// (`driveset history log --line L --drive NAME ...`).
    pub log: String,
}

/// Where the sets came from in git.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct GitInfo {
    /// Full commit id of HEAD.
    pub commit: String,
    /// Whether the work tree had uncommitted changes to tracked files.
    pub dirty: bool,
}

/// Overall result of a line run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LineResult {
    /// Every selected drive holds its set (verified).
    Ok,
    /// At least one drive differs from its set (`status`).
    Drift,
    /// At least one drive failed.
    Failed,
}

/// One bus of the line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BusReport {
    /// Bus name from the manifest.
    pub name: String,
    /// Port in the common port syntax.
    pub port: String,
    /// The bus protocol, written by its name (`lustbus`, `lecom`, `can`).
    pub protocol: BusProtocol,
    /// Line rate (baud, or CAN bit/s).
    pub rate: u32,
    /// Time the bus was busy, ms on the bus clock.
    pub elapsed_ms: f64,
    /// What happened when, for the timeline chart.
    pub timeline: Vec<TimelineEntry>,
}

/// One span of bus activity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimelineEntry {
    /// The drive's name.
    pub drive: String,
    /// The runner's phase, written by its name (`identify`, `read`,
    /// `plan`, `write`, `verify`, `broadcast`, `rollback`, ...).
    pub phase: Phase,
    /// Start, ms on the bus clock.
    pub start_ms: f64,
    /// End, ms on the bus clock.
    pub end_ms: f64,
}

/// What happened to one drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DriveResult {
    /// Written (if needed) and verified: holds its set.
    Verified,
    /// Already held its set; nothing written.
    Unchanged,
    /// Skipped: a previous run verified it at the same set fingerprint (resume).
    AlreadyVerified,
    /// Not selected by `--only` / `--skip`.
    NotSelected,
    /// `status`: differs from its set.
    Drift,
    /// The upload failed and the drive was rolled back to its old values.
    RolledBack,
    /// Failed; see `error`.
    Failed,
}

/// One drive of the line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriveReport {
    /// Drive name (manifest `name`, else `BUS/ADDRESS`).
    pub name: String,
    /// Optional position text from the manifest.
    pub position: Option<String>,
    /// Bus name.
    pub bus: String,
    /// Bus address / node id.
    pub address: u8,
    /// Set file as given in the manifest.
    pub set: String,
    /// Schema id.
    pub schema: String,
    /// Identification codes read (`["91 TYPE", "1234"]` ...), empty if not reached.
    pub identity: Vec<(String, String)>,
    /// Fingerprint of the set file.
    pub set_fingerprint: String,
    /// Fingerprint of the drive's values of the set's codes before the run.
    pub fingerprint_before: Option<String>,
    /// ... and after the run.
    pub fingerprint_after: Option<String>,
    /// Codes written.
    pub codes_written: u32,
    /// Telegrams repeated after failures.
    pub retries: u64,
    /// Telegrams sent.
    pub telegrams: u64,
    /// Time spent on this drive, ms on the bus clock.
    pub elapsed_ms: f64,
    /// Outcome.
    pub result: DriveResult,
    /// Error message (what, where, what to do), if any.
    pub error: Option<String>,
    /// The semantic differences found before writing (or, for `status`, now).
    pub diff: Vec<DiffLine>,
    /// The schema learned from the drive's own descriptions when the set
    /// names a built-in schema that lacks facts (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learned_schema: Option<LearnedSchemaReport>,
    /// The drive was "at factory settings (a new or exchanged unit?)": where
    /// it differed from its set it held its schema's defaults
    /// ([`super::factory`] gives the rule). `status`: now; `commission`:
    /// before writing. Absent (false) otherwise.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub factory_settings: bool,
    /// `driveset replace`: the drive is a spare that was given the drive's
    /// address and rate on a service port, then its set. Absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replacement: Option<ReplacementReport>,
    /// Whether the drive keeps its set over a power cycle, when its upload
    /// completed: "stored" (the store command was acknowledged), "stored
    /// (the drive stores every write)", or "not stored: lost at power off
    /// (...)" ([`crate::upload::Stored::text`]). Absent otherwise. The
    /// human progress line leaves the every-write case out
    /// ([`DriveReport::store_worth_saying`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stored: Option<String>,
    /// The drive's record in the plant history (docs/history.md), when the
    /// run recorded it; absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<DriveHistoryLink>,
}

impl DriveReport {
    /// The `stored` text when it says more than the default: a drive that
    /// stores every write needs no words on a progress line (the report
    /// still says it).
    pub fn store_worth_saying(&self) -> Option<&str> {
        self.stored
            .as_deref()
            .filter(|s| *s != crate::upload::Stored::EveryWrite.text())
    }
}

/// How a spare became the drive (`driveset replace`; the report of one
/// drive, command `replace`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ReplacementReport {
    /// The service port the spare was on.
    pub service_port: String,
    /// The address the spare was reached at (LUSTBUS 0, LECOM the factory 1).
    pub found_address: u8,
    /// The rate it was found at.
    pub found_rate: u32,
    /// Its own address before, where it read as one.
    pub old_address: Option<i64>,
    /// The drive's manifest address, given to it.
    pub address: u8,
    /// The rate it runs at now.
    pub rate: u32,
    /// When a stored rate takes effect (VF1000, Tmd: at the next restart).
    pub rate_note: Option<String>,
    /// The assignment's writes.
    pub assigned: Vec<String>,
}

/// The schema a line run learned from one drive (`commission`'s module
/// docs, "Learning the schema").
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LearnedSchemaReport {
    /// The learned schema's id (`learned-<family>-type<TYPE>-<software>`);
    /// the drive's `schema` is this id too.
    pub id: String,
    /// The built-in schema the set names (and the learned one extends).
    pub base: String,
    /// The learned schema file: written by `commission`; for `status`, the
    /// file of an earlier commission run when one fits the drive's
    /// descriptions, else none (status writes nothing).
    pub file: Option<String>,
    /// Codes in the learned schema that came from the drive.
    pub codes: usize,
    /// Whether the MC value substitution texts and units were read (the
    /// only learning step that writes: the RAM selector 108-STEXT; never
    /// by `status`).
    pub texts: bool,
    /// Parameters whose description was left out or downgraded.
    pub findings: usize,
}

/// One line of a semantic diff, in engineering units with labels
/// (passwords redacted).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiffLine {
    /// Code as the schema displays it (`C0011`, `428-RSIO`).
    pub code: String,
    /// Code name.
    pub name: String,
    /// `added`, `removed` or `changed`.
    pub kind: DiffLineKind,
    /// Value on the drive (or in A), display text.
    pub old: Option<String>,
    /// Value in the set (or in B), display text.
    pub new: Option<String>,
}

/// What a [`DiffLine`] says happened to its code (the JSON strings
/// `added`, `removed`, `changed`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DiffLineKind {
    /// Only in the set (or in B).
    Added,
    /// Only on the drive (or in A).
    Removed,
    /// In both, different.
    Changed,
}

impl DiffLineKind {
    /// The report's word: `added`, `removed` or `changed`.
    pub fn as_str(self) -> &'static str {
        match self {
            DiffLineKind::Added => "added",
            DiffLineKind::Removed => "removed",
            DiffLineKind::Changed => "changed",
        }
    }
}

impl From<DiffKind> for DiffLineKind {
    fn from(k: DiffKind) -> Self {
        match k {
            DiffKind::Added => DiffLineKind::Added,
            DiffKind::Removed => DiffLineKind::Removed,
            DiffKind::Changed => DiffLineKind::Changed,
        }
    }
}
