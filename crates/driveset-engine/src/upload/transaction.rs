//! The transaction ([`Transaction`]: its parts are in `state.rs`) and the
//! steps that frame an attempt: [`Transaction::begin`] (check,
//! unfinished-journal guard, identify, check with the identity),
//! [`Transaction::replan`] (read back, plan) and [`Transaction::stopped`]
//! (roll back, or redo after a drive restart); the other steps are in the
//! sibling modules (module docs of `crate::upload`). The steps the dry run
//! shares ([`Opening`]: check, identify; the read-back, the motor and the
//! plan) are written once here, and `super::prepare` takes them without
//! a journal (docs/architecture.md, "The data path of an upload").

use std::collections::{BTreeSet, VecDeque};
use std::sync::Arc;

use driveset_schema::{CodeKey, ResolvedSet, Schema};

use super::journal_writer::guard;
use super::state::{Attempt, Codes, Counters, DatasetState, Drive, JournalState, Progress};
use super::{CodeOutcome, Next, Replanned, StepError, UploadOptions, read_observed, refused};
use crate::client::{DriveClient, Identity, Target};
use crate::error::{DeviceFailure, EngineError, ErrorKind};
use crate::journal::{JournalFile, TxnState};
use crate::observe::{Hook, Phase as Step};
use crate::overrides::Overrides;
use crate::plan::{Phase, Plan, PlanOptions, Running, check_set, plan, value_text};

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
    /// The drive it is for.
    pub(super) drive: Drive,
    /// How it runs.
    pub(super) opts: UploadOptions,
    /// Its journal.
    pub(super) journal: JournalState,
    /// Every code it planned or found unchanged, in write order.
    pub(super) codes: Codes,
    /// The current attempt.
    pub(super) attempt: Option<Attempt>,
    /// The MC6000/7000 dataset handshake.
    pub(super) dataset: DatasetState,
    /// What it has done so far, for the report.
    pub(super) progress: Progress,
    /// Time and telegram counts across the clients it went through.
    pub(super) counters: Counters,
}

/// A step called out of order (a caller's mistake, not the drive's).
pub(super) fn out_of_order(target: &Target, step: &str, before: &str) -> StepError {
    StepError::Settled(EngineError::refused(
        target.clone(),
        super::UploadRefusal::StepOutOfOrder {
            step: step.into(),
            before: before.into(),
        },
    ))
}

/// The first steps an upload and its dry run share, before the drive is
/// identified: the set checked against the schema and the overrides,
/// nothing sent yet ([`Opening::check`]), then [`Opening::identify`],
/// which makes the [`Transaction`].
pub(super) struct Opening {
    schema: Arc<Schema>,
    target: Target,
    popts: PlanOptions,
    /// Counting from before the first telegram.
    counters: Counters,
}

impl Opening {
    /// Check the set without the drive ([`check_set`]: codes, roles,
    /// family; the identity and the motor are not known yet). Sends
    /// nothing.
    pub(super) fn check(
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
        overrides: Overrides,
    ) -> Result<Opening, EngineError> {
        let counters = Counters::new(&*client);
        let schema = client.schema().clone();
        let target = client.target().clone();
        let popts = PlanOptions {
            overrides,
            dataset: client.dataset().is_some(),
            running: Running::NotRead,
            identity: None,
        };
        let problems = check_set(&schema, set, &popts);
        if !problems.is_empty() {
            return Err(refused(&target, problems));
        }
        Ok(Opening {
            schema,
            target,
            popts,
            counters,
        })
    }

    /// Identify the drive (the identify reads, phase `identify` on the
    /// observer of `opts`); the planner knows the identity from now on.
    /// Nothing is checked against it here: the real run does that next
    /// ([`Transaction::check_identity`]), the dry run in its plan.
    pub(super) fn identify(
        self,
        client: &mut dyn DriveClient,
        opts: &UploadOptions,
    ) -> Result<Transaction, EngineError> {
        let Opening {
            schema,
            target,
            mut popts,
            counters,
        } = self;
        opts.observer.enter(client.clock(), Step::Identify, None);
        let identity = client.identify()?;
        popts.identity = Some(identity.clone());
        Ok(Transaction {
            drive: Drive {
                schema,
                target,
                identity,
                popts,
            },
            opts: opts.clone(),
            journal: JournalState::default(),
            codes: Codes::default(),
            attempt: None,
            dataset: DatasetState::default(),
            progress: Progress::default(),
            counters,
        })
    }
}

impl Transaction {
    /// Check the set, refuse when the journal directory holds an
    /// unfinished journal of the drive (the guard, `journal_writer::guard`),
    /// identify it and check again. Sends only the identify reads; nothing
    /// is journalled yet.
    ///
    /// The dry run ([`super::prepare`]) takes the same steps but the
    /// guard and the second check.
    pub fn begin(
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
        opts: &UploadOptions,
    ) -> Result<Transaction, EngineError> {
        let opening = Opening::check(&mut *client, set, opts.overrides)?;
        guard(&*client, opts)?;
        let tx = opening.identify(client, opts)?;
        tx.check_identity(set)?;
        Ok(tx)
    }

    /// The set checked again with the drive's identity (its protocol and
    /// 91-TYPE against the schema's, [`check_set`]), before the read-back:
    /// a drive of another family is refused without reading a code. The
    /// running-motor check is done in [`Transaction::replan`], only when
    /// something has to be written (a re-run that changes nothing costs no
    /// exchange).
    pub(super) fn check_identity(&self, set: &ResolvedSet) -> Result<(), EngineError> {
        let problems = check_set(&self.drive.schema, set, &self.drive.popts);
        if problems.is_empty() {
            Ok(())
        } else {
            Err(refused(&self.drive.target, problems))
        }
    }

    /// What the drive said it is.
    pub fn identity(&self) -> &Identity {
        &self.drive.identity
    }

    /// The journal file, once [`Transaction::journal`] created it.
    pub fn journal_file(&self) -> Option<&JournalFile> {
        self.journal.file.as_ref()
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
        self.counters.detach(client);
    }

    /// The next steps go through `client` (after [`Transaction::detach`]
    /// of the previous one).
    pub fn attach(&mut self, client: &dyn DriveClient) {
        self.counters.attach(client);
    }

    /// The steps from now on report to `hook` (a caller that splits a
    /// drive's work into parts gives each part its own).
    pub fn set_observer(&mut self, hook: Hook) {
        self.opts.observer = hook;
    }

    /// Note for the report.
    pub fn warn(&mut self, note: String) {
        self.progress.warnings.push(note);
    }

    pub(super) fn take_attempt(&mut self, step: &str, before: &str) -> Result<Attempt, StepError> {
        self.attempt
            .take()
            .ok_or_else(|| out_of_order(&self.drive.target, step, before))
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
            // the drive holds the set; an earlier, cut run may have left it
            // in RAM only
            return self.store(client, set);
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
        let current = self.read_back(client, set)?;
        self.plan_against(client, set, &current)
    }

    /// The first half of [`Transaction::replan`]: a new attempt, the set's
    /// codes read back (phase `read`).
    pub(super) fn read_back(
        &mut self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
    ) -> Result<ResolvedSet, EngineError> {
        self.progress.attempts += 1;
        self.attempt = None;
        let hook = &self.opts.observer;
        read_observed(client, set.values.keys().copied(), hook, Step::Read)
    }

    /// Ask the drive whether its motor runs (one status read); the plan
    /// refuses a running motor, or one whose state cannot be known, unless
    /// overridden ([`check_set`]).
    pub(super) fn ask_running(&mut self, client: &mut dyn DriveClient) -> Result<(), EngineError> {
        self.drive.popts.running = client.running()?.into();
        Ok(())
    }

    /// The second half of [`Transaction::replan`]: plan against `current`
    /// (phase `plan`), asking the motor first when something is to be
    /// written and it was not asked yet, and update each code's record.
    pub(super) fn plan_against(
        &mut self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
        current: &ResolvedSet,
    ) -> Result<Replanned, StepError> {
        self.opts.observer.enter(client.clock(), Step::Plan, None);
        let mut planned = plan(&self.drive.schema, set, current, &self.drive.popts);
        if self.drive.popts.running == Running::NotRead
            && planned.as_ref().is_ok_and(|p| !p.is_empty())
        {
            // the running check is part of planning (one status read)
            self.ask_running(client)?;
            planned = plan(&self.drive.schema, set, current, &self.drive.popts);
        }
        let plan = match planned {
            Ok(p) => p,
            Err(problems) => {
                let e = refused(&self.drive.target, problems);
                return Err(if self.journal.file.is_none() {
                    StepError::Settled(e)
                } else {
                    StepError::Error(e)
                });
            }
        };
        if self.progress.attempts == 1 {
            self.progress.fingerprint_before = plan.fingerprint_before.clone();
            self.progress.warnings.extend(plan.warnings.iter().cloned());
        }
        for r in self.codes.records.values_mut() {
            r.unchanged = None;
        }
        for k in &plan.unchanged {
            if let Some(v) = current.values.get(k) {
                let r = self.codes.records.entry(*k).or_default();
                r.unchanged = Some(v.clone());
                // written by an earlier attempt and read back equal now
                if r.new.as_ref() == Some(v) {
                    r.outcome = CodeOutcome::Verified;
                    r.verified = Some(v.clone());
                }
            }
        }
        for w in &plan.writes {
            let schema = Arc::clone(&self.drive.schema);
            let r = self.codes.records.entry(w.key).or_default();
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
        for k in &self.codes.order {
            if !order.contains(k) {
                order.push(*k);
            }
        }
        self.codes.order = order;
        let nothing = plan.is_empty() && self.journal.file.is_none();
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
                if matches!(*e.kind, ErrorKind::Device(DeviceFailure::Restarted { .. }))
                    && self.progress.attempts <= self.opts.max_restarts =>
            {
                if self.journal.file.is_some() {
                    let note = format!("{e}; redoing from the read-back");
                    self.progress.warnings.push(note.clone());
                    if let Err(je) = self.set_state(client, TxnState::Planned, Some(note)) {
                        return Next::Failed(self.fail(client, je));
                    }
                }
                Next::Redo
            }
            StepError::Error(e) => {
                if self.journal.file.is_none() {
                    Next::Failed(e)
                } else {
                    Next::Failed(self.fail(client, e))
                }
            }
        }
    }
}
