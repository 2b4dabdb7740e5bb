//! LecomClient against the simulated Lenze Tmd (driveset-sim) in virtual
//! time: exact bytes, NAK causes via C0068 / C1962, "?" and lost answers,
//! broadcast, running(), identify.

use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{
    DriveClient, LecomClient, LecomOptions, dataset_or_refuse, set_line_rate,
};
use driveset_engine::error::{DeviceFailure, ErrorKind, LinkFailure, Refused};
use driveset_link::Clock;
use driveset_schema::{CodeKey, RawValue, Schema};
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::{ByteDrive, ReactionTime};
use driveset_sim::log::Dir;
use driveset_sim::tmd::{TmdDrive, TmdOptions};
use driveset_test_support::{sim_byte_bus, wire_bytes};

fn tmd(address: u8, control_source: u8) -> Box<dyn ByteDrive> {
    Box::new(
        TmdDrive::new(TmdOptions {
            address,
            control_source,
            reaction: ReactionTime::fixed(Duration::from_millis(3)),
            ..TmdOptions::default()
        })
        .expect("tmd"),
    )
}

fn schema() -> Arc<Schema> {
    catalog::schema(Family::Tmd).expect("schema")
}

#[test]
fn send_and_receive_exact_bytes() {
    // 8.I example: C11 = 95.2 at address 34.
    let (_clock, log, bus) = sim_byte_bus(9600, vec![tmd(34, 3)], None);
    let mut c = LecomClient::new(bus, schema(), 34).unwrap();
    c.write(CodeKey::new(11), &RawValue::Int(952_000)).unwrap();
    assert_eq!(c.read(CodeKey::new(11)).unwrap(), RawValue::Int(952_000));
    c.finish().unwrap();
    let host = wire_bytes(&log, Dir::Host);
    let text = b"1195.2\x03";
    let bcc = text.iter().fold(0u8, |a, b| a ^ b);
    let mut send = vec![0x04, b'3', b'4', 0x02];
    send.extend_from_slice(text);
    send.push(bcc);
    assert_eq!(host[0], send);
    assert_eq!(host[1], b"\x0434\x31\x31\x05".to_vec());
    assert_eq!(host[2], vec![0x04]);
    assert_eq!(host.len(), 3);
    let drive = wire_bytes(&log, Dir::Drive);
    assert_eq!(drive[0], vec![0x06]);
    let text = b"1195.2\x03";
    let bcc = text.iter().fold(0u8, |a, b| a ^ b);
    let mut answer = vec![0x02];
    answer.extend_from_slice(text);
    answer.push(bcc);
    assert_eq!(drive[1], answer);
}

/// The LECOM client has neither capability of [`DriveClient`]: no dataset
/// handshake (an MC6000/7000 one, LUSTBUS 11.4) and no line rate the
/// engine sets (`--transfer-baud` is LUSTBUS 11.5); a caller that needs
/// one is refused, and nothing is sent.
#[test]
fn no_dataset_download_and_no_settable_line_rate() {
    let (_clock, log, bus) = sim_byte_bus(9600, vec![tmd(1, 3)], None);
    let mut c = LecomClient::new(bus, schema(), 1).unwrap();
    assert!(c.dataset().is_none());
    assert!(c.line().is_none());
    assert_eq!(c.line_rate(), None);
    let err = dataset_or_refuse(&mut c).err().expect("refused");
    assert_eq!(
        err.to_string(),
        "sim address 1: refused: this drive family has no dataset download handshake"
    );
    let err = set_line_rate(&mut c, 19200).unwrap_err();
    assert!(
        matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{err}"
    );
    assert!(
        err.to_string()
            .contains("this client has no serial line whose rate could be set to 19200 baud"),
        "{err}"
    );
    assert!(wire_bytes(&log, Dir::Host).is_empty());
}

#[test]
fn nak_cause_is_read_from_c0068_and_c1962() {
    let (_clock, log, bus) = sim_byte_bus(9600, vec![tmd(1, 3)], None);
    let mut c = LecomClient::new(bus, schema(), 1).unwrap();
    // C0011 range 7.5..240 Hz.
    let err = c
        .write(CodeKey::new(11), &RawValue::Int(9_000_000))
        .unwrap_err();
    let ErrorKind::Device(DeviceFailure::Refused { cause, what, .. }) = &*err.kind else {
        panic!("{err}")
    };
    assert!(what.contains("C0011"), "{what}");
    assert_eq!(cause.cause(), "invalid variable");
    assert!(cause.raw().contains("bits 4..7 = 5"), "{}", cause.raw());
    assert!(
        cause.raw().contains("C1962 = invalid variable (14)"),
        "{}",
        cause.raw()
    );
    assert!(cause.remedy().contains("range"), "{}", cause.remedy());
    // C0068 (RECEIVE "68") and C1962 (extended field? no: standard C1 C2) read.
    let host = wire_bytes(&log, Dir::Host);
    assert_eq!(host.len(), 3);
    assert_eq!(host[1], b"\x0401\x36\x38\x05".to_vec());
}

#[test]
fn no_access_permission_names_the_remedy() {
    // C0001 = 0: LECOM may only read (manual 4e).
    let (_clock, _log, bus) = sim_byte_bus(9600, vec![tmd(1, 0)], None);
    let mut c = LecomClient::new(bus, schema(), 1).unwrap();
    let err = c
        .write(CodeKey::new(11), &RawValue::Int(500_000))
        .unwrap_err();
    let ErrorKind::Device(DeviceFailure::Refused { cause, .. }) = &*err.kind else {
        panic!("{err}")
    };
    assert_eq!(cause.cause(), "no access permission");
    assert!(
        cause.raw().contains("C1962 = no access permission (8)"),
        "{}",
        cause.raw()
    );
}

#[test]
fn checksum_answers_and_lost_answers_are_repeated() {
    let (_clock, _log, bus) =
        sim_byte_bus(9600, vec![tmd(1, 3)], Some("flip=0.15,lose=0.1,seed=11"));
    let opts = LecomOptions {
        tries: 6,
        ..LecomOptions::default()
    };
    let mut c = LecomClient::with_options(bus, schema(), 1, opts).unwrap();
    for _ in 0..15 {
        assert_eq!(c.read(CodeKey::new(11)).unwrap(), RawValue::Int(500_000));
    }
    assert!(c.stats().retries > 0);
}

#[test]
fn no_answer_after_the_configured_tries() {
    let (clock, _log, bus) = sim_byte_bus(9600, vec![tmd(1, 3)], None);
    let opts = LecomOptions {
        tries: 2,
        answer_timeout: Some(Duration::from_millis(100)),
        ..LecomOptions::default()
    };
    let mut c = LecomClient::with_options(bus, schema(), 2, opts).unwrap();
    let t0 = clock.now();
    let err = c.read(CodeKey::new(11)).unwrap_err();
    assert!(
        matches!(
            *err.kind,
            ErrorKind::Link(LinkFailure::NoAnswer { tries: 2, .. })
        ),
        "{err}"
    );
    assert!(clock.now() - t0 >= Duration::from_millis(200));
}

#[test]
fn group_addresses_are_refused_and_broadcast_is_separate() {
    let (_clock, log, bus) = sim_byte_bus(9600, vec![tmd(1, 3), tmd(2, 3)], None);
    let err = LecomClient::new(bus, schema(), 10).unwrap_err();
    assert!(err.to_string().contains("BROADCAST"), "{err}");
    let (_clock, log2, bus) = sim_byte_bus(9600, vec![tmd(1, 3), tmd(2, 3)], None);
    let _ = log;
    let mut c = LecomClient::new(bus, schema(), 1).unwrap();
    // C0011 = 60 Hz to everybody: unacknowledged.
    c.broadcast(CodeKey::new(11), &RawValue::Int(600_000))
        .unwrap();
    assert!(
        wire_bytes(&log2, Dir::Drive).is_empty(),
        "nobody answers a broadcast"
    );
    assert_eq!(c.read(CodeKey::new(11)).unwrap(), RawValue::Int(600_000));
    let mut c2 = LecomClient::new(c.into_link(), schema(), 2).unwrap();
    assert_eq!(c2.read(CodeKey::new(11)).unwrap(), RawValue::Int(600_000));
    assert!(
        c2.multicast(0, CodeKey::new(11), &RawValue::Int(600_000))
            .is_err()
    );
}

#[test]
fn running_identify_and_no_such_code() {
    let (_clock, _log, mut bus) = sim_byte_bus(9600, vec![tmd(7, 3)], None);
    bus.drive_mut(7).unwrap().set_running(true);
    let mut c = LecomClient::new(bus, schema(), 7).unwrap();
    assert_eq!(c.running().unwrap(), Some(true));
    c.link_mut().drive_mut(7).unwrap().set_running(false);
    assert_eq!(c.running().unwrap(), Some(false));
    let id = c.identify().unwrap();
    assert_eq!(id.protocol.name(), "lecom");
    assert_eq!(id.software.as_deref(), Some("1.20"));
    assert!(
        id.codes
            .iter()
            .any(|c| c.name == "C0200" && c.value.to_string() == "33STMD-M_12000"),
        "{id:?}"
    );
}

/// The write guard on LECOM's writing telegrams (issue 17): SEND,
/// BROADCAST and MULTICAST of C0040 = 1 (controller enabled) or of the
/// C0043 fault-reset command are refused and not a byte goes out.
#[test]
fn the_write_guard_refuses_enable_and_commands_on_send_broadcast_and_multicast() {
    let (_clock, log, bus) = sim_byte_bus(9600, vec![tmd(11, 3), tmd(12, 3)], None);
    let mut c = LecomClient::new(bus, schema(), 11).unwrap();
    let enable = RawValue::Int(10_000);
    let refusals = [
        c.write(CodeKey::new(40), &enable).unwrap_err(),
        c.broadcast(CodeKey::new(40), &enable).unwrap_err(),
        c.multicast(1, CodeKey::new(40), &enable).unwrap_err(),
        c.write(CodeKey::new(43), &RawValue::Int(10_000))
            .unwrap_err(),
    ];
    for e in &refusals[..3] {
        assert_eq!(
            e.to_string(),
            "sim address 11: refused: C0040 = \"Controller enabled\" would enable the drive (the stopped values are 0): driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control"
        );
    }
    assert!(
        refusals[3].to_string().contains("C0043 = "),
        "{}",
        refusals[3]
    );
    assert!(
        refusals[3]
            .to_string()
            .contains(" is a command: driveset never writes one"),
        "{}",
        refusals[3]
    );
    assert!(wire_bytes(&log, Dir::Host).is_empty(), "nothing sent");
    // the stopped value goes out
    c.write(CodeKey::new(40), &RawValue::Int(0)).unwrap();
    assert_eq!(wire_bytes(&log, Dir::Host).len(), 1);
}
