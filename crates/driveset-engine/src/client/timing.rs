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
}
