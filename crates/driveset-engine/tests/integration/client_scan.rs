//! scan and identify against simulated buses: only the drives present are
//! found, reserved addresses are refused, baud detection finds the rate.

use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{DriveClient, LustbusClient};
use driveset_engine::error::{ErrorKind, Refused};
use driveset_engine::identify::check_family;
use driveset_engine::scan::{
    LUSTBUS_BAUDS, ScanOptions, can_nodes, detect_baud, lecom_addresses, lustbus_addresses,
    scan_can, scan_lecom, scan_lustbus,
};
use driveset_link::{ByteLink, VirtualClock};
use driveset_proto::can::NodeId;
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
