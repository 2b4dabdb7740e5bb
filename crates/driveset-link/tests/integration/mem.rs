//! In-memory links: exact wire timing in virtual time.

use std::time::Duration;

use driveset_link::mem::{byte_pair, wire_time};
use driveset_link::{ByteLink, Clock, Instant, LinkError, VirtualClock};

/// `n` characters at 9600 baud take n x 10 / 9600 s.
fn at_9600(n: u64) -> Instant {
    Instant::from_nanos(n * 10 * 1_000_000_000 / 9600)
}

#[test]
fn wire_time_is_ten_bits_a_character() {
    assert_eq!(wire_time(1, 9600), Duration::from_nanos(1_041_666));
    assert_eq!(wire_time(3, 9600), Duration::from_nanos(3_125_000));
    assert_eq!(wire_time(96, 9600), Duration::from_millis(100));
    assert_eq!(wire_time(12, 57600), Duration::from_nanos(2_083_333));
    assert_eq!(wire_time(1, 1200), Duration::from_nanos(8_333_333));
    assert_eq!(wire_time(0, 9600), Duration::ZERO);
    assert_eq!(wire_time(5, 0), Duration::ZERO);
}

#[test]
fn send_occupies_the_sender_for_the_wire_time() {
    let clock = VirtualClock::new();
    let (mut a, mut b) = byte_pair(&clock, 9600).unwrap();
    let request = b"\x040011TYPE\x05"; // 10 characters
    a.send(request).unwrap();
    assert_eq!(clock.now(), at_9600(10));
    assert_eq!(clock.now(), Instant::from_nanos(10_416_666));

    let mut buf = [0u8; 64];
    let n = b.recv(&mut buf, Instant::MAX).unwrap();
    assert_eq!(&buf[..n], request);
    // Everything had arrived: receiving took no time.
    assert_eq!(clock.now(), at_9600(10));
}

#[test]
fn request_and_reply_take_exactly_their_characters() {
    let clock = VirtualClock::new();
    let (mut host, mut drive) = byte_pair(&clock, 9600).unwrap();
    let mut buf = [0u8; 16];

    host.send(b"ABC").unwrap(); // 3 characters
    let n = drive.recv(&mut buf, Instant::MAX).unwrap();
    assert_eq!(&buf[..n], b"ABC");
    assert_eq!(clock.now(), Instant::from_nanos(3_125_000));

    drive.send(&[0x06]).unwrap(); // ACK, 1 character
    let n = host.recv(&mut buf, Instant::MAX).unwrap();
    assert_eq!(&buf[..n], &[0x06]);
    assert_eq!(
        clock.now(),
        Instant::from_nanos(3_125_000 + 1_041_666),
        "3 + 1 characters at 9600 baud"
    );
}

#[test]
fn characters_arrive_one_by_one_while_the_sender_is_busy() {
    // The receiver sees character i at start + (i + 1) x 10 / baud: observe
    // it through next_arrival before the sender's clock moves on.
    let clock = VirtualClock::starting_at(Instant::from_nanos(500));
    let (mut a, b) = byte_pair(&clock, 19200).unwrap();
    a.send(b"xy").unwrap();
    assert_eq!(b.next_arrival(), Some(Instant::from_nanos(500 + 520_833)));
    assert_eq!(clock.now(), Instant::from_nanos(500 + 1_041_666));
    // A second send starts when the first has finished.
    a.send(b"z").unwrap();
    assert_eq!(clock.now(), Instant::from_nanos(500 + 1_041_666 + 520_833));
}

#[test]
fn recv_returns_what_fits_then_the_rest() {
    let clock = VirtualClock::new();
    let (mut a, mut b) = byte_pair(&clock, 9600).unwrap();
    a.send(b"hello").unwrap();
    let mut small = [0u8; 2];
    assert_eq!(b.recv(&mut small, Instant::MAX).unwrap(), 2);
    assert_eq!(&small, b"he");
    let mut rest = [0u8; 8];
    let n = b.recv(&mut rest, Instant::MAX).unwrap();
    assert_eq!(&rest[..n], b"llo");
    assert_eq!(b.recv(&mut [], Instant::MAX).unwrap(), 0);
}

#[test]
fn an_idle_line_moves_time_to_the_deadline() {
    let clock = VirtualClock::new();
    let (mut a, _b) = byte_pair(&clock, 9600).unwrap();
    let mut buf = [0u8; 4];
    let deadline = clock.deadline_in(Duration::from_millis(250));
    assert_eq!(a.recv(&mut buf, deadline).unwrap(), 0);
    assert_eq!(clock.now(), Instant::from_nanos(250_000_000));
}

#[test]
fn discard_drops_what_has_arrived() {
    let clock = VirtualClock::new();
    let (mut a, mut b) = byte_pair(&clock, 9600).unwrap();
    a.send(b"stale").unwrap();
    b.discard_input().unwrap();
    a.send(b"new").unwrap();
    let mut buf = [0u8; 8];
    let n = b.recv(&mut buf, Instant::MAX).unwrap();
    assert_eq!(&buf[..n], b"new");
    b.flush().unwrap();
}

#[test]
fn eight_bit_bytes_and_odd_rates_are_refused() {
    let clock = VirtualClock::new();
    let (mut a, _b) = byte_pair(&clock, 9600).unwrap();
    match a.send(&[0x02, 0x41, 0xC1]) {
        Err(LinkError::NotSevenBit { offset, byte, .. }) => {
            assert_eq!((offset, byte), (2, 0xC1));
        }
        other => panic!("expected NotSevenBit, got {other:?}"),
    }
    assert_eq!(clock.now(), Instant::ZERO, "nothing was sent");
    match byte_pair(&clock, 115_200) {
        Err(LinkError::UnsupportedBaud { baud, .. }) => assert_eq!(baud, 115_200),
        other => panic!("expected UnsupportedBaud, got {other:?}"),
    }
}

#[test]
fn a_dropped_end_is_a_cut_cable() {
    let clock = VirtualClock::new();
    let (mut a, b) = byte_pair(&clock, 9600).unwrap();
    drop(b);
    a.send(b"anyone?").unwrap();
    let mut buf = [0u8; 8];
    assert_eq!(
        a.recv(&mut buf, Instant::from_nanos(1_000_000_000))
            .unwrap(),
        0
    );
    assert_eq!(clock.now(), Instant::from_nanos(1_000_000_000));
}

#[test]
fn ends_are_usable_as_trait_objects() {
    let clock = VirtualClock::new();
    let (a, b) = byte_pair(&clock, 4800).unwrap();
    let mut a: Box<dyn ByteLink> = Box::new(a);
    let mut b: Box<dyn ByteLink> = Box::new(b);
    assert_eq!((a.port(), b.port(), a.baud()), ("mem-a", "mem-b", 4800));
    a.send(b"k").unwrap();
    let mut buf = [0u8; 1];
    assert_eq!(b.recv(&mut buf, Instant::MAX).unwrap(), 1);
    assert_eq!(b.clock().now(), Instant::from_nanos(2_083_333));
}

mod frames {
    use driveset_link::mem::{can_frame_time, frame_pair};
    use driveset_link::{CanFrame, Clock, FrameLink, Instant, LinkError, VirtualClock};
    use driveset_proto::can::timing::{Stuffing, frame_bits};

    #[test]
    fn a_frame_takes_its_bits_at_the_bit_rate() {
        let clock = VirtualClock::new();
        let (mut master, mut drive) = frame_pair(&clock, 500_000).unwrap();
        let request = CanFrame::new(0x601, &[0x40, 0xF4, 0x5F, 0x00, 0, 0, 0, 0]).unwrap();
        let bits = frame_bits(&request, Stuffing::Exact).unwrap();
        assert!((111..=135).contains(&bits), "{bits} bits");
        // 2 µs a bit at 500 kbit/s.
        let t1 = Instant::from_nanos(u64::from(bits) * 2_000);
        assert_eq!(can_frame_time(&request, 500_000).unwrap(), t1.since_epoch());

        master.send(&request).unwrap();
        assert_eq!(clock.now(), t1);
        assert_eq!(drive.recv(Instant::MAX).unwrap(), Some(request));
        assert_eq!(clock.now(), t1);

        let reply = CanFrame::new(0x581, &[0x4B, 0xF4, 0x5F, 0x00, 0xE8, 0x03, 0, 0]).unwrap();
        let reply_bits = frame_bits(&reply, Stuffing::Exact).unwrap();
        drive.send(&reply).unwrap();
        assert_eq!(master.recv(Instant::MAX).unwrap(), Some(reply));
        assert_eq!(
            clock.now(),
            Instant::from_nanos(u64::from(bits + reply_bits) * 2_000)
        );
    }

    #[test]
    fn frames_queue_in_order_and_time_out_when_idle() {
        let clock = VirtualClock::new();
        let (mut a, mut b) = frame_pair(&clock, 125_000).unwrap();
        let f1 = CanFrame::new(0x701, &[0x05]).unwrap();
        let f2 = CanFrame::new_extended(0x1234_5678, &[]).unwrap();
        a.send(&f1).unwrap();
        a.send(&f2).unwrap();
        let end = clock.now();
        assert_eq!(b.recv(Instant::MAX).unwrap(), Some(f1));
        assert_eq!(b.recv(Instant::MAX).unwrap(), Some(f2));
        assert_eq!(clock.now(), end);
        let deadline = end + std::time::Duration::from_millis(10);
        assert_eq!(b.recv(deadline).unwrap(), None);
        assert_eq!(clock.now(), deadline);

        a.send(&f1).unwrap();
        b.discard_input().unwrap();
        assert_eq!(b.recv(clock.now()).unwrap(), None);
        assert_eq!((b.port(), b.bitrate()), ("mem-can-b", 125_000));
    }

    #[test]
    fn invalid_frames_and_rates_are_refused() {
        let clock = VirtualClock::new();
        let (mut a, _b) = frame_pair(&clock, 1_000_000).unwrap();
        let bad = CanFrame {
            id: 0x800,
            ..CanFrame::default()
        };
        assert!(matches!(a.send(&bad), Err(LinkError::InvalidFrame { .. })));
        assert_eq!(clock.now(), Instant::ZERO);
        assert!(matches!(
            frame_pair(&clock, 33_333),
            Err(LinkError::UnsupportedBitrate {
                bitrate: 33_333,
                ..
            })
        ));
    }
}
