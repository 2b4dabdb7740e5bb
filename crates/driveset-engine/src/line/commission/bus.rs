//! Owns the work of one bus thread: opening the bus's port, its drives as
//! the run's walk does them (in turn until the observer stops the bus or
//! the link fails; `commission` with the broadcast the bus gets: LECOM
//! MULTICAST, LUSTBUS address 31, or none), each drive done told to the
//! observer, and the bus report with its timeline (module docs of
//! [`super`]).

use driveset_link::{Instant, Link};

use super::broadcast::{lustbus_broadcast_refusal, run_lustbus_broadcast};
use super::drive::{Failure, blank_report, run_drive};
use super::multicast::broadcast_common;
use super::options::{DriveDone, Flow, Opener};
use super::resume::Resume;
use super::run::Ctx;
use super::timeline::{link_now, push_spans, since};
use crate::line::manifest::{Bus, BusProtocol, Drive};
use crate::line::report::{BusReport, DriveReport, DriveResult};

/// What a bus thread gives back.
pub(super) struct BusRun {
    pub(super) report: BusReport,
    pub(super) drives: Vec<DriveReport>,
    pub(super) failed: bool,
}

/// One bus of a run, as its drives' work sees it: the bus, the run, the
/// bus clock's start and how many drives the bus does.
pub(in crate::line) struct OnBus<'a> {
    pub(super) bus: &'a Bus,
    pub(in crate::line) ctx: &'a Ctx<'a>,
    pub(super) start: Instant,
    total: usize,
}

impl OnBus<'_> {
    /// Tell the observer that `done` drives of the bus are done, the last
    /// being `d`.
    pub(super) fn drive_done(&self, done: usize, d: &DriveReport) {
        if let Some(o) = &self.ctx.opts.observer {
            o.drive_done(&DriveDone {
                bus: &self.bus.name,
                done,
                total: self.total,
                drive: d,
            });
        }
    }

    /// Whether the observer stops the bus before its next drive, `done`
    /// of its drives done: why.
    fn stopped(&self, done: usize) -> Option<String> {
        let o = self.ctx.opts.observer.as_ref()?;
        match o.before_drive(&self.bus.name, done) {
            Flow::Go => None,
            Flow::Stop(why) => Some(why),
        }
    }
}

/// Run bus `bus` with its selected `drives`; `listed`: every drive the
/// manifest puts on it.
pub(super) fn run_bus(
    bus: &Bus,
    drives: &[&Drive],
    listed: &[&Drive],
    ctx: &Ctx<'_>,
    opener: &Opener<'_>,
) -> BusRun {
    let mut report = BusReport {
        name: bus.name.clone(),
        port: bus.port_name.clone(),
        protocol: bus.protocol,
        rate: bus.rate,
        elapsed_ms: 0.0,
        timeline: Vec::new(),
    };
    if drives.is_empty() {
        return BusRun {
            report,
            drives: Vec::new(),
            failed: false,
        };
    }
    if let Some(o) = &ctx.opts.observer {
        o.bus(&bus.name, drives.len());
    }
    let mut link = match opener(bus) {
        Ok(l) => l,
        Err(e) => {
            return BusRun {
                drives: unopened(bus, drives, ctx, &e),
                report,
                failed: true,
            };
        }
    };
    let on = OnBus {
        bus,
        ctx,
        start: link_now(&link),
        total: drives.len(),
    };
    let (out, failed) = ctx
        .walk
        .bus_drives(&on, drives, listed, &mut link, &mut report);
    report.elapsed_ms = since(on.start, link_now(&link));
    BusRun {
        report,
        drives: out,
        failed,
    }
}

/// A bus of `commission --broadcast-common` (module docs of [`super`],
/// "Broadcast"): a LUSTBUS bus that may take it gets its broadcast to
/// address 31; a LECOM bus its MULTICAST per group (a CAN bus a warning),
/// then its drives one by one.
pub(super) fn with_broadcast(
    on: &OnBus<'_>,
    resume: &Resume,
    drives: &[&Drive],
    listed: &[&Drive],
    link: &mut Link,
    report: &mut BusReport,
) -> (Vec<DriveReport>, bool) {
    let bus = on.bus;
    if bus.protocol == BusProtocol::Lustbus && may_broadcast(on, drives, listed, link) {
        let (out, failed) = run_lustbus_broadcast(on, resume, drives, link, report);
        record_reports(bus, drives, &out, on.ctx);
        (out, failed)
    } else {
        if bus.protocol != BusProtocol::Lustbus {
            broadcast_common(on, drives, link, report);
        }
        drive_by_drive(on, drives, link, report)
    }
}

/// The drives of a LUSTBUS broadcast run on the run's record
/// ([`crate::history`]): their parked transactions end in their reports,
/// whose diff holds the codes written.
fn record_reports(bus: &Bus, drives: &[&Drive], out: &[DriveReport], ctx: &Ctx<'_>) {
    use crate::history::{DriveRecord, Unit, diff_codes};
    let Some(h) = ctx.opts.env.history() else {
        return;
    };
    for r in out {
        let Some(d) = drives.iter().find(|d| d.name == r.name) else {
            continue;
        };
        let unit = Unit {
            family: crate::client::IdentProtocol::Family(d.schema.family)
                .name()
                .to_string(),
            device_type: r.identity.first().map(|(_, v)| v.clone()),
            identity: r.identity.clone(),
            ..Unit::default()
        };
        let record = DriveRecord::of_line(ctx.line, r, unit, diff_codes(r));
        if let Err(e) = h.drive(&record) {
            ctx.warn(format!(
                "{} ({}): not recorded in the history: {e}",
                r.name, bus.name
            ));
        }
    }
}

/// Every drive of a bus whose port could not be opened: failed, saying so.
fn unopened(bus: &Bus, drives: &[&Drive], ctx: &Ctx<'_>, e: &str) -> Vec<DriveReport> {
    let on = OnBus {
        bus,
        ctx,
        // no bus clock: the port never opened
        start: Instant::ZERO,
        total: drives.len(),
    };
    let mut out = Vec::new();
    for (i, d) in drives.iter().enumerate() {
        let mut r = blank_report(d, bus, DriveResult::Failed);
        r.error = Some(format!(
            "bus `{}` ({}) could not be opened: {e}",
            bus.name, bus.port_name
        ));
        on.drive_done(i + 1, &r);
        out.push(r);
    }
    out
}

/// Whether a LUSTBUS bus gets its broadcast to address 31 (module docs of
/// [`super`], "Broadcast"); when it may not, a warning says why. A bus the
/// observer may stop ([`super::LineObserver::may_stop`]) runs drive by
/// drive, without a warning.
fn may_broadcast(on: &OnBus<'_>, drives: &[&Drive], listed: &[&Drive], link: &Link) -> bool {
    let refusal = match on.bus.transfer_baud {
        // the broadcast path runs every drive at the bus's rate
        Some(rate) => Some(format!(
            "the bus has transfer_baud = {rate}, and a broadcast needs every drive of the bus at one rate (each MC drive is switched on its own)"
        )),
        None => lustbus_broadcast_refusal(drives, listed, link, on.ctx),
    };
    match refusal {
        None => !on.ctx.opts.observer.as_ref().is_some_and(|o| o.may_stop()),
        Some(why) => {
            on.ctx.warn(format!(
                "bus `{}`: no broadcast (address 31): {why}; values were written drive by drive",
                on.bus.name
            ));
            false
        }
    }
}

/// The drives of a bus one by one: each drive's report and its timeline;
/// after a link failure (or where the observer stops the bus) the rest
/// are not reached. Also gives whether the bus failed.
pub(super) fn drive_by_drive(
    on: &OnBus<'_>,
    drives: &[&Drive],
    link: &mut Link,
    report: &mut BusReport,
) -> (Vec<DriveReport>, bool) {
    let bus = on.bus;
    let mut out = Vec::new();
    let mut failed = false;
    let mut dead: Option<String> = None;
    for (i, d) in drives.iter().enumerate() {
        if dead.is_none()
            && let Some(why) = on.stopped(i)
        {
            failed = true;
            dead = Some(format!(
                "not reached: the run stopped after {} drive(s) on bus `{}` ({why}); run the command again to resume",
                i, bus.name
            ));
        }
        if let Some(why) = &dead {
            let mut r = blank_report(d, bus, DriveResult::Failed);
            r.error = Some(why.clone());
            on.drive_done(i + 1, &r);
            out.push(r);
            continue;
        }
        let (r, spans, link_failed) = run_drive(bus, d, link, on.ctx);
        push_spans(report, on.start, &d.name, spans);
        if let Some(kind) = link_failed {
            failed = true;
            if kind == Failure::Link {
                dead = Some(format!(
                    "not reached: the link of bus `{}` failed at drive `{}`",
                    bus.name, d.name
                ));
            }
        }
        on.drive_done(i + 1, &r);
        out.push(r);
    }
    (out, failed)
}
