//! LustbusClient against the simulated MC6000 and VF1000 (driveset-sim) in
//! virtual time: exact bytes on the wire, SIOF/SERR handling, MC EEPROM
//! pacing, the SLOAD dataset download, retries and power cycles.

use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{
    DatasetDownload, DatasetOutcome, DriveClient, LustbusClient, LustbusOptions, dataset_or_refuse,
    set_line_rate,
};
use driveset_engine::error::{DeviceFailure, ErrorKind, LinkFailure, Refused};
use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, Clock, Instant, VirtualClock};
use driveset_schema::{CodeKey, RawValue, Schema};
use driveset_sim::bus::SimByteBus;
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::{ByteDrive, ReactionTime};
use driveset_sim::log::{Dir, EventLog};
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::vf1000::Vf1000;
use driveset_test_support::{sim_byte_bus, wire_timed};

const REACTION: Duration = Duration::from_millis(2);

fn opts(address: u8) -> LustOptions {
    LustOptions::new(address).reaction(ReactionTime::fixed(REACTION))
}

fn mc(address: u8) -> Box<dyn ByteDrive> {
    Box::new(Mc6000::new(opts(address)).expect("mc6000"))
}

fn vf(address: u8) -> Box<dyn ByteDrive> {
    Box::new(Vf1000::new(opts(address)).expect("vf1000"))
}

fn schema(f: Family) -> Arc<Schema> {
    catalog::schema(f).expect("schema")
}

struct Rig {
    clock: VirtualClock,
    log: EventLog,
}

fn rig_bus(baud: u32, drives: Vec<Box<dyn ByteDrive>>, faults: Option<&str>) -> (Rig, SimByteBus) {
    let (clock, log, bus) = sim_byte_bus(baud, drives, faults);
    (Rig { clock, log }, bus)
}

fn bcc(text: &[u8]) -> u8 {
    text.iter().fold(0, |a, b| a ^ b)
}

fn select(adr: u8, code: &str, value: &str) -> Vec<u8> {
    let mut text = format!("{code}={value}").into_bytes();
    text.push(0x03);
    let mut out = vec![0x04, 0x40 + adr, 0x02];
    out.extend_from_slice(&text);
    out.push(bcc(&text));
    out
}

fn enquiry(adr: u8, code: &str) -> Vec<u8> {
    let mut out = vec![0x04, 0x40 + adr];
    out.extend_from_slice(code.as_bytes());
    out.push(0x05);
    out
}

fn value_reply(adr: u8, code: &str, value: &str) -> Vec<u8> {
    let mut text = format!("{code}={value}").into_bytes();
    text.push(0x03);
    let mut out = vec![0x40 + adr, 0x02];
    out.extend_from_slice(&text);
    out.push(bcc(&text));
    out
}

#[test]
fn mc_read_and_write_exact_bytes_one_eot_between_exchanges() {
    let (rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    assert_eq!(c.read(CodeKey::new(300)).unwrap(), RawValue::Int(2));
    c.write(CodeKey::new(416), &RawValue::Int(0)).unwrap();
    assert!(matches!(
        c.read(CodeKey::new(91)).unwrap(),
        RawValue::Int(_)
    ));
    c.finish().unwrap();
    let host: Vec<Vec<u8>> = wire_timed(&rig.log, Dir::Host)
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    assert_eq!(host[0], enquiry(1, "20300"));
    // First SELECT of the session: SERR is read (and cleared) first.
    assert_eq!(host[1], enquiry(1, "00085"));
    assert_eq!(host[2], select(1, "20416", "0"));
    // TYPE is a compatible parameter: CODE 00091.
    assert_eq!(host[3], enquiry(1, "00091"));
    // Only finish() sends a lone EOT, once, at the very end.
    let lone: Vec<usize> = host
        .iter()
        .enumerate()
        .filter(|(_, b)| b.as_slice() == [0x04])
        .map(|(i, _)| i)
        .collect();
    assert_eq!(lone, vec![host.len() - 1]);
    let drive: Vec<Vec<u8>> = wire_timed(&rig.log, Dir::Drive)
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    assert_eq!(drive[0], value_reply(1, "20300", "02"));
    // SERR at start: power on.
    assert_eq!(drive[1], value_reply(1, "00085", "01"));
    assert_eq!(drive[2], vec![0x41, 0x06]);
    assert_eq!(c.stats().retries, 0);
}

#[test]
fn mc_signed_and_q16_values_round_trip() {
    let (_rig, bus) = rig_bus(19200, vec![mc(4)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 4).unwrap();
    // 428-RSIO: untyped, width 4 -> PT_INT32Q16 (as the simulator).
    let raw = RawValue::Int(-132 * 65536);
    c.write(CodeKey::new(428), &raw).unwrap();
    assert_eq!(c.read(CodeKey::new(428)).unwrap(), raw);
}

#[test]
fn mc_eeprom_pacing_waits_exactly_the_remaining_store_time() {
    let (rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    // 101-MAINV: EEPROM, 2 bytes -> 30 ms store.
    c.write(CodeKey::new(101), &RawValue::Int(410)).unwrap();
    let ack = rig.clock.now();
    let busy = ack + Duration::from_millis(30);
    assert_eq!(c.ready_for_write(CodeKey::new(102)), Some(busy));
    // RAM writes and reads are not held back.
    assert_eq!(c.ready_for_write(CodeKey::new(416)), None);
    // 102-UVLIM issued immediately: the SELECT starts exactly at `busy`.
    c.write(CodeKey::new(102), &RawValue::Int(300)).unwrap();
    let host = wire_timed(&rig.log, Dir::Host);
    let (t, bytes) = host.last().unwrap();
    assert_eq!(bytes, &select(1, "20102", "12C"));
    assert_eq!(Instant::from_nanos(*t), busy);
    assert_eq!(c.stats().retries, 0, "no EEPROM busy NAK");

    // A read in the gap uses it: the next EEPROM write then waits only the
    // rest of 102's 30 ms (the ENQUIRY of 77 takes 26 characters + 2 ms).
    let ack2 = rig.clock.now();
    c.read(CodeKey::new(77)).unwrap();
    let after_read = rig.clock.now();
    assert!(after_read < ack2 + Duration::from_millis(30));
    assert!(after_read > ack2 + Duration::from_millis(25));
    c.write(CodeKey::new(300), &RawValue::Int(3)).unwrap();
    let (t, bytes) = wire_timed(&rig.log, Dir::Host).last().cloned().unwrap();
    assert_eq!(bytes, select(1, "20300", "3"));
    assert_eq!(Instant::from_nanos(t), ack2 + Duration::from_millis(30));
    // 300-CFCON is 1 byte: 15 ms; a RAM write meanwhile is not held back.
    let ack3 = rig.clock.now();
    c.write(CodeKey::new(416), &RawValue::Int(0)).unwrap();
    let (t, _) = wire_timed(&rig.log, Dir::Host).last().cloned().unwrap();
    assert_eq!(Instant::from_nanos(t), ack3);
    assert_eq!(c.stats().retries, 0);
}

#[test]
fn mc_eeprom_busy_nak_waits_and_repeats() {
    // A second session on the same line does not know the drive is still
    // storing: its SELECT is NAKed, SERR says 0x04, it waits and repeats.
    let (rig, bus) = rig_bus(57600, vec![mc(1)], None);
    let s = schema(Family::Mc6000);
    let mut a = LustbusClient::new(bus, Arc::clone(&s), 1).unwrap();
    a.write(CodeKey::new(101), &RawValue::Int(420)).unwrap();
    let mut b = LustbusClient::new(a.into_link(), s, 1).unwrap();
    b.write(CodeKey::new(102), &RawValue::Int(310)).unwrap();
    assert_eq!(b.read(CodeKey::new(102)).unwrap(), RawValue::Int(310));
    let drive = wire_timed(&rig.log, Dir::Drive);
    assert!(drive.iter().any(|(_, r)| r == &vec![0x41, 0x15]), "a NAK");
    assert!(
        drive
            .iter()
            .any(|(_, r)| r == &value_reply(1, "00085", "04")),
        "SERR read back: EEPROM busy"
    );
    let host = wire_timed(&rig.log, Dir::Host);
    let selects: Vec<u64> = host
        .iter()
        .filter(|(_, b)| b == &select(1, "20102", "136"))
        .map(|(t, _)| *t)
        .collect();
    assert_eq!(selects.len(), 2);
    assert!(selects[1] - selects[0] > 61_000_000, "waited > 60 ms");
    assert!(b.stats().retries >= 1);
}

#[test]
fn mc_invalid_value_is_a_device_error_with_cause_and_remedy() {
    let (_rig, bus) = rig_bus(9600, vec![mc(2)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 2).unwrap();
    // 300-CFCON: 0..7.
    let err = c.write(CodeKey::new(300), &RawValue::Int(9)).unwrap_err();
    let ErrorKind::Device(DeviceFailure::Refused { cause, what, .. }) = &*err.kind else {
        panic!("{err}")
    };
    assert!(what.contains("300-CFCON"), "{what}");
    assert!(cause.cause().contains("invalid value"), "{}", cause.cause());
    assert_eq!(cause.raw(), "SERR 80H Invalid value");
    assert_eq!(cause.remedy(), "Choose a different value");
    let text = err.to_string();
    assert!(text.contains("sim address 2"), "{text}");
    // The error word was read and cleared: the next write goes through.
    c.write(CodeKey::new(300), &RawValue::Int(3)).unwrap();
}

#[test]
fn enquiry_nak_is_a_device_error() {
    // The MC schema as the client sees it, but the drive on the line is a
    // VF1000: the MC CODE 20300 does not exist there -> NAK.
    let (_rig, bus) = rig_bus(9600, vec![vf(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    let err = c.read(CodeKey::new(300)).unwrap_err();
    let ErrorKind::Device(DeviceFailure::Refused { cause, .. }) = &*err.kind else {
        panic!("{err}")
    };
    assert!(
        cause.cause().contains("no such parameter"),
        "{}",
        cause.cause()
    );
    assert_eq!(cause.raw(), "NAK to ENQUIRY 20300");
    // A code the schema does not know is refused before sending.
    let err = c.read(CodeKey::new(12)).unwrap_err();
    assert!(
        matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{err}"
    );
}

#[test]
fn restart_mid_session_is_reported() {
    let (rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    c.write(CodeKey::new(416), &RawValue::Int(0)).unwrap();
    let now = rig.clock.now();
    c.link_mut()
        .drive_mut(1)
        .unwrap()
        .power_cycle(now, Duration::from_millis(50));
    rig.clock.advance(Duration::from_secs(2));
    let err = c.write(CodeKey::new(416), &RawValue::Int(0)).unwrap_err();
    assert!(
        matches!(
            *err.kind,
            ErrorKind::Device(DeviceFailure::Restarted { .. })
        ),
        "{err}"
    );
    assert!(err.to_string().contains("restarted"));
}

#[test]
fn lost_replies_are_retried() {
    let (_rig, bus) = rig_bus(19200, vec![mc(1)], Some("lose=0.3,seed=7"));
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    for _ in 0..20 {
        assert_eq!(c.read(CodeKey::new(300)).unwrap(), RawValue::Int(2));
    }
    assert!(c.stats().retries > 0);
}

#[test]
fn no_answer_after_three_tries() {
    let (rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 5).unwrap();
    let t0 = rig.clock.now();
    let err = c.read(CodeKey::new(300)).unwrap_err();
    let ErrorKind::Link(LinkFailure::NoAnswer { tries, .. }) = *err.kind else {
        panic!("{err}")
    };
    assert_eq!(tries, 3);
    assert_eq!(c.stats().telegrams, 3);
    // Each try: 8 characters out, the timeout (30 ms + 18 characters + the
    // first-contact allowance of 200 ms: nothing measured yet), then as
    // long again listening for a late reply.
    let timeout = Duration::from_millis(230) + wire_time(18, 9600);
    let one = wire_time(8, 9600) + timeout * 2;
    assert_eq!(rig.clock.now() - t0, one * 3);
    assert_eq!(c.stats().late, 0);
}

#[test]
fn garbled_replies_are_retried() {
    let (_rig, bus) = rig_bus(9600, vec![mc(1)], Some("flip=0.3,seed=3"));
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    for _ in 0..10 {
        assert_eq!(c.read(CodeKey::new(402)).unwrap(), RawValue::Int(2));
    }
    assert!(c.stats().retries > 0);
}

#[test]
fn dataset_download_accepted() {
    let (_rig, bus) = rig_bus(19200, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    assert!(c.dataset().is_some());
    c.begin().unwrap();
    c.write(CodeKey::new(101), &RawValue::Int(230)).unwrap();
    c.write(CodeKey::new(102), &RawValue::Int(180)).unwrap();
    c.write(CodeKey::new(300), &RawValue::Int(4)).unwrap();
    // Not CardWriteable: refused before sending (the drive would ignore it).
    let err = c.write(CodeKey::new(110), &RawValue::Int(3)).unwrap_err();
    assert!(
        matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{err}"
    );
    assert_eq!(
        c.commit(Duration::from_secs(10)).unwrap(),
        DatasetOutcome::Accepted
    );
    assert_eq!(c.read(CodeKey::new(101)).unwrap(), RawValue::Int(230));
    assert_eq!(c.read(CodeKey::new(300)).unwrap(), RawValue::Int(4));
    assert_eq!(c.read(CodeKey::new(80)).unwrap(), RawValue::Int(0));
}

#[test]
fn dataset_download_rejected_keeps_the_old_set() {
    let (_rig, bus) = rig_bus(19200, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    c.begin().unwrap();
    // FICTIONAL rule of the simulator: 102-UVLIM <= 101-MAINV.
    c.write(CodeKey::new(101), &RawValue::Int(200)).unwrap();
    c.write(CodeKey::new(102), &RawValue::Int(300)).unwrap();
    assert_eq!(
        c.commit(Duration::from_secs(10)).unwrap(),
        DatasetOutcome::Rejected { parameter: 102 }
    );
    assert_eq!(c.read(CodeKey::new(101)).unwrap(), RawValue::Int(400));
}

#[test]
fn dataset_begin_while_running_names_standstill() {
    let (_rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    // the write guard never writes a start: the machine's control starts it
    let refused = c.write(CodeKey::new(416), &RawValue::Int(1)).unwrap_err();
    assert_eq!(
        refused.to_string(),
        "sim address 1: refused: 416-SCTL1 = { start = 1, error_reset = 0 } would start or enable the drive (start set): driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control"
    );
    assert_eq!(c.running().unwrap(), Some(false));
    c.link_mut().drive_mut(1).unwrap().set_running(true);
    assert_eq!(c.running().unwrap(), Some(true));
    let err = c.begin().unwrap_err();
    let ErrorKind::Device(DeviceFailure::Refused { cause, .. }) = &*err.kind else {
        panic!("{err}")
    };
    assert!(cause.cause().contains("standstill"), "{}", cause.cause());
    assert!(cause.raw().contains("40H"), "{}", cause.raw());
    c.write(CodeKey::new(416), &RawValue::Int(0)).unwrap();
    assert_eq!(c.running().unwrap(), Some(false));
    c.begin().unwrap();
}

/// The VF1000 has no SLOAD handshake (section 11.4): its client offers no
/// dataset download, and a caller that needs one is refused in the
/// VF1000's words; its serial line's rate can be set like the MC's.
#[test]
fn vf1000_offers_no_dataset_download_but_a_serial_line() {
    let (_rig, bus) = rig_bus(9600, vec![vf(3)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Vf1000), 3).unwrap();
    assert!(c.dataset().is_none());
    let err = dataset_or_refuse(&mut c).err().expect("refused");
    assert_eq!(
        err.to_string(),
        "sim address 3: refused: the VF1000 has no dataset download handshake (SLOAD is MC6000/7000 only, section 11.4)"
    );
    assert_eq!(c.line_rate(), Some(9600));
    assert_eq!(c.line().map(|l| l.rate()), Some(9600));
    set_line_rate(&mut c, 4800).unwrap();
    assert_eq!(c.line_rate(), Some(4800));
    assert_eq!(c.link().baud(), 4800);
}

#[test]
fn vf1000_read_and_write_exact_bytes() {
    let (rig, bus) = rig_bus(9600, vec![vf(3)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Vf1000), 3).unwrap();
    c.read(CodeKey::new(12)).unwrap();
    // 20-FFIX1, PT_FIXPOINT16: 50.00 Hz = raw 1000 = 03E8.
    c.write(CodeKey::new(20), &RawValue::Int(1000)).unwrap();
    assert_eq!(c.read(CodeKey::new(20)).unwrap(), RawValue::Int(1000));
    // 3-CNTL bit 7: running.
    assert_eq!(c.running().unwrap(), Some(false));
    c.finish().unwrap();
    let host: Vec<Vec<u8>> = wire_timed(&rig.log, Dir::Host)
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    assert_eq!(host[0], enquiry(3, "00112"));
    assert_eq!(host[1], enquiry(3, "00085"));
    assert_eq!(host[2], select(3, "00120", "03E8"));
    assert_eq!(host[3], enquiry(3, "00120"));
    assert_eq!(host[4], enquiry(3, "00103"));
    assert_eq!(host[5], vec![0x04]);
    assert_eq!(host.len(), 6);
    let drive: Vec<Vec<u8>> = wire_timed(&rig.log, Dir::Drive)
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    assert_eq!(drive[1], value_reply(3, "00085", "0001"));
    assert_eq!(drive[3], value_reply(3, "00120", "03E8"));
}

#[test]
fn vf1000_eeprom_write_allows_the_delayed_ack() {
    let (rig, bus) = rig_bus(9600, vec![vf(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Vf1000), 1).unwrap();
    c.read(CodeKey::new(30)).unwrap();
    let t0 = rig.clock.now();
    // 30-VFBOV: EEPROM, 2 bytes: the ACK comes ~120 ms late (section 10).
    c.write(CodeKey::new(30), &RawValue::Int(40)).unwrap();
    assert!(rig.clock.now() - t0 > Duration::from_millis(100));
    assert_eq!(c.stats().retries, 0);
    assert_eq!(c.read(CodeKey::new(30)).unwrap(), RawValue::Int(40));
}

#[test]
fn addresses_and_family_are_checked() {
    let (_rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let err = LustbusClient::new(bus, schema(Family::Mc6000), 31).unwrap_err();
    assert!(
        matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{err}"
    );
    let (_rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let err = LustbusClient::new(bus, schema(Family::Tmd), 1).unwrap_err();
    assert!(err.to_string().contains("not a LUSTBUS family"), "{err}");
    // Read-only codes are refused before anything is sent.
    let (rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    let err = c.write(CodeKey::new(77), &RawValue::Int(1)).unwrap_err();
    assert!(
        matches!(*err.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{err}"
    );
    assert!(wire_timed(&rig.log, Dir::Host).is_empty());
    let _ = c.link().baud();
}

#[test]
fn passwords_never_appear_in_errors() {
    let (_rig, bus) = rig_bus(9600, vec![vf(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Vf1000), 1).unwrap();
    // 70 keypad password, 0..9999: 54321 is refused with SIOF 0x80.
    let err = c
        .write(CodeKey::new(70), &RawValue::Int(54321))
        .unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(*err.kind, ErrorKind::Device(DeviceFailure::Refused { .. })),
        "{text}"
    );
    assert!(!text.contains("54321") && !text.contains("D431"), "{text}");
    assert!(text.contains("password, not shown"), "{text}");
    // Out of the type's range: refused before sending, still redacted.
    let err = c
        .write(CodeKey::new(70), &RawValue::Int(987_654))
        .unwrap_err();
    assert!(!err.to_string().contains("987654"), "{err}");
}

#[test]
fn options_change_the_answer_timeout() {
    let (rig, bus) = rig_bus(9600, vec![mc(1)], None);
    let o = LustbusOptions {
        tries: 1,
        answer_timeout: Some(Duration::from_millis(5)),
        ..LustbusOptions::default()
    };
    let mut c = LustbusClient::with_options(bus, schema(Family::Mc6000), 9, o).unwrap();
    let t0 = rig.clock.now();
    assert!(matches!(
        *c.read(CodeKey::new(300)).unwrap_err().kind,
        ErrorKind::Link(LinkFailure::NoAnswer { tries: 1, .. })
    ));
    // 5 ms for the answer, then 5 ms more listening for a late one.
    assert_eq!(
        rig.clock.now() - t0,
        wire_time(8, 9600) + Duration::from_millis(10)
    );
}

/// Learning a schema from the simulated drives' own descriptions
/// (driveset_engine::learn) in every description layout and type-character
/// reading the errata discuss, and the handling of descriptions that
/// contradict themselves.
mod learn {
    use super::*;
    use driveset_engine::learn::{
        LearnOptions, LearnSource, Learned, LearnedSchema, RawDescription, interpret, learn,
        learned_id, render_schema,
    };
    use driveset_proto::lustbus::description::{McLayout, McTypeChars};
    use driveset_schema::{Family, Registry, check_schema};

    fn learn_from(
        drive: Box<dyn ByteDrive>,
        protocol: Family,
        base_id: &str,
        opts: &LearnOptions,
    ) -> (Learned, LearnedSchema) {
        let (_rig, bus) = rig_bus(9600, vec![drive], None);
        let registry = Registry::builtin().expect("builtin");
        let base = registry.get(base_id).expect("base");
        let mut client = LustbusClient::new(bus, base.clone(), 1).expect("client");
        let identity = client.identify().expect("identify");
        let mut learned = learn(&mut client, protocol, opts).expect("learn");
        let id = learned_id(protocol, &identity, &learned);
        let source = LearnSource {
            drive: "sim address 1".into(),
            identity,
        };
        let schema = render_schema(&mut learned, &base, &id, &source, &registry).expect("render");
        assert!(check_schema(&schema.schema).is_empty());
        (learned, schema)
    }

    fn mc_with(layout: McLayout, types: McTypeChars) -> Box<dyn ByteDrive> {
        let mut o = opts(1);
        o.description_layout = layout;
        o.type_chars = types;
        Box::new(Mc6000::new(o).expect("mc6000"))
    }

    /// Every learned code has the type, kind and range of the simulated
    /// drive's (fixture) schema wherever the spec leaves them unset.
    fn agrees_with_fixture(s: &Schema, fixture: &Schema) -> usize {
        let mut same = 0;
        for c in &s.codes {
            let Some(f) = fixture.code(c.number) else {
                continue;
            };
            assert_eq!(
                s.type_of(c).map(|t| t.name()),
                fixture.type_of(f).map(|t| t.name()),
                "type of {}",
                c.number
            );
            assert_eq!(c.kind, f.kind, "kind of {}", c.number);
            if s.type_of(c).is_some() {
                same += 1;
            }
        }
        same
    }

    #[test]
    fn mc6000_every_layout_and_type_reading() {
        let fixture = schema(Family::Mc6000);
        let mut counts = Vec::new();
        for (layout, types) in [
            (McLayout::Hex52, McTypeChars::Driveset),
            (McLayout::Table43, McTypeChars::Table),
            (McLayout::Table42, McTypeChars::Table),
            (McLayout::Basic34, McTypeChars::Driveset),
            (McLayout::Table43, McTypeChars::Driveset),
        ] {
            let (learned, s) = learn_from(
                mc_with(layout, types.clone()),
                Family::Mc6000,
                "lust-mc6000",
                &LearnOptions::default(),
            );
            assert_eq!(
                learned.layouts.iter().copied().collect::<Vec<_>>(),
                vec![layout]
            );
            assert_eq!(learned.type_chars.as_ref(), Some(&types), "{layout:?}");
            assert!(learned.type_chars_guessed);
            assert_eq!(learned.findings, vec![], "{layout:?}");
            let typed = agrees_with_fixture(&s.schema, &fixture);
            counts.push((layout.name(), s.codes, typed, learned.texts_read));
        }
        assert_eq!(
            counts,
            vec![
                ("52", 250, 250, 313),
                ("43", 250, 250, 313),
                ("42", 250, 250, 313),
                // No ShowText attribute in 34 characters: texts are asked
                // for, and a parameter whose minimum has no text is taken
                // as one without texts.
                ("34", 250, 250, 309),
                ("43", 250, 250, 313),
            ]
        );
    }

    fn mc52(name: &str, ty: char, min: u32, max: u32, def: u32) -> Vec<u8> {
        let mut v = name.as_bytes().to_vec();
        v.resize(6, 0);
        v.extend(format!("001{ty}{min:08X}{max:08X}{def:08X}000000000000000000").bytes());
        assert_eq!(v.len(), 52);
        v
    }

    #[test]
    fn self_contradicting_descriptions_are_downgraded_or_left_out() {
        let raws = vec![
            RawDescription {
                number: 310,
                text: mc52("MINMX", '4', 0x10, 0x05, 0x07),
            },
            RawDescription {
                number: 311,
                text: mc52("DEFOU", '4', 0, 100, 200),
            },
            RawDescription {
                number: 312,
                text: mc52("UNKTY", 'Z', 0, 0x1F4, 0x64),
            },
            RawDescription {
                number: 313,
                text: mc52("WIDE", 'Z', 0, 0x0010_0000, 0),
            },
            RawDescription {
                number: 314,
                text: mc52("NOFIT", '4', 0, 0x1FF, 0),
            },
            RawDescription {
                number: 315,
                text: mc52("GOOD", '7', 0xFFFF_FF9C, 100, 0),
            },
            RawDescription {
                number: 316,
                text: b"SHORT\x00001".to_vec(),
            },
        ];
        let opts = LearnOptions {
            type_chars: Some(McTypeChars::Driveset),
            ..LearnOptions::default()
        };
        let mut learned = interpret(Family::Mc6000, &raws, &opts);
        let findings: Vec<(u32, &str, String)> = learned
            .findings
            .iter()
            .map(|f| (f.number, f.action, f.reason.clone()))
            .collect();
        assert_eq!(
            findings,
            vec![
                (316, "left out", "its description does not decode: MC6000/7000 parameter description has 9 characters; expected 52, 43, 42 or 34".to_string()),
                (310, "downgraded", "its minimum 16 is above its maximum 5; range and default left out".to_string()),
                (311, "downgraded", "its default 200 is outside its range 0..100; default left out".to_string()),
                (312, "downgraded", "type character 'Z' is not one driveset knows; kept as a raw integer PT_USIGN16 (the width its min/max/default need)".to_string()),
                (313, "downgraded", "type character 'Z' is not one driveset knows; kept without a type (its min/max/default need 32 bits; LUSTBUS has no raw 32-bit type), so it is not read".to_string()),
                (314, "downgraded", "its min/max/default (0x0, 0x1FF, 0x0) do not fit its type PT_USIGN8; type downgraded to the raw integer PT_USIGN16".to_string()),
            ]
        );
        let registry = Registry::builtin().expect("builtin");
        let base = registry.get("lust-mc6000").expect("base");
        let source = LearnSource {
            drive: "test".into(),
            identity: driveset_engine::client::Identity::default(),
        };
        let s =
            render_schema(&mut learned, &base, "learned-test", &source, &registry).expect("render");
        assert!(check_schema(&s.schema).is_empty());
        assert_eq!(s.codes, 6);
        let c = |n: u32| s.schema.code(n).expect("code");
        let ty = |n: u32| s.schema.type_of(c(n)).map(|t| t.name());
        assert_eq!(ty(310), Some("PT_USIGN8"));
        assert!(c(310).min.is_none() && c(310).max.is_none() && c(310).default.is_none());
        assert!(c(311).min.is_some() && c(311).default.is_none());
        assert_eq!(ty(312), Some("PT_USIGN16"));
        assert_eq!(ty(313), None);
        assert_eq!(ty(314), Some("PT_USIGN16"));
        assert_eq!(ty(315), Some("PT_INTEGER16"));
        assert_eq!(
            c(315).min.as_ref().map(|m| m.value.clone()),
            Some(driveset_schema::doc::NodeKind::Str("-100".into()))
        );
        assert!(s.schema.code(316).is_none());
        assert_eq!(
            c(312).note.as_deref(),
            Some(
                "guessed: type character 'Z' is not one driveset knows; kept as a raw integer PT_USIGN16 (the width its min/max/default need)"
            )
        );
        assert!(s.text.contains("# learned: type, min, max, default, kind, width, card_writeable\n[[code]]\nnumber = 312\n"), "{}", s.text);
    }

    #[test]
    fn vf1000_learns_every_parameter() {
        let fixture = schema(Family::Vf1000);
        let (learned, s) = learn_from(
            vf(1),
            Family::Vf1000,
            "lust-vf1000",
            &LearnOptions::default(),
        );
        assert_eq!(learned.findings, vec![]);
        let typed = agrees_with_fixture(&s.schema, &fixture);
        assert_eq!(
            (learned.asked, learned.absent, s.codes, typed),
            (99, 99 - s.codes, s.codes, s.codes)
        );
        assert_eq!(s.codes, 58);
    }
}

/// A drive (or link) 150 ms slow, far beyond section 10's 30 ms: the first
/// telegram's first-contact allowance (200 ms) sees its reply, and from
/// then on the measured latency sizes every timeout; nothing is repeated.
#[test]
fn a_slow_link_is_measured_not_timed_out() {
    let slow = |a| -> Box<dyn ByteDrive> {
        Box::new(
            Mc6000::new(
                LustOptions::new(a).reaction(ReactionTime::fixed(Duration::from_millis(150))),
            )
            .expect("mc6000"),
        )
    };
    let (_rig, bus) = rig_bus(9600, vec![slow(1)], None);
    let mut c = LustbusClient::new(bus, schema(Family::Mc6000), 1).unwrap();
    c.identify().expect("identify");
    for _ in 0..10 {
        c.read(CodeKey::new(100)).expect("read");
    }
    c.write(CodeKey::new(561), &RawValue::Int(-42))
        .expect("write");
    assert_eq!(c.read(CodeKey::new(561)).unwrap(), RawValue::Int(-42));
    assert_eq!(c.stats().retries, 0);
    assert_eq!(c.stats().late, 0);
    // 150 ms less the 1 ms minimum reaction, measured; 1.5 x + 10 ms.
    let a = c.latency().allowance();
    assert!(
        a >= Duration::from_millis(230) && a <= Duration::from_millis(240),
        "{a:?}"
    );

    // The same drive with the fixed answer timeout of the spec alone
    // (30 ms + wire time + 10 ms): the first try times out and its reply
    // comes after the late window, during the repetition; being the same
    // ENQUIRY (same address and CODE) it is that repetition's answer, but
    // only after a retry.
    let (_rig, bus) = rig_bus(9600, vec![slow(1)], None);
    let o = LustbusOptions {
        answer_timeout: Some(Duration::from_millis(40) + wire_time(18, 9600)),
        ..LustbusOptions::default()
    };
    let mut c = LustbusClient::with_options(bus, schema(Family::Mc6000), 1, o).unwrap();
    c.read(CodeKey::new(100)).expect("read");
    assert_eq!(c.stats().retries, 1);
}

/// A reply after its answer timeout but within the late window (as long
/// again) is counted as late and dropped, and the telegram repeated.
#[test]
fn a_late_reply_is_recognised_and_dropped() {
    let late =
        Mc6000::new(LustOptions::new(1).reaction(ReactionTime::fixed(Duration::from_millis(70))))
            .expect("mc6000");
    let (_rig, bus) = rig_bus(9600, vec![Box::new(late)], None);
    let o = LustbusOptions {
        tries: 2,
        answer_timeout: Some(Duration::from_millis(50)),
        ..LustbusOptions::default()
    };
    let mut c = LustbusClient::with_options(bus, schema(Family::Mc6000), 1, o).unwrap();
    let err = c.read(CodeKey::new(100)).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(
            *err.kind,
            ErrorKind::Link(LinkFailure::NoAnswer { tries: 2, .. })
        ),
        "{text}"
    );
    assert!(
        text.contains("later than the answer timeout of 50 ms (late, discarded)"),
        "{text}"
    );
    assert_eq!(c.stats().late, 2);
    assert_eq!(c.stats().telegrams, 2);
}

/// LUSTBUS 4.2 / 9.1: a SELECT to address 31 (`_`) is executed by every
/// device without a receipt. The client sends it and awaits nothing but the
/// longest MC reaction time (30 ms with KEYPAD); two drives with open
/// datasets both stage it. Compatible codes, codes with a role and values
/// no dataset stages are refused before anything is sent.
#[test]
fn mc_broadcast_to_address_31_is_staged_by_every_open_dataset_without_a_reply() {
    let (rig, bus) = rig_bus(9600, vec![mc(1), mc(2)], None);
    let s = schema(Family::Mc6000);
    let mut c1 = LustbusClient::new(bus, s.clone(), 1).unwrap();
    c1.begin().unwrap();
    let mut c2 = LustbusClient::new(c1.into_link(), s.clone(), 2).unwrap();
    c2.begin().unwrap();
    let before = wire_timed(&rig.log, Dir::Host).len();
    let replies_before = wire_timed(&rig.log, Dir::Drive).len();
    let t0 = rig.clock.now();
    c2.broadcast(CodeKey::new(171), &RawValue::Int(2048))
        .unwrap();
    let host = wire_timed(&rig.log, Dir::Host);
    assert_eq!(host.len(), before + 1);
    let sent = &host[before].1;
    assert_eq!(sent, &select(31, "20171", "800"));
    assert_eq!(sent.as_slice(), b"\x04_\x0220171=800\x033");
    // no receipt, none awaited: the wire time, then 30 ms
    assert_eq!(wire_timed(&rig.log, Dir::Drive).len(), replies_before);
    assert_eq!(
        rig.clock.now() - t0,
        wire_time(sent.len(), 9600) + Duration::from_millis(30)
    );
    for (key, why) in [
        (
            81,
            "a numerically compatible code (81..85, 91; section 5.2) is never broadcast",
        ),
        (
            85,
            "a numerically compatible code (81..85, 91; section 5.2) is never broadcast",
        ),
        (416, "a code with role `control-word` is never broadcast"),
        (80, "a code with role `command` is never broadcast"),
    ] {
        let e = c2
            .broadcast(CodeKey::new(key), &RawValue::Int(1))
            .expect_err("refused");
        let name = s.display_code(key, None);
        assert_eq!(
            e.to_string(),
            format!("sim address 2: refused: broadcast (address 31) of {name}: {why}")
        );
    }
    assert_eq!(wire_timed(&rig.log, Dir::Host).len(), before + 1);
    // both drives commit it
    assert_eq!(
        c2.commit(Duration::from_secs(10)).unwrap(),
        DatasetOutcome::Accepted
    );
    let mut c1 = LustbusClient::new(c2.into_link(), s.clone(), 1).unwrap();
    assert!(c1.resume_dataset().unwrap().is_empty());
    assert_eq!(
        c1.commit(Duration::from_secs(10)).unwrap(),
        DatasetOutcome::Accepted
    );
    assert_eq!(c1.read(CodeKey::new(171)).unwrap(), RawValue::Int(2048));
    let mut c2 = LustbusClient::new(c1.into_link(), s, 2).unwrap();
    assert_eq!(c2.read(CodeKey::new(171)).unwrap(), RawValue::Int(2048));
}
