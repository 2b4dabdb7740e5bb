//! The plant history as the CLI runs it (docs/history.md): the global
//! flags (`--history URL`, `--history-required`, `--operator`, `--reason`;
//! `DRIVESET_HISTORY`, `DRIVESET_OPERATOR`), the store chosen by them
//! (SQLite `.driveset/history.sqlite` by default), when a command opens
//! its session ([`begin_writing`], [`begin_reading`]; before the first write: refused under
//! `--history-required` when it cannot be recorded) and `main` closes it
//! with the outcome ([`end`]), the engine's history seam over it
//! ([`recorded_env`], for the line runner) and [`drive`] for the one-drive
//! commands. The session itself (begun with the run's facts, its recorder
//! thread, the local store a shared one that cannot be reached is owed by,
//! closing, the report's links) is `driveset_history::run`'s.

pub mod cmd;

use std::path::Path;
use std::sync::{Mutex, OnceLock, PoisonError};

use driveset_engine::env::WithHistory;
use driveset_engine::history::{DriveRecord, History};
use driveset_engine::line::report::{GitInfo, LineReport};
use driveset_history::Target;
use driveset_history::run::{self, RunFacts, RunSession};

use crate::fail::Fail;

/// The history flags, global to every command.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct HistoryArgs {
    /// Where the run is recorded: sqlite:PATH, postgresql://USER@HOST/DB, or off
    /// (default: $DRIVESET_HISTORY, else sqlite:.driveset/history.sqlite).
    #[arg(long, global = true, value_name = "URL")]
    pub history: Option<String>,
    /// Refuse to write a drive when the run cannot be recorded.
    #[arg(long, global = true)]
    pub history_required: bool,
    /// Who runs it, for the history (default: $DRIVESET_OPERATOR).
    #[arg(long, global = true, value_name = "NAME")]
    pub operator: Option<String>,
    /// Why, for the history.
    #[arg(long, global = true, value_name = "TEXT")]
    pub reason: Option<String>,
}

static ARGS: OnceLock<HistoryArgs> = OnceLock::new();
static RUN: Mutex<Option<RunSession>> = Mutex::new(None);

/// Keep the parsed flags (`main`, once).
pub fn set_args(a: HistoryArgs) {
    let _ = ARGS.set(a);
}

fn args() -> HistoryArgs {
    ARGS.get().cloned().unwrap_or_default()
}

/// The store the flags choose.
pub fn target() -> Result<Target, Fail> {
    let text = args().history.or_else(|| {
        std::env::var("DRIVESET_HISTORY")
            .ok()
            .filter(|s| !s.is_empty())
    });
    match text {
        None => Ok(Target::default_sqlite()),
        Some(t) => Target::parse(&t).map_err(|e| Fail::input(e.to_string())),
    }
}

/// What a command tells the history about its run.
#[derive(Debug, Default, Clone)]
pub struct Context {
    /// The label (`--label`, the manifest's).
    pub label: Option<String>,
    /// The line manifest.
    pub manifest: Option<String>,
    /// A file or directory of the sets, for their git commit.
    pub sets: Option<std::path::PathBuf>,
}

/// A notice of the history to stderr.
fn say(line: &str) {
    eprintln!("{line}");
}

/// Open the session of a run that writes to drives (before its first
/// write): `--history-required` refuses it when it cannot be recorded
/// (exit 2, nothing sent).
pub fn begin_writing(command: &str, ctx: Context) -> Result<(), Fail> {
    begin(command, ctx, true)
}

/// Open the session of a run that only reads drives: a run that cannot
/// be recorded is warned of and goes on.
pub fn begin_reading(command: &str, ctx: Context) -> Result<(), Fail> {
    begin(command, ctx, false)
}

fn begin(command: &str, ctx: Context, writes: bool) -> Result<(), Fail> {
    let target = target()?;
    if target == Target::Off {
        return Ok(());
    }
    let a = args();
    let refuse = |why: String| -> Result<(), Fail> {
        if writes && a.history_required {
            Err(Fail::input(format!(
                "history: this run cannot be recorded ({why}); nothing was sent (--history-required)"
            )))
        } else {
            eprintln!("warning: history: this run is not recorded: {why}");
            Ok(())
        }
    };
    let git: Option<GitInfo> = ctx.sets.as_deref().and_then(|p| {
        let dir = if p.is_dir() {
            p
        } else {
            p.parent().unwrap_or(Path::new(""))
        };
        crate::git::info(dir)
    });
    let facts = RunFacts {
        command: command.to_string(),
        args: std::env::args().collect(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        operator: a.operator.clone().or_else(|| {
            std::env::var("DRIVESET_OPERATOR")
                .ok()
                .filter(|s| !s.is_empty())
        }),
        reason: a.reason.clone(),
        label: ctx.label,
        manifest: ctx.manifest,
        git,
    };
    match run::begin(&target, facts, say) {
        Ok(session) => {
            *RUN.lock().unwrap_or_else(PoisonError::into_inner) = Some(session);
            Ok(())
        }
        Err(why) => refuse(why),
    }
}

/// Put `record` on the open session (no session: nothing); a failure is
/// warned, the run goes on.
pub fn drive(record: &DriveRecord) {
    if let Some(h) = current()
        && let Err(e) = h.drive(record)
    {
        eprintln!("warning: history: not recorded: {e}");
    }
}

/// Close the open session with the command's exit code and, when it
/// failed, its message (`main`, after the command).
pub fn end(code: u8, failure: Option<&str>) {
    let run = RUN.lock().unwrap_or_else(PoisonError::into_inner).take();
    if let Some(run) = run {
        run.end(code, failure);
    }
}

/// Close the sessions of this station left open by processes that are
/// gone (killed mid-way): `recover` does this with what it found.
pub fn close_interrupted(found: &str) {
    if let Some(s) = current() {
        s.close_interrupted(found);
    }
}

/// Link a line run's report to its session (report.json `history`, each
/// drive's `history`; the HTML report shows them). No session: the report
/// is left as it is.
pub fn link_report(report: &mut LineReport) {
    if let Some(s) = current() {
        s.link_report(report);
    }
}

/// This run's session, when one is open.
fn current() -> Option<RunSession> {
    RUN.lock().unwrap_or_else(PoisonError::into_inner).clone()
}

/// The CLI's [`Environment`](driveset_engine::env::Environment) with the
/// run's session as its history.
pub type RecordedEnv = WithHistory<crate::env::SystemEnv, RunSession>;

/// The system, recording into this run's session (if one is open).
pub fn recorded_env() -> RecordedEnv {
    WithHistory {
        inner: crate::env::SystemEnv,
        history: current(),
    }
}
