//! PortSpec: every form parses, prints back canonically, and every error
//! says exactly what is wrong.

use std::collections::BTreeMap;

use driveset_link::spec::{DEFAULT_BAUD, DEFAULT_BITRATE};
use driveset_link::{EchoMode, OpaqueSpec, PortSpec, PortSpecErrorKind};

fn ok(input: &str) -> PortSpec {
    match PortSpec::parse(input) {
        Ok(spec) => spec,
        Err(e) => panic!("`{input}` should parse: {e}"),
    }
}

fn err(input: &str) -> PortSpecErrorKind {
    match PortSpec::parse(input) {
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
fn serial_paths() {
    assert_eq!(
        ok("/dev/ttyUSB0"),
        PortSpec::Serial {
            path: "/dev/ttyUSB0".into(),
            baud: None,
            echo: None,
            latency: None
        }
    );
    assert_eq!(
        ok("COM3?baud=19200"),
        PortSpec::Serial {
            path: "COM3".into(),
            baud: Some(19200),
            echo: None,
            latency: None
        }
    );
    round_trip("/dev/ttyUSB0?baud=9600", "/dev/ttyUSB0?baud=9600");
    round_trip("  COM3  ", "COM3");
    assert_eq!(ok("COM3").line_baud(), Some(DEFAULT_BAUD));
    assert_eq!(ok("COM3").can_bitrate(), None);
    assert!(!ok("COM3").is_can());
}

#[test]
fn tcp_hosts() {
    assert_eq!(
        ok("tcp://192.168.0.7:4001"),
        PortSpec::Tcp {
            host: "192.168.0.7".into(),
            port: 4001,
            baud: None,
            echo: None,
            latency: None
        }
    );
    assert_eq!(
        ok("tcp://[::1]:4001?baud=57600"),
        PortSpec::Tcp {
            host: "::1".into(),
            port: 4001,
            baud: Some(57600),
            echo: None,
            latency: None
        }
    );
    round_trip(
        "tcp://moxa-3.line2.local:950",
        "tcp://moxa-3.line2.local:950",
    );
    round_trip(
        "tcp://[fe80::1]:4001?baud=1200",
        "tcp://[fe80::1]:4001?baud=1200",
    );
    assert_eq!(ok("tcp://h:1?baud=38400").line_baud(), Some(38400));
}

#[test]
fn echo_option_on_character_lines() {
    assert_eq!(
        ok("/dev/ttyUSB0?echo=on&baud=19200"),
        PortSpec::Serial {
            path: "/dev/ttyUSB0".into(),
            baud: Some(19200),
            echo: Some(EchoMode::On),
            latency: None
        }
    );
    // Canonical: baud before echo; auto (the default) left out.
    round_trip(
        "/dev/ttyUSB0?echo=on&baud=19200",
        "/dev/ttyUSB0?baud=19200&echo=on",
    );
    round_trip("COM3?echo=auto", "COM3");
    round_trip("tcp://h:4001?echo=off", "tcp://h:4001?echo=off");
    round_trip(
        "rfc2217://h:2217?echo=on&baud=57600",
        "rfc2217://h:2217?baud=57600&echo=on",
    );
    assert_eq!(ok("COM3").echo(), Some(EchoMode::Auto));
    assert_eq!(ok("COM3?echo=off").echo(), Some(EchoMode::Off));
    assert_eq!(ok("sim://mc6000?addresses=1").echo(), None);
    assert_eq!(
        ok("COM3?echo=on").with_echo(EchoMode::Off).to_string(),
        "COM3?echo=off"
    );
    assert_eq!(
        ok("COM3?echo=on").with_echo(EchoMode::Auto).to_string(),
        "COM3"
    );
    assert_eq!(
        err("COM3?echo=yes"),
        PortSpecErrorKind::BadValue {
            key: "echo".into(),
            value: "yes".into(),
            reason: "use auto (detect, the default), on (the line returns what driveset sends: strip it) or off".into()
        }
    );
    assert_eq!(
        PortSpec::parse("COM3?echo=yes")
            .expect_err("bad")
            .to_string(),
        "invalid port `COM3?echo=yes`: `echo=yes`: use auto (detect, the default), on (the line returns what driveset sends: strip it) or off"
    );
    // Not for CAN or simulated ports.
    assert!(matches!(
        err("slcan:///dev/ttyACM0?echo=on"),
        PortSpecErrorKind::UnknownOption { ref key, .. } if key == "echo"
    ));
}

#[test]
fn rfc2217_hosts() {
    assert_eq!(
        ok("rfc2217://192.168.0.7:2217?baud=19200"),
        PortSpec::Rfc2217 {
            host: "192.168.0.7".into(),
            port: 2217,
            baud: Some(19200),
            echo: None,
            latency: None
        }
    );
    round_trip("rfc2217://[::1]:2217", "rfc2217://[::1]:2217");
    assert_eq!(ok("rfc2217://h:7000").line_baud(), Some(DEFAULT_BAUD));
    assert_eq!(ok("rfc2217://h:7000").can_bitrate(), None);
    assert!(!ok("rfc2217://h:7000").is_can());
    // raw tcp:// stays its own kind.
    assert!(matches!(ok("tcp://h:7000"), PortSpec::Tcp { .. }));
    assert!(matches!(
        err("rfc2217://"),
        PortSpecErrorKind::Missing {
            scheme: "rfc2217",
            what: "host:port",
            example: "rfc2217://192.168.0.7:2217"
        }
    ));
    assert!(matches!(
        err("rfc2217://h:1/x"),
        PortSpecErrorKind::TrailingPath {
            scheme: "rfc2217",
            ..
        }
    ));
    assert_eq!(
        PortSpec::parse("rfc2217://h:1?bitrate=500000")
            .expect_err("bad")
            .to_string(),
        "invalid port `rfc2217://h:1?bitrate=500000`: unknown option `bitrate` for rfc2217:// ports; allowed: baud, echo, latency"
    );
}

#[test]
fn slcan_and_can() {
    assert_eq!(
        ok("slcan:///dev/ttyACM0?bitrate=500000"),
        PortSpec::Slcan {
            path: "/dev/ttyACM0".into(),
            bitrate: Some(500_000),
            baud: None
        }
    );
    round_trip(
        "slcan://COM4?bitrate=125000&baud=115200",
        "slcan://COM4?baud=115200&bitrate=125000",
    );
    assert_eq!(
        ok("slcan:///dev/ttyACM0").can_bitrate(),
        Some(DEFAULT_BITRATE)
    );
    assert!(ok("slcan:///dev/ttyACM0").is_can());
    assert_eq!(ok("slcan:///dev/ttyACM0").line_baud(), None);
    assert_eq!(
        ok("can://can0"),
        PortSpec::SocketCan {
            interface: "can0".into(),
            bitrate: None
        }
    );
    round_trip("can://can0?bitrate=250000", "can://can0?bitrate=250000");
    // baud= is a synonym of bitrate= for can://
    round_trip("can://can1?baud=1000000", "can://can1?bitrate=1000000");
    round_trip(
        "can://can1?baud=1000000&bitrate=1000000",
        "can://can1?bitrate=1000000",
    );
}

/// `sim://` ports are the simulator's (its opener checks the keys:
/// driveset-sim's `port` module and its tests): this crate keeps the query
/// opaque and checks only its form.
#[test]
fn opener_ports_keep_their_query_opaque() {
    let mut query = BTreeMap::new();
    query.insert("colour".to_string(), "red".to_string());
    query.insert("addresses".to_string(), " 7".to_string());
    assert_eq!(
        ok("sim://any thing?colour=red&addresses= 7"),
        PortSpec::Sim(OpaqueSpec {
            scheme: "sim".into(),
            path: "any thing".into(),
            query,
        })
    );
    round_trip(
        "sim://mc6000?seed=1&addresses=1",
        "sim://mc6000?addresses=1&seed=1",
    );
    assert_eq!(ok("sim://x?baud=19200").line_baud(), Some(19200));
    assert_eq!(ok("sim://x?bitrate=x").can_bitrate(), Some(DEFAULT_BITRATE));
    assert_eq!(
        err("sim://x?a=1&a=2"),
        PortSpecErrorKind::DuplicateOption { key: "a".into() }
    );
    assert_eq!(err("sim://x?a=1&&b=2"), PortSpecErrorKind::EmptyOption);
    assert_eq!(
        err("sim://x?a"),
        PortSpecErrorKind::MalformedOption { item: "a".into() }
    );
    assert!(matches!(
        err("sim://x?a="),
        PortSpecErrorKind::BadValue { ref key, .. } if key == "a"
    ));
}

#[test]
fn errors_name_what_is_wrong() {
    assert_eq!(err(""), PortSpecErrorKind::Empty);
    assert_eq!(err("   "), PortSpecErrorKind::Empty);
    assert_eq!(
        err("udp://1.2.3.4:5"),
        PortSpecErrorKind::UnknownScheme {
            scheme: "udp".into()
        }
    );
    assert!(matches!(
        err("?baud=9600"),
        PortSpecErrorKind::Missing {
            scheme: "serial",
            ..
        }
    ));
    assert_eq!(err("/dev/ttyS0?"), PortSpecErrorKind::EmptyOption);
    assert_eq!(err("/dev/ttyS0?baud=9600&"), PortSpecErrorKind::EmptyOption);
    assert_eq!(
        err("/dev/ttyS0?baud"),
        PortSpecErrorKind::MalformedOption {
            item: "baud".into()
        }
    );
    assert!(matches!(
        err("/dev/ttyS0?parity=odd"),
        PortSpecErrorKind::UnknownOption { ref key, scheme: "serial", allowed: &["baud", "echo", "latency"] } if key == "parity"
    ));
    assert!(matches!(
        err("tcp://h:1?bitrate=500000"),
        PortSpecErrorKind::UnknownOption { ref key, scheme: "tcp://", .. } if key == "bitrate"
    ));
    assert!(matches!(
        err("can://can0?addresses=1"),
        PortSpecErrorKind::UnknownOption { ref key, scheme: "can://", .. } if key == "addresses"
    ));
    assert!(matches!(
        err("slcan:///dev/ttyACM0?speed=1"),
        PortSpecErrorKind::UnknownOption { ref key, scheme: "slcan://", .. } if key == "speed"
    ));
    assert_eq!(
        err("COM1?baud=9600&baud=9600"),
        PortSpecErrorKind::DuplicateOption { key: "baud".into() }
    );
    assert!(matches!(
        err("COM1?baud=fast"),
        PortSpecErrorKind::BadValue { ref key, ref value, .. } if key == "baud" && value == "fast"
    ));
    assert!(matches!(
        err("COM1?baud="),
        PortSpecErrorKind::BadValue { .. }
    ));
    assert!(matches!(
        err("COM1?baud=0"),
        PortSpecErrorKind::BadValue { .. }
    ));
    assert_eq!(
        err("COM1?baud=115200"),
        PortSpecErrorKind::UnsupportedBaud { baud: 115_200 }
    );
    assert_eq!(
        err("tcp://h:1?baud=300"),
        PortSpecErrorKind::UnsupportedBaud { baud: 300 }
    );
    assert_eq!(
        err("slcan://COM4?bitrate=333333"),
        PortSpecErrorKind::UnsupportedBitrate { bitrate: 333_333 }
    );
    assert_eq!(
        err("can://can0?baud=9600"),
        PortSpecErrorKind::UnsupportedBitrate { bitrate: 9600 }
    );
    assert_eq!(
        err("can://can0?baud=125000&bitrate=500000"),
        PortSpecErrorKind::ConflictingRates {
            baud: 125_000,
            bitrate: 500_000
        }
    );
}

#[test]
fn tcp_errors() {
    assert!(matches!(
        err("tcp://"),
        PortSpecErrorKind::Missing {
            scheme: "tcp",
            what: "host:port",
            ..
        }
    ));
    assert!(matches!(
        err("tcp://host"),
        PortSpecErrorKind::Missing {
            what: "a port after the host",
            ..
        }
    ));
    assert!(matches!(
        err("tcp://:4001"),
        PortSpecErrorKind::Missing {
            what: "a host before the port",
            ..
        }
    ));
    assert!(matches!(
        err("tcp://[::1]"),
        PortSpecErrorKind::Missing {
            what: "a port after the host",
            ..
        }
    ));
    assert!(matches!(
        err("tcp://[::1:4001"),
        PortSpecErrorKind::BadHost { .. }
    ));
    assert!(
        matches!(err("tcp://::1:4001"), PortSpecErrorKind::BadHost { ref host, .. } if host == "::1")
    );
    assert!(matches!(
        err("tcp://us er:1"),
        PortSpecErrorKind::BadHost { .. }
    ));
    assert_eq!(
        err("tcp://h:0"),
        PortSpecErrorKind::BadTcpPort { value: "0".into() }
    );
    assert_eq!(
        err("tcp://h:65536"),
        PortSpecErrorKind::BadTcpPort {
            value: "65536".into()
        }
    );
    assert_eq!(
        err("tcp://h:x"),
        PortSpecErrorKind::BadTcpPort { value: "x".into() }
    );
    assert!(matches!(
        err("tcp://h:4001/ttyS1"),
        PortSpecErrorKind::TrailingPath { ref rest, scheme: "tcp", .. } if rest == "/ttyS1"
    ));
}

#[test]
fn can_slcan_sim_errors() {
    assert!(matches!(
        err("slcan://"),
        PortSpecErrorKind::Missing {
            scheme: "slcan",
            ..
        }
    ));
    assert!(matches!(
        err("can://"),
        PortSpecErrorKind::Missing { scheme: "can", .. }
    ));
    assert!(matches!(
        err("can://can0/x"),
        PortSpecErrorKind::TrailingPath { ref rest, scheme: "can", .. } if rest == "/x"
    ));
    assert!(matches!(
        err("can://a_very_long_name0"),
        PortSpecErrorKind::BadInterface { .. }
    ));
    assert!(matches!(
        err("can://can 0"),
        PortSpecErrorKind::BadInterface { .. }
    ));
}

#[test]
fn error_messages_carry_input_and_remedy() {
    let e = PortSpec::parse("COM1?baud=115200").unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid port `COM1?baud=115200`: baud=115200 is not supported; a 7E1 line runs at one of 1200, 2400, 4800, 9600, 19200, 38400, 57600 baud"
    );
    let e = PortSpec::parse("/dev/ttyS0?parity=odd").unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid port `/dev/ttyS0?parity=odd`: unknown option `parity` for serial ports; allowed: baud, echo, latency"
    );
}

mod properties {
    use driveset_link::PortSpec;
    use proptest::prelude::*;

    proptest! {
        /// Any input gives a spec or an error, never a panic; a spec's
        /// canonical string parses back to the same spec.
        #[test]
        fn parse_never_panics_and_round_trips(input in ".{0,40}") {
            if let Ok(spec) = PortSpec::parse(&input) {
                prop_assert_eq!(PortSpec::parse(&spec.to_string()), Ok(spec));
            }
        }

        #[test]
        fn generated_specs_round_trip(
            scheme in 0usize..7,
            name in "[a-z][a-z0-9_-]{0,10}",
            port in 1u16..,
            baud in prop::sample::select(driveset_link::spec::ALLOWED_BAUDS),
            bitrate in prop::sample::select(driveset_link::spec::ALLOWED_BITRATES),
            addresses in prop::collection::btree_set(any::<u8>(), 1..5),
        ) {
            let addresses: Vec<String> = addresses.iter().map(u8::to_string).collect();
            let input = match scheme {
                0 => format!("/dev/{name}?baud={baud}"),
                1 => format!("tcp://{name}:{port}?baud={baud}"),
                2 => format!("slcan:///dev/{name}?bitrate={bitrate}"),
                3 => format!("can://{name}?bitrate={bitrate}"),
                4 => format!("rfc2217://{name}:{port}?baud={baud}&echo=on"),
                5 => format!("/dev/{name}?echo=off"),
                _ => format!("sim://{name}?addresses={}&baud={baud}", addresses.join(",")),
            };
            let spec = PortSpec::parse(&input);
            prop_assert!(spec.is_ok(), "{input}: {spec:?}");
            if let Ok(spec) = spec {
                prop_assert_eq!(spec.to_string(), input);
            }
        }
    }
}

#[test]
fn latency_option_on_serial_and_tcp_ports() {
    use std::time::Duration;
    assert_eq!(
        ok("tcp://127.0.0.1:4001?latency=40ms"),
        PortSpec::Tcp {
            host: "127.0.0.1".into(),
            port: 4001,
            baud: None,
            echo: None,
            latency: Some(Duration::from_millis(40))
        }
    );
    assert_eq!(
        ok("/dev/ttyUSB0?latency=0.1s&baud=19200").latency(),
        Some(Duration::from_millis(100))
    );
    assert_eq!(
        ok("COM3?latency=16.5ms").latency(),
        Some(Duration::from_micros(16_500))
    );
    round_trip(
        "tcp://127.0.0.1:4001?latency=0.25s&baud=57600",
        "tcp://127.0.0.1:4001?baud=57600&latency=250ms",
    );
    round_trip("COM3?latency=16.5ms", "COM3?latency=16500us");
    round_trip("COM3?latency=0ms", "COM3?latency=0ms");
    assert_eq!(ok("COM3").latency(), None);
    for (input, reason) in [
        (
            "COM3?latency=40",
            "give a unit: e.g. latency=40ms or latency=0.1s",
        ),
        (
            "COM3?latency=fast ms",
            "not a number with a unit (ms, s, us), e.g. latency=40ms",
        ),
        (
            "COM3?latency=-4ms",
            "not a number with a unit (ms, s, us), e.g. latency=40ms",
        ),
        ("COM3?latency=11s", "at most 10 s"),
        ("COM3?latency=0.0000001s", "finer than a microsecond"),
    ] {
        let e = PortSpec::parse(input).unwrap_err();
        let value = input.split_once("latency=").unwrap().1;
        assert_eq!(
            e.to_string(),
            format!("invalid port `{input}`: `latency={value}`: {reason}"),
            "{input}"
        );
    }
    let e = PortSpec::parse("slcan:///dev/ttyACM0?latency=4ms").unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid port `slcan:///dev/ttyACM0?latency=4ms`: unknown option `latency` for slcan:// ports; allowed: bitrate, baud"
    );
}
