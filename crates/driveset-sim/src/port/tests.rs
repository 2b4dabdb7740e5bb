//! The `sim://` port's keys (moved here from driveset-link's port
//! parser tests with the keys): every form parses, prints back
//! canonically, every error says exactly what is wrong.

use std::collections::BTreeMap;

use driveset_link::{OpaqueSpec, PortOpener, PortSpecErrorKind};

use super::*;

#[test]
fn a_port_name_keeps_its_state_file_absolute_and_drops_no_run_key_until_asked() {
    let dir = std::env::temp_dir().join(format!("driveset-sim-port-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let canon = std::fs::canonicalize(&dir).unwrap();
    let spelled = format!(
        "sim://tmd?seed=7&state={}/./s.json&addresses=11&faults=cable@30+600s&c0001=3",
        dir.display()
    );
    let s = SimSpec::parse(&spelled).unwrap();
    assert_eq!(
        s.name(),
        format!(
            "sim://tmd?addresses=11&c0001=3&faults=cable@30+600s&seed=7&state={}",
            canon.join("s.json").display()
        )
    );
    assert_eq!(
        s.without_run_keys().name(),
        format!(
            "sim://tmd?addresses=11&c0001=3&state={}",
            canon.join("s.json").display()
        )
    );
    // the bus id ignores the run keys and the key order
    let a = SimOpener::default().config(&s).unwrap().bus_id();
    let b = SimOpener::default()
        .config(&s.without_run_keys())
        .unwrap()
        .bus_id();
    assert_eq!(a, b);
    assert_eq!(a, format!("sim:tmd@{}", canon.join("s.json").display()));
    let _ = std::fs::remove_dir_all(&dir);
}

fn ok(input: &str) -> SimSpec {
    match SimSpec::parse(input) {
        Ok(spec) => spec,
        Err(e) => panic!("`{input}` should parse: {e}"),
    }
}

fn err(input: &str) -> PortSpecErrorKind {
    match SimSpec::parse(input) {
        Ok(spec) => panic!("`{input}` should not parse, got {spec:?}"),
        Err(e) => {
            assert_eq!(e.input, input);
            e.kind
        }
    }
}

fn round_trip(input: &str, canonical: &str) {
    let spec = ok(input);
    assert_eq!(spec.to_string(), canonical, "canonical form of `{input}`");
    assert_eq!(ok(canonical), spec, "`{canonical}` parses back");
}

#[test]
fn sim_ports_take_no_line_options() {
    assert!(matches!(
        err("sim://mc6000?addresses=1&echo=on"),
        PortSpecErrorKind::UnknownOption { ref key, .. } if key == "echo"
    ));
}

#[test]
fn sim_buses() {
    let mut options = BTreeMap::new();
    options.insert("seed".to_string(), "42".to_string());
    assert_eq!(
        ok("sim://lust-vf1000?seed=42&addresses=3,1,2&baud=19200"),
        (SimSpec {
            family: "lust-vf1000".into(),
            addresses: vec![3, 1, 2],
            families: BTreeMap::new(),
            factory: Vec::new(),
            bench: false,
            baud: Some(19200),
            bitrate: None,
            options,
        })
    );
    round_trip(
        "sim://lust-vf1000?seed=42&addresses=3,1,2&baud=19200",
        "sim://lust-vf1000?addresses=3,1,2&baud=19200&seed=42",
    );
    round_trip(
        "sim://lenze_ecs?bitrate=125000&addresses=1&faults=drop:0.1",
        "sim://lenze_ecs?addresses=1&bitrate=125000&faults=drop:0.1",
    );
    round_trip(
        "sim://mc6000?state=/tmp/line/sim.json&keypad=true&addresses=1",
        "sim://mc6000?addresses=1&keypad=true&state=/tmp/line/sim.json",
    );
    assert_eq!(ok("sim://x?addresses=0").baud, None);
    assert_eq!(
        SimSpec::parse("sim://x?addresses= 7").map(|s| s.to_string()),
        Ok("sim://x?addresses=7".into())
    );
}

#[test]
fn mixed_lustbus_sim_buses() {
    let sim = ok("sim://lustbus?vf1000=7,5&mc6000=1,2&baud=19200");
    assert!(sim.is_mixed());
    assert!(sim.addresses.is_empty());
    assert_eq!(sim.families["mc6000"], [1, 2]);
    assert_eq!(sim.families["vf1000"], [7, 5]);
    assert_eq!(
        sim.drives(),
        [("mc6000", 1), ("mc6000", 2), ("vf1000", 7), ("vf1000", 5)]
    );
    assert_eq!(sim.all_addresses(), [1, 2, 7, 5]);
    round_trip(
        "sim://lustbus?vf1000=7,5&seed=1&mc6000=1,2&baud=19200",
        "sim://lustbus?mc6000=1,2&vf1000=7,5&baud=19200&seed=1",
    );
    round_trip("sim://lustbus?mc7000=3", "sim://lustbus?mc7000=3");
    let single = ok("sim://mc6000?addresses=1,2");
    assert!(!single.is_mixed());
    assert_eq!(single.drives(), [("mc6000", 1), ("mc6000", 2)]);
    // One address space across the families.
    assert_eq!(
        err("sim://lustbus?mc6000=1,2&vf1000=2"),
        PortSpecErrorKind::DuplicateAddress { address: 2 }
    );
    assert_eq!(
        err("sim://lustbus?vf1000=x"),
        PortSpecErrorKind::BadAddress { value: "x".into() }
    );
    assert!(matches!(
        err("sim://lustbus"),
        PortSpecErrorKind::Missing { scheme: "sim", .. }
    ));
    assert!(matches!(
        err("sim://lustbus?addresses=1&mc6000=2"),
        PortSpecErrorKind::MixedBus { ref reason } if reason.contains("not addresses=")
    ));
    assert!(matches!(
        err("sim://mc6000?addresses=1&vf1000=2"),
        PortSpecErrorKind::MixedBus { ref reason } if reason.contains("sim://lustbus?vf1000=")
    ));
    assert!(matches!(
        err("sim://lustbus?tmd=1"),
        PortSpecErrorKind::UnknownOption { ref key, scheme: "sim://", .. } if key == "tmd"
    ));
}

#[test]
fn errors_name_what_is_wrong() {
    assert!(matches!(
        err("sim://x?addresses=1&colour=red"),
        PortSpecErrorKind::UnknownOption { ref key, scheme: "sim://", .. } if key == "colour"
    ));

    assert!(matches!(
        err("sim://"),
        PortSpecErrorKind::Missing {
            scheme: "sim",
            what: "a drive family",
            ..
        }
    ));
    assert!(matches!(
        err("sim://vf1000?addresses=x"),
        PortSpecErrorKind::BadAddress { .. }
    ));
    assert_eq!(
        err("sim://vf 1000?addresses=1"),
        PortSpecErrorKind::BadFamily {
            family: "vf 1000".into()
        }
    );
    assert_eq!(
        err("sim://vf1000?addresses=1,,2"),
        PortSpecErrorKind::BadAddress { value: "".into() }
    );
    assert_eq!(
        err("sim://vf1000?addresses=256"),
        PortSpecErrorKind::BadAddress {
            value: "256".into()
        }
    );
    assert_eq!(
        err("sim://vf1000?addresses=1,2,1"),
        PortSpecErrorKind::DuplicateAddress { address: 1 }
    );
    assert!(matches!(
        err("sim://vf1000?addresses=1&seed=-1"),
        PortSpecErrorKind::BadValue { ref key, .. } if key == "seed"
    ));
    assert_eq!(
        err("sim://vf1000?addresses=1&baud=100"),
        PortSpecErrorKind::UnsupportedBaud { baud: 100 }
    );
}

#[test]
fn options_are_kept_for_the_config() {
    // Without addresses= the port parses with no drive; the command's
    // --address supplies it (driveset-cli), the simulator refuses an empty bus.
    let sim = ok("sim://vf1000");
    assert!(sim.addresses.is_empty());
    let sim = ok("sim://mc6000?layout=43&types=table");
    assert_eq!(sim.options.get("layout").map(String::as_str), Some("43"));
    assert_eq!(sim.options.get("types").map(String::as_str), Some("table"));
}

/// The opener checks what driveset-link keeps opaque: unknown keys by
/// name, with the keys a `sim://` port takes.
#[test]
fn the_opener_checks_the_keys() {
    let opener = SimOpener::default();
    let opaque = |s: &str| match PortSpec::parse(s).unwrap() {
        PortSpec::Sim(o) => o,
        other => panic!("{other:?}"),
    };
    let e = opener
        .check(&opaque("sim://mc6000?addresses=1&colour=red"))
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid port `sim://mc6000?addresses=1&colour=red`: unknown option `colour` for sim:// ports; allowed: addresses, baud, bench, bitrate, c0001, describe, dir, factory, faults, file, keypad, layout, mc6000, mc7000, refuse, seed, state, types, vf1000"
    );
    let e = SimSpec::parse("sim://vf1000?baud=100&addresses=1").unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid port `sim://vf1000?baud=100&addresses=1`: baud=100 is not supported; a 7E1 line runs at one of 1200, 2400, 4800, 9600, 19200, 38400, 57600 baud"
    );
    let shape = opener
        .check(&opaque("sim://lustbus?vf1000=5&mc6000=1&state=/tmp/s.json"))
        .unwrap();
    assert_eq!(
        shape,
        PortShape {
            frames: false,
            drives: vec![("mc6000".into(), 1), ("vf1000".into(), 5)],
            mixed: true,
            name: "sim://lustbus?mc6000=1&vf1000=5&state=/tmp/s.json".into(),
        }
    );
    assert!(
        opener
            .check(&opaque("sim://ecs?addresses=3"))
            .unwrap()
            .frames
    );
    // A manifest's drives go onto a port that names none; its rate too.
    let filled = opener.with_drives(
        &opaque("sim://lustbus?seed=2"),
        &[("vf1000", 7), ("mc6000", 2), ("mc6000", 1)],
    );
    assert_eq!(
        filled.to_string(),
        "sim://lustbus?mc6000=1,2&seed=2&vf1000=7"
    );
    let kept = opener.with_drives(&opaque("sim://tmd?addresses=4"), &[("tmd", 9)]);
    assert_eq!(kept.to_string(), "sim://tmd?addresses=4");
    let mut q = BTreeMap::new();
    q.insert("addresses".to_string(), "1".to_string());
    q.insert("bitrate".to_string(), "250000".to_string());
    assert_eq!(
        opener.with_rate(&opaque("sim://ecs?addresses=1"), 250_000),
        OpaqueSpec {
            scheme: "sim".into(),
            path: "ecs".into(),
            query: q
        }
    );
    assert_eq!(
        opener
            .with_rate(&opaque("sim://tmd?addresses=1"), 19200)
            .to_string(),
        "sim://tmd?addresses=1&baud=19200"
    );
}
