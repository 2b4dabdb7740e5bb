//! A switched session (module docs of `crate::transfer`, steps 1-2 and
//! 4): [`begin`] checks, decides and, when it pays, journals and switches
//! over; [`end`] switches back and settles a placeholder journal nobody
//! replaced.

use std::path::Path;

use driveset_schema::CodeKey;

use super::decide::decide;
use super::record::placeholder;
use super::switch::{switch_back, switch_over, with_rate_note};
use super::{Codes, TransferRequest, check, codes_of, refuse};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::{JournalFile, JournalValue, TransferRecord, TransferState, TxnState};
use crate::plan::code_label;
use crate::rate_report::{Decision, TransferReport};

/// A switched session: what [`begin`] did, for `end`.
#[derive(Debug)]
pub struct Session {
    codes: Option<Codes>,
    record: Option<TransferRecord>,
    decision: Decision,
}

impl Session {
    /// The record to give the upload ([`crate::upload::UploadOptions::transfer`]).
    pub fn record(&self) -> Option<&TransferRecord> {
        self.record.as_ref()
    }

    /// The estimate.
    pub fn decision(&self) -> &Decision {
        &self.decision
    }
}

/// Check, decide, and when it pays switch (module docs, steps 1-2): the
/// journal at `journal` is created (placeholder, `set_fingerprint`) before
/// the first telegram of the switch. `reads` / `writes`: the exchanges
/// the command cannot avoid, for [`decide`].
pub fn begin(
    client: &mut dyn DriveClient,
    req: &TransferRequest,
    journal: &Path,
    set_fingerprint: String,
    reads: &[CodeKey],
    writes: &[CodeKey],
) -> Result<Session, EngineError> {
    check(client, req)?;
    crate::upload::check_unfinished(&*client, journal)?;
    let decision = decide(&*client, req, reads, writes);
    let Some(c) = codes_of(client.schema()).filter(|_| decision.switch) else {
        return Ok(Session {
            codes: None,
            record: None,
            decision,
        });
    };
    let target = client.target().clone();
    let identity = client.identify()?;
    // the guard's running rule, without override (module docs)
    if let Err(e) = crate::guard::standstill(client, crate::overrides::Overrides::none()) {
        if !e.is_refused() {
            return Err(e);
        }
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: the drive reports a running motor (or its running state cannot be read); the line rate is switched only at standstill, and no override lifts that: stop the drive, or leave out --transfer-baud",
                req.rate
            ),
        ));
    }
    let before = client.read(c.rate)?;
    let mut record = TransferRecord {
        code: code_label(client.schema(), c.rate),
        old_rate: decision.old_rate,
        transfer_rate: req.rate,
        before: JournalValue::from(&before),
        state: TransferState::Switching,
        switched_at_ns: None,
        back_at_ns: None,
        stored: None,
        keep: None,
    };
    if let Some(dir) = journal.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::journal::ensure_dir(dir)?;
    }
    let mut j = placeholder(&*client, &identity, set_fingerprint, record.clone());
    j.transition(
        TxnState::Planned,
        client.clock().now().as_nanos(),
        Some(format!(
            "switching to the transfer rate {} baud (from {})",
            req.rate, decision.old_rate
        )),
    );
    JournalFile::create(journal, j)?;
    switch_over(client, c, &mut record, journal).map_err(|e| {
        let j = journal.display();
        with_rate_note(e, &Ok(format!("journal {j}: run `driveset recover {j}`")))
    })?;
    Ok(Session {
        codes: Some(c),
        record: Some(record),
        decision,
    })
}

/// Switch back (module docs, step 4) and settle the journal: a placeholder
/// nobody replaced becomes `complete` when `ok`, else `rolled-back`
/// (nothing but the rate was written). Returns the report, or the error
/// text when the drive could not be switched back (the journal then keeps
/// the record open for `driveset recover`).
pub(super) fn end(
    client: &mut dyn DriveClient,
    session: Session,
    journal: &Path,
    ok: bool,
) -> Result<TransferReport, Box<(TransferReport, String)>> {
    let (Some(c), Some(mut rec)) = (session.codes, session.record) else {
        return Ok(TransferReport {
            decision: session.decision,
            switched: false,
            state: String::new(),
        });
    };
    // The upload may have rewritten the journal (with this record in it).
    let back = switch_back(client, c, &mut rec, journal);
    let report = |state: String| TransferReport {
        decision: session.decision.clone(),
        switched: true,
        state,
    };
    match back {
        Ok(state) => {
            if let Ok(mut jf) = JournalFile::open(journal)
                && jf.journal.plan.is_empty()
                && jf.journal.state == TxnState::Planned
            {
                let (st, note) = if ok {
                    (
                        TxnState::Complete,
                        "nothing to write; line rate switched back",
                    )
                } else {
                    (
                        TxnState::RolledBack,
                        "nothing written; line rate switched back",
                    )
                };
                jf.journal
                    .transition(st, client.clock().now().as_nanos(), Some(note.into()));
                if let Err(e) = jf.persist() {
                    return Err(Box::new((report(state), e.to_string())));
                }
            }
            Ok(report(state))
        }
        Err(why) => Err(Box::new((report(why.clone()), why))),
    }
}
