//! The transaction's journal (docs/journals.md): the journal step
//! ([`Transaction::journal`]: the backup durable before any write), its
//! state transitions and periodic persists, the error when a persist
//! fails while settling, and the guard that refuses a drive whose journal
//! directory holds an unfinished journal ([`check_unfinished`]; the real
//! run's step [`guard`], which the dry run does not take).

use std::path::{Path, PathBuf};

use driveset_schema::{CodeKey, RawValue};

use super::{CodeOutcome, StepError, Transaction, UploadOptions};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::{
    BackupEntry, JOURNAL_VERSION, Journal, JournalFile, JournalTarget, JournalValue,
    PlanEntryRecord, TxnState,
};
use crate::observe::Phase as Step;
use crate::plan::{code_label, is_secret};

impl Transaction {
    pub(super) fn journal_path(&self) -> String {
        self.opts.journal.display().to_string()
    }

    pub(super) fn set_state(
        &mut self,
        client: &dyn DriveClient,
        state: TxnState,
        note: Option<String>,
    ) -> Result<(), EngineError> {
        let at = client.clock().now().as_nanos();
        if let Some(j) = &mut self.journal.file {
            j.journal.transition(state, at, note);
            j.persist()?;
            self.journal.since_persist = 0;
            self.journal.on_disk = Some(state);
        }
        Ok(())
    }

    pub(super) fn note_written(&mut self, key: CodeKey) -> Result<(), EngineError> {
        self.progress.written += 1;
        self.codes.records.entry(key).or_default().outcome = CodeOutcome::Written;
        let every = self.opts.journal_every.max(1);
        if let Some(j) = &mut self.journal.file {
            j.journal
                .written
                .push(key.canonical(self.drive.schema.code_style));
            self.journal.since_persist += 1;
            if self.journal.since_persist >= every {
                j.persist()?;
                self.journal.since_persist = 0;
            }
        }
        Ok(())
    }

    fn backup_entry(&self, key: CodeKey, v: &RawValue) -> BackupEntry {
        BackupEntry {
            number: key.number,
            subcode: key.subcode,
            code: code_label(&self.drive.schema, key),
            secret: is_secret(&self.drive.schema, key),
            old: JournalValue::from(v),
        }
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
            .codes
            .records
            .iter()
            .filter_map(|(k, r)| r.backup.as_ref().map(|v| self.backup_entry(*k, v)))
            .collect();
        let unchanged: Vec<BackupEntry> = self
            .codes
            .records
            .iter()
            .filter(|(_, r)| r.backup.is_none())
            .filter_map(|(k, r)| r.unchanged.as_ref().map(|v| self.backup_entry(*k, v)))
            .collect();
        match &mut self.journal.file {
            None => {
                let at = client.clock().now().as_nanos();
                let mut journal = Journal {
                    journal_version: JOURNAL_VERSION,
                    state: TxnState::Planned,
                    target: JournalTarget::of(&*client),
                    identity: (&self.drive.identity).into(),
                    schema: self.drive.schema.id.clone(),
                    schema_source: crate::journal::SchemaSource::of(&self.drive.schema),
                    set_fingerprint,
                    fingerprint_before,
                    dataset: self.drive.popts.dataset,
                    attempt: self.progress.attempts,
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
                    // the transfer-rate switch's journal of this transaction
                    JournalFile::replace(&self.opts.journal, journal)
                } else {
                    JournalFile::create(&self.opts.journal, journal)
                };
                self.journal.file = Some(file.map_err(StepError::Settled)?);
                self.journal.on_disk = Some(TxnState::Planned);
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
                j.journal.attempt = self.progress.attempts;
                j.journal.written.clear();
                j.journal.broadcast.clear();
            }
        }
        self.set_state(client, TxnState::Writing, None)?;
        Ok(())
    }

    /// A journal persist failed while the transaction settled in `state`:
    /// the error names what the drive holds (`drive`) and that the journal
    /// on disk still says an earlier state.
    pub(super) fn journal_lost(
        &self,
        persist: EngineError,
        state: TxnState,
        drive: &str,
    ) -> EngineError {
        let on_disk = self
            .journal
            .on_disk
            .map_or("an earlier state", TxnState::as_str);
        EngineError::journal(
            self.journal_path(),
            format!(
                "{drive}; but recording state `{}` failed ({persist}), so the journal on disk still says `{on_disk}`: fix the journal directory, then run `driveset recover {}`",
                state.as_str(),
                self.journal_path()
            ),
        )
    }
}

/// The journal path of the drive `client` reaches, in `dir`: the one
/// naming scheme of `upload` and `commission`
/// ([`crate::journal::journal_path`]: bus id and address, sanitised).
pub fn default_journal_path(dir: &Path, client: &dyn DriveClient) -> PathBuf {
    crate::journal::journal_path(dir, &client.bus_id(), client.target().address)
}

/// The directory [`super::upload`] scans for unfinished journals: the journal
/// file's own.
fn journal_dir(journal: &Path) -> &Path {
    match journal.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// The guard step of a real upload, between the check of the set and
/// identify ([`Transaction::begin`]): [`check_unfinished`] for the
/// journal of `opts`, unless the transfer-rate switch ran it already before
/// switching the rate (`opts.transfer`: the journal file is then this
/// transaction's own). A dry run ([`super::prepare`]) writes no journal
/// and nothing to the drive, so it does not take this step: a dry run
/// next to an unfinished journal is not refused.
pub(super) fn guard(client: &dyn DriveClient, opts: &UploadOptions) -> Result<(), EngineError> {
    if opts.transfer.is_some() {
        return Ok(());
    }
    check_unfinished(client, &opts.journal)
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
