//! The simulated Lenze ECS as an SDO server, frame by frame: exact request
//! and response bytes for the page 454 commands, the Lenze index mapping
//! (index = 24575 - code), FIX32 and bit-coded values, every abort the
//! drive chooses, segmented transfers through the codec, power cycles.

use crate::ecs_support as support;

use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::can::NodeId;
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::drive::{FrameDrive, ReactionTime};
use driveset_sim::ecs::EcsDrive;
use support::{frame, test_drive};

const T0: Instant = Instant::from_nanos(1_000_000_000);

/// Sends `req` to node 1 (COB-ID 0x601) and returns the answer's COB-ID
/// and 8 data bytes.
fn ask(d: &mut EcsDrive, req: [u8; 8]) -> (u32, [u8; 8]) {
    let r = d
        .hear(T0, &frame(0x601, &req))
        .unwrap_or_else(|| panic!("no answer to {req:02X?}"));
    assert_eq!(r.frame.len, 8);
    assert!(!r.frame.extended && !r.frame.rtr);
    (r.frame.id, r.frame.data)
}

fn answer(d: &mut EcsDrive, req: [u8; 8]) -> [u8; 8] {
    let (id, data) = ask(d, req);
    assert_eq!(id, 0x581, "response COB-ID is 0x580 + node");
    data
}

fn raw(d: &EcsDrive, code: u32) -> RawValue {
    d.state().values[&CodeKey::new(code)].clone()
}

#[test]
fn read_c5001_expedited_fix32() {
    let mut d = test_drive(1);
    // C5001 -> index 24575 - 5001 = 19574 = 0x4C76; 3000 rpm -> raw 30000000 = 0x01C9C380.
    assert_eq!(
        answer(&mut d, [0x40, 0x76, 0x4C, 0x00, 0, 0, 0, 0]),
        [0x43, 0x76, 0x4C, 0x00, 0x80, 0xC3, 0xC9, 0x01]
    );
}

#[test]
fn write_fix32_then_read_back() {
    let mut d = test_drive(1);
    // C5002 (index 0x4C75) = 1234.5678 -> raw 12345678 = 0x00BC614E.
    assert_eq!(
        answer(&mut d, [0x23, 0x75, 0x4C, 0x00, 0x4E, 0x61, 0xBC, 0x00]),
        [0x60, 0x75, 0x4C, 0x00, 0, 0, 0, 0]
    );
    assert_eq!(
        answer(&mut d, [0x40, 0x75, 0x4C, 0x00, 0, 0, 0, 0]),
        [0x43, 0x75, 0x4C, 0x00, 0x4E, 0x61, 0xBC, 0x00]
    );
    assert_eq!(raw(&d, 5002), RawValue::Int(12_345_678));
    // FIX32 is signed: -0.0001 is raw -1 = 0xFFFFFFFF, below C5001's min 0.
    assert_eq!(
        answer(&mut d, [0x23, 0x76, 0x4C, 0x00, 0xFF, 0xFF, 0xFF, 0xFF]),
        [0x80, 0x76, 0x4C, 0x00, 0x32, 0x00, 0x09, 0x06]
    );
}

#[test]
fn bit_coded_c0135_and_c0150_without_factor() {
    let mut d = test_drive(1);
    // C0135 -> index 24440 = 0x5F78; bit 31 set: unsigned, no factor.
    assert_eq!(
        answer(&mut d, [0x23, 0x78, 0x5F, 0x00, 0x01, 0x04, 0x00, 0x80]),
        [0x60, 0x78, 0x5F, 0x00, 0, 0, 0, 0]
    );
    assert_eq!(
        answer(&mut d, [0x40, 0x78, 0x5F, 0x00, 0, 0, 0, 0]),
        [0x43, 0x78, 0x5F, 0x00, 0x01, 0x04, 0x00, 0x80]
    );
    assert_eq!(raw(&d, 135), RawValue::Int(0x8000_0401));
    // C0150 -> index 24425 = 0x5F69, factory 0; a poked pattern reads back as is.
    assert_eq!(
        answer(&mut d, [0x40, 0x69, 0x5F, 0x00, 0, 0, 0, 0]),
        [0x43, 0x69, 0x5F, 0x00, 0, 0, 0, 0]
    );
    d.poke(CodeKey::new(150), RawValue::Int(0xFFFF_FFFF))
        .unwrap();
    assert_eq!(
        answer(&mut d, [0x40, 0x69, 0x5F, 0x00, 0, 0, 0, 0]),
        [0x43, 0x69, 0x5F, 0x00, 0xFF, 0xFF, 0xFF, 0xFF]
    );
}

#[test]
fn aborts_carry_the_ds301_codes() {
    let mut d = test_drive(1);
    let cases: [([u8; 8], [u8; 8]); 10] = [
        // no code C9999 (index 0x38F0): 0x06020000
        (
            [0x40, 0xF0, 0x38, 0x00, 0, 0, 0, 0],
            [0x80, 0xF0, 0x38, 0x00, 0x00, 0x00, 0x02, 0x06],
        ),
        // index above 0x5FFF is no Lenze code: 0x06020000
        (
            [0x40, 0x00, 0x60, 0x00, 0, 0, 0, 0],
            [0x80, 0x00, 0x60, 0x00, 0x00, 0x00, 0x02, 0x06],
        ),
        // C5001 has no subcodes: subindex 1 -> 0x06090011
        (
            [0x40, 0x76, 0x4C, 0x01, 0, 0, 0, 0],
            [0x80, 0x76, 0x4C, 0x01, 0x11, 0x00, 0x09, 0x06],
        ),
        // write to read-only C5017 (index 0x4C66): 0x06010002
        (
            [0x23, 0x66, 0x4C, 0x00, 0x05, 0, 0, 0],
            [0x80, 0x66, 0x4C, 0x00, 0x02, 0x00, 0x01, 0x06],
        ),
        // read-only is checked before the length
        (
            [0x2B, 0x66, 0x4C, 0x00, 0x05, 0, 0, 0],
            [0x80, 0x66, 0x4C, 0x00, 0x02, 0x00, 0x01, 0x06],
        ),
        // C5001 above max 16000 (raw 160000001 = 0x09896801): 0x06090031
        (
            [0x23, 0x76, 0x4C, 0x00, 0x01, 0x68, 0x89, 0x09],
            [0x80, 0x76, 0x4C, 0x00, 0x31, 0x00, 0x09, 0x06],
        ),
        // C5008 (index 0x4C6F) below min 1.0 (raw 9999 = 0x270F): 0x06090032
        (
            [0x23, 0x6F, 0x4C, 0x00, 0x0F, 0x27, 0x00, 0x00],
            [0x80, 0x6F, 0x4C, 0x00, 0x32, 0x00, 0x09, 0x06],
        ),
        // C5016 (index 0x4C67) 1.5 is within 0..2 but no enumerated value: 0x06090030
        (
            [0x23, 0x67, 0x4C, 0x00, 0x98, 0x3A, 0x00, 0x00],
            [0x80, 0x67, 0x4C, 0x00, 0x30, 0x00, 0x09, 0x06],
        ),
        // 2-byte write (0x2B) to a FIX32 code: 0x06070010
        (
            [0x2B, 0x76, 0x4C, 0x00, 0x10, 0x27, 0, 0],
            [0x80, 0x76, 0x4C, 0x00, 0x10, 0x00, 0x07, 0x06],
        ),
        // 1-byte write (0x2F) to bit-coded C0150: 0x06070010
        (
            [0x2F, 0x69, 0x5F, 0x00, 0x01, 0, 0, 0],
            [0x80, 0x69, 0x5F, 0x00, 0x10, 0x00, 0x07, 0x06],
        ),
    ];
    for (req, want) in cases {
        assert_eq!(answer(&mut d, req), want, "request {req:02X?}");
    }
    // nothing changed
    assert_eq!(raw(&d, 5001), RawValue::Int(30_000_000));
    assert_eq!(raw(&d, 5016), RawValue::Int(0));
    // an enumerated value is taken: Position control = 2 -> raw 20000
    assert_eq!(
        answer(&mut d, [0x23, 0x67, 0x4C, 0x00, 0x20, 0x4E, 0x00, 0x00]),
        [0x60, 0x67, 0x4C, 0x00, 0, 0, 0, 0]
    );
    assert_eq!(raw(&d, 5016), RawValue::Int(20_000));
}

#[test]
fn protocol_errors_are_the_codecs_aborts() {
    let mut d = test_drive(1);
    // unknown command byte: 0x05040001, index/subindex echoed
    assert_eq!(
        answer(&mut d, [0xE0, 0x76, 0x4C, 0x00, 0, 0, 0, 0]),
        [0x80, 0x76, 0x4C, 0x00, 0x01, 0x00, 0x04, 0x05]
    );
    // a frame of 4 data bytes (DS301 SDO frames carry 8): 0x05040001
    let r = d
        .hear(T0, &frame(0x601, &[0x40, 0x76, 0x4C, 0x00]))
        .expect("answer");
    assert_eq!(
        r.frame.data,
        [0x80, 0x76, 0x4C, 0x00, 0x01, 0x00, 0x04, 0x05]
    );
    // a download segment while idle: 0x05040001
    assert_eq!(
        answer(&mut d, [0x00, 1, 2, 3, 4, 5, 6, 7]),
        [0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05]
    );
    // a client abort is not answered
    assert!(
        d.hear(T0, &frame(0x601, &[0x80, 0x76, 0x4C, 0, 0, 0, 0x04, 0x05]))
            .is_none()
    );
}

#[test]
fn only_its_own_request_cob_id_is_answered() {
    let mut d = test_drive(5);
    let read = [0x40, 0x76, 0x4C, 0x00, 0, 0, 0, 0];
    for f in [
        frame(0x601, &read), // another node
        frame(0x585, &read), // a response COB-ID
        driveset_proto::can::CanFrame::new_extended(0x605, &read).unwrap(), // 29-bit
        driveset_proto::can::CanFrame::new_remote(0x605, 8).unwrap(),
        frame(0x000, &[0x01, 0x05]), // NMT start: not an SDO server's business
    ] {
        assert!(d.hear(T0, &f).is_none(), "{f:?}");
    }
    let r = d.hear(T0, &frame(0x605, &read)).expect("answer");
    assert_eq!(r.frame.id, 0x585);
    assert_eq!(
        r.frame.data,
        [0x43, 0x76, 0x4C, 0x00, 0x80, 0xC3, 0xC9, 0x01]
    );
    assert_eq!(r.reaction, Duration::from_millis(1));
}

#[test]
fn segmented_download_of_4_bytes_is_taken_longer_is_refused() {
    let mut d = test_drive(1);
    // C5004 (index 0x4C73): initiate with size 4 (page 454 "Block" 0x21)
    assert_eq!(
        answer(&mut d, [0x21, 0x73, 0x4C, 0x00, 0x04, 0, 0, 0]),
        [0x60, 0x73, 0x4C, 0x00, 0, 0, 0, 0]
    );
    // one last segment, toggle 0, n = 3 unused, c = 1 -> 0x07; 2.5 s = raw 25000 = 0x61A8
    assert_eq!(
        answer(&mut d, [0x07, 0xA8, 0x61, 0x00, 0x00, 0, 0, 0]),
        [0x20, 0, 0, 0, 0, 0, 0, 0]
    );
    assert_eq!(raw(&d, 5004), RawValue::Int(25_000));

    // 8 bytes: the codec acknowledges every segment, the drive refuses the
    // value after the last one: 0x06070010.
    assert_eq!(
        answer(&mut d, [0x21, 0x73, 0x4C, 0x00, 0x08, 0, 0, 0]),
        [0x60, 0x73, 0x4C, 0x00, 0, 0, 0, 0]
    );
    assert_eq!(
        answer(&mut d, [0x00, 1, 2, 3, 4, 5, 6, 7]),
        [0x20, 0, 0, 0, 0, 0, 0, 0]
    );
    // toggle 1, n = 6, c = 1 -> 0x1D
    assert_eq!(
        answer(&mut d, [0x1D, 8, 0, 0, 0, 0, 0, 0]),
        [0x80, 0x73, 0x4C, 0x00, 0x10, 0x00, 0x07, 0x06]
    );
    assert_eq!(raw(&d, 5004), RawValue::Int(25_000));

    // toggle error mid-transfer: 0x05030000
    answer(&mut d, [0x21, 0x73, 0x4C, 0x00, 0x0E, 0, 0, 0]);
    answer(&mut d, [0x00, 1, 2, 3, 4, 5, 6, 7]);
    assert_eq!(
        answer(&mut d, [0x00, 1, 2, 3, 4, 5, 6, 7]),
        [0x80, 0x73, 0x4C, 0x00, 0x00, 0x00, 0x03, 0x05]
    );
}

#[test]
fn every_value_is_at_most_4_bytes_so_uploads_are_expedited() {
    let mut d = test_drive(1);
    for p in d.table().clone().iter() {
        // the store object 0x1010 sub 1 is kept by index, not a Lenze code
        let Ok(number) = u16::try_from(p.key.number) else {
            continue;
        };
        let index = 24575 - number;
        let [lo, hi] = index.to_le_bytes();
        let resp = answer(&mut d, [0x40, lo, hi, 0x00, 0, 0, 0, 0]);
        assert_eq!(resp[0], 0x43, "C{:04}: {resp:02X?}", p.key.number);
        // an upload segment request after an expedited read: 0x05040001
        assert_eq!(
            answer(&mut d, [0x60, 0, 0, 0, 0, 0, 0, 0]),
            [0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05]
        );
    }
}

#[test]
fn power_cycle_keeps_saved_values_and_drops_transfers() {
    let mut d = test_drive(1);
    answer(&mut d, [0x23, 0x75, 0x4C, 0x00, 0x4E, 0x61, 0xBC, 0x00]);
    // the demo fixture keeps writes only once saved: 0x1010 sub 1 = "save"
    assert_eq!(
        answer(&mut d, [0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'e']),
        [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]
    );
    // a segmented download is running when the power goes
    answer(&mut d, [0x21, 0x73, 0x4C, 0x00, 0x08, 0, 0, 0]);
    d.power_cycle(T0, Duration::from_millis(500));
    let read = frame(0x601, &[0x40, 0x75, 0x4C, 0x00, 0, 0, 0, 0]);
    assert!(d.hear(T0, &read).is_none());
    assert!(d.hear(T0 + Duration::from_millis(499), &read).is_none());
    let back = T0 + Duration::from_millis(500);
    let r = d
        .hear(back, &read)
        .expect("answers after the power is back");
    assert_eq!(
        r.frame.data,
        [0x43, 0x75, 0x4C, 0x00, 0x4E, 0x61, 0xBC, 0x00]
    );
    // the transfer was lost: its next segment is a command out of place
    let r = d
        .hear(back, &frame(0x601, &[0x00, 1, 2, 3, 4, 5, 6, 7]))
        .expect("answer");
    assert_eq!(r.frame.data, [0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05]);
    assert_eq!(raw(&d, 5002), RawValue::Int(12_345_678));
}

#[test]
fn state_poke_and_factory_values() {
    let mut d = EcsDrive::new(NodeId::new(1).unwrap(), 1).unwrap();
    let s = d.state();
    assert_eq!(s.schema, "fictional-ecs-demo");
    // C0135, C0150, C5001..C5016 and the store object 0x1010 sub 1
    assert_eq!(s.values.len(), 19);
    assert_eq!(s.values[&CodeKey::new(5001)], RawValue::Int(30_000_000));
    assert_eq!(s.values[&CodeKey::new(5015)], RawValue::Int(5_000));
    assert_eq!(s.values[&CodeKey::new(135)], RawValue::Int(0));
    d.poke(CodeKey::new(5001), RawValue::Int(-1)).unwrap();
    assert_eq!(d.state().values[&CodeKey::new(5001)], RawValue::Int(-1));
    assert!(d.poke(CodeKey::new(5001), RawValue::Int(1 << 31)).is_err());
    assert!(d.poke(CodeKey::new(135), RawValue::Int(-1)).is_err());
    assert!(
        d.poke(CodeKey::new(135), RawValue::Int(0xFFFF_FFFF))
            .is_ok()
    );
    assert!(
        d.poke(CodeKey::new(5001), RawValue::Text("x".into()))
            .is_err()
    );
    assert!(d.poke(CodeKey::new(9999), RawValue::Int(0)).is_err());
    assert_eq!(d.family(), "ecs");
    assert_eq!(d.node_id(), 1);
}

#[test]
fn reaction_times_are_seeded_and_within_the_assumed_range() {
    let read = frame(0x601, &[0x40, 0x76, 0x4C, 0x00, 0, 0, 0, 0]);
    let run = |seed| {
        let mut d = EcsDrive::new(NodeId::new(1).unwrap(), seed).unwrap();
        (0..20)
            .map(|_| d.hear(T0, &read).expect("answer").reaction)
            .collect::<Vec<_>>()
    };
    let a = run(42);
    assert_eq!(a, run(42));
    assert_ne!(a, run(43));
    let r = ReactionTime::of(
        driveset_schema::Family::Ecs,
        driveset_schema::family::Keypad::Absent,
    );
    assert!(a.iter().all(|t| *t >= r.min && *t <= r.max), "{a:?}");
}
