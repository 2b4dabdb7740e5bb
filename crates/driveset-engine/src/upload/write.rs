//! The transaction's writes after the dataset and its verification:
//! [`Transaction::write_rest`] paced as the module docs of `crate::upload`
//! say (EEPROM gaps filled with verification reads, or the naive fixed
//! wait of [`super::Strategy::Naive`]), each write recorded in the
//! journal, and [`Transaction::verify`] (read back every written code).

use driveset_schema::{CodeKey, ResolvedSet};

use super::state::Attempt;
use super::{CodeOutcome, StepError, Strategy, Transaction};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::TxnState;
use crate::observe::Phase as Step;
use crate::plan::{Phase, Storage, code_label, value_text};

impl Transaction {
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
    /// `verifying`), wait until the drive has saved its last EEPROM write
    /// (`crate::client::saved`), store where the schema's drives keep writes only on
    /// command ([`Transaction::store`], state `storing`), then `complete`
    /// with the fingerprint of what the drive holds.
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
        crate::client::saved(client, set.values.keys().copied());
        self.store(client, set)?;
        let after_fp = self.codes.after(&self.drive.schema, set).fingerprint();
        self.set_state(
            client,
            TxnState::Complete,
            Some(format!("drive holds {after_fp}")),
        )?;
        Ok(())
    }

    pub(super) fn write(
        &mut self,
        client: &mut dyn DriveClient,
        key: CodeKey,
        a: &Attempt,
    ) -> Result<(), StepError> {
        let Some(v) = a.expected.get(&key) else {
            return Ok(());
        };
        self.codes.records.entry(key).or_default().touched = true;
        if let Err(e) = client.write(key, v) {
            // A refusal the drive gave with its own cause (LUSTBUS / LECOM
            // NAK: "the parameter value was not changed"; an SDO abort) left
            // the code as it was: there is nothing of it to roll back. Any
            // other failure (no answer, a garbled one) may or may not have
            // landed, so the code stays touched (a broadcast one always).
            let r = self.codes.records.entry(key).or_default();
            if e.device_cause().is_some() && !a.broadcast.contains(&key) {
                r.touched = false;
            }
            r.outcome = CodeOutcome::Failed(e.to_string());
            return Err(StepError::Error(e));
        }
        self.note_written(key)?;
        let touched = self.codes.records.values().filter(|r| r.touched).count();
        let (done, total) = (touched, self.codes.order.len().max(touched));
        self.opts
            .observer
            .step(client.clock(), Step::Write, done, total);
        Ok(())
    }

    /// Wait until the drive takes a write of `key`, filling the gap with
    /// verification reads that fit.
    pub(super) fn pace(
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
            self.progress.interleaved += 1;
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
                self.codes
                    .set_outcome(key, CodeOutcome::Failed(format!("verify: {e}")));
                return Err(StepError::Error(e));
            }
        };
        if got != want && a.broadcast.contains(&key) && a.repaired.insert(key) {
            // The broadcast did not land on this drive (no receipt tells):
            // the value is written on its own, then read back.
            let note = format!(
                "{}: the broadcast value did not land (reads back {}); written on its own and verified",
                code_label(&self.drive.schema, key),
                value_text(&self.drive.schema, key, &got)
            );
            self.progress.warnings.push(note);
            self.write(client, key, a)?;
            return self.verify_one(client, key, a);
        }
        if got != want {
            let detail = format!(
                "reads back {} instead of {}; the drive did not take the value",
                value_text(&self.drive.schema, key, &got),
                value_text(&self.drive.schema, key, &want)
            );
            self.codes
                .set_outcome(key, CodeOutcome::Failed(detail.clone()));
            return Err(StepError::Error(EngineError::protocol(
                self.drive.target.clone(),
                format!("verify {}", code_label(&self.drive.schema, key)),
                detail,
            )));
        }
        let r = self.codes.records.entry(key).or_default();
        r.outcome = CodeOutcome::Verified;
        r.verified = Some(got);
        if self.opts.observer.is_set() {
            let done = a
                .expected
                .keys()
                .filter(|k| {
                    self.codes
                        .records
                        .get(k)
                        .is_some_and(|r| r.verified.is_some())
                })
                .count();
            self.opts
                .observer
                .step(client.clock(), Step::Verify, done, a.expected.len());
        }
        Ok(())
    }
}
