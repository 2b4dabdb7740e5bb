//! Simulated buses (driveset-sim) in virtual time with an in-memory wire
//! log, the host's and the drives' telegrams read back from that log, and
//! the port openers a `sim://` port needs.

use std::sync::Arc;

use driveset_link::{Openers, VirtualClock};
use driveset_sim::bus::SimByteBus;
use driveset_sim::can_bus::SimCanBus;
use driveset_sim::drive::{ByteDrive, FrameDrive};
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::{Dir, EventLog};
use driveset_sim::port::SimOpener;

/// The seed of the fault plans of [`sim_byte_bus`] and [`sim_can_bus`].
const FAULT_SEED: u64 = 1;

/// A simulated byte bus (LUSTBUS, LECOM) at `baud` holding `drives`, on a
/// fresh virtual clock, logging to memory, with the fault plan `faults`
/// (the `faults=` syntax of a `sim://` port) if given.
pub fn sim_byte_bus(
    baud: u32,
    drives: Vec<Box<dyn ByteDrive>>,
    faults: Option<&str>,
) -> (VirtualClock, EventLog, SimByteBus) {
    let clock = VirtualClock::new();
    let log = EventLog::memory();
    let mut bus = SimByteBus::new(&clock, baud, drives)
        .expect("a simulated byte bus")
        .with_log(log.clone());
    if let Some(f) = faults {
        bus = bus.with_faults(FaultPlan::parse(f).expect("a fault plan"), FAULT_SEED);
    }
    (clock, log, bus)
}

/// A simulated CAN bus at 500 kbit/s holding `drives`, as
/// [`sim_byte_bus`].
pub fn sim_can_bus(
    drives: Vec<Box<dyn FrameDrive>>,
    faults: Option<&str>,
) -> (VirtualClock, EventLog, SimCanBus) {
    let clock = VirtualClock::new();
    let log = EventLog::memory();
    let mut bus = SimCanBus::new(&clock, 500_000, drives)
        .expect("a simulated CAN bus")
        .with_log(log.clone());
    if let Some(f) = faults {
        bus = bus.with_faults(FaultPlan::parse(f).expect("a fault plan"), FAULT_SEED);
    }
    (clock, log, bus)
}

/// The telegrams one side (`dir`) sent, as logged: each with its virtual
/// time in nanoseconds and its bytes.
pub fn wire_timed(log: &EventLog, dir: Dir) -> Vec<(u64, Vec<u8>)> {
    log.events()
        .into_iter()
        .filter(|e| e.dir == dir)
        .map(|e| {
            let bytes = e
                .hex
                .split(' ')
                .filter(|s| !s.is_empty())
                .map(|h| u8::from_str_radix(h, 16).expect("the log's hex bytes"))
                .collect();
            (e.t_ns, bytes)
        })
        .collect()
}

/// The telegrams one side (`dir`) sent, as byte vectors.
pub fn wire_bytes(log: &EventLog, dir: Dir) -> Vec<Vec<u8>> {
    wire_timed(log, dir).into_iter().map(|(_, b)| b).collect()
}

/// The port openers with the simulator's: what a `sim://` port needs.
pub fn sim_openers() -> Openers {
    Openers::none().with(Arc::new(SimOpener::default()))
}
