//! `driveset commission LINE`: bring every selected drive of a line to its
//! set. Buses run in parallel (a thread per bus, each bus on its own link
//! and clock); the drives of one bus run in turn. Per drive: identify, read
//! back, diff, upload what differs as one transaction
//! ([`crate::upload::upload`]), verify.
//!
//! **Resume.** Every drive that ends holding its set is recorded in the
//! state file [`STATE_FILE`] in the report directory (bus, address, port,
//! set fingerprint, the fingerprint read back, when). A rerun does not
//! trust the file blindly: for a drive recorded at the set's current
//! fingerprint it identifies the drive and reads the set's codes once
//! (the cost of a `status` check, no planning, no journal, no writes); if
//! the drive still holds the set the drive is [`DriveResult::AlreadyVerified`],
//! otherwise it is commissioned again. A drive whose set changed since is
//! commissioned again. `fresh` ignores the file.
//!
//! **Unfinished journals.** Journals go to [`LineOptions::journal_dir`]
//! under the one naming scheme of [`crate::journal::journal_path`] (bus id
//! and address), so `upload` and `commission` see each other's. Before a
//! drive is touched the directory is scanned for unfinished journals of
//! that drive (by recorded bus and address, not file name). `commission`
//! recovers each ([`crate::recover::recover`]: it refuses another drive or
//! a stale journal), warns what it did, then commissions the drive; the
//! drive is then [`DriveResult::Verified`], never `Unchanged`, and its
//! recorded resume state is not trusted. A refused or failed recovery makes
//! the drive [`DriveResult::Failed`]. `status` writes nothing: such a drive
//! is `Failed` (exit 1). A LECOM group or a LUSTBUS bus with an unfinished
//! journal gets no broadcast (`broadcast_common`).
//!
//! **Verdict** ([`LineOutcome::verdict`], which the CLI maps to its exit
//! codes 0, 1 and 3): [`Verdict::Holds`] every selected drive holds its
//! set; [`Verdict::Differs`] a drive does not (drift, refused, rolled back,
//! failed); [`Verdict::BusFailed`] a bus could not be opened, a link
//! failed, a drive did not answer, or the run stopped before every drive
//! was reached (`stop_after`). A bus failure wins over a difference.
//!
//! **The world** ([`LineOptions::env`], [`crate::env::Environment`]): the
//! wall-clock times of the report and the state file, the git commit of the
//! sets, and the state and learned-schema files go through it; the run
//! itself does no file IO but the journals'.
//!
//! **Timeline and progress.** Each drive's work is observed
//! ([`crate::observe`]): the transaction runner reports its own phases,
//! the line runner adds `learn`, `recover`, `broadcast` and the `identify` /
//! `read` of `status` and of a resume check. The bus report's timeline
//! holds those spans (zero-length ones, planning and journal writes on a
//! virtual clock, left out); [`LineOptions::observer`] gets every event
//! with its bus and drive.
//!
//! **Broadcast** (`broadcast_common`; LECOM and LUSTBUS buses; CAN buses
//! fall back to per-drive writes with a warning).
//!
//! LECOM: values every selected drive of a LECOM group (addresses x1..x9)
//! sets identically are sent once per group with MULTICAST to x0 before
//! the drives are done one by one; each drive's own transaction then reads
//! every code back, writes what did not land and verifies, so the
//! broadcast only saves telegrams. MULTICAST is unacknowledged and has no
//! journal backup; drives of the group that the line does not list receive
//! it too.
//!
//! LUSTBUS (sections 2.1, 4.2, 9.1, 11.4): a SELECT to address 31 is
//! executed by every device on the bus, listed in the manifest or not, and
//! none gives a receipt. The common values are the codes every selected
//! MC6000/7000 drive's set gives the same value that are CardWriteable
//! (the ones the SLOAD dataset stages, [`crate::plan::Phase::Dataset`]) and
//! that every drive's plan writes; never the numerically compatible codes
//! 81..85 and 91 (SBAUD, SADDR, SDMMY, SWDGT, SERR, TYPE), never a code
//! with a role (address, baud rate, control, command, mode ...), never
//! SLOAD itself. They go out once, inside every drive's dataset download:
//! 1. every drive is taken through its own [`Transaction`] to "dataset
//!    open": identify, read back, plan (the running check), journal with
//!    backup, SERR cleared, SLOAD = -1 (taken at standstill only; the
//!    drive is then secured against being started until the download
//!    ends, 11.4);
//! 2. each journal records the codes the broadcast sends (its `broadcast`
//!    field) and is made durable;
//! 3. one SELECT per value to address 31 (`_`), nothing awaited but the
//!    longest MC reaction time (timeline phase `broadcast`, drive
//!    `address 31`);
//! 4. each drive in turn: SERR read (the new session's first read: clears
//!    what a broadcast may have latched), its own remaining dataset writes,
//!    SLOAD = -2 and the poll, the writes after the dataset, and the
//!    verification of every code one by one, broadcast ones included. A
//!    broadcast value that did not land is written on its own (after the
//!    commit, as a plain SELECT) and verified; the run warns which.
//!
//! No broadcast (the drives are done one by one, with a warning saying
//! why) when the bus also lists VF1000 drives (a VF1000 executes the
//! SELECT as a write of its own parameter of that number), when a drive
//! the manifest puts on the bus is not selected (`--only` / `--skip`), when
//! the drives do not share one schema or learn theirs first, when any
//! address 0..30 of the bus has an unfinished journal, when a drive does
//! not reach "dataset open" (it runs, refuses, fails, or already holds its
//! set: address 31 would reach it outside a dataset download), and with
//! `stop_after`. A drive's `codes_written` counts its own SELECTs, not the
//! broadcast; its `elapsed_ms` is the time of its own exchanges.
//!
//! **Learning the schema.** A drive whose set names a built-in LUSTBUS
//! schema that lacks facts ([`Drive::learn_from`], see
//! [`crate::learn::needs_learning`]) is learned first, as `pull` and
//! `upload` do: over the bus's own link, before anything else is done to
//! the drive, its descriptions (VF1000 specifier 1, MC specifier 3) are
//! read and interpreted by [`crate::learn::learn`], rendered and checked by
//! [`crate::learn::render_schema`] (the built-in schema's spec facts stand),
//! and the set is resolved again against the learned schema; its findings
//! then fail the drive. `commission` also reads the MC unit strings and
//! value substitution texts (this selects texts with the RAM selector
//! 108-STEXT and sets it back) and writes the learned schema to
//! `LineLearn::schema_dir/<id>.toml`. `status` writes nothing: it reads the
//! descriptions only (ENQUIRY), and uses the file an earlier `commission`
//! wrote for the same descriptions (same id: the id holds their hash) when
//! there is one, else the schema learned without texts. The drive's report
//! names the learned schema ([`LearnedSchemaReport`]); the run's timeline
//! has a `learn` phase. Without [`LineOptions::learn`] such a drive fails.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use driveset_link::{Instant, Link, OpenOptions};
use driveset_schema::error::SourceFile;
use driveset_schema::{CodeKey, DiffKind, RawValue, Registry, ResolvedSet, Role, Schema, load_set};
use serde::{Deserialize, Serialize};

use super::manifest::{Bus, BusProtocol, Drive, Manifest};
use super::report::{
    BusReport, DiffLine, DriveReport, DriveResult, LearnedSchemaReport, LineReport, LineResult,
    REPORT_VERSION, TimelineEntry,
};
use crate::client::{BorrowedByteLink, DriveClient, Identity, LecomClient, LustbusClient, Target};
use crate::env::{Environment, rfc3339};
use crate::error::{EngineError, ErrorKind, Refusal};
use crate::identify::check_family;
use crate::learn::{LearnOptions, LearnSource, learn, learned_id, render_schema};
use crate::live::live_values;
use crate::observe::{Event, Hook, Observer, Phase, Spans};
use crate::overrides::Overrides;
use crate::plan::value_text;
use crate::recover::{RecoverAction, RecoverOptions, recover};
use crate::upload::{
    Next, Replanned, StepError, Transaction, UploadOptions, default_journal_path, upload,
};

/// The state file's name inside the report directory.
pub const STATE_FILE: &str = ".commission-state.json";
/// The state file's format version.
pub const STATE_VERSION: u32 = 1;

/// The outcome of a line run in one word (module docs, "Verdict").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Every selected drive holds its set.
    Holds,
    /// A drive differs from its set (drift, refused, rolled back, failed).
    Differs,
    /// A bus could not be opened, a link failed, a drive did not answer, or
    /// the run stopped before every drive was reached.
    BusFailed,
}

/// Told every event of every drive's work, with its bus and drive names
/// (the CLI's progress bars). Called from the bus threads.
pub trait LineObserver: Send + Sync {
    /// Bus `bus` starts, with `drives` selected drives.
    fn bus(&self, bus: &str, drives: usize) {
        let _ = (bus, drives);
    }

    /// Drive `drive` on bus `bus` reached `event` at `at` (the bus clock).
    fn event(&self, bus: &str, drive: &str, at: Instant, event: Event);
}

/// Opens a bus's port as a link. The CLI passes one that opens `sim://`
/// ports with the simulator; [`open_port`] opens real ports.
pub type Opener<'a> = dyn Fn(&Bus) -> Result<Link, String> + Sync + 'a;

/// Open a real port (serial, TCP, slcan, SocketCAN); `sim://` is refused.
pub fn open_port(bus: &Bus) -> Result<Link, String> {
    driveset_link::open(&bus.port, &OpenOptions::default()).map_err(|e| e.to_string())
}

/// What a line run does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Upload what differs and verify.
    Commission,
    /// Read only: compare every drive with its set.
    Status,
}

/// One drive done (for progress output).
#[derive(Debug, Clone)]
pub struct Progress {
    /// Bus name.
    pub bus: String,
    /// Drives of this bus done so far (this one included).
    pub done: usize,
    /// Selected drives on this bus.
    pub total: usize,
    /// The drive's report.
    pub drive: DriveReport,
}

/// A progress callback.
pub type ProgressFn = Arc<dyn Fn(&Progress) + Send + Sync>;

/// Options of a line run.
#[derive(Clone)]
pub struct LineOptions {
    /// Drive (or bus) names to do; empty: all.
    pub only: Vec<String>,
    /// Drive (or bus) names to leave out.
    pub skip: Vec<String>,
    /// Label for the report.
    pub label: Option<String>,
    /// Where the report and the state file go.
    pub report_dir: PathBuf,
    /// Wall-clock time, git, the state and learned-schema files.
    pub env: Arc<dyn Environment>,
    /// Told the phases and steps of every drive's work.
    pub observer: Option<Arc<dyn LineObserver>>,
    /// Where the upload journals go.
    pub journal_dir: PathBuf,
    /// Passed to every upload (each lifts one refusal; see
    /// [`crate::overrides`]).
    pub overrides: Overrides,
    /// Broadcast the values common to the drives: LECOM MULTICAST per
    /// group, LUSTBUS SELECT to address 31 inside every MC dataset
    /// download (module docs, "Broadcast").
    pub broadcast_common: bool,
    /// Ignore the state file (commission every drive again).
    pub fresh: bool,
    /// Test hook: every bus stops after this many drives, as if the run had
    /// been killed there.
    pub stop_after: Option<usize>,
    /// Called after every drive.
    pub progress: Option<ProgressFn>,
    /// How drives whose set's schema lacks facts are learned (module
    /// docs); `None`: such drives fail.
    pub learn: Option<LineLearn>,
}

/// How a line run learns the schema of a drive whose set names a built-in
/// schema that lacks facts (module docs, "Learning the schema").
#[derive(Debug, Clone)]
pub struct LineLearn {
    /// Holds the built-in schemas the learned ones extend.
    pub registry: Registry,
    /// Where `commission` writes learned schemas (`<id>.toml`) and where
    /// `status` looks for them.
    pub schema_dir: PathBuf,
    /// Layout and type-character overrides (`status` forces `no_texts`).
    pub options: LearnOptions,
}

impl std::fmt::Debug for LineOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LineOptions")
            .field("only", &self.only)
            .field("skip", &self.skip)
            .field("report_dir", &self.report_dir)
            .field("stop_after", &self.stop_after)
            .finish_non_exhaustive()
    }
}

impl LineOptions {
    /// Defaults: everything selected, report in `report_dir`, journals in
    /// `report_dir/journals`, the world through `env`.
    pub fn new(report_dir: impl Into<PathBuf>, env: Arc<dyn Environment>) -> Self {
        let report_dir = report_dir.into();
        LineOptions {
            env,
            observer: None,
            only: Vec::new(),
            skip: Vec::new(),
            label: None,
            journal_dir: report_dir.join("journals"),
            report_dir,
            overrides: Overrides::none(),
            broadcast_common: false,
            fresh: false,
            stop_after: None,
            progress: None,
            learn: None,
        }
    }
}

/// A run that could not start.
#[derive(Debug, thiserror::Error)]
pub enum LineError {
    /// `--only` / `--skip` name something the manifest does not have.
    #[error("{0}")]
    Selection(String),
    /// The report directory or the state file cannot be used.
    #[error("{0}")]
    Io(String),
}

/// The result of a line run.
#[derive(Debug, Clone)]
pub struct LineOutcome {
    /// The report.
    pub report: LineReport,
    /// Whether a bus failed (exit 3).
    pub bus_failure: bool,
    /// Notes (broadcast fallbacks, state file trouble).
    pub warnings: Vec<String>,
}

impl LineOutcome {
    /// The run in one word (module docs).
    pub fn verdict(&self) -> Verdict {
        if self.bus_failure {
            Verdict::BusFailed
        } else if self.report.result == LineResult::Ok {
            Verdict::Holds
        } else {
            Verdict::Differs
        }
    }

    /// The slowest bus's time (ms on its clock): the line's time, as buses
    /// run in parallel.
    pub fn line_ms(&self) -> f64 {
        self.report
            .buses
            .iter()
            .map(|b| b.elapsed_ms)
            .fold(0.0, f64::max)
    }
}

/// The resume state (the file [`STATE_FILE`]).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CommissionState {
    /// [`STATE_VERSION`].
    pub state_version: u32,
    /// Line name.
    pub line: String,
    /// Drives that held their set, by `BUS/ADDRESS`.
    pub drives: BTreeMap<String, StateEntry>,
}

/// One drive in the resume state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateEntry {
    /// Drive name.
    pub name: String,
    /// Port of its bus.
    pub port: String,
    /// Set file as the manifest gives it.
    pub set: String,
    /// Fingerprint of the set at the time.
    pub set_fingerprint: String,
    /// Fingerprint read back from the drive.
    pub fingerprint: String,
    /// When (RFC 3339 UTC, milliseconds: [`crate::env::rfc3339`]).
    pub verified_at: String,
}

impl CommissionState {
    /// Read the state file of `report_dir` through `env` (empty if there
    /// is none).
    pub fn load(env: &dyn Environment, report_dir: &Path) -> Result<Self, String> {
        let path = report_dir.join(STATE_FILE);
        match env.read_file(&path) {
            Ok(Some(text)) => serde_json::from_str(&text).map_err(|e| {
                format!(
                    "state file {}: {e}; delete it (or pass --fresh) to commission every drive again",
                    path.display()
                )
            }),
            Ok(None) => Ok(Self::default()),
            Err(e) => Err(format!("state file {}: {e}", path.display())),
        }
    }

    /// Write it through `env` (atomically: [`Environment::write_file`]).
    pub fn save(&self, env: &dyn Environment, report_dir: &Path) -> Result<(), String> {
        let path = report_dir.join(STATE_FILE);
        let text = serde_json::to_string_pretty(self).map_err(|e| e.to_string())?;
        env.write_file(&path, &(text + "\n"))
            .map_err(|e| format!("state file {}: {e}", path.display()))
    }
}

fn state_key(bus: &str, address: u8) -> String {
    format!("{bus}/{address}")
}

/// Commission the line (module docs).
pub fn commission(
    manifest: &Manifest,
    opts: &LineOptions,
    opener: &Opener<'_>,
) -> Result<LineOutcome, LineError> {
    run_line(manifest, opts, opener, Mode::Commission)
}

/// Run the line in `mode`.
pub fn run_line(
    manifest: &Manifest,
    opts: &LineOptions,
    opener: &Opener<'_>,
    mode: Mode,
) -> Result<LineOutcome, LineError> {
    let env = &*opts.env;
    let started = rfc3339(env.now_utc());
    let selected = select(manifest, opts)?;
    env.create_dir(&opts.report_dir).map_err(|e| {
        LineError::Io(format!(
            "cannot create the report directory {}: {e}",
            opts.report_dir.display()
        ))
    })?;
    let mut warnings = Vec::new();
    let state = if mode == Mode::Commission {
        // the one way to create a journal directory: it keeps itself out of
        // git with its own .gitignore, as upload's does
        crate::journal::ensure_dir(&opts.journal_dir).map_err(|e| LineError::Io(e.to_string()))?;
        let mut s = if opts.fresh {
            CommissionState::default()
        } else {
            CommissionState::load(env, &opts.report_dir).map_err(LineError::Io)?
        };
        if s.line != manifest.name {
            s.drives.clear();
        }
        s.state_version = STATE_VERSION;
        s.line = manifest.name.clone();
        Some(Mutex::new(s))
    } else {
        None
    };
    let ctx = Ctx {
        opts,
        mode,
        state: state.as_ref(),
        warnings: Mutex::new(Vec::new()),
    };

    // the manifest's address is the truth: refused before the bus is opened
    let mut refused = super::address_truth::refuse_line(manifest, &selected);
    let results: Vec<BusRun> = std::thread::scope(|scope| {
        let handles: Vec<_> = manifest
            .buses
            .iter()
            .enumerate()
            .map(|(bi, bus)| {
                let listed: Vec<&Drive> = manifest
                    .drives
                    .iter()
                    .filter(|d| d.bus_index == bi)
                    .collect();
                let drives: Vec<&Drive> = listed
                    .iter()
                    .filter(|d| selected.contains(&d.name) && !refused.contains_key(&d.name))
                    .copied()
                    .collect();
                let ctx = &ctx;
                scope.spawn(move || run_bus(bus, &drives, &listed, ctx, opener))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a bus thread panicked"))
            .collect()
    });

    warnings.extend(
        ctx.warnings
            .into_inner()
            .unwrap_or_else(PoisonError::into_inner),
    );
    let mut by_drive: BTreeMap<String, DriveReport> = BTreeMap::new();
    let mut buses = Vec::new();
    let mut bus_failure = false;
    for r in results {
        bus_failure |= r.failed;
        for d in r.drives {
            by_drive.insert(d.name.clone(), d);
        }
        buses.push(r.report);
    }
    let drives: Vec<DriveReport> = manifest
        .drives
        .iter()
        .map(|d| {
            by_drive
                .remove(&d.name)
                .or_else(|| refused.remove(&d.name))
                .unwrap_or_else(|| {
                    blank_report(d, &manifest.buses[d.bus_index], DriveResult::NotSelected)
                })
        })
        .collect();
    let result = line_result(&drives);
    let dir = manifest.path.parent().unwrap_or(Path::new("."));
    let report = LineReport {
        report_version: REPORT_VERSION,
        command: match mode {
            Mode::Commission => "commission".into(),
            Mode::Status => "status".into(),
        },
        line: manifest.name.clone(),
        manifest: manifest.path.display().to_string(),
        label: opts.label.clone().or_else(|| manifest.label.clone()),
        started,
        finished: rfc3339(env.now_utc()),
        git: env.git_info(dir),
        result,
        buses,
        drives,
    };
    Ok(LineOutcome {
        report,
        bus_failure,
        warnings,
    })
}

fn line_result(drives: &[DriveReport]) -> LineResult {
    let mut r = LineResult::Ok;
    for d in drives {
        match d.result {
            DriveResult::Verified
            | DriveResult::Unchanged
            | DriveResult::AlreadyVerified
            | DriveResult::NotSelected => {}
            DriveResult::Drift => {
                if r == LineResult::Ok {
                    r = LineResult::Drift;
                }
            }
            DriveResult::RolledBack | DriveResult::Failed => r = LineResult::Failed,
        }
    }
    r
}

/// The drive names `--only` / `--skip` select (names of drives or buses).
fn select(manifest: &Manifest, opts: &LineOptions) -> Result<BTreeSet<String>, LineError> {
    let known = |n: &str| {
        manifest.drives.iter().any(|d| d.name == n) || manifest.buses.iter().any(|b| b.name == n)
    };
    for n in opts.only.iter().chain(&opts.skip) {
        if !known(n) {
            let names: Vec<&str> = manifest.drives.iter().map(|d| d.name.as_str()).collect();
            return Err(LineError::Selection(format!(
                "no drive or bus is named `{n}` in {}; drives: {}",
                manifest.path.display(),
                names.join(", ")
            )));
        }
    }
    let hit = |list: &[String], d: &Drive| list.iter().any(|n| *n == d.name || *n == d.bus);
    Ok(manifest
        .drives
        .iter()
        .filter(|d| (opts.only.is_empty() || hit(&opts.only, d)) && !hit(&opts.skip, d))
        .map(|d| d.name.clone())
        .collect())
}

struct Ctx<'a> {
    opts: &'a LineOptions,
    mode: Mode,
    state: Option<&'a Mutex<CommissionState>>,
    warnings: Mutex<Vec<String>>,
}

impl Ctx<'_> {
    fn warn(&self, w: String) {
        self.warnings
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(w);
    }

    fn recorded(&self, bus: &Bus, d: &Drive) -> Option<StateEntry> {
        let s = self.state?.lock().unwrap_or_else(PoisonError::into_inner);
        s.drives.get(&state_key(&bus.name, d.address)).cloned()
    }

    fn record(&self, bus: &Bus, d: &Drive, fingerprint: Option<&str>) {
        let Some(state) = self.state else { return };
        let mut s = state.lock().unwrap_or_else(PoisonError::into_inner);
        let key = state_key(&bus.name, d.address);
        match fingerprint {
            Some(fp) => {
                s.drives.insert(
                    key,
                    StateEntry {
                        name: d.name.clone(),
                        port: bus.port_name.clone(),
                        set: d.set_text.clone(),
                        set_fingerprint: d.set.fingerprint(),
                        fingerprint: fp.to_string(),
                        verified_at: rfc3339(self.opts.env.now_utc()),
                    },
                );
            }
            None => {
                if s.drives.remove(&key).is_none() {
                    return;
                }
            }
        }
        if let Err(e) = s.save(&*self.opts.env, &self.opts.report_dir) {
            drop(s);
            self.warn(e);
        }
    }
}

struct BusRun {
    report: BusReport,
    drives: Vec<DriveReport>,
    failed: bool,
}

pub(super) fn blank_report(d: &Drive, bus: &Bus, result: DriveResult) -> DriveReport {
    DriveReport {
        name: d.name.clone(),
        position: d.position.clone(),
        bus: bus.name.clone(),
        address: d.address,
        set: d.set_text.clone(),
        schema: d.schema.id.clone(),
        identity: Vec::new(),
        set_fingerprint: d.set.fingerprint(),
        fingerprint_before: None,
        fingerprint_after: None,
        codes_written: 0,
        retries: 0,
        telegrams: 0,
        elapsed_ms: 0.0,
        result,
        error: None,
        diff: Vec::new(),
        learned_schema: None,
        factory_settings: false,
        replacement: None,
    }
}

fn link_now(link: &Link) -> Instant {
    match link {
        Link::Bytes(b) => b.clock().now(),
        Link::Frames(f) => f.clock().now(),
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

fn since(start: Instant, at: Instant) -> f64 {
    ms(at.saturating_duration_since(start))
}

fn run_bus(
    bus: &Bus,
    drives: &[&Drive],
    listed: &[&Drive],
    ctx: &Ctx<'_>,
    opener: &Opener<'_>,
) -> BusRun {
    let mut report = BusReport {
        name: bus.name.clone(),
        port: bus.port_name.clone(),
        protocol: bus.protocol,
        rate: bus.rate,
        elapsed_ms: 0.0,
        timeline: Vec::new(),
    };
    let mut out = Vec::new();
    if drives.is_empty() {
        return BusRun {
            report,
            drives: out,
            failed: false,
        };
    }
    let total = drives.len();
    if let Some(o) = &ctx.opts.observer {
        o.bus(&bus.name, total);
    }
    let progress = |done: usize, d: &DriveReport| {
        if let Some(p) = &ctx.opts.progress {
            p(&Progress {
                bus: bus.name.clone(),
                done,
                total,
                drive: d.clone(),
            });
        }
    };
    let mut link = match opener(bus) {
        Ok(l) => l,
        Err(e) => {
            for (i, d) in drives.iter().enumerate() {
                let mut r = blank_report(d, bus, DriveResult::Failed);
                r.error = Some(format!(
                    "bus `{}` ({}) could not be opened: {e}",
                    bus.name, bus.port_name
                ));
                progress(i + 1, &r);
                out.push(r);
            }
            return BusRun {
                report,
                drives: out,
                failed: true,
            };
        }
    };
    let start = link_now(&link);
    let mut failed = false;
    let mut dead: Option<String> = None;
    if ctx.mode == Mode::Commission && ctx.opts.broadcast_common {
        if bus.protocol == BusProtocol::Lustbus {
            let refusal = match bus.transfer_baud {
                // the broadcast path runs every drive at the bus's rate
                Some(rate) => Some(format!(
                    "the bus has transfer_baud = {rate}, and a broadcast needs every drive of the bus at one rate (each MC drive is switched on its own)"
                )),
                None => lustbus_broadcast_refusal(drives, listed, &link, ctx),
            };
            match refusal {
                // the kill test hook runs drive by drive
                None if ctx.opts.stop_after.is_none() => {
                    let (out, failed) = run_lustbus_broadcast(
                        bus,
                        drives,
                        &mut link,
                        start,
                        &mut report,
                        ctx,
                        &progress,
                    );
                    report.elapsed_ms = since(start, link_now(&link));
                    return BusRun {
                        report,
                        drives: out,
                        failed,
                    };
                }
                None => {}
                Some(why) => ctx.warn(format!(
                    "bus `{}`: no broadcast (address 31): {why}; values were written drive by drive",
                    bus.name
                )),
            }
        } else {
            broadcast_common(bus, drives, &mut link, start, &mut report, ctx);
        }
    }
    for (i, d) in drives.iter().enumerate() {
        if let Some(why) = &dead {
            let mut r = blank_report(d, bus, DriveResult::Failed);
            r.error = Some(why.clone());
            progress(i + 1, &r);
            out.push(r);
            continue;
        }
        if ctx.opts.stop_after.is_some_and(|n| i >= n) {
            failed = true;
            let why = format!(
                "not reached: the run stopped after {} drive(s) on bus `{}` (--stop-after); run the command again to resume",
                i, bus.name
            );
            dead = Some(why.clone());
            let mut r = blank_report(d, bus, DriveResult::Failed);
            r.error = Some(why);
            progress(i + 1, &r);
            out.push(r);
            continue;
        }
        let (r, spans, link_failed) = run_drive(bus, d, &mut link, ctx);
        // zero-length spans (planning, journal writes on a virtual clock)
        // would draw nothing
        for (phase, s, e) in spans.into_iter().filter(|(_, s, e)| s != e) {
            report.timeline.push(TimelineEntry {
                drive: d.name.clone(),
                phase,
                start_ms: since(start, s),
                end_ms: since(start, e),
            });
        }
        if let Some(kind) = link_failed {
            failed = true;
            if kind == Failure::Link {
                dead = Some(format!(
                    "not reached: the link of bus `{}` failed at drive `{}`",
                    bus.name, d.name
                ));
            }
        }
        progress(i + 1, &r);
        out.push(r);
    }
    report.elapsed_ms = since(start, link_now(&link));
    BusRun {
        report,
        drives: out,
        failed,
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Failure {
    /// The link is gone: stop the bus.
    Link,
    /// This drive did not answer: go on with the next.
    NoAnswer,
}

fn failure_of(e: &EngineError) -> Option<Failure> {
    match &*e.kind {
        ErrorKind::Link(_) => Some(Failure::Link),
        ErrorKind::NoAnswer { .. } => Some(Failure::NoAnswer),
        ErrorKind::RolledBack { cause, .. } => failure_of(cause),
        _ => None,
    }
}

type Span = (Phase, Instant, Instant);

/// The observer of one drive's work: keeps its spans for the timeline and
/// passes every event on to the line's observer.
struct DriveWatch {
    spans: Spans,
    line: Option<(Arc<dyn LineObserver>, String, String)>,
}

impl Observer for DriveWatch {
    fn event(&self, at: Instant, event: Event) {
        self.spans.event(at, event);
        if let Some((o, bus, drive)) = &self.line {
            o.event(bus, drive, at, event);
        }
    }
}

fn link_clock(link: &Link) -> &dyn driveset_link::Clock {
    match link {
        Link::Bytes(b) => b.clock(),
        Link::Frames(f) => f.clock(),
    }
}

fn run_drive(
    bus: &Bus,
    d: &Drive,
    link: &mut Link,
    ctx: &Ctx<'_>,
) -> (DriveReport, Vec<Span>, Option<Failure>) {
    let t0 = link_now(link);
    let watch = Arc::new(DriveWatch {
        spans: Spans::new(),
        line: ctx
            .opts
            .observer
            .clone()
            .map(|o| (o, bus.name.clone(), d.name.clone())),
    });
    let hook = Hook::new(watch.clone());
    let learned_drive;
    let mut learned_report = None;
    let d = match &d.learn_from {
        None => d,
        Some(base) => {
            hook.enter(link_clock(link), Phase::Learn, None);
            let got = learn_drive(bus, d, base, link, ctx);
            match got {
                Ok((nd, rep)) => {
                    learned_drive = nd;
                    learned_report = Some(rep);
                    &learned_drive
                }
                Err((e, failure)) => {
                    let mut r = blank_report(d, bus, DriveResult::Failed);
                    r.error = Some(e);
                    r.elapsed_ms = since(t0, link_now(link));
                    if ctx.mode == Mode::Commission {
                        ctx.record(bus, d, None);
                    }
                    hook.end(link_clock(link));
                    return (r, watch.spans.spans(), failure);
                }
            }
        }
    };
    let mut r = blank_report(d, bus, DriveResult::Failed);
    r.learned_schema = learned_report;
    if r.learned_schema.is_some()
        && let Err(e) = super::address_truth::check_drive(bus, d)
    {
        r.error = Some(e.to_string());
        if ctx.mode == Mode::Commission {
            ctx.record(bus, d, None);
        }
        hook.end(link_clock(link));
        return (r, watch.spans.spans(), None);
    }
    let mut client = match crate::connect::connect_on(link, d.schema.clone(), d.address) {
        Ok(c) => c,
        Err(e) => {
            r.error = Some(e.to_string());
            return (r, watch.spans.spans(), None);
        }
    };
    let stats0 = client.stats();
    let set_fp = d.set.fingerprint();
    let mut recovered: Vec<String> = Vec::new();
    let mut failure = None;
    let journal_path = default_journal_path(&ctx.opts.journal_dir, &*client);
    let outcome: Result<(), EngineError> = (|| {
        // A drive with an unfinished journal is not done (module docs,
        // "Unfinished journals"): status reports it failed, commission
        // recovers it first.
        let unfinished = crate::journal::unfinished_for(
            &ctx.opts.journal_dir,
            &client.bus_id(),
            &client.target().port,
            d.address,
        )?;
        if !unfinished.is_empty() && ctx.mode == Mode::Status {
            let list: Vec<String> = unfinished
                .iter()
                .map(|u| format!("{} (state {})", u.path.display(), u.journal.state.as_str()))
                .collect();
            return Err(EngineError::journal(
                unfinished[0].path.display().to_string(),
                format!(
                    "the drive at {} has an unfinished transaction ({}); its values are not trusted. Run `driveset commission` (it recovers the journal first) or `driveset recover {}`",
                    client.target(),
                    list.join(", "),
                    unfinished[0].path.display()
                ),
            ));
        }
        if !unfinished.is_empty() {
            hook.enter(client.clock(), Phase::Recover, None);
        }
        for u in &unfinished {
            let rep = recover(&mut *client, &u.path, &RecoverOptions::default()).map_err(|e| {
                EngineError::journal(u.path.display().to_string(), format!(
                        "the drive has an unfinished transaction from an earlier run, and recovering it failed: {e}"
                    ))
            })?;
            let did = match rep.action {
                RecoverAction::Completed => "completed (the drive held the new values)",
                RecoverAction::RolledBack => "rolled back (old values restored)",
                RecoverAction::Nothing => "already settled",
            };
            recovered.push(format!(
                "{}: recovered the unfinished journal {} of an earlier run: {did}",
                d.name,
                u.path.display()
            ));
        }
        match ctx.mode {
            Mode::Status => {
                hook.enter(client.clock(), Phase::Identify, None);
                let id = check_family(&mut *client)?;
                r.identity = id.pairs();
                hook.enter(client.clock(), Phase::Read, Some(d.set.values.len()));
                let live = live_values(&mut *client, &d.set)?;
                let fp = live.fingerprint();
                r.diff = diff_lines(&d.schema, &live, &d.set);
                r.factory_settings =
                    super::factory::live_at_factory_settings(&d.schema, &live, &d.set);
                // values, not fingerprints: a fingerprint does not cover a
                // secret's value, a drifted password is drift too
                r.result = if live.values == d.set.values {
                    DriveResult::Unchanged
                } else {
                    DriveResult::Drift
                };
                r.fingerprint_before = Some(fp.clone());
                r.fingerprint_after = Some(fp);
                Ok(())
            }
            Mode::Commission => {
                if recovered.is_empty()
                    && still_holds(&mut *client, bus, d, &set_fp, &mut r, &hook, ctx)?
                {
                    return Ok(());
                }
                let mut uo = UploadOptions::new(&journal_path);
                uo.overrides = ctx.opts.overrides;
                let transfer = bus
                    .transfer_baud
                    .filter(|_| d.schema.family.descriptor().line_rates.online.is_some())
                    .map(|rate| {
                        let mut others = bus.families.clone();
                        if let Some(i) = others.iter().position(|f| *f == d.schema.family) {
                            others.remove(i);
                        }
                        crate::transfer::TransferRequest {
                            rate,
                            others,
                            allow_shared: ctx.opts.overrides.allow_shared_transfer_baud,
                        }
                    });
                uo.observer = hook.clone();
                let result = match &transfer {
                    Some(req) => crate::transfer::upload(&mut *client, &d.set, &uo, req),
                    None => upload(&mut *client, &d.set, &uo),
                };
                if let Some(t) = result.as_ref().map_or_else(
                    |f| f.report.as_ref().and_then(|r| r.transfer.clone()),
                    |r| r.transfer.clone(),
                ) {
                    ctx.warn(format!("{}: {}", d.name, t.decision.summary()));
                }
                match result {
                    Ok(rep) => {
                        fill_from_upload(&mut r, &d.schema, &rep.identity, &rep.codes);
                        r.fingerprint_before = Some(rep.fingerprint_before.clone());
                        r.fingerprint_after = rep.fingerprint_after.clone();
                        r.codes_written = rep.codes_written as u32;
                        // a recovered journal changed the drive: never "unchanged"
                        r.result = if rep.codes_written == 0 && recovered.is_empty() {
                            DriveResult::Unchanged
                        } else {
                            DriveResult::Verified
                        };
                        Ok(())
                    }
                    Err(f) => {
                        if let Some(rep) = &f.report {
                            fill_from_upload(&mut r, &d.schema, &rep.identity, &rep.codes);
                            r.fingerprint_before = Some(rep.fingerprint_before.clone());
                            r.fingerprint_after = rep.fingerprint_after.clone();
                            r.codes_written = rep.codes_written as u32;
                        }
                        let e = *f.error;
                        if matches!(*e.kind, ErrorKind::RolledBack { .. }) {
                            r.result = DriveResult::RolledBack;
                        }
                        Err(e)
                    }
                }
            }
        }
    })();
    for w in recovered {
        ctx.warn(w);
    }
    if let Err(e) = outcome {
        failure = failure_of(&e);
        if r.result != DriveResult::RolledBack {
            r.result = DriveResult::Failed;
        }
        r.error = Some(e.to_string());
    }
    let _ = client.finish();
    let stats = client.stats();
    r.telegrams = stats.telegrams.saturating_sub(stats0.telegrams);
    r.retries = stats.retries.saturating_sub(stats0.retries);
    let t1 = client.clock().now();
    r.elapsed_ms = since(t0, t1);
    hook.end(client.clock());
    let spans = watch.spans.spans();
    if ctx.mode == Mode::Commission {
        record_drive(bus, d, &r, ctx);
    }
    (r, spans, failure)
}

/// Learns the schema of drive `d` (whose set names `base`, a built-in
/// schema that lacks facts) over the bus's link and resolves its set
/// against it (module docs, "Learning the schema"). Returns the drive as
/// the run then treats it, or the error text and what kind of failure it
/// was.
fn learn_drive(
    bus: &Bus,
    d: &Drive,
    base: &Arc<Schema>,
    link: &mut Link,
    ctx: &Ctx<'_>,
) -> Result<(Drive, LearnedSchemaReport), (String, Option<Failure>)> {
    let what = format!(
        "drive `{}` ({} address {})",
        d.name, bus.port_name, d.address
    );
    let Some(cfg) = &ctx.opts.learn else {
        return Err((
            format!(
                "{what}: set `{}` names `{}`, which lacks facts (types, kinds, ranges) the drive's descriptions give, and learning is off (--no-learn); name a learned schema in the set (`driveset schema pull`)",
                d.set_text, base.id
            ),
            None,
        ));
    };
    let Link::Bytes(b) = link else {
        return Err((
            format!(
                "{what}: `{}` is a LUSTBUS schema, but bus `{}` is a CAN bus",
                base.id, bus.name
            ),
            None,
        ));
    };
    let eng = |e: EngineError| {
        let f = failure_of(&e);
        (
            format!("{what}: learning the schema from the drive's descriptions: {e}"),
            f,
        )
    };
    let mut opts = cfg.options.clone();
    if ctx.mode == Mode::Status {
        // descriptions only: reading texts selects them through 108-STEXT
        opts.no_texts = true;
    }
    let mut client =
        LustbusClient::new(BorrowedByteLink(&mut **b), base.clone(), d.address).map_err(eng)?;
    let identity = client.identify().map_err(eng)?;
    let opts = crate::learn::options_for(base, &opts);
    let mut learned = learn(&mut client, base.family, &opts).map_err(eng)?;
    client.finish().map_err(eng)?;
    let id = learned_id(base.family, &identity, &learned);
    let source = LearnSource {
        drive: format!("{} address {}", bus.port_name, d.address),
        identity,
    };
    let path = cfg.schema_dir.join(format!("{id}.toml"));
    let input = |e: String| (format!("{what}: {e}"), None);
    let mut registry = cfg.registry.clone();
    let env = &*ctx.opts.env;
    let earlier = if ctx.mode == Mode::Status {
        env.read_file(&path)
            .map_err(|e| input(format!("cannot read {}: {e}", path.display())))?
    } else {
        None
    };
    let (schema, file, codes) = if let Some(text) = earlier {
        // the file an earlier commission wrote for these very descriptions
        let schema = registry
            .add_source(SourceFile::new(path.display().to_string(), text))
            .map_err(|e| input(format!("learned schema {}: {}", path.display(), e.message)))?;
        let codes = learned.codes.len();
        (schema, Some(path.display().to_string()), codes)
    } else {
        let rendered = render_schema(&mut learned, base, &id, &source, &registry).map_err(input)?;
        let file = if ctx.mode == Mode::Commission {
            env.create_dir(&cfg.schema_dir)
                .map_err(|e| input(format!("cannot create {}: {e}", cfg.schema_dir.display())))?;
            env.write_file(&path, &rendered.text)
                .map_err(|e| input(format!("cannot write {}: {e}", path.display())))?;
            Some(path.display().to_string())
        } else {
            None
        };
        (rendered.schema, file, rendered.codes)
    };
    registry.insert_as(&base.id, schema.clone());
    let loaded = load_set(&d.set_path, &mut registry)
        .map_err(|e| input(format!("set {}: {}", d.set_path.display(), e.message)))?;
    let resolved = match (loaded.findings.is_empty(), loaded.resolved) {
        (true, Some(set)) => set,
        _ => {
            let list: Vec<String> = loaded.findings.iter().map(|f| f.to_string()).collect();
            let hint = if ctx.mode == Mode::Status && file.is_none() {
                format!(
                    "; status reads no substitution texts and found no learned file {} (run `driveset commission` first, whose file status then uses, or give --schema-dir where it is)",
                    path.display()
                )
            } else {
                String::new()
            };
            return Err(input(format!(
                "set `{}` does not fit the schema learned from the drive ({id}): {}; fix the set (`driveset validate {}` after naming the learned schema){hint}",
                d.set_text,
                list.join("; "),
                d.set_path.display()
            )));
        }
    };
    let report = LearnedSchemaReport {
        id: schema.id.clone(),
        base: base.id.clone(),
        file,
        codes,
        texts: !opts.no_texts,
        findings: learned.findings.len(),
    };
    let drive = Drive {
        schema,
        set: resolved,
        set_bus_codes: loaded.bus_codes,
        ..d.clone()
    };
    Ok((drive, report))
}

pub(super) fn fill_from_upload(
    r: &mut DriveReport,
    schema: &Schema,
    identity: &Identity,
    codes: &[crate::upload::CodeReport],
) {
    r.identity = identity.pairs();
    r.factory_settings = super::factory::upload_at_factory_settings(schema, codes);
    r.diff = codes
        .iter()
        .filter(|c| c.outcome != crate::upload::CodeOutcome::Unchanged)
        .map(|c| DiffLine {
            code: schema.display_code(c.number, c.subcode),
            name: schema
                .code(c.number)
                .map(|x| x.name.clone())
                .unwrap_or_default(),
            kind: "changed".into(),
            old: Some(c.old.clone()),
            new: Some(c.new.clone()),
        })
        .collect();
}

/// The semantic diff drive -> set as report lines.
pub fn diff_lines(schema: &Schema, live: &ResolvedSet, set: &ResolvedSet) -> Vec<DiffLine> {
    let Ok(d) = driveset_schema::diff(live, set, schema) else {
        return Vec::new();
    };
    d.entries
        .iter()
        .map(|e| DiffLine {
            code: schema.display_code(e.key.number, e.key.subcode),
            name: schema
                .code(e.key.number)
                .map(|x| x.name.clone())
                .unwrap_or_default(),
            kind: match e.kind {
                DiffKind::Added => "added",
                DiffKind::Removed => "removed",
                DiffKind::Changed => "changed",
            }
            .into(),
            old: e.old.as_ref().map(|v| value_text(schema, e.key, v)),
            new: e.new.as_ref().map(|v| value_text(schema, e.key, v)),
        })
        .collect()
}

/// LECOM MULTICAST of the values common to every selected drive of a group.
fn broadcast_common(
    bus: &Bus,
    drives: &[&Drive],
    link: &mut Link,
    start: Instant,
    report: &mut BusReport,
    ctx: &Ctx<'_>,
) {
    if bus.protocol != BusProtocol::Lecom {
        ctx.warn(format!(
            "bus `{}` ({}): --broadcast-common is done on LECOM and LUSTBUS buses only (the engine's {} client has no broadcast); values were written drive by drive",
            bus.name, bus.protocol, bus.protocol
        ));
        return;
    }
    let mut groups: BTreeMap<u8, Vec<&Drive>> = BTreeMap::new();
    for d in drives {
        if d.address >= 10 {
            groups.entry(d.address / 10).or_default().push(d);
        }
    }
    for (tens, members) in groups {
        if members.len() < 2 || members.iter().any(|m| m.schema.id != members[0].schema.id) {
            continue;
        }
        let common: Vec<(CodeKey, RawValue)> = members[0]
            .set
            .values
            .iter()
            // never the station address or the baud rate
            .filter(|(k, _)| {
                !matches!(
                    members[0].schema.role_of(k.number),
                    Some(Role::BusAddress | Role::BaudRate)
                )
            })
            .filter(|(k, v)| members[1..].iter().all(|m| m.set.values.get(k) == Some(v)))
            .map(|(k, v)| (*k, v.clone()))
            .collect();
        if common.is_empty() {
            continue;
        }
        let schema = members[0].schema.clone();
        let t0 = link_now(link);
        let Link::Bytes(b) = link else { return };
        // a MULTICAST reaches every drive of the group: none may hold an
        // unfinished journal (each is recovered first, drive by drive)
        let (bus_id, port) = (b.bus_id(), b.port().to_string());
        let open: Vec<String> = (tens * 10..=tens * 10 + 9)
            .flat_map(|a| {
                crate::journal::unfinished_for(&ctx.opts.journal_dir, &bus_id, &port, a)
                    .unwrap_or_default()
            })
            .map(|u| u.path.display().to_string())
            .collect();
        if !open.is_empty() {
            ctx.warn(format!(
                "bus `{}` group {tens}0: no MULTICAST while the group has unfinished journals ({}); values were written drive by drive after recovery",
                bus.name,
                open.join(", ")
            ));
            continue;
        }
        // refuse while a member runs (the per-drive upload would refuse too)
        let mut running = Vec::new();
        for m in &members {
            if let Ok(mut c) =
                LecomClient::new(BorrowedByteLink(&mut **b), schema.clone(), m.address)
                && let Ok(Some(true)) = c.running()
            {
                running.push(m.name.clone());
            }
        }
        if !running.is_empty() && !ctx.opts.overrides.allow_running {
            ctx.warn(format!(
                "bus `{}` group {tens}0: not broadcast, running: {}",
                bus.name,
                running.join(", ")
            ));
            continue;
        }
        let mut c = match LecomClient::new(
            BorrowedByteLink(&mut **b),
            schema.clone(),
            members[0].address,
        ) {
            Ok(c) => c,
            Err(e) => {
                ctx.warn(e.to_string());
                continue;
            }
        };
        for (k, v) in &common {
            if let Err(e) = c.multicast(tens, *k, v) {
                ctx.warn(format!(
                    "bus `{}` group {tens}0: MULTICAST of {} failed: {e}; the drives get it one by one",
                    bus.name,
                    schema.display_code(k.number, k.subcode)
                ));
                break;
            }
        }
        let _ = c.finish();
        let t1 = link_now(link);
        report.timeline.push(TimelineEntry {
            drive: format!("group {tens}0"),
            phase: Phase::Broadcast,
            start_ms: since(start, t0),
            end_ms: since(start, t1),
        });
    }
}

// ---------------------------------------------------------------------------
// LUSTBUS broadcast of common values (module docs, "Broadcast").
// ---------------------------------------------------------------------------

/// The values a LUSTBUS broadcast may carry for `drives` (module docs): the
/// codes every drive's set gives the same value, CardWriteable (staged by
/// the SLOAD dataset), never a numerically compatible code (81..85, 91),
/// never a code with a role, never the handshake code itself.
pub fn lustbus_common_values(drives: &[&Drive]) -> Vec<(CodeKey, RawValue)> {
    let Some(first) = drives.first() else {
        return Vec::new();
    };
    let schema = &first.schema;
    first
        .set
        .values
        .iter()
        .filter(|(k, _)| k.subcode.is_none())
        .filter(|(k, _)| {
            schema
                .code(k.number)
                .is_some_and(|c| crate::client::lustbus::not_broadcast(schema, c).is_none())
        })
        .filter(|(k, v)| drives[1..].iter().all(|m| m.set.values.get(k) == Some(*v)))
        .map(|(k, v)| (*k, v.clone()))
        .collect()
}

/// Why a LUSTBUS bus gets no broadcast, checked before anything is sent;
/// `None`: it may (the values are then chosen per drive after the datasets
/// are open). `listed`: every drive the manifest puts on the bus.
fn lustbus_broadcast_refusal(
    drives: &[&Drive],
    listed: &[&Drive],
    link: &Link,
    ctx: &Ctx<'_>,
) -> Option<String> {
    let vf: Vec<&str> = listed
        .iter()
        .filter(|d| d.schema.family == driveset_schema::Family::Vf1000)
        .map(|d| d.name.as_str())
        .collect();
    if !vf.is_empty() {
        return Some(format!(
            "refused: the bus also has VF1000 drives ({}), which would execute every SELECT to address 31 as a write of their own parameter of that number (LUSTBUS 4.2)",
            vf.join(", ")
        ));
    }
    let left_out: Vec<&str> = listed
        .iter()
        .filter(|d| !drives.iter().any(|s| s.name == d.name))
        .map(|d| d.name.as_str())
        .collect();
    if !left_out.is_empty() {
        return Some(format!(
            "address 31 reaches every device on the bus, and {} are not part of this run (--only / --skip): they would take the values outside any transaction",
            left_out.join(", ")
        ));
    }
    if drives.len() < 2 {
        return Some("fewer than two drives: nothing to share".into());
    }
    if let Some(d) = drives.iter().find(|d| d.learn_from.is_some()) {
        return Some(format!(
            "drive `{}` has its schema learned first; the broadcast needs every drive's schema up front",
            d.name
        ));
    }
    if let Some(d) = drives.iter().find(|d| d.schema.id != drives[0].schema.id) {
        return Some(format!(
            "the drives do not share one schema (`{}` has `{}`, `{}` has `{}`)",
            drives[0].name, drives[0].schema.id, d.name, d.schema.id
        ));
    }
    if drives[0].schema.family != driveset_schema::Family::Mc6000 {
        return Some("broadcasts go into MC6000/7000 dataset downloads only".into());
    }
    let Link::Bytes(b) = link else {
        return Some("not a character line".into());
    };
    // Every address, listed or not: a drive with an unfinished transaction
    // must not take values outside its recovery.
    let (bus_id, port) = (b.bus_id(), b.port().to_string());
    let open: Vec<String> = (0..=30)
        .flat_map(|a| {
            crate::journal::unfinished_for(&ctx.opts.journal_dir, &bus_id, &port, a)
                .unwrap_or_default()
        })
        .map(|u| u.path.display().to_string())
        .collect();
    if !open.is_empty() {
        return Some(format!(
            "the bus has unfinished journals ({}); they are recovered drive by drive first",
            open.join(", ")
        ));
    }
    if lustbus_common_values(drives).is_empty() {
        return Some("the drives share no CardWriteable value".into());
    }
    None
}

/// A drive of a broadcast bus between its two halves.
struct Parked<'d> {
    d: &'d Drive,
    tx: Transaction,
    /// The transaction opened a dataset download.
    dataset: bool,
    r: DriveReport,
    spans: Vec<Span>,
    telegrams: u64,
    retries: u64,
    /// Bus time this drive's own exchanges took so far.
    own: Duration,
}

/// What became of a drive in the first half.
enum FirstHalf<'d> {
    /// Done (unchanged, already verified, refused, failed).
    Done(Box<DriveReport>, Vec<Span>, Option<Failure>),
    /// Its transaction waits (dataset open, or nothing to stage).
    Parked(Box<Parked<'d>>),
}

/// The resume check ([module docs](self)): a drive the state file records
/// as verified at its set's fingerprint, on this port, is identified and
/// its set's codes read once. `true`: it still holds its set (`r` says
/// [`DriveResult::AlreadyVerified`]); `false`: commission it (a warning
/// says why when the record was there).
fn still_holds(
    client: &mut dyn DriveClient,
    bus: &Bus,
    d: &Drive,
    set_fp: &str,
    r: &mut DriveReport,
    hook: &Hook,
    ctx: &Ctx<'_>,
) -> Result<bool, EngineError> {
    let Some(rec) = ctx.recorded(bus, d) else {
        return Ok(false);
    };
    if rec.set_fingerprint != set_fp || rec.port != bus.port_name {
        return Ok(false);
    }
    hook.enter(client.clock(), Phase::Identify, None);
    let id = check_family(&mut *client)?;
    r.identity = id.pairs();
    hook.enter(client.clock(), Phase::Read, Some(d.set.values.len()));
    let live = live_values(&mut *client, &d.set)?;
    let fp = live.fingerprint();
    if live.values == d.set.values {
        r.result = DriveResult::AlreadyVerified;
        r.fingerprint_before = Some(fp.clone());
        r.fingerprint_after = Some(fp);
        return Ok(true);
    }
    ctx.warn(format!(
        "{}: recorded as verified at {}, but the drive no longer holds its set; commissioning it again",
        d.name, rec.verified_at
    ));
    Ok(false)
}

/// A drive's observer for one part of its work: its spans for the
/// timeline, its events for the line's observer.
fn drive_watch(bus: &Bus, d: &Drive, ctx: &Ctx<'_>) -> (Arc<DriveWatch>, Hook) {
    let watch = Arc::new(DriveWatch {
        spans: Spans::new(),
        line: ctx
            .opts
            .observer
            .clone()
            .map(|o| (o, bus.name.clone(), d.name.clone())),
    });
    let hook = Hook::new(watch.clone());
    (watch, hook)
}

fn lust_client<'l>(
    link: &'l mut Link,
    d: &Drive,
) -> Result<LustbusClient<BorrowedByteLink<'l>>, EngineError> {
    match link {
        Link::Bytes(b) => {
            LustbusClient::new(BorrowedByteLink(&mut **b), d.schema.clone(), d.address)
        }
        Link::Frames(f) => Err(EngineError::refused(
            Target {
                port: f.port().to_string(),
                address: d.address,
            },
            Refusal::LustbusOnCan,
        )),
    }
}

/// The end of a drive's transaction: the upload's outcome into its report,
/// its notes (a broadcast value written on its own ...) into the run's
/// warnings.
fn settle_drive(
    r: &mut DriveReport,
    d: &Drive,
    done: Result<crate::upload::UploadReport, crate::upload::UploadFailure>,
    ctx: &Ctx<'_>,
) -> Option<EngineError> {
    let notes = match &done {
        Ok(rep) => rep.warnings.clone(),
        Err(f) => f
            .report
            .as_ref()
            .map(|r| r.warnings.clone())
            .unwrap_or_default(),
    };
    for w in notes {
        ctx.warn(format!("{}: {w}", d.name));
    }
    match done {
        Ok(rep) => {
            fill_from_upload(r, &d.schema, &rep.identity, &rep.codes);
            r.fingerprint_before = Some(rep.fingerprint_before.clone());
            r.fingerprint_after = rep.fingerprint_after.clone();
            r.codes_written = rep.codes_written as u32;
            // values a broadcast brought count as changed, though no own
            // SELECT wrote them
            let changed = rep
                .codes
                .iter()
                .any(|c| c.outcome != crate::upload::CodeOutcome::Unchanged);
            r.result = if !changed {
                DriveResult::Unchanged
            } else {
                DriveResult::Verified
            };
            None
        }
        Err(f) => {
            if let Some(rep) = &f.report {
                fill_from_upload(r, &d.schema, &rep.identity, &rep.codes);
                r.fingerprint_before = Some(rep.fingerprint_before.clone());
                r.fingerprint_after = rep.fingerprint_after.clone();
                r.codes_written = rep.codes_written as u32;
            }
            let e = *f.error;
            r.result = if matches!(*e.kind, ErrorKind::RolledBack { .. }) {
                DriveResult::RolledBack
            } else {
                DriveResult::Failed
            };
            r.error = Some(e.to_string());
            Some(e)
        }
    }
}

/// Runs a step result to its end: on a stop, roll back or redo (the whole
/// attempt again, as [`crate::upload::upload`] does).
fn drive_to_end(
    tx: &mut Transaction,
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    mut res: Result<(), StepError>,
) -> Result<(), EngineError> {
    loop {
        match res {
            Ok(()) => return Ok(()),
            Err(stop) => match tx.stopped(client, stop) {
                Next::Redo => res = tx.run_attempt(client, set),
                Next::Failed(e) => return Err(e),
            },
        }
    }
}

/// First half of a drive on a broadcast bus: resume check, begin, replan,
/// journal, SLOAD = -1.
fn first_half<'d>(bus: &Bus, d: &'d Drive, link: &mut Link, ctx: &Ctx<'_>) -> FirstHalf<'d> {
    let t0 = link_now(link);
    let mut r = blank_report(d, bus, DriveResult::Failed);
    let journal_dir = &ctx.opts.journal_dir;
    let c = match lust_client(link, d) {
        Ok(c) => c,
        Err(e) => {
            r.error = Some(e.to_string());
            return FirstHalf::Done(Box::new(r), Vec::new(), None);
        }
    };
    let journal_path = default_journal_path(journal_dir, &c);
    let (watch, hook) = drive_watch(bus, d, ctx);
    let mut client: Box<dyn DriveClient + '_> = Box::new(c);
    let mut ended = false;
    let stats0 = client.stats();
    let set_fp = d.set.fingerprint();
    let mut uo = UploadOptions::new(&journal_path);
    uo.overrides = ctx.opts.overrides;
    uo.observer = hook.clone();
    let mut parked_tx = None;
    let outcome: Result<(), EngineError> = (|| {
        if still_holds(&mut *client, bus, d, &set_fp, &mut r, &hook, ctx)? {
            return Ok(());
        }
        let mut tx = Transaction::begin(&mut *client, &d.set, &uo)?;
        let res = (|| {
            if tx.replan(&mut *client, &d.set)? == Replanned::Nothing {
                return Ok(None);
            }
            tx.journal(&mut *client)?;
            tx.open_dataset(&mut *client).map(Some)
        })();
        match res {
            Ok(None) => {
                ended = true;
                let done = tx.finish(&mut *client, &d.set, Ok(()));
                if let Some(e) = settle_drive(&mut r, d, done, ctx) {
                    return Err(e);
                }
                Ok(())
            }
            Ok(Some(dataset)) => {
                parked_tx = Some((tx, dataset));
                Ok(())
            }
            Err(stop) => {
                let end = drive_to_end(&mut tx, &mut *client, &d.set, Err(stop));
                ended = true;
                let done = tx.finish(&mut *client, &d.set, end);
                if let Some(e) = settle_drive(&mut r, d, done, ctx) {
                    return Err(e);
                }
                Ok(())
            }
        }
    })();
    let _ = client.finish();
    let stats = client.stats();
    let telegrams = stats.telegrams.saturating_sub(stats0.telegrams);
    let retries = stats.retries.saturating_sub(stats0.retries);
    let own = client.clock().now().saturating_duration_since(t0);
    if parked_tx.is_none() && !ended {
        hook.end(client.clock());
    }
    // this half's spans, the open one closed now (the drive goes on later)
    watch.spans.event(client.clock().now(), Event::End);
    let spans = watch.spans.spans();
    if let Some((mut tx, dataset)) = parked_tx {
        tx.detach(&*client);
        return FirstHalf::Parked(Box::new(Parked {
            d,
            tx,
            dataset,
            r,
            spans,
            telegrams,
            retries,
            own,
        }));
    }
    let mut failure = None;
    if let Err(e) = outcome {
        failure = failure_of(&e);
        if r.result != DriveResult::RolledBack {
            r.result = DriveResult::Failed;
        }
        if r.error.is_none() {
            r.error = Some(e.to_string());
        }
    }
    r.telegrams = telegrams;
    r.retries = retries;
    r.elapsed_ms = ms(own);
    record_drive(bus, d, &r, ctx);
    FirstHalf::Done(Box::new(r), spans, failure)
}

/// Record in the resume state whether the drive ended holding its set.
fn record_drive(bus: &Bus, d: &Drive, r: &DriveReport, ctx: &Ctx<'_>) {
    let holds = matches!(
        r.result,
        DriveResult::Verified | DriveResult::Unchanged | DriveResult::AlreadyVerified
    );
    ctx.record(
        bus,
        d,
        if holds {
            r.fingerprint_after.as_deref()
        } else {
            None
        },
    );
}

/// The rest of a drive on a broadcast bus, in two calls. `last == false`:
/// resume the dataset download, the drive's own dataset writes, SLOAD = -2
/// (the drive then checks and stores while the others are done); the drive
/// is parked again. `last == true`: poll SLOAD, the writes after the
/// dataset, verify every code, finish. A failure ends the drive at once
/// (roll back, report).
fn next_half<'d>(
    bus: &Bus,
    mut p: Parked<'d>,
    link: &mut Link,
    ctx: &Ctx<'_>,
    last: bool,
) -> FirstHalf<'d> {
    let d = p.d;
    let t0 = link_now(link);
    let mut c = match lust_client(link, d) {
        Ok(c) => c,
        Err(e) => {
            p.r.error = Some(e.to_string());
            return FirstHalf::Done(Box::new(p.r), p.spans, None);
        }
    };
    let resumed = if p.dataset && !last {
        c.resume_dataset().map(Some)
    } else {
        Ok(None)
    };
    let (watch, hook) = drive_watch(bus, d, ctx);
    let mut client: Box<dyn DriveClient + '_> = Box::new(c);
    let stats0 = client.stats();
    let tx = &mut p.tx;
    tx.set_observer(hook);
    tx.attach(&*client);
    let res = match resumed {
        Ok(siof) => {
            if let Some(s) = siof.filter(|s| !s.is_empty()) {
                tx.warn(format!(
                    "SERR read {s} after the broadcast (cleared); every value is read back"
                ));
            }
            (|| {
                if last {
                    tx.await_dataset(&mut *client)?;
                    tx.write_rest(&mut *client)?;
                    tx.verify(&mut *client, &d.set)
                } else {
                    tx.write_dataset(&mut *client)?;
                    tx.end_dataset(&mut *client)
                }
            })()
        }
        Err(e) => Err(StepError::Error(e)),
    };
    let ends = last || res.is_err();
    let done = if ends {
        let end = drive_to_end(tx, &mut *client, &d.set, res);
        Some(end)
    } else {
        None
    };
    let account = |p: &mut Parked<'_>, client: &mut Box<dyn DriveClient + '_>| {
        let _ = client.finish();
        let stats = client.stats();
        p.telegrams += stats.telegrams.saturating_sub(stats0.telegrams);
        p.retries += stats.retries.saturating_sub(stats0.retries);
        p.own += client.clock().now().saturating_duration_since(t0);
        watch.spans.event(client.clock().now(), Event::End);
        p.spans.extend(watch.spans.spans());
    };
    let Some(end) = done else {
        account(&mut p, &mut client);
        p.tx.detach(&*client);
        return FirstHalf::Parked(Box::new(p));
    };
    let Parked {
        tx,
        mut r,
        mut spans,
        mut telegrams,
        mut retries,
        mut own,
        ..
    } = p;
    let finished = tx.finish(&mut *client, &d.set, end);
    let error = settle_drive(&mut r, d, finished, ctx);
    let _ = client.finish();
    let stats = client.stats();
    telegrams += stats.telegrams.saturating_sub(stats0.telegrams);
    retries += stats.retries.saturating_sub(stats0.retries);
    own += client.clock().now().saturating_duration_since(t0);
    spans.extend(watch.spans.spans());
    r.telegrams = telegrams;
    r.retries = retries;
    r.elapsed_ms = ms(own);
    record_drive(bus, d, &r, ctx);
    FirstHalf::Done(Box::new(r), spans, error.as_ref().and_then(failure_of))
}

/// A LUSTBUS bus with `--broadcast-common` (module docs, "Broadcast"):
/// every drive to "dataset open", the common values once to address 31,
/// then every drive to its end.
fn run_lustbus_broadcast(
    bus: &Bus,
    drives: &[&Drive],
    link: &mut Link,
    start: Instant,
    report: &mut BusReport,
    ctx: &Ctx<'_>,
    progress: &dyn Fn(usize, &DriveReport),
) -> (Vec<DriveReport>, bool) {
    let mut done: Vec<Option<DriveReport>> = vec![None; drives.len()];
    let mut count = 0usize;
    let mut failed = false;
    let push_spans = |report: &mut BusReport, name: &str, spans: Vec<Span>| {
        // zero-length spans (planning, journal writes) would draw nothing
        for (phase, s, e) in spans.into_iter().filter(|(_, s, e)| s != e) {
            report.timeline.push(TimelineEntry {
                drive: name.to_string(),
                phase,
                start_ms: since(start, s),
                end_ms: since(start, e),
            });
        }
    };
    let mut parked: Vec<(usize, Parked<'_>)> = Vec::new();
    let mut why_not: Option<String> = None;
    for (i, d) in drives.iter().enumerate() {
        match first_half(bus, d, link, ctx) {
            FirstHalf::Done(r, spans, f) => {
                let r = *r;
                push_spans(report, &d.name, spans);
                failed |= f.is_some();
                why_not.get_or_insert_with(|| match r.result {
                    DriveResult::AlreadyVerified | DriveResult::Unchanged => format!(
                        "`{}` already holds its set and opens no dataset download",
                        d.name
                    ),
                    _ => format!("`{}` did not reach its dataset download", d.name),
                });
                count += 1;
                progress(count, &r);
                done[i] = Some(r);
            }
            FirstHalf::Parked(p) => {
                if !p.dataset {
                    why_not.get_or_insert_with(|| {
                        format!("`{}` stages no value in a dataset download", d.name)
                    });
                }
                parked.push((i, *p));
            }
        }
    }
    // the codes every waiting drive stages, with the common value
    let common = lustbus_common_values(drives);
    let codes: Vec<(CodeKey, RawValue)> = common
        .into_iter()
        .filter(|(k, _)| parked.iter().all(|(_, p)| p.tx.staged().contains(k)))
        .collect();
    if why_not.is_none() && codes.is_empty() {
        why_not = Some("no common value is to be written on every drive".into());
    }
    let mut sent = false;
    if why_not.is_none() {
        // every drive's journal records the values first
        let keys: Vec<CodeKey> = codes.iter().map(|(k, _)| *k).collect();
        let mut ok = true;
        for (_, p) in parked.iter_mut() {
            if let Err(e) = p.tx.expect_broadcast(&keys) {
                why_not = Some(format!(
                    "`{}`: the journal could not record the broadcast: {}",
                    p.d.name,
                    e.error()
                ));
                ok = false;
                break;
            }
        }
        if ok {
            let t0 = link_now(link);
            let first = parked[0].1.d;
            let res = lust_client(link, first).and_then(|mut c| {
                for (k, v) in &codes {
                    c.broadcast(*k, v)?;
                }
                c.finish()
            });
            let t1 = link_now(link);
            report.timeline.push(TimelineEntry {
                drive: "address 31".into(),
                phase: Phase::Broadcast,
                start_ms: since(start, t0),
                end_ms: since(start, t1),
            });
            match res {
                Ok(()) => sent = true,
                Err(e) => {
                    // what did not go out is found missing and written drive by drive
                    ctx.warn(format!(
                        "bus `{}`: the broadcast stopped: {e}; each drive writes what did not land",
                        bus.name
                    ));
                    sent = true;
                }
            }
        } else {
            for (_, p) in parked.iter_mut() {
                p.tx.cancel_broadcast();
            }
        }
    }
    match (&why_not, sent) {
        (Some(w), _) => ctx.warn(format!(
            "bus `{}`: no broadcast (address 31): {w}; values were written drive by drive",
            bus.name
        )),
        (None, true) => ctx.warn(format!(
            "bus `{}`: {} value(s) common to its {} drives sent once to address 31 (broadcast, no receipt) inside each drive's dataset download; every value verified drive by drive",
            bus.name,
            codes.len(),
            parked.len()
        )),
        (None, false) => {}
    }
    // every drive's own dataset writes and SLOAD = -2, then every drive's
    // poll, writes and verification: each drive checks and stores its
    // dataset while the bus serves the others
    for last in [false, true] {
        let mut again = Vec::new();
        for (i, p) in parked {
            let name = p.d.name.clone();
            match next_half(bus, p, link, ctx, last) {
                FirstHalf::Parked(p) => again.push((i, *p)),
                FirstHalf::Done(r, spans, f) => {
                    let r = *r;
                    push_spans(report, &name, spans);
                    failed |= f.is_some();
                    count += 1;
                    progress(count, &r);
                    done[i] = Some(r);
                }
            }
        }
        parked = again;
    }
    let out = done
        .into_iter()
        .zip(drives)
        .map(|(r, d)| r.unwrap_or_else(|| blank_report(d, bus, DriveResult::Failed)))
        .collect();
    (out, failed)
}
