//! The upload transaction (DESIGN.md "Transactions"): identify, read back,
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
//! Times come only from the client's clock.
//!
//! **Progress.** The runner reports its own phase to
//! [`UploadOptions::observer`] ([`crate::observe`]): identify, read, plan,
//! journal, dataset, write (code i of n), commit (SLOAD poll), verify,
//! rollback; a rollback is reported as such, whatever telegrams it sends.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use crate::client::{DatasetOutcome, DriveClient, Identity, Target};
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
            observer: Hook::none(),
        }
    }
}

/// What happened to one code of the set.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "outcome", content = "detail")]
pub enum CodeOutcome {
    /// The drive already held the value.
    Unchanged,
    /// Planned, not written (the transaction stopped before it).
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
pub fn upload(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    opts: &UploadOptions,
) -> Result<UploadReport, UploadFailure> {
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
        return Err(refused(&target, problems).into());
    }
    check_unfinished(&*client, &opts.journal)?;
    opts.observer.enter(client.clock(), Step::Identify, None);
    let identity = client.identify()?;
    popts.identity = Some(identity.clone());
    // The running-motor check is done in the attempt, only when something
    // has to be written (a re-run that changes nothing costs no exchange).
    let problems = check_set(&schema, set, &popts);
    if !problems.is_empty() {
        return Err(refused(&target, problems).into());
    }
    let mut tx = Txn {
        client,
        schema,
        target,
        opts,
        popts,
        identity,
        journal: None,
        backup: BTreeMap::new(),
        order: Vec::new(),
        touched: BTreeSet::new(),
        new_values: BTreeMap::new(),
        outcomes: BTreeMap::new(),
        texts: BTreeMap::new(),
        storages: BTreeMap::new(),
        unchanged: BTreeMap::new(),
        verified: BTreeMap::new(),
        since_persist: 0,
        dataset_touched: false,
        dataset_note: None,
        interleaved: 0,
        written_count: 0,
        attempts: 0,
        fingerprint_before: String::new(),
        warnings: Vec::new(),
        start,
        stats0,
    };
    let result = loop {
        tx.attempts += 1;
        match tx.attempt(set) {
            Ok(()) => break Ok(()),
            Err(Stop::Settled(e)) => break Err(e),
            Err(Stop::Error(e))
                if matches!(*e.kind, ErrorKind::Restarted { .. })
                    && tx.attempts <= tx.opts.max_restarts =>
            {
                if tx.journal.is_some() {
                    let note = format!("{e}; redoing from the read-back");
                    tx.warnings.push(note.clone());
                    if let Err(je) = tx.set_state(TxnState::Planned, Some(note)) {
                        break Err(tx.fail(je));
                    }
                }
                continue;
            }
            Err(Stop::Error(e)) => {
                if tx.journal.is_none() {
                    break Err(e);
                }
                break Err(tx.fail(e));
            }
        }
    };
    tx.opts.observer.end(tx.client.clock());
    let report = tx.report(set);
    match result {
        Ok(()) => Ok(report),
        Err(e) => Err(UploadFailure {
            error: Box::new(e),
            report: tx.journal.as_ref().map(|_| Box::new(report)),
        }),
    }
}

enum Stop {
    /// The transaction reached a final state; return this error as is.
    Settled(EngineError),
    /// Failed; roll back if anything may have been written.
    Error(EngineError),
}

impl From<EngineError> for Stop {
    fn from(e: EngineError) -> Self {
        Stop::Error(e)
    }
}

struct Txn<'a> {
    client: &'a mut dyn DriveClient,
    schema: Arc<Schema>,
    target: Target,
    opts: &'a UploadOptions,
    popts: PlanOptions,
    identity: Identity,
    journal: Option<JournalFile>,
    /// Old values (first attempt's), by code.
    backup: BTreeMap<CodeKey, RawValue>,
    /// Planned codes in write order (latest plan; earlier attempts' extra codes after).
    order: Vec<(CodeKey, Phase)>,
    /// Codes a write was sent to, in any attempt.
    touched: BTreeSet<CodeKey>,
    new_values: BTreeMap<CodeKey, RawValue>,
    outcomes: BTreeMap<CodeKey, CodeOutcome>,
    texts: BTreeMap<CodeKey, (String, String)>,
    storages: BTreeMap<CodeKey, Storage>,
    unchanged: BTreeMap<CodeKey, RawValue>,
    verified: BTreeMap<CodeKey, RawValue>,
    since_persist: usize,
    dataset_touched: bool,
    dataset_note: Option<String>,
    interleaved: usize,
    written_count: usize,
    attempts: u32,
    fingerprint_before: String,
    warnings: Vec<String>,
    start: driveset_link::Instant,
    stats0: crate::client::ClientStats,
}

impl Txn<'_> {
    fn now_ns(&self) -> u64 {
        self.client.clock().now().as_nanos()
    }

    fn journal_path(&self) -> String {
        self.opts.journal.display().to_string()
    }

    fn set_state(&mut self, state: TxnState, note: Option<String>) -> Result<(), EngineError> {
        let at = self.now_ns();
        if let Some(j) = &mut self.journal {
            j.journal.transition(state, at, note);
            j.persist()?;
            self.since_persist = 0;
        }
        Ok(())
    }

    fn note_written(&mut self, key: CodeKey) -> Result<(), EngineError> {
        self.written_count += 1;
        self.outcomes.insert(key, CodeOutcome::Written);
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

    fn entry_records(&self, plan: &Plan) -> (Vec<BackupEntry>, Vec<PlanEntryRecord>) {
        let backup = self
            .backup
            .iter()
            .map(|(k, v)| BackupEntry {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.schema, *k),
                secret: is_secret(&self.schema, *k),
                old: JournalValue::from(v),
            })
            .collect();
        let records = plan
            .writes
            .iter()
            .map(|w| PlanEntryRecord {
                number: w.key.number,
                subcode: w.key.subcode,
                code: w.label.clone(),
                secret: w.secret,
                storage: w.storage.as_str().into(),
                width: w.width,
                phase: w.phase.as_str().into(),
                new: JournalValue::from(&w.new),
            })
            .collect();
        (backup, records)
    }

    /// One attempt: read back, plan, journal, write, verify, complete.
    fn attempt(&mut self, set: &ResolvedSet) -> Result<(), Stop> {
        let hook = &self.opts.observer;
        let current = read_observed(self.client, set.values.keys().copied(), hook, Step::Read)?;
        hook.enter(self.client.clock(), Step::Plan, None);
        let mut planned = plan(&self.schema, set, &current, &self.popts);
        if self.popts.running == Running::NotRead && planned.as_ref().is_ok_and(|p| !p.is_empty()) {
            // the running check is part of planning (one status read)
            self.popts.running = self.client.running()?.into();
            planned = plan(&self.schema, set, &current, &self.popts);
        }
        let plan = match planned {
            Ok(p) => p,
            Err(problems) => {
                let e = refused(&self.target, problems);
                return Err(if self.journal.is_none() {
                    Stop::Settled(e)
                } else {
                    Stop::Error(e)
                });
            }
        };
        if self.attempts == 1 {
            self.fingerprint_before = plan.fingerprint_before.clone();
            self.warnings.extend(plan.warnings.iter().cloned());
        }
        self.unchanged.clear();
        for k in &plan.unchanged {
            if let Some(v) = current.values.get(k) {
                self.unchanged.insert(*k, v.clone());
                // written by an earlier attempt and read back equal now
                if self.new_values.get(k) == Some(v) {
                    self.outcomes.insert(*k, CodeOutcome::Verified);
                    self.verified.insert(*k, v.clone());
                }
            }
        }
        for w in &plan.writes {
            self.backup.entry(w.key).or_insert_with(|| w.old.clone());
            self.new_values.insert(w.key, w.new.clone());
            self.storages.insert(w.key, w.storage);
            let old_text = self
                .backup
                .get(&w.key)
                .map(|o| value_text(&self.schema, w.key, o))
                .unwrap_or_default();
            self.texts.insert(w.key, (old_text, w.new_text.clone()));
            self.outcomes.insert(w.key, CodeOutcome::NotWritten);
        }
        // write order: this plan's, then codes only an earlier attempt planned
        let mut order: Vec<(CodeKey, Phase)> =
            plan.writes.iter().map(|w| (w.key, w.phase)).collect();
        for (k, p) in &self.order {
            if !order.iter().any(|(o, _)| o == k) {
                order.push((*k, *p));
            }
        }
        self.order = order;

        if plan.is_empty() && self.journal.is_none() {
            return Ok(());
        }
        self.opts
            .observer
            .enter(self.client.clock(), Step::Journal, None);
        let (backup, records) = self.entry_records(&plan);
        let unchanged: Vec<BackupEntry> = self
            .unchanged
            .iter()
            .filter(|(k, _)| !self.backup.contains_key(k))
            .map(|(k, v)| BackupEntry {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.schema, *k),
                secret: is_secret(&self.schema, *k),
                old: JournalValue::from(v),
            })
            .collect();
        match &mut self.journal {
            None => {
                let at = self.now_ns();
                let mut journal = Journal {
                    journal_version: JOURNAL_VERSION,
                    state: TxnState::Planned,
                    target: JournalTarget::of(&*self.client),
                    identity: (&self.identity).into(),
                    schema: self.schema.id.clone(),
                    set_fingerprint: plan.set_fingerprint.clone(),
                    fingerprint_before: plan.fingerprint_before.clone(),
                    dataset: self.popts.dataset,
                    attempt: self.attempts,
                    backup,
                    plan: records,
                    unchanged,
                    written: Vec::new(),
                    transitions: Vec::new(),
                    failure: None,
                    failure_cause: None,
                    holding: Vec::new(),
                };
                journal.transition(TxnState::Planned, at, None);
                crate::journal::ensure_dir(journal_dir(&self.opts.journal))
                    .map_err(Stop::Settled)?;
                self.journal =
                    Some(JournalFile::create(&self.opts.journal, journal).map_err(Stop::Settled)?);
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
            }
        }
        self.set_state(TxnState::Writing, None)?;

        let expected: BTreeMap<CodeKey, RawValue> =
            plan.writes.iter().map(|w| (w.key, w.new.clone())).collect();
        let mut pending: VecDeque<CodeKey> = VecDeque::new();

        // 1. dataset (MC6000/7000)
        let staged: Vec<CodeKey> = plan
            .writes
            .iter()
            .filter(|w| w.phase == Phase::Dataset)
            .map(|w| w.key)
            .collect();
        if !staged.is_empty() {
            self.dataset_touched = true;
            let hook = &self.opts.observer;
            hook.enter(self.client.clock(), Step::Dataset, None);
            self.client.dataset_begin()?;
            hook.enter(self.client.clock(), Step::Write, Some(plan.writes.len()));
            for &k in &staged {
                self.pace(k, &mut pending, &expected)?;
                self.write(k, &expected)?;
            }
            self.opts
                .observer
                .enter(self.client.clock(), Step::Commit, None);
            match self.client.dataset_commit(self.opts.dataset_timeout)? {
                DatasetOutcome::Accepted => {
                    self.dataset_note = Some("accepted (SLOAD = 0)".into());
                    self.set_state(
                        TxnState::Committed,
                        Some("the drive accepted the dataset (SLOAD = 0)".into()),
                    )?;
                    pending.extend(staged.iter().copied());
                }
                DatasetOutcome::Rejected { parameter } => {
                    return Err(self.dataset_rejected(parameter, &staged));
                }
            }
        }
        // 2..4. the other writes, pacing EEPROM with verification reads
        let others = plan.writes.iter().any(|w| w.phase != Phase::Dataset);
        if others {
            let n = Some(plan.writes.len());
            self.opts
                .observer
                .enter(self.client.clock(), Step::Write, n);
        }
        for w in plan.writes.iter().filter(|w| w.phase != Phase::Dataset) {
            self.pace(w.key, &mut pending, &expected)?;
            self.write(w.key, &expected)?;
            pending.push_back(w.key);
            if let Strategy::Naive { eeprom_wait } = self.opts.strategy
                && matches!(w.storage, Storage::Eeprom | Storage::FselIsel)
            {
                self.client.clock().sleep(eeprom_wait);
            }
        }
        self.set_state(TxnState::Verifying, None)?;
        let n = Some(expected.len());
        self.opts
            .observer
            .enter(self.client.clock(), Step::Verify, n);
        while let Some(k) = pending.pop_front() {
            self.verify_one(k, &expected)?;
        }
        // what the drive holds now, over the set's codes
        let mut after = ResolvedSet::new(&self.schema);
        for k in set.values.keys() {
            if let Some(v) = self.verified.get(k).or_else(|| self.unchanged.get(k)) {
                after.insert(*k, v.clone());
            }
        }
        let after_fp = after.fingerprint();
        self.set_state(TxnState::Complete, Some(format!("drive holds {after_fp}")))?;
        Ok(())
    }

    fn write(&mut self, key: CodeKey, expected: &BTreeMap<CodeKey, RawValue>) -> Result<(), Stop> {
        let Some(v) = expected.get(&key) else {
            return Ok(());
        };
        self.touched.insert(key);
        if let Err(e) = self.client.write(key, v) {
            // A refusal the drive gave with its own cause (LUSTBUS / LECOM
            // NAK: "the parameter value was not changed"; an SDO abort) left
            // the code as it was: there is nothing of it to roll back. Any
            // other failure (no answer, a garbled one) may or may not have
            // landed, so the code stays touched.
            if matches!(*e.kind, ErrorKind::Device { .. }) {
                self.touched.remove(&key);
            }
            self.outcomes
                .insert(key, CodeOutcome::Failed(e.to_string()));
            return Err(Stop::Error(e));
        }
        self.note_written(key)?;
        let (done, total) = (self.touched.len(), self.order.len().max(self.touched.len()));
        self.opts
            .observer
            .step(self.client.clock(), Step::Write, done, total);
        Ok(())
    }

    /// Wait until the drive takes a write of `key`, filling the gap with
    /// verification reads that fit.
    fn pace(
        &mut self,
        key: CodeKey,
        pending: &mut VecDeque<CodeKey>,
        expected: &BTreeMap<CodeKey, RawValue>,
    ) -> Result<(), Stop> {
        if matches!(self.opts.strategy, Strategy::Naive { .. }) {
            // the client itself still waits whatever store time is left
            return Ok(());
        }
        let Some(ready) = self.client.ready_for_write(key) else {
            return Ok(());
        };
        loop {
            let now = self.client.clock().now();
            if ready <= now {
                break;
            }
            let gap = ready - now;
            // A read that fits the gap; else any read: it is work the
            // transaction must do anyway, and running past `ready` by part of
            // a read costs less than idling through the whole gap.
            let Some(i) = pending
                .iter()
                .position(|k| self.client.read_time(*k) <= gap)
                .or(if pending.is_empty() { None } else { Some(0) })
            else {
                break;
            };
            let Some(k) = pending.remove(i) else {
                break;
            };
            self.verify_one(k, expected)?;
            self.interleaved += 1;
        }
        self.client.clock().sleep_until(ready);
        Ok(())
    }

    fn verify_one(
        &mut self,
        key: CodeKey,
        expected: &BTreeMap<CodeKey, RawValue>,
    ) -> Result<(), Stop> {
        let Some(want) = expected.get(&key) else {
            return Ok(());
        };
        let got = match self.client.read(key) {
            Ok(v) => v,
            Err(e) => {
                self.outcomes
                    .insert(key, CodeOutcome::Failed(format!("verify: {e}")));
                return Err(Stop::Error(e));
            }
        };
        if &got != want {
            let detail = format!(
                "reads back {} instead of {}; the drive did not take the value",
                value_text(&self.schema, key, &got),
                value_text(&self.schema, key, want)
            );
            self.outcomes
                .insert(key, CodeOutcome::Failed(detail.clone()));
            return Err(Stop::Error(EngineError::protocol(
                self.target.clone(),
                format!("verify {}", code_label(&self.schema, key)),
                detail,
            )));
        }
        self.outcomes.insert(key, CodeOutcome::Verified);
        self.verified.insert(key, got);
        if self.opts.observer.is_set() {
            let done = expected
                .keys()
                .filter(|k| self.verified.contains_key(k))
                .count();
            self.opts
                .observer
                .step(self.client.clock(), Step::Verify, done, expected.len());
        }
        Ok(())
    }

    /// SLOAD went to a parameter number: the drive reactivated its old set.
    fn dataset_rejected(&mut self, parameter: u32, staged: &[CodeKey]) -> Stop {
        let name = code_label(&self.schema, CodeKey::new(parameter));
        let detail = format!(
            "the drive rejected the dataset at parameter {name} (the first invalid value) and reactivated its old set; fix {name} in the set"
        );
        self.dataset_note = Some(format!("rejected at parameter {name}"));
        for k in staged {
            self.outcomes
                .insert(*k, CodeOutcome::Failed("dataset rejected".into()));
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
        let n = Some(self.backup.len());
        self.opts
            .observer
            .enter(self.client.clock(), Step::Rollback, n);
        match self.compare_with_backup() {
            Ok(diffs) if diffs.is_empty() => {
                self.dataset_touched = false;
                if let Err(e) = self.set_state(TxnState::RolledBack, Some(detail.clone())) {
                    return Stop::Settled(e);
                }
                Stop::Settled(EngineError::rolled_back(
                    self.target.clone(),
                    self.journal_path(),
                    detail,
                    cause,
                ))
            }
            _ => Stop::Error(cause),
        }
    }

    /// Read every backed-up code; the codes that differ from the backup.
    fn compare_with_backup(&mut self) -> Result<Vec<CodeKey>, EngineError> {
        let mut diffs = Vec::new();
        let keys: Vec<(CodeKey, RawValue)> =
            self.backup.iter().map(|(k, v)| (*k, v.clone())).collect();
        for (k, old) in keys {
            if self.client.read(k)? != old {
                diffs.push(k);
            }
        }
        Ok(diffs)
    }

    /// Roll back after `cause`; returns the error to report.
    fn fail(&mut self, cause: EngineError) -> EngineError {
        let cause_text = cause.to_string();
        if let Some(j) = &mut self.journal {
            j.journal.failure = Some(cause_text.clone());
            j.journal.failure_cause = Some(FailureCause::of(&cause));
        }
        let n = Some(self.touched.len());
        self.opts
            .observer
            .enter(self.client.clock(), Step::Rollback, n);
        if let Err(e) = self.set_state(TxnState::RollingBack, Some(cause_text.clone())) {
            // The journal on disk still says an earlier state and holds the backup.
            return e;
        }
        let restore_result = restore(
            self.client,
            &self.schema,
            &self.order,
            &self.backup,
            &self.touched,
            self.dataset_touched,
            self.opts.dataset_timeout,
        )
        .and_then(|()| self.compare_with_backup());
        match restore_result {
            Ok(diffs) if diffs.is_empty() => {
                for k in &self.touched {
                    if !matches!(self.outcomes.get(k), Some(CodeOutcome::Failed(_))) {
                        self.outcomes.insert(*k, CodeOutcome::Restored);
                    }
                }
                let detail = format!("{cause_text}; restored the old values");
                if let Err(e) = self.set_state(TxnState::RolledBack, Some(detail)) {
                    return e;
                }
                EngineError::rolled_back(
                    self.target.clone(),
                    self.journal_path(),
                    cause_text,
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
                let holding = holdings(self.client, &self.schema, &self.backup, &self.new_values);
                let detail = format!(
                    "{cause_text}; {restore_err}; {}",
                    describe_holdings(&holding)
                );
                if let Some(j) = &mut self.journal {
                    j.journal.holding = holding;
                }
                let _ = self.set_state(TxnState::Failed, Some(detail.clone()));
                EngineError::inconsistent(self.target.clone(), self.journal_path(), detail)
            }
        }
    }

    fn report(&self, set: &ResolvedSet) -> UploadReport {
        let stats = self.client.stats();
        let state = self
            .journal
            .as_ref()
            .map(|j| j.journal.state)
            .unwrap_or(TxnState::Complete);
        let mut codes = Vec::new();
        for (k, _) in &self.order {
            let (old, new) = self.texts.get(k).cloned().unwrap_or_default();
            codes.push(CodeReport {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.schema, *k),
                old,
                new,
                storage: self.storages.get(k).copied(),
                outcome: self
                    .outcomes
                    .get(k)
                    .cloned()
                    .unwrap_or(CodeOutcome::NotWritten),
            });
        }
        for (k, v) in &self.unchanged {
            if self.new_values.contains_key(k) {
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
            TxnState::Complete => {
                let mut after = ResolvedSet::new(&self.schema);
                for k in set.values.keys() {
                    if let Some(v) = self.verified.get(k).or_else(|| self.unchanged.get(k)) {
                        after.insert(*k, v.clone());
                    }
                }
                Some(after.fingerprint())
            }
            TxnState::RolledBack => Some(self.fingerprint_before.clone()),
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
            telegrams: stats.telegrams.saturating_sub(self.stats0.telegrams),
            retries: stats.retries.saturating_sub(self.stats0.retries),
            elapsed: self.client.clock().now() - self.start,
            interleaved_reads: self.interleaved,
            dataset: self.dataset_note.clone(),
            sload_polls: Some(stats.sload_polls.saturating_sub(self.stats0.sload_polls))
                .filter(|n| *n > 0),
            late_replies: stats.late.saturating_sub(self.stats0.late),
            codes,
            warnings: self.warnings.clone(),
        }
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
