//! The simulated CAN bus (Lenze system bus): owns [`FrameLine`], the
//! clock-free core (drives, arbitration, faults, log), and [`SimCanBus`],
//! the core on a [`VirtualClock`] behind [`driveset_link::FrameLink`]. The
//! core's methods are public so an slcan server on a pty can drive it in
//! real time the way `crate::serve` drives [`crate::bus::ByteLine`].
//!
//! # Timing
//!
//! One bus, one frame at a time. A frame occupies the bus for
//! [`can_frame_time`] (the proto crate's exact bit count at the bit rate).
//! The host's frame starts at `max(now, bus free)`; every node hears it at
//! its end ([`FrameDrive::hear`]; nodes never hear each other's answers). A
//! node's answer is ready at `end + reaction` and starts when the bus is
//! free; answers ready at the same instant (or waiting for the bus
//! together) go in identifier order, lowest first, as arbitration decides;
//! a host frame waiting at the same instant takes part in the same
//! arbitration. `recv` returns the next frame that has arrived, moving the
//! clock to its arrival, or moves the clock to the deadline.
//!
//! Faults ([`crate::faults`]): `flip` makes a frame's first attempt fail
//! with an error frame ([`ERROR_FRAME_BITS`] bit times) and go again, so it
//! arrives one frame time and an error frame later; `lose` drops a node's
//! answer; power cycles and pulled cables as on the byte bus; every host
//! frame counts as a telegram. `truncate` and `garbage` do not apply.

use std::collections::VecDeque;
use std::time::Duration;

use driveset_link::mem::{bits_time, can_frame_time};
use driveset_link::spec::ALLOWED_BITRATES;
use driveset_link::{CanFrame, Clock, FrameLink, Instant, LinkError, VirtualClock};
use serde_json::json;

use crate::bus::{BusError, drive_dump, list};
use crate::drive::FrameDrive;
use crate::faults::{Action, CableWindows, FaultInjector, FaultPlan, Schedule, Scheduled, Trigger};
use crate::log::{Dir, Event, EventLog};

/// Bit times an error frame takes: 6-bit error flag, 8-bit delimiter,
/// 3-bit intermission (error flags of other nodes overlap the first).
pub const ERROR_FRAME_BITS: u128 = 17;

/// A frame as candump prints it: `601#4018100000000000`, `601#R`.
pub fn candump(frame: &CanFrame) -> String {
    let id = if frame.extended {
        format!("{:08X}", frame.id)
    } else {
        format!("{:03X}", frame.id)
    };
    if frame.rtr {
        return format!("{id}#R");
    }
    let data: String = frame.payload().iter().map(|b| format!("{b:02X}")).collect();
    format!("{id}#{data}")
}

fn frame_event(t: Instant, dir: Dir, addr: Option<u8>, frame: &CanFrame) -> Event {
    let mut e = Event::bytes(t.as_nanos(), dir, addr, frame.payload());
    e.text = candump(frame);
    e
}

/// Arbitration priority: base identifier first, then standard before
/// extended, then the full identifier.
fn priority(frame: &CanFrame) -> (u32, bool, u32) {
    let base = if frame.extended {
        frame.id >> 18
    } else {
        frame.id
    };
    (base, frame.extended, frame.id)
}

#[derive(Debug, Clone)]
struct Pending {
    ready: Instant,
    frame: CanFrame,
    from: usize,
    flip: bool,
}

#[derive(Debug, Clone, Copy)]
struct Flight {
    at: Instant,
    frame: CanFrame,
    from: usize,
}

/// The clock-free core of a simulated CAN bus.
#[derive(Debug)]
pub struct FrameLine {
    drives: Vec<Box<dyn FrameDrive>>,
    bitrate: u32,
    faults: FaultInjector,
    schedule: Schedule,
    cables: CableWindows,
    log: EventLog,
    origin: Instant,
    telegrams: u64,
    bus_free: Instant,
    pending: Vec<Pending>,
    in_flight: VecDeque<Flight>,
}

impl FrameLine {
    /// A bus at `bitrate` (one of [`ALLOWED_BITRATES`]) with `drives`.
    pub fn new(bitrate: u32, drives: Vec<Box<dyn FrameDrive>>) -> Result<Self, BusError> {
        if !ALLOWED_BITRATES.contains(&bitrate) {
            return Err(BusError::UnsupportedBitrate {
                bitrate,
                allowed: list(ALLOWED_BITRATES),
            });
        }
        for (i, a) in drives.iter().enumerate() {
            if let Some(b) = drives[..i].iter().find(|b| b.node_id() == a.node_id()) {
                return Err(BusError::DuplicateAddress {
                    address: a.node_id(),
                    first: b.family(),
                    second: a.family(),
                });
            }
        }
        Ok(FrameLine {
            drives,
            bitrate,
            faults: FaultInjector::none(),
            schedule: Schedule::default(),
            cables: CableWindows::default(),
            log: EventLog::off(),
            origin: Instant::ZERO,
            telegrams: 0,
            bus_free: Instant::ZERO,
            pending: Vec::new(),
            in_flight: VecDeque::new(),
        })
    }

    /// Inject the faults of `plan`.
    pub fn with_faults(mut self, plan: FaultPlan, run_seed: u64) -> Self {
        self.schedule = Schedule::new(&plan);
        self.faults = FaultInjector::new(plan, run_seed);
        self
    }

    /// Record into `log`.
    pub fn with_log(mut self, log: EventLog) -> Self {
        self.log = log;
        self
    }

    /// The instant the bus started (time-triggered faults count from it).
    pub fn set_origin(&mut self, origin: Instant) {
        self.origin = origin;
    }

    /// The bit rate.
    pub fn bitrate(&self) -> u32 {
        self.bitrate
    }

    /// Host frames so far.
    pub fn telegrams(&self) -> u64 {
        self.telegrams
    }

    /// The event log.
    pub fn log(&self) -> &EventLog {
        &self.log
    }

    /// The nodes, in the order given.
    pub fn drives(&self) -> &[Box<dyn FrameDrive>] {
        &self.drives
    }

    /// The node with `node_id`.
    pub fn drive_mut(&mut self, node_id: u8) -> Option<&mut (dyn FrameDrive + 'static)> {
        self.drives
            .iter_mut()
            .find(|d| d.node_id() == node_id)
            .map(|d| &mut **d)
    }

    /// Give the nodes back.
    pub fn into_drives(self) -> Vec<Box<dyn FrameDrive>> {
        self.drives
    }

    /// Every node's family, id, schema, fingerprint and canonical state.
    pub fn state_dump(&self) -> serde_json::Value {
        let drives: Vec<_> = self
            .drives
            .iter()
            .map(|d| drive_dump(d.family(), d.node_id(), &d.state()))
            .collect();
        json!({ "bitrate": self.bitrate, "telegrams": self.telegrams, "drives": drives })
    }

    fn frame_time(&self, frame: &CanFrame, flip: bool) -> Option<Duration> {
        let t = can_frame_time(frame, self.bitrate).ok()?;
        Some(if flip {
            t + bits_time(ERROR_FRAME_BITS, self.bitrate) + t
        } else {
            t
        })
    }

    /// Earliest start of a waiting answer.
    fn next_start(&self) -> Option<Instant> {
        self.pending
            .iter()
            .map(|p| p.ready.max(self.bus_free))
            .min()
    }

    /// When a driver must look again: next arrival, next answer to start,
    /// next time-triggered fault.
    pub fn next_wakeup(&self) -> Option<Instant> {
        [
            self.in_flight.front().map(|f| f.at),
            self.next_start(),
            self.schedule.next_time().map(|d| self.origin + d),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// When the next frame reaches the host (answers already on the bus).
    pub fn next_arrival(&self) -> Option<Instant> {
        self.in_flight.front().map(|f| f.at)
    }

    /// Fire due faults and put on the bus every answer that starts by
    /// `now`.
    pub fn advance(&mut self, now: Instant) {
        self.fire_due(now);
        self.arbitrate(now, None);
    }

    fn fire_due(&mut self, now: Instant) {
        if now < self.origin {
            return;
        }
        for ev in self.schedule.take_due(now - self.origin) {
            let at = match ev.at {
                Trigger::Time(d) => self.origin + d,
                Trigger::Telegram(_) => now,
            };
            self.apply(ev, at);
        }
    }

    /// Commit waiting answers in arbitration order while they start by
    /// `until`; with a host frame of identifier priority `host` waiting
    /// from `until`, stop where the host wins and return its start.
    fn arbitrate(&mut self, until: Instant, host: Option<(u32, bool, u32)>) -> Instant {
        loop {
            let host_start = until.max(self.bus_free);
            let Some(t) = self.next_start() else {
                return host_start;
            };
            if t > until && (host.is_none() || t > host_start) {
                return host_start;
            }
            // The best answer among those that can start at `t`.
            let best = self
                .pending
                .iter()
                .enumerate()
                .filter(|(_, p)| p.ready.max(self.bus_free) == t)
                .min_by_key(|(_, p)| (priority(&p.frame), p.from))
                .map(|(i, _)| i);
            let Some(i) = best else {
                return host_start;
            };
            if let Some(h) = host
                && t == host_start
                && h < priority(&self.pending[i].frame)
            {
                return host_start;
            }
            let p = self.pending.remove(i);
            let Some(ft) = self.frame_time(&p.frame, p.flip) else {
                self.log.push(
                    frame_event(t, Dir::Drive, self.node(p.from), &p.frame).with_fault(
                        "invalid-frame",
                        "the node's answer is not a valid CAN frame: dropped",
                    ),
                );
                continue;
            };
            let at = t + ft;
            self.bus_free = at;
            let mut ev = frame_event(t, Dir::Drive, self.node(p.from), &p.frame);
            if p.flip {
                ev = ev.with_fault("flip", "error frame, retransmitted");
            }
            if self.cables.down(at) {
                ev = ev.with_fault("cable", "the answer did not reach the host");
            } else {
                self.in_flight.push_back(Flight {
                    at,
                    frame: p.frame,
                    from: p.from,
                });
            }
            self.log.push(ev);
        }
    }

    fn node(&self, j: usize) -> Option<u8> {
        self.drives.get(j).map(|d| d.node_id())
    }

    /// The host sends `frame`, ready at `now`. Returns the instant it has
    /// left the bus, or the frame's error if it is not a valid frame.
    pub fn host_send(
        &mut self,
        now: Instant,
        frame: &CanFrame,
    ) -> Result<Instant, driveset_proto::can::FrameError> {
        let plain = can_frame_time(frame, self.bitrate)?;
        self.fire_due(now);
        let start = self.arbitrate(now, Some(priority(frame)));
        let flip = self.faults.frame_flip();
        let ft = if flip {
            plain + bits_time(ERROR_FRAME_BITS, self.bitrate) + plain
        } else {
            plain
        };
        let end = start + ft;
        self.bus_free = end;
        let mut ev = frame_event(start, Dir::Host, None, frame);
        if flip {
            ev = ev.with_fault("flip", "error frame, retransmitted");
        }
        self.log.push(ev);
        self.fire_due(end);
        if self.cables.down(end) {
            self.log.push(Event::note(
                end.as_nanos(),
                None,
                "cable",
                "the host frame did not reach the nodes",
            ));
            return Ok(end);
        }
        for j in 0..self.drives.len() {
            let Some(r) = self.drives[j].hear(end, frame) else {
                continue;
            };
            if self.faults.frame_lose() {
                self.log.push(
                    frame_event(end + r.reaction, Dir::Drive, self.node(j), &r.frame)
                        .with_fault("lose", "the node did not answer"),
                );
                continue;
            }
            let flip = self.faults.frame_flip();
            self.pending.push(Pending {
                ready: end + r.reaction,
                frame: r.frame,
                from: j,
                flip,
            });
        }
        self.telegrams += 1;
        for ev in self.schedule.take_telegram(self.telegrams) {
            self.apply(ev, end);
        }
        Ok(end)
    }

    /// Take the next frame arrived by `now`.
    pub fn take_arrived(&mut self, now: Instant) -> Option<CanFrame> {
        if self.in_flight.front().is_some_and(|f| f.at <= now) {
            self.in_flight.pop_front().map(|f| f.frame)
        } else {
            None
        }
    }

    /// Drop the frames arrived by `now`.
    pub fn discard_arrived(&mut self, now: Instant) {
        while self.in_flight.front().is_some_and(|f| f.at <= now) {
            self.in_flight.pop_front();
        }
    }

    fn apply(&mut self, ev: Scheduled, at: Instant) {
        match ev.action {
            Action::PowerCycle { addr, off } => {
                let mut hit = false;
                for j in 0..self.drives.len() {
                    let id = self.drives[j].node_id();
                    if addr.is_some_and(|a| a != id) {
                        continue;
                    }
                    hit = true;
                    self.drives[j].power_cycle(at, off);
                    self.pending.retain(|p| p.from != j);
                    self.in_flight.retain(|f| !(f.from == j && f.at > at));
                    self.log.push(Event::note(
                        at.as_nanos(),
                        Some(id),
                        "power-cycle",
                        format!(
                            "power off for {}; a waiting answer is dropped",
                            crate::faults::format_duration(off)
                        ),
                    ));
                }
                if !hit {
                    self.log.push(Event::note(
                        at.as_nanos(),
                        addr,
                        "power-cycle",
                        "no node with that id on this bus: nothing happened",
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

/// A simulated CAN bus on a [`VirtualClock`], the host side as a
/// [`FrameLink`].
#[derive(Debug)]
pub struct SimCanBus {
    line: FrameLine,
    clock: VirtualClock,
    name: String,
    /// [`FrameLink::bus_id`]; `None`: `sim:` and the name.
    bus_id: Option<String>,
}

impl SimCanBus {
    /// A bus at `bitrate` on `clock` with `drives`, named `sim-can`.
    pub fn new(
        clock: &VirtualClock,
        bitrate: u32,
        drives: Vec<Box<dyn FrameDrive>>,
    ) -> Result<Self, BusError> {
        Ok(Self::from_line(clock, FrameLine::new(bitrate, drives)?))
    }

    /// A bus around a configured core; it starts at the clock's instant.
    pub fn from_line(clock: &VirtualClock, mut line: FrameLine) -> Self {
        line.set_origin(clock.now());
        SimCanBus {
            line,
            clock: clock.clone(),
            name: "sim-can".into(),
            bus_id: None,
        }
    }

    /// Inject the faults of `plan`.
    pub fn with_faults(mut self, plan: FaultPlan, run_seed: u64) -> Self {
        self.line = self.line.with_faults(plan, run_seed);
        self
    }

    /// Record into `log`.
    pub fn with_log(mut self, log: EventLog) -> Self {
        self.line = self.line.with_log(log);
        self
    }

    /// Name the port.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// Give the bus its identity ([`FrameLink::bus_id`], default `sim:` and
    /// the port name): two buses with the same id are one bus to journals.
    pub fn with_bus_id(mut self, id: impl Into<String>) -> Self {
        self.bus_id = Some(id.into());
        self
    }

    /// The core.
    pub fn line(&self) -> &FrameLine {
        &self.line
    }

    /// The core, mutable.
    pub fn line_mut(&mut self) -> &mut FrameLine {
        &mut self.line
    }

    /// The nodes.
    pub fn drives(&self) -> &[Box<dyn FrameDrive>] {
        self.line.drives()
    }

    /// The node with `node_id`.
    pub fn drive_mut(&mut self, node_id: u8) -> Option<&mut (dyn FrameDrive + 'static)> {
        self.line.drive_mut(node_id)
    }

    /// See [`FrameLine::state_dump`].
    pub fn state_dump(&self) -> serde_json::Value {
        self.line.state_dump()
    }

    /// Give the nodes back.
    pub fn into_drives(self) -> Vec<Box<dyn FrameDrive>> {
        self.line.into_drives()
    }
}

impl FrameLink for SimCanBus {
    fn port(&self) -> &str {
        &self.name
    }

    fn bus_id(&self) -> String {
        self.bus_id
            .clone()
            .unwrap_or_else(|| format!("sim:{}", self.name))
    }

    fn bitrate(&self) -> u32 {
        self.line.bitrate()
    }

    fn clock(&self) -> &dyn Clock {
        &self.clock
    }

    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let end = self
            .line
            .host_send(self.clock.now(), frame)
            .map_err(|source| LinkError::InvalidFrame {
                port: self.name.clone(),
                source,
            })?;
        self.clock.sleep_until(end);
        Ok(())
    }

    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        loop {
            let now = self.clock.now();
            self.line.advance(now);
            if let Some(f) = self.line.take_arrived(now) {
                return Ok(Some(f));
            }
            match self.line.next_wakeup() {
                Some(t) if t > now && t <= deadline => self.clock.sleep_until(t),
                _ => {
                    self.clock.sleep_until(deadline);
                    self.line.advance(deadline);
                    return Ok(None);
                }
            }
        }
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        let now = self.clock.now();
        self.line.advance(now);
        self.line.discard_arrived(now);
        Ok(())
    }
}
