//! Owns the open simulated bus ([`SimLink`], [`SimBus`]): its byte and
//! frame handles, its drives by address and by slot, and saving its state
//! when the last handle drops.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use driveset_link::VirtualClock;
use driveset_link::{ByteLink, CanFrame, Clock, FrameLink, Instant, Link, LinkError};
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};

use super::config::*;
use super::state::*;
use super::{SIM_MIXED_LUSTBUS, SimOpenError, SimSpec, is_can};
use crate::bus::SimByteBus;
use crate::can_bus::SimCanBus;
use crate::catalog::Family;
use crate::factory::DriveSlot;
use crate::log::EventLog;

/// The bus behind a [`SimLink`].
#[derive(Debug)]
pub enum SimBus {
    /// A character line (LUSTBUS, LECOM).
    Bytes(SimByteBus),
    /// A CAN bus.
    Frames(SimCanBus),
}

#[derive(Debug)]
struct Shared {
    bus: Mutex<SimBus>,
    /// The bus's family ([`SimConfig::family`]).
    family: Family,
    /// Which of the port's drives are on the line, by slot, and the
    /// state of those that are not.
    line: LineDrives,
    /// A family name, or `lustbus` for a mixed LUSTBUS.
    name: &'static str,
    state: Option<PathBuf>,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, SimBus> {
        self.bus.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn dump(&self) -> StateDump {
        match &*self.lock() {
            SimBus::Bytes(b) => self.line.byte_line_dump(self.name, b.line()),
            SimBus::Frames(b) => self.line.frame_line_dump(self.name, b.line()),
        }
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        if let Some(path) = &self.state
            && let Err(e) = self.dump().write(path)
        {
            // Nobody is left to return the error to.
            eprintln!("warning: {e}");
        }
    }
}

/// An open simulated bus in virtual time: the host side as a byte or frame
/// link ([`SimLink::link`], [`SimLink::byte_link`],
/// [`SimLink::frame_link`]; every handle drives the same bus), plus the
/// drives ([`SimLink::state`], [`SimLink::poke`], [`SimLink::dump`]).
///
/// With a state file, the drives' state is written back when the last of
/// the `SimLink` and its handles is dropped (a failure then is printed as
/// a warning on stderr), or at once with [`SimLink::save`].
#[derive(Debug, Clone)]
pub struct SimLink {
    shared: Arc<Shared>,
    clock: VirtualClock,
    port: String,
}

/// Open the simulated bus a `sim://` port names, on `clock`: drives of the
/// family at the addresses, seed and faults from the options, state from
/// `state=` or [`super::STATE_DIR_ENV`]. No event log.
pub fn open_sim(spec: &SimSpec, clock: &VirtualClock) -> Result<SimLink, SimOpenError> {
    let config = SimConfig::from_spec(spec)?;
    let port = spec.to_string();
    open_sim_with(&config, clock, &port, EventLog::off())
}

/// Open a simulated bus from checked settings, named `port`, logging to
/// `log`.
pub fn open_sim_with(
    config: &SimConfig,
    clock: &VirtualClock,
    port: &str,
    log: EventLog,
) -> Result<SimLink, SimOpenError> {
    config.check()?;
    let id = config.bus_id();
    let (bus, line) = if is_can(config.family) {
        let (frames, line) = config.frame_line_drives(log)?;
        (
            SimBus::Frames(
                SimCanBus::from_line(clock, frames)
                    .with_name(port)
                    .with_bus_id(id),
            ),
            line,
        )
    } else {
        let (bytes, line) = config.byte_line_drives(log)?;
        (
            SimBus::Bytes(
                SimByteBus::from_line(clock, bytes)
                    .with_name(port)
                    .with_bus_id(id),
            ),
            line,
        )
    };
    Ok(SimLink {
        shared: Arc::new(Shared {
            bus: Mutex::new(bus),
            family: config.family,
            line,
            name: config.bus_name(),
            state: config.state.clone(),
        }),
        clock: clock.clone(),
        port: port.to_string(),
    })
}

impl SimLink {
    /// The family of the drives; on a mixed LUSTBUS the family of the
    /// first drive (see [`SimLink::families`], [`SimLink::family_of`]).
    pub fn family(&self) -> Family {
        self.shared.family
    }

    /// Every family on the bus, each once, in bus order.
    pub fn families(&self) -> Vec<Family> {
        let mut out = Vec::new();
        for f in self.shared.line.slots.iter().map(DriveSlot::family) {
            if !out.contains(&f) {
                out.push(f);
            }
        }
        out
    }

    /// The family of the drive at `address` now (its own address code,
    /// which the host may have changed; the first such drive when several
    /// share it).
    pub fn family_of(&self, address: u8) -> Option<Family> {
        let j = self.index_of(address)?;
        self.shared.line.slots.get(j).map(DriveSlot::family)
    }

    /// The line index of the first drive at `address` now.
    fn index_of(&self, address: u8) -> Option<usize> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.drives().iter().position(|d| d.address() == address),
            SimBus::Frames(b) => b.drives().iter().position(|d| d.node_id() == address),
        })
    }

    /// The slots ([`DriveSlot`]) of the drives on the line, in line order
    /// (as [`SimLink::addresses`]).
    pub fn slots(&self) -> Vec<DriveSlot> {
        self.shared.line.slots.clone()
    }

    /// The slots of the port's drives the line does not hold (the service
    /// bench's waiting or finished drives, [`crate::factory`]); their
    /// state is in [`SimLink::dump`].
    pub fn detached(&self) -> Vec<DriveSlot> {
        self.shared
            .line
            .detached
            .iter()
            .filter_map(|d| d.slot.as_deref().and_then(DriveSlot::parse))
            .collect()
    }

    /// The address the drive in `slot` has now, if it is on the line.
    pub fn address_of(&self, slot: &DriveSlot) -> Option<u8> {
        let j = self.shared.line.slots.iter().position(|s| s == slot)?;
        self.addresses().get(j).copied()
    }

    /// The state of the drive in `slot`, if it is on the line.
    pub fn state_of(&self, slot: &DriveSlot) -> Option<ResolvedSet> {
        let j = self.shared.line.slots.iter().position(|s| s == slot)?;
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.drives().get(j).map(|d| d.state()),
            SimBus::Frames(b) => b.drives().get(j).map(|d| d.state()),
        })
    }

    /// Whether this is a mixed LUSTBUS (`sim://lustbus`).
    pub fn is_mixed(&self) -> bool {
        self.shared.name == SIM_MIXED_LUSTBUS
    }

    /// The bus's name in state files: a family name or `lustbus`.
    pub fn bus_name(&self) -> &'static str {
        self.shared.name
    }

    /// The port name (`sim://...`).
    pub fn port(&self) -> &str {
        &self.port
    }

    /// Whether this is a CAN bus (use [`SimLink::frame_link`]).
    pub fn is_can(&self) -> bool {
        is_can(self.family())
    }

    /// The virtual clock the bus runs on.
    pub fn clock(&self) -> &VirtualClock {
        &self.clock
    }

    /// The state file, if any.
    pub fn state_file(&self) -> Option<&Path> {
        self.shared.state.as_deref()
    }

    /// The host side as a byte link (`None` on CAN).
    pub fn byte_link(&self) -> Option<Box<dyn ByteLink>> {
        (!self.is_can()).then(|| Box::new(SimByteHandle(self.clone())) as Box<dyn ByteLink>)
    }

    /// The host side as a frame link (`None` on a character line).
    pub fn frame_link(&self) -> Option<Box<dyn FrameLink>> {
        self.is_can()
            .then(|| Box::new(SimFrameHandle(self.clone())) as Box<dyn FrameLink>)
    }

    /// The host side as `driveset-link` hands out real transports.
    pub fn link(&self) -> Link {
        if self.is_can() {
            Link::Frames(Box::new(SimFrameHandle(self.clone())))
        } else {
            Link::Bytes(Box::new(SimByteHandle(self.clone())))
        }
    }

    /// Work on the bus itself (drives, log, faults) under its lock.
    pub fn with_bus<R>(&self, f: impl FnOnce(&mut SimBus) -> R) -> R {
        f(&mut self.shared.lock())
    }

    /// Work on a character line's bus under its lock; a CAN bus is the
    /// wrong kind for a [`ByteLink`].
    fn with_bytes<R>(
        &self,
        f: impl FnOnce(&mut SimByteBus) -> Result<R, LinkError>,
    ) -> Result<R, LinkError> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => f(b),
            SimBus::Frames(_) => Err(wrong_kind(&self.port)),
        })
    }

    /// Work on a CAN bus under its lock; a character line is the wrong
    /// kind for a [`FrameLink`].
    fn with_frames<R>(
        &self,
        f: impl FnOnce(&mut SimCanBus) -> Result<R, LinkError>,
    ) -> Result<R, LinkError> {
        self.with_bus(|bus| match bus {
            SimBus::Frames(b) => f(b),
            SimBus::Bytes(_) => Err(wrong_kind(&self.port)),
        })
    }

    /// The drives' addresses (node ids), in bus order.
    pub fn addresses(&self) -> Vec<u8> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.drives().iter().map(|d| d.address()).collect(),
            SimBus::Frames(b) => b.drives().iter().map(|d| d.node_id()).collect(),
        })
    }

    /// The state of the drive at `address`.
    pub fn state(&self, address: u8) -> Option<ResolvedSet> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b
                .drives()
                .iter()
                .find(|d| d.address() == address)
                .map(|d| d.state()),
            SimBus::Frames(b) => b
                .drives()
                .iter()
                .find(|d| d.node_id() == address)
                .map(|d| d.state()),
        })
    }

    /// Set a value of the drive at `address` directly, bypassing the
    /// protocol (tests, drift demos).
    pub fn poke(&self, address: u8, key: CodeKey, raw: RawValue) -> Result<(), String> {
        self.with_bus(|bus| {
            let missing = || format!("no simulated drive at address {address}");
            match bus {
                SimBus::Bytes(b) => b.drive_mut(address).ok_or_else(missing)?.poke(key, raw),
                SimBus::Frames(b) => b.drive_mut(address).ok_or_else(missing)?.poke(key, raw),
            }
        })
    }

    /// Power the drive at `address` off at the bus clock's now and on
    /// again after `off`: it comes back with what its kind of drive keeps
    /// (RAM values lost; a CAN drive whose schema stores on command with
    /// what it stored last). The fault campaigns do this after every run
    /// that ends complete.
    pub fn power_cycle(&self, address: u8, off: std::time::Duration) -> Result<(), String> {
        let now = driveset_link::Clock::now(self.clock());
        self.with_bus(|bus| {
            let missing = || format!("no simulated drive at address {address}");
            match bus {
                SimBus::Bytes(b) => {
                    if !b.drives().iter().any(|d| d.address() == address) {
                        return Err(missing());
                    }
                    b.line_mut().power_cycle(now, Some(address), off);
                }
                SimBus::Frames(b) => b
                    .drive_mut(address)
                    .ok_or_else(missing)?
                    .power_cycle(now, off),
            }
            Ok(())
        })
    }

    /// Every drive's state (the `--dump` / state file content).
    pub fn dump(&self) -> StateDump {
        self.shared.dump()
    }

    /// Write the state file now. `Ok(false)` without a state file.
    pub fn save(&self) -> Result<bool, SimOpenError> {
        match &self.shared.state {
            Some(path) => self.dump().write(path).map(|()| true),
            None => Ok(false),
        }
    }

    /// Write the drives' state to `path` (any file, not the state file).
    pub fn save_to(&self, path: &Path) -> Result<(), SimOpenError> {
        self.dump().write(path)
    }
}

/// A [`SimLink`] as a [`ByteLink`].
#[derive(Debug)]
struct SimByteHandle(SimLink);

/// The error for a byte call on a CAN bus or the other way round (cannot
/// happen through [`SimLink`]'s constructors of handles).
fn wrong_kind(port: &str) -> LinkError {
    LinkError::Unsupported {
        port: port.into(),
        what: "the simulated bus is of the other kind (bytes / CAN frames)".into(),
    }
}

impl ByteLink for SimByteHandle {
    fn port(&self) -> &str {
        &self.0.port
    }
    fn bus_id(&self) -> String {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::bus_id(b),
            SimBus::Frames(b) => FrameLink::bus_id(b),
        })
    }
    fn baud(&self) -> u32 {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::baud(b),
            SimBus::Frames(_) => 0,
        })
    }
    fn clock(&self) -> &dyn Clock {
        &self.0.clock
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.0.with_bytes(|b| b.send(bytes))
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        self.0.with_bytes(|b| b.recv(buf, deadline))
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.0.with_bytes(|b| b.discard_input())
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        self.0.with_bytes(ByteLink::flush)
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.0.with_bytes(|b| ByteLink::set_baud(b, baud))
    }
}

/// A [`SimLink`] as a [`FrameLink`].
#[derive(Debug)]
struct SimFrameHandle(SimLink);

impl FrameLink for SimFrameHandle {
    fn port(&self) -> &str {
        &self.0.port
    }
    fn bus_id(&self) -> String {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::bus_id(b),
            SimBus::Frames(b) => FrameLink::bus_id(b),
        })
    }
    fn bitrate(&self) -> u32 {
        self.0.with_bus(|bus| match bus {
            SimBus::Frames(b) => b.bitrate(),
            SimBus::Bytes(_) => 0,
        })
    }
    fn clock(&self) -> &dyn Clock {
        &self.0.clock
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.0.with_frames(|b| b.send(frame))
    }
    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        self.0.with_frames(|b| b.recv(deadline))
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.0.with_frames(|b| b.discard_input())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(port: &str) -> SimLink {
        let spec = SimSpec::parse(port).expect("spec");
        open_sim(&spec, &VirtualClock::new()).expect("open")
    }

    #[test]
    fn a_link_face_of_the_other_kind_of_bus_is_refused_for_every_transfer() {
        let wrong = |e: LinkError| {
            assert_eq!(
                e.to_string(),
                wrong_kind("sim://ecs?addresses=5").to_string()
            )
        };
        let mut bytes = SimByteHandle(open("sim://ecs?addresses=5"));
        wrong(bytes.send(b"x").expect_err("send"));
        wrong(bytes.recv(&mut [0u8; 4], Instant::ZERO).expect_err("recv"));
        wrong(bytes.discard_input().expect_err("discard"));
        wrong(ByteLink::flush(&mut bytes).expect_err("flush"));
        wrong(ByteLink::set_baud(&mut bytes, 9600).expect_err("baud"));
        let mut frames = SimFrameHandle(open("sim://tmd?addresses=1"));
        let wrong = |e: LinkError| {
            assert_eq!(
                e.to_string(),
                wrong_kind("sim://tmd?addresses=1").to_string()
            )
        };
        wrong(frames.recv(Instant::ZERO).expect_err("recv"));
        wrong(frames.discard_input().expect_err("discard"));
    }
}
