//! TcpLink against a loopback listener standing in for a serial device
//! server in raw TCP mode.

use std::io::{Read, Write};
use std::net::TcpListener;
use std::thread;
use std::time::Duration;

use driveset_link::tcp::TcpLink;
use driveset_link::{
    ByteLink, Clock, Instant, Link, LinkError, OpenOptions, PortSpec, RealClock, open,
};

use driveset_test_support::{read_exact_n, recv_n};

const CONNECT: Duration = Duration::from_secs(5);

/// How long the server side waits for what it reads.
const SERVER_READ: Duration = Duration::from_secs(5);

fn listener() -> (TcpListener, u16) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind a loopback port");
    let port = listener.local_addr().expect("local addr").port();
    (listener, port)
}

#[test]
fn sends_and_receives_exact_bytes() {
    let (listener, port) = listener();
    let server = thread::spawn(move || {
        let (mut stream, _) = listener.accept().expect("accept");
        stream.set_read_timeout(Some(SERVER_READ)).expect("timeout");
        assert!(stream.nodelay().is_ok());
        let request = read_exact_n(&mut stream, 10);
        stream.write_all(b"\x06").expect("write ack");
        stream
            .write_all(b"\x0211+12.5\x03\x1b")
            .expect("write reply");
        request
    });
    let mut link = TcpLink::connect("127.0.0.1", port, 19200, CONNECT).expect("connect");
    assert_eq!(link.port(), format!("tcp://127.0.0.1:{port}"));
    assert_eq!(link.baud(), 19200);
    link.send(b"\x0400112TYP\x05").expect("send");
    link.flush().expect("flush");
    let request = server.join().expect("server thread");
    assert_eq!(request, b"\x0400112TYP\x05");
    assert_eq!(recv_n(&mut link, 10), b"\x06\x0211+12.5\x03\x1b");
}

#[test]
fn read_deadline_expiry_returns_nothing() {
    let (listener, port) = listener();
    let server = thread::spawn(move || {
        let (mut stream, _) = listener.accept().expect("accept");
        // Stay connected and silent until the client is done.
        let mut buf = [0u8; 1];
        let _ = stream.read(&mut buf);
    });
    let mut link = TcpLink::connect("localhost", port, 9600, CONNECT).expect("connect");
    let mut buf = [0u8; 8];
    let deadline = RealClock.deadline_in(Duration::from_millis(30));
    assert_eq!(link.recv(&mut buf, deadline).expect("recv"), 0);
    assert!(RealClock.now() >= deadline);
    // A deadline already past polls without waiting.
    assert_eq!(link.recv(&mut buf, Instant::ZERO).expect("poll"), 0);
    link.discard_input().expect("discard");
    link.send(b"x").expect("send");
    server.join().expect("server thread");
}

#[test]
fn discard_drops_pending_input() {
    let (listener, port) = listener();
    let server = thread::spawn(move || {
        let (mut stream, _) = listener.accept().expect("accept");
        stream.set_read_timeout(Some(SERVER_READ)).expect("timeout");
        stream.write_all(b"stale").expect("write");
        // Wait for the client's go, then send the fresh reply.
        let go = read_exact_n(&mut stream, 1);
        stream.write_all(b"fresh").expect("write");
        go
    });
    let mut link = TcpLink::connect("127.0.0.1", port, 9600, CONNECT).expect("connect");
    // Make sure the stale bytes are here before discarding them.
    let mut first = [0u8; 1];
    let deadline = RealClock.deadline_in(Duration::from_secs(5));
    assert_eq!(link.recv(&mut first, deadline).expect("recv"), 1);
    assert_eq!(first[0], b's');
    // The other 4 stale bytes may still be in flight: wait for them.
    let mut rest = Vec::new();
    while rest.len() < 4 {
        let mut buf = [0u8; 4];
        let k = link
            .recv(&mut buf[..4 - rest.len()], deadline)
            .expect("recv");
        assert!(k > 0, "stale bytes arrive");
        rest.extend_from_slice(&buf[..k]);
    }
    assert_eq!(rest, b"tale");
    link.discard_input().expect("discard");
    link.send(b"g").expect("send");
    assert_eq!(recv_n(&mut link, 5), b"fresh");
    assert_eq!(server.join().expect("server"), b"g");
}

#[test]
fn connection_refused_is_a_typed_error() {
    let (listener, port) = listener();
    drop(listener); // nothing listens there now
    match TcpLink::connect("127.0.0.1", port, 9600, CONNECT) {
        Err(LinkError::ConnectionRefused { port: name, addr }) => {
            assert_eq!(name, format!("tcp://127.0.0.1:{port}"));
            assert_eq!(addr, format!("127.0.0.1:{port}"));
        }
        other => panic!("expected ConnectionRefused, got {other:?}"),
    }
}

#[test]
fn closed_by_the_server_is_a_typed_error() {
    let (listener, port) = listener();
    let server = thread::spawn(move || {
        let (stream, _) = listener.accept().expect("accept");
        drop(stream);
    });
    let mut link = TcpLink::connect("127.0.0.1", port, 9600, CONNECT).expect("connect");
    server.join().expect("server");
    let mut buf = [0u8; 4];
    let deadline = RealClock.deadline_in(Duration::from_secs(5));
    match link.recv(&mut buf, deadline) {
        Err(LinkError::ConnectionClosed { .. }) | Err(LinkError::ConnectionReset { .. }) => {}
        other => panic!("expected ConnectionClosed, got {other:?}"),
    }
}

#[test]
fn bad_input_is_refused_before_the_wire() {
    match TcpLink::connect("127.0.0.1", 1, 14400, CONNECT) {
        Err(LinkError::UnsupportedBaud { baud: 14400, .. }) => {}
        other => panic!("expected UnsupportedBaud, got {other:?}"),
    }
    match TcpLink::connect("no-such-host.invalid", 4001, 9600, CONNECT) {
        Err(LinkError::Resolve { host, .. }) => assert_eq!(host, "no-such-host.invalid"),
        other => panic!("expected Resolve, got {other:?}"),
    }
    let (listener, port) = listener();
    let server = thread::spawn(move || listener.accept().map(|_| ()));
    let mut link = TcpLink::connect("127.0.0.1", port, 9600, CONNECT).expect("connect");
    match link.send(b"A\x80") {
        Err(LinkError::NotSevenBit {
            offset: 1,
            byte: 0x80,
            ..
        }) => {}
        other => panic!("expected NotSevenBit, got {other:?}"),
    }
    let _ = server.join();
}

#[test]
fn open_from_a_port_string() {
    let (listener, port) = listener();
    let server = thread::spawn(move || {
        let (mut stream, _) = listener.accept().expect("accept");
        stream.set_read_timeout(Some(SERVER_READ)).expect("timeout");
        read_exact_n(&mut stream, 3)
    });
    let spec = PortSpec::parse(&format!("tcp://127.0.0.1:{port}?baud=38400")).unwrap();
    let Link::Bytes(mut link) = open(&spec, &OpenOptions::default()).expect("open") else {
        panic!("tcp:// opens a byte link");
    };
    assert_eq!(link.baud(), 38400);
    link.send(b"abc").expect("send");
    assert_eq!(server.join().expect("server"), b"abc");

    let sim = PortSpec::parse("sim://lust-vf1000?addresses=1").unwrap();
    let err = open(&sim, &OpenOptions::default()).unwrap_err();
    assert!(matches!(err, LinkError::SimPort { .. }));
    assert_eq!(
        err.to_string(),
        "sim://lust-vf1000?addresses=1: open sim:// ports through the simulator (driveset-sim), not driveset-link"
    );
}

/// The bus id names the address connected to, not the host as spelled:
/// `tcp://127.0.0.1:P` and `tcp://localhost:P` are one bus (journals bound
/// to their drive, docs/journals.md "One name per drive").
#[test]
fn bus_id_is_the_same_for_every_spelling_of_the_host() {
    let (listener, port) = listener();
    let server = thread::spawn(move || {
        let a = listener.accept().expect("accept 1");
        let b = listener.accept().expect("accept 2");
        (a, b)
    });
    let by_ip = TcpLink::connect("127.0.0.1", port, 9600, CONNECT).expect("connect by ip");
    let by_name = TcpLink::connect("localhost", port, 9600, CONNECT).expect("connect by name");
    assert_eq!(by_ip.port(), format!("tcp://127.0.0.1:{port}"));
    assert_eq!(by_name.port(), format!("tcp://localhost:{port}"));
    assert_eq!(by_ip.bus_id(), format!("tcp:127.0.0.1:{port}"));
    assert_eq!(by_name.bus_id(), by_ip.bus_id());
    drop(server.join().expect("server"));
}

#[test]
fn a_raw_tcp_link_cannot_change_its_rate_and_says_to_use_rfc2217() {
    let (listener, port) = listener();
    let h = thread::spawn(move || {
        let _ = listener.accept().expect("accept");
    });
    let mut link = TcpLink::connect("127.0.0.1", port, 9600, CONNECT).expect("connect");
    let err = link.set_baud(57600).expect_err("raw tcp");
    assert_eq!(
        err.to_string(),
        format!(
            "tcp://127.0.0.1:{port}: a raw tcp:// device server keeps the line rate it is configured with, so driveset cannot switch it to 57600 baud; use rfc2217://127.0.0.1:{port} so driveset can set the device server's rate"
        )
    );
    assert_eq!(link.baud(), 9600);
    drop(link);
    h.join().expect("server");
}
