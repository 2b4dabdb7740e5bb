//! Switching the drive and the host's port (module docs of
//! `crate::transfer`, "The switch"; `lustbus-protocol.txt` §11.5): over to
//! the transfer rate, back to the old rate (searching for the drive first
//! when it does not answer), the search over the family's rates (§5.1),
//! and where the rate stands added to an error's text.

use std::fmt::Write as _;
use std::path::Path;

use driveset_schema::{CodeKey, RawValue};

use super::TransferRefusal;
use super::record::{as_rate_j, keep_value, persist_record, planned_rate, start_back, whereabouts};
use super::{Codes, as_rate, codes_of};
use crate::client::{DriveClient, Target, set_line_rate};
use crate::error::{
    DeviceFailure, EngineError, ErrorKind, LinkFailure, Refusal, Refused, TransactionOutcome,
};
use crate::guard::Permit;
use crate::journal::{JournalFile, JournalValue, TransferRecord, TransferState};
use crate::plan::code_label;

/// Write `raw` to the rate code.
fn write_rate(client: &mut dyn DriveClient, c: Codes, baud: u32) -> Result<(), EngineError> {
    client.write_named(c.rate, &RawValue::Int(i64::from(baud)), Permit::RATE_SWITCH)
}

/// Tell the drive to activate the rate its rate code holds (§11.5).
fn activate(client: &mut dyn DriveClient, c: Codes) -> Result<(), EngineError> {
    client.write_named(
        CodeKey::new(c.online.command),
        &RawValue::Int(c.online.activate),
        Permit::ACTIVATE_RATE,
    )
}

/// Read the rate code at the host's current rate, expecting `want`.
fn confirm(client: &mut dyn DriveClient, c: Codes, want: u32) -> Result<(), EngineError> {
    let got = client.read(c.rate)?;
    if as_rate(&got) == Some(want) {
        Ok(())
    } else {
        Err(EngineError::protocol(
            client.target().clone(),
            format!("confirm the line rate {want}"),
            format!(
                "{} reads {got:?} at {want} baud instead of {want}",
                code_label(client.schema(), c.rate)
            ),
        ))
    }
}

/// §5.1: "the connection will be attempted using all possible transfer
/// rates": probe the drive (a read of the rate code) at `first` rates in
/// order, then at every rate of the family, highest first. The host is
/// left at the rate that answered. `Ok(None)`: no rate answers.
pub fn search(client: &mut dyn DriveClient, first: &[u32]) -> Result<Option<u32>, EngineError> {
    let schema = client.schema().clone();
    let Some(c) = codes_of(&schema) else {
        return Ok(None);
    };
    let mut order: Vec<u32> = first.to_vec();
    for r in schema.family.descriptor().line_rates.rates {
        if !order.contains(r) {
            order.push(*r);
        }
    }
    for r in order {
        if client.line_rate() != Some(r)
            && let Err(e) = set_line_rate(client, r)
        {
            if matches!(
                e.kind(),
                ErrorKind::Link(LinkFailure::Transport(
                    driveset_link::LinkError::UnsupportedBaud { .. }
                ))
            ) {
                continue;
            }
            return Err(e);
        }
        match client.read(c.rate) {
            Ok(_) => return Ok(Some(r)),
            Err(e) => match e.kind() {
                ErrorKind::Link(LinkFailure::NoAnswer { .. } | LinkFailure::Protocol { .. }) => {
                    continue;
                }
                ErrorKind::Device(DeviceFailure::Refused { .. }) => return Ok(Some(r)),
                _ => return Err(e),
            },
        }
    }
    Ok(None)
}

/// Switch the drive and the port to `rec.transfer_rate` (module docs, steps
/// 1-2), recording every step in the journal at `journal`. On failure the
/// drive is searched for and switched back; the error says where it is.
pub(super) fn switch_over(
    client: &mut dyn DriveClient,
    c: Codes,
    rec: &mut TransferRecord,
    journal: &Path,
) -> Result<(), EngineError> {
    let rate = rec.transfer_rate;
    let step =
        |client: &mut dyn DriveClient, rec: &mut TransferRecord| -> Result<(), EngineError> {
            write_rate(client, c, rate)?;
            rec.switched_at_ns = Some(client.clock().now().as_nanos());
            activate(client, c)?;
            set_line_rate(client, rate)?;
            confirm(client, c, rate)?;
            if as_rate_j(&rec.before) != Some(rate) {
                let before = rec.before.to_raw().unwrap_or(RawValue::Int(0));
                client.write(c.rate, &before)?;
            }
            Ok(())
        };
    match step(client, rec) {
        Ok(()) => {
            rec.state = TransferState::AtTransferRate;
            persist_record(journal, rec)
        }
        Err(e) => {
            // Back to the old rate, whatever happened.
            let back = switch_back(client, c, rec, journal);
            Err(with_rate_note(e, &back))
        }
    }
}

/// The outcome of [`switch_back`], for messages: `Ok(state text)`.
pub(super) type Back = Result<String, String>;

/// Switch the drive back to `rec.old_rate` (module docs, step 4), searching
/// for it first if it does not answer at the host's rate. The rate code
/// gets [`TransferRecord::keep`] ([`keep_value`]), journalled before the
/// first write of the switch back.
pub(super) fn switch_back(
    client: &mut dyn DriveClient,
    c: Codes,
    rec: &mut TransferRecord,
    journal: &Path,
) -> Back {
    let planned = JournalFile::open(journal)
        .ok()
        .and_then(|jf| planned_rate(&jf.journal, c));
    let state0 = rec.state;
    start_back(rec);
    persist_record(journal, rec).map_err(|e| e.to_string())?;
    let old = rec.old_rate;
    let mut tried_search = false;
    let mut persist = |r: &TransferRecord| persist_record(journal, r);
    loop {
        match switch_back_once(client, c, rec, planned.as_ref(), &mut persist) {
            Ok(state) => {
                rec.state = TransferState::Back;
                rec.back_at_ns = Some(client.clock().now().as_nanos());
                persist_record(journal, rec).map_err(|e| e.to_string())?;
                return Ok(state);
            }
            Err(e) if !tried_search => {
                tried_search = true;
                let first = [client.line_rate().unwrap_or(old), rec.transfer_rate, old];
                match search(client, &first) {
                    Ok(Some(_)) => continue,
                    Ok(None) => return Err(format!("{e}; {}", whereabouts(rec, state0, None))),
                    Err(e2) => return Err(format!("{e}; searching the drive: {e2}")),
                }
            }
            Err(e) => {
                return Err(format!(
                    "{e}; the drive answered at {} baud before this failure and may run at {} or {} baud now",
                    client.line_rate().unwrap_or(old),
                    rec.transfer_rate,
                    old
                ));
            }
        }
    }
}

/// One attempt at the switch back from wherever the host reaches the
/// drive: decide and journal the value to keep (through `persist`) before
/// the first write, activate the old rate if the drive is not at it, write
/// the value to keep without activating it and read it back.
pub(super) fn switch_back_once(
    client: &mut dyn DriveClient,
    c: Codes,
    rec: &mut TransferRecord,
    planned: Option<&RawValue>,
    persist: &mut dyn FnMut(&TransferRecord) -> Result<(), EngineError>,
) -> Result<String, EngineError> {
    let old = rec.old_rate;
    let label = rec.code.clone();
    let now = client.read(c.rate)?;
    let keep = keep_value(rec, planned, &now);
    if rec.keep.is_none() {
        rec.keep = Some(JournalValue::from(&keep));
        persist(rec)?;
    }
    // What the rate code holds, read at the old rate: the confirm's read
    // after a switch, else the read above (the drive answered at the old
    // rate already).
    let holds = if client.line_rate() != Some(old) {
        write_rate(client, c, old)?;
        activate(client, c)?;
        set_line_rate(client, old)?;
        confirm(client, c, old)?;
        RawValue::Int(i64::from(old))
    } else {
        now
    };
    if holds != keep {
        client.write(c.rate, &keep)?;
        let got = client.read(c.rate)?;
        if got != keep {
            return Err(EngineError::protocol(
                client.target().clone(),
                format!("verify {label}"),
                format!("reads back {got:?} instead of {keep:?}"),
            ));
        }
    }
    // the rate code is an EEPROM value: back only once the drive has
    // saved it (a restart before then comes up at the rate it held)
    crate::client::saved(client, std::iter::once(c.rate));
    let stored = JournalValue::from(&keep);
    let text = stored.to_string();
    rec.stored = Some(stored);
    Ok(if as_rate(&keep) == Some(old) {
        format!("the drive runs at {old} baud again; {label} = {text}")
    } else {
        format!(
            "the drive runs at {old} baud again; {label} holds {text} (not active: in effect after the drive's next restart)"
        )
    })
}

/// Add where the drive's rate stands to an error's text.
pub(super) fn with_rate_note(mut e: EngineError, back: &Back) -> EngineError {
    let note = match back {
        Ok(s) => s.clone(),
        Err(s) => format!("switching back from the transfer rate failed: {s}"),
    };
    match &mut *e.kind {
        ErrorKind::Transaction(
            TransactionOutcome::RolledBack { detail, .. }
            | TransactionOutcome::Inconsistent { detail, .. },
        )
        | ErrorKind::Link(LinkFailure::Protocol { detail, .. }) => {
            let _ = write!(detail, "; {note}");
        }
        ErrorKind::Link(LinkFailure::NoAnswer { what, .. })
        | ErrorKind::Device(DeviceFailure::Refused { what, .. }) => {
            let _ = write!(what, " ({note})");
        }
        ErrorKind::Refusal(Refused::Rule(Refusal::Transfer(TransferRefusal::Rate { detail }))) => {
            let _ = write!(detail, "; {note}");
        }
        _ => {
            return EngineError::protocol(
                target_of(&e),
                "the transaction at the transfer rate",
                format!("{e}; {note}"),
            );
        }
    }
    e
}

fn target_of(e: &EngineError) -> Target {
    e.target.clone().unwrap_or_else(|| Target {
        port: String::new(),
        address: 0,
    })
}
