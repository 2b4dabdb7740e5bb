//! In-memory links with wire timing in virtual time: [`byte_pair`] (a 7E1
//! serial line) and [`frame_pair`] (a CAN bus between two nodes). This is
//! what fast tests and benchmarks run on.
//!
//! Timing model, all on the pair's [`VirtualClock`]:
//!
//! - A byte send starts when the sender's direction of the line is free
//!   (`max(now, end of the previous send)`), takes [`wire_time`]`(n, baud)`
//!   for `n` characters (10 bit times each: start, 7 data, parity, stop),
//!   and occupies the sender: `send` returns with the clock at the end of
//!   the transmission. Character `i` (0-based) becomes readable at the
//!   other end at `start + wire_time(i + 1, baud)`.
//! - A frame send works the same with [`can_frame_time`] per frame.
//! - `recv` with something in flight that arrives by the deadline moves
//!   the clock to its arrival and returns everything arrived by then; with
//!   nothing arriving by the deadline it moves the clock to the deadline
//!   (the line stayed idle that long) and returns nothing.
//!
//! One thread driving both ends (send, let the other end receive and
//! answer, receive) gives exact, repeatable instants. The ends are `Send`
//! and share state behind a mutex, so they may live on different threads,
//! but virtual time is then only as deterministic as the interleaving.
//! Dropping one end is a cut cable: the other end's sends go nowhere and
//! its receives time out.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use crate::ByteLink;
use crate::clock::{Clock, Instant, VirtualClock};
use crate::error::LinkError;
use crate::spec::ALLOWED_BAUDS;
use crate::spec::ALLOWED_BITRATES;
use crate::{CanFrame, FrameLink};

/// Bits per character on a 7E1 line: start, 7 data, parity, stop.
pub const BITS_PER_CHAR: u64 = 10;

/// Time `chars` characters take on a 7E1 line at `baud`:
/// `chars x 10 / baud` seconds, rounded down to the nanosecond (computed
/// from the total so rounding never accumulates). Zero for `baud == 0`.
pub fn wire_time(chars: usize, baud: u32) -> Duration {
    bits_time(chars as u128 * u128::from(BITS_PER_CHAR), baud)
}

/// Time `bits` bits take at `rate` bit/s, rounded down to the nanosecond.
/// Zero for `rate == 0`.
pub fn bits_time(bits: u128, rate: u32) -> Duration {
    if rate == 0 {
        return Duration::ZERO;
    }
    let nanos = bits * 1_000_000_000 / u128::from(rate);
    Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
}
/// Time one CAN frame occupies the bus at `bitrate`: the proto crate's
/// exact bit count for this frame (its own stuff bits, 3-bit intermission
/// included), rounded up to the nanosecond. Fails for an invalid frame.
pub fn can_frame_time(
    frame: &CanFrame,
    bitrate: u32,
) -> Result<Duration, driveset_proto::can::FrameError> {
    use driveset_proto::can::timing::{Stuffing, frame_bits, frame_time_ns};
    let bits = frame_bits(frame, Stuffing::Exact)?;
    Ok(Duration::from_nanos(
        frame_time_ns(bits, bitrate).unwrap_or(0),
    ))
}

/// One direction of the wire: what is in flight and when the sender is
/// free again.
#[derive(Debug)]
struct Direction<T> {
    in_flight: VecDeque<(Instant, T)>,
    busy_until: Instant,
}

impl<T> Default for Direction<T> {
    fn default() -> Self {
        Direction {
            in_flight: VecDeque::new(),
            busy_until: Instant::ZERO,
        }
    }
}

#[derive(Debug)]
struct Wire<T> {
    /// `dirs[side]` carries what `side` sends.
    dirs: [Direction<T>; 2],
}

/// The state one end holds: its side, the shared wire, the clock.
#[derive(Debug)]
struct End<T> {
    wire: Arc<Mutex<Wire<T>>>,
    side: usize,
    clock: VirtualClock,
    name: String,
    /// [`crate::bus_id::mem`] of the pair: both ends are one bus, two
    /// pairs two buses.
    bus: String,
}

impl<T> End<T> {
    fn pair(clock: &VirtualClock, names: [&str; 2]) -> (End<T>, End<T>) {
        let wire = Arc::new(Mutex::new(Wire {
            dirs: [Direction::default(), Direction::default()],
        }));
        let bus = crate::bus_id::mem();
        let end = |side: usize| End {
            wire: Arc::clone(&wire),
            side,
            clock: clock.clone(),
            name: names[side].to_string(),
            bus: bus.clone(),
        };
        (end(0), end(1))
    }

    fn lock(&self) -> MutexGuard<'_, Wire<T>> {
        // A panic elsewhere while holding the lock leaves consistent data
        // (every update is a single push or pop): carry on.
        self.wire.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Put `items` on the wire, item `i` taking until `start + end_of(i)`;
    /// occupy the sender until the last one is through.
    fn send(
        &self,
        items: impl IntoIterator<Item = T>,
        mut end_of: impl FnMut(usize, &T) -> Duration,
    ) {
        let done = {
            let mut wire = self.lock();
            let dir = &mut wire.dirs[self.side];
            let start = self.clock.now().max(dir.busy_until);
            let mut done = start;
            for (i, item) in items.into_iter().enumerate() {
                done = start + end_of(i, &item);
                dir.in_flight.push_back((done, item));
            }
            dir.busy_until = done;
            done
        };
        self.clock.sleep_until(done);
    }

    /// Wait for the first item in flight towards us (or the deadline), then
    /// take up to `max` items that have arrived.
    fn recv(&self, deadline: Instant, max: usize, mut take: impl FnMut(T)) -> usize {
        let first = {
            let wire = self.lock();
            wire.dirs[1 - self.side]
                .in_flight
                .front()
                .map(|(at, _)| *at)
        };
        match first {
            Some(at) if at <= deadline => {
                self.clock.sleep_until(at);
            }
            _ => {
                self.clock.sleep_until(deadline);
                return 0;
            }
        }
        let now = self.clock.now();
        let mut wire = self.lock();
        let queue = &mut wire.dirs[1 - self.side].in_flight;
        let mut n = 0;
        while n < max {
            match queue.front() {
                Some((at, _)) if *at <= now => {}
                _ => break,
            }
            if let Some((_, item)) = queue.pop_front() {
                take(item);
                n += 1;
            }
        }
        n
    }

    /// Drop what has arrived and not been read; what is still in flight
    /// arrives later as usual.
    fn discard_arrived(&self) {
        let now = self.clock.now();
        let mut wire = self.lock();
        let queue = &mut wire.dirs[1 - self.side].in_flight;
        while queue.front().is_some_and(|(at, _)| *at <= now) {
            queue.pop_front();
        }
    }

    /// Instant the next item in flight towards this end arrives.
    fn next_arrival(&self) -> Option<Instant> {
        self.lock().dirs[1 - self.side]
            .in_flight
            .front()
            .map(|(at, _)| *at)
    }
}

/// One end of an in-memory 7E1 line (see the module docs for timing).
#[derive(Debug)]
pub struct MemByteLink {
    end: End<u8>,
    baud: u32,
}

/// Two connected ends of an in-memory 7E1 line at `baud` (one of
/// [`ALLOWED_BAUDS`]) on `clock`, named `mem-a` and `mem-b`.
pub fn byte_pair(clock: &VirtualClock, baud: u32) -> Result<(MemByteLink, MemByteLink), LinkError> {
    if !ALLOWED_BAUDS.contains(&baud) {
        return Err(LinkError::UnsupportedBaud {
            port: "mem-a/mem-b".into(),
            baud,
        });
    }
    let (a, b) = End::pair(clock, ["mem-a", "mem-b"]);
    Ok((MemByteLink { end: a, baud }, MemByteLink { end: b, baud }))
}

impl MemByteLink {
    /// When the next character in flight towards this end arrives, if any.
    pub fn next_arrival(&self) -> Option<Instant> {
        self.end.next_arrival()
    }

    /// The pair's clock.
    pub fn virtual_clock(&self) -> &VirtualClock {
        &self.end.clock
    }
}

impl ByteLink for MemByteLink {
    fn port(&self) -> &str {
        &self.end.name
    }

    fn bus_id(&self) -> String {
        self.end.bus.clone()
    }

    fn baud(&self) -> u32 {
        self.baud
    }

    fn clock(&self) -> &dyn Clock {
        &self.end.clock
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        LinkError::check_seven_bit(&self.end.name, bytes)?;
        let baud = self.baud;
        self.end
            .send(bytes.iter().copied(), |i, _| wire_time(i + 1, baud));
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let mut n = 0;
        let max = buf.len();
        self.end.recv(deadline, max, |byte| {
            if let Some(slot) = buf.get_mut(n) {
                *slot = byte;
                n += 1;
            }
        });
        Ok(n)
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.end.discard_arrived();
        Ok(())
    }

    fn flush(&mut self) -> Result<(), LinkError> {
        // `send` already returns when the last character is through.
        Ok(())
    }

    /// This end sends at `baud` from now on (the other end keeps its own
    /// rate; the in-memory line does not garble a mismatch).
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(LinkError::UnsupportedBaud {
                port: self.end.name.clone(),
                baud,
            });
        }
        self.baud = baud;
        Ok(())
    }
}
/// One end of an in-memory CAN bus between two nodes (see the module docs
/// for timing).
#[derive(Debug)]
pub struct MemFrameLink {
    end: End<CanFrame>,
    bitrate: u32,
}
/// Two connected ends of an in-memory CAN bus at `bitrate` (one of
/// [`ALLOWED_BITRATES`]) on `clock`, named `mem-can-a` and `mem-can-b`.
pub fn frame_pair(
    clock: &VirtualClock,
    bitrate: u32,
) -> Result<(MemFrameLink, MemFrameLink), LinkError> {
    if !ALLOWED_BITRATES.contains(&bitrate) {
        return Err(LinkError::UnsupportedBitrate {
            port: "mem-can-a/mem-can-b".into(),
            bitrate,
        });
    }
    let (a, b) = End::pair(clock, ["mem-can-a", "mem-can-b"]);
    Ok((
        MemFrameLink { end: a, bitrate },
        MemFrameLink { end: b, bitrate },
    ))
}
impl MemFrameLink {
    /// When the next frame in flight towards this end arrives, if any.
    pub fn next_arrival(&self) -> Option<Instant> {
        self.end.next_arrival()
    }

    /// The pair's clock.
    pub fn virtual_clock(&self) -> &VirtualClock {
        &self.end.clock
    }
}
impl FrameLink for MemFrameLink {
    fn port(&self) -> &str {
        &self.end.name
    }

    fn bus_id(&self) -> String {
        self.end.bus.clone()
    }

    fn bitrate(&self) -> u32 {
        self.bitrate
    }

    fn clock(&self) -> &dyn Clock {
        &self.end.clock
    }

    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let time =
            can_frame_time(frame, self.bitrate).map_err(|source| LinkError::InvalidFrame {
                port: self.end.name.clone(),
                source,
            })?;
        self.end.send([*frame], |_, _| time);
        Ok(())
    }

    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        let mut got = None;
        self.end.recv(deadline, 1, |frame| got = Some(frame));
        Ok(got)
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.end.discard_arrived();
        Ok(())
    }
}
