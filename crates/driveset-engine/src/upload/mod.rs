//! The upload transaction (docs/architecture.md, "The data path of an upload"): identify, read back,
//! plan, journal, write (with the MC6000/7000 SLOAD handshake and EEPROM
//! pacing), verify, and on failure roll back from the journal.
//!
//! **Pacing with interleaving.** Before each write the runner asks the
//! client when the drive will take it ([`DriveClient::ready_for_write`]:
//! MC6000/7000 EEPROM still storing an earlier value). Instead of sleeping
//! through that gap it reads back codes written earlier, oldest first,
//! preferring one whose read exchange ([`DriveClient::read_time`]) fits in
//! what is left of the gap (else any: the read is due anyway, and running
//! past the gap by part of it beats idling through it), and waits only the
//! rest. RAM writes never wait. Values staged in
//! an MC dataset are verified only after the drive accepted the dataset.
//!
//! **Failure.** A failed write, a failed or mismatching verification, or a
//! dataset the drive does not accept ends the attempt:
//! - MC6000/7000 dataset rejected (`SLOAD > 0`): the drive reactivated its
//!   old set; the runner reads every planned code back to confirm nothing
//!   changed and marks the journal `rolled-back`, naming the parameter.
//! - otherwise the old values are restored from the backup in reverse write
//!   order (CardWriteable values again through a dataset download), read
//!   back and compared: `rolled-back`; if that fails too, `failed` with what
//!   each code holds, and the error says `driveset recover JOURNAL`.
//! - [`DeviceFailure::Restarted`](crate::error::DeviceFailure::Restarted) (the drive restarted; the attempt is void):
//!   redone from the read-back, at most [`UploadOptions::max_restarts`]
//!   times, keeping the first attempt's backup.
//!
//! **Steps.** [`Transaction`] is the transaction as explicit steps, each
//! one call a caller (the line runner, a progress observer) can drive or
//! watch: [`Transaction::begin`] (check, unfinished-journal guard,
//! identify), then per attempt [`Transaction::replan`] (read back, plan),
//! [`Transaction::journal`] (backup durable before any write),
//! [`Transaction::open_dataset`] (SLOAD = -1), [`Transaction::write_dataset`],
//! [`Transaction::commit`] (SLOAD = -2, poll), [`Transaction::write_rest`],
//! [`Transaction::verify`], and [`Transaction::finish`] (the report). A
//! failed step goes to [`Transaction::stopped`] (roll back, or redo after a
//! restart). Each code has one record (old, new, texts, storage, phase,
//! outcome, touched, verified). [`upload`] runs the steps in order. A
//! failure to persist the journal is never discarded: the step fails with
//! it, and a persist failure while settling is reported with what the
//! drive holds and the state the journal on disk still says.
//!
//! Times come only from the client's clock.
//!
//! **Progress.** The runner reports its own phase to
//! [`UploadOptions::observer`] ([`crate::observe`]): identify, read, plan,
//! journal, dataset, write (code i of n), commit (SLOAD poll), verify,
//! rollback; a rollback is reported as such, whatever telegrams it sends.
//! Each step of [`Transaction`] enters its phase itself.
//!
//! **The dry run.** [`prepare`] is [`Transaction::begin`] and
//! [`Transaction::replan`] without a journal: the same check, identify,
//! read-back and plan, minus the unfinished-journal guard, with the
//! identity checked in the plan and the motor asked before the read-back
//! (its docs say why). [`crate::dry_run`] adds what `--transfer-baud` would
//! do and the forms a front end prints.
//!
//! **Rooms.** This module holds the public API: [`UploadOptions`],
//! [`upload`] and the dry run's [`prepare`]. The transaction's state and
//! its first steps are in `transaction.rs` (the checks and identify an
//! upload shares with its dry run, begin, replan, stopped), the
//! journal it keeps in `journal_writer.rs` (the journal step, state
//! transitions, the unfinished-journal guard), the MC6000/7000 dataset
//! handshake in `dataset.rs`, the paced writes and the verification in
//! `write.rs`, the rollback in `rollback.rs`, and what a caller is told
//! (report, failure, a step's outcome) in `report.rs`.

mod dataset;
mod journal_writer;
mod refusal;
mod report;
mod rollback;
mod state;
mod store;
mod transaction;
mod write;

use std::path::PathBuf;
use std::time::Duration;

use driveset_schema::{CodeKey, ResolvedSet};

use crate::client::{DriveClient, Identity, Target};
use crate::error::{EngineError, Refusal};
use crate::observe::{Hook, Phase as Step};
use crate::overrides::Overrides;
use crate::plan::{DATASET_TIMEOUT, Plan, Problem, TimeEstimate};

pub use journal_writer::{check_unfinished, default_journal_path};
pub use refusal::UploadRefusal;
pub use report::{
    CodeOutcome, CodeReport, Next, Replanned, StepError, UploadFailure, UploadReport,
};
pub(crate) use rollback::{RollbackPlan, describe_holdings, holdings, restore};
pub use store::Stored;
use transaction::Opening;
pub use transaction::Transaction;

/// How to run an upload.
#[derive(Debug, Clone)]
pub struct UploadOptions {
    /// Journal file (created; must not hold an unfinished transaction).
    pub journal: PathBuf,
    /// The named overrides (each lifts one refusal; see [`crate::overrides`]).
    pub overrides: Overrides,
    /// Rewrite the journal with the codes written so far every this many
    /// writes (and at every state transition). At least 1.
    pub journal_every: usize,
    /// How often an attempt voided by a drive restart is redone.
    pub max_restarts: u32,
    /// How long the MC6000/7000 dataset check may take (SLOAD poll).
    pub dataset_timeout: Duration,
    /// How writes are paced. Default [`Strategy::Interleaved`].
    pub strategy: Strategy,
    /// The transfer-rate switch (`--transfer-baud`) recorded in the
    /// journal before this upload: the journal file is this transaction's
    /// (the guard has run), and the upload's journal keeps the record.
    pub transfer: Option<crate::journal::TransferRecord>,
    /// Told each phase and step of the transaction ([`crate::observe`]).
    pub observer: Hook,
}

/// How the runner paces writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Wait only what the drive needs and fill MC6000/7000 EEPROM gaps with
    /// verification reads (see the module docs).
    #[default]
    Interleaved,
    /// The naive reference for benchmarks: a fixed wait after every write
    /// the drive stores in EEPROM on the spot (storage `eeprom` or
    /// `fsel-isel`), nothing interleaved, every verification read at the end.
    Naive {
        /// The fixed wait after each EEPROM write (60 ms in the benchmark).
        eeprom_wait: Duration,
    },
}

impl UploadOptions {
    /// Defaults: no force, journal every 8 writes, one redo, 10 s dataset check.
    pub fn new(journal: impl Into<PathBuf>) -> Self {
        UploadOptions {
            journal: journal.into(),
            overrides: Overrides::none(),
            journal_every: 8,
            max_restarts: 1,
            dataset_timeout: DATASET_TIMEOUT,
            strategy: Strategy::Interleaved,
            transfer: None,
            observer: Hook::none(),
        }
    }
}

/// A plan against the live drive, for `--dry-run` (nothing is written).
#[derive(Debug, Clone)]
pub struct Prepared {
    /// What the drive said it is.
    pub identity: Identity,
    /// The drive's values of the set's codes.
    pub current: ResolvedSet,
    /// The plan.
    pub plan: Plan,
    /// Expected duration.
    pub estimate: TimeEstimate,
}

pub(crate) fn refused(target: &Target, problems: Vec<Problem>) -> EngineError {
    EngineError::refused(target.clone(), Refusal::Plan { problems })
}

/// Read `keys` off the drive into a set of the client's schema.
pub(crate) fn read_values(
    client: &mut dyn DriveClient,
    keys: impl IntoIterator<Item = CodeKey>,
) -> Result<ResolvedSet, EngineError> {
    read_observed(client, keys, &Hook::none(), Step::Read)
}

/// [`read_values`], entering `phase` on `hook` and reporting each code read.
pub(crate) fn read_observed(
    client: &mut dyn DriveClient,
    keys: impl IntoIterator<Item = CodeKey>,
    hook: &Hook,
    phase: Step,
) -> Result<ResolvedSet, EngineError> {
    let keys: Vec<CodeKey> = keys.into_iter().collect();
    hook.enter(client.clock(), phase, Some(keys.len()));
    let schema = client.schema().clone();
    let mut out = ResolvedSet::new(&schema);
    for (i, k) in keys.iter().enumerate() {
        let v = client.read(*k)?;
        out.insert(*k, v);
        hook.step(client.clock(), phase, i + 1, keys.len());
    }
    Ok(out)
}

/// What an upload would do, without writing anything (`--dry-run`): the
/// steps of [`Transaction::begin`] and [`Transaction::replan`] without a
/// journal. Three of them differ from the real run, each on purpose (the
/// dry run reports what it always reported, telegram for telegram):
///
/// - no unfinished-journal guard (`journal_writer::guard`): a dry run
///   writes nothing, so a journal left unfinished does not refuse it;
/// - the identity is checked in the plan, with the read-back and the motor
///   ([`check_set`](crate::plan::check_set) inside [`plan`](crate::plan::plan)), not on its own
///   before the read-back ([`Transaction::begin`]'s second check): a dry
///   run lists every refusal at once;
/// - the motor is asked before the read-back, whether or not anything
///   differs ([`Transaction::replan`] asks only when something is to be
///   written): a dry run of a running drive is refused even when the drive
///   already holds the set.
///
/// The sequence: check the set (nothing sent), identify, ask the motor,
/// read back, plan, estimate.
pub fn prepare(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    overrides: Overrides,
) -> Result<Prepared, EngineError> {
    let settled = |stop: StepError| match stop {
        StepError::Settled(e) | StepError::Error(e) => e,
    };
    // no journal step follows, so the journal path is never used
    let opts = UploadOptions {
        overrides,
        ..UploadOptions::new(PathBuf::new())
    };
    let mut tx = Opening::check(&mut *client, set, overrides)?.identify(client, &opts)?;
    tx.ask_running(client)?;
    let current = tx.read_back(client, set)?;
    tx.plan_against(client, set, &current).map_err(settled)?;
    let plan = tx.take_attempt("dry run", "plan").map_err(settled)?.plan;
    let estimate = plan.estimate(set, &*client);
    Ok(Prepared {
        identity: tx.drive.identity,
        current,
        plan,
        estimate,
    })
}

/// Upload `set` to the drive as one transaction (see the module docs).
/// `Ok` only when the drive holds the set (verified); the report then has
/// `state == Complete`.
///
/// The one-call form of [`Transaction`]: begin, then attempts of
/// replan, journal, dataset, writes and verify until one settles (an
/// attempt voided by a drive restart is redone), then finish.
pub fn upload(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    opts: &UploadOptions,
) -> Result<UploadReport, UploadFailure> {
    let mut tx = Transaction::begin(client, set, opts)?;
    let result = loop {
        match tx.run_attempt(client, set) {
            Ok(()) => break Ok(()),
            Err(stop) => match tx.stopped(client, stop) {
                Next::Redo => continue,
                Next::Failed(e) => break Err(e),
            },
        }
    };
    tx.finish(client, set, result)
}
