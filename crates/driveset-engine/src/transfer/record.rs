//! The switch's record in the journal ([`TransferRecord`],
//! docs/journals.md): the placeholder journal a switch starts, updating
//! the record in whoever's journal holds it, the value the rate code is to
//! keep once the drive is back at its old rate, and where the switch
//! stands, for messages.

use std::path::Path;

use driveset_schema::RawValue;

use super::{Codes, as_rate};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::{
    JOURNAL_VERSION, Journal, JournalFile, JournalTarget, JournalValue, TransferRecord,
    TransferState, TxnState,
};

/// A placeholder journal of the transaction, before anything is sent:
/// the rate switch is recorded in it; an upload that plans writes replaces
/// it, keeping the record.
pub(super) fn placeholder(
    client: &dyn DriveClient,
    identity: &crate::client::Identity,
    set_fingerprint: String,
    record: TransferRecord,
) -> Journal {
    let schema = client.schema();
    Journal {
        journal_version: JOURNAL_VERSION,
        state: TxnState::Planned,
        target: JournalTarget::of(client),
        identity: identity.into(),
        schema: schema.id.clone(),
        schema_source: crate::journal::SchemaSource::of(schema),
        set_fingerprint,
        fingerprint_before: String::new(),
        dataset: false,
        attempt: 0,
        backup: Vec::new(),
        plan: Vec::new(),
        unchanged: Vec::new(),
        written: Vec::new(),
        transitions: Vec::new(),
        failure: None,
        failure_cause: None,
        holding: Vec::new(),
        broadcast: Vec::new(),
        transfer: Some(record),
        assign: None,
    }
}

/// Update the record in the journal file (whoever wrote it last).
pub(super) fn persist_record(path: &Path, record: &TransferRecord) -> Result<(), EngineError> {
    let mut jf = JournalFile::open(path)?;
    jf.journal.transfer = Some(record.clone());
    jf.persist()
}

/// Where the switch stands after a failure, for messages; `state`: where
/// the record stood when the failing step began.
pub(super) fn whereabouts(
    rec: &TransferRecord,
    state: TransferState,
    found: Option<u32>,
) -> String {
    let keep = rec.keep.as_ref().unwrap_or(&rec.before);
    match found {
        Some(r) if r == rec.old_rate => format!("the drive runs at {r} baud again"),
        Some(r) => format!(
            "the drive answers at {r} baud, not at the port's {} baud",
            rec.old_rate
        ),
        None if state == TransferState::AtTransferRate => format!(
            "the drive answers at no rate (it may still run at the transfer rate {} baud; its {} holds {} in EEPROM, so a restart brings it to that rate)",
            rec.transfer_rate, rec.code, rec.before
        ),
        None => format!(
            "the drive answers at no rate (it may run at the transfer rate {} baud or at {} baud, and its {} may hold {} in EEPROM until the switch back is finished: run `driveset recover` as soon as the drive is reachable again; it searches every rate and leaves {} holding {keep})",
            rec.transfer_rate, rec.old_rate, rec.code, rec.transfer_rate, rec.code
        ),
    }
}

pub(super) fn as_rate_j(v: &JournalValue) -> Option<u32> {
    v.to_raw().as_ref().and_then(as_rate)
}

/// What the rate code is to hold once the drive runs at the old rate again
/// ([`TransferRecord::keep`]), given what it holds `now` and the value the
/// transaction plans for it (`planned`): the recorded decision when there
/// is one; `before` while the switch-over was under way (the transfer rate
/// or `before` is in EEPROM, nothing of the set); else what the
/// transaction left there (its old or its new value), but never the
/// transfer rate unless that is the set's own value.
pub(super) fn keep_value(
    rec: &TransferRecord,
    planned: Option<&RawValue>,
    now: &RawValue,
) -> RawValue {
    if let Some(k) = rec.keep.as_ref().and_then(JournalValue::to_raw) {
        return k;
    }
    let before = rec.before.to_raw().unwrap_or_else(|| now.clone());
    if rec.state == TransferState::Switching
        || (as_rate(now) == Some(rec.transfer_rate) && planned != Some(now))
    {
        return before;
    }
    now.clone()
}

/// The value the journal at `path` plans for the rate code, if any.
pub(super) fn planned_rate(journal: &crate::journal::Journal, c: Codes) -> Option<RawValue> {
    journal
        .plan
        .iter()
        .find(|p| p.number == c.rate.number && p.subcode == c.rate.subcode)
        .and_then(|p| p.new.to_raw())
}

/// Mark the record `switching-back`, deciding [`TransferRecord::keep`]
/// right away when the switch-over itself was cut (then it is `before`).
pub(super) fn start_back(rec: &mut TransferRecord) {
    if rec.state == TransferState::Switching && rec.keep.is_none() {
        rec.keep = Some(rec.before.clone());
    }
    rec.state = TransferState::SwitchingBack;
}
