//! Owns what a line run is told and what it gives back: the run's options
//! (selection, report and journal directories, overrides, broadcast,
//! learning, its one observer), the observer's events (a drive's phases, a
//! drive done) and its say in whether a bus goes on, the port opener, the
//! reasons a run cannot start, and its outcome with the verdict the CLI
//! maps to exit codes (module docs of [`super`], "Verdict").

use std::path::PathBuf;
use std::sync::Arc;

use driveset_link::{Instant, Link};
use driveset_schema::Registry;

use super::resume::StateFileError;
use crate::env::Environment;
use crate::error::EngineError;
use crate::learn::LearnOptions;
use crate::line::manifest::Bus;
use crate::line::report::{DriveReport, LineReport, LineResult};
use crate::observe::Event;
use crate::overrides::Overrides;

/// The outcome of a line run in one word ([`super`] module docs, "Verdict").
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

/// Told what the drives of a run go through, with their bus and drive
/// names: each bus's start, every event of every drive's work, each drive
/// done with its report (the CLI's progress bars and lines); asked before
/// each drive whether the bus goes on. Called from the bus threads.
pub trait LineObserver: Send + Sync {
    /// Bus `bus` starts, with `drives` selected drives.
    fn bus(&self, bus: &str, drives: usize) {
        let _ = (bus, drives);
    }

    /// Drive `drive` on bus `bus` reached `event` at `at` (the bus clock).
    fn event(&self, bus: &str, drive: &str, at: Instant, event: Event) {
        let _ = (bus, drive, at, event);
    }

    /// A drive is done: its report is final.
    fn drive_done(&self, done: &DriveDone<'_>) {
        let _ = done;
    }

    /// Asked before each drive of a bus done drive by drive, `done` of
    /// its drives done so far: [`Flow::Stop`] ends the bus there, as if
    /// the run had been killed (its other drives are not reached, the bus
    /// fails; a rerun resumes from the state file).
    fn before_drive(&self, bus: &str, done: usize) -> Flow {
        let _ = (bus, done);
        Flow::Go
    }

    /// Whether [`Self::before_drive`] may stop a bus. A bus that may stop
    /// is done drive by drive, never with a LUSTBUS broadcast (whose
    /// drives' transactions are open together until every drive ends).
    fn may_stop(&self) -> bool {
        false
    }
}

/// A line observer that stops every bus after `n` drives, as if the run
/// were killed there (the CLI's hidden `commission --stop-after N`, which
/// tests of an interrupted run use), and tells `inner` everything else.
pub struct StopAfter {
    /// Drives each bus does before it stops.
    pub n: usize,
    /// Who stopped it: the text the drives not reached name.
    pub who: String,
    /// Told every bus, event and drive done.
    pub inner: Arc<dyn LineObserver>,
}

impl LineObserver for StopAfter {
    fn bus(&self, bus: &str, drives: usize) {
        self.inner.bus(bus, drives);
    }

    fn event(&self, bus: &str, drive: &str, at: Instant, event: Event) {
        self.inner.event(bus, drive, at, event);
    }

    fn drive_done(&self, done: &DriveDone<'_>) {
        self.inner.drive_done(done);
    }

    fn before_drive(&self, _bus: &str, done: usize) -> Flow {
        if done >= self.n {
            Flow::Stop(self.who.clone())
        } else {
            Flow::Go
        }
    }

    fn may_stop(&self) -> bool {
        true
    }
}

/// Whether a bus goes on with its next drive ([`LineObserver::before_drive`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Flow {
    /// Go on.
    Go,
    /// Stop the bus here; the text says who stopped it (the drives not
    /// reached name it).
    Stop(String),
}

/// One drive done ([`LineObserver::drive_done`]).
#[derive(Debug, Clone, Copy)]
pub struct DriveDone<'a> {
    /// Bus name.
    pub bus: &'a str,
    /// Drives of this bus done so far (this one included).
    pub done: usize,
    /// Selected drives on this bus.
    pub total: usize,
    /// The drive's report.
    pub drive: &'a DriveReport,
}

/// Opens a bus's port as a link and locks its bus. The CLI passes one that
/// runs the session's sequence ([`crate::session::open_port`]: the lock
/// before and after the open, `sim://` in-process); tests pass the
/// simulator's buses.
pub type Opener<'a> = dyn Fn(&Bus) -> Result<Link, String> + Sync + 'a;

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
    /// Told the phases and steps of every drive's work and each drive
    /// done; asked whether a bus goes on.
    pub observer: Option<Arc<dyn LineObserver>>,
    /// Where the upload journals go.
    pub journal_dir: PathBuf,
    /// Passed to every upload (each lifts one refusal; see
    /// [`crate::overrides`]).
    pub overrides: Overrides,
    /// Broadcast the values common to the drives: LECOM MULTICAST per
    /// group, LUSTBUS SELECT to address 31 inside every MC dataset
    /// download ([`super`] module docs, "Broadcast").
    pub broadcast_common: bool,
    /// Ignore the state file (commission every drive again).
    pub fresh: bool,
    /// How drives whose set's schema lacks facts are learned (module
    /// docs); `None`: such drives fail.
    pub learn: Option<LineLearn>,
}

/// How a line run learns the schema of a drive whose set names a built-in
/// schema that lacks facts ([`super`] module docs, "Learning the schema").
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
    /// The report directory cannot be created.
    #[error("cannot create the report directory {}: {source}", dir.display())]
    ReportDir {
        /// The report directory (`LineOptions::report_dir`).
        dir: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The journal directory cannot be created
    /// ([`crate::journal::ensure_dir`]).
    #[error(transparent)]
    JournalDir(EngineError),
    /// The state file cannot be read
    /// ([`super::resume::CommissionState::load`]).
    #[error(transparent)]
    StateFile(#[from] StateFileError),
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
    /// The run in one word ([`super`] module docs).
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

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;

    #[derive(Default)]
    struct Buses(Mutex<Vec<(String, usize)>>);

    impl LineObserver for Buses {
        fn bus(&self, bus: &str, drives: usize) {
            self.0.lock().unwrap().push((bus.to_string(), drives));
        }
    }

    #[test]
    fn stop_after_stops_each_bus_after_n_drives_and_tells_the_rest() {
        let inner = Arc::new(Buses::default());
        let stop = StopAfter {
            n: 2,
            who: "--stop-after".into(),
            inner: inner.clone(),
        };
        assert!(stop.may_stop());
        assert_eq!(stop.before_drive("press", 0), Flow::Go);
        assert_eq!(stop.before_drive("press", 1), Flow::Go);
        assert_eq!(
            stop.before_drive("press", 2),
            Flow::Stop("--stop-after".into())
        );
        stop.bus("press", 3);
        assert_eq!(*inner.0.lock().unwrap(), vec![("press".to_string(), 3)]);
    }
}
