//! Cuts around `--transfer-baud` (issue 17, item 4): a pulled cable or a
//! power cycle at any telegram of an MC6000 transfer-rate upload, then
//! `recover`; the end state is read from the simulated drive.

use std::path::Path;
use std::time::Duration;

use driveset_engine::client::{DriveClient, LustbusClient};
use driveset_engine::transfer::{self, TransferRequest};
use driveset_engine::upload::UploadOptions;
use driveset_link::VirtualClock;
use driveset_schema::{Registry, ResolvedSet, load_set};
use driveset_sim::bus::SimByteBus;
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::ReactionTime;
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::{Dir, EventLog};
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;

fn set(rel: &str) -> ResolvedSet {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel);
    let mut reg = Registry::builtin().expect("builtin");
    let loaded = load_set(&path, &mut reg).expect("set loads");
    loaded.resolved.expect("resolved")
}

fn client(log: &EventLog, faults: Option<&str>) -> LustbusClient<SimByteBus> {
    let clock = VirtualClock::new();
    let o = LustOptions::new(1).reaction(ReactionTime::fixed(Duration::from_millis(2)));
    let mut bus = SimByteBus::new(&clock, 9600, vec![Box::new(Mc6000::new(o).expect("mc"))])
        .expect("bus")
        .with_log(log.clone());
    if let Some(f) = faults {
        bus = bus.with_faults(FaultPlan::parse(f).expect("faults"), 1);
    }
    LustbusClient::new(bus, catalog::schema(Family::Mc6000).expect("schema"), 1).expect("client")
}

#[test]
fn dump_sequence() {
    let set = set("parameter-sets/mc6000/axis-1.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    let log = EventLog::memory();
    let mut c = client(&log, None);
    transfer::upload(&mut c, &set, &UploadOptions::new(dir.path().join("j.json")), &TransferRequest::new(57600)).unwrap_or_else(|f| panic!("{f}"));
    let mut n = 0;
    for e in log.events() {
        if e.dir == Dir::Host { n += 1; eprintln!("{n}: {}", e.text); }
    }
    let _ = c.stats();
}
