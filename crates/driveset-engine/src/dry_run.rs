//! The dry run of an upload (`driveset upload --dry-run`): what an upload
//! would do, with nothing written, as one typed result ([`DryRun`]) that a
//! front end only renders ([`DryRun::render`], [`DryRun::json`]). It is
//! the transaction's steps without a journal ([`crate::upload::prepare`]:
//! check, identify, read back, plan, estimate) and, with a transfer rate,
//! whether switching would pay ([`crate::transfer::check`] and
//! [`crate::transfer::decide`]; nothing is switched).
//!
//! It stands beside [`crate::upload`] and [`crate::transfer`], as
//! [`crate::transfer::upload`] does for the real run: the transaction
//! knows nothing of the transfer rate.

use std::time::Duration;

use driveset_schema::ResolvedSet;
use serde::Serialize;

use crate::client::{DriveClient, Identity};
use crate::error::EngineError;
use crate::overrides::Overrides;
use crate::plan::{Phase, PlannedWrite, Storage, TimeEstimate};
use crate::transfer::{Decision, TransferRequest};
use crate::upload::{Prepared, prepare};

/// How to run a dry run.
#[derive(Debug, Clone, Default)]
pub struct DryRunOptions {
    /// The named overrides (the same refusals as the upload's).
    pub overrides: Overrides,
    /// `--transfer-baud`: say whether switching would pay.
    pub transfer: Option<TransferRequest>,
}

/// What an upload would do.
#[derive(Debug, Clone)]
pub struct DryRun {
    /// The identity, the drive's values, the plan and its expected time.
    pub prepared: Prepared,
    /// Whether the transfer rate asked for would pay (none asked: `None`).
    pub transfer: Option<Decision>,
}

/// What a dry run's output names: the port as the front end names it,
/// the address and the set file.
#[derive(Debug, Clone)]
pub struct Subject {
    /// The port.
    pub port: String,
    /// The bus address.
    pub address: u8,
    /// The set file, as given.
    pub set: String,
}

/// Plan the upload of `set` against the drive, and with
/// [`DryRunOptions::transfer`] check the transfer rate (what needs no
/// telegram) and estimate whether switching would pay; nothing is
/// written or switched. The refusals are the upload's
/// ([`crate::upload::prepare`] says which steps differ, and why).
pub fn run(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    opts: &DryRunOptions,
) -> Result<DryRun, EngineError> {
    let prepared = prepare(client, set, opts.overrides)?;
    let transfer = match &opts.transfer {
        Some(req) => {
            crate::transfer::check(client, req)?;
            let reads = crate::transfer::upload_exchanges(set);
            Some(crate::transfer::decide(&*client, req, &reads, &[]))
        }
        None => None,
    };
    Ok(DryRun { prepared, transfer })
}

impl DryRun {
    /// The human text: `dry run: SET to PORT address A; nothing is
    /// written`, the plan with its expected time ([`crate::plan::Plan::render`]),
    /// and the transfer rate's summary line.
    pub fn render(&self, of: &Subject) -> String {
        let p = &self.prepared;
        format!(
            "dry run: {} to {} address {}; nothing is written\n{}{}",
            of.set,
            of.port,
            of.address,
            p.plan.render(Some(&p.estimate)),
            self.transfer
                .as_ref()
                .map(|d| format!("{}\n", d.summary()))
                .unwrap_or_default()
        )
    }

    /// The JSON form (`--format json`): an object whose keys are in
    /// alphabetical order at every level, as a [`serde_json::Value`] keeps
    /// them; times in milliseconds.
    pub fn json(&self, of: &Subject) -> serde_json::Value {
        let p = &self.prepared;
        let doc = Json {
            port: &of.port,
            address: of.address,
            set: &of.set,
            schema: &p.plan.schema,
            identity: &p.identity,
            set_fingerprint: &p.plan.set_fingerprint,
            fingerprint_before: &p.plan.fingerprint_before,
            dataset: p.plan.dataset,
            writes: p.plan.writes.iter().map(WriteJson::of).collect(),
            unchanged: p.plan.unchanged.len(),
            warnings: &p.plan.warnings,
            transfer: self.transfer.as_ref().map(|d| TransferJson {
                decision: d,
                summary: d.summary(),
            }),
            estimate_ms: EstimateJson::of(&p.estimate),
        };
        serde_json::to_value(doc).unwrap_or_default()
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// [`DryRun::json`]'s object.
#[derive(Serialize)]
struct Json<'a> {
    port: &'a str,
    address: u8,
    set: &'a str,
    schema: &'a str,
    identity: &'a Identity,
    set_fingerprint: &'a str,
    fingerprint_before: &'a str,
    dataset: bool,
    writes: Vec<WriteJson<'a>>,
    unchanged: usize,
    warnings: &'a [String],
    transfer: Option<TransferJson<'a>>,
    estimate_ms: EstimateJson,
}

/// One planned write.
#[derive(Serialize)]
struct WriteJson<'a> {
    code: &'a str,
    old: &'a str,
    new: &'a str,
    storage: Storage,
    width: Option<u8>,
    phase: Phase,
    store_ms: f64,
    ack_delay_ms: f64,
}

impl<'a> WriteJson<'a> {
    fn of(w: &'a PlannedWrite) -> Self {
        WriteJson {
            code: &w.label,
            old: &w.old_text,
            new: &w.new_text,
            storage: w.storage,
            width: w.width,
            phase: w.phase,
            store_ms: ms(w.store_time),
            ack_delay_ms: ms(w.ack_delay),
        }
    }
}

/// The transfer rate's decision and its summary line.
#[derive(Serialize)]
struct TransferJson<'a> {
    decision: &'a Decision,
    summary: String,
}

/// [`TimeEstimate`] in milliseconds.
#[derive(Serialize)]
struct EstimateJson {
    total: f64,
    read_back: f64,
    writes: f64,
    verify: f64,
    waits: f64,
}

impl EstimateJson {
    fn of(e: &TimeEstimate) -> Self {
        EstimateJson {
            total: ms(e.total),
            read_back: ms(e.read_back),
            writes: ms(e.writes),
            verify: ms(e.verify),
            waits: ms(e.waits),
        }
    }
}
