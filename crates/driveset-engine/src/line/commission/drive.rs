//! Owns one drive's work on a bus drive by drive (module docs of
//! [`super`]): its schema learned first where its set asks, its unfinished
//! journals recovered, then `status` (identify, read, compare) or
//! `commission` (the resume check, then one upload of what differs, over
//! the online baud-rate switch where the bus asks for one); its report,
//! and how a failure ends it (the link gone, or the drive silent).

use std::cell::RefCell;

use driveset_link::Link;
use driveset_schema::{ResolvedSet, Schema};

use super::learning::learn_drive;
use super::options::Mode;
use super::recovery::recover_unfinished;
use super::resume::{record_drive, still_holds};
use super::run::Ctx;
use super::timeline::{Span, drive_watch, link_clock, link_now, since};
use crate::client::{DriveClient, IdentProtocol, Identity};
use crate::error::{EngineError, ErrorKind};
use crate::history::{CodeRecord, DriveRecord, Unit, read_codes};
use crate::identify::check_family;
use crate::line::manifest::{Bus, Drive};
use crate::line::report::{DiffLine, DiffLineKind, DriveReport, DriveResult};
use crate::live::live_values;
use crate::observe::{Hook, Phase};
use crate::overrides::Override;
use crate::plan::value_text;
use crate::session::BusSession;
use crate::transfer::TransferRequest;
use crate::upload::{
    CodeOutcome, CodeReport, UploadOptions, UploadReport, default_journal_path, upload,
};

/// How a drive's failure bears on the rest of its bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Failure {
    /// The link is gone: stop the bus.
    Link,
    /// This drive did not answer: go on with the next.
    NoAnswer,
}

/// The kind of failure `e` is, if it bears on the bus.
pub(super) fn failure_of(e: &EngineError) -> Option<Failure> {
    match &*e.kind {
        ErrorKind::Link(_) => Some(Failure::Link),
        ErrorKind::NoAnswer { .. } => Some(Failure::NoAnswer),
        ErrorKind::RolledBack { cause, .. } => failure_of(cause),
        _ => None,
    }
}

/// The drive failed with `e` (unless it was rolled back): its result and
/// error, and what the failure means for its bus.
pub(super) fn mark_failed(r: &mut DriveReport, e: &EngineError) -> Option<Failure> {
    if r.result != DriveResult::RolledBack {
        r.result = DriveResult::Failed;
    }
    r.error = Some(e.to_string());
    failure_of(e)
}

/// The report of drive `d` before anything is known of it.
pub(in crate::line) fn blank_report(d: &Drive, bus: &Bus, result: DriveResult) -> DriveReport {
    DriveReport {
        name: d.name.clone(),
        position: d.position.clone(),
        bus: bus.name.clone(),
        address: d.address,
        set: d.set_text.clone(),
        schema: d.schema.id.clone(),
        identity: Vec::new(),
        set_fingerprint: d.set.fingerprint(),
        fingerprint_before: None,
        fingerprint_after: None,
        codes_written: 0,
        retries: 0,
        telegrams: 0,
        elapsed_ms: 0.0,
        result,
        error: None,
        diff: Vec::new(),
        learned_schema: None,
        factory_settings: false,
        replacement: None,
        stored: None,
        history: None,
    }
}

/// What a drive's work found for its history record ([`crate::history`]):
/// the unit, the codes, the typed cause.
#[derive(Default)]
struct Recorded {
    unit: Option<Unit>,
    codes: Vec<CodeRecord>,
    cause: Option<String>,
}

/// One drive on a bus drive by drive: learning, recovery, then `status` or
/// `commission` (module docs of [`super`]). Gives its report, its spans for
/// the timeline, and what kind of failure ended it; the drive goes on the
/// run's record ([`crate::env::Environment::history`]) whatever happened.
pub(super) fn run_drive(
    bus: &Bus,
    d: &Drive,
    link: &mut Link,
    ctx: &Ctx<'_>,
) -> (DriveReport, Vec<Span>, Option<Failure>) {
    let rec = RefCell::new(Recorded::default());
    let out = work_drive(bus, d, link, ctx, &rec);
    if let Some(h) = ctx.opts.env.history() {
        let rec = rec.into_inner();
        let unit = rec.unit.unwrap_or_else(|| Unit {
            family: IdentProtocol::Family(d.schema.family).name().to_string(),
            identity: out.0.identity.clone(),
            ..Unit::default()
        });
        let mut record = DriveRecord::of_line(ctx.line, &out.0, unit, rec.codes);
        record.cause = rec.cause;
        if let Err(e) = h.drive(&record) {
            ctx.warn(format!("{}: not recorded in the history: {e}", d.name));
        }
    }
    out
}

fn work_drive(
    bus: &Bus,
    d: &Drive,
    link: &mut Link,
    ctx: &Ctx<'_>,
    rec: &RefCell<Recorded>,
) -> (DriveReport, Vec<Span>, Option<Failure>) {
    let t0 = link_now(link);
    let (watch, hook) = drive_watch(bus, d, ctx);
    let learned_drive;
    let (d, session, learned_report) = match &d.learn_from {
        None => match BusSession::connect_using(
            link,
            &bus.port_name,
            d.schema.clone(),
            d.address,
            bus.connect(),
        ) {
            Ok(s) => (d, s, None),
            Err(e) => {
                let mut r = blank_report(d, bus, DriveResult::Failed);
                r.error = Some(e.to_string());
                return (r, watch.spans.spans(), None);
            }
        },
        Some(base) => 'learn: {
            hook.enter(link_clock(link), Phase::Learn, None);
            // the failed learning is dropped with its statement: the link
            // is free again below
            let (e, failure) = match learn_drive(bus, d, base, link, ctx) {
                Ok((nd, rep, s)) => {
                    learned_drive = nd;
                    break 'learn (&learned_drive, s, Some(rep));
                }
                Err(err) => err,
            };
            let mut r = blank_report(d, bus, DriveResult::Failed);
            r.error = Some(e);
            r.elapsed_ms = since(t0, link_now(link));
            forget(bus, d, ctx);
            hook.end(link_clock(link));
            return (r, watch.spans.spans(), failure);
        }
    };
    let mut r = blank_report(d, bus, DriveResult::Failed);
    r.learned_schema = learned_report;
    if r.learned_schema.is_some()
        && let Err(e) = crate::line::address_truth::check_drive(bus, d)
    {
        drop(session);
        r.error = Some(e.to_string());
        forget(bus, d, ctx);
        hook.end(link_clock(link));
        return (r, watch.spans.spans(), None);
    }
    let mut client = session.client;
    let stats0 = client.stats();
    let job = Job {
        bus,
        d,
        ctx,
        hook: &hook,
        rec,
    };
    let mut recovered: Vec<String> = Vec::new();
    let outcome = job.work(&mut *client, &mut r, &mut recovered);
    for w in recovered {
        ctx.warn(w);
    }
    if let Err(e) = &outcome {
        rec.borrow_mut().cause = Some(crate::history::cause_json(e));
    }
    let failure = outcome.err().and_then(|e| mark_failed(&mut r, &e));
    let _ = client.finish();
    let stats = client.stats();
    r.telegrams = stats.telegrams.saturating_sub(stats0.telegrams);
    r.retries = stats.retries.saturating_sub(stats0.retries);
    r.elapsed_ms = since(t0, client.clock().now());
    hook.end(client.clock());
    let spans = watch.spans.spans();
    if ctx.mode == Mode::Commission {
        record_drive(bus, d, &r, ctx);
    }
    (r, spans, failure)
}

/// A drive that did not get to its work holds nothing the resume state may
/// keep (`commission` only).
fn forget(bus: &Bus, d: &Drive, ctx: &Ctx<'_>) {
    if ctx.mode == Mode::Commission {
        ctx.record(bus, d, None);
    }
}

/// One drive's work once its client is connected.
struct Job<'a> {
    bus: &'a Bus,
    d: &'a Drive,
    ctx: &'a Ctx<'a>,
    hook: &'a Hook,
    rec: &'a RefCell<Recorded>,
}

impl Job<'_> {
    /// Recovery, then the mode's work; `recovered` gets a note per journal
    /// recovered (warned also when a later step fails).
    fn work(
        &self,
        client: &mut dyn DriveClient,
        r: &mut DriveReport,
        recovered: &mut Vec<String>,
    ) -> Result<(), EngineError> {
        recover_unfinished(client, self.d, self.ctx, self.hook, recovered)?;
        match self.ctx.mode {
            Mode::Status => self.status(client, r),
            Mode::Commission => {
                let set_fp = self.d.set.fingerprint();
                if recovered.is_empty()
                    && still_holds(client, self.bus, self.d, &set_fp, r, self.hook, self.ctx)?
                {
                    return Ok(());
                }
                self.upload(client, r, !recovered.is_empty())
            }
        }
    }

    /// `status`: identify, read the set's codes, compare.
    fn status(&self, client: &mut dyn DriveClient, r: &mut DriveReport) -> Result<(), EngineError> {
        let d = self.d;
        self.hook.enter(client.clock(), Phase::Identify, None);
        let id = check_family(&mut *client)?;
        r.identity = id.pairs();
        self.hook
            .enter(client.clock(), Phase::Read, Some(d.set.values.len()));
        self.rec.borrow_mut().unit = Some(Unit::of(&d.schema, &id));
        let live = live_values(&mut *client, &d.set)?;
        self.rec.borrow_mut().codes = read_codes(&d.schema, &live, &d.set);
        let fp = live.fingerprint();
        r.diff = diff_lines(&d.schema, &live, &d.set);
        r.factory_settings =
            crate::line::factory::live_at_factory_settings(&d.schema, &live, &d.set);
        // values, not fingerprints: a fingerprint does not cover a
        // secret's value, a drifted password is drift too
        r.result = if live.values == d.set.values {
            DriveResult::Unchanged
        } else {
            DriveResult::Drift
        };
        r.fingerprint_before = Some(fp.clone());
        r.fingerprint_after = Some(fp);
        Ok(())
    }

    /// `commission`: one upload of what differs ([`crate::upload::upload`],
    /// or [`crate::transfer::upload`] where the bus switches the drive to
    /// its transfer rate). `recovered`: a journal of the drive was recovered
    /// first, so the drive changed even if the upload writes nothing.
    fn upload(
        &self,
        client: &mut dyn DriveClient,
        r: &mut DriveReport,
        recovered: bool,
    ) -> Result<(), EngineError> {
        let (d, ctx) = (self.d, self.ctx);
        let journal_path = default_journal_path(&ctx.opts.journal_dir, &*client);
        let mut uo = UploadOptions::new(&journal_path);
        uo.overrides = ctx.opts.overrides;
        let transfer = transfer_request(self.bus, d, ctx);
        uo.observer = self.hook.clone();
        let result = match &transfer {
            Some(req) => crate::transfer::upload(&mut *client, &d.set, &uo, req),
            None => upload(&mut *client, &d.set, &uo),
        };
        if let Some(rep) = result.as_ref().map_or_else(|f| f.report.as_deref(), Some) {
            let mut rec = self.rec.borrow_mut();
            rec.unit = Some(Unit::of(&d.schema, &rep.identity));
            rec.codes = crate::history::upload_codes(&d.schema, &rep.codes);
        }
        if let Some(t) = result.as_ref().map_or_else(
            |f| f.report.as_ref().and_then(|r| r.transfer.clone()),
            |r| r.transfer.clone(),
        ) {
            ctx.warn(format!("{}: {}", d.name, t.decision.summary()));
        }
        match result {
            Ok(rep) => {
                take_upload(r, &d.schema, &rep);
                // a recovered journal changed the drive: never "unchanged"
                r.result = if rep.codes_written == 0 && !recovered {
                    DriveResult::Unchanged
                } else {
                    DriveResult::Verified
                };
                Ok(())
            }
            Err(f) => {
                if let Some(rep) = &f.report {
                    take_upload(r, &d.schema, rep);
                }
                let e = *f.error;
                if matches!(*e.kind, ErrorKind::RolledBack { .. }) {
                    r.result = DriveResult::RolledBack;
                }
                Err(e)
            }
        }
    }
}

/// The online baud-rate switch the drive's upload runs in: the bus's
/// `transfer_baud`, where the drive's family can switch online.
fn transfer_request(bus: &Bus, d: &Drive, ctx: &Ctx<'_>) -> Option<TransferRequest> {
    bus.transfer_baud
        .filter(|_| d.schema.family.descriptor().line_rates.online.is_some())
        .map(|rate| {
            let mut others = bus.families.clone();
            if let Some(i) = others.iter().position(|f| *f == d.schema.family) {
                others.remove(i);
            }
            TransferRequest {
                rate,
                others,
                allow_shared: ctx.opts.overrides.allows(Override::AllowSharedTransferBaud),
            }
        })
}

/// An upload's report (finished or not) into the drive's: identity, diff,
/// factory settings, fingerprints, codes written.
pub(super) fn take_upload(r: &mut DriveReport, schema: &Schema, rep: &UploadReport) {
    fill_from_upload(r, schema, &rep.identity, &rep.codes);
    r.fingerprint_before = Some(rep.fingerprint_before.clone());
    r.fingerprint_after = rep.fingerprint_after.clone();
    r.codes_written = rep.codes_written as u32;
    r.stored =
        (rep.state == crate::journal::TxnState::Complete).then(|| rep.stored.text().to_string());
}

/// The identity, factory settings and diff of an upload's codes.
pub(in crate::line) fn fill_from_upload(
    r: &mut DriveReport,
    schema: &Schema,
    identity: &Identity,
    codes: &[CodeReport],
) {
    r.identity = identity.pairs();
    r.factory_settings = crate::line::factory::upload_at_factory_settings(schema, codes);
    r.diff = codes
        .iter()
        .filter(|c| c.outcome != CodeOutcome::Unchanged)
        .map(|c| DiffLine {
            code: schema.display_code(c.number, c.subcode),
            name: schema
                .code(c.number)
                .map(|x| x.name.clone())
                .unwrap_or_default(),
            kind: DiffLineKind::Changed,
            old: Some(c.old.clone()),
            new: Some(c.new.clone()),
        })
        .collect();
}

/// The semantic diff drive -> set as report lines.
pub fn diff_lines(schema: &Schema, live: &ResolvedSet, set: &ResolvedSet) -> Vec<DiffLine> {
    let Ok(d) = driveset_schema::diff(live, set, schema) else {
        return Vec::new();
    };
    d.entries
        .iter()
        .map(|e| DiffLine {
            code: schema.display_code(e.key.number, e.key.subcode),
            name: schema
                .code(e.key.number)
                .map(|x| x.name.clone())
                .unwrap_or_default(),
            kind: e.kind.into(),
            old: e.old.as_ref().map(|v| value_text(schema, e.key, v)),
            new: e.new.as_ref().map(|v| value_text(schema, e.key, v)),
        })
        .collect()
}
