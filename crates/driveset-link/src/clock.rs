//! Time for everything that waits on a bus: the [`Clock`] trait, the
//! crate's [`Instant`] (nanoseconds since the clock's epoch), the wall-clock
//! [`RealClock`] and the deterministic [`VirtualClock`].
//!
//! The engine and the simulator take time only from a [`Clock`], so the same
//! transaction code runs in real time against a port and in virtual time
//! against the in-memory links of [`crate::mem`] (fast, deterministic tests
//! and benchmarks). Deadlines passed to [`crate::ByteLink::recv`] and
//! [`crate::FrameLink::recv`] are instants of the clock the link was built
//! with: [`RealClock`] for the real transports, the pair's [`VirtualClock`]
//! for the in-memory links.

use std::fmt;
use std::ops::{Add, AddAssign, Sub};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

/// A point in time: nanoseconds since the epoch of the clock it came from.
///
/// Instants of different clock kinds do not mix: a [`RealClock`] instant
/// counts from the first use of any `RealClock` in the process, a
/// [`VirtualClock`] instant from the creation of that virtual clock. About
/// 584 years fit; arithmetic saturates instead of wrapping or panicking.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Instant(u64);

impl Instant {
    /// The clock's epoch.
    pub const ZERO: Instant = Instant(0);
    /// The latest representable instant ("never" as a deadline).
    pub const MAX: Instant = Instant(u64::MAX);

    /// The instant `nanos` nanoseconds after the epoch.
    pub const fn from_nanos(nanos: u64) -> Self {
        Instant(nanos)
    }

    /// Nanoseconds since the epoch.
    pub const fn as_nanos(self) -> u64 {
        self.0
    }

    /// Time elapsed since the epoch.
    pub const fn since_epoch(self) -> Duration {
        Duration::from_nanos(self.0)
    }

    /// `self - earlier`, or zero if `earlier` is later than `self`.
    pub const fn saturating_duration_since(self, earlier: Instant) -> Duration {
        Duration::from_nanos(self.0.saturating_sub(earlier.0))
    }

    /// `self + d`, or `None` if it does not fit.
    pub fn checked_add(self, d: Duration) -> Option<Instant> {
        let nanos = u64::try_from(d.as_nanos()).ok()?;
        self.0.checked_add(nanos).map(Instant)
    }

    /// `self - d`, or `None` before the epoch.
    pub fn checked_sub(self, d: Duration) -> Option<Instant> {
        let nanos = u64::try_from(d.as_nanos()).ok()?;
        self.0.checked_sub(nanos).map(Instant)
    }

    /// `self + d`, saturating at [`Instant::MAX`].
    pub fn saturating_add(self, d: Duration) -> Instant {
        self.checked_add(d).unwrap_or(Instant::MAX)
    }

    /// `self - d`, saturating at [`Instant::ZERO`].
    pub fn saturating_sub(self, d: Duration) -> Instant {
        self.checked_sub(d).unwrap_or(Instant::ZERO)
    }
}

impl fmt::Display for Instant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}.{:09}s",
            self.0 / 1_000_000_000,
            self.0 % 1_000_000_000
        )
    }
}

/// Saturates at [`Instant::MAX`].
impl Add<Duration> for Instant {
    type Output = Instant;
    fn add(self, rhs: Duration) -> Instant {
        self.saturating_add(rhs)
    }
}

impl AddAssign<Duration> for Instant {
    fn add_assign(&mut self, rhs: Duration) {
        *self = self.saturating_add(rhs);
    }
}

/// Saturates at [`Instant::ZERO`].
impl Sub<Duration> for Instant {
    type Output = Instant;
    fn sub(self, rhs: Duration) -> Instant {
        self.saturating_sub(rhs)
    }
}

/// The time between two instants, zero if `rhs` is later.
impl Sub<Instant> for Instant {
    type Output = Duration;
    fn sub(self, rhs: Instant) -> Duration {
        self.saturating_duration_since(rhs)
    }
}

/// A source of time that can also wait.
///
/// Implementations are cheap to share (`&C`, `Arc<C>` and `Box<C>` are
/// clocks too) and usable from several threads.
pub trait Clock: Send + Sync + fmt::Debug {
    /// The current instant.
    fn now(&self) -> Instant;

    /// Wait until `deadline` (returns at once if it has passed).
    fn sleep_until(&self, deadline: Instant);

    /// Wait for `d`.
    fn sleep(&self, d: Duration) {
        self.sleep_until(self.now() + d);
    }

    /// The instant `d` from now: the usual way to build a deadline.
    fn deadline_in(&self, d: Duration) -> Instant {
        self.now() + d
    }
}

impl<C: Clock + ?Sized> Clock for &C {
    fn now(&self) -> Instant {
        (**self).now()
    }
    fn sleep_until(&self, deadline: Instant) {
        (**self).sleep_until(deadline)
    }
}

impl<C: Clock + ?Sized> Clock for Arc<C> {
    fn now(&self) -> Instant {
        (**self).now()
    }
    fn sleep_until(&self, deadline: Instant) {
        (**self).sleep_until(deadline)
    }
}

impl<C: Clock + ?Sized> Clock for Box<C> {
    fn now(&self) -> Instant {
        (**self).now()
    }
    fn sleep_until(&self, deadline: Instant) {
        (**self).sleep_until(deadline)
    }
}

/// Wall-clock time from [`std::time::Instant`] (monotonic).
///
/// Every `RealClock` in the process shares one epoch (the first use of any
/// of them), so instants from different `RealClock` values compare.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RealClock;

impl RealClock {
    fn epoch() -> std::time::Instant {
        static EPOCH: OnceLock<std::time::Instant> = OnceLock::new();
        *EPOCH.get_or_init(std::time::Instant::now)
    }

    /// The std instant for `at`, for APIs that take one.
    pub fn to_std(at: Instant) -> Option<std::time::Instant> {
        Self::epoch().checked_add(at.since_epoch())
    }

    /// Time left until `deadline`, zero if it has passed.
    pub fn remaining(deadline: Instant) -> Duration {
        deadline - RealClock.now()
    }
}

impl Clock for RealClock {
    fn now(&self) -> Instant {
        let elapsed = Self::epoch().elapsed();
        Instant(u64::try_from(elapsed.as_nanos()).unwrap_or(u64::MAX))
    }

    fn sleep_until(&self, deadline: Instant) {
        // `thread::sleep` may wake early on some platforms: loop.
        loop {
            let left = Self::remaining(deadline);
            if left.is_zero() {
                return;
            }
            std::thread::sleep(left);
        }
    }
}

/// Deterministic virtual time: a shared counter of nanoseconds that moves
/// only when someone sleeps on it or a link of [`crate::mem`] waits on it.
///
/// Clones share the same time (`Arc` inside, cheap to clone). Sleeping
/// never blocks the thread: [`Clock::sleep_until`] moves the time forward
/// to the deadline (never backwards) and returns. Driven from one thread,
/// every run with the same inputs sees the same instants. When several
/// threads share one virtual clock, time is the latest instant any of them
/// has reached (each sleep is a `max`), which stays monotonic but is only
/// deterministic if the threads' interleaving is.
#[derive(Debug, Clone, Default)]
pub struct VirtualClock {
    nanos: Arc<AtomicU64>,
}

impl VirtualClock {
    /// A virtual clock at its epoch ([`Instant::ZERO`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// A virtual clock starting at `start`.
    pub fn starting_at(start: Instant) -> Self {
        VirtualClock {
            nanos: Arc::new(AtomicU64::new(start.as_nanos())),
        }
    }

    /// Move the time forward by `d`; returns the new instant.
    pub fn advance(&self, d: Duration) -> Instant {
        let target = self.now() + d;
        self.advance_to(target)
    }

    /// Move the time forward to `at` (no effect if it is already later);
    /// returns the current instant afterwards.
    pub fn advance_to(&self, at: Instant) -> Instant {
        let before = self.nanos.fetch_max(at.as_nanos(), Ordering::AcqRel);
        Instant(before.max(at.as_nanos()))
    }

    /// Whether `self` and `other` are handles to the same time.
    pub fn same_clock(&self, other: &VirtualClock) -> bool {
        Arc::ptr_eq(&self.nanos, &other.nanos)
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> Instant {
        Instant(self.nanos.load(Ordering::Acquire))
    }

    fn sleep_until(&self, deadline: Instant) {
        self.advance_to(deadline);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instant_arithmetic_saturates() {
        let t = Instant::from_nanos(1_500);
        assert_eq!(t + Duration::from_nanos(500), Instant::from_nanos(2_000));
        assert_eq!(t - Duration::from_nanos(2_000), Instant::ZERO);
        assert_eq!(Instant::MAX + Duration::from_secs(1), Instant::MAX);
        assert_eq!(Instant::from_nanos(10) - t, Duration::ZERO);
        assert_eq!(t - Instant::from_nanos(500), Duration::from_nanos(1_000));
        assert_eq!(t.checked_add(Duration::MAX), None);
        assert_eq!(
            Instant::from_nanos(1_000_000_001).to_string(),
            "1.000000001s"
        );
    }

    #[test]
    fn virtual_clock_moves_only_when_asked_and_never_back() {
        let clock = VirtualClock::new();
        let other = clock.clone();
        assert_eq!(clock.now(), Instant::ZERO);
        clock.sleep(Duration::from_millis(5));
        assert_eq!(other.now(), Instant::from_nanos(5_000_000));
        other.sleep_until(Instant::from_nanos(1));
        assert_eq!(clock.now(), Instant::from_nanos(5_000_000));
        assert_eq!(
            clock.advance(Duration::from_nanos(7)),
            Instant::from_nanos(5_000_007)
        );
        assert!(clock.same_clock(&other));
        assert!(!clock.same_clock(&VirtualClock::new()));
        let shared: Arc<dyn Clock> = Arc::new(clock.clone());
        assert_eq!(
            shared.deadline_in(Duration::from_nanos(3)),
            Instant::from_nanos(5_000_010)
        );
    }

    #[test]
    fn real_clock_is_monotonic_and_shares_its_epoch() {
        let a = RealClock.now();
        let b = RealClock.now();
        assert!(b >= a);
        RealClock.sleep_until(a); // already past: returns at once
        assert!(RealClock::to_std(a).is_some());
    }
}
