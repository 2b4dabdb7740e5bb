//! `driveset recover JOURNAL`: finish or undo a transaction a crash or a
//! pulled cable interrupted, from the journal alone plus a client to the
//! same drive.
//!
//! - journal `complete` or `rolled-back`: nothing to do;
//! - **the drive is not the journal's drive**: refused with
//!   [`NotJournalDrive`](crate::journal::NotJournalDrive) (exit 2 in the CLI), in this order:
//!   a version 1 journal (it records no bus, [`Mismatch::Version`]), another
//!   schema ([`Mismatch::Schema`]), another bus ([`Mismatch::Bus`]: the
//!   client's [`DriveClient::bus_id`] is not the recorded one, whatever the
//!   port spelling), another address ([`Mismatch::Address`]; the planned
//!   new value of a bus address code also counts) — all four before
//!   anything is sent — then, after identify, other identify codes,
//!   protocol or software ([`Mismatch::Identity`]);
//! - **the journal is stale**: every planned code (and, on MC6000/7000,
//!   80-SLOAD) is read; a planned code that holds neither its old nor its
//!   new value was written since the transaction was cut: refused
//!   ([`Mismatch::Stale`], naming those codes). These reads are the only
//!   telegrams before the refusal; nothing is written, so a refusal never
//!   opens a dataset download (SLOAD = -1) on the drive;
//! - otherwise every code of the set is read. If every planned code holds
//!   its new value (and, on MC6000/7000, no dataset download is left open:
//!   80-SLOAD is not -1) the transaction landed: marked `complete`. Anything
//!   else is rolled back: the backup is restored (codes that differ, in
//!   reverse write order; CardWriteable values through a fresh dataset
//!   download of every backed-up CardWriteable value, which also closes an
//!   open one), read back and compared: `rolled-back`. If that fails the
//!   journal says `failed` with what each code holds, and recover can be
//!   run again.
//!
//! A dataset download left open (SLOAD = -1) is always rolled back, even if
//! the values read back look new: staged values are not committed.
//!
//! Codes the journal lists under `broadcast` (`commission
//! --broadcast-common`: their new value went to LUSTBUS address 31 into
//! the drive's open dataset download, with no receipt) are planned codes
//! like the others: they are read and judged by what the drive holds, and
//! since they only ever sit in a dataset download, a cut before SLOAD = -2
//! leaves it open and so rolled back; after an accepted SLOAD = -2 each
//! holds its new value, or its old one where the broadcast did not reach
//! the drive (then not every planned code is new: rolled back).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::Duration;

use driveset_schema::{CodeKey, RawValue, ResolvedSet};

use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::{FailureCause, JournalFile, Mismatch, TxnState, version_refusal};
use crate::observe::{Hook, Phase as Step};
use crate::plan::{DATASET_TIMEOUT, Phase, code_label};
use crate::upload::{
    RollbackPlan, describe_holdings, holdings, read_observed, read_values, restore,
};

/// What recovery did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RecoverAction {
    /// The journal was already settled.
    Nothing,
    /// The drive held the new values: verified, marked complete.
    Completed,
    /// The old values were restored (or were still there): verified, marked rolled-back.
    RolledBack,
}

impl RecoverAction {
    /// The action as the plant history records it (`nothing-to-do`,
    /// `completed`, `rolled-back`; the JSON report's `action` is serde's
    /// kebab-case, `nothing` for [`RecoverAction::Nothing`]).
    pub fn as_str(self) -> &'static str {
        match self {
            RecoverAction::Nothing => "nothing-to-do",
            RecoverAction::Completed => "completed",
            RecoverAction::RolledBack => "rolled-back",
        }
    }
}

/// Which recovery a journal asks for ([`route`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JournalRoute {
    /// An unfinished `driveset address` change: finished by
    /// [`crate::assign::recover()`], which finds the drive at its old or new
    /// address and rate.
    AddressChange,
    /// A transaction already settled (complete or rolled back, any
    /// transfer-rate switch back): nothing to do, no schema needed.
    Finished(TxnState),
    /// An unfinished upload: [`recover()`] with a client to the journal's
    /// drive and the journal's schema.
    Upload,
}

/// Which recovery `journal` asks for: an address change's unfinished
/// journal is the address change's to finish; a finished journal needs
/// nothing (an address change's names the schema learned from the drive,
/// which no file may hold); any other is an upload's.
pub fn route(journal: &crate::journal::Journal) -> JournalRoute {
    if crate::assign::is_assign_journal(journal) && !journal.is_finished() {
        JournalRoute::AddressChange
    } else if journal.is_finished() {
        JournalRoute::Finished(journal.state)
    } else {
        JournalRoute::Upload
    }
}

/// What `recover` found and did.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct RecoverReport {
    /// The journal file.
    pub journal: String,
    /// State the journal was in.
    pub found: TxnState,
    /// What was done.
    pub action: RecoverAction,
    /// Codes written while rolling back.
    pub restored: Vec<String>,
    /// The same codes with the values: what the drive held, what it was
    /// restored to (display texts; a password `<secret>`), for the plant
    /// history (docs/history.md). Not in the JSON report.
    #[serde(skip)]
    pub restored_values: Vec<crate::history::CodeRecord>,
    /// Control words the rollback left stopped instead of restoring a
    /// running state ("416-SCTL1 left stopped: the motor was running
    /// before; start it from the machine's control").
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Fingerprint of what the drive holds over the set's codes (when read).
    pub fingerprint: Option<String>,
    /// The store command was written again (`[schema.store] keeps =
    /// "on-command"`, the drive holding the new values).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub stored: bool,
    /// The client's port/address differ from the journal's (identity matched).
    pub target_note: Option<String>,
    /// A transfer-rate switch the journal left open: where the drive was
    /// found and that it runs at the old rate again ([`crate::transfer`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transfer: Option<String>,
}

/// Options of [`recover`].
#[derive(Debug, Clone)]
pub struct RecoverOptions {
    /// How long an MC6000/7000 dataset check may take.
    pub dataset_timeout: Duration,
    /// Told each phase: identify, read, rollback (restore and read back),
    /// verify (the final fingerprint read) ([`crate::observe`]).
    pub observer: Hook,
}

impl Default for RecoverOptions {
    fn default() -> Self {
        RecoverOptions {
            dataset_timeout: DATASET_TIMEOUT,
            observer: Hook::none(),
        }
    }
}

/// Finish or roll back the transaction recorded in `journal_path`.
pub fn recover(
    client: &mut dyn DriveClient,
    journal_path: &Path,
    opts: &RecoverOptions,
) -> Result<RecoverReport, EngineError> {
    let mut jf = JournalFile::open(journal_path)?;
    let journal_name = journal_path.display().to_string();
    let found = jf.journal.state;
    let report = RecoverReport {
        journal: journal_name.clone(),
        found,
        action: RecoverAction::Nothing,
        restored: Vec::new(),
        restored_values: Vec::new(),
        notes: Vec::new(),
        fingerprint: None,
        stored: false,
        target_note: None,
        transfer: None,
    };
    if jf.journal.is_finished() {
        return Ok(report);
    }
    if crate::assign::is_assign_journal(&jf.journal) {
        return Err(crate::assign::not_for_upload_recover(
            client.target().clone(),
            journal_path,
        ));
    }
    let schema = client.schema().clone();
    let target = client.target().clone();
    let refuse = |mismatch: Mismatch, detail: String| {
        EngineError::not_journal_drive(target.clone(), journal_name.clone(), mismatch, detail)
    };
    // checks that need no telegram: version, schema, bus, address
    let Some(journal_bus) = jf.journal.target.bus.clone() else {
        return Err(version_refusal(
            &target,
            journal_path,
            jf.journal.journal_version,
        ));
    };
    if schema.id != jf.journal.schema {
        return Err(refuse(
            Mismatch::Schema,
            format!(
                "it was written with schema `{}`, this client uses `{}`; nothing was sent. Recover with the schema the upload used",
                jf.journal.schema, schema.id
            ),
        ));
    }
    if let Some(fp) = &jf.journal.schema_source.schema_fingerprint
        && *fp != schema.fingerprint
    {
        let file = jf
            .journal
            .schema_source
            .schema_path
            .as_ref()
            .map_or_else(String::new, |p| format!(" from {p}"));
        return Err(refuse(
            Mismatch::Schema,
            format!(
                "it was written with schema `{}`{file} ({fp}), this client's `{}` is another version of it ({}); nothing was sent. Recover with the schema file the upload used (restore it from version control)",
                jf.journal.schema, schema.id, schema.fingerprint
            ),
        ));
    }
    let bus = client.bus_id();
    let jt = jf.journal.target.clone();
    if bus != journal_bus {
        return Err(refuse(
            Mismatch::Bus,
            format!(
                "it belongs to the drive at address {} on bus `{journal_bus}` (port {}), but this port reaches bus `{bus}`; nothing was sent. Recover through a port to that bus",
                jt.address, jt.port
            ),
        ));
    }
    let bad = |d: String| {
        EngineError::journal(
            journal_name.clone(),
            format!("{d}; the file is damaged, restore the drive by hand from it"),
        )
    };
    let planned = jf.journal.new_values().map_err(bad)?;
    let new_values: BTreeMap<CodeKey, RawValue> = planned.iter().cloned().collect();
    // the drive may answer at the address a planned bus address code gives it
    let moved_to: Vec<u8> = new_values
        .iter()
        .filter(|(k, _)| {
            schema
                .code(k.number)
                .is_some_and(|c| c.has_role(driveset_schema::Role::BusAddress))
        })
        .filter_map(|(_, v)| match v {
            RawValue::Int(a) => u8::try_from(*a).ok(),
            _ => None,
        })
        .collect();
    if target.address != jt.address && !moved_to.contains(&target.address) {
        return Err(refuse(
            Mismatch::Address,
            format!(
                "it belongs to the drive at address {} on bus `{journal_bus}`, not the one at address {}; nothing was sent. Recover at address {} (leave out --address)",
                jt.address, target.address, jt.address
            ),
        ));
    }

    // A transfer-rate switch left open: find the drive (LUSTBUS 5.1) and
    // switch it back to the journal's old rate first.
    // A journal the upload had settled is then checked like any other: its
    // `complete` or `rolled-back` is said again only after every code of
    // the set is read back (a restart during the switch back loses RAM
    // values).
    let rate_found = crate::transfer::find_drive(client, &jf)?;
    let settled_before = jf.journal.state.is_settled();
    let result = settle(client, &mut jf, opts, report);
    match rate_found {
        None => result,
        Some(rate) => {
            crate::transfer::finish_rate(client, journal_path, rate, settled_before, result)
        }
    }
}

/// The transaction part of [`recover`], after the checks that need no
/// telegram (and, for a journal with a transfer-rate switch, at whatever
/// rate the drive was found).
fn settle(
    client: &mut dyn DriveClient,
    jf: &mut JournalFile,
    opts: &RecoverOptions,
    mut report: RecoverReport,
) -> Result<RecoverReport, EngineError> {
    let journal_name = report.journal.clone();
    let found = report.found;
    let schema = client.schema().clone();
    let target = client.target().clone();
    let refuse = |mismatch: Mismatch, detail: String| {
        EngineError::not_journal_drive(target.clone(), journal_name.clone(), mismatch, detail)
    };
    let bus = client.bus_id();
    let jt = jf.journal.target.clone();
    let bad = |d: String| {
        EngineError::journal(
            journal_name.clone(),
            format!("{d}; the file is damaged, restore the drive by hand from it"),
        )
    };
    let backup: BTreeMap<CodeKey, RawValue> = jf
        .journal
        .backup_values()
        .map_err(bad)?
        .into_iter()
        .collect();
    let planned = jf.journal.new_values().map_err(bad)?;
    let unchanged = jf.journal.unchanged_values().map_err(bad)?;
    let new_values: BTreeMap<CodeKey, RawValue> = planned.iter().cloned().collect();
    let hook = &opts.observer;
    hook.enter(client.clock(), Step::Identify, None);
    let identity = client.identify()?;
    // An identification code the transaction itself writes (Tmd C0093 in a
    // set) may hold the old or the new value: leave it out of the match.
    let planned_names: BTreeSet<String> = new_values
        .keys()
        .map(|k| schema.display_code(k.number, k.subcode))
        .collect();
    let strip = |codes: &[(String, String)]| -> Vec<(String, String)> {
        codes
            .iter()
            .filter(|(n, _)| !planned_names.contains(n))
            .cloned()
            .collect()
    };
    let codes = identity.pairs();
    let same_drive = jf.journal.identity.same_protocol(identity.protocol)
        && jf.journal.identity.software == identity.software
        && strip(&jf.journal.identity.codes) == strip(&codes);
    if !same_drive {
        let show = |p: &str, codes: &[(String, String)], sw: &Option<String>| {
            let mut s: Vec<String> = codes.iter().map(|(n, v)| format!("{n} = {v}")).collect();
            if let Some(sw) = sw {
                s.push(format!("software {sw}"));
            }
            format!("{p}: {}", s.join(", "))
        };
        return Err(refuse(
            Mismatch::Identity,
            format!(
                "the drive identifies as {} but the journal was written for {}; nothing was written. Connect the drive the journal belongs to",
                show(identity.protocol.name(), &codes, &identity.software),
                show(
                    jf.journal.identity.protocol.name(),
                    &jf.journal.identity.codes,
                    &jf.journal.identity.software
                )
            ),
        ));
    }
    if jt.port != target.port || jt.address != target.address {
        report.target_note = Some(format!(
            "the journal was written through {} address {}; {target} reaches the same drive (bus `{bus}`)",
            jt.port, jt.address
        ));
    }

    // write order as planned; phase from the plan record
    let mut order: Vec<(CodeKey, Phase)> =
        jf.journal.plan.iter().map(|p| (p.key(), p.phase)).collect();
    for k in backup.keys() {
        if !order.iter().any(|(o, _)| o == k) {
            order.push((*k, Phase::Stored));
        }
    }

    let dataset = jf.journal.dataset && client.dataset().is_some();
    let handshake = schema.family.descriptor().dataset;
    hook.enter(client.clock(), Step::Read, None);
    let sload_open = if let Some(h) = handshake.filter(|h| dataset && schema.code(h.code).is_some())
    {
        client.read(CodeKey::new(h.code))? == RawValue::Int(h.begin)
    } else {
        false
    };
    let mut current = read_observed(client, backup.keys().copied(), hook, Step::Read)?;
    for (k, v) in current.values.iter_mut() {
        if let Some(keep) = crate::transfer::judged_rate(&jf.journal, &schema, *k, v) {
            *v = keep;
        }
    }
    // stale: a planned code holds neither its old nor its new value
    let stale: Vec<String> = order
        .iter()
        .filter(|(k, _)| {
            let now = current.values.get(k);
            now != backup.get(k) && now != new_values.get(k)
        })
        .map(|(k, _)| code_label(&schema, *k))
        .collect();
    if !stale.is_empty() {
        return Err(refuse(
            Mismatch::Stale {
                codes: stale.clone(),
            },
            format!(
                "{} {} neither the old nor the new value the journal records (written since the transaction was cut); nothing was written. The journal is stale: compare the drive with its set (`driveset diff SET --port ...`), upload the set again if needed, then delete the journal",
                stale.join(", "),
                if stale.len() == 1 { "holds" } else { "hold" }
            ),
        ));
    }
    let all_new = !new_values.is_empty()
        && new_values
            .iter()
            .all(|(k, v)| current.values.get(k) == Some(v));
    let at = |c: &dyn DriveClient| c.clock().now().as_nanos();

    if new_values.is_empty() && !sload_open {
        // Nothing was planned (a transfer-rate switch around a run that
        // had nothing to write, or that was cut before it planned): there
        // is nothing to restore; the codes it found unchanged must still
        // hold their values.
        held_or_failed(client, jf, &unchanged, hook, |codes, verb| {
            format!(
                "{codes} no longer {verb} the value the run found (nothing was planned, so nothing is restored); compare the drive with its set (`driveset diff SET --port ...`) and upload it again"
            )
        })?;
        let (state, action, note) = if found == TxnState::Complete {
            (
                TxnState::Complete,
                RecoverAction::Completed,
                "recover: nothing was planned; the codes the run found read back unchanged",
            )
        } else {
            (
                TxnState::RolledBack,
                RecoverAction::RolledBack,
                "recover: nothing was written but the line rate; read back",
            )
        };
        jf.journal
            .transition(state, at(&*client), Some(note.into()));
        jf.persist()?;
        report.action = action;
    } else if all_new && !sload_open {
        // a drive that keeps writes only on command holds them in RAM
        // until stored: store (again: a store command is idempotent)
        if let Some(command) = schema.store.command() {
            let t = at(&*client);
            jf.journal.transition(
                TxnState::Storing,
                t,
                Some("recover: the drive holds the new values (read back); storing".into()),
            );
            jf.persist()?;
            hook.enter(client.clock(), Step::Store, Some(1));
            client.store(command)?;
            // what was stored is what the drive holds now (a restart
            // between the read and the store stores the old values)
            held_or_failed(client, jf, &planned, hook, |codes, verb| {
                format!(
                    "after the store {codes} no longer {verb} the new value (did the drive restart?); run `driveset recover` again"
                )
            })?;
            report.stored = true;
        }
        let t = at(&*client);
        jf.journal.transition(
            TxnState::Complete,
            t,
            Some(if report.stored {
                "recover: the drive holds the new values (read back) and stored them".into()
            } else {
                "recover: the drive holds the new values (read back)".into()
            }),
        );
        jf.persist()?;
        report.action = RecoverAction::Completed;
    } else {
        let t = at(&*client);
        jf.journal.transition(
            TxnState::RollingBack,
            t,
            Some(if sload_open {
                "recover: a dataset download was left open (SLOAD = -1)".into()
            } else {
                "recover: the drive does not hold the whole new set".into()
            }),
        );
        jf.persist()?;
        let touched: BTreeSet<CodeKey> = backup
            .iter()
            .filter(|(k, old)| current.values.get(*k) != Some(*old))
            .map(|(k, _)| *k)
            .collect();
        let cw_differs = order
            .iter()
            .any(|(k, p)| *p == Phase::Dataset && touched.contains(k));
        hook.enter(client.clock(), Step::Rollback, None);
        report.restored = order
            .iter()
            .rev()
            .filter(|(k, p)| {
                touched.contains(k)
                    || (*p == Phase::Dataset && dataset && (sload_open || cw_differs))
            })
            .map(|(k, _)| code_label(&schema, *k))
            .collect();
        let plan = RollbackPlan::new(&schema, &backup, &new_values);
        report.notes = plan.notes(&schema, &touched);
        // read back equal to the plan's value when the rollback succeeds
        // (a failure below returns the error, not this report)
        let text =
            |k: &CodeKey, v: Option<&RawValue>| v.map(|v| crate::plan::value_text(&schema, *k, v));
        report.restored_values = order
            .iter()
            .rev()
            .filter(|(k, _)| report.restored.contains(&code_label(&schema, *k)))
            .map(|(k, _)| crate::history::CodeRecord {
                code: schema.display_code(k.number, k.subcode),
                old: text(k, current.values.get(k)),
                new: text(k, plan.restore.get(k)),
                verified: text(k, plan.restore.get(k)),
                outcome: "restored".into(),
                phase: None,
            })
            .collect();
        let result = restore(
            client,
            &schema,
            &order,
            &plan.restore,
            &touched,
            dataset && (sload_open || cw_differs),
            opts.dataset_timeout,
        )
        .and_then(|()| read_values(client, backup.keys().copied()));
        // a store command the transaction sent may have stored new values:
        // the restored old ones are stored again, once they read back
        let store_sent = jf
            .journal
            .transitions
            .iter()
            .any(|t| t.state == TxnState::Storing);
        let result = match (result, schema.store.command()) {
            (Ok(after), Some(command))
                if store_sent && backup.iter().all(|(k, v)| after.values.get(k) == Some(v)) =>
            {
                client.store(command).map(|()| {
                    report.stored = true;
                    after
                })
            }
            (r, _) => r,
        };
        let failure = match result {
            Ok(after) => {
                let differ: Vec<String> = backup
                    .keys()
                    .filter(|k| !after.values.get(*k).is_some_and(|v| plan.holds(**k, v)))
                    .map(|k| code_label(&schema, *k))
                    .collect();
                if differ.is_empty() {
                    None
                } else {
                    Some((
                        format!(
                            "after restoring, {} still differ from the backup",
                            differ.join(", ")
                        ),
                        FailureCause::StillDiffer { codes: differ },
                    ))
                }
            }
            Err(e) => Some((
                format!("restoring the old values failed: {e}"),
                FailureCause::of(&e),
            )),
        };
        if let Some((f, cause)) = failure {
            let holding = holdings(client, &schema, &backup, &new_values);
            let detail = format!("{f}; {}", describe_holdings(&holding));
            jf.journal.holding = holding;
            jf.journal.failure = Some(detail.clone());
            jf.journal.failure_cause = Some(cause);
            let t = at(&*client);
            jf.journal
                .transition(TxnState::Failed, t, Some(detail.clone()));
            jf.persist()?;
            return Err(EngineError::inconsistent(target, journal_name, detail));
        }
        let t = at(&*client);
        jf.journal.transition(
            TxnState::RolledBack,
            t,
            Some(
                std::iter::once("recover: old values restored and read back".to_string())
                    .chain(report.notes.iter().cloned())
                    .collect::<Vec<_>>()
                    .join("; "),
            ),
        );
        jf.persist()?;
        report.action = RecoverAction::RolledBack;
    }
    // fingerprint of what the drive holds over the set's codes
    let keys: Vec<CodeKey> = backup
        .keys()
        .chain(unchanged.iter().map(|(k, _)| k))
        .copied()
        .collect();
    let mut holds = ResolvedSet::new(&schema);
    for (k, v) in read_observed(client, keys, hook, Step::Verify)?.values {
        holds.insert(k, v);
    }
    report.fingerprint = Some(holds.fingerprint());
    hook.end(client.clock());
    Ok(report)
}

/// Read `want`'s codes (phase verify); when any does not hold its value,
/// the journal fails with `detail(codes, "holds" | "hold")` and so does
/// the call ([`EngineError::inconsistent`]).
fn held_or_failed(
    client: &mut dyn DriveClient,
    jf: &mut JournalFile,
    want: &[(CodeKey, RawValue)],
    hook: &Hook,
    detail: impl FnOnce(String, &str) -> String,
) -> Result<(), EngineError> {
    let now = read_observed(client, want.iter().map(|(k, _)| *k), hook, Step::Verify)?;
    let schema = client.schema().clone();
    let differ: Vec<String> = want
        .iter()
        .filter(|(k, v)| now.values.get(k) != Some(v))
        .map(|(k, _)| code_label(&schema, *k))
        .collect();
    if differ.is_empty() {
        return Ok(());
    }
    let verb = if differ.len() == 1 { "holds" } else { "hold" };
    let detail = detail(differ.join(", "), verb);
    jf.journal.failure = Some(detail.clone());
    let at = client.clock().now().as_nanos();
    jf.journal
        .transition(TxnState::Failed, at, Some(detail.clone()));
    jf.persist()?;
    Err(EngineError::inconsistent(
        client.target().clone(),
        jf.path().display().to_string(),
        detail,
    ))
}
