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
//! - [`EngineError::Restarted`] (the drive restarted; the attempt is void):
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

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use crate::client::{ClientStats, DatasetOutcome, DriveClient, Identity, Target};
use crate::error::{DeviceCause, EngineError, ErrorKind, Refusal};
use crate::journal::{
    BackupEntry, CodeHolding, FailureCause, Holding, JOURNAL_VERSION, Journal, JournalFile,
    JournalTarget, JournalValue, PlanEntryRecord, TxnState,
};
use crate::observe::{Hook, Phase as Step};
use crate::overrides::Overrides;
use crate::plan::{
    DATASET_TIMEOUT, Phase, Plan, PlanOptions, Problem, Running, Storage, TimeEstimate, check_set,
    code_label, is_secret, plan, value_text,
};

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
    /// The transfer-rate switch [`crate::transfer`] recorded in the
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

/// What happened to one code of the set.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "outcome", content = "detail")]
pub enum CodeOutcome {
    /// The drive already held the value.
    Unchanged,
    /// Planned, not written (the transaction stopped before it).
    #[default]
    NotWritten,
    /// Acknowledged, not yet read back.
    Written,
    /// Written and read back equal.
    Verified,
    /// The write or its verification failed (why).
    Failed(String),
    /// Restored to the old value and read back equal.
    Restored,
}

/// One code in a report.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct CodeReport {
    /// Code number.
    pub number: u32,
    /// Subcode.
    pub subcode: Option<u32>,
    /// Code as humans spell it.
    pub code: String,
    /// Old value for humans (`<redacted>` for passwords).
    pub old: String,
    /// New value for humans.
    pub new: String,
    /// Storage.
    pub storage: Option<Storage>,
    /// Outcome.
    pub outcome: CodeOutcome,
}

/// What an upload did.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct UploadReport {
    /// Port and address.
    pub target: String,
    /// What the drive said it is.
    pub identity: Identity,
    /// Schema id.
    pub schema: String,
    /// The journal file (none when nothing had to be written).
    pub journal: Option<String>,
    /// Final state.
    pub state: TxnState,
    /// Fingerprint of the set.
    pub set_fingerprint: String,
    /// Fingerprint of the drive's values of the set's codes before.
    pub fingerprint_before: String,
    /// Fingerprint of what the drive holds now (set's codes), when known.
    pub fingerprint_after: Option<String>,
    /// Codes in the set.
    pub codes_in_set: usize,
    /// Codes written (acknowledged).
    pub codes_written: usize,
    /// Attempts (a drive restart voids one).
    pub attempts: u32,
    /// Telegrams / requests sent, retries included.
    pub telegrams: u64,
    /// Repetitions after failures.
    pub retries: u64,
    /// Time taken on the client's clock.
    #[serde(serialize_with = "ser_duration_ms")]
    pub elapsed: Duration,
    /// Verification reads done in EEPROM gaps instead of waiting.
    pub interleaved_reads: usize,
    /// Dataset handshake outcome (MC6000/7000), e.g. `accepted`.
    pub dataset: Option<String>,
    /// 80-SLOAD polls while the drive checked the staged dataset
    /// (MC6000/7000, LUSTBUS 11.4); `None` when no dataset was committed.
    pub sload_polls: Option<u64>,
    /// Replies recognised as late and dropped (client::timing).
    pub late_replies: u64,
    /// Per code, in write order then the unchanged ones.
    pub codes: Vec<CodeReport>,
    /// Notes.
    pub warnings: Vec<String>,
    /// The transfer rate (`--transfer-baud`): switched or not, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transfer: Option<crate::transfer::TransferReport>,
}

fn ser_duration_ms<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64() * 1000.0)
}

impl UploadReport {
    /// Human text (passwords redacted).
    pub fn render(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{}: {} ({} of {} codes written, {} attempt(s), {} telegrams, {} retries, {:.3} s)",
            self.target,
            self.state.as_str(),
            self.codes_written,
            self.codes_in_set,
            self.attempts,
            self.telegrams,
            self.retries,
            self.elapsed.as_secs_f64()
        );
        if let Some(d) = &self.dataset {
            let _ = writeln!(out, "dataset: {d}");
        }
        if let Some(n) = self.sload_polls {
            let _ = writeln!(out, "dataset check: {n} SLOAD poll(s)");
        }
        if self.late_replies > 0 {
            let _ = writeln!(
                out,
                "late replies: {} (after their answer timeout; discarded)",
                self.late_replies
            );
        }
        let _ = writeln!(out, "before: {}", self.fingerprint_before);
        if let Some(a) = &self.fingerprint_after {
            let _ = writeln!(out, "after:  {a}");
        }
        for c in &self.codes {
            if c.outcome == CodeOutcome::Unchanged {
                continue;
            }
            let outcome = match &c.outcome {
                CodeOutcome::Failed(why) => format!("FAILED: {why}"),
                o => format!("{o:?}").to_lowercase(),
            };
            let _ = writeln!(out, "  {}: {} -> {}  {outcome}", c.code, c.old, c.new);
        }
        if let Some(t) = &self.transfer {
            out.push_str(&t.render());
        }
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        if let Some(j) = &self.journal {
            let _ = writeln!(
                out,
                "journal: {j} (holds old values, passwords included; mode 0600)"
            );
        }
        out
    }
}

/// An upload that did not complete: the error, and the report where the
/// transaction got far enough to have one.
#[derive(Debug)]
pub struct UploadFailure {
    /// What went wrong ([`EngineError::RolledBack`], [`EngineError::Inconsistent`],
    /// [`EngineError::Refused`], ...).
    pub error: Box<EngineError>,
    /// Per-code outcomes, when a journal was written.
    pub report: Option<Box<UploadReport>>,
}

impl std::fmt::Display for UploadFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.error.fmt(f)
    }
}

impl std::error::Error for UploadFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&*self.error)
    }
}

impl From<UploadFailure> for EngineError {
    fn from(f: UploadFailure) -> Self {
        *f.error
    }
}

impl From<EngineError> for UploadFailure {
    fn from(e: EngineError) -> Self {
        UploadFailure {
            error: Box::new(e),
            report: None,
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

/// Identify, check, read back and plan: what an upload would do, without
/// writing anything (`--dry-run`).
pub fn prepare(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    overrides: Overrides,
) -> Result<Prepared, EngineError> {
    let schema = client.schema().clone();
    let target = client.target().clone();
    let mut opts = PlanOptions {
        overrides,
        dataset: client.has_dataset_download(),
        running: Running::NotRead,
        identity: None,
    };
    let problems = check_set(&schema, set, &opts);
    if !problems.is_empty() {
        return Err(refused(&target, problems));
    }
    opts.identity = Some(client.identify()?);
    opts.running = client.running()?.into();
    let current = read_values(client, set.values.keys().copied())?;
    let plan = plan(&schema, set, &current, &opts).map_err(|p| refused(&target, p))?;
    let estimate = plan.estimate(set, &*client);
    Ok(Prepared {
        identity: opts.identity.unwrap_or_default(),
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

/// Why a step of a [`Transaction`] stopped.
#[derive(Debug)]
pub enum StepError {
    /// The transaction reached a final state; report this error as is.
    Settled(EngineError),
    /// Failed; [`Transaction::stopped`] rolls back if anything may have
    /// been written.
    Error(EngineError),
}

impl From<EngineError> for StepError {
    fn from(e: EngineError) -> Self {
        StepError::Error(e)
    }
}

impl StepError {
    /// The error.
    pub fn error(&self) -> &EngineError {
        match self {
            StepError::Settled(e) | StepError::Error(e) => e,
        }
    }
}

/// What [`Transaction::stopped`] decided.
#[derive(Debug)]
pub enum Next {
    /// The attempt was voided by a drive restart: run the steps again from
    /// [`Transaction::replan`] (the first attempt's backup is kept).
    Redo,
    /// The transaction is over (rolled back, failed, refused); this is the
    /// error to report.
    Failed(EngineError),
}

/// What [`Transaction::replan`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Replanned {
    /// The drive holds the set and no journal exists: nothing to do (the
    /// transaction is complete without a journal; go to
    /// [`Transaction::finish`]).
    Nothing,
    /// Writes are planned: go on with [`Transaction::journal`].
    Writes,
}

/// One code of a transaction: everything the runner knows about it.
#[derive(Debug, Clone, Default)]
struct CodeRecord {
    /// The old value (the first attempt's), once the code was planned.
    backup: Option<RawValue>,
    /// The set's value, once the code was planned.
    new: Option<RawValue>,
    /// Old and new value for humans.
    texts: (String, String),
    /// How the drive keeps it.
    storage: Option<Storage>,
    /// The phase of the latest plan that wrote it.
    phase: Option<Phase>,
    /// What happened to it.
    outcome: CodeOutcome,
    /// A write was sent to it in some attempt (it may have landed).
    touched: bool,
    /// The value the latest read-back found equal to the set's.
    unchanged: Option<RawValue>,
    /// The value read back equal to the set's after writing it.
    verified: Option<RawValue>,
}

/// The current attempt's plan and its progress.
#[derive(Debug)]
struct Attempt {
    plan: Plan,
    /// New values of the planned writes.
    expected: BTreeMap<CodeKey, RawValue>,
    /// Written, not yet read back (oldest first).
    pending: VecDeque<CodeKey>,
    /// The dataset's writes, in plan order.
    staged: Vec<CodeKey>,
    /// Dataset writes a broadcast sends instead of this drive's own
    /// SELECT ([`Transaction::expect_broadcast`]).
    broadcast: BTreeSet<CodeKey>,
    /// Broadcast codes already repaired by an own write.
    repaired: BTreeSet<CodeKey>,
}

/// An upload as explicit steps, for a caller that drives them one by one
/// (the line runner's broadcast); [`upload`] runs them in order.
///
/// ```text
/// begin -> replan -> journal -> open_dataset -> write_dataset -> commit
///       -> write_rest -> verify -> finish
/// ```
///
/// Each step takes the client it talks through; the transaction holds no
/// borrow of it, so a caller can keep several transactions of one bus open
/// and reach each drive through a client of its own per step
/// ([`Transaction::attach`] / [`Transaction::detach`] carry the telegram
/// counts across clients). A step's [`StepError`] goes to
/// [`Transaction::stopped`], which rolls back (or asks for a redo after a
/// drive restart). A failure to persist the journal is never dropped: the
/// step fails with it, and when it happens while settling, the reported
/// error names both what the drive holds and the journal failure.
#[derive(Debug)]
pub struct Transaction {
    schema: Arc<Schema>,
    target: Target,
    opts: UploadOptions,
    popts: PlanOptions,
    identity: Identity,
    journal: Option<JournalFile>,
    /// The state the journal on disk holds (the last one persisted).
    on_disk: Option<TxnState>,
    /// Every code the transaction planned or found unchanged.
    records: BTreeMap<CodeKey, CodeRecord>,
    /// Planned codes in write order (latest plan; earlier attempts' extra
    /// codes after).
    order: Vec<CodeKey>,
    attempt: Option<Attempt>,
    since_persist: usize,
    dataset_touched: bool,
    /// When SLOAD = -2 was ACKed ([`Transaction::end_dataset`]).
    dataset_ended: Option<driveset_link::Instant>,
    dataset_note: Option<String>,
    interleaved: usize,
    written_count: usize,
    attempts: u32,
    fingerprint_before: String,
    /// After a rollback that left a control word stopped instead of
    /// restoring its running value: the fingerprint of what the drive
    /// holds (read back), which is then not `fingerprint_before`.
    rolled_back_to: Option<String>,
    warnings: Vec<String>,
    start: driveset_link::Instant,
    /// The attached client's counters when it was attached.
    stats0: ClientStats,
    /// What earlier (detached) clients did.
    carried: ClientStats,
}

fn stats_add(a: ClientStats, b: ClientStats) -> ClientStats {
    ClientStats {
        telegrams: a.telegrams + b.telegrams,
        retries: a.retries + b.retries,
        sent: a.sent + b.sent,
        received: a.received + b.received,
        late: a.late + b.late,
        sload_polls: a.sload_polls + b.sload_polls,
    }
}

fn stats_since(now: ClientStats, then: ClientStats) -> ClientStats {
    ClientStats {
        telegrams: now.telegrams.saturating_sub(then.telegrams),
        retries: now.retries.saturating_sub(then.retries),
        sent: now.sent.saturating_sub(then.sent),
        received: now.received.saturating_sub(then.received),
        late: now.late.saturating_sub(then.late),
        sload_polls: now.sload_polls.saturating_sub(then.sload_polls),
    }
}

/// A step called out of order (a caller's mistake, not the drive's).
fn out_of_order(target: &Target, step: &str, before: &str) -> StepError {
    StepError::Settled(EngineError::refused(
        target.clone(),
        Refusal::StepOutOfOrder {
            step: step.into(),
            before: before.into(),
        },
    ))
}

impl Transaction {
    /// Check the set, refuse when the journal directory holds an
    /// unfinished journal of the drive, identify it and check again. Sends
    /// only the identify reads; nothing is journalled yet.
    pub fn begin(
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
        opts: &UploadOptions,
    ) -> Result<Transaction, EngineError> {
        let schema = client.schema().clone();
        let target = client.target().clone();
        let start = client.clock().now();
        let stats0 = client.stats();
        let mut popts = PlanOptions {
            overrides: opts.overrides,
            dataset: client.has_dataset_download(),
            running: Running::NotRead,
            identity: None,
        };
        let problems = check_set(&schema, set, &popts);
        if !problems.is_empty() {
            return Err(refused(&target, problems));
        }
        if opts.transfer.is_none() {
            check_unfinished(&*client, &opts.journal)?;
        }
        opts.observer.enter(client.clock(), Step::Identify, None);
        let identity = client.identify()?;
        popts.identity = Some(identity.clone());
        // The running-motor check is done in replan, only when something
        // has to be written (a re-run that changes nothing costs no exchange).
        let problems = check_set(&schema, set, &popts);
        if !problems.is_empty() {
            return Err(refused(&target, problems));
        }
        Ok(Transaction {
            schema,
            target,
            opts: opts.clone(),
            popts,
            identity,
            journal: None,
            on_disk: None,
            records: BTreeMap::new(),
            order: Vec::new(),
            attempt: None,
            since_persist: 0,
            dataset_touched: false,
            dataset_ended: None,
            rolled_back_to: None,
            dataset_note: None,
            interleaved: 0,
            written_count: 0,
            attempts: 0,
            fingerprint_before: String::new(),
            warnings: Vec::new(),
            start,
            stats0,
            carried: ClientStats::default(),
        })
    }

    /// What the drive said it is.
    pub fn identity(&self) -> &Identity {
        &self.identity
    }

    /// The journal file, once [`Transaction::journal`] created it.
    pub fn journal_file(&self) -> Option<&JournalFile> {
        self.journal.as_ref()
    }

    /// The current attempt's plan (after [`Transaction::replan`]).
    pub fn plan(&self) -> Option<&Plan> {
        self.attempt.as_ref().map(|a| &a.plan)
    }

    /// The codes the current attempt stages in the MC6000/7000 dataset, in
    /// write order.
    pub fn staged(&self) -> &[CodeKey] {
        self.attempt.as_ref().map_or(&[], |a| &a.staged)
    }

    /// The client the next steps go through is no longer `client`: keep
    /// its telegram counts for the report.
    pub fn detach(&mut self, client: &dyn DriveClient) {
        self.carried = stats_add(self.carried, stats_since(client.stats(), self.stats0));
        self.stats0 = client.stats();
    }

    /// The next steps go through `client` (after [`Transaction::detach`]
    /// of the previous one).
    pub fn attach(&mut self, client: &dyn DriveClient) {
        self.stats0 = client.stats();
    }

    /// The steps from now on report to `hook` (a caller that splits a
    /// drive's work into parts gives each part its own).
    pub fn set_observer(&mut self, hook: Hook) {
        self.opts.observer = hook;
    }

    /// Note for the report.
    pub fn warn(&mut self, note: String) {
        self.warnings.push(note);
    }

    fn stats(&self, client: &dyn DriveClient) -> ClientStats {
        stats_add(self.carried, stats_since(client.stats(), self.stats0))
    }

    fn journal_path(&self) -> String {
        self.opts.journal.display().to_string()
    }

    fn set_state(
        &mut self,
        client: &dyn DriveClient,
        state: TxnState,
        note: Option<String>,
    ) -> Result<(), EngineError> {
        let at = client.clock().now().as_nanos();
        if let Some(j) = &mut self.journal {
            j.journal.transition(state, at, note);
            j.persist()?;
            self.since_persist = 0;
            self.on_disk = Some(state);
        }
        Ok(())
    }

    fn note_written(&mut self, key: CodeKey) -> Result<(), EngineError> {
        self.written_count += 1;
        self.records.entry(key).or_default().outcome = CodeOutcome::Written;
        let every = self.opts.journal_every.max(1);
        if let Some(j) = &mut self.journal {
            j.journal
                .written
                .push(key.canonical(self.schema.code_style));
            self.since_persist += 1;
            if self.since_persist >= every {
                j.persist()?;
                self.since_persist = 0;
            }
        }
        Ok(())
    }

    fn backup_entry(&self, key: CodeKey, v: &RawValue) -> BackupEntry {
        BackupEntry {
            number: key.number,
            subcode: key.subcode,
            code: code_label(&self.schema, key),
            secret: is_secret(&self.schema, key),
            old: JournalValue::from(v),
        }
    }

    /// Old values by code (the journal's backup).
    fn backup(&self) -> BTreeMap<CodeKey, RawValue> {
        self.records
            .iter()
            .filter_map(|(k, r)| r.backup.clone().map(|v| (*k, v)))
            .collect()
    }

    /// The planned codes' new values.
    fn new_values(&self) -> BTreeMap<CodeKey, RawValue> {
        self.records
            .iter()
            .filter_map(|(k, r)| r.new.clone().map(|v| (*k, v)))
            .collect()
    }

    /// Codes a write was sent to.
    fn touched(&self) -> BTreeSet<CodeKey> {
        self.records
            .iter()
            .filter(|(_, r)| r.touched)
            .map(|(k, _)| *k)
            .collect()
    }

    /// Write order with each code's phase.
    fn phased_order(&self) -> Vec<(CodeKey, Phase)> {
        self.order
            .iter()
            .filter_map(|k| self.records.get(k).and_then(|r| r.phase).map(|p| (*k, p)))
            .collect()
    }

    fn set_outcome(&mut self, key: CodeKey, outcome: CodeOutcome) {
        self.records.entry(key).or_default().outcome = outcome;
    }

    fn take_attempt(&mut self, step: &str, before: &str) -> Result<Attempt, StepError> {
        self.attempt
            .take()
            .ok_or_else(|| out_of_order(&self.target, step, before))
    }

    /// Runs `f` on the current attempt, which stays current whatever `f`
    /// returns.
    fn with_attempt<R>(
        &mut self,
        step: &str,
        before: &str,
        f: impl FnOnce(&mut Self, &mut Attempt) -> Result<R, StepError>,
    ) -> Result<R, StepError> {
        let mut a = self.take_attempt(step, before)?;
        let r = f(self, &mut a);
        self.attempt = Some(a);
        r
    }

    /// One whole attempt: [`Transaction::replan`] and, when something is to
    /// be written, every following step up to [`Transaction::verify`].
    pub fn run_attempt(
        &mut self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
    ) -> Result<(), StepError> {
        if self.replan(client, set)? == Replanned::Nothing {
            return Ok(());
        }
        self.journal(client)?;
        self.open_dataset(client)?;
        self.write_dataset(client)?;
        self.commit(client)?;
        self.write_rest(client)?;
        self.verify(client, set)
    }

    /// Step 1 of an attempt: read the set's codes back, check the motor
    /// when something is to be written, plan, and update each code's
    /// record (the first attempt's old values are kept).
    pub fn replan(
        &mut self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
    ) -> Result<Replanned, StepError> {
        self.attempts += 1;
        self.attempt = None;
        let hook = &self.opts.observer;
        let current = read_observed(client, set.values.keys().copied(), hook, Step::Read)?;
        hook.enter(client.clock(), Step::Plan, None);
        let mut planned = plan(&self.schema, set, &current, &self.popts);
        if self.popts.running == Running::NotRead && planned.as_ref().is_ok_and(|p| !p.is_empty()) {
            // the running check is part of planning (one status read)
            self.popts.running = client.running()?.into();
            planned = plan(&self.schema, set, &current, &self.popts);
        }
        let plan = match planned {
            Ok(p) => p,
            Err(problems) => {
                let e = refused(&self.target, problems);
                return Err(if self.journal.is_none() {
                    StepError::Settled(e)
                } else {
                    StepError::Error(e)
                });
            }
        };
        if self.attempts == 1 {
            self.fingerprint_before = plan.fingerprint_before.clone();
            self.warnings.extend(plan.warnings.iter().cloned());
        }
        for r in self.records.values_mut() {
            r.unchanged = None;
        }
        for k in &plan.unchanged {
            if let Some(v) = current.values.get(k) {
                let r = self.records.entry(*k).or_default();
                r.unchanged = Some(v.clone());
                // written by an earlier attempt and read back equal now
                if r.new.as_ref() == Some(v) {
                    r.outcome = CodeOutcome::Verified;
                    r.verified = Some(v.clone());
                }
            }
        }
        for w in &plan.writes {
            let schema = Arc::clone(&self.schema);
            let r = self.records.entry(w.key).or_default();
            let old = r.backup.get_or_insert_with(|| w.old.clone());
            let old_text = value_text(&schema, w.key, old);
            r.new = Some(w.new.clone());
            r.storage = Some(w.storage);
            r.phase = Some(w.phase);
            r.texts = (old_text, w.new_text.clone());
            r.outcome = CodeOutcome::NotWritten;
        }
        // write order: this plan's, then codes only an earlier attempt planned
        let mut order: Vec<CodeKey> = plan.writes.iter().map(|w| w.key).collect();
        for k in &self.order {
            if !order.contains(k) {
                order.push(*k);
            }
        }
        self.order = order;
        let nothing = plan.is_empty() && self.journal.is_none();
        let expected = plan.writes.iter().map(|w| (w.key, w.new.clone())).collect();
        let staged = plan
            .writes
            .iter()
            .filter(|w| w.phase == Phase::Dataset)
            .map(|w| w.key)
            .collect();
        self.attempt = Some(Attempt {
            plan,
            expected,
            pending: VecDeque::new(),
            staged,
            broadcast: BTreeSet::new(),
            repaired: BTreeSet::new(),
        });
        Ok(if nothing {
            Replanned::Nothing
        } else {
            Replanned::Writes
        })
    }

    /// Step 2: create the journal with the backup (or, in a redone
    /// attempt, update it) and make it durable; state `writing`. Nothing
    /// is written to the drive before this returns `Ok`.
    pub fn journal(&mut self, client: &mut dyn DriveClient) -> Result<(), StepError> {
        let a = self.take_attempt("journal", "replan")?;
        self.opts
            .observer
            .enter(client.clock(), Step::Journal, None);
        let records: Vec<PlanEntryRecord> = a
            .plan
            .writes
            .iter()
            .map(|w| PlanEntryRecord {
                number: w.key.number,
                subcode: w.key.subcode,
                code: w.label.clone(),
                secret: w.secret,
                storage: w.storage,
                width: w.width,
                phase: w.phase,
                new: JournalValue::from(&w.new),
            })
            .collect();
        let set_fingerprint = a.plan.set_fingerprint.clone();
        let fingerprint_before = a.plan.fingerprint_before.clone();
        self.attempt = Some(a);
        let backup: Vec<BackupEntry> = self
            .records
            .iter()
            .filter_map(|(k, r)| r.backup.as_ref().map(|v| self.backup_entry(*k, v)))
            .collect();
        let unchanged: Vec<BackupEntry> = self
            .records
            .iter()
            .filter(|(_, r)| r.backup.is_none())
            .filter_map(|(k, r)| r.unchanged.as_ref().map(|v| self.backup_entry(*k, v)))
            .collect();
        match &mut self.journal {
            None => {
                let at = client.clock().now().as_nanos();
                let mut journal = Journal {
                    journal_version: JOURNAL_VERSION,
                    state: TxnState::Planned,
                    target: JournalTarget::of(&*client),
                    identity: (&self.identity).into(),
                    schema: self.schema.id.clone(),
                    schema_source: crate::journal::SchemaSource::of(&self.schema),
                    set_fingerprint,
                    fingerprint_before,
                    dataset: self.popts.dataset,
                    attempt: self.attempts,
                    backup,
                    plan: records,
                    unchanged,
                    written: Vec::new(),
                    broadcast: Vec::new(),
                    transitions: Vec::new(),
                    failure: None,
                    failure_cause: None,
                    holding: Vec::new(),
                    transfer: self.opts.transfer.clone(),
                    assign: None,
                };
                journal.transition(TxnState::Planned, at, None);
                crate::journal::ensure_dir(journal_dir(&self.opts.journal))
                    .map_err(StepError::Settled)?;
                let file = if self.opts.transfer.is_some() {
                    // crate::transfer's journal of this transaction
                    JournalFile::replace(&self.opts.journal, journal)
                } else {
                    JournalFile::create(&self.opts.journal, journal)
                };
                self.journal = Some(file.map_err(StepError::Settled)?);
                self.on_disk = Some(TxnState::Planned);
            }
            Some(j) => {
                // keep codes only an earlier attempt planned (their new value is the set's)
                let mut records = records;
                for r in &j.journal.plan {
                    if !records
                        .iter()
                        .any(|n| n.number == r.number && n.subcode == r.subcode)
                    {
                        records.push(r.clone());
                    }
                }
                j.journal.backup = backup;
                j.journal.plan = records;
                j.journal.unchanged = unchanged;
                j.journal.attempt = self.attempts;
                j.journal.written.clear();
                j.journal.broadcast.clear();
            }
        }
        self.set_state(client, TxnState::Writing, None)?;
        Ok(())
    }

    /// Step 3 (MC6000/7000): when the plan stages values, register the
    /// dataset download (SLOAD = -1, LUSTBUS 11.4). `Ok(true)`: a dataset
    /// is open.
    pub fn open_dataset(&mut self, client: &mut dyn DriveClient) -> Result<bool, StepError> {
        let staged = self.staged().to_vec();
        if self.attempt.is_none() {
            return Err(out_of_order(&self.target, "open_dataset", "journal"));
        }
        if staged.is_empty() {
            return Ok(false);
        }
        self.dataset_touched = true;
        self.opts
            .observer
            .enter(client.clock(), Step::Dataset, None);
        client.dataset_begin()?;
        Ok(true)
    }

    /// Between [`Transaction::open_dataset`] and
    /// [`Transaction::write_dataset`]: `keys` (staged codes of this
    /// attempt) reach the drive's dataset by a broadcast the caller sends,
    /// not by this drive's own SELECTs. Records them in the journal (field
    /// `broadcast`: they may have landed) and makes it durable before the
    /// caller broadcasts. [`Transaction::verify`] reads them back like every
    /// code; one that did not land is written on its own and verified.
    pub fn expect_broadcast(&mut self, keys: &[CodeKey]) -> Result<(), StepError> {
        let mut a = self.take_attempt("expect_broadcast", "open_dataset")?;
        let mut unknown = Vec::new();
        for k in keys {
            if a.staged.contains(k) {
                a.broadcast.insert(*k);
            } else {
                unknown.push(code_label(&self.schema, *k));
            }
        }
        let names: Vec<String> = a
            .broadcast
            .iter()
            .map(|k| k.canonical(self.schema.code_style))
            .collect();
        let marked: Vec<CodeKey> = a.broadcast.iter().copied().collect();
        self.attempt = Some(a);
        if !unknown.is_empty() {
            return Err(StepError::Error(EngineError::refused(
                self.target.clone(),
                Refusal::BroadcastNotStaged { codes: unknown },
            )));
        }
        for k in marked {
            self.records.entry(k).or_default().touched = true;
        }
        if let Some(j) = &mut self.journal {
            j.journal.broadcast = names;
            j.persist()?;
            self.since_persist = 0;
        }
        Ok(())
    }

    /// The broadcast [`Transaction::expect_broadcast`] announced is not
    /// sent: this drive writes those values itself. The journal keeps
    /// listing them until its next persist (harmless: recovery reads the
    /// drive).
    pub fn cancel_broadcast(&mut self) {
        if let Some(a) = &mut self.attempt {
            a.broadcast.clear();
        }
        if let Some(j) = &mut self.journal {
            j.journal.broadcast.clear();
        }
    }

    /// Step 4: the staged writes (except those a broadcast sends).
    pub fn write_dataset(&mut self, client: &mut dyn DriveClient) -> Result<(), StepError> {
        self.with_attempt("write_dataset", "journal", |tx, a| {
            let keys: Vec<CodeKey> = a
                .staged
                .iter()
                .filter(|k| !a.broadcast.contains(k))
                .copied()
                .collect();
            if !a.staged.is_empty() {
                let n = Some(a.plan.writes.len());
                tx.opts.observer.enter(client.clock(), Step::Write, n);
            }
            for k in keys {
                tx.pace(client, k, a)?;
                tx.write(client, k, a)?;
            }
            Ok(())
        })
    }

    /// Step 5 (MC6000/7000): end the dataset download (SLOAD = -2) and poll
    /// until the drive accepts it (state `committed`) or rejects it (the
    /// drive reactivated its old set: confirmed by reading the backup
    /// back, state `rolled-back`). [`Transaction::end_dataset`] and
    /// [`Transaction::await_dataset`] are the same in two halves.
    pub fn commit(&mut self, client: &mut dyn DriveClient) -> Result<(), StepError> {
        self.with_attempt("commit", "journal", |tx, a| {
            if a.staged.is_empty() {
                return Ok(());
            }
            tx.opts.observer.enter(client.clock(), Step::Commit, None);
            let outcome = client.dataset_commit(tx.opts.dataset_timeout)?;
            tx.dataset_settled(client, a, outcome)
        })
    }

    /// Step 5, first half: SLOAD = -2 only; the drive checks and stores
    /// while the caller talks to other drives of the bus.
    pub fn end_dataset(&mut self, client: &mut dyn DriveClient) -> Result<(), StepError> {
        self.with_attempt("end_dataset", "journal", |tx, a| {
            if a.staged.is_empty() {
                return Ok(());
            }
            tx.opts.observer.enter(client.clock(), Step::Commit, None);
            tx.dataset_ended = Some(client.dataset_end()?);
            Ok(())
        })
    }

    /// Step 5, second half: poll SLOAD (the timeout counts from
    /// [`Transaction::end_dataset`]), then as [`Transaction::commit`].
    pub fn await_dataset(&mut self, client: &mut dyn DriveClient) -> Result<(), StepError> {
        self.with_attempt("await_dataset", "journal", |tx, a| {
            if a.staged.is_empty() {
                return Ok(());
            }
            let Some(ended) = tx.dataset_ended.take() else {
                return Err(out_of_order(&tx.target, "await_dataset", "end_dataset"));
            };
            tx.opts.observer.enter(client.clock(), Step::Commit, None);
            let outcome = client.dataset_await(ended, tx.opts.dataset_timeout)?;
            tx.dataset_settled(client, a, outcome)
        })
    }

    fn dataset_settled(
        &mut self,
        client: &mut dyn DriveClient,
        a: &mut Attempt,
        outcome: DatasetOutcome,
    ) -> Result<(), StepError> {
        match outcome {
            DatasetOutcome::Accepted => {
                self.dataset_note = Some("accepted (SLOAD = 0)".into());
                self.set_state(
                    client,
                    TxnState::Committed,
                    Some("the drive accepted the dataset (SLOAD = 0)".into()),
                )?;
                a.pending.extend(a.staged.iter().copied());
                Ok(())
            }
            DatasetOutcome::Rejected { parameter } => {
                let staged = a.staged.clone();
                Err(self.dataset_rejected(client, parameter, &staged))
            }
        }
    }

    /// Step 6: the writes after the dataset (stored values, control, mode,
    /// link), pacing MC6000/7000 EEPROM writes with verification reads.
    pub fn write_rest(&mut self, client: &mut dyn DriveClient) -> Result<(), StepError> {
        self.with_attempt("write_rest", "journal", |tx, a| {
            let writes: Vec<(CodeKey, Storage)> = a
                .plan
                .writes
                .iter()
                .filter(|w| w.phase != Phase::Dataset)
                .map(|w| (w.key, w.storage))
                .collect();
            if !writes.is_empty() {
                let n = Some(a.plan.writes.len());
                tx.opts.observer.enter(client.clock(), Step::Write, n);
            }
            for (key, storage) in writes {
                tx.pace(client, key, a)?;
                tx.write(client, key, a)?;
                a.pending.push_back(key);
                if let Strategy::Naive { eeprom_wait } = tx.opts.strategy
                    && matches!(storage, Storage::Eeprom | Storage::FselIsel)
                {
                    client.clock().sleep(eeprom_wait);
                }
            }
            Ok(())
        })
    }

    /// Step 7: read back every written code not yet verified (state
    /// `verifying`), then `complete` with the fingerprint of what the
    /// drive holds.
    pub fn verify(
        &mut self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
    ) -> Result<(), StepError> {
        self.with_attempt("verify", "journal", |tx, a| {
            tx.set_state(client, TxnState::Verifying, None)?;
            let n = Some(a.expected.len());
            tx.opts.observer.enter(client.clock(), Step::Verify, n);
            while let Some(k) = a.pending.pop_front() {
                tx.verify_one(client, k, a)?;
            }
            Ok(())
        })?;
        let after_fp = self.after(set).fingerprint();
        self.set_state(
            client,
            TxnState::Complete,
            Some(format!("drive holds {after_fp}")),
        )?;
        Ok(())
    }

    /// What the drive holds now, over the set's codes (verified or found
    /// unchanged).
    fn after(&self, set: &ResolvedSet) -> ResolvedSet {
        let mut after = ResolvedSet::new(&self.schema);
        for k in set.values.keys() {
            if let Some(r) = self.records.get(k)
                && let Some(v) = r.verified.as_ref().or(r.unchanged.as_ref())
            {
                after.insert(*k, v.clone());
            }
        }
        after
    }

    /// After a step failed: a restart voids the attempt ([`Next::Redo`],
    /// at most [`UploadOptions::max_restarts`] times); any other failure
    /// rolls back when a journal exists.
    pub fn stopped(&mut self, client: &mut dyn DriveClient, stop: StepError) -> Next {
        match stop {
            StepError::Settled(e) => Next::Failed(e),
            StepError::Error(e)
                if matches!(*e.kind, ErrorKind::Restarted { .. })
                    && self.attempts <= self.opts.max_restarts =>
            {
                if self.journal.is_some() {
                    let note = format!("{e}; redoing from the read-back");
                    self.warnings.push(note.clone());
                    if let Err(je) = self.set_state(client, TxnState::Planned, Some(note)) {
                        return Next::Failed(self.fail(client, je));
                    }
                }
                Next::Redo
            }
            StepError::Error(e) => {
                if self.journal.is_none() {
                    Next::Failed(e)
                } else {
                    Next::Failed(self.fail(client, e))
                }
            }
        }
    }

    /// The end: the report, and the error when `result` is one (with the
    /// report once a journal exists).
    pub fn finish(
        self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
        result: Result<(), EngineError>,
    ) -> Result<UploadReport, UploadFailure> {
        self.opts.observer.end(client.clock());
        let report = self.report(&*client, set);
        match result {
            Ok(()) => Ok(report),
            Err(e) => Err(UploadFailure {
                error: Box::new(e),
                report: self.journal.as_ref().map(|_| Box::new(report)),
            }),
        }
    }

    fn write(
        &mut self,
        client: &mut dyn DriveClient,
        key: CodeKey,
        a: &Attempt,
    ) -> Result<(), StepError> {
        let Some(v) = a.expected.get(&key) else {
            return Ok(());
        };
        self.records.entry(key).or_default().touched = true;
        if let Err(e) = client.write(key, v) {
            // A refusal the drive gave with its own cause (LUSTBUS / LECOM
            // NAK: "the parameter value was not changed"; an SDO abort) left
            // the code as it was: there is nothing of it to roll back. Any
            // other failure (no answer, a garbled one) may or may not have
            // landed, so the code stays touched (a broadcast one always).
            let r = self.records.entry(key).or_default();
            if matches!(*e.kind, ErrorKind::Device { .. }) && !a.broadcast.contains(&key) {
                r.touched = false;
            }
            r.outcome = CodeOutcome::Failed(e.to_string());
            return Err(StepError::Error(e));
        }
        self.note_written(key)?;
        let touched = self.records.values().filter(|r| r.touched).count();
        let (done, total) = (touched, self.order.len().max(touched));
        self.opts
            .observer
            .step(client.clock(), Step::Write, done, total);
        Ok(())
    }

    /// Wait until the drive takes a write of `key`, filling the gap with
    /// verification reads that fit.
    fn pace(
        &mut self,
        client: &mut dyn DriveClient,
        key: CodeKey,
        a: &mut Attempt,
    ) -> Result<(), StepError> {
        if matches!(self.opts.strategy, Strategy::Naive { .. }) {
            // the client itself still waits whatever store time is left
            return Ok(());
        }
        let Some(ready) = client.ready_for_write(key) else {
            return Ok(());
        };
        loop {
            let now = client.clock().now();
            if ready <= now {
                break;
            }
            let gap = ready - now;
            // A read that fits the gap; else any read: it is work the
            // transaction must do anyway, and running past `ready` by part of
            // a read costs less than idling through the whole gap.
            let Some(i) = a
                .pending
                .iter()
                .position(|k| client.read_time(*k) <= gap)
                .or(if a.pending.is_empty() { None } else { Some(0) })
            else {
                break;
            };
            let Some(k) = a.pending.remove(i) else {
                break;
            };
            self.verify_one(client, k, a)?;
            self.interleaved += 1;
        }
        client.clock().sleep_until(ready);
        Ok(())
    }

    fn verify_one(
        &mut self,
        client: &mut dyn DriveClient,
        key: CodeKey,
        a: &mut Attempt,
    ) -> Result<(), StepError> {
        let Some(want) = a.expected.get(&key).cloned() else {
            return Ok(());
        };
        let got = match client.read(key) {
            Ok(v) => v,
            Err(e) => {
                self.set_outcome(key, CodeOutcome::Failed(format!("verify: {e}")));
                return Err(StepError::Error(e));
            }
        };
        if got != want && a.broadcast.contains(&key) && a.repaired.insert(key) {
            // The broadcast did not land on this drive (no receipt tells):
            // the value is written on its own, then read back.
            let note = format!(
                "{}: the broadcast value did not land (reads back {}); written on its own and verified",
                code_label(&self.schema, key),
                value_text(&self.schema, key, &got)
            );
            self.warnings.push(note);
            self.write(client, key, a)?;
            return self.verify_one(client, key, a);
        }
        if got != want {
            let detail = format!(
                "reads back {} instead of {}; the drive did not take the value",
                value_text(&self.schema, key, &got),
                value_text(&self.schema, key, &want)
            );
            self.set_outcome(key, CodeOutcome::Failed(detail.clone()));
            return Err(StepError::Error(EngineError::protocol(
                self.target.clone(),
                format!("verify {}", code_label(&self.schema, key)),
                detail,
            )));
        }
        let r = self.records.entry(key).or_default();
        r.outcome = CodeOutcome::Verified;
        r.verified = Some(got);
        if self.opts.observer.is_set() {
            let done = a
                .expected
                .keys()
                .filter(|k| self.records.get(k).is_some_and(|r| r.verified.is_some()))
                .count();
            self.opts
                .observer
                .step(client.clock(), Step::Verify, done, a.expected.len());
        }
        Ok(())
    }

    /// SLOAD went to a parameter number: the drive reactivated its old set.
    fn dataset_rejected(
        &mut self,
        client: &mut dyn DriveClient,
        parameter: u32,
        staged: &[CodeKey],
    ) -> StepError {
        let name = code_label(&self.schema, CodeKey::new(parameter));
        let detail = format!(
            "the drive rejected the dataset at parameter {name} (the first invalid value) and reactivated its old set; fix {name} in the set"
        );
        self.dataset_note = Some(format!("rejected at parameter {name}"));
        for k in staged {
            self.set_outcome(*k, CodeOutcome::Failed("dataset rejected".into()));
        }
        let cause = EngineError::device(
            self.target.clone(),
            "dataset download (80-SLOAD)",
            DeviceCause::DatasetRejected {
                parameter,
                name: name.clone(),
                backup: false,
            },
        );
        // confirm nothing changed
        let n = Some(self.backup().len());
        self.opts.observer.enter(client.clock(), Step::Rollback, n);
        let plan = RollbackPlan::new(&self.schema, &self.backup(), &self.new_values());
        match self.compare_with_backup(client, &plan) {
            Ok(diffs) if diffs.is_empty() => {
                self.dataset_touched = false;
                if let Err(e) = self.set_state(client, TxnState::RolledBack, Some(detail.clone())) {
                    return StepError::Settled(self.journal_lost(
                        e,
                        TxnState::RolledBack,
                        &format!("{detail}; the drive holds its old values again (verified)"),
                    ));
                }
                StepError::Settled(EngineError::rolled_back(
                    self.target.clone(),
                    self.journal_path(),
                    detail,
                    cause,
                ))
            }
            _ => StepError::Error(cause),
        }
    }

    /// A journal persist failed while the transaction settled in `state`:
    /// the error names what the drive holds (`drive`) and that the journal
    /// on disk still says an earlier state.
    fn journal_lost(&self, persist: EngineError, state: TxnState, drive: &str) -> EngineError {
        let on_disk = self.on_disk.map_or("an earlier state", TxnState::as_str);
        EngineError::journal(
            self.journal_path(),
            format!(
                "{drive}; but recording state `{}` failed ({persist}), so the journal on disk still says `{on_disk}`: fix the journal directory, then run `driveset recover {}`",
                state.as_str(),
                self.journal_path()
            ),
        )
    }

    /// Read every backed-up code; the codes that differ from the backup.
    fn compare_with_backup(
        &mut self,
        client: &mut dyn DriveClient,
        plan: &RollbackPlan,
    ) -> Result<Vec<CodeKey>, EngineError> {
        let mut diffs = Vec::new();
        let keys: BTreeSet<CodeKey> = plan.keys().collect();
        let mut held = ResolvedSet::new(&self.schema);
        for k in keys {
            let now = client.read(k)?;
            if !plan.holds(k, &now) {
                diffs.push(k);
            }
            held.insert(k, now);
        }
        if held
            .values
            .iter()
            .any(|(k, v)| self.backup().get(k) != Some(v))
        {
            for (k, r) in &self.records {
                if let Some(v) = &r.unchanged {
                    held.insert(*k, v.clone());
                }
            }
            self.rolled_back_to = Some(held.fingerprint());
        }
        Ok(diffs)
    }

    /// Roll back after `cause`; returns the error to report.
    fn fail(&mut self, client: &mut dyn DriveClient, cause: EngineError) -> EngineError {
        let cause_text = cause.to_string();
        if let Some(j) = &mut self.journal {
            j.journal.failure = Some(cause_text.clone());
            j.journal.failure_cause = Some(FailureCause::of(&cause));
        }
        let n = Some(self.touched().len());
        self.opts.observer.enter(client.clock(), Step::Rollback, n);
        if let Err(e) = self.set_state(client, TxnState::RollingBack, Some(cause_text.clone())) {
            // The journal on disk still says an earlier state and holds the
            // backup; nothing is sent while it cannot be updated.
            return self.journal_lost(
                e,
                TxnState::RollingBack,
                &format!("{cause_text}; nothing was rolled back"),
            );
        }
        let plan = RollbackPlan::new(&self.schema, &self.backup(), &self.new_values());
        let notes = plan.notes(&self.schema, &self.touched());
        let restore_result = restore(
            client,
            &self.schema,
            &self.phased_order(),
            &plan.restore,
            &self.touched(),
            self.dataset_touched,
            self.opts.dataset_timeout,
        )
        .and_then(|()| self.compare_with_backup(client, &plan));
        match restore_result {
            Ok(diffs) if diffs.is_empty() => {
                for k in self.touched() {
                    let r = self.records.entry(k).or_default();
                    if !matches!(r.outcome, CodeOutcome::Failed(_)) {
                        r.outcome = CodeOutcome::Restored;
                    }
                }
                self.warnings.extend(notes.iter().cloned());
                let with_notes = std::iter::once(cause_text.clone())
                    .chain(notes.iter().cloned())
                    .collect::<Vec<_>>()
                    .join("; ");
                let detail = format!("{with_notes}; restored the old values");
                if let Err(e) = self.set_state(client, TxnState::RolledBack, Some(detail.clone())) {
                    return self.journal_lost(
                        e,
                        TxnState::RolledBack,
                        &format!("{detail} (read back and compared)"),
                    );
                }
                EngineError::rolled_back(
                    self.target.clone(),
                    self.journal_path(),
                    with_notes,
                    cause,
                )
            }
            other => {
                let restore_err = match other {
                    Ok(diffs) => format!(
                        "after restoring, {} still differ from the backup",
                        diffs
                            .iter()
                            .map(|k| code_label(&self.schema, *k))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    Err(e) => format!("restoring the old values failed: {e}"),
                };
                let holding = holdings(client, &self.schema, &self.backup(), &self.new_values());
                let detail = format!(
                    "{cause_text}; {restore_err}; {}",
                    describe_holdings(&holding)
                );
                if let Some(j) = &mut self.journal {
                    j.journal.holding = holding;
                }
                if let Err(e) = self.set_state(client, TxnState::Failed, Some(detail.clone())) {
                    return self.journal_lost(
                        e,
                        TxnState::Failed,
                        &format!("the drive holds a mix of old and new values: {detail}"),
                    );
                }
                EngineError::inconsistent(self.target.clone(), self.journal_path(), detail)
            }
        }
    }

    /// The report so far.
    pub fn report(&self, client: &dyn DriveClient, set: &ResolvedSet) -> UploadReport {
        let stats = self.stats(client);
        let state = self
            .journal
            .as_ref()
            .map(|j| j.journal.state)
            .unwrap_or(TxnState::Complete);
        let mut codes = Vec::new();
        for k in &self.order {
            let r = self.records.get(k).cloned().unwrap_or_default();
            let (old, new) = r.texts;
            codes.push(CodeReport {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.schema, *k),
                old,
                new,
                storage: r.storage,
                outcome: r.outcome,
            });
        }
        for (k, r) in &self.records {
            let Some(v) = &r.unchanged else { continue };
            if r.new.is_some() {
                continue;
            }
            let t = value_text(&self.schema, *k, v);
            codes.push(CodeReport {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.schema, *k),
                old: t.clone(),
                new: t,
                storage: None,
                outcome: CodeOutcome::Unchanged,
            });
        }
        let fingerprint_after = match state {
            TxnState::Complete => Some(self.after(set).fingerprint()),
            TxnState::RolledBack => Some(
                self.rolled_back_to
                    .clone()
                    .unwrap_or_else(|| self.fingerprint_before.clone()),
            ),
            _ => None,
        };
        UploadReport {
            target: self.target.to_string(),
            identity: self.identity.clone(),
            schema: self.schema.id.clone(),
            journal: self
                .journal
                .as_ref()
                .map(|j| j.path().display().to_string()),
            state,
            set_fingerprint: set.fingerprint(),
            fingerprint_before: self.fingerprint_before.clone(),
            fingerprint_after,
            codes_in_set: set.values.len(),
            codes_written: self.written_count,
            attempts: self.attempts,
            telegrams: stats.telegrams,
            retries: stats.retries,
            elapsed: client.clock().now() - self.start,
            interleaved_reads: self.interleaved,
            dataset: self.dataset_note.clone(),
            sload_polls: Some(stats.sload_polls).filter(|n| *n > 0),
            late_replies: stats.late,
            codes,
            warnings: self.warnings.clone(),
            transfer: None,
        }
    }
}

/// What a rollback (the upload's or `recover`'s) writes back and accepts:
/// the backup, except a control word whose old value is not a stopped state
/// (the motor was running before the transaction). That one is restored to
/// its stopped state ([`crate::guard::stopped_instead`]: the old value with
/// its start / enable / release and reset bits cleared, or its first
/// `stopped` value), never to the running value, and a drive that still
/// holds the old value (the code was never written) counts as restored
/// too. A journal edited by hand is no different: its old values are what
/// the plan is made from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct RollbackPlan {
    /// The value each code is restored to.
    pub restore: BTreeMap<CodeKey, RawValue>,
    /// Control words whose old value was not stopped: that old value.
    running_old: BTreeMap<CodeKey, RawValue>,
}

impl RollbackPlan {
    /// The plan for `backup` (old values) of a transaction that wrote
    /// `new_values`, under `schema`'s roles.
    pub(crate) fn new(
        schema: &Schema,
        backup: &BTreeMap<CodeKey, RawValue>,
        new_values: &BTreeMap<CodeKey, RawValue>,
    ) -> Self {
        let mut restore = BTreeMap::new();
        let mut running_old = BTreeMap::new();
        for (k, old) in backup {
            match schema.code(k.number) {
                Some(code) if !crate::guard::is_stopped(schema, code, old) => {
                    running_old.insert(*k, old.clone());
                    if let Some(stop) =
                        crate::guard::stopped_instead(schema, code, old, new_values.get(k))
                    {
                        restore.insert(*k, stop);
                    }
                }
                _ => {
                    restore.insert(*k, old.clone());
                }
            }
        }
        RollbackPlan {
            restore,
            running_old,
        }
    }

    /// Whether `now`, read from `key` after the rollback, is what the
    /// rollback leaves there.
    pub(crate) fn holds(&self, key: CodeKey, now: &RawValue) -> bool {
        self.restore.get(&key) == Some(now) || self.running_old.get(&key) == Some(now)
    }

    /// The codes the plan restores (every backed-up code but a running
    /// control word without a known stopped state), for `holds` checks.
    pub(crate) fn keys(&self) -> impl Iterator<Item = CodeKey> + '_ {
        self.restore.keys().chain(self.running_old.keys()).copied()
    }

    /// What the rollback says about the control words it left stopped
    /// among `touched`: "416-SCTL1 left stopped: the motor was running
    /// before; start it from the machine's control".
    pub(crate) fn notes(&self, schema: &Schema, touched: &BTreeSet<CodeKey>) -> Vec<String> {
        self.running_old
            .keys()
            .filter(|k| touched.contains(k))
            .map(|k| {
                let name = code_label(schema, *k);
                if self.restore.contains_key(k) {
                    format!(
                        "{name} left stopped: the motor was running before; start it from the machine's control"
                    )
                } else {
                    format!(
                        "{name} not restored: the motor was running before and the schema knows no stopped state of it; start it from the machine's control"
                    )
                }
            })
            .collect()
    }
}

/// Restore `backup` values of the `touched` codes in reverse `order`;
/// CardWriteable codes (when `dataset`) again through a dataset download of
/// every backed-up CardWriteable value, last (they were written first).
///
/// Every code is tried even when one fails, so as much of the old set as the
/// drive takes is back; the first failure is returned and the caller reads
/// back what each code holds.
pub(crate) fn restore(
    client: &mut dyn DriveClient,
    schema: &Schema,
    order: &[(CodeKey, Phase)],
    backup: &BTreeMap<CodeKey, RawValue>,
    touched: &BTreeSet<CodeKey>,
    dataset: bool,
    dataset_timeout: Duration,
) -> Result<(), EngineError> {
    let mut first_error: Option<EngineError> = None;
    for (k, phase) in order.iter().rev() {
        if *phase == Phase::Dataset || !touched.contains(k) {
            continue;
        }
        if let Some(old) = backup.get(k)
            && let Err(e) = client.write(*k, old)
        {
            first_error.get_or_insert(e);
        }
    }
    let staged: Vec<(CodeKey, &RawValue)> = order
        .iter()
        .filter(|(_, p)| *p == Phase::Dataset)
        .filter_map(|(k, _)| backup.get(k).map(|v| (*k, v)))
        .collect();
    if dataset
        && !staged.is_empty()
        && let Err(e) = restore_dataset(client, schema, &staged, dataset_timeout)
    {
        first_error.get_or_insert(e);
    }
    match first_error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The MC6000/7000 part of [`restore`]: one dataset download of the
/// backed-up CardWriteable values.
fn restore_dataset(
    client: &mut dyn DriveClient,
    schema: &Schema,
    staged: &[(CodeKey, &RawValue)],
    dataset_timeout: Duration,
) -> Result<(), EngineError> {
    client.dataset_begin()?;
    for (k, old) in staged {
        client.write(*k, old)?;
    }
    match client.dataset_commit(dataset_timeout)? {
        DatasetOutcome::Accepted => Ok(()),
        DatasetOutcome::Rejected { parameter } => {
            let name = code_label(schema, CodeKey::new(parameter));
            Err(EngineError::device(
                client.target().clone(),
                "dataset download of the backup (80-SLOAD)",
                DeviceCause::DatasetRejected {
                    parameter,
                    name,
                    backup: true,
                },
            ))
        }
    }
}

/// What each backed-up code holds now.
pub(crate) fn holdings(
    client: &mut dyn DriveClient,
    schema: &Schema,
    backup: &BTreeMap<CodeKey, RawValue>,
    new_values: &BTreeMap<CodeKey, RawValue>,
) -> Vec<CodeHolding> {
    backup
        .iter()
        .map(|(k, old)| {
            let holds = match client.read(*k) {
                Ok(v) if &v == old => Holding::Old,
                Ok(v) if new_values.get(k) == Some(&v) => Holding::New,
                Ok(_) => Holding::Other,
                Err(_) => Holding::Unknown,
            };
            CodeHolding {
                code: code_label(schema, *k),
                holds,
            }
        })
        .collect()
}

pub(crate) fn describe_holdings(h: &[CodeHolding]) -> String {
    let mut by: BTreeMap<Holding, Vec<&str>> = BTreeMap::new();
    for x in h {
        by.entry(x.holds).or_default().push(x.code.as_str());
    }
    let parts: Vec<String> = [Holding::New, Holding::Other, Holding::Unknown, Holding::Old]
        .iter()
        .filter_map(|w| {
            by.get(w)
                .map(|codes| format!("{} {}", codes.join(", "), w.describe()))
        })
        .collect();
    if parts.is_empty() {
        "no planned codes".into()
    } else {
        parts.join("; ")
    }
}

/// The journal path of the drive `client` reaches, in `dir`: the one
/// naming scheme of `upload` and `commission`
/// ([`crate::journal::journal_path`]: bus id and address, sanitised).
pub fn default_journal_path(dir: &Path, client: &dyn DriveClient) -> PathBuf {
    crate::journal::journal_path(dir, &client.bus_id(), client.target().address)
}

/// The directory [`upload`] scans for unfinished journals: the journal
/// file's own.
fn journal_dir(journal: &Path) -> &Path {
    match journal.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// The guard: refuse (nothing sent) when the journal directory holds an
/// unfinished journal of the drive `client` reaches, whatever its file
/// name or port spelling ([`crate::journal::unfinished_for`]).
pub fn check_unfinished(client: &dyn DriveClient, journal: &Path) -> Result<(), EngineError> {
    let target = client.target();
    let found = crate::journal::unfinished_for(
        journal_dir(journal),
        &client.bus_id(),
        &target.port,
        target.address,
    )?;
    if found.is_empty() {
        Ok(())
    } else {
        Err(crate::journal::unfinished_error(target, &found))
    }
}
