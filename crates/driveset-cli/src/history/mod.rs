//! Owns the run's session in the plant history (docs/history.md): the
//! global flags (`--history URL`, `--history-required`, `--operator`,
//! `--reason`; `DRIVESET_HISTORY`, `DRIVESET_OPERATOR`), the store chosen
//! by them (SQLite `.driveset/history.sqlite` by default), the session a
//! command opens before its first write ([`begin`]) and `main` closes with
//! the outcome ([`end`]), the engine's [`History`] seam over it
//! ([`RecordedEnv`], for the line runner) and [`drive`] for the one-drive
//! commands. Drive records go to the store through a thread of their own
//! ([`Recorder`]: the records waiting, one transaction), flushed before
//! the session closes. A shared store that cannot be reached: the session goes to
//! the local SQLite store, owed to the shared one, and is forwarded by the
//! next run that reaches it or by `driveset history sync`.

pub mod cmd;

use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

use driveset_engine::env::{Environment, rfc3339};
use driveset_engine::history::{DriveRecord, History};
use driveset_engine::line::report::{DriveHistoryLink, GitInfo, HistoryLink, LineReport};
use driveset_history::{SessionEnd, SessionStart, Store, Target};

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
static RUN: Mutex<Option<Run>> = Mutex::new(None);

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

/// The drive records of this run: (line, drive, place in the chain).
type Records = Arc<Mutex<Vec<(Option<String>, Option<String>, i64)>>>;

/// The open session of this run.
struct Run {
    id: String,
    store: Arc<Mutex<Store>>,
    records: Records,
    recorder: Recorder,
}

/// What the recorder thread is sent.
enum Job {
    /// A drive's record, with the time it was taken.
    Drive(String, Box<DriveRecord>),
    /// Answer once every record sent before is in the store.
    Flush(std::sync::mpsc::Sender<()>),
}

/// The thread that puts drive records into the store, so a bus thread
/// never waits for the database: it takes every record waiting at once
/// into one transaction (docs/history.md, "Recording's cost").
#[derive(Clone)]
struct Recorder {
    tx: std::sync::mpsc::Sender<Job>,
}

impl Recorder {
    fn start(id: String, store: Arc<Mutex<Store>>, records: Records) -> Recorder {
        let (tx, rx) = std::sync::mpsc::channel::<Job>();
        std::thread::spawn(move || {
            while let Ok(first) = rx.recv() {
                let mut batch = Vec::new();
                let mut flushes = Vec::new();
                let mut take = |job: Job| match job {
                    Job::Drive(at, r) => batch.push((at, *r)),
                    Job::Flush(done) => flushes.push(done),
                };
                take(first);
                while let Ok(job) = rx.try_recv() {
                    take(job);
                }
                if !batch.is_empty() {
                    let done = store
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .drives(&id, &batch);
                    match done {
                        Ok(seqs) => records
                            .lock()
                            .unwrap_or_else(PoisonError::into_inner)
                            .extend(batch.iter().zip(seqs).map(|((_, r), seq)| {
                                (r.slot.line.clone(), r.slot.drive.clone(), seq)
                            })),
                        Err(e) => eprintln!(
                            "warning: history: {} drive record(s) not recorded: {e}",
                            batch.len()
                        ),
                    }
                }
                for done in flushes {
                    let _ = done.send(());
                }
            }
        });
        Recorder { tx }
    }

    fn send(&self, at: String, record: &DriveRecord) -> Result<(), String> {
        self.tx
            .send(Job::Drive(at, Box::new(record.clone())))
            .map_err(|_| "the recorder has stopped".to_string())
    }

    /// Wait until every record sent before is in the store.
    fn flush(&self) {
        let (done, wait) = std::sync::mpsc::channel();
        if self.tx.send(Job::Flush(done)).is_ok() {
            let _ = wait.recv();
        }
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

/// The station's name.
fn station() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".into())
}

/// The OS user: `$USER` / `$LOGNAME`, else the name `/etc/passwd` gives
/// the process's uid, else `uid N`.
fn os_user() -> String {
    if let Some(u) = std::env::var("USER")
        .or_else(|_| std::env::var("LOGNAME"))
        .ok()
        .filter(|s| !s.is_empty())
    {
        return u;
    }
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let Some(uid) = status
        .lines()
        .find_map(|l| l.strip_prefix("Uid:"))
        .and_then(|l| l.split_whitespace().next())
    else {
        return "unknown".into();
    };
    let passwd = std::fs::read_to_string("/etc/passwd").unwrap_or_default();
    passwd
        .lines()
        .find_map(|l| {
            let f: Vec<&str> = l.split(':').collect();
            (f.len() > 2 && f[2] == uid).then(|| f[0].to_string())
        })
        .unwrap_or_else(|| format!("uid {uid}"))
}

/// The command line with secrets masked: a store URL's password, and the
/// value of any `password` key.
fn masked_args() -> Vec<String> {
    std::env::args()
        .map(|a| driveset_history::mask_url(&a))
        .collect()
}

fn new_id(station: &str, now: jiff::Timestamp) -> String {
    use sha2::{Digest, Sha256};
    let mut h = Sha256::new();
    h.update(station.as_bytes());
    h.update(std::process::id().to_le_bytes());
    h.update(now.as_nanosecond().to_le_bytes());
    if let Ok(b) = std::fs::read("/proc/sys/kernel/random/uuid") {
        h.update(b);
    }
    let hex: String = h.finalize().iter().map(|b| format!("{b:02x}")).collect();
    hex[..20].to_string()
}

/// Open the local store and the shared one the flags name; forward what
/// the local store owes the shared one. Gives the store to record in and
/// the shared store it is owed to when the shared one could not be reached.
fn open_for_run(target: &Target) -> Result<(Store, Option<String>), String> {
    match target {
        Target::Postgres(_) => match target.open() {
            Ok(Some(mut shared)) => {
                forward_owed(&mut shared);
                Ok((shared, None))
            }
            Ok(None) => Err("off".into()),
            Err(e) => {
                let local =
                    driveset_history::open_sqlite(Path::new(driveset_history::DEFAULT_SQLITE))
                        .map_err(|l| format!("{e}; the local store too: {l}"))?;
                eprintln!(
                    "warning: {e}; this run is recorded in {} and forwarded by the next run that reaches the store, or by `driveset history sync`",
                    driveset_history::DEFAULT_SQLITE
                );
                Ok((local, Some(target.shown())))
            }
        },
        _ => match target.open() {
            Ok(Some(s)) => Ok((s, None)),
            Ok(None) => Err("off".into()),
            Err(e) => Err(e.to_string()),
        },
    }
}

/// Forward the sessions the local store owes `shared` (a run that reached
/// it does this first; `driveset history sync` does only this).
fn forward_owed(shared: &mut Store) -> Vec<String> {
    let local = Path::new(driveset_history::DEFAULT_SQLITE);
    if !local.is_file() {
        return Vec::new();
    }
    let now = rfc3339(jiff::Timestamp::now());
    match driveset_history::open_sqlite(local).and_then(|mut l| l.forward_to(shared, &now)) {
        Ok(ids) => {
            if !ids.is_empty() {
                eprintln!(
                    "history: forwarded {} session(s) recorded locally to {}",
                    ids.len(),
                    shared.shown
                );
            }
            ids
        }
        Err(e) => {
            eprintln!("warning: history: forwarding the local sessions failed: {e}");
            Vec::new()
        }
    }
}

/// Open this run's session (before the first write). `writes`: the
/// command writes to drives, so `--history-required` refuses it when it
/// cannot be recorded (exit 2, nothing sent).
pub fn begin(command: &str, ctx: Context, writes: bool) -> Result<(), Fail> {
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
    let (mut store, owed) = match open_for_run(&target) {
        Ok(s) => s,
        Err(why) => return refuse(why),
    };
    let now = jiff::Timestamp::now();
    let station = station();
    let git: Option<GitInfo> = ctx.sets.as_deref().and_then(|p| {
        let dir = if p.is_dir() {
            p
        } else {
            p.parent().unwrap_or(Path::new(""))
        };
        crate::git::info(dir)
    });
    let start = SessionStart {
        id: new_id(&station, now),
        command: command.to_string(),
        args: masked_args(),
        version: env!("CARGO_PKG_VERSION").to_string(),
        station,
        os_user: os_user(),
        operator: a.operator.clone().or_else(|| {
            std::env::var("DRIVESET_OPERATOR")
                .ok()
                .filter(|s| !s.is_empty())
        }),
        reason: a.reason.clone(),
        label: ctx.label,
        manifest: ctx.manifest,
        git_commit: git.as_ref().map(|g| g.commit.clone()),
        git_dirty: git.as_ref().map(|g| g.dirty),
        started: rfc3339(now),
        pid: std::process::id(),
        forward_to: owed,
    };
    if let Err(e) = store.open_session(&start) {
        return refuse(e.to_string());
    }
    let store = Arc::new(Mutex::new(store));
    let records = Records::default();
    let recorder = Recorder::start(start.id.clone(), store.clone(), records.clone());
    *RUN.lock().unwrap_or_else(PoisonError::into_inner) = Some(Run {
        id: start.id,
        store,
        records,
        recorder,
    });
    Ok(())
}

/// Put `record` on the open session (no session: nothing); a failure is
/// warned, the run goes on.
pub fn drive(record: &DriveRecord) {
    if let Some(h) = Session::current()
        && let Err(e) = h.drive(record)
    {
        eprintln!("warning: history: not recorded: {e}");
    }
}

/// Close the open session with the command's exit code and, when it
/// failed, its message (`main`, after the command).
pub fn end(code: u8, failure: Option<&str>) {
    let Some(run) = RUN.lock().unwrap_or_else(PoisonError::into_inner).take() else {
        return;
    };
    // every drive's record before the close
    run.recorder.flush();
    let outcome = match code {
        0 => "ok",
        1 => "differs",
        2 => "refused",
        _ => "failed",
    };
    let e = SessionEnd {
        ended: rfc3339(jiff::Timestamp::now()),
        outcome: outcome.into(),
        exit_code: Some(code),
        detail: failure
            .filter(|f| !f.is_empty())
            .map(driveset_history::mask_url),
        closed_by: None,
    };
    let mut store = run.store.lock().unwrap_or_else(PoisonError::into_inner);
    if let Err(err) = store.close_session(&run.id, &e) {
        eprintln!("warning: history: the session was not closed: {err}");
    }
}

/// Close the sessions of this station left open by processes that are
/// gone (killed mid-way): `recover` does this with what it found.
pub fn close_interrupted(found: &str) {
    let Some(s) = Session::current() else { return };
    s.recorder.flush();
    let mut store = s.store.lock().unwrap_or_else(PoisonError::into_inner);
    let open = match store.open_sessions(&station()) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("warning: history: {e}");
            return;
        }
    };
    for o in open {
        if o.id == s.id || Path::new(&format!("/proc/{}", o.pid)).exists() {
            continue;
        }
        let e = SessionEnd {
            ended: rfc3339(jiff::Timestamp::now()),
            outcome: "interrupted".into(),
            exit_code: None,
            detail: Some(format!(
                "process {} ended without closing its session (`driveset {}` started {}); {found}",
                o.pid, o.command, o.started
            )),
            closed_by: Some(s.id.clone()),
        };
        match store.close_session(&o.id, &e) {
            Ok(()) => eprintln!(
                "history: closed session {} of `driveset {}` (process {} gone)",
                o.id, o.command, o.pid
            ),
            Err(err) => eprintln!("warning: history: session {} not closed: {err}", o.id),
        }
    }
}

/// Link a line run's report to its session (report.json `history`, each
/// drive's `history`; the HTML report shows them): the store, the
/// session, each drive's record and the commands that list the drive's
/// history and the line as built. No session: the report is left as it is.
pub fn link_report(report: &mut LineReport) {
    let Some(s) = Session::current() else { return };
    // every drive's record in, with its place in the chain
    s.recorder.flush();
    let shown = s
        .store
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .shown
        .clone();
    // the default store needs no flag; another is named
    let flag = if shown == Target::default_sqlite().shown() {
        String::new()
    } else {
        format!(" --history {}", sh_quote(&shown))
    };
    let at = report
        .label
        .as_deref()
        .map(|l| format!(" --at {}", sh_quote(l)))
        .unwrap_or_default();
    report.history = Some(HistoryLink {
        store: shown,
        session: s.id.clone(),
        as_built: format!(
            "driveset history as-built {}{at}{flag}",
            sh_quote(&report.manifest)
        ),
    });
    let records = s.records.lock().unwrap_or_else(PoisonError::into_inner);
    for d in &mut report.drives {
        // the run's last record of the drive
        let Some(seq) = records
            .iter()
            .rev()
            .find(|(l, n, _)| {
                l.as_deref() == Some(report.line.as_str()) && n.as_deref() == Some(d.name.as_str())
            })
            .map(|r| r.2)
        else {
            continue;
        };
        d.history = Some(DriveHistoryLink {
            record: seq,
            log: format!(
                "driveset history log --line {} --drive {}{flag}",
                sh_quote(&report.line),
                sh_quote(&d.name)
            ),
        });
    }
}

/// `s` as one shell word: as it is when it is plain, else single-quoted.
fn sh_quote(s: &str) -> String {
    let plain = !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"-_./:@,+=%".contains(&b));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The open session as the engine's [`History`] seam.
#[derive(Clone)]
pub struct Session {
    id: String,
    store: Arc<Mutex<Store>>,
    records: Records,
    recorder: Recorder,
}

impl Session {
    /// This run's session, when one is open.
    pub fn current() -> Option<Session> {
        RUN.lock()
            .unwrap_or_else(PoisonError::into_inner)
            .as_ref()
            .map(|r| Session {
                id: r.id.clone(),
                store: r.store.clone(),
                records: r.records.clone(),
                recorder: r.recorder.clone(),
            })
    }
}

impl History for Session {
    fn drive(&self, record: &DriveRecord) -> Result<(), String> {
        // to the recorder thread: the caller (a bus thread) goes on
        self.recorder.send(rfc3339(jiff::Timestamp::now()), record)
    }
}

/// The CLI's [`Environment`] with the run's session as its history.
pub struct RecordedEnv {
    inner: crate::env::SystemEnv,
    session: Option<Session>,
}

impl RecordedEnv {
    /// The system, recording into this run's session (if one is open).
    pub fn system() -> Self {
        RecordedEnv {
            inner: crate::env::SystemEnv,
            session: Session::current(),
        }
    }
}

impl Environment for RecordedEnv {
    fn now_utc(&self) -> jiff::Timestamp {
        self.inner.now_utc()
    }

    fn git_info(&self, dir: &Path) -> Option<GitInfo> {
        self.inner.git_info(dir)
    }

    fn read_file(&self, path: &Path) -> std::io::Result<Option<String>> {
        self.inner.read_file(path)
    }

    fn write_file(&self, path: &Path, text: &str) -> std::io::Result<()> {
        self.inner.write_file(path, text)
    }

    fn create_dir(&self, dir: &Path) -> std::io::Result<()> {
        self.inner.create_dir(dir)
    }

    fn history(&self) -> Option<&dyn History> {
        self.session.as_ref().map(|s| s as &dyn History)
    }
}
