//! Rolling back (the upload's and `recover`'s): [`Transaction::fail`]
//! restores the backup in reverse write order (CardWriteable values again
//! through a dataset download), reads it back and compares, and settles
//! the journal `rolled-back` or `failed` with what each code holds;
//! [`RollbackPlan`] says what a rollback writes and accepts (a running
//! control word is left stopped), [`restore`] writes it, [`holdings`]
//! reads what each code holds.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use super::{CodeOutcome, Transaction};
use crate::client::{DatasetOutcome, DriveClient, dataset_or_refuse};
use crate::error::{DeviceCause, EngineError};
use crate::journal::{CodeHolding, FailureCause, Holding, TxnState};
use crate::observe::Phase as Step;
use crate::plan::{Phase, code_label};

impl Transaction {
    /// Read every backed-up code; the codes that differ from the backup.
    pub(super) fn compare_with_backup(
        &mut self,
        client: &mut dyn DriveClient,
        plan: &RollbackPlan,
    ) -> Result<Vec<CodeKey>, EngineError> {
        let mut diffs = Vec::new();
        let keys: BTreeSet<CodeKey> = plan.keys().collect();
        let mut held = ResolvedSet::new(&self.drive.schema);
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
            .any(|(k, v)| self.codes.backup().get(k) != Some(v))
        {
            for (k, r) in &self.codes.records {
                if let Some(v) = &r.unchanged {
                    held.insert(*k, v.clone());
                }
            }
            self.progress.rolled_back_to = Some(held.fingerprint());
        }
        Ok(diffs)
    }

    /// Roll back after `cause`; returns the error to report.
    pub(super) fn fail(&mut self, client: &mut dyn DriveClient, cause: EngineError) -> EngineError {
        let cause_text = cause.to_string();
        if let Some(j) = &mut self.journal.file {
            j.journal.failure = Some(cause_text.clone());
            j.journal.failure_cause = Some(FailureCause::of(&cause));
        }
        let n = Some(self.codes.touched().len());
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
        let plan = RollbackPlan::new(
            &self.drive.schema,
            &self.codes.backup(),
            &self.codes.new_values(),
        );
        let notes = plan.notes(&self.drive.schema, &self.codes.touched());
        let restore_result = restore(
            client,
            &self.drive.schema,
            &self.codes.phased_order(),
            &plan.restore,
            &self.codes.touched(),
            self.dataset.touched,
            self.opts.dataset_timeout,
        )
        .and_then(|()| self.compare_with_backup(client, &plan));
        // a store command already sent may have stored the new values: the
        // restored old ones are stored again (`[schema.store]` on-command)
        let restore_result = match (restore_result, self.drive.schema.store.command()) {
            (Ok(diffs), Some(command)) if diffs.is_empty() && self.progress.store_sent => {
                client.store(command).map(|()| diffs)
            }
            (r, _) => r,
        };
        match restore_result {
            Ok(diffs) if diffs.is_empty() => {
                for k in self.codes.touched() {
                    let r = self.codes.records.entry(k).or_default();
                    if !matches!(r.outcome, CodeOutcome::Failed(_)) {
                        r.outcome = CodeOutcome::Restored;
                    }
                }
                self.progress.warnings.extend(notes.iter().cloned());
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
                    self.drive.target.clone(),
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
                            .map(|k| code_label(&self.drive.schema, *k))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    Err(e) => format!("restoring the old values failed: {e}"),
                };
                let holding = holdings(
                    client,
                    &self.drive.schema,
                    &self.codes.backup(),
                    &self.codes.new_values(),
                );
                if holding.iter().all(|h| h.holds == Holding::Old) {
                    // the restore could not run (a refused SLOAD = -1), but
                    // every code reads back its old value: nothing landed,
                    // which is a rollback, not a mix
                    return self.nothing_landed(client, &cause_text, &restore_err, cause);
                }
                let detail = format!(
                    "{cause_text}; {restore_err}; {}",
                    describe_holdings(&holding)
                );
                if let Some(j) = &mut self.journal.file {
                    j.journal.holding = holding;
                }
                if let Err(e) = self.set_state(client, TxnState::Failed, Some(detail.clone())) {
                    return self.journal_lost(
                        e,
                        TxnState::Failed,
                        &format!("the drive holds a mix of old and new values: {detail}"),
                    );
                }
                EngineError::inconsistent(self.drive.target.clone(), self.journal_path(), detail)
            }
        }
    }
}

impl Transaction {
    /// [`Transaction::fail`] when the restore failed but every code reads
    /// back its old value: settled `rolled-back`, said as such.
    fn nothing_landed(
        &mut self,
        client: &mut dyn DriveClient,
        cause_text: &str,
        restore_err: &str,
        cause: EngineError,
    ) -> EngineError {
        let with_notes = format!(
            "{cause_text}; nothing landed ({restore_err}; every code reads back its old value)"
        );
        let detail = format!("{with_notes}; restored the old values");
        if let Err(e) = self.set_state(client, TxnState::RolledBack, Some(detail.clone())) {
            return self.journal_lost(
                e,
                TxnState::RolledBack,
                &format!("{detail} (read back and compared)"),
            );
        }
        EngineError::rolled_back(
            self.drive.target.clone(),
            self.journal_path(),
            with_notes,
            cause,
        )
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
/// back what each code holds. Returns once the drive has saved its last
/// EEPROM write ([`crate::client::saved`]).
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
    // "rolled back" only once the drive keeps the old values: its last
    // background EEPROM save done (MC6000/7000, §3)
    crate::client::saved(client, order.iter().map(|(k, _)| *k));
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
    dataset_or_refuse(client)?.begin()?;
    for (k, old) in staged {
        client.write(*k, old)?;
    }
    match dataset_or_refuse(client)?.commit(dataset_timeout)? {
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
