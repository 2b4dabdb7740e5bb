//! SerialLink and SlcanLink over real pseudo terminals
//! (`serialport::TTYPort::pair()`): the link opens the slave end by path,
//! the test plays the far side (a drive, a fake slcan adapter) on the
//! master end.
//!
//! A Linux pty accepts but ignores 7E1 (it runs 8N1), so nothing here
//! asserts termios settings; the bytes are what is checked.

use std::io::{Read, Write};
use std::thread;
use std::time::Duration;

use driveset_link::serial::SerialLink;
use driveset_link::slcan::SlcanLink;
use driveset_link::{
    ByteLink, CanFrame, Clock, FrameLink, Instant, Link, LinkError, OpenOptions, PortSpec,
    RealClock, open,
};
use serialport::TTYPort;

use driveset_test_support::{pty_pair, read_exact_n, recv_n};

/// Read on the master end up to and including the next CR.
fn master_line(master: &mut TTYPort) -> Vec<u8> {
    let mut line = Vec::new();
    let mut byte = [0u8; 1];
    while line.last() != Some(&b'\r') {
        master.read_exact(&mut byte).expect("master reads a line");
        line.push(byte[0]);
    }
    line
}

#[test]
fn serial_link_moves_exact_bytes_both_ways() {
    let (mut master, path, _hold) = pty_pair();
    let mut link = SerialLink::open(&path, 9600).expect("open the slave pty");
    assert_eq!(link.port(), path);
    assert_eq!(link.baud(), 9600);

    // LUSTBUS value request, plain 7-bit ASCII.
    let request = b"\x04001\x0291\x05";
    link.send(request).expect("send");
    link.flush().expect("flush");
    assert_eq!(read_exact_n(&mut master, request.len()), request);

    let reply = b"\x0291(+1000.)\x03\x2d";
    master.write_all(reply).expect("master writes");
    assert_eq!(recv_n(&mut link, reply.len()), reply);
}

#[test]
fn serial_link_passes_received_bytes_unmasked() {
    // Masking bit 7 is the codec's job: the link hands over what it read.
    let (mut master, path, _hold) = pty_pair();
    let mut link = SerialLink::open(&path, 19200).expect("open");
    master.write_all(&[0x86, 0x15]).expect("master writes");
    assert_eq!(recv_n(&mut link, 2), [0x86, 0x15]);
}

#[test]
fn serial_link_deadline_and_discard() {
    let (mut master, path, _hold) = pty_pair();
    let mut link = SerialLink::open(&path, 9600).expect("open");
    let mut buf = [0u8; 8];
    let deadline = RealClock.deadline_in(Duration::from_millis(30));
    assert_eq!(link.recv(&mut buf, deadline).expect("recv"), 0);
    assert_eq!(link.recv(&mut buf, Instant::ZERO).expect("poll"), 0);
    assert_eq!(link.recv(&mut [], Instant::MAX).expect("empty buf"), 0);

    master.write_all(b"stale").expect("write");
    master.flush().expect("flush");
    // Wait until the stale bytes are there, then drop them.
    let mut first = [0u8; 1];
    let deadline = RealClock.deadline_in(Duration::from_secs(5));
    assert_eq!(link.recv(&mut first, deadline).expect("recv"), 1);
    assert_eq!(&first, b"s");
    // The pty delivers a write at once; give the rest a moment to land.
    let settle = RealClock.deadline_in(Duration::from_millis(50));
    RealClock.sleep_until(settle);
    link.discard_input().expect("discard");
    master.write_all(b"new").expect("write");
    assert_eq!(recv_n(&mut link, 3), b"new");
}

#[test]
fn serial_link_refuses_eight_bit_bytes() {
    let (_master, path, _hold) = pty_pair();
    let mut link = SerialLink::open(&path, 9600).expect("open");
    match link.send(b"\x02\xB1\x03") {
        Err(LinkError::NotSevenBit {
            port,
            offset: 1,
            byte: 0xB1,
        }) => assert_eq!(port, path),
        other => panic!("expected NotSevenBit, got {other:?}"),
    }
}

#[test]
fn serial_open_is_exclusive() {
    let (_master, path, _hold) = pty_pair();
    let _first = SerialLink::open(&path, 9600).expect("first open");
    match SerialLink::open(&path, 9600) {
        Err(LinkError::Busy { port }) => assert_eq!(port, path),
        other => panic!("expected Busy, got {other:?}"),
    }
}

#[test]
fn serial_open_errors() {
    match SerialLink::open("/dev/ttyUSB0", 115_200) {
        Err(e @ LinkError::UnsupportedBaud { .. }) => assert_eq!(
            e.to_string(),
            "/dev/ttyUSB0: 115200 baud is not supported; LUSTBUS and LECOM lines (7E1) run at 1200, 2400, 4800, 9600, 19200, 38400, 57600 baud: pick one of these and set the drives to match"
        ),
        other => panic!("expected UnsupportedBaud, got {other:?}"),
    }
    match SerialLink::open("/dev/driveset-no-such-tty", 9600) {
        Err(LinkError::NoDevice { port }) => assert_eq!(port, "/dev/driveset-no-such-tty"),
        other => panic!("expected NoDevice, got {other:?}"),
    }
}

#[test]
fn open_a_serial_port_string() {
    let (mut master, path, _hold) = pty_pair();
    let spec = PortSpec::parse(&format!("{path}?baud=4800")).expect("parse");
    let Link::Bytes(mut link) = open(&spec, &OpenOptions::default()).expect("open") else {
        panic!("a serial path opens a byte link");
    };
    assert_eq!(link.baud(), 4800);
    link.send(b"\x04").expect("send");
    assert_eq!(read_exact_n(&mut master, 1), b"\x04");
}

/// A fake slcan adapter on the master end: answers the open sequence with
/// `replies` (one per command line) and returns the lines it got.
fn fake_adapter_open(master: &mut TTYPort, replies: &[&[u8]]) -> Vec<Vec<u8>> {
    let mut lines = Vec::new();
    for reply in replies {
        lines.push(master_line(master));
        master.write_all(reply).expect("adapter replies");
    }
    lines
}

#[test]
fn slcan_open_sequence_and_frames() {
    let (mut master, path, _hold) = pty_pair();
    let adapter = thread::spawn(move || {
        let lines = fake_adapter_open(&mut master, &[b"\x07", b"\r", b"\r"]);
        (master, lines)
    });
    let mut link = SlcanLink::open(&path, 500_000, 115_200, Duration::from_secs(5)).expect("open");
    let (mut master, lines) = adapter.join().expect("adapter thread");
    assert_eq!(lines, [b"C\r".to_vec(), b"S6\r".to_vec(), b"O\r".to_vec()]);
    assert_eq!(link.bitrate(), 500_000);
    assert_eq!(link.port(), format!("slcan://{path}"));

    // SDO read request to node 1: C0011 (index 0x5FF4), subindex 0.
    let request = CanFrame::new(0x601, &[0x40, 0xF4, 0x5F, 0x00, 0, 0, 0, 0]).unwrap();
    let adapter = thread::spawn(move || {
        let line = master_line(&mut master);
        master.write_all(b"z\r").expect("ack");
        // The drive's answer, with a Z1 timestamp.
        master
            .write_all(b"t58184BF45F00E80300001234\r")
            .expect("frame");
        (master, line)
    });
    link.send(&request).expect("send");
    let (mut master, line) = adapter.join().expect("adapter thread");
    assert_eq!(line, b"t601840F45F0000000000\r");

    let deadline = RealClock.deadline_in(Duration::from_secs(5));
    let reply = link.recv(deadline).expect("recv").expect("a frame");
    assert_eq!(
        reply,
        CanFrame::new(0x581, &[0x4B, 0xF4, 0x5F, 0x00, 0xE8, 0x03, 0x00, 0x00]).unwrap()
    );

    // Nothing more: the deadline passes.
    let deadline = RealClock.deadline_in(Duration::from_millis(30));
    assert_eq!(link.recv(deadline).expect("recv"), None);

    // An extended remote frame, acknowledged with CR.
    let remote = CanFrame::new_remote_extended(0x1234567, 0).unwrap();
    let adapter = thread::spawn(move || {
        let line = master_line(&mut master);
        master.write_all(b"\r").expect("ack");
        (master, line)
    });
    link.send(&remote).expect("send remote");
    let (mut master, line) = adapter.join().expect("adapter thread");
    assert_eq!(line, b"R012345670\r");

    // A refused transmit (BELL) is an error naming the frame.
    let adapter = thread::spawn(move || {
        let line = master_line(&mut master);
        master.write_all(b"\x07").expect("bell");
        (master, line)
    });
    let frame = CanFrame::new(0x000, &[0x01, 0x00]).unwrap();
    match link.send(&frame) {
        Err(LinkError::Slcan { detail, .. }) => {
            assert!(detail.starts_with("refused frame `t00020100`"), "{detail}")
        }
        other => panic!("expected Slcan error, got {other:?}"),
    }
    let (mut master, _) = adapter.join().expect("adapter thread");

    // Dropping the link closes the channel.
    drop(link);
    assert_eq!(master_line(&mut master), b"C\r");
}

#[test]
fn slcan_frames_arriving_during_a_reply_wait_are_kept() {
    let (mut master, path, _hold) = pty_pair();
    let adapter = thread::spawn(move || {
        let lines = fake_adapter_open(&mut master, &[b"\r", b"\r", b"\r"]);
        // Before acknowledging the first transmit, a frame from the bus.
        let line = master_line(&mut master);
        master.write_all(b"t701110\rz\r").expect("heartbeat + ack");
        (master, lines, line)
    });
    let mut link = SlcanLink::open(&path, 125_000, 115_200, Duration::from_secs(5)).expect("open");
    link.send(&CanFrame::new(0x000, &[0x01, 0x00]).unwrap())
        .expect("send");
    let (_master, lines, line) = adapter.join().expect("adapter thread");
    assert_eq!(lines[1], b"S4\r");
    assert_eq!(line, b"t00020100\r");
    let got = link
        .recv(Instant::ZERO)
        .expect("recv")
        .expect("the kept frame");
    assert_eq!(got, CanFrame::new(0x701, &[0x10]).unwrap());
}

#[test]
fn slcan_open_failures_name_the_command() {
    // The adapter refuses the bit rate.
    let (mut master, path, _hold) = pty_pair();
    let adapter = thread::spawn(move || {
        let lines = fake_adapter_open(&mut master, &[b"\r", b"\x07"]);
        (master, lines)
    });
    match SlcanLink::open(&path, 250_000, 115_200, Duration::from_secs(5)) {
        Err(LinkError::Slcan { port, detail }) => {
            assert_eq!(port, format!("slcan://{path}"));
            assert_eq!(detail, "refused `S5` (set the bit rate, answered BELL)");
        }
        other => panic!("expected Slcan error, got {other:?}"),
    }
    let (_master, lines) = adapter.join().expect("adapter thread");
    assert_eq!(lines, [b"C\r".to_vec(), b"S5\r".to_vec()]);

    // A silent device: not an slcan adapter.
    let (_master, path, _hold) = pty_pair();
    match SlcanLink::open(&path, 500_000, 115_200, Duration::from_millis(20)) {
        Err(LinkError::Slcan { detail, .. }) => {
            assert!(
                detail.starts_with("did not answer `S6` (set the bit rate)"),
                "{detail}"
            )
        }
        other => panic!("expected Slcan error, got {other:?}"),
    }

    match SlcanLink::open("/dev/ttyACM0", 333_000, 115_200, Duration::from_millis(20)) {
        Err(LinkError::UnsupportedBitrate {
            bitrate: 333_000, ..
        }) => {}
        other => panic!("expected UnsupportedBitrate, got {other:?}"),
    }
}
