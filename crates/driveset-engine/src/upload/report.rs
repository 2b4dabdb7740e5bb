//! What a caller of the upload is told: the report ([`UploadReport`], one
//! [`CodeReport`] per code with its [`CodeOutcome`], rendered for humans
//! or serialized), the failure ([`UploadFailure`]: the error and the
//! report so far), what a step's failure and [`Transaction::stopped`]
//! decide ([`StepError`], [`Next`]) and what [`Transaction::replan`] found
//! ([`Replanned`]); and [`Transaction::report`] / [`Transaction::finish`],
//! which build them (docs/architecture.md, "The data path of an upload").

use std::fmt::Write as _;
use std::time::Duration;

use driveset_schema::ResolvedSet;

use super::Transaction;
use crate::client::{DriveClient, Identity};
use crate::error::EngineError;
use crate::journal::TxnState;
use crate::plan::{Storage, code_label, value_text};

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
    /// Whether the drive keeps the set over a power cycle
    /// ([`crate::upload::Stored`]).
    pub stored: crate::upload::Stored,
    /// The transfer rate (`--transfer-baud`): switched or not, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transfer: Option<crate::rate_report::TransferReport>,
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
        // a drive that stores every write needs no line of its own (the
        // JSON says `every-write`)
        if self.state == TxnState::Complete && self.stored != crate::upload::Stored::EveryWrite {
            let _ = writeln!(out, "store: {}", self.stored.text());
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
    /// What went wrong ([`TransactionOutcome::RolledBack`](crate::error::TransactionOutcome::RolledBack), [`TransactionOutcome::Inconsistent`](crate::error::TransactionOutcome::Inconsistent),
    /// [`Refused::Rule`](crate::error::Refused::Rule), ...).
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

impl Transaction {
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
                report: self.journal.file.as_ref().map(|_| Box::new(report)),
            }),
        }
    }

    /// The report so far.
    pub fn report(&self, client: &dyn DriveClient, set: &ResolvedSet) -> UploadReport {
        let stats = self.counters.total(client);
        let state = self
            .journal
            .file
            .as_ref()
            .map(|j| j.journal.state)
            .unwrap_or(TxnState::Complete);
        let mut codes = Vec::new();
        for k in &self.codes.order {
            let r = self.codes.records.get(k).cloned().unwrap_or_default();
            let (old, new) = r.texts;
            codes.push(CodeReport {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.drive.schema, *k),
                old,
                new,
                storage: r.storage,
                outcome: r.outcome,
            });
        }
        for (k, r) in &self.codes.records {
            let Some(v) = &r.unchanged else { continue };
            if r.new.is_some() {
                continue;
            }
            let t = value_text(&self.drive.schema, *k, v);
            codes.push(CodeReport {
                number: k.number,
                subcode: k.subcode,
                code: code_label(&self.drive.schema, *k),
                old: t.clone(),
                new: t,
                storage: None,
                outcome: CodeOutcome::Unchanged,
            });
        }
        let fingerprint_after = match state {
            TxnState::Complete => Some(self.codes.after(&self.drive.schema, set).fingerprint()),
            TxnState::RolledBack => Some(
                self.progress
                    .rolled_back_to
                    .clone()
                    .unwrap_or_else(|| self.progress.fingerprint_before.clone()),
            ),
            _ => None,
        };
        UploadReport {
            target: self.drive.target.to_string(),
            identity: self.drive.identity.clone(),
            schema: self.drive.schema.id.clone(),
            journal: self
                .journal
                .file
                .as_ref()
                .map(|j| j.path().display().to_string()),
            state,
            set_fingerprint: set.fingerprint(),
            fingerprint_before: self.progress.fingerprint_before.clone(),
            fingerprint_after,
            codes_in_set: set.values.len(),
            codes_written: self.progress.written,
            attempts: self.progress.attempts,
            telegrams: stats.telegrams,
            retries: stats.retries,
            elapsed: client.clock().now() - self.counters.start,
            interleaved_reads: self.progress.interleaved,
            dataset: self.dataset.note.clone(),
            sload_polls: Some(stats.sload_polls).filter(|n| *n > 0),
            late_replies: stats.late,
            codes,
            warnings: self.progress.warnings.clone(),
            stored: self.stored(state == TxnState::Complete),
            transfer: None,
        }
    }
}
