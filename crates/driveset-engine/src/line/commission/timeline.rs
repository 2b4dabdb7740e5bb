//! Owns a bus's timeline and the clock readings it is drawn from: the bus
//! clock's time, each drive's observer (its spans for the timeline, its
//! events for the line's [`super::LineObserver`]), and the entries the bus
//! report's timeline gets (module docs of [`super`], "Timeline and
//! progress").

use std::sync::Arc;
use std::time::Duration;

use driveset_link::{Clock, Instant, Link};

use super::LineObserver;
use super::run::Ctx;
use crate::line::manifest::{Bus, Drive};
use crate::line::report::{BusReport, TimelineEntry};
use crate::observe::{Event, Hook, Observer, Phase, Spans};

/// A phase of a drive's work, from its start to its end on the bus clock.
pub(super) type Span = (Phase, Instant, Instant);

/// The time of the link's clock (the bus clock).
pub(super) fn link_now(link: &Link) -> Instant {
    link_clock(link).now()
}

/// The link's clock.
pub(super) fn link_clock(link: &Link) -> &dyn Clock {
    match link {
        Link::Bytes(b) => b.clock(),
        Link::Frames(f) => f.clock(),
    }
}

/// A duration in milliseconds, as reports give them.
pub(super) fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// Milliseconds from `start` to `at`.
pub(super) fn since(start: Instant, at: Instant) -> f64 {
    ms(at.saturating_duration_since(start))
}

/// The observer of one drive's work: keeps its spans for the timeline and
/// passes every event on to the line's observer.
pub(super) struct DriveWatch {
    pub(super) spans: Spans,
    line: Option<(Arc<dyn LineObserver>, String, String)>,
}

impl Observer for DriveWatch {
    fn event(&self, at: Instant, event: Event) {
        self.spans.event(at, event);
        if let Some((o, bus, drive)) = &self.line {
            o.event(bus, drive, at, event);
        }
    }
}

/// A drive's observer for one part of its work: its spans for the
/// timeline, its events for the line's observer.
pub(super) fn drive_watch(bus: &Bus, d: &Drive, ctx: &Ctx<'_>) -> (Arc<DriveWatch>, Hook) {
    let watch = Arc::new(DriveWatch {
        spans: Spans::new(),
        line: ctx
            .opts
            .observer
            .clone()
            .map(|o| (o, bus.name.clone(), d.name.clone())),
    });
    let hook = Hook::new(watch.clone());
    (watch, hook)
}

/// Drive `drive`'s spans into the bus timeline (`start`: the bus's start);
/// zero-length spans (planning, journal writes on a virtual clock) would
/// draw nothing and are left out.
pub(super) fn push_spans(report: &mut BusReport, start: Instant, drive: &str, spans: Vec<Span>) {
    for (phase, s, e) in spans.into_iter().filter(|(_, s, e)| s != e) {
        report.timeline.push(TimelineEntry {
            drive: drive.to_string(),
            phase,
            start_ms: since(start, s),
            end_ms: since(start, e),
        });
    }
}

/// A broadcast from `t0` to `t1` into the bus timeline, under `to` (a LECOM
/// group, LUSTBUS address 31).
pub(super) fn push_broadcast(
    report: &mut BusReport,
    start: Instant,
    to: String,
    (t0, t1): (Instant, Instant),
) {
    report.timeline.push(TimelineEntry {
        drive: to,
        phase: Phase::Broadcast,
        start_ms: since(start, t0),
        end_ms: since(start, t1),
    });
}
