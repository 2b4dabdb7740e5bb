//! The commands at a transfer rate: [`upload`] (the upload between
//! [`super::begin`] and [`super::end`], then a check at the old rate that
//! the drive did not restart in between, with a full read-back when it
//! did), [`pull`] and [`live_diff`] (reads only), and the exchanges each
//! cannot avoid, for [`super::decide`].

use std::path::Path;

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use super::TransferRequest;
use super::session::{Session, begin, end};
use super::switch::{Back, with_rate_note};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::{JournalFile, TxnState};
use crate::plan::code_label;
use crate::pull::{PullOptions, Pulled};
use crate::rate_report::TransferReport;
use crate::upload::{UploadFailure, UploadOptions, UploadReport};

/// The exchanges an upload of `set` cannot avoid: the read-back of every
/// code (the writes are not known before it, and only add to the saving).
pub fn upload_exchanges(set: &ResolvedSet) -> Vec<CodeKey> {
    set.values.keys().copied().collect()
}

/// `upload` with a transfer rate (module docs): the upload runs between
/// [`begin`] and `end`; the report says whether the rate was switched.
pub fn upload(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    opts: &UploadOptions,
    req: &TransferRequest,
) -> Result<UploadReport, UploadFailure> {
    let session = begin(
        client,
        req,
        &opts.journal,
        set.fingerprint(),
        &upload_exchanges(set),
        &[],
    )?;
    let mut o = opts.clone();
    o.transfer = session.record().cloned();
    let result = crate::upload::upload(client, set, &o);
    let ok = result.is_ok();
    let restarts = client.stats().restarts;
    let back = end(client, session, &opts.journal, ok).map_err(|b| *b);
    match (result, back) {
        (Ok(mut report), Ok(t)) => {
            let verified = final_verify(client, set, &report, &opts.journal, restarts);
            report.transfer = Some(t);
            match verified {
                Ok(()) => Ok(report),
                Err(e) => {
                    report.state = TxnState::Failed;
                    Err(UploadFailure {
                        error: Box::new(e),
                        report: Some(Box::new(report)),
                    })
                }
            }
        }
        (Ok(mut report), Err((t, why))) => {
            report.transfer = Some(t);
            Err(UploadFailure {
                error: Box::new(EngineError::no_answer(
                    client.target().clone(),
                    format!(
                        "switching back from the transfer rate (the drive holds the set, verified; {why}; journal {}: run `driveset recover {}`)",
                        opts.journal.display(),
                        opts.journal.display()
                    ),
                    1,
                )),
                report: Some(Box::new(report)),
            })
        }
        (Err(mut f), back) => {
            let (t, note): (TransferReport, Back) = match back {
                Ok(t) => {
                    let s = t.state.clone();
                    (t, Ok(s))
                }
                Err((t, why)) => (t, Err(why)),
            };
            if t.switched {
                f.error = Box::new(with_rate_note(*f.error, &note));
            }
            if let Some(r) = &mut f.report {
                r.transfer = Some(t);
            }
            Err(f)
        }
    }
}

/// The last step of a switched upload. The switch back came after the
/// upload's own verify, and a restart in between loses RAM values and
/// activates whatever the rate code held; the drive's power-on bit says
/// whether it restarted (`lustbus-protocol.txt` §6: SIOF/SERR has it set
/// after every start until a read clears it, and the session's first
/// read cleared it before the switch over). So: when the client saw no
/// power-on bit since the upload returned (`restarts`: its
/// [`ClientStats::restarts`](crate::client::ClientStats::restarts) then; the switch back reads SIOF/SERR
/// after a NAKed SELECT and may recover from the restart it finds), one
/// read of SIOF/SERR at the rate the drive runs at now; when that shows no
/// restart either, the upload's verify stands and the upload is complete.
/// Otherwise (or when the read fails, or the schema has no SIOF/SERR to
/// ask), every code of the set the upload verified or found unchanged is
/// read back again ([`read_back_all`]).
///
/// Before, every code was read back at the old rate whatever happened:
/// 215 reads at 9600 baud made an MC6000 upload at 57600 baud 0.72x the
/// same upload at 9600 and an unchanged re-run 1.23x (slower than not
/// switching at all; issue 33, the upload bench's transfer-rate rows).
fn final_verify(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    report: &UploadReport,
    journal: &Path,
    restarts: u64,
) -> Result<(), EngineError> {
    if client.stats().restarts == restarts && not_restarted(client) {
        return Ok(());
    }
    read_back_all(client, set, report, journal)
}

/// Whether the drive answers its SIOF/SERR without a power-on bit, so it
/// has not restarted since the session's first read of it (a power-on bit
/// now is [`crate::error::DeviceFailure::Restarted`] from the LUSTBUS client,
/// which clears it). `false` for a restart, for any other failure of the
/// read (the read-back then says what fails and journals it), and when the
/// schema has no SIOF/SERR code (nothing tells).
fn not_restarted(client: &mut dyn DriveClient) -> bool {
    let siof = CodeKey::new(crate::client::lustbus::SIOF);
    client.schema().code(siof.number).is_some() && client.read(siof).is_ok()
}

/// After a restart ([`final_verify`]): read every code of the set the
/// upload verified or found unchanged back again, at the rate the drive
/// runs at now. A code that reads otherwise (or not at all) fails the
/// upload: the journal goes to `failed` with what each planned code holds,
/// for `driveset recover`.
fn read_back_all(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    report: &UploadReport,
    journal: &Path,
) -> Result<(), EngineError> {
    use crate::upload::CodeOutcome;
    let schema = client.schema().clone();
    let rate = client.line_rate();
    let mut differ: Vec<String> = Vec::new();
    let mut failure: Option<EngineError> = None;
    for c in &report.codes {
        if !matches!(c.outcome, CodeOutcome::Verified | CodeOutcome::Unchanged) {
            continue;
        }
        let key = CodeKey {
            number: c.number,
            subcode: c.subcode,
        };
        let Some(want) = set.values.get(&key) else {
            continue;
        };
        match client.read(key) {
            Ok(got) if &got == want => {}
            Ok(got) => differ.push(format!(
                "{} reads {} instead of {}",
                code_label(&schema, key),
                crate::plan::value_text(&schema, key, &got),
                crate::plan::value_text(&schema, key, want)
            )),
            Err(e) => {
                failure = Some(e);
                break;
            }
        }
    }
    if differ.is_empty() && failure.is_none() {
        return Ok(());
    }
    let at = rate.map_or_else(String::new, |r| format!(" at {r} baud"));
    let what = match &failure {
        Some(e) => format!("the final read-back{at} after the switch back failed: {e}"),
        None => format!(
            "after the switch back, the final read-back{at} finds {} (did the drive restart?)",
            differ.join(", ")
        ),
    };
    let mut detail = what.clone();
    if let Ok(mut jf) = JournalFile::open(journal) {
        let backup: std::collections::BTreeMap<CodeKey, RawValue> = jf
            .journal
            .backup_values()
            .unwrap_or_default()
            .into_iter()
            .collect();
        let new_values: std::collections::BTreeMap<CodeKey, RawValue> = jf
            .journal
            .new_values()
            .unwrap_or_default()
            .into_iter()
            .collect();
        if failure.is_none() {
            let holding = crate::upload::holdings(client, &schema, &backup, &new_values);
            detail = format!("{what}; {}", crate::upload::describe_holdings(&holding));
            jf.journal.holding = holding;
        }
        jf.journal.failure = Some(detail.clone());
        jf.journal.transition(
            TxnState::Failed,
            client.clock().now().as_nanos(),
            Some(detail.clone()),
        );
        jf.persist()?;
    }
    Err(EngineError::inconsistent(
        client.target().clone(),
        journal.display().to_string(),
        detail,
    ))
}

/// The codes [`crate::pull::pull`] reads (for [`super::decide`]): every code
/// and subcode of the schema but those pull leaves out on purpose (see
/// its module docs).
pub fn pull_exchanges(schema: &Schema, opts: &PullOptions) -> Vec<CodeKey> {
    let mut out = Vec::new();
    for code in &schema.codes {
        if crate::pull::left_out_reason(schema, code, opts).is_some() {
            continue;
        }
        match code.subcodes {
            Some(n) if n > 0 => out.extend((1..=n).map(|s| CodeKey::sub(code.number, s))),
            _ => out.push(CodeKey::new(code.number)),
        }
    }
    out
}

/// `pull` with a transfer rate: the journal at `journal` records the
/// switch (nothing else is written).
pub fn pull(
    client: &mut dyn DriveClient,
    opts: &PullOptions,
    req: &TransferRequest,
    journal: &Path,
    hook: &crate::observe::Hook,
) -> Result<(Pulled, TransferReport), EngineError> {
    let reads = pull_exchanges(client.schema(), opts);
    let session = begin(client, req, journal, String::new(), &reads, &[])?;
    read_only(client, session, journal, "the pull itself completed", |c| {
        crate::pull::pull_observed(c, opts, hook)
    })
}

/// A live diff ([`crate::live::live_diff`]) with a transfer rate; the
/// journal at `journal` records the switch.
pub fn live_diff(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    req: &TransferRequest,
    journal: &Path,
) -> Result<(driveset_schema::Diff, TransferReport), EngineError> {
    let keys = upload_exchanges(set);
    let session = begin(client, req, journal, set.fingerprint(), &keys, &[])?;
    read_only(client, session, journal, "the values were read", |c| {
        crate::live::live_diff(c, set)
    })
}

/// Run the reads of a command that writes nothing but the rate inside
/// `session`, then switch back; `done` says what completed when only the
/// switch back failed.
fn read_only<T>(
    client: &mut dyn DriveClient,
    session: Session,
    journal: &Path,
    done: &str,
    work: impl FnOnce(&mut dyn DriveClient) -> Result<T, EngineError>,
) -> Result<(T, TransferReport), EngineError> {
    let result = work(&mut *client);
    let back = end(client, session, journal, result.is_ok()).map_err(|b| *b);
    match (result, back) {
        (Ok(v), Ok(t)) => Ok((v, t)),
        (Ok(_), Err((_, why))) => Err(EngineError::no_answer(
            client.target().clone(),
            format!(
                "switching back from the transfer rate ({done}; {why}; journal {}: run `driveset recover {}`)",
                journal.display(),
                journal.display()
            ),
            1,
        )),
        (Err(e), Ok(t)) => Err(with_rate_note(e, &Ok(t.state))),
        (Err(e), Err((_, why))) => Err(with_rate_note(e, &Err(why))),
    }
}
