//! [`LinkLatency`]: what the transport between driveset and a serial line
//! adds to every exchange (USB adapter latency timers, serial device
//! servers, networks), measured from the exchanges themselves and added to
//! the spec's answer timeouts by the LUSTBUS and LECOM clients.
//!
//! # Answer timeout
//!
//! `timeout = spec reaction + reply wire time (10 bits a character) +
//! allowance`, where the spec reaction is LUSTBUS section 10's longest
//! reaction time ([`crate::plan::MC_MAX_REACTION_KEYPAD`] and friends) or
//! LECOM's monitoring time (8.J b: twice the longest response time), and
//! the allowance is this module's:
//!
//! - Every answered exchange gives one sample: the time from the end of the
//!   request to the last character of the reply, less what a direct line
//!   needs at least (the reply's wire time and the minimum reaction time of
//!   1 ms; a VF1000 EEPROM write also less its ACK delay). The sample is
//!   the link's round-trip latency plus whatever of the drive's reaction
//!   time is above the minimum.
//! - The estimate is a decaying peak of the samples: a larger sample raises
//!   it at once, a smaller one lowers it by 1/16 of the difference.
//! - allowance = `1.5 x peak + LATENCY_FLOOR`, at least
//!   [`LATENCY_FLOOR`] (10 ms), at most [`LATENCY_CAP`] (1 s). 1.5 x covers
//!   jitter the first samples have not shown yet (100 ms +- 20 ms each way
//!   is a round trip of 160..240 ms: a first sample of 160 ms already gives
//!   250 ms).
//! - Before the first sample (the first telegram of the session: identify)
//!   the allowance is [`FIRST_CONTACT`] (200 ms): with the late window
//!   below, a first reply up to about half a second late is still seen and
//!   measured, so a slow link is not mistaken for a missing drive, and a
//!   missing drive is reported after 3 x 2 x ~250 ms.
//! - A timeout doubles the estimate (plus the floor, up to the cap): the
//!   repetition waits longer.
//! - The port option `?latency=D` ([`LinkLatency::new`]) is a round-trip
//!   delay the user knows the transport adds: the allowance is then at
//!   least `D + LATENCY_FLOOR`, from the first telegram on.
//!
//! # Late replies
//!
//! After a timeout the client keeps listening for as long again (the late
//! window, [`LinkLatency::late_window`]) before it repeats or gives up: a
//! reply that arrives then is the late answer to the request just sent. It
//! is counted ([`super::ClientStats::late`]), its time raises the estimate,
//! and it is dropped: the repetition (after the input is discarded) gets
//! its own answer, and the next request never takes it for its own. A late
//! value reply that arrives later still is told apart by its address and
//! CODE (LUSTBUS) or code (LECOM).

use std::time::Duration;

use driveset_link::Instant;
use driveset_link::mem::wire_time;

/// The least allowance for the transport, whatever was measured (the
/// figure the clients used before they measured: host scheduling and a
/// direct serial port).
pub const LATENCY_FLOOR: Duration = Duration::from_millis(10);

/// The most allowance measurement can reach (a `?latency=` above it is
/// taken as given): far above any device server's round trip, short
/// enough that a drive that stopped answering is reported within seconds.
pub const LATENCY_CAP: Duration = Duration::from_secs(1);

/// The allowance before anything was measured (the first telegram of a
/// session), unless `?latency=` gives one.
pub const FIRST_CONTACT: Duration = Duration::from_millis(200);

/// The decaying peak of a link's measured latency (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinkLatency {
    /// `?latency=`: the round-trip delay the user says the transport adds.
    given: Option<Duration>,
    /// The decaying peak of the samples; `None` before the first.
    peak: Option<Duration>,
    /// Smoothed whole round trip (request end to reply end), for pacing
    /// polls (`1/8` weight per sample).
    round_trip: Option<Duration>,
    /// Samples taken.
    samples: u64,
}

impl LinkLatency {
    /// A tracker; `given` is the port's `?latency=` (round trip).
    pub fn new(given: Option<Duration>) -> Self {
        LinkLatency {
            given,
            peak: None,
            round_trip: None,
            samples: 0,
        }
    }

    /// The least allowance: the floor, or `?latency=` plus the floor.
    fn least(&self) -> Duration {
        self.given
            .map_or(LATENCY_FLOOR, |g| g.saturating_add(LATENCY_FLOOR))
    }

    /// What to add to the spec's answer timeout now.
    pub fn allowance(&self) -> Duration {
        let least = self.least();
        match self.peak {
            None if self.given.is_some() => least,
            None => FIRST_CONTACT.max(least),
            Some(p) => p
                .saturating_add(p / 2)
                .saturating_add(LATENCY_FLOOR)
                .min(LATENCY_CAP)
                .max(least),
        }
    }

    /// One answered exchange: `elapsed` from the end of the request to the
    /// end of the reply, `expected` what a direct line needs at least.
    pub fn observe(&mut self, elapsed: Duration, expected: Duration) {
        let excess = elapsed.saturating_sub(expected).min(LATENCY_CAP);
        self.peak = Some(match self.peak {
            None => excess,
            Some(p) if excess >= p => excess,
            Some(p) => p - (p - excess) / 16,
        });
        self.round_trip = Some(match self.round_trip {
            None => elapsed,
            Some(r) => (r * 7 + elapsed) / 8,
        });
        self.samples += 1;
    }

    /// An exchange timed out: the repetition waits longer.
    pub fn timed_out(&mut self) {
        if let Some(p) = self.peak {
            self.peak = Some(
                p.saturating_mul(2)
                    .saturating_add(LATENCY_FLOOR)
                    .min(LATENCY_CAP),
            );
        }
    }

    /// How long to keep listening for a late reply after a timeout of
    /// `timeout`: as long again.
    pub fn late_window(&self, timeout: Duration) -> Duration {
        timeout
    }

    /// The smoothed round trip (end of request to end of reply) measured so
    /// far, if any.
    pub fn round_trip(&self) -> Option<Duration> {
        self.round_trip
    }

    /// Samples taken so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// The port's `?latency=`.
    pub fn given(&self) -> Option<Duration> {
        self.given
    }
}

/// One exchange's wait for its answer on a character line (LUSTBUS,
/// LECOM; the module docs): until the answer timeout after the send, then,
/// where the line listens for late answers, the late window; and the
/// latency sample the answer gives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct AnswerWait {
    /// The end of the send.
    start: Instant,
    timeout: Duration,
    /// The end of the late window, once the timeout has passed and the
    /// line listens for a late answer.
    late_until: Option<Instant>,
    /// Characters received since the send.
    received: usize,
}

impl AnswerWait {
    /// The wait for the answer to a telegram whose send ended at `start`,
    /// `timeout` long.
    pub(crate) fn begin(start: Instant, timeout: Duration) -> Self {
        AnswerWait {
            start,
            timeout,
            late_until: None,
            received: 0,
        }
    }

    /// Until when the next receive waits: the timeout, or the end of the
    /// late window.
    pub(crate) fn until(&self) -> Instant {
        self.late_until.unwrap_or(self.start + self.timeout)
    }

    /// Nothing came by [`until`](Self::until). At the timeout it is told
    /// to `latency` (the repetition waits longer) and, where the line
    /// `listens_late`, the late window opens: `true`, receive again.
    /// Otherwise `false`: the wait is over.
    pub(crate) fn nothing_came(&mut self, latency: &mut LinkLatency, listens_late: bool) -> bool {
        if self.late_until.is_some() {
            return false;
        }
        latency.timed_out();
        if !listens_late {
            return false;
        }
        self.late_until = Some(self.start + self.timeout + latency.late_window(self.timeout));
        true
    }

    /// `n` characters came.
    pub(crate) fn came(&mut self, n: usize) {
        self.received += n;
    }

    /// Whether the timeout has passed (an answer now is a late one).
    pub(crate) fn is_late(&self) -> bool {
        self.late_until.is_some()
    }

    /// The answer timeout this wait began with.
    pub(crate) fn timeout(&self) -> Duration {
        self.timeout
    }

    /// An answer is complete at `now` on a line at `baud`: its sample
    /// told to `latency` (what a direct line needs at least is the wire
    /// time of every character received and `least_reaction`). The time
    /// since the send.
    pub(crate) fn answered(
        &self,
        latency: &mut LinkLatency,
        now: Instant,
        baud: u32,
        least_reaction: Duration,
    ) -> Duration {
        let elapsed = now.saturating_duration_since(self.start);
        let expected = wire_time(self.received, baud).saturating_add(least_reaction);
        latency.observe(elapsed, expected);
        elapsed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn first_contact_then_measured() {
        let mut l = LinkLatency::new(None);
        assert_eq!(l.allowance(), FIRST_CONTACT);
        // 100 ms of excess: 1.5 x 100 + 10.
        l.observe(130 * MS, 30 * MS);
        assert_eq!(l.allowance(), 160 * MS);
        // a larger sample raises it at once
        l.observe(230 * MS, 30 * MS);
        assert_eq!(l.allowance(), 310 * MS);
        // a smaller one lowers it by 1/16 of the difference
        l.observe(30 * MS, 30 * MS);
        assert_eq!(l.allowance(), (200 * MS - 200 * MS / 16) * 3 / 2 + 10 * MS);
        assert_eq!(l.samples(), 3);
    }

    #[test]
    fn floor_cap_and_timeouts() {
        let mut l = LinkLatency::new(None);
        l.observe(5 * MS, 10 * MS);
        assert_eq!(l.allowance(), LATENCY_FLOOR);
        l.timed_out(); // 0 -> 10 ms
        assert_eq!(l.allowance(), 25 * MS);
        for _ in 0..20 {
            l.timed_out();
        }
        assert_eq!(l.allowance(), LATENCY_CAP);
        l.observe(Duration::from_secs(30), MS);
        assert_eq!(l.allowance(), LATENCY_CAP);
    }

    #[test]
    fn a_given_latency_is_the_least_allowance() {
        let mut l = LinkLatency::new(Some(80 * MS));
        assert_eq!(l.allowance(), 90 * MS);
        l.observe(2 * MS, MS);
        assert_eq!(l.allowance(), 90 * MS);
        l.observe(201 * MS, MS);
        assert_eq!(l.allowance(), 310 * MS);
        let l = LinkLatency::new(Some(Duration::from_secs(3)));
        assert_eq!(l.allowance(), Duration::from_secs(3) + LATENCY_FLOOR);
    }

    #[test]
    fn round_trip_is_smoothed() {
        let mut l = LinkLatency::new(None);
        assert_eq!(l.round_trip(), None);
        l.observe(80 * MS, MS);
        l.observe(160 * MS, MS);
        assert_eq!(l.round_trip(), Some(90 * MS));
    }

    #[test]
    fn an_answer_wait_opens_the_late_window_once_where_the_line_listens_late() {
        let at = |ms: u64| Instant::from_nanos(ms * 1_000_000);
        let mut latency = LinkLatency::new(None);
        latency.observe(20 * MS, Duration::ZERO);
        let before = latency.allowance();
        let mut wait = AnswerWait::begin(at(100), 50 * MS);
        assert_eq!(wait.until(), at(150));
        assert!(!wait.is_late());
        assert!(
            wait.nothing_came(&mut latency, true),
            "the late window opens"
        );
        assert!(latency.allowance() > before, "the timeout was told");
        assert!(wait.is_late());
        assert_eq!(wait.until(), at(200), "as long again");
        assert!(!wait.nothing_came(&mut latency, true), "once only");
        assert_eq!(wait.timeout(), 50 * MS);

        // a scan probe's line does not listen late
        let mut wait = AnswerWait::begin(at(0), 50 * MS);
        assert!(!wait.nothing_came(&mut latency, false));
        assert!(!wait.is_late());
    }

    #[test]
    fn an_answered_wait_samples_what_exceeds_the_wire_time_and_the_least_reaction() {
        let at = |ms: u64| Instant::from_nanos(ms * 1_000_000);
        let mut latency = LinkLatency::new(None);
        let mut wait = AnswerWait::begin(at(0), 50 * MS);
        wait.came(4);
        wait.came(6);
        // 10 characters at 9600 baud: about 10.4 ms on the wire
        let elapsed = wait.answered(&mut latency, at(40), 9600, MS);
        assert_eq!(elapsed, 40 * MS);
        assert_eq!(latency.samples(), 1);
        assert_eq!(latency.round_trip(), Some(40 * MS));
        let mut direct = LinkLatency::new(None);
        direct.observe(40 * MS, wire_time(10, 9600) + MS);
        assert_eq!(latency, direct);
    }
}
