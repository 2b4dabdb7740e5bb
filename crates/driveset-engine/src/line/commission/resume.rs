//! Owns the resume state (module docs of [`super`], "Resume"): the state
//! file [`STATE_FILE`] of the report directory, read and written through
//! the run's [`Environment`]; the run's state ([`Resume`], `commission`'s
//! only) with the record of each drive that ends holding its set; and the
//! resume check that trusts a record only after reading the drive once.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use serde::{Deserialize, Serialize};

use super::options::{LineError, LineOptions};
use super::run::Ctx;
use crate::client::DriveClient;
use crate::env::{Environment, rfc3339};
use crate::error::EngineError;
use crate::identify::check_family;
use crate::line::manifest::{Bus, Drive, Manifest};
use crate::line::report::{DriveReport, DriveResult};
use crate::live::live_values;
use crate::observe::{Hook, Phase};

/// The state file's name inside the report directory.
pub const STATE_FILE: &str = ".commission-state.json";
/// The state file's format version.
pub const STATE_VERSION: u32 = 1;

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

/// Why the state file could not be read or written: what went wrong and
/// the file ([`CommissionState::load`], [`CommissionState::save`]).
#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    /// The environment could not read it.
    #[error("state file {}: {source}", path.display())]
    Read {
        /// The state file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// Its content is not a resume state.
    #[error(
        "state file {}: {source}; delete it (or pass --fresh) to commission every drive again",
        path.display()
    )]
    Parse {
        /// The state file.
        path: PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// The state could not be put in JSON form.
    #[error("{source}")]
    Encode {
        /// The state file.
        path: PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// The environment could not write it.
    #[error("state file {}: {source}", path.display())]
    Write {
        /// The state file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
}

impl StateFileError {
    /// The state file it is about.
    pub fn path(&self) -> &Path {
        match self {
            StateFileError::Read { path, .. }
            | StateFileError::Parse { path, .. }
            | StateFileError::Encode { path, .. }
            | StateFileError::Write { path, .. } => path,
        }
    }
}

impl CommissionState {
    /// Read the state file of `report_dir` through `env` (empty if there
    /// is none).
    pub fn load(env: &dyn Environment, report_dir: &Path) -> Result<Self, StateFileError> {
        let path = report_dir.join(STATE_FILE);
        match env.read_file(&path) {
            Ok(Some(text)) => {
                serde_json::from_str(&text).map_err(|source| StateFileError::Parse { path, source })
            }
            Ok(None) => Ok(Self::default()),
            Err(source) => Err(StateFileError::Read { path, source }),
        }
    }

    /// Write it through `env` (atomically: [`Environment::write_file`]).
    pub fn save(&self, env: &dyn Environment, report_dir: &Path) -> Result<(), StateFileError> {
        let path = report_dir.join(STATE_FILE);
        let text = match serde_json::to_string_pretty(self) {
            Ok(text) => text,
            Err(source) => return Err(StateFileError::Encode { path, source }),
        };
        env.write_file(&path, &(text + "\n"))
            .map_err(|source| StateFileError::Write { path, source })
    }

    /// The state a commissioning run of `manifest` starts from: the file's
    /// (none with `fresh`), emptied when it belongs to another line.
    pub(super) fn for_run(manifest: &Manifest, opts: &LineOptions) -> Result<Self, LineError> {
        let mut s = if opts.fresh {
            CommissionState::default()
        } else {
            CommissionState::load(&*opts.env, &opts.report_dir).map_err(LineError::StateFile)?
        };
        if s.line != manifest.name {
            s.drives.clear();
        }
        s.state_version = STATE_VERSION;
        s.line = manifest.name.clone();
        Ok(s)
    }
}

fn state_key(bus: &str, address: u8) -> String {
    format!("{bus}/{address}")
}

/// A commissioning run's resume state, shared by its bus threads.
pub(super) struct Resume(Mutex<CommissionState>);

impl Resume {
    /// The run starts from `state`.
    pub(super) fn new(state: CommissionState) -> Self {
        Resume(Mutex::new(state))
    }

    /// The drive's record in the resume state.
    fn recorded(&self, bus: &Bus, d: &Drive) -> Option<StateEntry> {
        let s = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        s.drives.get(&state_key(&bus.name, d.address)).cloned()
    }

    /// Record the drive as holding its set at `fingerprint`, or (`None`)
    /// drop its record; the file is saved when it changed.
    fn record(&self, ctx: &Ctx<'_>, bus: &Bus, d: &Drive, fingerprint: Option<&str>) {
        let mut s = self.0.lock().unwrap_or_else(PoisonError::into_inner);
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
                        verified_at: rfc3339(ctx.opts.env.now_utc()),
                    },
                );
            }
            None => {
                if s.drives.remove(&key).is_none() {
                    return;
                }
            }
        }
        if let Err(e) = s.save(&*ctx.opts.env, &ctx.opts.report_dir) {
            drop(s);
            ctx.warn(e.to_string());
        }
    }

    /// Record in the resume state whether the drive ended holding its set.
    pub(super) fn record_drive(&self, ctx: &Ctx<'_>, bus: &Bus, d: &Drive, r: &DriveReport) {
        let holds = matches!(
            r.result,
            DriveResult::Verified | DriveResult::Unchanged | DriveResult::AlreadyVerified
        );
        self.record(
            ctx,
            bus,
            d,
            if holds {
                r.fingerprint_after.as_deref()
            } else {
                None
            },
        );
    }

    /// The resume check (module docs of [`super`], "Resume"): a drive the
    /// state file records as verified at its set's fingerprint, on this
    /// port, is identified and its set's codes read once. `true`: it still
    /// holds its set (`r` says [`DriveResult::AlreadyVerified`]); `false`:
    /// commission it (a warning says why when the record was there).
    pub(super) fn still_holds(
        &self,
        client: &mut dyn DriveClient,
        bus: &Bus,
        d: &Drive,
        r: &mut DriveReport,
        hook: &Hook,
        ctx: &Ctx<'_>,
    ) -> Result<bool, EngineError> {
        let Some(rec) = self.recorded(bus, d) else {
            return Ok(false);
        };
        if rec.set_fingerprint != d.set.fingerprint() || rec.port != bus.port_name {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::Memory;
    use crate::line::report::GitInfo;

    /// An environment whose files cannot be read nor written.
    struct Broken;

    impl Environment for Broken {
        fn now_utc(&self) -> jiff::Timestamp {
            jiff::Timestamp::UNIX_EPOCH
        }
        fn git_info(&self, _dir: &Path) -> Option<GitInfo> {
            None
        }
        fn read_file(&self, _path: &Path) -> io::Result<Option<String>> {
            Err(io::Error::new(io::ErrorKind::PermissionDenied, "denied"))
        }
        fn write_file(&self, _path: &Path, _text: &str) -> io::Result<()> {
            Err(io::Error::new(io::ErrorKind::StorageFull, "full"))
        }
        fn create_dir(&self, _dir: &Path) -> io::Result<()> {
            Ok(())
        }
    }

    /// The state file's errors say what went wrong and where, with the
    /// messages the run has always shown; a missing file is an empty state
    /// and a written one reads back.
    #[test]
    fn state_file_errors_are_typed_with_the_file_and_their_messages() {
        let dir = Path::new("/plant/reports");
        let path = dir.join(STATE_FILE);
        let env = Memory::at(jiff::Timestamp::UNIX_EPOCH);
        assert_eq!(
            CommissionState::load(&env, dir).expect("none"),
            CommissionState::default()
        );
        let state = CommissionState {
            state_version: STATE_VERSION,
            line: "press-3".into(),
            drives: BTreeMap::new(),
        };
        state.save(&env, dir).expect("saved");
        assert_eq!(CommissionState::load(&env, dir).expect("read"), state);

        env.write_file(&path, "{ not json").expect("write");
        let e = CommissionState::load(&env, dir).expect_err("parse");
        assert!(matches!(e, StateFileError::Parse { .. }), "{e:?}");
        assert_eq!(e.path(), path);
        let m = e.to_string();
        assert!(
            m.starts_with("state file /plant/reports/.commission-state.json: key must be a string")
                && m.ends_with("; delete it (or pass --fresh) to commission every drive again"),
            "{m}"
        );

        let e = CommissionState::load(&Broken, dir).expect_err("read");
        assert!(matches!(e, StateFileError::Read { .. }), "{e:?}");
        assert_eq!(
            e.to_string(),
            "state file /plant/reports/.commission-state.json: denied"
        );
        let e = state.save(&Broken, dir).expect_err("write");
        assert!(matches!(e, StateFileError::Write { .. }), "{e:?}");
        assert_eq!(e.path(), path);
        assert_eq!(
            e.to_string(),
            "state file /plant/reports/.commission-state.json: full"
        );
        // a run that cannot read its state does not start, with the same message
        let line = LineError::from(CommissionState::load(&Broken, dir).expect_err("read"));
        assert_eq!(
            line.to_string(),
            "state file /plant/reports/.commission-state.json: denied"
        );
    }
}
