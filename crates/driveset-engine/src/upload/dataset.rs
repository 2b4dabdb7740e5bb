//! The MC6000/7000 dataset path of the transaction (`lustbus-protocol.txt`
//! §11.4, 80-SLOAD): open the download (SLOAD = -1), the staged writes
//! (some of them sent by a broadcast the caller announces), commit
//! (SLOAD = -2 and the poll, whole or in two halves), and a rejected
//! dataset: the drive reactivated its old set, confirmed by reading the
//! backup back.

use driveset_schema::CodeKey;

use super::rollback::RollbackPlan;
use super::state::Attempt;
use super::transaction::out_of_order;
use super::{CodeOutcome, StepError, Transaction};
use crate::client::{DatasetOutcome, DriveClient, dataset_or_refuse};
use crate::error::{DeviceCause, EngineError};
use crate::journal::TxnState;
use crate::observe::Phase as Step;
use crate::plan::code_label;

impl Transaction {
    /// Step 3 (MC6000/7000): when the plan stages values, register the
    /// dataset download (SLOAD = -1, LUSTBUS 11.4). `Ok(true)`: a dataset
    /// is open.
    pub fn open_dataset(&mut self, client: &mut dyn DriveClient) -> Result<bool, StepError> {
        let staged = self.staged().to_vec();
        if self.attempt.is_none() {
            return Err(out_of_order(&self.drive.target, "open_dataset", "journal"));
        }
        if staged.is_empty() {
            return Ok(false);
        }
        self.dataset.touched = true;
        self.opts
            .observer
            .enter(client.clock(), Step::Dataset, None);
        dataset_or_refuse(client)?.begin()?;
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
                unknown.push(code_label(&self.drive.schema, *k));
            }
        }
        let names: Vec<String> = a
            .broadcast
            .iter()
            .map(|k| k.canonical(self.drive.schema.code_style))
            .collect();
        let marked: Vec<CodeKey> = a.broadcast.iter().copied().collect();
        self.attempt = Some(a);
        if !unknown.is_empty() {
            return Err(StepError::Error(EngineError::refused(
                self.drive.target.clone(),
                super::UploadRefusal::BroadcastNotStaged { codes: unknown },
            )));
        }
        for k in marked {
            self.codes.records.entry(k).or_default().touched = true;
        }
        if let Some(j) = &mut self.journal.file {
            j.journal.broadcast = names;
            j.persist()?;
            self.journal.since_persist = 0;
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
        if let Some(j) = &mut self.journal.file {
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
            let outcome = dataset_or_refuse(client)?.commit(tx.opts.dataset_timeout)?;
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
            tx.dataset.ended = Some(dataset_or_refuse(client)?.end()?);
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
            let Some(ended) = tx.dataset.ended.take() else {
                return Err(out_of_order(
                    &tx.drive.target,
                    "await_dataset",
                    "end_dataset",
                ));
            };
            tx.opts.observer.enter(client.clock(), Step::Commit, None);
            let outcome =
                dataset_or_refuse(client)?.await_outcome(ended, tx.opts.dataset_timeout)?;
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
                self.dataset.note = Some("accepted (SLOAD = 0)".into());
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

    /// SLOAD went to a parameter number: the drive reactivated its old set.
    fn dataset_rejected(
        &mut self,
        client: &mut dyn DriveClient,
        parameter: u32,
        staged: &[CodeKey],
    ) -> StepError {
        let name = code_label(&self.drive.schema, CodeKey::new(parameter));
        let detail = format!(
            "the drive rejected the dataset at parameter {name} (the first invalid value) and reactivated its old set; fix {name} in the set"
        );
        self.dataset.note = Some(format!("rejected at parameter {name}"));
        for k in staged {
            self.codes
                .set_outcome(*k, CodeOutcome::Failed("dataset rejected".into()));
        }
        let cause = EngineError::device(
            self.drive.target.clone(),
            "dataset download (80-SLOAD)",
            DeviceCause::DatasetRejected {
                parameter,
                name: name.clone(),
                backup: false,
            },
        );
        // confirm nothing changed
        let n = Some(self.codes.backup().len());
        self.opts.observer.enter(client.clock(), Step::Rollback, n);
        let plan = RollbackPlan::new(
            &self.drive.schema,
            &self.codes.backup(),
            &self.codes.new_values(),
        );
        match self.compare_with_backup(client, &plan) {
            Ok(diffs) if diffs.is_empty() => {
                self.dataset.touched = false;
                if let Err(e) = self.set_state(client, TxnState::RolledBack, Some(detail.clone())) {
                    return StepError::Settled(self.journal_lost(
                        e,
                        TxnState::RolledBack,
                        &format!("{detail}; the drive holds its old values again (verified)"),
                    ));
                }
                StepError::Settled(EngineError::rolled_back(
                    self.drive.target.clone(),
                    self.journal_path(),
                    detail,
                    cause,
                ))
            }
            _ => StepError::Error(cause),
        }
    }
}
