//! Progress as the engine's runners see it: the transaction runner
//! ([`crate::upload::upload`]), [`crate::recover::recover`],
//! [`crate::pull::pull`] and the line runner call an [`Observer`] with the
//! phase they are in and each step they finish. The runner names its own
//! phase, so a rollback is reported as [`Phase::Rollback`] (a client
//! wrapper guessing from traffic would see writes and reads, and call them
//! writing and verifying).
//!
//! Events carry the instant on the client's clock (virtual against the
//! simulator), so an observer can turn them into a timeline (the line
//! report's) or into a progress bar (the CLI's). Observing is free when no
//! observer is set ([`Hook::none`]): the clock is not even read.

use std::fmt;
use std::sync::Arc;

use driveset_link::{Clock, Instant};

/// A step of bus work, named by the runner doing it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Phase {
    /// Reading the identify codes (the family check).
    Identify,
    /// Reading values back from the drive (before planning, `status`, `pull`).
    Read,
    /// Planning: no bus traffic.
    Plan,
    /// Writing the journal (before the first write, at state transitions).
    Journal,
    /// MC6000/7000: opening the dataset download (80-SLOAD = -1).
    Dataset,
    /// Writing the planned values.
    Write,
    /// MC6000/7000: committing the dataset (80-SLOAD = -2) and polling
    /// 80-SLOAD until the drive accepted or rejected it.
    Commit,
    /// Reading the written values back and comparing them.
    Verify,
    /// The store command of a drive that keeps writes only on command
    /// (`[schema.store]`, CiA 301 0x1010 "save").
    Store,
    /// Restoring the old values from the backup and reading them back
    /// (also confirming the old set after a rejected dataset).
    Rollback,
    /// Finishing or undoing an unfinished journal (`recover`, and
    /// `commission` before it touches such a drive).
    Recover,
    /// Learning a schema from the drive's descriptions.
    Learn,
    /// LECOM MULTICAST of a group's common values.
    Broadcast,
}

impl Phase {
    /// The name in reports and timelines (`identify`, `read`, `write`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Identify => "identify",
            Phase::Read => "read",
            Phase::Plan => "plan",
            Phase::Journal => "journal",
            Phase::Dataset => "dataset",
            Phase::Write => "write",
            Phase::Commit => "commit",
            Phase::Verify => "verify",
            Phase::Store => "store",
            Phase::Rollback => "rollback",
            Phase::Recover => "recover",
            Phase::Learn => "learn",
            Phase::Broadcast => "broadcast",
        }
    }
}

impl Phase {
    /// Every phase, in declaration order.
    pub const ALL: [Phase; 12] = [
        Phase::Identify,
        Phase::Read,
        Phase::Plan,
        Phase::Journal,
        Phase::Dataset,
        Phase::Write,
        Phase::Commit,
        Phase::Verify,
        Phase::Rollback,
        Phase::Recover,
        Phase::Learn,
        Phase::Broadcast,
    ];

    /// The phase named `name` ([`Phase::as_str`]).
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.as_str() == name)
    }
}

/// A phase is written by its name ([`Phase::as_str`]), as reports'
/// timelines spell it.
impl serde::Serialize for Phase {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> serde::Deserialize<'de> for Phase {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = <String as serde::Deserialize>::deserialize(d)?;
        Phase::parse(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("unknown phase `{name}`")))
    }
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What a runner reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// The runner starts `phase`; `total` is the number of steps it will
    /// take when known (codes to read, write or verify). The previous
    /// phase ends here.
    Enter {
        /// The phase.
        phase: Phase,
        /// Steps planned, when known.
        total: Option<usize>,
    },
    /// A step done: code `done` of `total` read, written or verified.
    /// `phase` may differ from the phase entered last: verification reads
    /// that fill MC6000/7000 EEPROM gaps are [`Phase::Verify`] steps inside
    /// [`Phase::Write`].
    Step {
        /// What the step was.
        phase: Phase,
        /// Steps of this kind done so far (this one included).
        done: usize,
        /// Steps of this kind planned.
        total: usize,
    },
    /// The runner is done (whatever the outcome): the last phase ends here.
    End,
}

/// Receives a runner's [`Event`]s, each with the instant on the client's
/// clock it happened at. Called from the thread doing the bus work (a line
/// run has one per bus), hence `Send + Sync` and `&self`.
pub trait Observer: Send + Sync {
    /// One event.
    fn event(&self, at: Instant, event: Event);
}

/// The observer a runner reports to, or none. Runners' option structs hold
/// one; cloning shares the observer.
#[derive(Clone, Default)]
pub struct Hook(Option<Arc<dyn Observer>>);

impl Hook {
    /// No observer: events are dropped and the clock is not read.
    pub fn none() -> Self {
        Hook(None)
    }

    /// Report to `observer`.
    pub fn new(observer: Arc<dyn Observer>) -> Self {
        Hook(Some(observer))
    }

    /// Whether an observer is set.
    pub fn is_set(&self) -> bool {
        self.0.is_some()
    }

    /// Report `event`, stamped with `clock`'s now.
    pub fn emit(&self, clock: &dyn Clock, event: Event) {
        if let Some(o) = &self.0 {
            o.event(clock.now(), event);
        }
    }

    /// Report that `phase` starts (`total` steps, when known).
    pub fn enter(&self, clock: &dyn Clock, phase: Phase, total: Option<usize>) {
        self.emit(clock, Event::Enter { phase, total });
    }

    /// Report step `done` of `total` of kind `phase`.
    pub fn step(&self, clock: &dyn Clock, phase: Phase, done: usize, total: usize) {
        self.emit(clock, Event::Step { phase, done, total });
    }

    /// Report the end of the run.
    pub fn end(&self, clock: &dyn Clock) {
        self.emit(clock, Event::End);
    }
}

impl fmt::Debug for Hook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "Hook(observer)"
        } else {
            "Hook(none)"
        })
    }
}

/// An observer that keeps the spans of the phases entered: (phase, start,
/// end) in order, consecutive entries of one phase merged. The line runner
/// builds its timeline from one; tests use it to check the phase sequence.
#[derive(Debug, Default)]
pub struct Spans {
    inner: std::sync::Mutex<SpansInner>,
}

#[derive(Debug, Default)]
struct SpansInner {
    spans: Vec<(Phase, Instant, Instant)>,
    open: Option<(Phase, Instant)>,
}

impl Spans {
    /// An empty recorder.
    pub fn new() -> Self {
        Spans::default()
    }

    /// The spans so far, the open one ending at its start (call after
    /// [`Event::End`] for the complete list).
    pub fn spans(&self) -> Vec<(Phase, Instant, Instant)> {
        let g = self
            .inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let mut v = g.spans.clone();
        if let Some((p, s)) = g.open {
            push_span(&mut v, p, s, s);
        }
        v
    }

    /// The phases in order (consecutive repeats merged).
    pub fn phases(&self) -> Vec<Phase> {
        self.spans().into_iter().map(|(p, _, _)| p).collect()
    }
}

fn push_span(v: &mut Vec<(Phase, Instant, Instant)>, p: Phase, s: Instant, e: Instant) {
    match v.last_mut() {
        Some(last) if last.0 == p => last.2 = e,
        _ => v.push((p, s, e)),
    }
}

impl Observer for Spans {
    fn event(&self, at: Instant, event: Event) {
        let mut g = self
            .inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match event {
            Event::Enter { phase, .. } => {
                if let Some((p, s)) = g.open.take() {
                    push_span(&mut g.spans, p, s, at);
                }
                g.open = Some((phase, at));
            }
            Event::Step { .. } => {}
            Event::End => {
                if let Some((p, s)) = g.open.take() {
                    push_span(&mut g.spans, p, s, at);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use driveset_link::VirtualClock;
    use std::time::Duration;

    #[test]
    fn spans_merge_repeats_and_close_at_end() {
        let clock = VirtualClock::new();
        let spans = Arc::new(Spans::new());
        let hook = Hook::new(spans.clone());
        hook.enter(&clock, Phase::Identify, None);
        clock.sleep(Duration::from_millis(5));
        hook.enter(&clock, Phase::Read, Some(2));
        hook.step(&clock, Phase::Read, 1, 2);
        clock.sleep(Duration::from_millis(10));
        hook.enter(&clock, Phase::Read, Some(2));
        clock.sleep(Duration::from_millis(10));
        hook.enter(&clock, Phase::Write, Some(1));
        clock.sleep(Duration::from_millis(3));
        hook.end(&clock);
        let ms = |i: Instant| i.as_nanos() / 1_000_000;
        let got: Vec<(Phase, u64, u64)> = spans
            .spans()
            .into_iter()
            .map(|(p, s, e)| (p, ms(s), ms(e)))
            .collect();
        assert_eq!(
            got,
            [
                (Phase::Identify, 0, 5),
                (Phase::Read, 5, 25),
                (Phase::Write, 25, 28)
            ]
        );
        assert_eq!(format!("{:?}", Hook::none()), "Hook(none)");
        assert!(!Hook::none().is_set());
    }
}
