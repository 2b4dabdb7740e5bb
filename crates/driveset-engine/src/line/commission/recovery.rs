//! Owns what a line run does with unfinished journals (module docs of
//! [`super`], "Unfinished journals"): before a drive is touched,
//! `commission` recovers its unfinished journals (found by recorded bus
//! and address; `status` fails such a drive, [`crate::line::status`]); a
//! broadcast asks whether any address it reaches has one.

use std::ops::RangeInclusive;

use super::run::Ctx;
use crate::client::{DriveClient, IdentProtocol};
use crate::error::EngineError;
use crate::history::{DriveRecord, Slot, Unit};
use crate::journal::Unfinished;
use crate::line::manifest::Drive;
use crate::observe::{Hook, Phase};
use crate::recover::{RecoverAction, RecoverOptions, RecoverReport, recover};

/// A drive with an unfinished journal is not done: `commission` recovers
/// each of its `unfinished` journals first ([`crate::recover::recover`]:
/// it refuses another drive or a stale journal); `recovered` gets a note
/// per journal recovered.
pub(super) fn recover_unfinished(
    client: &mut dyn DriveClient,
    d: &Drive,
    ctx: &Ctx<'_>,
    hook: &Hook,
    unfinished: &[Unfinished],
    recovered: &mut Vec<String>,
) -> Result<(), EngineError> {
    if unfinished.is_empty() {
        return Ok(());
    }
    hook.enter(client.clock(), Phase::Recover, None);
    for u in unfinished {
        let rep = recover(&mut *client, &u.path, &RecoverOptions::default()).map_err(|e| {
            EngineError::journal(u.path.display().to_string(), format!(
                    "the drive has an unfinished transaction from an earlier run, and recovering it failed: {e}"
                ))
        })?;
        record_recovery(client, d, ctx, &u.path, &rep);
        let did = match rep.action {
            RecoverAction::Completed => "completed (the drive held the new values)",
            RecoverAction::RolledBack => "rolled back (old values restored)",
            RecoverAction::Nothing => "already settled",
        };
        recovered.push(format!(
            "{}: recovered the unfinished journal {} of an earlier run: {did}",
            d.name,
            u.path.display()
        ));
    }
    Ok(())
}

/// Put a recovery that wrote or settled the drive on the run's record
/// ([`crate::history`]), before the drive's own record: result
/// `rolled-back` (each code restored: what it held, what it was restored
/// to, the read-back) or `completed`.
fn record_recovery(
    client: &dyn DriveClient,
    d: &Drive,
    ctx: &Ctx<'_>,
    journal: &std::path::Path,
    rep: &RecoverReport,
) {
    let result = match rep.action {
        RecoverAction::Nothing => return,
        RecoverAction::Completed => "completed",
        RecoverAction::RolledBack => "rolled-back",
    };
    let Some(h) = ctx.opts.env.history() else {
        return;
    };
    let record = DriveRecord {
        slot: Slot {
            line: Some(ctx.line.to_string()),
            drive: Some(d.name.clone()),
            bus: d.bus.clone(),
            address: d.address,
        },
        unit: Unit {
            family: IdentProtocol::Family(d.schema.family).name().to_string(),
            ..Unit::default()
        },
        schema: client.schema().id.clone(),
        set_fingerprint: None,
        fingerprint_before: None,
        fingerprint_after: rep.fingerprint.clone(),
        result: result.into(),
        cause: None,
        error: None,
        journal: Some(journal.display().to_string()),
        codes: rep.restored_values.clone(),
    };
    if let Err(e) = h.drive(&record) {
        ctx.warn(format!("{}: not recorded in the history: {e}", d.name));
    }
}

/// The unfinished journals of any address in `addresses` on the bus
/// `bus_id` (port `port`): their paths, for a broadcast's refusal (an error
/// reading them counts as none here; each drive's own check reports it).
pub(super) fn unfinished_at(
    ctx: &Ctx<'_>,
    bus_id: &str,
    port: &str,
    addresses: RangeInclusive<u8>,
) -> Vec<String> {
    addresses
        .flat_map(|a| {
            crate::journal::unfinished_for(&ctx.opts.journal_dir, bus_id, port, a)
                .unwrap_or_default()
        })
        .map(|u| u.path.display().to_string())
        .collect()
}
