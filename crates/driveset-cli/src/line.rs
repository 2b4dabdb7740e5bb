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
    LineError, LineLearn, LineOptions, LineOutcome, Opener, StopAfter, Verdict,
};
use driveset_engine::line::manifest::{Bus, Manifest, load_manifest};
use driveset_engine::session::PortError;
use driveset_link::Link;

use crate::{EXIT_BUS, EXIT_FINDINGS, EXIT_INPUT, EXIT_OK, port, report};

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

pub use driveset_engine::line::manifest::LearnedSets;

/// What the learning flags say of the sets whose schema is learned from
/// the drive: `--no-learn` counts their findings.
pub fn learned_sets(learn: &crate::port_args::LearnArgs) -> LearnedSets {
    if learn.no_learn {
        LearnedSets::Counted
    } else {
        LearnedSets::Excused
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
    match loaded.runnable(learned) {
        Ok(m) => Ok(m),
        Err(findings) => {
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
    let manifest = match load(&c.manifest, learned_sets(&c.learn)) {
        Ok(m) => m,
        Err(code) => return Err(crate::fail::Fail::reported(code)),
    };
    let learn_options = match c.learn.options() {
        Ok(o) => o,
        Err(f) => {
            return Err(f);
        }
    };
    let report_dir = manifest.report_dir_or(c.report_dir);
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
    opts.journal_dir = manifest.journal_dir();
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
        Some(dir) => Some(rehearsal(&manifest, &mut opts, dir)?),
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
            who: "--stop-after".into(),
            inner: bars.clone(),
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

/// A rehearsal (`commission --rehearse DIR`): `opts` made a rehearsal's
/// ([`driveset_twin::rehearse::for_run`]); the drives with no twin said.
/// Gives the buses' opener and the drives left out.
fn rehearsal(
    manifest: &Manifest,
    opts: &mut LineOptions,
    dir: &Path,
) -> Result<(Box<Opener<'static>>, Vec<String>), crate::fail::Fail> {
    let r = driveset_twin::rehearse::for_run(manifest, dir, opts)?;
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
