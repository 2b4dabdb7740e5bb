//! scan and identify against simulated buses: only the drives present are
//! found, reserved addresses are refused, baud detection finds the rate.

use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{DriveClient, LustbusClient};
use driveset_engine::error::{ErrorKind, Layer, Refused};
use driveset_engine::identify::check_family;
use driveset_engine::scan::{
    LUSTBUS_BAUDS, ScanError, ScanOptions, ScanPlan, can_nodes, detect_baud, lecom_addresses,
    lustbus_addresses, scan_bus, scan_can, scan_lecom, scan_lustbus, scan_rates,
};
use driveset_link::{ByteLink, Link, VirtualClock};
use driveset_proto::can::NodeId;
use driveset_schema::BusProtocol;
use driveset_sim::bus::SimByteBus;
use driveset_sim::can_bus::SimCanBus;
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::{ByteDrive, FrameDrive, ReactionTime};
use driveset_sim::ecs::EcsDrive;
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::tmd::{TmdDrive, TmdOptions};
use driveset_sim::vf1000::Vf1000;

fn lust(address: u8) -> LustOptions {
    LustOptions::new(address).reaction(ReactionTime::fixed(Duration::from_millis(2)))
}

fn lust_drives() -> Vec<Box<dyn ByteDrive>> {
    vec![
        Box::new(Mc6000::new(lust(3)).unwrap()),
        Box::new(Vf1000::new(lust(7)).unwrap()),
        Box::new(Mc6000::new(lust(30)).unwrap()),
    ]
}

#[test]
fn lustbus_scan_finds_exactly_the_drives_present() {
    let clock = VirtualClock::new();
    let mut bus = SimByteBus::new(&clock, 19200, lust_drives()).unwrap();
    let found = scan_lustbus(&mut bus, &lustbus_addresses(), &ScanOptions::default()).unwrap();
    let addresses: Vec<u8> = found.iter().map(|f| f.address).collect();
    assert_eq!(addresses, vec![3, 7, 30]);
    assert!(found.iter().all(|f| f.identity.codes[0].name == "91-TYPE"));
    for bad in [0u8, 31] {
        let err = scan_lustbus(&mut bus, &[bad], &ScanOptions::default()).unwrap_err();
        assert!(
            matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
            "{err}"
        );
    }
}

#[test]
fn lecom_scan_skips_group_addresses() {
    let clock = VirtualClock::new();
    let drives: Vec<Box<dyn ByteDrive>> = vec![
        Box::new(TmdDrive::new(TmdOptions::at(5)).unwrap()),
        Box::new(TmdDrive::new(TmdOptions::at(23)).unwrap()),
    ];
    let mut bus = SimByteBus::new(&clock, 9600, drives).unwrap();
    let addrs = lecom_addresses();
    assert_eq!(addrs.len(), 90);
    assert!(!addrs.contains(&10) && !addrs.contains(&0));
    let schema = catalog::schema(Family::Tmd).unwrap();
    let found = scan_lecom(&mut bus, Some(&schema), &addrs, &ScanOptions::default()).unwrap();
    let addresses: Vec<u8> = found.iter().map(|f| f.address).collect();
    assert_eq!(addresses, vec![5, 23]);
    assert_eq!(found[0].identity.codes[0].name, "C0093");
    let err = scan_lecom(&mut bus, None, &[20], &ScanOptions::default()).unwrap_err();
    assert!(
        matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{err}"
    );
}

#[test]
fn can_scan_finds_the_nodes() {
    let clock = VirtualClock::new();
    let drives: Vec<Box<dyn FrameDrive>> = vec![
        Box::new(EcsDrive::new(NodeId::new(2).unwrap(), 1).unwrap()),
        Box::new(EcsDrive::new(NodeId::new(100).unwrap(), 1).unwrap()),
    ];
    let mut bus = SimCanBus::new(&clock, 500_000, drives).unwrap();
    let schema = catalog::schema(Family::Ecs).unwrap();
    let found = scan_can(&mut bus, &schema, &can_nodes(), &ScanOptions::default()).unwrap();
    let nodes: Vec<u8> = found.iter().map(|f| f.address).collect();
    assert_eq!(nodes, vec![2, 100]);
    assert!(scan_can(&mut bus, &schema, &[0], &ScanOptions::default()).is_err());
}

#[test]
fn baud_detection_tries_rates_highest_first() {
    let clock = VirtualClock::new();
    let mut tried = Vec::new();
    let mut open = |baud: u32| -> Result<Box<dyn ByteLink>, driveset_link::LinkError> {
        tried.push(baud);
        // The drives run at 9600; the host opens its end at `baud`.
        let mut bus = SimByteBus::new(&clock, 9600, lust_drives()).unwrap();
        bus.set_baud(baud).unwrap();
        Ok(Box::new(bus))
    };
    let opts = ScanOptions::default();
    let mut scan = |link: &mut dyn ByteLink| scan_lustbus(link, &[3, 7], &opts);
    let got = detect_baud(&LUSTBUS_BAUDS, &mut open, &mut scan)
        .unwrap()
        .expect("found");
    assert_eq!(got.baud, 9600);
    assert_eq!(got.link.baud(), 9600);
    assert_eq!(got.found.len(), 2);
    assert_eq!(tried, vec![57600, 38400, 19200, 9600]);
}

/// `driveset scan`'s plan on a character line of unknown protocol:
/// LUSTBUS, then LECOM.
fn line_plan() -> ScanPlan {
    ScanPlan {
        choices: vec![
            (
                BusProtocol::Lustbus,
                catalog::schema(Family::Mc6000).unwrap(),
            ),
            (BusProtocol::Lecom, catalog::schema(Family::Tmd).unwrap()),
        ],
        options: ScanOptions::default(),
    }
}

#[test]
fn a_bus_scan_tries_the_protocols_in_turn_and_names_the_one_that_answered() {
    let clock = VirtualClock::new();
    let drives: Vec<Box<dyn ByteDrive>> = vec![Box::new(TmdDrive::new(TmdOptions::at(5)).unwrap())];
    let mut link = Link::Bytes(Box::new(SimByteBus::new(&clock, 9600, drives).unwrap()));
    let got = scan_bus(&mut link, "sim://line", &line_plan()).unwrap();
    assert_eq!(got.protocol, BusProtocol::Lecom);
    assert_eq!(got.probed, vec![BusProtocol::Lecom]);
    assert_eq!((got.baud, got.other_rate), (None, None));
    let addresses: Vec<u8> = got.found.iter().map(|f| f.address).collect();
    assert_eq!(addresses, vec![5]);
}

#[test]
fn a_bus_scan_finds_lustbus_drives_left_at_another_rate_on_the_same_port() {
    let clock = VirtualClock::new();
    // the drives run at 9600; the port is opened at 19200
    let mut bus = SimByteBus::new(&clock, 9600, lust_drives()).unwrap();
    bus.set_baud(19200).unwrap();
    let mut link = Link::Bytes(Box::new(bus));
    let got = scan_bus(&mut link, "sim://line", &line_plan()).unwrap();
    assert_eq!(got.protocol, BusProtocol::Lustbus);
    assert_eq!((got.baud, got.other_rate), (Some(9600), Some(19200)));
    assert_eq!(got.found.len(), 3);
    // nobody anywhere: every protocol asked is named as probed, the first
    // is the report's
    let mut empty = Link::Bytes(Box::new(SimByteBus::new(&clock, 9600, Vec::new()).unwrap()));
    let got = scan_bus(&mut empty, "sim://line", &line_plan()).unwrap();
    assert!(got.found.is_empty());
    assert_eq!(got.protocol, BusProtocol::Lustbus);
    assert_eq!(got.probed, vec![BusProtocol::Lustbus, BusProtocol::Lecom]);
}

#[test]
fn a_bus_scan_refuses_a_protocol_the_link_does_not_carry_as_an_input_error() {
    let clock = VirtualClock::new();
    let ecs = catalog::schema(Family::Ecs).unwrap();
    let can_plan = ScanPlan {
        choices: vec![(BusProtocol::CanSdo, ecs)],
        options: ScanOptions::default(),
    };
    let mut line = Link::Bytes(Box::new(SimByteBus::new(&clock, 9600, Vec::new()).unwrap()));
    let e = scan_bus(&mut line, "sim://line", &can_plan).unwrap_err();
    assert!(matches!(e, ScanError::CharacterLine { .. }), "{e}");
    assert_eq!(e.layer(), Layer::Input);
    assert_eq!(
        e.to_string(),
        "sim://line is a character line: scan it with --protocol lustbus or lecom"
    );
    let mut can = Link::Frames(Box::new(
        SimCanBus::new(&clock, 500_000, Vec::new()).unwrap(),
    ));
    let e = scan_bus(&mut can, "sim://can", &line_plan()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "sim://can is a CAN port: scan it with --protocol sdo"
    );
    assert_eq!(e.layer(), Layer::Input);
    let mut reopen = |_: u32| -> Result<Box<dyn ByteLink>, driveset_link::LinkError> {
        unreachable!("a rate search on CAN SDO is refused before any opening")
    };
    let e = scan_rates(&can_plan, &mut reopen).unwrap_err();
    assert!(matches!(e, ScanError::RatesOnCan), "{e}");
}

#[test]
fn a_rate_search_reports_the_rate_and_the_protocol_that_answered() {
    let clock = VirtualClock::new();
    let mut open = |baud: u32| -> Result<Box<dyn ByteLink>, driveset_link::LinkError> {
        let mut bus = SimByteBus::new(&clock, 9600, lust_drives()).unwrap();
        bus.set_baud(baud).unwrap();
        Ok(Box::new(bus))
    };
    let got = scan_rates(&line_plan(), &mut open).unwrap();
    assert_eq!(got.protocol, BusProtocol::Lustbus);
    assert_eq!((got.baud, got.other_rate), (Some(9600), None));
    assert_eq!(got.found.len(), 3);
}

#[test]
fn identify_and_family_check() {
    let clock = VirtualClock::new();
    let bus = SimByteBus::new(&clock, 19200, lust_drives()).unwrap();
    let schema = catalog::schema(Family::Mc6000).unwrap();
    let mut c = LustbusClient::new(bus, Arc::clone(&schema), 3).unwrap();
    let id = check_family(&mut c).unwrap();
    assert_eq!(id.protocol.name(), "lustbus-mc");
    assert_eq!(id.codes[0].name, "91-TYPE");
    c.finish().unwrap();
}
