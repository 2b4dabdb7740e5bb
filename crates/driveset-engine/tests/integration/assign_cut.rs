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

fn refused(r: Result<assign::AssignReport, driveset_engine::error::EngineError>) -> String {
    match r {
        Ok(r) => panic!("not refused: {r:?}"),
        Err(e) => {
            assert!(
                matches!(
                    e.kind(),
                    driveset_engine::error::ErrorKind::Refusal(
                        driveset_engine::error::Refused::Rule(
                            driveset_engine::error::Refusal::Assign { .. }
                        )
                    )
                ),
                "{e}"
            );
            e.to_string()
        }
    }
}

/// Host telegrams that write (LUSTBUS SELECT and LECOM SEND carry an STX;
/// ENQUIRY and RECEIVE do not).
fn writes(log: &EventLog) -> usize {
    log.events()
        .iter()
        .filter(|e| e.dir == Dir::Host && e.text.contains("<STX>"))
        .count()
}

#[test]
fn mc6000_with_baud_vf1000_and_tmd() {
    let dir = tempfile::tempdir().expect("dir");
    let sim = open("sim://mc6000?addresses=1", EventLog::off());
    let mut link = sim.link();
    let r = assign::assign(
        &mut link,
        &AssignRequest::new(BusProtocol::Lustbus, 7).baud(38400),
        &schemas(),
        &dir.path().join("mc.json"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sim.addresses(), vec![7]);
    assert_eq!(value(&sim, 7, 82), Some(RawValue::Int(7)));
    assert_eq!(value(&sim, 7, 81), Some(RawValue::Int(38400)));
    assert_eq!(r.rate_now, 38400);
    assert_eq!(
        r.written,
        vec![
            "82-SADDR = 5 at address 0".replace('5', "7"),
            "81-SBAUD = 38400 Baud at address 7".to_string(),
            "4-PROG = \"Activate new baud rate\" at address 7".to_string(),
        ]
    );
    let Link::Bytes(b) = &link else { panic!() };
    assert_eq!(b.baud(), 38400);

    let sim = open("sim://vf1000?addresses=1", EventLog::off());
    let mut link = sim.link();
    let r = assign::assign(
        &mut link,
        &AssignRequest::new(BusProtocol::Lustbus, 3).baud(4800),
        &schemas(),
        &dir.path().join("vf.json"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(value(&sim, 3, 82), Some(RawValue::Int(3)));
    assert_eq!(value(&sim, 3, 81), Some(RawValue::Int(4800)));
    assert_eq!(r.rate_now, 9600);
    assert!(
        r.rate_note
            .as_deref()
            .unwrap_or("")
            .contains("at its next restart"),
        "{r:?}"
    );

    let sim = open("sim://tmd?addresses=1&c0001=2", EventLog::off());
    let mut link = sim.link();
    let r = assign::assign(
        &mut link,
        &AssignRequest::new(BusProtocol::Lecom, 12).baud(4800),
        &schemas(),
        &dir.path().join("tmd.json"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sim.addresses(), vec![12]);
    assert_eq!(value(&sim, 12, 9), Some(RawValue::Int(120_000)));
    assert_eq!(value(&sim, 12, 125), Some(RawValue::Int(10_000)));
    println!("{:?}", r.written);
}

#[test]
fn refusals_write_nothing() {
    let dir = tempfile::tempdir().expect("dir");
    let j = dir.path().join("j.json");
    let cases: [(&str, AssignRequest, &str); 6] = [
        (
            "sim://mc6000?addresses=1,2",
            AssignRequest::new(BusProtocol::Lustbus, 5),
            "do not decode",
        ),
        (
            "sim://mc6000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 31),
            "--to 31: LUSTBUS address 0 is the group address",
        ),
        (
            "sim://mc6000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 0),
            "--to 0:",
        ),
        (
            "sim://vf1000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 4).baud(19200),
            "--baud 19200: a Lust SMARTDRIVE VF1000 runs at 2400, 4800, 9600 baud",
        ),
        (
            "sim://tmd?addresses=1,12&c0001=2",
            AssignRequest::new(BusProtocol::Lecom, 12),
            "address 12 is taken",
        ),
        (
            "sim://tmd?addresses=1",
            AssignRequest::new(BusProtocol::Lecom, 12),
            "C0001 = ",
        ),
    ];
    for (port, req, want) in cases {
        let log = EventLog::memory();
        let sim = open(port, log.clone());
        let mut link = sim.link();
        let msg = refused(assign::assign(&mut link, &req, &schemas(), &j));
        assert!(msg.contains(want), "{port}: {msg}");
        assert_eq!(writes(&log), 0, "{port}: a write was sent");
        assert!(!j.exists(), "{port}: journal written");
        println!("{port}: {msg}");
    }
}

/// The rate the simulated drive at `address` runs at.
fn drive_baud(sim: &SimLink, address: u8) -> Option<u32> {
    sim.with_bus(|b| match b {
        driveset_sim::open::SimBus::Bytes(bus) => bus.line().drive_baud(address),
        driveset_sim::open::SimBus::Frames(_) => None,
    })
}

/// Host telegrams of a clean `address --to 7 --baud 38400` on a lone
/// MC6000 (and the link clock time it takes).
fn clean_run(port: &str, req: &AssignRequest) -> (u64, Duration) {
    let dir = tempfile::tempdir().expect("dir");
    let log = EventLog::memory();
    let sim = open(port, log.clone());
    let mut link = sim.link();
    let r = assign::assign(&mut link, req, &schemas(), &dir.path().join("j.json"))
        .unwrap_or_else(|e| panic!("{e}"));
    let n = log.events().iter().filter(|e| e.dir == Dir::Host).count() as u64;
    (n, r.elapsed)
}

/// One cut run: `address` with `faults`, then (a new process, the cable
/// back, the port at 9600 baud) `recover` when a journal is left
/// unfinished. Returns the outcome for the table; panics when the drive
/// ends anywhere but fully switched (address 7, 81 = 38400, answering at
/// 38400) or fully untouched (address 1 at 9600, no journal needed).
fn cut_run(faults: &str) -> String {
    let dir = tempfile::tempdir().expect("dir");
    let journal = dir.path().join("j.journal.json");
    let sim = open(
        &format!("sim://mc6000?addresses=1&faults={faults}"),
        EventLog::off(),
    );
    let req = AssignRequest::new(BusProtocol::Lustbus, 7).baud(38400);
    let mut link = sim.link();
    let result = assign::assign(&mut link, &req, &schemas(), &journal);
    let exit0 = result.is_ok();
    sim.clock().sleep(Duration::from_secs(700));
    // a new process: the port at the usual 9600 baud
    let mut link = sim.link();
    if let Link::Bytes(b) = &mut link {
        b.set_baud(9600).expect("9600");
    }
    let unfinished = journal.exists()
        && !driveset_engine::journal::JournalFile::open(&journal)
            .expect("journal")
            .journal
            .is_finished();
    let recovered = unfinished
        .then(|| assign::recover(&mut link, &journal, &schemas()).map_err(|e| e.to_string()));
    let switched = sim.addresses() == vec![7]
        && value(&sim, 7, 82) == Some(RawValue::Int(7))
        && value(&sim, 7, 81) == Some(RawValue::Int(38400))
        && drive_baud(&sim, 7) == Some(38400);
    let untouched = sim.addresses() == vec![1]
        && value(&sim, 1, 81) == Some(RawValue::Int(9600))
        && drive_baud(&sim, 1) == Some(9600);
    match &recovered {
        Some(Ok(_)) => assert!(
            switched,
            "{faults}: recover said done but the drive is not switched"
        ),
        Some(Err(e)) => panic!("{faults}: recover failed: {e}"),
        None if exit0 => assert!(
            switched,
            "{faults}: address said done but the drive is not switched"
        ),
        None => assert!(
            untouched,
            "{faults}: failed with no journal to recover, and the drive is not untouched: addresses {:?}",
            sim.addresses()
        ),
    }
    if journal.exists() {
        let j = driveset_engine::journal::JournalFile::open(&journal)
            .expect("journal")
            .journal;
        assert!(j.is_finished(), "{faults}: journal left {:?}", j.state);
    }
    match (exit0, &recovered) {
        (true, None) => "exit 0, switched".into(),
        (false, None) => "failed before the first write (no journal), untouched".into(),
        (_, Some(_)) => "failed, recover finished: switched".into(),
    }
}

/// Every host telegram index of the clean run x {pulled cable, power
/// cycle}: every run ends fully switched or untouched (`cut_run`).
#[test]
fn a_baud_change_cut_at_every_telegram_recovers() {
    let req = AssignRequest::new(BusProtocol::Lustbus, 7).baud(38400);
    let (n, _) = clean_run("sim://mc6000?addresses=1", &req);
    assert!(n > 30, "{n} telegrams");
    let mut runs = 0;
    for kind in ["cable", "power-cycle"] {
        let mut table: Vec<(String, u64, u64)> = Vec::new();
        for i in 1..=n {
            let fault = if kind == "cable" {
                format!("cable@{i}+600s")
            } else {
                format!("power-cycle@{i}")
            };
            let outcome = cut_run(&fault);
            runs += 1;
            match table.last_mut() {
                Some((o, _, to)) if *o == outcome => *to = i,
                _ => table.push((outcome, i, i)),
            }
        }
        for (o, from, to) in &table {
            println!("{kind} at telegram {from}..={to}: {o}");
        }
    }
    assert_eq!(runs, 2 * n as usize);
}

/// The virtual time figures of the report: each family on a 9600-baud
/// line, with and without `--baud`, and the 1..30 scan's share.
#[test]
fn address_times_on_a_9600_baud_line() {
    let cases = [
        (
            "sim://mc6000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 7),
        ),
        (
            "sim://mc6000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 7).baud(38400),
        ),
        (
            "sim://vf1000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 7),
        ),
        (
            "sim://vf1000?addresses=1",
            AssignRequest::new(BusProtocol::Lustbus, 7).baud(4800),
        ),
        (
            "sim://tmd?addresses=1&c0001=2",
            AssignRequest::new(BusProtocol::Lecom, 7),
        ),
        (
            "sim://tmd?addresses=1&c0001=2",
            AssignRequest::new(BusProtocol::Lecom, 7).baud(4800),
        ),
    ];
    for (port, req) in cases {
        let dir = tempfile::tempdir().expect("dir");
        let sim = open(port, EventLog::off());
        let mut link = sim.link();
        let r = assign::assign(&mut link, &req, &schemas(), &dir.path().join("j.json"))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(r.elapsed > r.plan.scan_time);
        println!(
            "FIGURE {port} --to 7{}: {} ms total, scan {} ms",
            req.baud
                .map_or_else(String::new, |b| format!(" --baud {b}")),
            r.elapsed.as_millis(),
            r.plan.scan_time.as_millis()
        );
    }
}
