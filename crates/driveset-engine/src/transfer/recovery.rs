//! `recover`'s part of a transfer-rate switch (module docs of
//! `crate::transfer`, "Failure"): [`find_drive`] searches for the drive
//! before the transaction is settled, [`finish_rate`] switches it back
//! after, and [`judged_rate`] tells recover how to judge the rate code
//! while a switch back is open.

use std::path::Path;

use driveset_schema::{CodeKey, RawValue, Schema};

use super::record::{planned_rate, start_back, whereabouts};
use super::switch::{Back, search, switch_back_once, with_rate_note};
use super::{Codes, as_rate, codes_of, refuse};
use crate::client::{DriveClient, set_line_rate};
use crate::error::EngineError;
use crate::journal::{JournalFile, JournalValue, TransferRecord, TransferState};

/// What the rate code keeps once recover settled the transaction with
/// `action`: the planned new value (completed) or the backup (rolled back)
/// when the transaction has the code, else the drive's own `before`.
fn settled_keep(
    journal: &crate::journal::Journal,
    c: Codes,
    rec: &TransferRecord,
    action: crate::recover::RecoverAction,
) -> JournalValue {
    use crate::recover::RecoverAction;
    let backup = journal
        .backup
        .iter()
        .find(|b| b.number == c.rate.number && b.subcode == c.rate.subcode)
        .map(|b| b.old.clone());
    let planned = journal
        .plan
        .iter()
        .find(|p| p.number == c.rate.number && p.subcode == c.rate.subcode)
        .map(|p| p.new.clone());
    let unchanged = journal
        .unchanged
        .iter()
        .find(|b| b.number == c.rate.number && b.subcode == c.rate.subcode)
        .map(|b| b.old.clone());
    let chosen = match action {
        RecoverAction::Completed => planned.or(unchanged),
        RecoverAction::RolledBack | RecoverAction::Nothing => backup.or(unchanged),
    };
    chosen.unwrap_or_else(|| rec.before.clone())
}

/// While a switch back is open, the rate code may hold the old rate (the
/// switch back writes it on the way) or the transfer rate (the
/// switch-over): recover judges the code by the value the upload decided
/// it keeps ([`TransferRecord::keep`]) instead, so that a cut in the switch
/// back does not make a landed transaction look rolled back. `None`: judge
/// what the drive holds.
pub(crate) fn judged_rate(
    journal: &crate::journal::Journal,
    schema: &Schema,
    key: CodeKey,
    holds: &RawValue,
) -> Option<RawValue> {
    let rec = journal.transfer.as_ref().filter(|t| !t.is_back())?;
    let c = codes_of(schema)?;
    let keep = rec.keep.as_ref()?.to_raw()?;
    let switch_wrote = as_rate(holds).is_some_and(|r| r == rec.old_rate || r == rec.transfer_rate);
    (key == c.rate && switch_wrote).then_some(keep)
}

/// `recover`'s first step for a journal that records a transfer-rate
/// switch: find the drive at whatever rate it answers (§5.1: the port's
/// rate, the transfer rate, the old rate, then every rate of the family)
/// and leave the host there; `Ok(None)` when the journal records no
/// switch. The transaction is then settled at that rate, and
/// `finish_rate` switches back.
pub fn find_drive(
    client: &mut dyn DriveClient,
    jf: &JournalFile,
) -> Result<Option<u32>, EngineError> {
    let Some(rec) = jf.journal.transfer.clone() else {
        return Ok(None);
    };
    let schema = client.schema().clone();
    let target = client.target().clone();
    if codes_of(&schema).is_none() {
        return Err(refuse(
            &target,
            format!(
                "the journal records a transfer-rate switch, but schema `{}` has no online rate change",
                schema.id
            ),
        ));
    }
    let here = client.line_rate().unwrap_or(rec.old_rate);
    match search(client, &[here, rec.transfer_rate, rec.old_rate])? {
        Some(found) => Ok(Some(found)),
        None => {
            let _ = set_line_rate(client, here);
            Err(EngineError::no_answer(
                target,
                format!(
                    "the search for the drive over every rate (lustbus-protocol.txt §5.1; the journal records a switch from {} to {} baud); {}",
                    rec.old_rate,
                    rec.transfer_rate,
                    whereabouts(&rec, rec.state, None)
                ),
                1,
            ))
        }
    }
}

/// `recover`'s last step for a journal that records a transfer-rate
/// switch, after the transaction was settled (`result`) with the drive
/// found at `found` baud: an open switch is switched back to the old rate,
/// the rate code keeping what a successful settle left in it
/// (`keep_value`: never the transfer rate unless the set's), or after a
/// failed one the [`TransferRecord::keep`] the upload recorded when it had
/// settled the transaction itself (`settled_before`).
/// This is done after a failed settle too, so that the drive is not left
/// at the transfer rate, but never when the drive is not the journal's.
/// A switch already back with the drive found at another rate (it
/// restarted at what its rate code held) is switched back the same way.
pub(crate) fn finish_rate(
    client: &mut dyn DriveClient,
    journal: &Path,
    found: u32,
    settled_before: bool,
    result: Result<crate::recover::RecoverReport, EngineError>,
) -> Result<crate::recover::RecoverReport, EngineError> {
    if let Err(e) = &result
        && e.not_journal_drive_refusal().is_some()
    {
        return result;
    }
    let mut jf = match JournalFile::open(journal) {
        Ok(jf) => jf,
        Err(e) => return result.and(Err(e)),
    };
    let Some(mut rec) = jf.journal.transfer.clone() else {
        return result;
    };
    let Some(c) = codes_of(client.schema()) else {
        return result;
    };
    let back: Back = if rec.is_back() && found == rec.old_rate {
        Ok(format!("the drive runs at {found} baud"))
    } else {
        // A drive found elsewhere though the switch was back has
        // restarted since at what its rate code held: it is switched back
        // too, keeping what the settle left there.
        // After a successful settle the outcome says what the rate code
        // keeps: the set's value (completed) or the old one (rolled back)
        // when the set has the code, else the drive's own `before`; after a
        // failed one, the decision the upload recorded stands.
        match result.as_ref().map(|r| r.action) {
            Ok(action) => rec.keep = Some(settled_keep(&jf.journal, c, &rec, action)),
            Err(_) if !settled_before || rec.is_back() => rec.keep = None,
            Err(_) => {}
        }
        let planned = planned_rate(&jf.journal, c);
        let state0 = rec.state;
        start_back(&mut rec);
        let mut persist = |r: &TransferRecord| {
            jf.journal.transfer = Some(r.clone());
            jf.persist()
        };
        match persist(&rec)
            .and_then(|()| switch_back_once(client, c, &mut rec, planned.as_ref(), &mut persist))
        {
            Ok(state) => {
                rec.state = TransferState::Back;
                rec.back_at_ns = Some(client.clock().now().as_nanos());
                jf.journal.transfer = Some(rec);
                match jf.persist() {
                    Ok(()) => Ok(format!("found at {found} baud; {state}")),
                    Err(e) => Err(e.to_string()),
                }
            }
            Err(e) => Err(format!(
                "{e}; {}",
                whereabouts(&rec, state0, client.line_rate())
            )),
        }
    };
    match (result, back) {
        (Ok(mut r), Ok(text)) => {
            r.transfer = Some(text);
            Ok(r)
        }
        (Ok(_), Err(why)) => Err(EngineError::no_answer(
            client.target().clone(),
            format!(
                "switching back from the transfer rate (the transaction was settled; {why}; run `driveset recover {}` again)",
                journal.display()
            ),
            1,
        )),
        (Err(e), back) => Err(with_rate_note(e, &back)),
    }
}
