//! Factory-fresh drives and the service bench (`sim://...?factory=`,
//! `bench=true`, `driveset_sim::factory`): the port grammar and its
//! errors; several drives at the factory address answer at once and the
//! host gets garbage (event `collision`), on LUSTBUS at the factory address
//! and at 0, on LECOM at C0009 = 1; a drive keeps its identity (slot) when
//! its own address changes; the bench holds one waiting drive per open.

use std::path::PathBuf;
use std::time::Duration;

use driveset_link::VirtualClock;
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::catalog::Family;
use driveset_sim::factory::DriveSlot;
use driveset_sim::log::EventLog;
use driveset_sim::open::{SimConfig, SimLink, StateDump, open_sim_with};
use driveset_sim::port::SimSpec;

fn spec(s: &str) -> SimSpec {
    SimSpec::parse(s).unwrap_or_else(|e| panic!("`{s}` should parse: {e}"))
}

fn open(port: &str, log: EventLog) -> SimLink {
    let config = SimConfig::from_spec(&spec(port)).unwrap_or_else(|e| panic!("{port}: {e}"));
    open_sim_with(&config, &VirtualClock::new(), port, log).unwrap()
}

/// A fresh state file path (removed on drop).
struct TempState(PathBuf);
impl TempState {
    fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!(
            "driveset-sim-factory-{}-{tag}.json",
            std::process::id()
        ));
        let _ = std::fs::remove_file(&p);
        TempState(p)
    }
    fn port(&self, port: &str) -> String {
        format!("{port}&state={}", self.0.display())
    }
}
impl Drop for TempState {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Send `bytes`, then collect what the line returns until 100 ms of quiet.
fn ask(link: &SimLink, bytes: &[u8]) -> Vec<u8> {
    let mut l = link.byte_link().unwrap();
    l.send(bytes).unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    loop {
        let deadline = l.clock().deadline_in(Duration::from_millis(100));
        let n = l.recv(&mut buf, deadline).unwrap();
        if n == 0 {
            return got;
        }
        got.extend_from_slice(&buf[..n]);
    }
}

use crate::lust_support::{enq as enquiry, sel as select};

fn collisions(log: &EventLog) -> Vec<Option<u8>> {
    log.events()
        .into_iter()
        .filter(|e| e.fault.as_deref() == Some("collision"))
        .map(|e| e.addr)
        .collect()
}

fn mc(n: usize) -> DriveSlot {
    DriveSlot::Factory {
        family: Family::Mc6000,
        n,
    }
}

#[test]
fn factory_ports_parse_print_back_and_open() {
    let s = spec("sim://mc6000?factory=3");
    assert_eq!(s.factory, ["mc6000"; 3]);
    assert!(!s.bench);
    assert_eq!(s.to_string(), "sim://mc6000?factory=3");
    assert_eq!(
        spec("sim://mc6000?factory=mc6000*2").to_string(),
        "sim://mc6000?factory=2"
    );
    let s = spec("sim://lustbus?factory=mc6000*4,vf1000*3&bench=true");
    assert!(s.is_mixed() && s.bench);
    assert_eq!(
        s.to_string(),
        "sim://lustbus?factory=mc6000*4,vf1000*3&bench=true"
    );
    assert_eq!(spec(&s.to_string()), s);
    let s = spec("sim://mc6000?factory=1&addresses=5");
    assert_eq!(s.to_string(), "sim://mc6000?addresses=5&factory=1");
    assert_eq!(s.drives(), [("mc6000", 5)]);
    assert_eq!(s.factory_drives(), [("mc6000", 1)]);
    assert!(s.names_drives());
    assert!(!spec("sim://mc6000").names_drives());

    // one configured drive at 5 and one new unit at the factory address 1
    let link = open("sim://mc6000?addresses=5&factory=1", EventLog::off());
    assert_eq!(link.addresses(), [5, 1]);
    assert_eq!(
        link.slots(),
        [
            DriveSlot::Port {
                family: Family::Mc6000,
                address: 5
            },
            mc(1)
        ]
    );
    assert_eq!(link.family_of(1), Some(Family::Mc6000));
    let fresh = link.state(1).unwrap();
    assert_eq!(fresh.values[&CodeKey::new(82)], RawValue::Int(1));
    assert_eq!(fresh.values[&CodeKey::new(81)], RawValue::Int(9600));

    let link = open("sim://lustbus?factory=mc6000*4,vf1000*3", EventLog::off());
    assert_eq!(link.addresses(), [1; 7]);
    assert_eq!(link.families(), [Family::Mc6000, Family::Vf1000]);
    assert_eq!(link.bus_name(), "lustbus");
    let tmd = open("sim://tmd?factory=2", EventLog::off());
    assert_eq!(tmd.addresses(), [1, 1]);
    let s = tmd.state(1).unwrap();
    assert_eq!(s.values[&CodeKey::new(125)], RawValue::Int(0));
    assert_eq!(
        open("sim://vf1000?factory=1", EventLog::off()).addresses(),
        [1]
    );
}

#[test]
fn factory_port_errors_say_what_to_write() {
    let e = |s: &str| SimSpec::parse(s).unwrap_err().to_string();
    assert_eq!(
        e("sim://ecs?factory=1"),
        "invalid port `sim://ecs?factory=1`: `factory=1`: factory-fresh drives are modelled on LUSTBUS (mc6000, vf1000) and LECOM (tmd) only; an ECS node's id is set at the unit: give it with addresses=, e.g. sim://ecs?addresses=1"
    );
    assert_eq!(
        e("sim://mc6000?addresses=1&bench=true"),
        "invalid port `sim://mc6000?addresses=1&bench=true`: `bench=true`: the service bench connects factory-fresh drives one at a time; give them with factory=, e.g. sim://mc6000?factory=3&bench=true"
    );
    assert_eq!(
        e("sim://mc6000?factory=2&bench=maybe"),
        "invalid port `sim://mc6000?factory=2&bench=maybe`: `bench=maybe`: use true or false"
    );
    assert_eq!(
        e("sim://mc6000?factory=0"),
        "invalid port `sim://mc6000?factory=0`: `factory=0`: `0`: the count is a whole number 1..=30; write FAMILY*N (mc6000*3) or, on a one-family bus, N"
    );
    assert_eq!(
        e("sim://tmd?factory=mc6000*1"),
        "invalid port `sim://tmd?factory=mc6000*1`: `factory=mc6000*1`: `mc6000*1`: sim://tmd holds tmd drives only; put mc6000 and tmd drives on sim://lustbus?factory=..."
    );
    assert_eq!(
        e("sim://lustbus?factory=2"),
        "invalid port `sim://lustbus?factory=2`: `factory=2`: `2`: on sim://lustbus every item names its family: FAMILY*N, e.g. factory=mc6000*4,vf1000*3"
    );
    assert_eq!(
        e("sim://lustbus?factory=tmd*2"),
        "invalid port `sim://lustbus?factory=tmd*2`: `factory=tmd*2`: `tmd*2`: tmd drives cannot be on a mixed LUSTBUS; put them on sim://tmd?factory=N"
    );
    // The config refuses the same when built by hand.
    let mut c = SimConfig::new(Family::Ecs, vec![]);
    c.factory = vec![Family::Ecs];
    assert!(
        c.check()
            .unwrap_err()
            .to_string()
            .starts_with("factory-fresh drives are modelled on LUSTBUS")
    );
    let mut c = SimConfig::new(Family::Mc6000, vec![1]);
    c.bench = true;
    assert!(
        c.check()
            .unwrap_err()
            .to_string()
            .starts_with("bench=true:")
    );
}

#[test]
fn three_factory_mc6000_answer_address_1_and_0_with_garbage() {
    let log = EventLog::memory();
    let link = open("sim://mc6000?factory=3", log.clone());
    // One drive alone answers `A STX 00085=01 ETX BCC` (power-on bit).
    let alone = open("sim://mc6000?factory=1", EventLog::off());
    assert_eq!(ask(&alone, &enquiry(1, 85)), b"A\x0200085=01\x03\x02");
    assert_eq!(ask(&alone, &enquiry(0, 85)), b"@\x0200085=00\x03\x03");
    let at_1 = ask(&link, &enquiry(1, 85));
    assert_eq!(at_1, [1, 2, 0, 0, 0, 0, 33, 41, 0, 1, 1, 0]);
    assert_eq!(collisions(&log), [Some(1), Some(1)]);
    let at_0 = ask(&link, &enquiry(0, 85));
    assert_eq!(at_0, [0, 2, 0, 0, 0, 0, 33, 41, 0, 0, 1, 0]);
    assert_eq!(collisions(&log).len(), 4);
}

#[test]
fn two_factory_tmd_at_c0009_1_answer_with_garbage() {
    let log = EventLog::memory();
    let link = open("sim://tmd?factory=2", log.clone());
    // RECEIVE of C0009 at station 01: `EOT 0 1 0 9 ENQ` (8.H).
    let receive = b"\x0401\x30\x39\x05";
    let alone = open("sim://tmd?factory=1", EventLog::off());
    let one = ask(&alone, receive);
    assert_eq!(one, b"\x02091\x03;");
    let got = ask(&link, receive);
    assert_eq!(got, [0x02, 0x00, 0x09, 0x01, 0x03, 0x1B]);
    assert_eq!(collisions(&log), [Some(1)]);
}

#[test]
fn a_factory_drive_given_address_7_is_found_there_again() {
    let file = TempState::new("saddr");
    let port = file.port("sim://mc6000?factory=1");
    let link = open(&port, EventLog::off());
    // SELECT 82 = 7 at the group address 0, as a lone drive answers it,
    // once the power-on bit is read out of 85 (a SELECT is refused while
    // SIOF/SERR holds a bit, section 9.2).
    assert_eq!(ask(&link, &enquiry(0, 85)), b"@\x0200085=01\x03\x02");
    assert_eq!(ask(&link, &select(0, 82, "7")), b"@\x06");
    assert_eq!(link.addresses(), [7]);
    assert_eq!(link.family_of(7), Some(Family::Mc6000));
    assert_eq!(link.family_of(1), None);
    assert_eq!(link.address_of(&mc(1)), Some(7));
    assert_eq!(ask(&link, &enquiry(7, 82)), b"G\x0200082=07\x03\x03");
    drop(link);
    let dump = StateDump::read(&file.0).unwrap();
    assert_eq!(dump.drives.len(), 1);
    assert_eq!(dump.drives[0].address, 7);
    assert_eq!(dump.drives[0].slot.as_deref(), Some("mc6000#1"));
    assert!(dump.drives[0].assigned);
    // The same port string: the drive is at 7, nothing at the factory address.
    let again = open(&port, EventLog::off());
    assert_eq!(again.addresses(), [7]);
    assert_eq!(
        again.state_of(&mc(1)).unwrap().values[&CodeKey::new(82)],
        RawValue::Int(7)
    );
    assert!(ask(&again, &enquiry(1, 82)).is_empty());
    assert_eq!(ask(&again, &enquiry(7, 82)), b"G\x0200082=07\x03\x03");
}

#[test]
fn a_dump_without_slots_still_loads_by_family_and_address() {
    let file = TempState::new("old");
    let port = file.port("sim://mc6000?addresses=3");
    let link = open(&port, EventLog::off());
    link.poke(3, CodeKey::new(100), RawValue::Int(4)).unwrap();
    let want = link.state(3).unwrap();
    drop(link);
    // strip the slot as an older version wrote it
    let mut dump = StateDump::read(&file.0).unwrap();
    assert_eq!(dump.drives[0].slot.as_deref(), Some("mc6000@3"));
    dump.drives[0].slot = None;
    dump.write(&file.0).unwrap();
    let again = open(&port, EventLog::off());
    assert_eq!(again.state(3).unwrap().fingerprint(), want.fingerprint());
}

#[test]
fn the_bench_connects_one_waiting_drive_per_open_then_the_line() {
    let file = TempState::new("bench");
    let port = file.port("sim://mc6000?factory=3&bench=true");
    for (n, to) in [(1, "2"), (2, "3"), (3, "1")] {
        let link = open(&port, EventLog::off());
        assert_eq!(link.slots(), [mc(n)], "open {n}");
        assert_eq!(link.addresses(), [1]);
        let others: Vec<DriveSlot> = (1..=3).filter(|k| *k != n).map(mc).collect();
        assert_eq!(link.detached(), others);
        // alone on the line: address 0 gets one valid answer
        assert_eq!(ask(&link, &enquiry(0, 82)), b"@\x0200082=01\x03\x05");
        // the third gets its factory address 1 written: given, off the bench
        ask(&link, &enquiry(0, 85));
        assert_eq!(ask(&link, &select(0, 82, to)), b"@\x06");
        // every drive is in the dump, in port order
        let dump = link.dump();
        let slots: Vec<Option<&str>> = dump.drives.iter().map(|d| d.slot.as_deref()).collect();
        assert_eq!(
            slots,
            [Some("mc6000#1"), Some("mc6000#2"), Some("mc6000#3")]
        );
    }
    let line = open(&port, EventLog::off());
    assert_eq!(line.slots(), [mc(1), mc(2), mc(3)]);
    assert_eq!(line.addresses(), [2, 3, 1]);
    assert!(line.detached().is_empty());
    assert_eq!(ask(&line, &enquiry(3, 82)), b"C\x0200082=03\x03\x07");
    assert_eq!(line.family_of(2), Some(Family::Mc6000));
}

#[test]
fn a_factory_tmd_keeps_9600_after_c0125_is_written_until_it_restarts() {
    let file = TempState::new("c0125");
    let port = file.port("sim://tmd?factory=1&c0001=2");
    let link = open(&port, EventLog::off());
    // SEND C0125 = 1 (4800 bps) to station 01 with extended addressing
    // (8.D: `!` code 0x007D, subcode 00, then the value).
    let text = b"!007D001";
    let mut send = vec![0x04, b'0', b'1', 0x02];
    send.extend_from_slice(text);
    send.push(0x03);
    send.push(text.iter().fold(0x03, |a, b| a ^ b));
    assert_eq!(ask(&link, &send), [0x06]);
    drop(link);
    let dump = StateDump::read(&file.0).unwrap();
    assert_eq!(
        dump.drives[0].rate,
        Some(9600),
        "C0125 waits for a power-up"
    );
    let again = open(&port, EventLog::off());
    assert_eq!(
        again.state(1).unwrap().values[&CodeKey::new(125)],
        RawValue::Int(10_000)
    );
    // still at 9600: RECEIVE of C0009 answers at the host's 9600
    assert_eq!(ask(&again, b"\x0401\x30\x39\x05"), b"\x02091\x03;");
}
