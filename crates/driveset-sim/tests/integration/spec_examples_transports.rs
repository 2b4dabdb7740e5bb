//! The specs' example telegrams, byte for byte, over every transport a host
//! can reach the simulator by: the in-memory buses in virtual time
//! ([`SimByteBus`] as a [`ByteLink`], [`SimCanBus`] as a [`FrameLink`]), a
//! real pseudo terminal ([`serve::serve_pty`], the slcan adapter of
//! [`SlcanServer`]) and TCP loopback ([`serve::serve_tcp`]).
//!
//! One table per line kind ([`byte_examples`], [`ecs_examples`]) is shared
//! by all transports, so each example is asserted identically on each. The
//! expectations are those of `lust_models.rs`, `tmd.rs` and `ecs_*.rs`.
//! Real-time transports use bounded waits only; nothing asserts a duration.

use crate::ecs_support as support;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use driveset_link::{ByteLink, Clock, FrameLink, VirtualClock};
use driveset_proto::can::CanFrame;
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::bus::{ByteLine, SimByteBus};
use driveset_sim::can_bus::{FrameLine, SimCanBus};
use driveset_sim::drive::{ByteDrive, FrameDrive, ReactionTime};
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::serve;
use driveset_sim::slcan_serve::{SlcanEvent, SlcanServer};
use driveset_sim::tmd::{TmdDrive, TmdOptions};
use driveset_sim::vf1000::Vf1000;
use support::test_drive;

use driveset_test_support::pty_lock;

const STX: u8 = 0x02;
const ETX: u8 = 0x03;
const EOT: u8 = 0x04;
const ENQ: u8 = 0x05;
const ACK: u8 = 0x06;

/// Longest wait for an expected reply on a real-time transport.
const REPLY_WITHIN: Duration = Duration::from_secs(5);
/// How long "no answer" is listened for on a real-time transport.
const QUIET_FOR: Duration = Duration::from_millis(300);
/// The same, in virtual time (free).
const QUIET_VIRTUAL: Duration = Duration::from_secs(1);

// ---------------------------------------------------------------- the table

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Family {
    Mc6000,
    Vf1000,
    Tmd,
}

/// One spec example on a character line: a single drive, values poked
/// before, the telegrams with their exact replies (`None`: no answer), and
/// the values the drive must hold afterwards.
struct Example {
    name: &'static str,
    family: Family,
    address: u8,
    pokes: Vec<(u32, i64)>,
    steps: Vec<(Vec<u8>, Option<Vec<u8>>)>,
    after: Vec<(u32, i64)>,
}

/// LECOM BCC (8.G): XOR of the text after STX up to and including ETX.
fn lecom_bcc(text: &[u8]) -> u8 {
    text.iter().fold(ETX, |a, b| a ^ b)
}

use crate::lust_support::{enq as lust_enq, val as lust_val};

fn byte_examples() -> Vec<Example> {
    vec![
        Example {
            name: "LUSTBUS 6.1.1.1 VF1000 ENQUIRY of 12 via address 0",
            family: Family::Vf1000,
            address: 1,
            pokes: vec![(12, 0x03E8)],
            steps: vec![(
                vec![4, 64, 48, 48, 49, 49, 50, 5],
                Some(vec![64, 2, 48, 48, 49, 49, 50, 61, 48, 51, 69, 56, 3, 0x72]),
            )],
            after: vec![(12, 0x03E8)],
        },
        Example {
            name: "LUSTBUS 6.1.1.2 MC6000 ENQUIRY of 77-SPEED via address 0",
            family: Family::Mc6000,
            address: 1,
            pokes: vec![(77, 0x04FA_4000)],
            steps: vec![(
                vec![4, 64, 50, 48, 48, 55, 55, 5],
                Some(vec![
                    64, 2, 50, 48, 48, 55, 55, 61, 48, 52, 70, 65, 52, 48, 48, 48, 3, 0x0B,
                ]),
            )],
            after: vec![(77, 0x04FA_4000)],
        },
        Example {
            name: "LUSTBUS 6.2.2 VF1000 SELECT 05-FSSIO = 03E8",
            family: Family::Vf1000,
            address: 1,
            pokes: vec![],
            steps: vec![
                // The power-on bit first (section 6): read SIOF.
                (lust_enq(0, 85), Some(lust_val(0, 85, "0001"))),
                (
                    vec![4, 64, 2, 48, 48, 49, 48, 53, 61, 48, 51, 69, 56, 3, 0x74],
                    Some(vec![0x40, ACK]),
                ),
            ],
            after: vec![(5, 1000)],
        },
        Example {
            name: "LECOM 8.H b Tmd RECEIVE C46 at 01",
            family: Family::Tmd,
            address: 1,
            pokes: vec![(46, 354_000)],
            steps: vec![(
                vec![EOT, b'0', b'1', b'4', b'6', ENQ],
                Some(vec![STX, b'4', b'6', b'3', b'5', b'.', b'4', ETX, 0x1D]),
            )],
            after: vec![(46, 354_000)],
        },
        Example {
            name: "LECOM 8.I Tmd SEND C11 = 95.2 at 34",
            family: Family::Tmd,
            address: 34,
            pokes: vec![],
            steps: vec![
                (
                    vec![
                        EOT, b'3', b'4', STX, b'1', b'1', b'9', b'5', b'.', b'2', ETX, 0x13,
                    ],
                    Some(vec![ACK]),
                ),
                // Read back (8.H a).
                (
                    vec![EOT, b'3', b'4', b'1', b'1', ENQ],
                    Some(vec![
                        STX,
                        b'1',
                        b'1',
                        b'9',
                        b'5',
                        b'.',
                        b'2',
                        ETX,
                        lecom_bcc(b"1195.2"),
                    ]),
                ),
            ],
            after: vec![(11, 952_000)],
        },
        Example {
            name: "LECOM 8.J Tmd BROADCAST C40 = 0 to 00",
            family: Family::Tmd,
            address: 1,
            pokes: vec![],
            steps: vec![(
                vec![EOT, b'0', b'0', STX, b'4', b'0', b'0', ETX, 0x37],
                None,
            )],
            after: vec![(40, 0)],
        },
    ]
}

fn examples_of(family: Family) -> Vec<Example> {
    let v: Vec<_> = byte_examples()
        .into_iter()
        .filter(|e| e.family == family)
        .collect();
    assert!(!v.is_empty(), "no examples for {family:?}");
    v
}

fn drive_for(ex: &Example) -> Box<dyn ByteDrive> {
    let mut d: Box<dyn ByteDrive> = match ex.family {
        Family::Mc6000 => Box::new(
            Mc6000::new(LustOptions::new(ex.address).reaction(ReactionTime::ms(1, 1))).unwrap(),
        ),
        Family::Vf1000 => Box::new(
            Vf1000::new(LustOptions::new(ex.address).reaction(ReactionTime::ms(1, 1))).unwrap(),
        ),
        Family::Tmd => Box::new(
            TmdDrive::new(TmdOptions {
                reaction: ReactionTime::fixed(Duration::from_millis(5)),
                ..TmdOptions::at(ex.address).c0001(3)
            })
            .unwrap(),
        ),
    };
    for &(code, raw) in &ex.pokes {
        d.poke(CodeKey::new(code), RawValue::Int(raw)).unwrap();
    }
    d
}

fn line_for(ex: &Example) -> ByteLine {
    ByteLine::new(9600, vec![drive_for(ex)]).unwrap()
}

fn check_after(ex: &Example, drives: &[Box<dyn ByteDrive>]) {
    let d = drives
        .iter()
        .find(|d| d.address() == ex.address)
        .unwrap_or_else(|| panic!("{}: no drive at {}", ex.name, ex.address));
    let state = d.state();
    for &(code, raw) in &ex.after {
        assert_eq!(
            state.values.get(&CodeKey::new(code)),
            Some(&RawValue::Int(raw)),
            "{}: code {code} afterwards",
            ex.name
        );
    }
}

// ---------------------------------------------------------------- hosts

/// The host end of a character line.
trait ByteHost {
    fn send(&mut self, bytes: &[u8]);
    /// Exactly `n` bytes, or a panic after a bounded wait.
    fn read_n(&mut self, n: usize) -> Vec<u8>;
    /// Whatever arrives within the quiet period (expected: nothing).
    fn quiet(&mut self) -> Vec<u8>;
}

/// Runs `ex`'s steps against `host`: every reply byte for byte, and after
/// the last step nothing more.
fn run_steps(ex: &Example, host: &mut dyn ByteHost) {
    for (i, (request, reply)) in ex.steps.iter().enumerate() {
        host.send(request);
        match reply {
            Some(want) => {
                let got = host.read_n(want.len());
                assert_eq!(got, *want, "{}: step {i}: reply to {request:02X?}", ex.name);
            }
            None => {
                let got = host.quiet();
                assert!(
                    got.is_empty(),
                    "{}: step {i}: {request:02X?} must get no answer, got {got:02X?}",
                    ex.name
                );
            }
        }
    }
    let extra = host.quiet();
    assert!(extra.is_empty(), "{}: trailing {extra:02X?}", ex.name);
}

impl ByteHost for SimByteBus {
    fn send(&mut self, bytes: &[u8]) {
        ByteLink::send(self, bytes).unwrap();
    }

    fn read_n(&mut self, n: usize) -> Vec<u8> {
        let deadline = self.virtual_clock().now() + REPLY_WITHIN;
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        while got.len() < n {
            let want = (n - got.len()).min(buf.len());
            let k = self.recv(&mut buf[..want], deadline).unwrap();
            assert!(k > 0, "virtual deadline passed with only {got:02X?}");
            got.extend_from_slice(&buf[..k]);
        }
        got
    }

    fn quiet(&mut self) -> Vec<u8> {
        let deadline = self.virtual_clock().now() + QUIET_VIRTUAL;
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        loop {
            let k = self.recv(&mut buf, deadline).unwrap();
            if k == 0 {
                return got;
            }
            got.extend_from_slice(&buf[..k]);
        }
    }
}

fn timed_out(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::TimedOut
            | std::io::ErrorKind::WouldBlock
            | std::io::ErrorKind::Interrupted
    )
}

/// Reads everything that arrives until `until` or until `n` bytes.
fn read_until(r: &mut impl Read, n: usize, until: std::time::Instant) -> Vec<u8> {
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    while got.len() < n && std::time::Instant::now() < until {
        let want = (n - got.len()).min(buf.len());
        match r.read(&mut buf[..want]) {
            Ok(0) => panic!("the stream closed after {got:02X?}"),
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) if timed_out(&e) => {}
            Err(e) => panic!("read: {e}"),
        }
    }
    got
}

/// A real stream (the pty's slave end, a TCP client) whose reads time out
/// after a short poll.
struct Stream<S>(S);

impl<S: Read + Write> ByteHost for Stream<S> {
    fn send(&mut self, bytes: &[u8]) {
        self.0.write_all(bytes).unwrap();
        self.0.flush().unwrap();
    }

    fn read_n(&mut self, n: usize) -> Vec<u8> {
        let got = read_until(&mut self.0, n, std::time::Instant::now() + REPLY_WITHIN);
        assert_eq!(got.len(), n, "only {got:02X?} within {REPLY_WITHIN:?}");
        got
    }

    fn quiet(&mut self) -> Vec<u8> {
        read_until(
            &mut self.0,
            usize::MAX,
            std::time::Instant::now() + QUIET_FOR,
        )
    }
}

// ---------------------------------------------------------------- transports

fn over_memory(ex: &Example) {
    let clock = VirtualClock::new();
    let mut bus = SimByteBus::from_line(&clock, line_for(ex));
    run_steps(ex, &mut bus);
    check_after(ex, bus.drives());
}

#[cfg(unix)]
fn over_pty(ex: &Example) {
    use serialport::SerialPort;
    let pty = {
        let _guard = pty_lock();
        serve::open_pty().unwrap()
    };
    let serve::Pty {
        mut master,
        mut slave,
        ..
    } = pty;
    let mut line = line_for(ex);
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    // The server thread owns (and keeps alive) the master end until stop.
    let server = std::thread::spawn(move || {
        let r = serve::serve_pty(&mut line, &mut master, &flag);
        (r, line)
    });
    slave.set_timeout(Duration::from_millis(50)).unwrap();
    let mut host = Stream(slave);
    run_steps(ex, &mut host);
    stop.store(true, Ordering::SeqCst);
    let (r, line) = server.join().unwrap();
    r.unwrap();
    check_after(ex, line.drives());
    drop(host);
}

fn over_tcp(ex: &Example) {
    let listener = serve::bind_loopback(0).unwrap();
    let addr = listener.local_addr().unwrap();
    let mut line = line_for(ex);
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let server = std::thread::spawn(move || {
        let r = serve::serve_tcp(&mut line, &listener, &flag);
        (r, line)
    });
    let client = TcpStream::connect(addr).unwrap();
    client.set_nodelay(true).unwrap();
    client
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut host = Stream(client);
    run_steps(ex, &mut host);
    drop(host);
    stop.store(true, Ordering::SeqCst);
    let (r, line) = server.join().unwrap();
    r.unwrap();
    check_after(ex, line.drives());
}

macro_rules! byte_tests {
    ($($name:ident: $family:expr, $transport:ident;)*) => {
        $(
            #[test]
            fn $name() {
                for ex in examples_of($family) {
                    $transport(&ex);
                }
            }
        )*
    };
}

byte_tests! {
    mc6000_in_memory: Family::Mc6000, over_memory;
    mc6000_over_tcp: Family::Mc6000, over_tcp;
    vf1000_in_memory: Family::Vf1000, over_memory;
    vf1000_over_tcp: Family::Vf1000, over_tcp;
    tmd_in_memory: Family::Tmd, over_memory;
    tmd_over_tcp: Family::Tmd, over_tcp;
}

#[cfg(unix)]
byte_tests! {
    mc6000_over_pty: Family::Mc6000, over_pty;
    vf1000_over_pty: Family::Vf1000, over_pty;
    tmd_over_pty: Family::Tmd, over_pty;
}

#[test]
fn the_table_covers_every_spec_example() {
    let names: Vec<_> = byte_examples().iter().map(|e| e.name).collect();
    for section in ["6.1.1.1", "6.1.1.2", "6.2.2", "8.H b", "8.I", "8.J"] {
        assert!(
            names.iter().any(|n| n.contains(section)),
            "{section} missing from {names:?}"
        );
    }
    // The 8.I read-back's BCC is computed by the 8.G rule: it must agree
    // with the BCC the manual prints for the same text in the 8.I SEND.
    assert_eq!(lecom_bcc(b"1195.2"), 0x13);
}

// ---------------------------------------------------------------- ECS (CAN)

/// One SDO exchange on the simulated ECS bus (nodes 1 and 2): request
/// (COB-ID, data) and the exact response.
type SdoStep = ((u32, [u8; 8]), (u32, [u8; 8]));

/// The exchanges of `ecs_sdo.rs` / `ecs_slcan.rs`: read C5001 (FIX32
/// 3000.0000) from node 1, write C5002 = 1234.5678 to node 2, read it back.
fn ecs_examples() -> Vec<(&'static str, SdoStep)> {
    vec![
        (
            "read C5001 from node 1",
            (
                (0x601, [0x40, 0x76, 0x4C, 0x00, 0, 0, 0, 0]),
                (0x581, [0x43, 0x76, 0x4C, 0x00, 0x80, 0xC3, 0xC9, 0x01]),
            ),
        ),
        (
            "write C5002 = 1234.5678 to node 2",
            (
                (0x602, [0x23, 0x75, 0x4C, 0x00, 0x4E, 0x61, 0xBC, 0x00]),
                (0x582, [0x60, 0x75, 0x4C, 0x00, 0, 0, 0, 0]),
            ),
        ),
        (
            "read C5002 back from node 2",
            (
                (0x602, [0x40, 0x75, 0x4C, 0x00, 0, 0, 0, 0]),
                (0x582, [0x43, 0x75, 0x4C, 0x00, 0x4E, 0x61, 0xBC, 0x00]),
            ),
        ),
    ]
}

fn ecs_drives() -> Vec<Box<dyn FrameDrive>> {
    vec![Box::new(test_drive(1)), Box::new(test_drive(2))]
}

fn check_ecs_after(drives: &[Box<dyn FrameDrive>]) {
    let c5002 = |i: usize| drives[i].state().values[&CodeKey::new(5002)].clone();
    assert_eq!(c5002(1), RawValue::Int(12_345_678), "node 2 written");
    assert_eq!(c5002(0), RawValue::Int(0), "node 1 untouched");
}

#[test]
fn ecs_in_memory() {
    let clock = VirtualClock::new();
    let mut bus = SimCanBus::new(&clock, 500_000, ecs_drives()).unwrap();
    for (name, ((id, data), (want_id, want))) in ecs_examples() {
        bus.send(&CanFrame::new(id, &data).unwrap()).unwrap();
        let deadline = clock.now() + REPLY_WITHIN;
        let got = bus
            .recv(deadline)
            .unwrap()
            .unwrap_or_else(|| panic!("{name}: no answer"));
        assert_eq!((got.id, got.payload()), (want_id, &want[..]), "{name}");
    }
    assert_eq!(bus.recv(clock.now() + QUIET_VIRTUAL).unwrap(), None);
    check_ecs_after(&bus.into_drives());
}

/// `t<id:3><len><data>\r`, upper-case hex, as the adapter prints frames.
fn slcan_text(id: u32, data: &[u8]) -> Vec<u8> {
    let mut s = format!("t{id:03X}{}", data.len());
    for b in data {
        s.push_str(&format!("{b:02X}"));
    }
    s.push('\r');
    s.into_bytes()
}

#[cfg(unix)]
#[test]
fn ecs_over_slcan_pty() {
    let line = FrameLine::new(500_000, ecs_drives()).unwrap();
    let server = {
        let _guard = pty_lock();
        SlcanServer::spawn(line, |_: &SlcanEvent| {}).unwrap()
    };
    let port = serialport::new(server.path(), 115_200)
        .timeout(Duration::from_millis(50))
        .open_native()
        .unwrap();
    let mut host = Stream(port);
    // Close, 500 kbit/s, no FD rate, open: four CRs.
    host.send(b"C\rS6\r\rO\r");
    assert_eq!(host.read_n(4), b"\r\r\r\r");
    for (name, ((id, data), (want_id, want))) in ecs_examples() {
        host.send(&slcan_text(id, &data));
        let mut expected = b"z\r".to_vec();
        expected.extend_from_slice(&slcan_text(want_id, &want));
        assert_eq!(host.read_n(expected.len()), expected, "{name}");
    }
    assert_eq!(host.quiet(), b"", "trailing bytes");
    drop(host);
    let (line, stats) = server.stop().unwrap();
    assert_eq!(stats.frames_from_host, 3);
    assert_eq!(stats.answers, 3);
    check_ecs_after(line.drives());
}
