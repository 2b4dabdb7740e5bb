//! Unit tests of `sim://` opening: every family, options, state round
//! trips, mixed LUSTBUS, bad state files.

use std::time::Duration;

use driveset_proto::lustbus::{Address, Enquiry, ParameterCode};

use std::collections::BTreeMap;
use std::path::PathBuf;

use driveset_link::{ByteLink, CanFrame, FrameLink, Instant, Link, VirtualClock};
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};

use crate::catalog::Family;
use crate::log::EventLog;

use super::config::*;
use super::link::*;
use super::state::*;
use super::*;

fn spec(s: &str) -> SimSpec {
    SimSpec::parse(s).unwrap_or_else(|e| panic!("not a sim port: {e}"))
}

/// A fresh file path in the temp dir (removed on drop).
struct TempPath(PathBuf);
impl TempPath {
    fn new(tag: &str) -> Self {
        use std::sync::atomic::{AtomicU32, Ordering};
        static N: AtomicU32 = AtomicU32::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        TempPath(std::env::temp_dir().join(format!(
            "driveset-sim-open-{}-{tag}-{n}.json",
            std::process::id()
        )))
    }
}
impl Drop for TempPath {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn config(family: Family, addresses: &[u8]) -> SimConfig {
    SimConfig::new(family, addresses.to_vec())
}

/// ENQUIRY of 85 to `a`, then everything the line returns until 100 ms
/// of quiet; returns the bytes and the virtual instant at the end.
fn enquire_85(link: &SimLink, a: u8) -> (Vec<u8>, Instant) {
    let mut l = link.byte_link().unwrap();
    let t = Enquiry::new(Address::new(a).unwrap(), ParameterCode::new(85).unwrap());
    l.send(&t.encode()).unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    let mut last = l.clock().now();
    loop {
        let deadline = l.clock().deadline_in(Duration::from_millis(100));
        let n = l.recv(&mut buf, deadline).unwrap();
        if n == 0 {
            return (got, last);
        }
        last = l.clock().now();
        got.extend_from_slice(&buf[..n]);
    }
}

#[test]
fn every_family_opens_with_its_drives() {
    for (family, addresses) in [
        (Family::Mc6000, vec![1, 2]),
        (Family::Vf1000, vec![30]),
        (Family::Tmd, vec![1, 99]),
        (Family::Ecs, vec![1, 127]),
    ] {
        let clock = VirtualClock::new();
        let link =
            open_sim_with(&config(family, &addresses), &clock, "sim", EventLog::off()).unwrap();
        assert_eq!(link.family(), family);
        assert_eq!(link.addresses(), addresses);
        assert_eq!(link.is_can(), family == Family::Ecs);
        assert_eq!(link.byte_link().is_some(), family != Family::Ecs);
        assert_eq!(link.frame_link().is_some(), family == Family::Ecs);
        match link.link() {
            Link::Bytes(b) => assert_eq!(b.baud(), 9600),
            Link::Frames(f) => assert_eq!(f.bitrate(), 500_000),
        }
        for &a in &addresses {
            let s = link.state(a).unwrap();
            assert_eq!(
                s.schema,
                crate::catalog::sim_schema_id(family),
                "{}",
                family.name()
            );
        }
        assert!(link.state(3).is_none());
        let dump = link.dump();
        assert_eq!(dump.format, STATE_FORMAT);
        assert_eq!(dump.family, family.name());
        assert_eq!(dump.drives.len(), addresses.len());
    }
}

#[test]
fn spec_options_and_family_spellings() {
    let c = SimConfig::from_spec(&spec(
        "sim://lust-mc6000?addresses=2,1&baud=19200&seed=7&faults=lose=0.5",
    ))
    .unwrap();
    assert_eq!(c.family, Family::Mc6000);
    assert_eq!(c.addresses, [2, 1]);
    assert_eq!((c.baud, c.seed), (19200, 7));
    assert_eq!(c.faults.lose, 0.5);
    for (name, family) in [
        ("mc7000", Family::Mc6000),
        ("lust-vf1000", Family::Vf1000),
        ("fictional-vf1000-demo", Family::Vf1000),
        ("lenze-tmd", Family::Tmd),
        ("lenze_ecs", Family::Ecs),
        ("ECS", Family::Ecs),
    ] {
        assert_eq!(parse_family(name).unwrap(), family, "{name}");
    }
    let e = parse_family("s7-300").unwrap_err().to_string();
    assert!(e.contains("mc6000, vf1000, tmd, ecs"), "{e}");
    let e = SimConfig::from_spec(&spec("sim://tmd?addresses=1&faults=lose=2"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("faults: invalid fault item `lose=2`"), "{e}");
}

#[test]
fn addresses_are_checked_per_family() {
    let bad = |f, a: &[u8]| config(f, a).check().unwrap_err().to_string();
    assert!(bad(Family::Mc6000, &[31]).contains("1..=30"));
    assert!(bad(Family::Vf1000, &[0]).contains("address 0 is not allowed"));
    assert!(bad(Family::Tmd, &[20]).contains("10, 20, ... 90"));
    assert!(bad(Family::Tmd, &[100]).contains("1..=99"));
    assert!(bad(Family::Ecs, &[128]).contains("1..=127"));
    assert!(bad(Family::Ecs, &[]).contains("no drive address"));
    assert!(bad(Family::Mc6000, &[3, 3]).contains("address 3 is given twice"));
    let mut c = config(Family::Tmd, &[1]);
    c.baud = 1000;
    assert!(c.check().unwrap_err().to_string().contains("1000 baud"));
    let mut c = config(Family::Ecs, &[1]);
    c.bitrate = 33_000;
    assert!(c.check().unwrap_err().to_string().contains("33000"));
    assert!(config(Family::Tmd, &[1, 11, 99]).check().is_ok());
}

#[test]
fn first_enquiry_of_85_after_power_on_and_seed_reproducibility() {
    let run = |seed: u64| {
        let clock = VirtualClock::new();
        let link = open_sim(
            &spec(&format!("sim://mc6000?addresses=1,2&seed={seed}")),
            &clock,
        )
        .unwrap();
        let first = enquire_85(&link, 1);
        let second = enquire_85(&link, 1);
        (first, second)
    };
    let ((bytes, at), (again, _)) = run(7);
    // 6.1.1.2: A STX 00085 = 01 ETX BCC; power-on bit, then cleared.
    assert_eq!(bytes, b"A\x0200085=01\x03\x02");
    assert_eq!(again, b"A\x0200085=00\x03\x03");
    assert_eq!(run(7).0.1, at, "same seed, same instants");
    let other: Vec<Instant> = (8..12).map(|s| run(s).0.1).collect();
    assert!(other.iter().any(|t| *t != at), "{other:?} vs {at}");
}

#[test]
fn poke_changes_the_fingerprint() {
    let clock = VirtualClock::new();
    let link = open_sim(&spec("sim://tmd?addresses=1"), &clock).unwrap();
    let before = link.state(1).unwrap().fingerprint();
    link.poke(1, CodeKey::new(11), RawValue::Int(600_000))
        .unwrap();
    let after = link.state(1).unwrap();
    assert_ne!(after.fingerprint(), before);
    assert_eq!(after.values[&CodeKey::new(11)], RawValue::Int(600_000));
    assert!(link.poke(2, CodeKey::new(11), RawValue::Int(1)).is_err());
}

/// Poke the first integer code the drive accepts a change of.
fn poke_something(link: &SimLink, a: u8) -> CodeKey {
    let s = link.state(a).unwrap();
    for (k, v) in &s.values {
        if let RawValue::Int(v) = v
            && ![82, 85, 9].contains(&k.number)
            && link.poke(a, *k, RawValue::Int(v + 1)).is_ok()
            && link.state(a).unwrap().values[k] == RawValue::Int(v + 1)
        {
            return *k;
        }
    }
    panic!("nothing to poke");
}

#[test]
fn state_round_trip_keeps_the_fingerprint() {
    for family in Family::ALL {
        let file = TempPath::new(family.name());
        let mut c = config(family, &[1, 3]);
        c.state = Some(file.0.clone());
        let clock = VirtualClock::new();
        let link = open_sim_with(&c, &clock, "sim", EventLog::off()).unwrap();
        let key = poke_something(&link, 3);
        let want = link.state(3).unwrap();
        assert!(link.save().unwrap());
        drop(link);
        let again = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        let got = again.state(3).unwrap();
        assert_eq!(got.fingerprint(), want.fingerprint(), "{}", family.name());
        assert_eq!(got.values[&key], want.values[&key]);
        // A drive the file does not hold starts from factory state.
        let mut wider = c.clone();
        wider.addresses = vec![1, 3, 5];
        drop(again);
        let wide = open_sim_with(&wider, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        let fresh = open_sim_with(
            &config(family, &[5]),
            &VirtualClock::new(),
            "sim",
            EventLog::off(),
        )
        .unwrap();
        assert_eq!(
            wide.state(5).unwrap().fingerprint(),
            fresh.state(5).unwrap().fingerprint()
        );
    }
}

#[test]
fn the_state_is_saved_when_the_last_handle_drops() {
    let file = TempPath::new("drop");
    let mut c = config(Family::Mc6000, &[1]);
    c.state = Some(file.0.clone());
    let link = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
    let handle = link.byte_link().unwrap();
    // The first read clears the power-on bit; that is state too.
    let (bytes, _) = enquire_85(&link, 1);
    assert!(bytes.starts_with(b"A\x0200085=01"));
    drop(link);
    assert!(!file.0.exists(), "a handle still holds the bus");
    drop(handle);
    let dump = StateDump::read(&file.0).unwrap();
    assert_eq!(dump.drives.len(), 1);
    assert_eq!(dump.drives[0].address, 1);
    assert!(dump.drives[0].fingerprint.starts_with("sha256:"));
    let again = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
    assert_eq!(
        again.state(1).unwrap().fingerprint(),
        dump.drives[0].fingerprint
    );
    let (bytes, _) = enquire_85(&again, 1);
    assert!(bytes.starts_with(b"A\x0200085=00"), "{bytes:?}");
}

#[test]
fn bad_state_files_are_refused_with_the_path() {
    let file = TempPath::new("bad");
    let mut c = config(Family::Vf1000, &[1]);
    c.state = Some(file.0.clone());
    std::fs::write(&file.0, "{}").unwrap();
    let e = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off())
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a simulator state dump"), "{e}");
    assert!(e.contains(&file.0.display().to_string()), "{e}");
    // A dump of another family.
    let tmd = open_sim_with(
        &config(Family::Tmd, &[1]),
        &VirtualClock::new(),
        "sim",
        EventLog::off(),
    )
    .unwrap();
    tmd.save_to(&file.0).unwrap();
    let e = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("it holds tmd drives, this bus has vf1000 drives"),
        "{e}"
    );
}

#[test]
fn canonical_text_parses_back() {
    let mut s = ResolvedSet {
        schema: "lenze-tmd".into(),
        code_style: driveset_schema::schema::CodeStyle::Lenze,
        values: BTreeMap::new(),
        secrets: Default::default(),
    };
    s.insert(CodeKey::new(7), RawValue::Int(-17185));
    s.insert(CodeKey::sub(39, 1), RawValue::Int(200000));
    s.insert(CodeKey::new(39), RawValue::Octets(vec![0x0a, 0xff]));
    s.insert(CodeKey::new(200), RawValue::Text("33 \"TMD\"\n".into()));
    let (schema, values) = parse_canonical(&s.canonical()).unwrap();
    assert_eq!(schema, "lenze-tmd");
    assert_eq!(values, s.values);
    assert!(parse_canonical("hello").is_err());
    assert!(parse_canonical("driveset-canonical 1\nschema x\nC0001 o0").is_err());
}

#[test]
fn a_mixed_lustbus_holds_servos_and_inverters_on_one_line() {
    let sim = spec("sim://lustbus?vf1000=5,6&mc6000=1,2&seed=3");
    let c = SimConfig::from_spec(&sim).unwrap();
    assert!(c.is_mixed());
    assert_eq!(c.bus_name(), "lustbus");
    assert_eq!(
        c.drives(),
        [
            (Family::Mc6000, 1),
            (Family::Mc6000, 2),
            (Family::Vf1000, 5),
            (Family::Vf1000, 6)
        ]
    );
    let link = open_sim(&sim, &VirtualClock::new()).unwrap();
    assert!(link.is_mixed() && !link.is_can());
    assert_eq!(link.families(), [Family::Mc6000, Family::Vf1000]);
    assert_eq!(link.family_of(5), Some(Family::Vf1000));
    assert_eq!(link.family_of(2), Some(Family::Mc6000));
    assert_eq!(link.family_of(3), None);
    assert_eq!(link.addresses(), [1, 2, 5, 6]);
    assert_eq!(
        link.state(1).unwrap().schema,
        crate::catalog::sim_schema_id(Family::Mc6000)
    );
    assert_eq!(
        link.state(6).unwrap().schema,
        crate::catalog::sim_schema_id(Family::Vf1000)
    );
    // Both families answer on the same byte link, each at its address.
    let (mc, _) = enquire_85(&link, 2);
    assert!(mc.starts_with(b"B\x0200085="), "{mc:?}");
    let (vf, _) = enquire_85(&link, 5);
    assert!(vf.starts_with(b"E\x0200085="), "{vf:?}");
    let dump = link.dump();
    assert_eq!(dump.family, "lustbus");
    let fams: Vec<(&str, u8)> = dump
        .drives
        .iter()
        .map(|d| (d.family.as_str(), d.address))
        .collect();
    assert_eq!(
        fams,
        [("mc6000", 1), ("mc6000", 2), ("vf1000", 5), ("vf1000", 6)]
    );
}

#[test]
fn a_mixed_lustbus_keeps_its_state_per_family_and_address() {
    let file = TempPath::new("mixed");
    let mut c = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Vf1000, 3)]);
    c.state = Some(file.0.clone());
    let link = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
    let mc_key = poke_something(&link, 1);
    let vf_key = poke_something(&link, 3);
    let (mc, vf) = (link.state(1).unwrap(), link.state(3).unwrap());
    assert!(link.save().unwrap());
    drop(link);
    let again = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
    assert_eq!(again.state(1).unwrap().fingerprint(), mc.fingerprint());
    assert_eq!(again.state(3).unwrap().fingerprint(), vf.fingerprint());
    assert_eq!(again.state(1).unwrap().values[&mc_key], mc.values[&mc_key]);
    assert_eq!(again.state(3).unwrap().values[&vf_key], vf.values[&vf_key]);
    drop(again);
    // Same addresses, families swapped: nothing in the file matches,
    // every drive starts from factory state.
    let mut swapped = SimConfig::mixed(&[(Family::Vf1000, 1), (Family::Mc6000, 3)]);
    swapped.state = Some(file.0.clone());
    let fresh = open_sim_with(&swapped, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
    let factory = open_sim_with(
        &SimConfig::mixed(&[(Family::Vf1000, 1), (Family::Mc6000, 3)]),
        &VirtualClock::new(),
        "sim",
        EventLog::off(),
    )
    .unwrap();
    for a in [1, 3] {
        assert_eq!(
            fresh.state(a).unwrap().fingerprint(),
            factory.state(a).unwrap().fingerprint()
        );
    }
    drop(fresh);
    // A single-family bus refuses the mixed bus's file.
    let mut single = config(Family::Mc6000, &[1]);
    single.state = Some(file.0.clone());
    let e = open_sim_with(&single, &VirtualClock::new(), "sim", EventLog::off())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("it holds lustbus drives, this bus has mc6000 drives"),
        "{e}"
    );
}

#[test]
fn a_mixed_lustbus_refuses_what_cannot_share_the_line() {
    let e = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Tmd, 2)])
        .check()
        .unwrap_err()
        .to_string();
    assert!(e.contains("tmd drives cannot be on a mixed LUSTBUS"), "{e}");
    let e = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Vf1000, 31)])
        .check()
        .unwrap_err()
        .to_string();
    assert!(e.contains("vf1000: address 31 is not allowed"), "{e}");
    let mut c = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Vf1000, 2)]);
    c.addresses.push(3);
    let e = c.check().unwrap_err().to_string();
    assert!(e.contains("2 drive families for 3 addresses"), "{e}");
    let e = SimConfig::mixed(&[(Family::Mc6000, 4), (Family::Vf1000, 4)])
        .check()
        .unwrap_err()
        .to_string();
    assert!(e.contains("address 4 is given twice"), "{e}");
    // A single family through the per-family key is a mixed bus too
    // (named lustbus), and equal to itself on the wire.
    let c = SimConfig::from_spec(&spec("sim://lustbus?mc7000=1")).unwrap();
    assert_eq!(
        (c.bus_name(), c.drives()),
        ("lustbus", vec![(Family::Mc6000, 1)])
    );
}

#[test]
fn ecs_answers_on_the_frame_link() {
    let clock = VirtualClock::new();
    let link = open_sim(&spec("sim://ecs?addresses=5&bitrate=125000"), &clock).unwrap();
    let mut l = link.frame_link().unwrap();
    assert_eq!(l.bitrate(), 125_000);
    // SDO upload request of index 0x5FFF - 1 (C0001), subindex 0.
    let req = CanFrame::new(0x605, &[0x40, 0xFE, 0x5F, 0, 0, 0, 0, 0]).unwrap();
    l.send(&req).unwrap();
    let deadline = l.clock().deadline_in(Duration::from_millis(100));
    let answer = l.recv(deadline).unwrap().expect("an answer");
    assert_eq!(answer.id, 0x585);
}

/// The simulator refuses exactly the addresses the descriptor's rule
/// refuses, on every family's bus, in its own words.
#[test]
fn the_address_check_is_the_descriptors_rule() {
    for family in Family::ALL {
        for address in 0..=u8::MAX {
            let rule = family.descriptor().check_address(i64::from(address));
            let sim = check_address(family, address);
            assert_eq!(sim.is_ok(), rule.is_ok(), "{family:?} {address}");
            if let Err(e) = sim {
                assert!(
                    e.to_string().starts_with(&format!(
                        "{}: address {address} is not allowed: ",
                        family.name()
                    )),
                    "{e}"
                );
            }
        }
    }
}
