//! Owns one run's session in a store (docs/history.md): the store a run
//! records in (the shared one, or the local SQLite store it is then owed
//! to, [`open_for_run`]), the session opened before the first write
//! ([`RunSession::open`]), drive records put into the store by a thread of
//! their own ([`RunSession`] as the engine's [`History`] seam: the records
//! waiting, one transaction), closing it with the outcome
//! ([`RunSession::end`]) or closing the sessions of processes that are gone
//! ([`RunSession::close_interrupted`]), and the links a line report carries
//! to it ([`RunSession::link_report`]). A run's session begun with what
//! the front end knows of the run ([`begin`], [`RunFacts`]) and the
//! station's facts: [`station`], [`os_user`], [`new_id`]. What it has to say
//! (a record not stored, a session forwarded) goes to the caller's
//! [`Say`]; the front end decides when a run opens its session and what a
//! failure to open one means.

use std::path::Path;
use std::sync::mpsc::{Sender, channel};
use std::sync::{Arc, Mutex, PoisonError};

use driveset_engine::env::rfc3339;
use driveset_engine::history::{DriveRecord, History};
use driveset_engine::line::report::{DriveHistoryLink, GitInfo, HistoryLink, LineReport};

use crate::{DEFAULT_SQLITE, SessionEnd, SessionStart, Store, Target};

/// Where a run's notices go (a line of the front end's stderr).
pub type Say = fn(&str);

/// The drive records of this run: (line, drive, place in the chain).
type Records = Arc<Mutex<Vec<(Option<String>, Option<String>, i64)>>>;

/// What the recorder thread is sent.
enum Job {
    /// A drive's record, with the time it was taken.
    Drive(String, Box<DriveRecord>),
    /// Answer once every record sent before is in the store.
    Flush(Sender<()>),
}

/// The thread that puts drive records into the store, so a bus thread
/// never waits for the database: it takes every record waiting at once
/// into one transaction (docs/history.md, "Recording's cost").
#[derive(Clone)]
struct Recorder {
    tx: Sender<Job>,
}

impl Recorder {
    fn start(id: String, store: Arc<Mutex<Store>>, records: Records, say: Say) -> Recorder {
        let (tx, rx) = channel::<Job>();
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
                        Err(e) => say(&format!(
                            "warning: history: {} drive record(s) not recorded: {e}",
                            batch.len()
                        )),
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
        let (done, wait) = channel();
        if self.tx.send(Job::Flush(done)).is_ok() {
            let _ = wait.recv();
        }
    }
}

/// A run's open session: the engine's [`History`] seam (each record to
/// the recorder thread; the caller, a bus thread, goes on).
#[derive(Clone)]
pub struct RunSession {
    id: String,
    store: Arc<Mutex<Store>>,
    records: Records,
    recorder: Recorder,
    say: Say,
}

impl RunSession {
    /// Open `start`'s session in `store` and start its recorder.
    pub fn open(mut store: Store, start: &SessionStart, say: Say) -> Result<Self, String> {
        store.open_session(start).map_err(|e| e.to_string())?;
        let store = Arc::new(Mutex::new(store));
        let records = Records::default();
        let recorder = Recorder::start(start.id.clone(), store.clone(), records.clone(), say);
        Ok(RunSession {
            id: start.id.clone(),
            store,
            records,
            recorder,
            say,
        })
    }

    /// Close the session with the command's exit code and, when it
    /// failed, its message; every drive's record is in first.
    pub fn end(&self, code: u8, failure: Option<&str>) {
        self.recorder.flush();
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
            detail: failure.filter(|f| !f.is_empty()).map(crate::mask_url),
            closed_by: None,
        };
        let mut store = self.store.lock().unwrap_or_else(PoisonError::into_inner);
        if let Err(err) = store.close_session(&self.id, &e) {
            (self.say)(&format!(
                "warning: history: the session was not closed: {err}"
            ));
        }
    }

    /// Close the sessions of this station left open by processes that are
    /// gone (killed mid-way), saying what `found` (recover's finding).
    pub fn close_interrupted(&self, found: &str) {
        self.recorder.flush();
        let say = self.say;
        let mut store = self.store.lock().unwrap_or_else(PoisonError::into_inner);
        let open = match store.open_sessions(&station()) {
            Ok(o) => o,
            Err(e) => {
                say(&format!("warning: history: {e}"));
                return;
            }
        };
        for o in open {
            if o.id == self.id || Path::new(&format!("/proc/{}", o.pid)).exists() {
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
                closed_by: Some(self.id.clone()),
            };
            match store.close_session(&o.id, &e) {
                Ok(()) => say(&format!(
                    "history: closed session {} of `driveset {}` (process {} gone)",
                    o.id, o.command, o.pid
                )),
                Err(err) => say(&format!(
                    "warning: history: session {} not closed: {err}",
                    o.id
                )),
            }
        }
    }

    /// Link a line run's report to the session (report.json `history`,
    /// each drive's `history`; the HTML report shows them): the store, the
    /// session, each drive's record and the commands that list the drive's
    /// history and the line as built.
    pub fn link_report(&self, report: &mut LineReport) {
        // every drive's record in, with its place in the chain
        self.recorder.flush();
        let shown = self
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
            session: self.id.clone(),
            as_built: format!(
                "driveset history as-built {}{at}{flag}",
                sh_quote(&report.manifest)
            ),
        });
        let records = self.records.lock().unwrap_or_else(PoisonError::into_inner);
        for d in &mut report.drives {
            // the run's last record of the drive
            let Some(seq) = records
                .iter()
                .rev()
                .find(|(l, n, _)| {
                    l.as_deref() == Some(report.line.as_str())
                        && n.as_deref() == Some(d.name.as_str())
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
}

impl History for RunSession {
    fn drive(&self, record: &DriveRecord) -> Result<(), String> {
        self.recorder.send(rfc3339(jiff::Timestamp::now()), record)
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

/// The station's name.
pub fn station() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".into())
}

/// The OS user: `$USER` / `$LOGNAME`, else the name `/etc/passwd` gives
/// the process's uid, else `uid N`.
pub fn os_user() -> String {
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

/// A new session id: 20 hex digits of a hash of the station, the process
/// and the time (and the kernel's random UUID where there is one).
pub fn new_id(station: &str, now: jiff::Timestamp) -> String {
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

/// What the front end tells a run's session about the run; the rest of
/// its [`SessionStart`] (id, station, OS user, start, process, the shared
/// store it is owed to) is [`begin`]'s.
#[derive(Debug, Clone, Default)]
pub struct RunFacts {
    /// The command (`commission`, `upload` ...).
    pub command: String,
    /// The command line as given; [`begin`] masks its secrets (a store
    /// URL's password, any `password=` value: [`crate::mask_url`]) before
    /// anything is recorded.
    pub args: Vec<String>,
    /// The driveset version.
    pub version: String,
    /// `--operator` / `DRIVESET_OPERATOR`.
    pub operator: Option<String>,
    /// `--reason`.
    pub reason: Option<String>,
    /// The label (`--label`, the manifest's).
    pub label: Option<String>,
    /// The line manifest.
    pub manifest: Option<String>,
    /// The sets' git commit and whether their work tree had changes.
    pub git: Option<GitInfo>,
}

/// Open the session of a run in the store `target` names
/// ([`open_for_run`]), started now on this station; `Err` says why the run
/// cannot be recorded (`"off"`: history is off). Whether that refuses the
/// run is the front end's.
pub fn begin(target: &Target, facts: RunFacts, say: Say) -> Result<RunSession, String> {
    let (store, owed) = open_for_run(target, say)?;
    let now = jiff::Timestamp::now();
    let station = station();
    let start = SessionStart {
        id: new_id(&station, now),
        command: facts.command,
        args: facts.args.iter().map(|a| crate::mask_url(a)).collect(),
        version: facts.version,
        station,
        os_user: os_user(),
        operator: facts.operator,
        reason: facts.reason,
        label: facts.label,
        manifest: facts.manifest,
        git_commit: facts.git.as_ref().map(|g| g.commit.clone()),
        git_dirty: facts.git.as_ref().map(|g| g.dirty),
        started: rfc3339(now),
        pid: std::process::id(),
        forward_to: owed,
    };
    RunSession::open(store, &start, say)
}

/// Open the store `target` names for a run (the shared one forwards first
/// what the local store owes it, [`forward_owed`]). Gives the store to
/// record in and the shared store it is owed to when the shared one could
/// not be reached (the local SQLite store then records the run); `Err`
/// says why the run cannot be recorded (`"off"`: history is off).
pub fn open_for_run(target: &Target, say: Say) -> Result<(Store, Option<String>), String> {
    match target {
        Target::Postgres(_) => match target.open() {
            Ok(Some(mut shared)) => {
                forward_owed(&mut shared, say);
                Ok((shared, None))
            }
            Ok(None) => Err("off".into()),
            Err(e) => {
                let local = crate::open_sqlite(Path::new(DEFAULT_SQLITE))
                    .map_err(|l| format!("{e}; the local store too: {l}"))?;
                say(&format!(
                    "warning: {e}; this run is recorded in {DEFAULT_SQLITE} and forwarded by the next run that reaches the store, or by `driveset history sync`"
                ));
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
/// it does this first; `driveset history sync` does only this); the ids
/// forwarded.
pub fn forward_owed(shared: &mut Store, say: Say) -> Vec<String> {
    let local = Path::new(DEFAULT_SQLITE);
    if !local.is_file() {
        return Vec::new();
    }
    let now = rfc3339(jiff::Timestamp::now());
    match crate::open_sqlite(local).and_then(|mut l| l.forward_to(shared, &now)) {
        Ok(ids) => {
            if !ids.is_empty() {
                say(&format!(
                    "history: forwarded {} session(s) recorded locally to {}",
                    ids.len(),
                    shared.shown
                ));
            }
            ids
        }
        Err(e) => {
            say(&format!(
                "warning: history: forwarding the local sessions failed: {e}"
            ));
            Vec::new()
        }
    }
}
