//! The transaction's state ([`Transaction`]: per code one record, the
//! current attempt, the counters the report needs) and the steps that
//! frame an attempt: [`Transaction::begin`] (check, unfinished-journal
//! guard, identify), [`Transaction::replan`] (read back, plan) and
//! [`Transaction::stopped`] (roll back, or redo after a drive restart);
//! the other steps are in the sibling modules (module docs of
//! `crate::upload`).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use super::{
    CodeOutcome, Next, Replanned, StepError, UploadOptions, check_unfinished, read_observed,
    refused,
};
use crate::client::{ClientStats, DriveClient, Identity, Target};
use crate::error::{EngineError, ErrorKind, Refusal};
use crate::journal::{JournalFile, TxnState};
use crate::observe::{Hook, Phase as Step};
use crate::plan::{Phase, Plan, PlanOptions, Running, Storage, check_set, plan, value_text};

/// One code of a transaction: everything the runner knows about it.
#[derive(Debug, Clone, Default)]
pub(super) struct CodeRecord {
    /// The old value (the first attempt's), once the code was planned.
    pub(super) backup: Option<RawValue>,
    /// The set's value, once the code was planned.
    pub(super) new: Option<RawValue>,
    /// Old and new value for humans.
    pub(super) texts: (String, String),
    /// How the drive keeps it.
    pub(super) storage: Option<Storage>,
    /// The phase of the latest plan that wrote it.
    pub(super) phase: Option<Phase>,
    /// What happened to it.
    pub(super) outcome: CodeOutcome,
    /// A write was sent to it in some attempt (it may have landed).
    pub(super) touched: bool,
    /// The value the latest read-back found equal to the set's.
    pub(super) unchanged: Option<RawValue>,
    /// The value read back equal to the set's after writing it.
    pub(super) verified: Option<RawValue>,
}

/// The current attempt's plan and its progress.
#[derive(Debug)]
pub(super) struct Attempt {
    pub(super) plan: Plan,
    /// New values of the planned writes.
    pub(super) expected: BTreeMap<CodeKey, RawValue>,
    /// Written, not yet read back (oldest first).
    pub(super) pending: VecDeque<CodeKey>,
    /// The dataset's writes, in plan order.
    pub(super) staged: Vec<CodeKey>,
    /// Dataset writes a broadcast sends instead of this drive's own
    /// SELECT ([`Transaction::expect_broadcast`]).
    pub(super) broadcast: BTreeSet<CodeKey>,
    /// Broadcast codes already repaired by an own write.
    pub(super) repaired: BTreeSet<CodeKey>,
}

/// An upload as explicit steps, for a caller that drives them one by one
/// (the line runner's broadcast); [`super::upload`] runs them in order.
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
    pub(super) schema: Arc<Schema>,
    pub(super) target: Target,
    pub(super) opts: UploadOptions,
    pub(super) popts: PlanOptions,
    pub(super) identity: Identity,
    pub(super) journal: Option<JournalFile>,
    /// The state the journal on disk holds (the last one persisted).
    pub(super) on_disk: Option<TxnState>,
    /// Every code the transaction planned or found unchanged.
    pub(super) records: BTreeMap<CodeKey, CodeRecord>,
    /// Planned codes in write order (latest plan; earlier attempts' extra
    /// codes after).
    pub(super) order: Vec<CodeKey>,
    pub(super) attempt: Option<Attempt>,
    pub(super) since_persist: usize,
    pub(super) dataset_touched: bool,
    /// When SLOAD = -2 was ACKed ([`Transaction::end_dataset`]).
    pub(super) dataset_ended: Option<driveset_link::Instant>,
    pub(super) dataset_note: Option<String>,
    pub(super) interleaved: usize,
    pub(super) written_count: usize,
    pub(super) attempts: u32,
    pub(super) fingerprint_before: String,
    /// After a rollback that left a control word stopped instead of
    /// restoring its running value: the fingerprint of what the drive
    /// holds (read back), which is then not `fingerprint_before`.
    pub(super) rolled_back_to: Option<String>,
    pub(super) warnings: Vec<String>,
    pub(super) start: driveset_link::Instant,
    /// The attached client's counters when it was attached.
    pub(super) stats0: ClientStats,
    /// What earlier (detached) clients did.
    pub(super) carried: ClientStats,
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
pub(super) fn out_of_order(target: &Target, step: &str, before: &str) -> StepError {
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

    pub(super) fn stats(&self, client: &dyn DriveClient) -> ClientStats {
        stats_add(self.carried, stats_since(client.stats(), self.stats0))
    }

    /// Old values by code (the journal's backup).
    pub(super) fn backup(&self) -> BTreeMap<CodeKey, RawValue> {
        self.records
            .iter()
            .filter_map(|(k, r)| r.backup.clone().map(|v| (*k, v)))
            .collect()
    }

    /// The planned codes' new values.
    pub(super) fn new_values(&self) -> BTreeMap<CodeKey, RawValue> {
        self.records
            .iter()
            .filter_map(|(k, r)| r.new.clone().map(|v| (*k, v)))
            .collect()
    }

    /// Codes a write was sent to.
    pub(super) fn touched(&self) -> BTreeSet<CodeKey> {
        self.records
            .iter()
            .filter(|(_, r)| r.touched)
            .map(|(k, _)| *k)
            .collect()
    }

    /// Write order with each code's phase.
    pub(super) fn phased_order(&self) -> Vec<(CodeKey, Phase)> {
        self.order
            .iter()
            .filter_map(|k| self.records.get(k).and_then(|r| r.phase).map(|p| (*k, p)))
            .collect()
    }

    pub(super) fn set_outcome(&mut self, key: CodeKey, outcome: CodeOutcome) {
        self.records.entry(key).or_default().outcome = outcome;
    }

    pub(super) fn take_attempt(&mut self, step: &str, before: &str) -> Result<Attempt, StepError> {
        self.attempt
            .take()
            .ok_or_else(|| out_of_order(&self.target, step, before))
    }

    /// Runs `f` on the current attempt, which stays current whatever `f`
    /// returns.
    pub(super) fn with_attempt<R>(
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
}
