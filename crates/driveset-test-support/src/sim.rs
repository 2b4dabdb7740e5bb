//! Simulated buses (driveset-sim) in virtual time with an in-memory wire
//! log, the host's and the drives' telegrams read back from that log, and
//! the port openers a `sim://` port needs; a simulated drive's state file
//! read and changed behind the tool's back (as a keypad would).

use std::path::Path;
use std::sync::Arc;

use driveset_schema::{CodeKey, CodeStyle, RawValue, ResolvedSet};
use driveset_sim::open::{DriveDump, StateDump, parse_canonical};

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

/// Put `raw` into code `number` of the simulated drive at `address` (the
/// file's first drive where `None`) in the state file `path` an earlier
/// run saved, its canonical text written with `style`'s code names: a
/// change made on the drive itself, behind the tool's back.
pub fn poke_state(path: &Path, address: Option<u8>, number: u32, raw: i64, style: CodeStyle) {
    let mut dump = StateDump::read(path)
        .unwrap_or_else(|e| panic!("{}: simulator state saved: {e}", path.display()));
    let d = match address {
        Some(a) => dump
            .drives
            .iter_mut()
            .find(|d| d.address == a)
            .unwrap_or_else(|| panic!("{}: no drive at {a} in the dump", path.display())),
        None => dump
            .drives
            .first_mut()
            .unwrap_or_else(|| panic!("{}: no drive in the dump", path.display())),
    };
    let (schema, mut values) = parse_canonical(&d.canonical).expect("canonical");
    values.insert(CodeKey::new(number), RawValue::Int(raw));
    let set = ResolvedSet {
        schema,
        code_style: style,
        values,
        secrets: Default::default(),
    };
    let at = d.address;
    *d = DriveDump::new(&d.family.clone(), at, &set);
    dump.write(path)
        .unwrap_or_else(|e| panic!("{}: state written: {e}", path.display()));
}

/// The raw value of code `number` that the simulated drive at `address`
/// holds in the state file `path`; `None` where it holds none.
pub fn state_raw(path: &Path, address: u8, number: u32) -> Option<RawValue> {
    let dump = StateDump::read(path)
        .unwrap_or_else(|e| panic!("{}: simulator state saved: {e}", path.display()));
    let d = dump
        .drives
        .iter()
        .find(|d| d.address == address)
        .unwrap_or_else(|| panic!("{}: no drive at {address} in the dump", path.display()));
    let (_, values) = parse_canonical(&d.canonical).expect("canonical");
    values.get(&CodeKey::new(number)).cloned()
}
