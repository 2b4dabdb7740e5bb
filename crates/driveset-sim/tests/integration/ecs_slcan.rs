//! The simulated slcan adapter on a real pseudo terminal: the exact bytes a
//! host sees (python-can's open sequence, identity queries, an SDO
//! exchange), and driveset's own `slcan://` link talking to a simulated ECS
//! through it. Real time, but nothing asserts a duration.

use crate::ecs_support as support;

use std::io::Write;
use std::time::Duration;

use driveset_link::slcan::SlcanLink;
use driveset_link::{Clock, FrameLink, RealClock};
use driveset_proto::can::{CodeNumber, NodeId, SdoRequest, SdoResponse, Subindex};
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::can_bus::FrameLine;
use driveset_sim::drive::FrameDrive;
use driveset_sim::slcan_serve::{SlcanEvent, SlcanServer};
use serialport::TTYPort;
use support::test_drive;

use driveset_test_support::{pty_lock, read_exact_n};

fn server(nodes: &[u8]) -> SlcanServer {
    let drives: Vec<Box<dyn FrameDrive>> = nodes
        .iter()
        .map(|&n| Box::new(test_drive(n)) as Box<dyn FrameDrive>)
        .collect();
    let line = FrameLine::new(500_000, drives).expect("a 500 kbit/s bus");
    let _guard = pty_lock();
    SlcanServer::spawn(line, |_: &SlcanEvent| {}).expect("serve on a pty")
}

/// Opens the slave path as a host would (serialport opens exclusively:
/// TIOCEXCL + flock, so this also shows the server holds no lock on it).
fn host(path: &str) -> TTYPort {
    serialport::new(path, 115_200)
        .timeout(Duration::from_secs(10))
        .open_native()
        .expect("the slave path opens by name")
}

fn send(h: &mut TTYPort, bytes: &[u8]) {
    h.write_all(bytes).expect("host writes");
    h.flush().expect("host flushes");
}

#[test]
fn python_can_open_sequence_and_identity_exact_bytes() {
    let s = server(&[1]);
    let mut h = host(s.path());
    // python-can 4.6 slcan: C, S6, empty line (no CAN FD data rate), O, O.
    send(&mut h, b"C\rS6\r\rO\rO\r");
    assert_eq!(read_exact_n(&mut h, 5), b"\r\r\r\r\x07");
    send(&mut h, b"V\rN\rF\r");
    assert_eq!(read_exact_n(&mut h, 16), b"V1013\rNDSIM\rF00\r");
    // while open: no bit rate, no timestamps change; garbage is refused
    send(&mut h, b"S6\rZ1\rXYZ\r");
    assert_eq!(read_exact_n(&mut h, 3), b"\x07\x07\x07");
    // closed: frames refused; a rate the bus does not run at is refused
    send(&mut h, b"C\rt601840764C0000000000\rS8\r");
    assert_eq!(read_exact_n(&mut h, 3), b"\r\x07\x07");
    let (_, stats) = s.stop().expect("stop");
    assert_eq!(stats.frames_from_host, 0);
    assert_eq!(stats.bad_lines, 1);
}

#[test]
fn sdo_read_through_the_adapter_exact_bytes() {
    let s = server(&[1, 2]);
    let mut h = host(s.path());
    send(&mut h, b"C\rS6\r\rO\r");
    assert_eq!(read_exact_n(&mut h, 4), b"\r\r\r\r");
    // read C5001 (index 0x4C76) from node 1
    send(&mut h, b"t601840764C0000000000\r");
    assert_eq!(read_exact_n(&mut h, 2), b"z\r");
    assert_eq!(read_exact_n(&mut h, 22), b"t581843764C0080C3C901\r");
    // write C5002 = 1234.5678 to node 2 (lower-case hex is accepted)
    send(&mut h, b"t602823754c004e61bc00\r");
    assert_eq!(read_exact_n(&mut h, 2), b"z\r");
    assert_eq!(read_exact_n(&mut h, 22), b"t582860754C0000000000\r");
    // timestamps: Z1 while closed, then every received frame carries 4 digits
    send(&mut h, b"C\rZ1\rO\rt601840764C0000000000\r");
    assert_eq!(read_exact_n(&mut h, 5), b"\r\r\rz\r");
    let line = read_exact_n(&mut h, 26);
    assert_eq!(&line[..21], b"t581843764C0080C3C901");
    assert!(line[21..25].iter().all(u8::is_ascii_hexdigit), "{line:?}");
    assert_eq!(line[25], b'\r');
    let (line, stats) = s.stop().expect("stop");
    let drives = line.drives();
    assert_eq!(
        drives[1].state().values[&CodeKey::new(5002)],
        RawValue::Int(12_345_678)
    );
    assert_eq!(
        drives[0].state().values[&CodeKey::new(5002)],
        RawValue::Int(0)
    );
    assert_eq!(stats.frames_from_host, 3);
    assert_eq!(stats.answers, 3);
}

#[test]
fn driveset_slcan_link_talks_to_the_simulated_ecs() {
    let s = server(&[3]);
    let node = NodeId::new(3).unwrap();
    let mut link = SlcanLink::open(s.path(), 500_000, 115_200, Duration::from_secs(5))
        .expect("driveset's slcan link opens the simulated adapter");
    let code = CodeNumber::new(5001).unwrap();
    link.send(&SdoRequest::read_code(code, Subindex(0)).to_can(node))
        .expect("send");
    let got = link
        .recv(RealClock.deadline_in(Duration::from_secs(10)))
        .expect("recv")
        .expect("an answer");
    let r = SdoResponse::from_can(&got, node).expect("an SDO response from node 3");
    assert_eq!(r.encode(), [0x43, 0x76, 0x4C, 0x00, 0x80, 0xC3, 0xC9, 0x01]);
    drop(link);
    s.stop().expect("stop");
}
