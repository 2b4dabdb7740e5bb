//! Owns the resume state (module docs of [`super`], "Resume"): the state
//! file [`STATE_FILE`] of the report directory, read and written through
//! the run's [`Environment`]; the record of each drive that ends holding
//! its set; and the resume check that trusts a record only after reading
//! the drive once.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::PoisonError;

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

impl Ctx<'_> {
    /// The drive's record in the resume state (none in `status`).
    pub(super) fn recorded(&self, bus: &Bus, d: &Drive) -> Option<StateEntry> {
        let s = self.state?.lock().unwrap_or_else(PoisonError::into_inner);
        s.drives.get(&state_key(&bus.name, d.address)).cloned()
    }

    /// Record the drive as holding its set at `fingerprint`, or (`None`)
    /// drop its record; the file is saved when it changed.
    pub(super) fn record(&self, bus: &Bus, d: &Drive, fingerprint: Option<&str>) {
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

/// Record in the resume state whether the drive ended holding its set.
pub(super) fn record_drive(bus: &Bus, d: &Drive, r: &DriveReport, ctx: &Ctx<'_>) {
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

/// The resume check (module docs of [`super`], "Resume"): a drive the state file records
/// as verified at its set's fingerprint, on this port, is identified and
/// its set's codes read once. `true`: it still holds its set (`r` says
/// [`DriveResult::AlreadyVerified`]); `false`: commission it (a warning
/// says why when the record was there).
pub(super) fn still_holds(
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
