//! Owns a line run from start to report, whatever its walk: the selection,
//! the report directory, a thread per bus (the drives of one bus in turn),
//! and the line report gathered from the buses' (module docs of
//! [`super`]); and `commission`, the run with the commissioning walk.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::sync::{Mutex, PoisonError};

use super::bus::{BusRun, run_bus};
use super::commissioning::Commissioning;
use super::drive::blank_report;
use super::options::{LineError, LineOptions, LineOutcome, Opener};
use super::select::select;
use super::walk::Walk;
use crate::env::rfc3339;
use crate::line::manifest::{Drive, Manifest};
use crate::line::report::{
    BusReport, DriveReport, DriveResult, LineReport, LineResult, REPORT_VERSION,
};

/// What every bus thread of a run shares: the options, the walk and the
/// warnings gathered so far.
pub(in crate::line) struct Ctx<'a> {
    /// The line's name (the history's slots name it).
    pub(in crate::line) line: &'a str,
    pub(in crate::line) opts: &'a LineOptions,
    /// What the run does with each drive.
    pub(in crate::line) walk: &'a dyn Walk,
    pub(super) warnings: Mutex<Vec<String>>,
}

impl Ctx<'_> {
    /// Add a warning to the run's.
    pub(in crate::line) fn warn(&self, w: String) {
        self.warnings
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(w);
    }
}

/// Commission the line (module docs of [`super`]).
pub fn commission(
    manifest: &Manifest,
    opts: &LineOptions,
    opener: &Opener<'_>,
) -> Result<LineOutcome, LineError> {
    run_walk(manifest, opts, opener, || {
        Commissioning::start(manifest, opts)
    })
}

/// Run the line with the walk `start` gives once the selection holds and
/// the report directory is there.
pub(in crate::line) fn run_walk<W: Walk>(
    manifest: &Manifest,
    opts: &LineOptions,
    opener: &Opener<'_>,
    start: impl FnOnce() -> Result<W, LineError>,
) -> Result<LineOutcome, LineError> {
    let started = rfc3339(opts.env.now_utc());
    let selected = select(manifest, opts)?;
    create_report_dir(opts)?;
    let walk = start()?;
    let ctx = Ctx {
        line: &manifest.name,
        opts,
        walk: &walk,
        warnings: Mutex::new(Vec::new()),
    };
    // the manifest's address is the truth: refused before the bus is opened
    let mut refused = crate::line::address_truth::refuse_line(manifest, &selected);
    let results = run_buses(manifest, &selected, &refused, &ctx, opener);
    let warnings = ctx
        .warnings
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    let (buses, mut by_drive, bus_failure) = gather(results);
    // every drive of the manifest, in its order
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
    let report = line_report(manifest, opts, walk.command(), started, buses, drives);
    Ok(LineOutcome {
        report,
        bus_failure,
        warnings,
    })
}

fn create_report_dir(opts: &LineOptions) -> Result<(), LineError> {
    opts.env
        .create_dir(&opts.report_dir)
        .map_err(|source| LineError::ReportDir {
            dir: opts.report_dir.clone(),
            source,
        })
}

/// A thread per bus, each given the bus's selected drives (neither left
/// out nor refused) and every drive the manifest lists on it.
fn run_buses(
    manifest: &Manifest,
    selected: &BTreeSet<String>,
    refused: &BTreeMap<String, DriveReport>,
    ctx: &Ctx<'_>,
    opener: &Opener<'_>,
) -> Vec<BusRun> {
    std::thread::scope(|scope| {
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
                scope.spawn(move || run_bus(bus, &drives, &listed, ctx, opener))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a bus thread panicked"))
            .collect()
    })
}

/// The buses' reports, their drives' by name, and whether a bus failed.
fn gather(results: Vec<BusRun>) -> (Vec<BusReport>, BTreeMap<String, DriveReport>, bool) {
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
    (buses, by_drive, bus_failure)
}

fn line_report(
    manifest: &Manifest,
    opts: &LineOptions,
    command: &str,
    started: String,
    buses: Vec<BusReport>,
    drives: Vec<DriveReport>,
) -> LineReport {
    let env = &*opts.env;
    let result = line_result(&drives);
    let dir = manifest.path.parent().unwrap_or(Path::new("."));
    LineReport {
        report_version: REPORT_VERSION,
        command: command.into(),
        line: manifest.name.clone(),
        manifest: manifest.path.display().to_string(),
        label: opts.label.clone().or_else(|| manifest.label.clone()),
        started,
        finished: rfc3339(env.now_utc()),
        git: env.git_info(dir),
        result,
        buses,
        drives,
        history: None,
    }
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
