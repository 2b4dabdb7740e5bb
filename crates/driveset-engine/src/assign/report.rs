//! Owns what `driveset address` finds and does, as its callers see it: the
//! plan ([`AssignPlan`], its [`PlannedWrite`]s and how a new rate takes
//! effect, [`RateEffect`]), the report of a run ([`AssignReport`]) and of a
//! recover ([`AssignRecovered`]), and how found drives, identities and
//! rates are written for humans.

use std::fmt;
use std::sync::Arc;
use std::time::Duration;

use driveset_schema::{BusProtocol, CodeKey, Family, RawValue, Schema};
use serde::{Deserialize, Serialize};

use super::AssignStep;
use crate::client::Identity;
use crate::scan::{Found, ScanOptions};

/// How a new line rate takes effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RateEffect {
    /// Activated at once (MC6000/7000 4-PROG = 111, §11.5) and verified at
    /// the new rate.
    Online,
    /// Stored; active after the drive's next restart (VF1000 §11.5, Tmd
    /// C0125).
    AtRestart,
}

/// One write `address` sends (or, dry, would send).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PlannedWrite {
    /// The telegram, for humans (`LUSTBUS SELECT to address 0 (@), CODE 00082`).
    pub telegram: String,
    /// The code (`82-SADDR`).
    pub code: String,
    /// The value as shown.
    pub value: String,
    /// The address it is sent to.
    pub address: u8,
    /// The line rate it is sent at.
    pub baud: u32,
    #[serde(skip)]
    pub(super) key: CodeKey,
    #[serde(skip)]
    pub(super) raw: RawValue,
    #[serde(skip)]
    pub(super) step: Step,
}

/// Which step a write is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Step {
    Address,
    Rate,
    Activate,
}

/// What [`plan()`](super::plan()) found: the drive, the checks passed,
/// the writes.
#[derive(Debug, Clone, Serialize)]
pub struct AssignPlan {
    /// The port.
    pub port: String,
    /// The bus id.
    pub bus: String,
    /// The protocol.
    #[serde(serialize_with = "ser_name")]
    pub protocol: BusProtocol,
    /// The drive's family.
    #[serde(serialize_with = "ser_name")]
    pub family: Family,
    /// The schema id used.
    pub schema_id: String,
    #[serde(skip)]
    pub(super) schema: Arc<Schema>,
    /// What the drive identified as.
    pub identity: Identity,
    /// LUSTBUS 91-TYPE as read (`None`: NAK, or LECOM).
    pub type_value: Option<i64>,
    /// The address the drive was reached at (LUSTBUS 0, LECOM `--from`).
    pub reached_at: u8,
    /// Its own address before (82 / C0009), where it reads as one.
    pub old_address: Option<i64>,
    /// The address asked for.
    pub to: u8,
    /// The rate the drive was found at.
    pub rate: u32,
    /// The rate asked for (`None`: keep).
    pub baud: Option<u32>,
    /// How the new rate takes effect (when one is written).
    pub rate_effect: Option<RateEffect>,
    /// The network list / the probe of N: who answered.
    pub scan: Vec<Found>,
    /// Virtual (link clock) time of the 1..30 scan (LUSTBUS).
    #[serde(serialize_with = "ser_ms")]
    pub scan_time: Duration,
    /// Link clock time of the whole discovery.
    #[serde(serialize_with = "ser_ms")]
    pub elapsed: Duration,
    /// The writes, in order.
    pub writes: Vec<PlannedWrite>,
    /// The probe options of the request (for the verification probes).
    #[serde(skip)]
    pub(super) scan_opts: ScanOptions,
    /// The request's overrides of the running rule (asked again before
    /// the first write).
    #[serde(skip)]
    pub(super) overrides: crate::overrides::Overrides,
}

pub(super) fn ser_name<T: fmt::Display, S: serde::Serializer>(
    v: &T,
    s: S,
) -> Result<S::Ok, S::Error> {
    s.serialize_str(&v.to_string())
}

pub(super) fn ser_ms<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64() * 1000.0)
}

/// What [`run()`](super::run()) did.
#[derive(Debug, Clone, Serialize)]
pub struct AssignReport {
    /// The plan it carried out.
    pub plan: AssignPlan,
    /// Writes sent (acknowledged).
    pub written: Vec<String>,
    /// What was verified, for humans.
    pub verified: Vec<String>,
    /// The rate the drive runs at now.
    pub rate_now: u32,
    /// When a stored rate becomes active (VF1000, Tmd).
    pub rate_note: Option<String>,
    /// The journal file.
    pub journal: String,
    /// Link clock time of the whole command (discovery included).
    #[serde(serialize_with = "ser_ms")]
    pub elapsed: Duration,
}

/// What [`recover()`](super::recover()) found and did.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct AssignRecovered {
    /// The journal file.
    pub journal: String,
    /// The step the journal was at.
    pub found_step: AssignStep,
    /// Where the drive answered (address, rate).
    pub found_at: (u8, u32),
    /// Writes recover sent to finish.
    pub written: Vec<String>,
    /// The final state, for humans.
    pub state: String,
}

pub(super) fn list(rates: &[u32]) -> String {
    let mut r = rates.to_vec();
    r.sort_unstable();
    r.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}

/// The drives a scan found, each with its identify codes
/// (`address 3: 91-TYPE = 1000; address 7: ...`); empty when none answered.
pub fn found_text(found: &[Found]) -> String {
    found.iter().map(Found::text).collect::<Vec<_>>().join("; ")
}

pub(super) fn pairs(id: &Identity) -> String {
    id.codes
        .iter()
        .map(|c| format!("{} = {}", c.name, c.value))
        .collect::<Vec<_>>()
        .join(", ")
}

impl AssignPlan {
    pub(super) fn scan_opts(&self) -> ScanOptions {
        self.scan_opts.clone()
    }

    /// Whether there is nothing to write.
    pub fn is_noop(&self) -> bool {
        self.writes.is_empty()
    }

    /// Where and how the drive was found, as `driveset address` says it
    /// (`found a MC6000/7000 at address 0 at 9600 baud (91-TYPE = 1000),
    /// own address 3`): LUSTBUS at address 0 (§4.2) with its 91-TYPE or
    /// NAK, LECOM at its controller address.
    pub fn found_line(&self) -> String {
        let d = self.family.descriptor();
        let ty = match self.type_value {
            Some(t) => format!(" (91-TYPE = {t})"),
            None if self.protocol == BusProtocol::Lustbus => " (91-TYPE: NAK)".to_string(),
            None => String::new(),
        };
        let at = if self.protocol == BusProtocol::Lustbus {
            "address 0".to_string()
        } else {
            format!("controller {:02}", self.reached_at)
        };
        let own = self
            .old_address
            .map_or_else(String::new, |a| format!(", own address {a}"));
        format!("found a {} at {at} at {} baud{ty}{own}", d.title, self.rate)
    }

    /// What the scan before the writes saw, as `driveset address` says it:
    /// LUSTBUS the network list 1..30 of §5.2 and its time, LECOM the
    /// address asked for; `no answer` when nothing answered.
    pub fn scan_line(&self) -> String {
        let what = match found_text(&self.scan) {
            who if who.is_empty() => "no answer".to_string(),
            who => who,
        };
        match self.protocol {
            BusProtocol::Lustbus => format!(
                "network list 1..30 ({} ms): {what}",
                self.scan_time.as_millis()
            ),
            _ => format!("address {:02}: {what}", self.to),
        }
    }
}
