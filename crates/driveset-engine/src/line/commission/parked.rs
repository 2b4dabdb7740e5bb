//! Owns a drive's transaction on a LUSTBUS broadcast bus, which runs in
//! halves around the broadcast (module docs of [`super`], "Broadcast"):
//! the first half to "dataset open" (resume check, begin, replan, journal,
//! SLOAD = -1), then the drive parked while the others are served, its
//! own dataset writes and SLOAD = -2, and last the poll, the writes after
//! the dataset and the verification; and the drive's report at its end.

use std::time::Duration;

use driveset_link::{Instant, Link};
use driveset_schema::ResolvedSet;

use super::drive::{Failure, blank_report, failure_of, mark_failed, take_upload};
use super::resume::Resume;
use super::run::Ctx;
use super::timeline::{Span, drive_watch, link_now, ms};
use crate::client::{ClientStats, DriveClient};
use crate::error::EngineError;
use crate::line::manifest::{Bus, Drive};
use crate::line::report::{DriveReport, DriveResult};
use crate::observe::{Event, Observer};
use crate::upload::{
    CodeOutcome, Next, Replanned, StepError, Transaction, UploadFailure, UploadOptions,
    UploadReport, default_journal_path,
};

/// A drive of a broadcast bus between its two halves.
pub(super) struct Parked<'d> {
    pub(super) d: &'d Drive,
    pub(super) tx: Transaction,
    /// The transaction opened a dataset download.
    pub(super) dataset: bool,
    r: DriveReport,
    spans: Vec<Span>,
    /// What its own exchanges cost so far.
    cost: Cost,
}

/// What became of a drive in the first half.
pub(super) enum FirstHalf<'d> {
    /// Done (unchanged, already verified, refused, failed).
    Done(Box<DriveReport>, Vec<Span>, Option<Failure>),
    /// Its transaction waits (dataset open, or nothing to stage).
    Parked(Box<Parked<'d>>),
}

/// The end of a drive's transaction: the upload's outcome into its report,
/// its notes (a broadcast value written on its own ...) into the run's
/// warnings.
fn settle_drive(
    r: &mut DriveReport,
    d: &Drive,
    done: Result<UploadReport, UploadFailure>,
    ctx: &Ctx<'_>,
) -> Option<EngineError> {
    let notes = match &done {
        Ok(rep) => rep.warnings.clone(),
        Err(f) => f
            .report
            .as_ref()
            .map(|r| r.warnings.clone())
            .unwrap_or_default(),
    };
    for w in notes {
        ctx.warn(format!("{}: {w}", d.name));
    }
    match done {
        Ok(rep) => {
            take_upload(r, &d.schema, &rep);
            // values a broadcast brought count as changed, though no own
            // SELECT wrote them
            let changed = rep
                .codes
                .iter()
                .any(|c| c.outcome != CodeOutcome::Unchanged);
            r.result = if !changed {
                DriveResult::Unchanged
            } else {
                DriveResult::Verified
            };
            None
        }
        Err(f) => {
            if let Some(rep) = &f.report {
                take_upload(r, &d.schema, rep);
            }
            let e = *f.error;
            r.result = if e.is_rolled_back() {
                DriveResult::RolledBack
            } else {
                DriveResult::Failed
            };
            r.error = Some(e.to_string());
            Some(e)
        }
    }
}

/// Runs a step result to its end: on a stop, roll back or redo (the whole
/// attempt again, as [`crate::upload::upload`] does).
fn drive_to_end(
    tx: &mut Transaction,
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    mut res: Result<(), StepError>,
) -> Result<(), EngineError> {
    loop {
        match res {
            Ok(()) => return Ok(()),
            Err(stop) => match tx.stopped(client, stop) {
                Next::Redo => res = tx.run_attempt(client, set),
                Next::Failed(e) => return Err(e),
            },
        }
    }
}

/// First half of a drive on a broadcast bus: resume check, begin, replan,
/// journal, SLOAD = -1.
pub(super) fn first_half<'d>(
    bus: &Bus,
    d: &'d Drive,
    link: &mut Link,
    ctx: &Ctx<'_>,
    resume: &Resume,
) -> FirstHalf<'d> {
    let t0 = link_now(link);
    let mut r = blank_report(d, bus, DriveResult::Failed);
    let c = match crate::connect::lustbus_on(link, d.schema.clone(), d.address, &bus.connect()) {
        Ok(c) => c,
        Err(e) => {
            r.error = Some(e.to_string());
            return FirstHalf::Done(Box::new(r), Vec::new(), None);
        }
    };
    let journal_path = default_journal_path(&ctx.opts.journal_dir, &c);
    let (watch, hook) = drive_watch(bus, d, ctx);
    let mut client: Box<dyn DriveClient + '_> = Box::new(c);
    let stats0 = client.stats();
    let mut uo = UploadOptions::new(&journal_path);
    uo.overrides = ctx.opts.overrides;
    uo.observer = hook.clone();
    let opened = to_dataset(bus, d, ctx, resume, &mut *client, &mut r, &uo);
    let mut cost = Cost::default();
    cost.add(&mut *client, stats0, t0);
    if let Opened::Done { ended: false, .. } = opened {
        hook.end(client.clock());
    }
    // this half's spans, the open one closed now (the drive goes on later)
    watch.spans.event(client.clock().now(), Event::End);
    let spans = watch.spans.spans();
    let outcome = match opened {
        Opened::Waiting(mut tx, dataset) => {
            tx.detach(&*client);
            return FirstHalf::Parked(Box::new(Parked {
                d,
                tx: *tx,
                dataset,
                r,
                spans,
                cost,
            }));
        }
        Opened::Done { outcome, .. } => outcome,
    };
    let failure = outcome.err().and_then(|e| mark_failed(&mut r, &e));
    cost.into_report(&mut r);
    resume.record_drive(ctx, bus, d, &r);
    FirstHalf::Done(Box::new(r), spans, failure)
}

/// Where the first half's steps left a drive.
enum Opened {
    /// Its transaction waits, with a dataset download open (`true`) or
    /// nothing to stage (`false`).
    Waiting(Box<Transaction>, bool),
    /// The drive is done; `ended`: its transaction ran to its end (and
    /// closed its spans).
    Done {
        ended: bool,
        outcome: Result<(), EngineError>,
    },
}

/// The resume check, then the drive's transaction to "dataset open"; a
/// transaction with nothing to write, or stopped, is finished here.
fn to_dataset(
    bus: &Bus,
    d: &Drive,
    ctx: &Ctx<'_>,
    resume: &Resume,
    client: &mut dyn DriveClient,
    r: &mut DriveReport,
    uo: &UploadOptions,
) -> Opened {
    let not_begun = |outcome| Opened::Done {
        ended: false,
        outcome,
    };
    match resume.still_holds(&mut *client, bus, d, r, &uo.observer, ctx) {
        Ok(true) => return not_begun(Ok(())),
        Ok(false) => {}
        Err(e) => return not_begun(Err(e)),
    }
    let mut tx = match Transaction::begin(&mut *client, &d.set, uo) {
        Ok(tx) => tx,
        Err(e) => return not_begun(Err(e)),
    };
    let res = (|| {
        if tx.replan(&mut *client, &d.set)? == Replanned::Nothing {
            return Ok(None);
        }
        tx.journal(&mut *client)?;
        tx.open_dataset(&mut *client).map(Some)
    })();
    let end = match res {
        Ok(Some(dataset)) => return Opened::Waiting(Box::new(tx), dataset),
        Ok(None) => Ok(()),
        Err(stop) => drive_to_end(&mut tx, &mut *client, &d.set, Err(stop)),
    };
    let done = tx.finish(&mut *client, &d.set, end);
    Opened::Done {
        ended: true,
        outcome: settle_drive(r, d, done, ctx).map_or(Ok(()), Err),
    }
}

/// What a drive's own exchanges on a broadcast bus cost so far.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Cost {
    telegrams: u64,
    retries: u64,
    /// Bus time this drive's own exchanges took.
    own: Duration,
}

impl Cost {
    /// End the exchange with `client` begun at `t0` (its stats then
    /// `stats0`) and add what it cost.
    fn add(&mut self, client: &mut dyn DriveClient, stats0: ClientStats, t0: Instant) {
        let _ = client.finish();
        let stats = client.stats();
        self.telegrams += stats.telegrams.saturating_sub(stats0.telegrams);
        self.retries += stats.retries.saturating_sub(stats0.retries);
        self.own += client.clock().now().saturating_duration_since(t0);
    }

    /// The cost into the drive's report.
    fn into_report(self, r: &mut DriveReport) {
        r.telegrams = self.telegrams;
        r.retries = self.retries;
        r.elapsed_ms = ms(self.own);
    }
}

/// The rest of a drive on a broadcast bus, in two calls. `last == false`:
/// resume the dataset download, the drive's own dataset writes, SLOAD = -2
/// (the drive then checks and stores while the others are done); the drive
/// is parked again. `last == true`: poll SLOAD, the writes after the
/// dataset, verify every code, finish. A failure ends the drive at once
/// (roll back, report).
pub(super) fn next_half<'d>(
    bus: &Bus,
    mut p: Parked<'d>,
    link: &mut Link,
    ctx: &Ctx<'_>,
    resume: &Resume,
    last: bool,
) -> FirstHalf<'d> {
    let d = p.d;
    let t0 = link_now(link);
    let mut c = match crate::connect::lustbus_on(link, d.schema.clone(), d.address, &bus.connect())
    {
        Ok(c) => c,
        Err(e) => {
            p.r.error = Some(e.to_string());
            return FirstHalf::Done(Box::new(p.r), p.spans, None);
        }
    };
    let resumed = if p.dataset && !last {
        c.resume_dataset().map(Some)
    } else {
        Ok(None)
    };
    let (watch, hook) = drive_watch(bus, d, ctx);
    let mut client: Box<dyn DriveClient + '_> = Box::new(c);
    let stats0 = client.stats();
    p.tx.set_observer(hook);
    p.tx.attach(&*client);
    let res = match resumed {
        Ok(siof) => {
            if let Some(s) = siof.filter(|s| !s.is_empty()) {
                p.tx.warn(format!(
                    "SERR read {s} after the broadcast (cleared); every value is read back"
                ));
            }
            later_steps(&mut p.tx, &mut *client, &d.set, last)
        }
        Err(e) => Err(StepError::Error(e)),
    };
    if !last && res.is_ok() {
        // parked again: the drive checks and stores its dataset meanwhile
        p.cost.add(&mut *client, stats0, t0);
        watch.spans.event(client.clock().now(), Event::End);
        p.spans.extend(watch.spans.spans());
        p.tx.detach(&*client);
        return FirstHalf::Parked(Box::new(p));
    }
    let end = drive_to_end(&mut p.tx, &mut *client, &d.set, res);
    let Parked {
        tx,
        mut r,
        mut spans,
        mut cost,
        ..
    } = p;
    let finished = tx.finish(&mut *client, &d.set, end);
    let error = settle_drive(&mut r, d, finished, ctx);
    cost.add(&mut *client, stats0, t0);
    spans.extend(watch.spans.spans());
    cost.into_report(&mut r);
    resume.record_drive(ctx, bus, d, &r);
    FirstHalf::Done(Box::new(r), spans, error.as_ref().and_then(failure_of))
}

/// The steps of a later half: the drive's own dataset writes and SLOAD =
/// -2 (`last == false`); the SLOAD poll, the writes after the dataset and
/// the verification (`last`).
fn later_steps(
    tx: &mut Transaction,
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    last: bool,
) -> Result<(), StepError> {
    if last {
        tx.await_dataset(&mut *client)?;
        tx.write_rest(&mut *client)?;
        tx.verify(&mut *client, set)
    } else {
        tx.write_dataset(&mut *client)?;
        tx.end_dataset(&mut *client)
    }
}
