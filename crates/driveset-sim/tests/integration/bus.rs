//! SimByteBus: exact wire timing in virtual time, collisions, baud
//! changes, state dumps, errors.

use crate::bus_support as support;

use std::time::Duration;

use driveset_link::{ByteLink, Clock, Instant, LinkError, VirtualClock};
use driveset_sim::bus::{BusError, SimByteBus};
use support::{ACK, FakeDrive, telegram};

const MS: Duration = Duration::from_millis(1);

fn ns(n: u64) -> Instant {
    Instant::from_nanos(n)
}

#[test]
fn telegram_and_reply_at_exact_instants_at_9600() {
    let clock = VirtualClock::new();
    let (drive, seen) = FakeDrive::boxed(1, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![drive]).unwrap();
    bus.send(&telegram(b'1')).unwrap();
    // 8 characters x 10 bits / 9600 baud.
    assert_eq!(clock.now(), ns(8_333_333));
    {
        let seen = seen.lock().unwrap();
        let instants: Vec<u64> = seen.heard.iter().map(|h| h.0.as_nanos()).collect();
        assert_eq!(
            instants,
            [
                1_041_666, 2_083_333, 3_125_000, 4_166_666, 5_208_333, 6_250_000, 7_291_666,
                8_333_333
            ]
        );
        assert_eq!(seen.telegrams, [ns(8_333_333)]);
    }
    let mut buf = [0u8; 16];
    // Reply starts 1 ms after the telegram; its first character is through
    // one character time later.
    let n = bus.recv(&mut buf, clock.deadline_in(100 * MS)).unwrap();
    assert_eq!(&buf[..n], &[ACK]);
    assert_eq!(clock.now(), ns(8_333_333 + 1_000_000 + 1_041_666));
    let n = bus.recv(&mut buf, clock.deadline_in(100 * MS)).unwrap();
    assert_eq!(&buf[..n], b"1");
    // 8 x 10 / 9600 s + 1 ms + 2 x 10 / 9600 s.
    assert_eq!(clock.now(), ns(8_333_333 + 1_000_000 + 2_083_333));
}

#[test]
fn recv_returns_everything_arrived_and_times_out_at_the_deadline() {
    let clock = VirtualClock::new();
    let (drive, _) = FakeDrive::boxed(1, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![drive]).unwrap();
    bus.send(&telegram(b'1')).unwrap();
    // Sleep past the whole reply: one recv gets both characters, at once.
    clock.sleep(20 * MS);
    let t = clock.now();
    let mut buf = [0u8; 16];
    let n = bus.recv(&mut buf, clock.deadline_in(MS)).unwrap();
    assert_eq!(&buf[..n], &[ACK, b'1']);
    assert_eq!(clock.now(), t);
    // Nothing more: the clock goes to the deadline.
    let deadline = clock.deadline_in(50 * MS);
    assert_eq!(bus.recv(&mut buf, deadline).unwrap(), 0);
    assert_eq!(clock.now(), deadline);
    // A telegram for another address: no reply, deadline again.
    bus.send(&telegram(b'2')).unwrap();
    let deadline = clock.deadline_in(30 * MS);
    assert_eq!(bus.recv(&mut buf, deadline).unwrap(), 0);
    assert_eq!(clock.now(), deadline);
}

#[test]
fn a_deadline_before_the_reply_leaves_it_for_later() {
    let clock = VirtualClock::new();
    let (drive, _) = FakeDrive::boxed(1, 10 * MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![drive]).unwrap();
    bus.send(&telegram(b'1')).unwrap();
    let mut buf = [0u8; 1];
    let deadline = clock.deadline_in(5 * MS);
    assert_eq!(bus.recv(&mut buf, deadline).unwrap(), 0);
    assert_eq!(clock.now(), deadline);
    // A one-byte buffer takes one character; the rest waits.
    let mut two = [0u8; 2];
    clock.sleep(20 * MS);
    assert_eq!(bus.recv(&mut buf, clock.deadline_in(MS)).unwrap(), 1);
    assert_eq!(buf, [ACK]);
    assert_eq!(bus.recv(&mut two, clock.deadline_in(MS)).unwrap(), 1);
    assert_eq!(two[0], b'1');
}

#[test]
fn host_sends_queue_behind_each_other_like_mem_links() {
    let clock = VirtualClock::new();
    let mut bus = SimByteBus::new(&clock, 9600, vec![]).unwrap();
    bus.send(b"abc").unwrap();
    assert_eq!(clock.now(), ns(3_125_000));
    bus.send(b"d").unwrap();
    assert_eq!(clock.now(), ns(3_125_000 + 1_041_666));
    bus.flush().unwrap();
    assert_eq!(bus.baud(), 9600);
    assert_eq!(bus.port(), "sim");
}

#[test]
fn discard_input_drops_what_has_arrived_only() {
    let clock = VirtualClock::new();
    let (drive, _) = FakeDrive::boxed(1, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![drive]).unwrap();
    bus.send(&telegram(b'1')).unwrap();
    // At 8.333 + 1 + 1.042 ms the first character has arrived; not the second.
    clock.advance_to(ns(10_400_000));
    bus.discard_input().unwrap();
    let mut buf = [0u8; 4];
    let n = bus.recv(&mut buf, clock.deadline_in(10 * MS)).unwrap();
    assert_eq!(&buf[..n], b"1");
    assert_eq!(clock.now(), ns(11_416_666));
}

#[test]
fn two_drives_answering_at_once_collide_into_garbage() {
    let clock = VirtualClock::new();
    let (a, _) = FakeDrive::boxed(1, MS);
    let (b, _) = FakeDrive::boxed(2, MS);
    let log = driveset_sim::log::EventLog::memory();
    let mut bus = SimByteBus::new(&clock, 9600, vec![a, b])
        .unwrap()
        .with_log(log.clone());
    bus.send(&telegram(b'0')).unwrap();
    clock.sleep(50 * MS);
    let mut buf = [0u8; 8];
    let n = bus.recv(&mut buf, clock.deadline_in(MS)).unwrap();
    // ACK & ACK, '1' & '2' = 0x31 & 0x32 = 0x30.
    assert_eq!(&buf[..n], &[ACK, b'0']);
    let collisions: Vec<_> = log
        .events()
        .into_iter()
        .filter(|e| e.fault.as_deref() == Some("collision"))
        .collect();
    assert_eq!(collisions.len(), 1);
    assert_eq!(collisions[0].addr, Some(2));
}

#[test]
fn replies_of_different_lengths_in_time_do_not_collide() {
    let clock = VirtualClock::new();
    let (a, _) = FakeDrive::boxed(1, MS);
    let (b, _) = FakeDrive::boxed(2, 5 * MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![a, b]).unwrap();
    bus.send(&telegram(b'0')).unwrap();
    clock.sleep(50 * MS);
    let mut buf = [0u8; 8];
    let n = bus.recv(&mut buf, clock.deadline_in(MS)).unwrap();
    assert_eq!(&buf[..n], &[ACK, b'1', ACK, b'2']);
}

#[test]
fn a_baud_change_takes_effect_after_the_reply() {
    let clock = VirtualClock::new();
    let (drive, seen) = FakeDrive::boxed(1, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![drive]).unwrap();
    // "EOT 1 B ENQ": the drive acknowledges at 9600, then runs at 19200.
    bus.send(&[0x04, b'1', b'B', 0x05]).unwrap();
    let mut buf = [0u8; 4];
    clock.sleep(20 * MS);
    let n = bus.recv(&mut buf, clock.deadline_in(MS)).unwrap();
    assert_eq!(&buf[..n], &[ACK, b'1']);
    assert_eq!(bus.line().drive_baud(1), Some(19200));
    // The host still at 9600: the drive hears parity errors, answers nothing.
    bus.send(&telegram(b'1')).unwrap();
    assert!(seen.lock().unwrap().heard[4..].iter().all(|h| !h.2));
    assert_eq!(bus.recv(&mut buf, clock.deadline_in(50 * MS)).unwrap(), 0);
    // The host follows: exact 19200 timing.
    bus.set_baud(19200).unwrap();
    let t0 = clock.now();
    bus.send(&telegram(b'1')).unwrap();
    assert_eq!(clock.now(), t0 + Duration::from_nanos(4_166_666));
    clock.sleep(20 * MS);
    let n = bus.recv(&mut buf, clock.deadline_in(MS)).unwrap();
    assert_eq!(&buf[..n], &[ACK, b'1']);
    assert!(matches!(
        bus.set_baud(12345),
        Err(BusError::UnsupportedBaud { baud: 12345, .. })
    ));
}

#[test]
fn state_dump_and_drive_access() {
    let clock = VirtualClock::new();
    let (a, _) = FakeDrive::boxed(1, MS);
    let (b, _) = FakeDrive::boxed(3, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![a, b]).unwrap();
    assert_eq!(bus.drives().len(), 2);
    bus.drive_mut(3)
        .unwrap()
        .poke(
            driveset_schema::canonical::CodeKey::new(1),
            driveset_schema::canonical::RawValue::Int(42),
        )
        .unwrap();
    assert!(bus.drive_mut(9).is_none());
    let dump = bus.state_dump();
    assert_eq!(dump["baud"], 9600);
    let drives = dump["drives"].as_array().unwrap();
    assert_eq!(drives.len(), 2);
    assert_eq!(drives[1]["family"], "fake");
    assert_eq!(drives[1]["address"], 3);
    assert_eq!(drives[1]["schema"], "fake-schema");
    assert_eq!(
        drives[1]["canonical"],
        "driveset-canonical 1\nschema fake-schema\n1 42\n"
    );
    let fp = drives[1]["fingerprint"].as_str().unwrap();
    assert!(fp.starts_with("sha256:") && fp.len() == 71, "{fp}");
    assert_ne!(drives[0]["fingerprint"], drives[1]["fingerprint"]);
    assert_eq!(bus.into_drives().len(), 2);
}

#[test]
fn construction_and_send_errors_say_what_to_do() {
    let clock = VirtualClock::new();
    let err = SimByteBus::new(&clock, 1234, vec![]).unwrap_err();
    assert!(err.to_string().contains("use one of 1200, 2400"), "{err}");
    let (a, _) = FakeDrive::boxed(1, MS);
    let (b, _) = FakeDrive::boxed(1, MS);
    let err = SimByteBus::new(&clock, 9600, vec![a, b]).unwrap_err();
    assert_eq!(
        err.to_string(),
        "two drives at address 1 on one bus (fake and fake): give every drive its own address"
    );
    let mut bus = SimByteBus::new(&clock, 9600, vec![]).unwrap();
    let err = bus.send(&[0x04, 0x85]).unwrap_err();
    assert!(matches!(
        err,
        LinkError::NotSevenBit {
            offset: 1,
            byte: 0x85,
            ..
        }
    ));
    assert_eq!(clock.now(), Instant::ZERO, "nothing was sent");
    let mut empty = [0u8; 0];
    assert_eq!(bus.recv(&mut empty, clock.deadline_in(MS)).unwrap(), 0);
}
