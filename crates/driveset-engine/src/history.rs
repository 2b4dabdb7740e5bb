//! What a run puts on the plant's record (docs/history.md): one
//! [`DriveRecord`] per drive a command wrote or read — the slot (line,
//! drive name, bus, address) apart from the unit in it (family, TYPE,
//! software, every identity code), per code the old value, the new one,
//! the verified read-back and the outcome, the fingerprints before and
//! after, the final state and the typed failure cause — and the seam it
//! goes through, [`History`], which the front end's
//! [`Environment::history`](crate::env::Environment::history) hands out.
//! The engine keeps no store: the CLI's (`driveset-history`: SQLite,
//! PostgreSQL) opens the session around the run and implements the seam.
//!
//! Values are the display texts the reports use, so a password is
//! `<secret>` / `<redacted>` here already: its value never reaches the
//! seam in any form (the fingerprints do not cover a secret's value).

use std::path::Path;

use driveset_schema::{ResolvedSet, Schema};
use serde::{Deserialize, Serialize};

use crate::client::{IdentProtocol, Identity};
use crate::error::EngineError;
use crate::journal::FailureCause;
use crate::line::report::{DriveReport, DriveResult};
use crate::plan::value_text;
use crate::recover::RecoverReport;
use crate::upload::{CodeOutcome, CodeReport, UploadFailure, UploadReport};

/// Where a drive sits: what stays when its unit is exchanged.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Slot {
    /// The line's name (a line command), else none.
    pub line: Option<String>,
    /// The drive's name in the manifest (a line command), else none.
    pub drive: Option<String>,
    /// The bus: the manifest's bus name, else the port as given.
    pub bus: String,
    /// The drive's bus address.
    pub address: u8,
}

/// The unit in a slot: what it said it is.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Unit {
    /// The family's protocol name (`lustbus-mc`, `lecom` ...; empty when
    /// it was not identified).
    pub family: String,
    /// Its device type (the family's TYPE code's value, else the first
    /// identity code's), when read.
    pub device_type: Option<String>,
    /// Its software version, when the family has one.
    pub software: Option<String>,
    /// Every identity code read, as `(code, value)`, in the order read.
    pub identity: Vec<(String, String)>,
}

impl Unit {
    /// The unit `identity` describes; its TYPE is the value of the family's
    /// type code ([`driveset_schema::Descriptor::device_type_code`]).
    pub fn of(schema: &Schema, identity: &Identity) -> Self {
        let type_code = schema.family.descriptor().device_type_code();
        Unit {
            family: identity.protocol.name().to_string(),
            device_type: identity
                .codes
                .iter()
                .find(|c| c.key.number == type_code)
                .or(identity.codes.first())
                .map(|c| c.value.to_string()),
            software: identity.software.clone(),
            identity: identity.pairs(),
        }
    }
}

/// One code of a drive's record.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CodeRecord {
    /// The code as the schema spells it (`C0011`, `428-RSIO`).
    pub code: String,
    /// What the drive held before (display text; `<secret>` for a
    /// password), when read.
    pub old: Option<String>,
    /// What the set asked for, when it asked.
    pub new: Option<String>,
    /// What was read back and found equal to `new` after writing (or, for a
    /// code the drive already held, what it held), when verified.
    pub verified: Option<String>,
    /// What happened to it: `unchanged`, `verified`, `restored`,
    /// `not-written`, `written`, `failed`; `read` (a read-only command),
    /// `drift` (a read that differs from the set).
    pub outcome: String,
    /// The phase it was written in (its storage: `eeprom`, `ram`,
    /// `dataset`, ...), when written.
    pub phase: Option<String>,
}

/// One drive's part in a session.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveRecord {
    /// Where it sits.
    pub slot: Slot,
    /// What was in the slot.
    pub unit: Unit,
    /// The schema spoken.
    pub schema: String,
    /// The set's fingerprint, when a set was given.
    pub set_fingerprint: Option<String>,
    /// Fingerprint of what it held before.
    pub fingerprint_before: Option<String>,
    /// Fingerprint of what it holds after, when known.
    pub fingerprint_after: Option<String>,
    /// The result: the journal's final state for an upload (`complete`,
    /// `rolled-back`, `failed`), the line's result for a line drive
    /// (`verified`, `unchanged`, `drift` ...).
    pub result: String,
    /// The typed failure cause as JSON (the journal's `failure_cause`).
    pub cause: Option<String>,
    /// The error as the command printed it.
    pub error: Option<String>,
    /// The journal file, when one was written.
    pub journal: Option<String>,
    /// Every code of the set (or read).
    pub codes: Vec<CodeRecord>,
}

/// Where records go (module docs). Implemented by the front end's store;
/// an error is the store's text (the run goes on and warns; a run that
/// must be recorded is refused before its first write by the front end).
pub trait History: Send + Sync {
    /// Append `record` to the run's open session.
    fn drive(&self, record: &DriveRecord) -> Result<(), String>;
}

/// The typed cause of `e` as the journal stores it, as JSON.
pub fn cause_json(e: &EngineError) -> String {
    serde_json::to_string(&FailureCause::of(e)).unwrap_or_default()
}

fn outcome_word(o: &CodeOutcome) -> &'static str {
    match o {
        CodeOutcome::Unchanged => "unchanged",
        CodeOutcome::NotWritten => "not-written",
        CodeOutcome::Written => "written",
        CodeOutcome::Verified => "verified",
        CodeOutcome::Failed(_) => "failed",
        CodeOutcome::Restored => "restored",
    }
}

/// The code records of an upload's codes (of `schema`).
pub fn upload_codes(schema: &Schema, codes: &[CodeReport]) -> Vec<CodeRecord> {
    codes
        .iter()
        .map(|c| {
            let verified = match c.outcome {
                CodeOutcome::Verified | CodeOutcome::Unchanged => Some(c.new.clone()),
                CodeOutcome::Restored => Some(c.old.clone()),
                _ => None,
            };
            CodeRecord {
                code: schema.display_code(c.number, c.subcode),
                old: Some(c.old.clone()),
                new: Some(c.new.clone()),
                verified,
                outcome: outcome_word(&c.outcome).to_string(),
                phase: c.storage.map(|s| {
                    serde_json::to_value(s)
                        .ok()
                        .and_then(|v| v.as_str().map(str::to_string))
                        .unwrap_or_else(|| format!("{s:?}").to_lowercase())
                }),
            }
        })
        .collect()
}

impl DriveRecord {
    /// The record of a one-drive upload (`driveset upload`): its report,
    /// and the error when it did not complete.
    pub fn of_upload(
        slot: Slot,
        schema: &Schema,
        rep: &UploadReport,
        error: Option<&EngineError>,
    ) -> Self {
        DriveRecord {
            slot,
            unit: Unit::of(schema, &rep.identity),
            schema: rep.schema.clone(),
            set_fingerprint: Some(rep.set_fingerprint.clone()),
            fingerprint_before: Some(rep.fingerprint_before.clone()),
            fingerprint_after: rep.fingerprint_after.clone(),
            result: rep.state.as_str().to_string(),
            cause: error.map(cause_json),
            error: error.map(|e| e.to_string()),
            journal: rep.journal.clone(),
            codes: upload_codes(schema, &rep.codes),
        }
    }

    /// The record of a drive that failed before it had a report.
    pub fn of_error(slot: Slot, schema: &Schema, error: &EngineError) -> Self {
        DriveRecord {
            slot,
            unit: Unit {
                family: IdentProtocol::Family(schema.family).name().to_string(),
                ..Unit::default()
            },
            schema: schema.id.clone(),
            set_fingerprint: None,
            fingerprint_before: None,
            fingerprint_after: None,
            result: "failed".into(),
            cause: Some(cause_json(error)),
            error: Some(error.to_string()),
            journal: None,
            codes: Vec::new(),
        }
    }

    /// The record of a line's drive: its report and the codes its work
    /// went through.
    pub fn of_line(line: &str, r: &DriveReport, unit: Unit, codes: Vec<CodeRecord>) -> Self {
        DriveRecord {
            slot: Slot {
                line: Some(line.to_string()),
                drive: Some(r.name.clone()),
                bus: r.bus.clone(),
                address: r.address,
            },
            unit,
            schema: r.schema.clone(),
            set_fingerprint: Some(r.set_fingerprint.clone()),
            fingerprint_before: r.fingerprint_before.clone(),
            fingerprint_after: r.fingerprint_after.clone(),
            result: line_result(r.result).to_string(),
            cause: None,
            error: r.error.clone(),
            journal: None,
            codes,
        }
    }
}

/// The code records a line drive's report shows (its diff: what was
/// written or differs), for a run whose codes the report alone keeps
/// (`replace`).
pub fn diff_codes(r: &DriveReport) -> Vec<CodeRecord> {
    let verified = r.result == DriveResult::Verified;
    r.diff
        .iter()
        .map(|l| CodeRecord {
            code: l.code.clone(),
            old: l.old.clone(),
            new: l.new.clone(),
            verified: l.new.clone().filter(|_| verified),
            outcome: if verified { "verified" } else { "not-written" }.into(),
            phase: None,
        })
        .collect()
}

impl DriveRecord {
    /// The record of `driveset address` (a lone drive given its address
    /// and rate): the slot it was given, the codes written, each verified
    /// or not.
    pub fn of_assign(report: &crate::assign::AssignReport) -> Self {
        let p = &report.plan;
        DriveRecord {
            slot: Slot {
                line: None,
                drive: None,
                bus: p.bus.clone(),
                address: p.to,
            },
            unit: Unit {
                family: IdentProtocol::Family(p.family).name().to_string(),
                device_type: p.type_value.map(|t| t.to_string()),
                software: p.identity.software.clone(),
                identity: p.identity.pairs(),
            },
            schema: p.schema_id.clone(),
            set_fingerprint: None,
            fingerprint_before: None,
            fingerprint_after: None,
            result: "complete".into(),
            cause: None,
            error: None,
            journal: Some(report.journal.clone()),
            codes: report
                .written
                .iter()
                .map(|w| CodeRecord {
                    code: w.clone(),
                    old: None,
                    new: None,
                    verified: None,
                    outcome: if report.verified.contains(w) {
                        "verified"
                    } else {
                        "written"
                    }
                    .into(),
                    phase: None,
                })
                .collect(),
        }
    }
}

/// A line drive's result as the report writes it.
pub fn line_result(r: DriveResult) -> &'static str {
    match r {
        DriveResult::Verified => "verified",
        DriveResult::Unchanged => "unchanged",
        DriveResult::AlreadyVerified => "already-verified",
        DriveResult::NotSelected => "not-selected",
        DriveResult::Drift => "drift",
        DriveResult::RolledBack => "rolled-back",
        DriveResult::Failed => "failed",
    }
}

/// The code records of a read-only look at a drive against a set
/// (`status`, the live `diff`, `twin capture-line`): each code of `set`,
/// what the drive holds (`read`) or that it differs (`drift`); a secret's
/// value is never put in a record (its display text is `<secret>`).
pub fn read_codes(schema: &Schema, live: &ResolvedSet, set: &ResolvedSet) -> Vec<CodeRecord> {
    set.values
        .iter()
        .map(|(k, want)| {
            let have = live.values.get(k);
            let text = |v| value_text(schema, *k, v);
            CodeRecord {
                code: schema.display_code(k.number, k.subcode),
                old: have.map(text),
                new: Some(text(want)),
                verified: have.filter(|h| *h == want).map(text),
                outcome: if have == Some(want) { "read" } else { "drift" }.into(),
                phase: None,
            }
        })
        .collect()
}

/// The code records of a read without a set (`pull`, `twin capture`):
/// every value read, as `old` (what the drive holds), outcome `read`.
pub fn values_read(schema: &Schema, values: &ResolvedSet) -> Vec<CodeRecord> {
    values
        .values
        .iter()
        .map(|(k, v)| CodeRecord {
            code: schema.display_code(k.number, k.subcode),
            old: Some(value_text(schema, *k, v)),
            new: None,
            verified: None,
            outcome: "read".into(),
            phase: None,
        })
        .collect()
}

impl DriveRecord {
    /// The record of a command that read a drive and wrote nothing to it
    /// (`pull`, the live `diff`, `twin capture`, `twin capture-line`):
    /// the fingerprint of what it read is both before and after (a read
    /// leaves the drive as it was); `result` is `read` without a set,
    /// `unchanged` / `drift` against one.
    pub fn of_read(
        slot: Slot,
        unit: Unit,
        schema: &str,
        fingerprint: String,
        result: &str,
        codes: Vec<CodeRecord>,
    ) -> Self {
        DriveRecord {
            slot,
            unit,
            schema: schema.to_string(),
            set_fingerprint: None,
            fingerprint_before: Some(fingerprint.clone()),
            fingerprint_after: Some(fingerprint),
            result: result.to_string(),
            cause: None,
            error: None,
            journal: None,
            codes,
        }
    }
}

impl DriveRecord {
    /// The record of `driveset pull` (an [`DriveRecord::of_read`]): every
    /// value read, actual values included ([`crate::pull::ForFile::read`]),
    /// the fingerprint the set file carries.
    pub fn of_pull(slot: Slot, schema: &Schema, file: &crate::pull::ForFile) -> Self {
        DriveRecord::of_read(
            slot,
            Unit::of(schema, &file.pulled.identity),
            &schema.id,
            file.pulled.fingerprint.clone(),
            "read",
            file.read.clone(),
        )
    }

    /// The record of `driveset diff SET --port` (an
    /// [`DriveRecord::of_read`]): each code of `set`, what the drive
    /// `identity` holds for it (the set with the diff's old side, the
    /// drive's, in place of each value that differs), the fingerprint of
    /// that, `unchanged` or `drift`, and the set's fingerprint.
    pub fn of_live_diff(
        slot: Slot,
        schema: &Schema,
        identity: &Identity,
        set: &ResolvedSet,
        diff: &driveset_schema::Diff,
    ) -> Self {
        let mut live = set.clone();
        for e in &diff.entries {
            match &e.old {
                Some(v) => live.values.insert(e.key, v.clone()),
                None => live.values.remove(&e.key),
            };
        }
        let mut record = DriveRecord::of_read(
            slot,
            Unit::of(schema, identity),
            &schema.id,
            live.fingerprint(),
            if diff.is_empty() {
                "unchanged"
            } else {
                "drift"
            },
            read_codes(schema, &live, set),
        );
        record.set_fingerprint = Some(set.fingerprint());
        record
    }
}

impl DriveRecord {
    /// The record of `driveset upload` from its outcome: the report and,
    /// when it did not complete, the error; a failure before the upload
    /// had a report as [`DriveRecord::of_error`].
    pub fn of_upload_outcome(
        slot: Slot,
        schema: &Schema,
        outcome: &Result<UploadReport, UploadFailure>,
    ) -> Self {
        match outcome {
            Ok(r) => DriveRecord::of_upload(slot, schema, r, None),
            Err(f) => match &f.report {
                Some(r) => DriveRecord::of_upload(slot, schema, r, Some(&f.error)),
                None => DriveRecord::of_error(slot, schema, &f.error),
            },
        }
    }

    /// The record of `driveset replace`'s drive `d` of line `line`: the
    /// slot's new unit (of `family`, its first identify code its device
    /// type) with what was written to it ([`diff_codes`]).
    pub fn of_replacement(line: &str, d: &DriveReport, family: &str) -> Self {
        let unit = Unit {
            family: family.to_string(),
            device_type: d.identity.first().map(|(_, v)| v.clone()),
            identity: d.identity.clone(),
            ..Unit::default()
        };
        DriveRecord::of_line(line, d, unit, diff_codes(d))
    }

    /// The record of `driveset recover JOURNAL` on the drive at `slot`
    /// with `schema`: what recovery did (`nothing-to-do`, `completed`,
    /// `rolled-back`; the fingerprint the drive holds, the codes it
    /// restored), or its failure as [`DriveRecord::of_error`].
    pub fn of_recover(
        slot: Slot,
        schema: &Schema,
        result: &Result<RecoverReport, EngineError>,
    ) -> Self {
        match result {
            Ok(r) => DriveRecord {
                slot,
                unit: Unit {
                    family: IdentProtocol::Family(schema.family).name().to_string(),
                    ..Unit::default()
                },
                schema: schema.id.clone(),
                set_fingerprint: None,
                fingerprint_before: None,
                fingerprint_after: r.fingerprint.clone(),
                result: r.action.as_str().into(),
                cause: None,
                error: None,
                journal: Some(r.journal.clone()),
                codes: r.restored_values.clone(),
            },
            Err(e) => DriveRecord::of_error(slot, schema, e),
        }
    }
}

/// What `driveset recover JOURNAL` closes the sessions of this station
/// that processes killed mid-way left open with (docs/history.md): what
/// it found and did, or that it failed.
pub fn recover_note(journal: &Path, result: &Result<RecoverReport, EngineError>) -> String {
    match result {
        Ok(r) => format!(
            "`driveset recover {}` found the journal {} and {} it",
            journal.display(),
            r.found.as_str(),
            r.action.as_str()
        ),
        Err(e) => format!("`driveset recover {}` failed: {e}", journal.display()),
    }
}
