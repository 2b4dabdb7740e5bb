//! The simulated RS-485 line (LUSTBUS, LECOM-A/B): owns [`ByteLine`], the
//! clock-free core that feeds host characters to the drives, schedules
//! their replies, applies fault injection and writes the event log, and
//! [`SimByteBus`], the core on a [`VirtualClock`] behind
//! [`driveset_link::ByteLink`]. `crate::serve` runs the same core in real
//! time on a pty or a TCP socket.
//!
//! # Timing (virtual bus)
//!
//! Exactly the semantics of [`driveset_link::mem`]: a host `send` starts
//! when the host is free (`max(now, end of its previous send)`), takes
//! [`wire_time`]`(n, baud)` and returns with the clock at its end.
//! Character `i` ends at `start + wire_time(i + 1, baud)`; at that instant
//! every drive hears it ([`ByteDrive::hear`]). A drive that answers
//! (`Heard::Telegram { reply: Some(r) }`) starts its reply at
//! `end of the character that completed the telegram + r.reaction`, or
//! when its own previous reply has left the line if that is later; reply
//! character `k` arrives at `reply start + wire_time(k + 1, drive baud)`.
//! `recv` moves the clock to the first arrival and returns every character
//! arrived by then; with nothing by the deadline it moves the clock to the
//! deadline and returns 0.
//!
//! # What the model leaves out, on purpose
//!
//! - Drives hear only the host, never each other's replies (on a real
//!   RS-485 line they would, and would discard them as non-telegrams).
//! - The host and the drives' directions are independent, as in
//!   [`driveset_link::mem`]: a host that talks over a reply does not
//!   corrupt it.
//! - Collisions: when characters of two drives' replies overlap in time
//!   (address 0 / group telegrams with several drives on the line, drives
//!   sharing an address such as factory-fresh ones, `crate::factory`), the
//!   line carries the AND of both (a low bit wins, as the start bit does)
//!   and the host samples each data bit in the middle of its bit time of
//!   the character already on the line: aligned characters give the
//!   bitwise AND of both, characters shifted by a bit or more the bits of
//!   the shifted one where they fall. The later character is swallowed
//!   into every character it overlaps. The result is garbage,
//!   deliberately.
//! - Baud: each drive keeps its own rate (changed through
//!   [`ByteDrive::take_baud_change`], effective once the reply that
//!   announced it has left the line). A drive whose rate differs from the
//!   host's hears every host character with a parity error (the character
//!   XOR 0x2A), and the host receives its reply characters XOR 0x2A
//!   (framing garbage); the log marks both `baud-mismatch`.

use std::collections::VecDeque;
use std::time::Duration;

use driveset_link::mem::wire_time;
use driveset_link::spec::ALLOWED_BAUDS;
use driveset_link::{ByteLink, Clock, Instant, LinkError, VirtualClock};
use serde_json::json;

use crate::drive::{ByteDrive, Heard, Reply};
use crate::faults::{
    Action, CableWindows, FaultInjector, FaultPlan, ReplyFault, Schedule, Scheduled,
};
use crate::log::{Dir, Event, EventLog, MASKED, MaskProtocol, SecretMask, hex};

mod clocked;

pub use clocked::SimByteBus;

/// What a byte that crossed a rate mismatch turns into.
const MISMATCH_XOR: u8 = 0x2A;

/// Why a simulated bus could not be built or reconfigured.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum BusError {
    /// A line rate the link layer does not support.
    #[error("{baud} baud is not supported on a simulated 7E1 line; use one of {allowed}")]
    UnsupportedBaud {
        /// The rejected rate.
        baud: u32,
        /// The supported rates.
        allowed: String,
    },
    /// A CAN bit rate the link layer does not support.
    #[error("CAN bit rate {bitrate} is not supported on a simulated bus; use one of {allowed}")]
    UnsupportedBitrate {
        /// The rejected rate.
        bitrate: u32,
        /// The supported rates.
        allowed: String,
    },
    /// Two drives with the same address on one bus.
    #[error(
        "two drives at address {address} on one bus ({first} and {second}): give every drive its own address"
    )]
    DuplicateAddress {
        /// The address.
        address: u8,
        /// Family of the first drive.
        first: &'static str,
        /// Family of the second drive.
        second: &'static str,
    },
}

pub(crate) fn list(values: &[u32]) -> String {
    values
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// One drive's entry in a state dump: family, address, schema, fingerprint
/// and canonical text of `state`.
pub fn drive_dump(
    family: &str,
    address: u8,
    state: &driveset_schema::canonical::ResolvedSet,
) -> serde_json::Value {
    json!({
        "family": family,
        "address": address,
        "schema": state.schema,
        "fingerprint": state.fingerprint(),
        "canonical": state.canonical_with_secrets(),
    })
}

/// Per-drive line state.
#[derive(Debug, Clone)]
struct Slot {
    /// The drive's current rate.
    baud: u32,
    /// A rate change and the instant it takes effect.
    pending_baud: Option<(Instant, u32)>,
    /// When the drive's transmitter is free again.
    busy_until: Instant,
}

/// A character on its way to the host.
#[derive(Debug, Clone, Copy)]
struct Flight {
    /// End of its stop bit.
    at: Instant,
    byte: u8,
    /// Index of the sending drive; `None` for line noise.
    from: Option<usize>,
    /// Its duration on the line.
    char_time: Duration,
}

/// The level a 7E1 character `c` puts on the line at `t` (true = idle /
/// mark): start bit low, 7 data bits LSB first, even parity, stop bit high.
fn level(c: &Flight, t: Instant) -> bool {
    let start = c.at - c.char_time;
    let bit = (c.char_time.as_nanos() / 10).max(1);
    if t < start || t >= c.at {
        return true;
    }
    match (t - start).as_nanos() / bit {
        0 => false,
        k @ 1..=7 => (c.byte >> (k - 1)) & 1 == 1,
        8 => c.byte.count_ones() % 2 == 1,
        _ => true,
    }
}

/// What the host reads in the window of `e` when `f` overlaps it: each
/// data bit sampled mid-bit from the AND of both characters' levels.
fn sampled(e: &Flight, f: &Flight) -> u8 {
    let start = e.at - e.char_time;
    let bit = e.char_time / 10;
    (0..7u32).fold(0u8, |byte, i| {
        let t = start + bit * (i + 1) + bit / 2;
        if level(e, t) && level(f, t) {
            byte | (1 << i)
        } else {
            byte
        }
    })
}

/// The clock-free core of a simulated character line: drives, reply
/// scheduling, faults, log. Every method takes the instants it works at;
/// [`SimByteBus`] feeds it virtual time, `crate::serve` real time.
#[derive(Debug)]
pub struct ByteLine {
    drives: Vec<Box<dyn ByteDrive>>,
    slots: Vec<Slot>,
    baud: u32,
    faults: FaultInjector,
    schedule: Schedule,
    cables: CableWindows,
    log: EventLog,
    /// Masks the drives' secrets in what the log records.
    mask: SecretMask,
    origin: Instant,
    started: bool,
    telegrams: u64,
    in_flight: VecDeque<Flight>,
}

impl ByteLine {
    /// A line at `baud` (one of [`ALLOWED_BAUDS`]) with `drives` on it,
    /// no faults, no log, bus start at [`Instant::ZERO`].
    pub fn new(baud: u32, drives: Vec<Box<dyn ByteDrive>>) -> Result<Self, BusError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(BusError::UnsupportedBaud {
                baud,
                allowed: list(ALLOWED_BAUDS),
            });
        }
        for (i, a) in drives.iter().enumerate() {
            if let Some(b) = drives[..i].iter().find(|b| b.address() == a.address()) {
                return Err(BusError::DuplicateAddress {
                    address: a.address(),
                    first: b.family(),
                    second: a.family(),
                });
            }
        }
        ByteLine::sharing_addresses(baud, drives)
    }

    /// A line as [`ByteLine::new`] on which drives may share an address
    /// (factory-fresh drives, `crate::factory`): a telegram to it is
    /// answered by all of them at once, and their replies collide.
    pub fn sharing_addresses(baud: u32, drives: Vec<Box<dyn ByteDrive>>) -> Result<Self, BusError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(BusError::UnsupportedBaud {
                baud,
                allowed: list(ALLOWED_BAUDS),
            });
        }
        let slots = drives
            .iter()
            .map(|_| Slot {
                baud,
                pending_baud: None,
                busy_until: Instant::ZERO,
            })
            .collect();
        let protocol = if drives.iter().any(|d| d.family() == "tmd") {
            MaskProtocol::Lecom
        } else {
            MaskProtocol::Lustbus
        };
        let mask = SecretMask::new(
            protocol,
            drives.iter().flat_map(|d| d.secret_codes()).collect(),
        );
        Ok(ByteLine {
            drives,
            mask,
            slots,
            baud,
            faults: FaultInjector::none(),
            schedule: Schedule::default(),
            cables: CableWindows::default(),
            log: EventLog::off(),
            origin: Instant::ZERO,
            started: false,
            telegrams: 0,
            in_flight: VecDeque::new(),
        })
    }

    /// Inject the faults of `plan`, seeded from its seed or `run_seed`.
    pub fn with_faults(mut self, plan: FaultPlan, run_seed: u64) -> Self {
        self.schedule = Schedule::new(&plan);
        self.faults = FaultInjector::new(plan, run_seed);
        self
    }

    /// Record every telegram and fault in `log`.
    pub fn with_log(mut self, log: EventLog) -> Self {
        self.log = log;
        self
    }

    /// The instant the bus started: time-triggered faults count from it.
    pub fn set_origin(&mut self, origin: Instant) {
        self.origin = origin;
        self.started = true;
    }

    /// Set the bus start to `now` unless it has been set already.
    pub fn ensure_started(&mut self, now: Instant) {
        if !self.started {
            self.set_origin(now);
        }
    }

    /// The host's line rate.
    pub fn baud(&self) -> u32 {
        self.baud
    }

    /// The rate drive `address` runs at now.
    pub fn drive_baud(&self, address: u8) -> Option<u32> {
        let i = self.index_of(address)?;
        self.slots.get(i).map(|s| s.baud)
    }

    /// Run drive number `index` (in the order given) at `baud` from the
    /// start (a factory-fresh drive at 9600 on a line the host opens at
    /// another rate).
    pub fn set_drive_baud(&mut self, index: usize, baud: u32) {
        if let Some(slot) = self.slots.get_mut(index) {
            slot.baud = baud;
        }
    }

    /// Switch the host side to a new rate (the host reopened its port).
    pub fn set_baud(&mut self, baud: u32) -> Result<(), BusError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(BusError::UnsupportedBaud {
                baud,
                allowed: list(ALLOWED_BAUDS),
            });
        }
        self.baud = baud;
        Ok(())
    }

    /// Host telegrams counted so far (one per character that completed a
    /// telegram for at least one drive).
    pub fn telegrams(&self) -> u64 {
        self.telegrams
    }

    /// The event log.
    pub fn log(&self) -> &EventLog {
        &self.log
    }

    /// The fault plan in force.
    pub fn fault_plan(&self) -> &FaultPlan {
        self.faults.plan()
    }

    /// The drives, in the order given.
    pub fn drives(&self) -> &[Box<dyn ByteDrive>] {
        &self.drives
    }

    fn index_of(&self, address: u8) -> Option<usize> {
        self.drives.iter().position(|d| d.address() == address)
    }

    /// The drive at `address`, for tests and pokes.
    pub fn drive_mut(&mut self, address: u8) -> Option<&mut (dyn ByteDrive + 'static)> {
        let i = self.index_of(address)?;
        self.drives.get_mut(i).map(|d| &mut **d)
    }

    /// Give the drives back (the CLI dumps their state after serving).
    pub fn into_drives(self) -> Vec<Box<dyn ByteDrive>> {
        self.drives
    }

    /// Every drive's family, address, schema, fingerprint and canonical
    /// state, as JSON: `{"baud":..,"telegrams":..,"drives":[..]}`.
    pub fn state_dump(&self) -> serde_json::Value {
        let drives: Vec<_> = self
            .drives
            .iter()
            .map(|d| drive_dump(d.family(), d.address(), &d.state()))
            .collect();
        json!({ "baud": self.baud, "telegrams": self.telegrams, "drives": drives })
    }

    /// When the next time-triggered fault is due.
    pub fn next_event(&self) -> Option<Instant> {
        self.schedule.next_time().map(|d| self.origin + d)
    }

    /// When the next character reaches the host.
    pub fn next_arrival(&self) -> Option<Instant> {
        self.in_flight.front().map(|f| f.at)
    }

    /// The earlier of [`ByteLine::next_arrival`] and
    /// [`ByteLine::next_event`]: when a driver of this line must look again.
    pub fn next_wakeup(&self) -> Option<Instant> {
        match (self.next_arrival(), self.next_event()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Fire every time-triggered fault due by `now`, at its own instant.
    pub fn advance(&mut self, now: Instant) {
        for slot in &mut self.slots {
            if let Some((from, b)) = slot.pending_baud
                && from <= now
            {
                slot.baud = b;
                slot.pending_baud = None;
            }
        }
        if now < self.origin {
            return;
        }
        for ev in self.schedule.take_due(now - self.origin) {
            let at = match ev.at {
                crate::faults::Trigger::Time(d) => self.origin + d,
                crate::faults::Trigger::Telegram(_) => now,
            };
            self.apply(ev, at);
        }
    }

    /// Cut the power of the drive at `address` (every drive: `None`) at
    /// `at` for `off`, as the fault `power-cycle@..` does: RAM values
    /// lost, the rate its rate code holds active after the restart.
    pub fn power_cycle(&mut self, at: Instant, address: Option<u8>, off: Duration) {
        self.apply(
            Scheduled {
                at: crate::faults::Trigger::Time(Duration::ZERO),
                action: Action::PowerCycle { addr: address, off },
            },
            at,
        );
    }

    /// Copy characters arrived by `now` into `buf`; returns the count.
    pub fn take_arrived(&mut self, now: Instant, buf: &mut [u8]) -> usize {
        let mut n = 0;
        while n < buf.len() {
            match self.in_flight.front() {
                Some(f) if f.at <= now => {}
                _ => break,
            }
            if let (Some(f), Some(slot)) = (self.in_flight.pop_front(), buf.get_mut(n)) {
                *slot = f.byte;
                n += 1;
            }
        }
        n
    }

    /// Drop characters arrived by `now` and not yet taken.
    pub fn discard_arrived(&mut self, now: Instant) {
        while self.in_flight.front().is_some_and(|f| f.at <= now) {
            self.in_flight.pop_front();
        }
    }

    /// The host puts `bytes` on the line starting at `start`, paced at the
    /// line's rate: character `i` ends at `start + wire_time(i + 1, baud)`
    /// (virtual bus). Returns the end of the transmission.
    pub fn host_send_paced(&mut self, start: Instant, bytes: &[u8]) -> Instant {
        self.host_send(start, bytes, true)
    }

    /// The host puts `bytes` on the line at once: every character counts as
    /// ended at `start` (real-time serving: the bytes have already crossed
    /// the pty or socket). Returns the end of the transmission, `start`.
    pub fn host_send_at_once(&mut self, start: Instant, bytes: &[u8]) -> Instant {
        self.host_send(start, bytes, false)
    }

    /// [`ByteLine::host_send_paced`] (`paced`) or
    /// [`ByteLine::host_send_at_once`].
    fn host_send(&mut self, start: Instant, bytes: &[u8], paced: bool) -> Instant {
        let end_of = |i: usize, baud: u32| {
            if paced {
                start + wire_time(i + 1, baud)
            } else {
                start
            }
        };
        let n = bytes.len();
        let end = if n == 0 {
            start
        } else {
            end_of(n - 1, self.baud)
        };
        self.advance(start);
        let flip = self.faults.host_flip(n);
        let garbage = self.faults.garbage();
        let logged = self.mask.apply(Dir::Host, bytes);
        let mut line = Event::bytes(start.as_nanos(), Dir::Host, None, &logged);
        if let Some(f) = flip
            && let Some(&b) = bytes.get(f.index)
        {
            let heard = (b ^ (1 << f.bit)) & 0x7F;
            // a masked character stays masked in the fault's detail too
            let heard = if logged.get(f.index) == Some(&MASKED) && b != MASKED {
                "a masked character".to_string()
            } else {
                format!("0x{heard:02X}")
            };
            line = line.with_fault(
                "flip",
                format!(
                    "character {} bit {}: the drives heard {heard} with a parity error",
                    f.index, f.bit
                ),
            );
        }
        self.log.push(line);
        if let Some(g) = &garbage {
            self.log.push(
                Event::bytes(end.as_nanos(), Dir::Event, None, g).with_fault(
                    "garbage",
                    "noise towards the host, right after the host telegram",
                ),
            );
        }
        let mut lost_to_cable = 0usize;
        for (i, &raw) in bytes.iter().enumerate() {
            let t = end_of(i, self.baud);
            self.advance(t);
            if self.cables.down(t) {
                lost_to_cable += 1;
                continue;
            }
            let raw = raw & 0x7F;
            let (byte, parity_ok) = match flip {
                Some(f) if f.index == i => ((raw ^ (1 << f.bit)) & 0x7F, false),
                _ => (raw, true),
            };
            self.hear_all(t, byte, parity_ok);
        }
        if lost_to_cable > 0 {
            self.log.push(Event::note(
                start.as_nanos(),
                None,
                "cable",
                format!("{lost_to_cable} of {n} host characters did not reach the drives"),
            ));
        }
        if let Some(g) = garbage {
            let ct = wire_time(1, self.baud);
            for (k, &b) in g.iter().enumerate() {
                let at = end + wire_time(k + 1, self.baud);
                if !self.cables.down(at) {
                    self.insert_flight(Flight {
                        at,
                        byte: b,
                        from: None,
                        char_time: ct,
                    });
                }
            }
        }
        end
    }

    /// Hand one character to every drive at `t`.
    fn hear_all(&mut self, t: Instant, byte: u8, parity_ok: bool) {
        let mut telegram = false;
        let mut replies: Vec<(usize, Reply)> = Vec::new();
        let host_baud = self.baud;
        for (j, (drive, slot)) in self.drives.iter_mut().zip(&self.slots).enumerate() {
            let (b, ok) = if slot.baud == host_baud {
                (byte, parity_ok)
            } else {
                ((byte ^ MISMATCH_XOR) & 0x7F, false)
            };
            if let Heard::Telegram { reply } = drive.hear(t, b, ok) {
                telegram = true;
                if let Some(r) = reply {
                    replies.push((j, r));
                }
            }
        }
        for (j, r) in replies {
            self.schedule_reply(j, t, r);
        }
        // Rate changes take effect once the announcing reply has left.
        for (drive, slot) in self.drives.iter_mut().zip(&mut self.slots) {
            if let Some(b) = drive.take_baud_change() {
                let from = slot.busy_until.max(t);
                slot.pending_baud = Some((from, b));
                let addr = drive.address();
                self.log.push(Event::note(
                    from.as_nanos(),
                    Some(addr),
                    "baud-change",
                    format!("drive {addr} runs at {b} baud from here"),
                ));
            }
        }
        if telegram {
            self.telegrams += 1;
            for ev in self.schedule.take_telegram(self.telegrams) {
                self.apply(ev, t);
            }
        }
    }

    /// Put drive `j`'s reply to a telegram that ended at `t` on the line.
    fn schedule_reply(&mut self, j: usize, t: Instant, reply: Reply) {
        let Some(slot) = self.slots.get(j) else {
            return;
        };
        let addr = self.drives.get(j).map(|d| d.address());
        let dbaud = slot.baud;
        let start = (t + reply.reaction).max(slot.busy_until);
        let original: Vec<u8> = reply.bytes.iter().map(|b| b & 0x7F).collect();
        let len = original.len();
        if let Some(slot) = self.slots.get_mut(j) {
            slot.busy_until = start + wire_time(len, dbaud);
        }
        let mut bytes = original.clone();
        let logged = self.mask.apply(Dir::Drive, &original);
        let masked_at =
            |k: usize| logged.get(k) == Some(&MASKED) && original.get(k) != Some(&MASKED);
        let mut line = Event::bytes(start.as_nanos(), Dir::Drive, addr, &logged);
        match self.faults.reply(len) {
            ReplyFault::None => {}
            ReplyFault::Lose => {
                bytes.clear();
                line = line.with_fault("lose", "the reply did not reach the host");
            }
            ReplyFault::Truncate { keep } => {
                bytes.truncate(keep);
                line = line.with_fault(
                    "truncate",
                    format!("only the first {keep} of {len} characters reached the host"),
                );
            }
            ReplyFault::Flip(f) => {
                if let Some(b) = bytes.get_mut(f.index) {
                    let was = *b;
                    *b = (was ^ (1 << f.bit)) & 0x7F;
                    let detail = if masked_at(f.index) {
                        format!(
                            "character {} bit {}: the host got a masked character changed",
                            f.index, f.bit
                        )
                    } else {
                        format!(
                            "character {} bit {}: the host got 0x{:02X} instead of 0x{was:02X}",
                            f.index, f.bit, *b
                        )
                    };
                    line = line.with_fault("flip", detail);
                }
            }
        }
        if dbaud != self.baud {
            for b in &mut bytes {
                *b = (*b ^ MISMATCH_XOR) & 0x7F;
            }
            if line.fault.is_none() {
                line = line.with_fault(
                    "baud-mismatch",
                    format!(
                        "drive sends at {dbaud} baud, host listens at {}: the host got {}",
                        self.baud,
                        hex(&bytes
                            .iter()
                            .enumerate()
                            .map(|(k, &b)| if masked_at(k) { MASKED } else { b })
                            .collect::<Vec<u8>>())
                    ),
                );
            }
        }
        self.log.push(line);
        let ct = wire_time(1, dbaud);
        let (mut collided, mut cut) = (0usize, 0usize);
        for (k, &b) in bytes.iter().enumerate() {
            let at = start + wire_time(k + 1, dbaud);
            if self.cables.down(at) {
                cut += 1;
                continue;
            }
            if self.insert_flight(Flight {
                at,
                byte: b,
                from: Some(j),
                char_time: ct,
            }) {
                collided += 1;
            }
        }
        if collided > 0 {
            self.log.push(Event::note(
                start.as_nanos(),
                addr,
                "collision",
                format!(
                    "{collided} characters overlapped another drive's reply: the host got the AND of each overlapping pair"
                ),
            ));
        }
        if cut > 0 {
            self.log.push(Event::note(
                start.as_nanos(),
                addr,
                "cable",
                format!("{cut} reply characters did not reach the host"),
            ));
        }
    }

    /// Queue a character towards the host, colliding with an overlapping
    /// character of another drive. Returns whether it collided.
    fn insert_flight(&mut self, f: Flight) -> bool {
        if let Some(src) = f.from {
            let begin = f.at - f.char_time;
            let mut merged = false;
            for e in self.in_flight.iter_mut() {
                let other = matches!(e.from, Some(o) if o != src);
                if other && e.at - e.char_time < f.at && begin < e.at {
                    e.byte = sampled(e, &f);
                    merged = true;
                }
            }
            if merged {
                return true;
            }
        }
        let pos = self.in_flight.partition_point(|e| e.at <= f.at);
        self.in_flight.insert(pos, f);
        false
    }

    /// Carry out a scheduled fault at `at`.
    fn apply(&mut self, ev: Scheduled, at: Instant) {
        match ev.action {
            Action::PowerCycle { addr, off } => {
                let targets: Vec<usize> = (0..self.drives.len())
                    .filter(|&j| addr.is_none_or(|a| self.drives[j].address() == a))
                    .collect();
                if targets.is_empty() {
                    self.log.push(Event::note(
                        at.as_nanos(),
                        addr,
                        "power-cycle",
                        format!(
                            "no drive at address {} on this bus: nothing happened",
                            addr.map_or_else(|| "any".to_string(), |a| a.to_string())
                        ),
                    ));
                }
                for j in targets {
                    let a = self.drives[j].address();
                    self.drives[j].power_cycle(at, off);
                    // A restart activates the rate its rate code holds
                    // (LUSTBUS 11.5): the drive boots at that rate.
                    let change = self.drives[j].take_baud_change();
                    if let Some(slot) = self.slots.get_mut(j) {
                        slot.busy_until = slot.busy_until.min(at);
                        if let Some(b) = change {
                            slot.pending_baud = Some((at, b));
                            self.log.push(Event::note(
                                at.as_nanos(),
                                Some(a),
                                "baud-change",
                                format!("drive {a} runs at {b} baud from here (restart)"),
                            ));
                        }
                    }
                    self.in_flight.retain(|f| !(f.from == Some(j) && f.at > at));
                    self.log.push(Event::note(
                        at.as_nanos(),
                        Some(a),
                        "power-cycle",
                        format!(
                            "power off for {}; a reply still on the line is cut",
                            crate::faults::format_duration(off)
                        ),
                    ));
                }
            }
            Action::Cable { duration } => {
                let until = self.cables.pull_logged(at, duration, &self.log);
                self.in_flight.retain(|f| !(at <= f.at && f.at < until));
            }
        }
    }
}
