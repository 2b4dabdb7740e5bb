//! The run of a machine line that `driveset commission` and `driveset
//! status` share: loading the manifest (its findings printed), opening its
//! buses through [`crate::port`], the engine's line run with progress lines
//! and bars, the summary table (both rendered by `driveset_report::line`),
//! the report written; `commission --assign`'s first contact is
//! [`commission_assign`] (the engine's `line::commission_assign`; `assign`
//! alone is `driveset address`).

pub mod commission_assign;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_engine::line::commission::{
    DriveDone, Flow, LineError, LineLearn, LineObserver, LineOptions, LineOutcome, Opener, Verdict,
};
use driveset_engine::line::manifest::{Bus, Manifest, load_manifest};
use driveset_engine::observe::Event;
use driveset_engine::session::PortError;
use driveset_link::Link;

use crate::{EXIT_BUS, EXIT_FINDINGS, EXIT_INPUT, EXIT_OK, port, report};

/// The report directory when neither `--report-dir` nor the manifest's
/// `report_dir` gives one (relative to the current directory).
pub const DEFAULT_REPORT_DIR: &str = "target/driveset-report";

/// A line command as the front end runs it: its name, whether it writes
/// to drives, the summary's verb and the engine's run.
#[derive(Clone, Copy)]
pub struct LineCommand {
    /// The history session's command.
    name: &'static str,
    /// Whether the history session writes to drives.
    writes: bool,
    /// `N of M drives VERB` in the summary.
    verb: &'static str,
    /// The engine's run.
    run: fn(&Manifest, &LineOptions, &Opener<'_>) -> Result<LineOutcome, LineError>,
}

/// `driveset commission`.
pub const COMMISSION: LineCommand = LineCommand {
    name: "commission",
    writes: true,
    verb: "commissioned",
    run: driveset_engine::line::commission::commission,
};

/// `driveset status`.
pub const STATUS: LineCommand = LineCommand {
    name: "status",
    writes: false,
    verb: "checked",
    run: driveset_engine::line::status::status,
};

/// The hidden `--stop-after N`: every bus stops after N drives, as if the
/// run were killed there; the line's progress is told everything else.
struct StopAfter {
    n: usize,
    progress: Arc<crate::progress::LineProgress>,
}

impl LineObserver for StopAfter {
    fn bus(&self, bus: &str, drives: usize) {
        self.progress.bus(bus, drives);
    }

    fn event(&self, bus: &str, drive: &str, at: driveset_link::Instant, event: Event) {
        self.progress.event(bus, drive, at, event);
    }

    fn drive_done(&self, done: &DriveDone<'_>) {
        self.progress.drive_done(done);
    }

    fn before_drive(&self, _bus: &str, done: usize) -> Flow {
        if done >= self.n {
            Flow::Stop("--stop-after".into())
        } else {
            Flow::Go
        }
    }

    fn may_stop(&self) -> bool {
        true
    }
}

/// What `commission` and `status` share.
pub struct Common {
    /// Manifest path.
    pub manifest: PathBuf,
    /// `--only`.
    pub only: Vec<String>,
    /// `--skip`.
    pub skip: Vec<String>,
    /// `--label`.
    pub label: Option<String>,
    /// `--report-dir`.
    pub report_dir: Option<PathBuf>,
    /// `--schema-dir`, `--no-learn`, the description overrides.
    pub learn: crate::port_args::LearnArgs,
    /// `commission --rehearse DIR`: the twins' directory.
    pub rehearse: Option<PathBuf>,
    /// `commission --allow-missing-twins`.
    pub allow_missing_twins: bool,
    /// `commission --stop-after` (hidden).
    pub stop_after: Option<usize>,
}

/// Whether loading a manifest counts the findings of sets whose schema is
/// learned from the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LearnedSets {
    /// They do not count: the run learns the drive's schema and checks the
    /// set against it then.
    Excused,
    /// They count (`--no-learn`, or a command that learns nothing).
    Counted,
}

impl LearnedSets {
    /// What the learning flags say: `--no-learn` counts them.
    pub fn of(learn: &crate::port_args::LearnArgs) -> LearnedSets {
        if learn.no_learn {
            LearnedSets::Counted
        } else {
            LearnedSets::Excused
        }
    }
}

/// Load the manifest; print its findings (exit 2) if it has any. The
/// findings of sets whose schema is learned from the drive count as
/// `learned` says; the per-drive ones (`set-address`, `set-rate`: the
/// line run refuses that drive) do not.
pub fn load(path: &Path, learned: LearnedSets) -> Result<Manifest, u8> {
    let mut registry = match crate::output::registry(&[]) {
        Ok(r) => r,
        Err(e) => return Err(crate::output::fail_input(&e)),
    };
    let loaded = match load_manifest(path, &mut registry, &port::openers()) {
        Ok(l) => l,
        Err(e) => {
            eprint!("{}", e.render_human());
            return Err(EXIT_INPUT);
        }
    };
    // a set that disagrees with its drive's manifest address or rate
    // refuses that drive, not the line (engine `line::address_truth`)
    let mut findings: Vec<_> = loaded
        .findings
        .into_iter()
        .filter(|f| !f.is_per_drive())
        .collect();
    if learned == LearnedSets::Counted {
        findings.extend(loaded.learnable);
    }
    match loaded.manifest {
        Some(m) if findings.is_empty() => Ok(m),
        _ => {
            for f in &findings {
                eprint!("{}", f.render_human());
            }
            eprintln!(
                "error: {}: {} finding(s) in the line manifest; nothing was sent (see `driveset validate {}`)",
                path.display(),
                findings.len(),
                path.display()
            );
            Err(EXIT_INPUT)
        }
    }
}

/// Open a bus and lock it, as every command does (the engine's
/// [`driveset_engine::session::open_port`] over [`port::CliPorts`]:
/// `sim://` in-process); the message names the port as the manifest
/// spells it.
pub fn open_bus(bus: &Bus) -> Result<Link, String> {
    let text = bus.port.to_string();
    match driveset_engine::session::open_port(&port::CliPorts, &text, None) {
        Ok(opened) => Ok(opened.link),
        Err(PortError::Open { source, .. }) => Err(source.to_string()),
        Err(PortError::Settings { detail, .. }) => Err(format!("{text}: {detail}")),
        Err(e) => Err(e.to_string()),
    }
}

/// Run a line command.
pub fn run_mode(
    c: Common,
    command: LineCommand,
    tweak: impl FnOnce(&mut LineOptions),
) -> Result<u8, crate::fail::Fail> {
    let manifest = match load(&c.manifest, LearnedSets::of(&c.learn)) {
        Ok(m) => m,
        Err(code) => return Err(crate::fail::Fail::reported(code)),
    };
    let learn_options = match c.learn.options() {
        Ok(o) => o,
        Err(f) => {
            return Err(f);
        }
    };
    let report_dir = c
        .report_dir
        .or_else(|| manifest.report_dir.clone())
        .unwrap_or_else(|| PathBuf::from(DEFAULT_REPORT_DIR));
    // the report's files are checked before any bus is opened: a FIFO or
    // device there is refused, not found blocking after the line ran
    for name in [report::JSON_NAME, report::HTML_NAME, "report.junit.xml"] {
        crate::files::check_output("report", &report_dir.join(name))?;
    }
    // a rehearsal writes to twins, not to drives: not on record
    if c.rehearse.is_none() {
        let ctx = crate::history::Context {
            label: c.label.clone().or_else(|| manifest.label.clone()),
            manifest: Some(c.manifest.display().to_string()),
            sets: Some(c.manifest.clone()),
        };
        if command.writes {
            crate::history::begin_writing(command.name, ctx)?;
        } else {
            crate::history::begin_reading(command.name, ctx)?;
        }
    }
    let mut opts = LineOptions::new(&report_dir, Arc::new(crate::history::recorded_env()));
    // the journal directory `upload` uses, so each sees the other's journals
    opts.journal_dir = manifest
        .journal_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from(driveset_engine::journal::DEFAULT_JOURNAL_DIR));
    opts.only = c.only;
    opts.skip = c.skip;
    opts.label = c.label;
    if !c.learn.no_learn {
        let registry = match crate::output::registry(&[]) {
            Ok(r) => r,
            Err(e) => return Err(crate::fail::Fail::from(&e)),
        };
        opts.learn = Some(LineLearn {
            registry,
            schema_dir: c
                .learn
                .schema_dir
                .clone()
                .unwrap_or_else(|| report_dir.clone()),
            options: learn_options,
        });
    }
    tweak(&mut opts);
    // a rehearsal: the twins' buses, its own journals, no resume state
    let rehearsal = match &c.rehearse {
        Some(dir) => Some(rehearsal(&manifest, &mut opts, dir, &report_dir)?),
        None => None,
    };
    let width = manifest
        .buses
        .iter()
        .map(|b| b.name.len())
        .max()
        .unwrap_or(0);
    let bars = crate::progress::LineProgress::new(width, driveset_report::line::progress_line);
    opts.observer = Some(match c.stop_after {
        Some(n) => Arc::new(StopAfter {
            n,
            progress: bars.clone(),
        }),
        None => bars.clone(),
    });
    // wall time is the CLI's to measure: the engine reads no system clock
    let wall0 = std::time::Instant::now();
    let outcome = match &rehearsal {
        Some((opener, _)) => (command.run)(&manifest, &opts, opener.as_ref()),
        None => (command.run)(&manifest, &opts, &open_bus),
    };
    let wall = wall0.elapsed();
    bars.done();
    let mut outcome = match outcome {
        Ok(o) => o,
        Err(e) => {
            return Err(crate::fail::Fail::input(format!("{e}")));
        }
    };
    if let Some((_, missing)) = &rehearsal {
        outcome.report.command = driveset_twin::REHEARSE_COMMAND.into();
        outln!("{}", outcome.report.label.as_deref().unwrap_or_default());
        let junit = report_dir.join("report.junit.xml");
        let xml = driveset_report::junit::line(&outcome.report, missing);
        if let Err(e) = report::write_atomic(&junit, xml.as_bytes()) {
            return Err(crate::fail::Fail::input(format!(
                "cannot write {}: {e}",
                junit.display()
            )));
        }
    }
    for w in &outcome.warnings {
        eprintln!("warning: {w}");
    }
    out!(
        "{}",
        driveset_report::line::summary(&outcome, command.verb, wall)
    );
    crate::history::link_report(&mut outcome.report);
    match report::write_reports(&outcome.report, &report_dir) {
        Ok((json, html)) => outln!("report: {} {}", json.display(), html.display()),
        Err(e) => {
            return Err(crate::fail::Fail::input(format!(
                "cannot write the report into {}: {e}",
                report_dir.display()
            )));
        }
    }
    let code = exit_code(outcome.verdict());
    if let Some((_, missing)) = &rehearsal
        && !missing.is_empty()
        && !c.allow_missing_twins
    {
        eprintln!(
            "error: not rehearsed (no twin): {}; capture them (driveset twin capture-line), leave them out with --skip, or give --allow-missing-twins",
            missing.join(", ")
        );
        return Ok(code.max(EXIT_FINDINGS));
    }
    Ok(code)
}

/// A rehearsal (`commission --rehearse DIR`): the twins' buses, its own
/// journals, no resume state; the drives with no twin skipped (and said).
/// Gives the buses' opener and the drives left out.
fn rehearsal(
    manifest: &Manifest,
    opts: &mut LineOptions,
    dir: &Path,
    report_dir: &Path,
) -> Result<(Box<Opener<'static>>, Vec<String>), crate::fail::Fail> {
    let selected = driveset_engine::line::commission::select(manifest, opts)
        .map_err(|e| crate::fail::Fail::input(e.to_string()))?;
    let r = driveset_twin::rehearse::prepare(manifest, dir, &selected)?;
    opts.skip.extend(r.missing.iter().cloned());
    opts.label = Some(r.label);
    opts.fresh = true;
    opts.journal_dir = report_dir.join("rehearsal-journal");
    for m in &r.missing {
        let twin = driveset_twin::file::path_in(dir, m);
        eprintln!("{m}: not rehearsed: no twin {}", twin.display());
    }
    Ok((Box::new(r.opener), r.missing))
}

/// The process exit code of a line run: 0 every selected drive holds its
/// set, 1 a drive does not, 3 a bus failed (it wins over 1).
pub fn exit_code(v: Verdict) -> u8 {
    match v {
        Verdict::Holds => EXIT_OK,
        Verdict::Differs => EXIT_FINDINGS,
        Verdict::BusFailed => EXIT_BUS,
    }
}
