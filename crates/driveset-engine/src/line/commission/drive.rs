//! Owns one drive's turn on a bus drive by drive (module docs of
//! [`super`]), whatever the run's walk: its schema learned first where its
//! set asks, its session connected, its unfinished journals looked up, then
//! the walk's work ([`super::walk::Walk::work`]); its report, its telegram
//! count and time, its history record, and how a failure ends it (the
//! link gone, or the drive silent).

use std::cell::RefCell;

use driveset_link::Link;
use driveset_schema::{ResolvedSet, Schema};

use super::learning::learn_drive;
use super::run::Ctx;
use super::timeline::{Span, drive_watch, link_clock, link_now, since};
use crate::client::{DriveClient, IdentProtocol, Identity};
use crate::error::{EngineError, ErrorKind, LinkFailure, TransactionOutcome};
use crate::history::{CodeRecord, DriveRecord, Unit};
use crate::line::manifest::{Bus, Drive};
use crate::line::report::{DiffLine, DiffLineKind, DriveReport, DriveResult};
use crate::observe::{Hook, Phase};
use crate::plan::value_text;
use crate::session::BusSession;
use crate::upload::{CodeOutcome, CodeReport, UploadReport};

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
        ErrorKind::Link(LinkFailure::Transport(_)) => Some(Failure::Link),
        ErrorKind::Link(LinkFailure::NoAnswer { .. }) => Some(Failure::NoAnswer),
        ErrorKind::Transaction(TransactionOutcome::RolledBack { cause, .. }) => failure_of(cause),
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
pub(in crate::line) struct Recorded {
    pub(in crate::line) unit: Option<Unit>,
    pub(in crate::line) codes: Vec<CodeRecord>,
    cause: Option<String>,
}

/// One drive on a bus drive by drive: learning, connecting, then the
/// walk's work (module docs of [`super`]). Gives its report, its spans for
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
            ctx.walk.drive_ended(ctx, bus, d, &r);
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
        ctx.walk.drive_ended(ctx, bus, d, &r);
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
    ctx.walk.drive_ended(ctx, bus, d, &r);
    (r, spans, failure)
}

/// One drive's work once its client is connected.
pub(in crate::line) struct Job<'a> {
    pub(in crate::line) bus: &'a Bus,
    pub(in crate::line) d: &'a Drive,
    pub(in crate::line) ctx: &'a Ctx<'a>,
    /// The drive's observer.
    pub(in crate::line) hook: &'a Hook,
    /// What the drive's history record gets.
    pub(in crate::line) rec: &'a RefCell<Recorded>,
}

impl Job<'_> {
    /// The drive's unfinished journals looked up, then the walk's work;
    /// `recovered` gets a note per journal recovered (warned also when a
    /// later step fails).
    fn work(
        &self,
        client: &mut dyn DriveClient,
        r: &mut DriveReport,
        recovered: &mut Vec<String>,
    ) -> Result<(), EngineError> {
        let unfinished = crate::journal::unfinished_for(
            &self.ctx.opts.journal_dir,
            &client.bus_id(),
            &client.target().port,
            self.d.address,
        )?;
        self.ctx.walk.work(self, client, r, &unfinished, recovered)
    }
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
