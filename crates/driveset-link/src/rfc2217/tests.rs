//! Tests of the RFC 2217 link: the telnet codec's exact bytes, and whole
//! negotiations against a fake server on loopback.

use std::net::TcpListener;
use std::thread;

use super::*;

#[test]
fn parser_splits_data_commands_and_subnegotiations() {
    let mut t = Telnet::new();
    let mut ev = Vec::new();
    // Split at every awkward place: inside IAC IAC, inside SB.
    let stream: &[u8] = &[
        b'A', IAC, IAC, b'B', IAC, WILL, 1, IAC, SB, 44, 107, IAC, IAC, 0x30, IAC, SE, IAC, 0xF1,
        b'C',
    ];
    for chunk in stream.chunks(3) {
        t.feed(chunk, &mut ev);
    }
    assert_eq!(
        ev,
        vec![
            TelnetEvent::Data(b'A'),
            TelnetEvent::Data(0xFF),
            TelnetEvent::Data(b'B'),
            TelnetEvent::Negotiate(WILL, 1),
            TelnetEvent::Sub(vec![44, 107, 0xFF, 0x30]),
            TelnetEvent::Command(0xF1),
            TelnetEvent::Data(b'C'),
        ]
    );
}

#[test]
fn options_are_answered_once() {
    let mut t = Telnet::new();
    assert_eq!(t.opening(), vec![IAC, WILL, 0, IAC, DO, 0, IAC, WILL, 44]);
    // Acknowledgements of our requests need no answer.
    assert_eq!(t.answer(DO, BINARY), Vec::<u8>::new());
    assert_eq!(t.answer(DO, COM_PORT_OPTION), Vec::<u8>::new());
    assert_eq!(t.answer(WILL, BINARY), Vec::<u8>::new());
    // The server offers: SGA yes, ECHO no, COM-PORT yes; once each.
    assert_eq!(t.answer(WILL, SGA), vec![IAC, DO, SGA]);
    assert_eq!(t.answer(WILL, SGA), Vec::<u8>::new());
    assert_eq!(t.answer(WILL, 1), vec![IAC, DONT, 1]);
    assert_eq!(t.answer(WILL, 1), Vec::<u8>::new());
    assert_eq!(t.answer(WILL, 44), vec![IAC, DO, 44]);
    // An option we do not do (TERMINAL-TYPE).
    assert_eq!(t.answer(DO, 24), vec![IAC, WONT, 24]);
    assert_eq!(t.answer(DO, 24), Vec::<u8>::new());
    // Withdrawing an enabled option is acknowledged.
    assert_eq!(t.answer(DONT, BINARY), vec![IAC, WONT, BINARY]);
    assert_eq!(t.answer(WONT, 24), Vec::<u8>::new());
}

#[test]
fn settings_and_escaping_bytes() {
    assert_eq!(
        com_port_command(SET_BAUDRATE, &57600u32.to_be_bytes()),
        vec![IAC, SB, 44, 1, 0x00, 0x00, 0xE1, 0x00, IAC, SE]
    );
    // 16777215 = 0x00FFFFFF: every IAC in the value doubled.
    assert_eq!(
        com_port_command(SET_BAUDRATE, &0x00FF_FFFFu32.to_be_bytes()),
        vec![IAC, SB, 44, 1, 0, IAC, IAC, IAC, IAC, IAC, IAC, IAC, SE]
    );
    assert_eq!(escape(&[1, 0xFF, 2]), vec![1, 0xFF, 0xFF, 2]);
    assert_eq!(setting_value(SET_PARITY, &[1]), "NONE");
    assert_eq!(setting_value(SET_BAUDRATE, &9600u32.to_be_bytes()), "9600");
}

/// Reads exactly `n` bytes from the fake server's connection.
fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
    let mut buf = vec![0u8; n];
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .expect("timeout");
    s.read_exact(&mut buf).expect("read from the client");
    buf
}

/// A fake server: `script` runs on the accepted connection.
fn fake_server(script: impl FnOnce(TcpStream) + Send + 'static) -> (u16, thread::JoinHandle<()>) {
    let l = TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = l.local_addr().expect("addr").port();
    let h = thread::spawn(move || {
        let (s, _) = l.accept().expect("accept");
        script(s);
    });
    (port, h)
}

const OPENING: [u8; 9] = [IAC, WILL, 0, IAC, DO, 0, IAC, WILL, 44];

fn settings_bytes(baud: u32) -> Vec<u8> {
    let mut v = Vec::new();
    for (c, val) in line_settings(baud) {
        v.extend(com_port_command(c, &val));
    }
    v
}

fn confirm(baud: u32, parity: u8) -> Vec<u8> {
    let mut v = Vec::new();
    v.extend(com_port_command(101, &baud.to_be_bytes()));
    v.extend(com_port_command(102, &[7]));
    v.extend(com_port_command(103, &[parity]));
    v.extend(com_port_command(104, &[1]));
    v
}

/// The fake server's side of a plain opening: driveset's opening bytes,
/// `DO COM-PORT-OPTION`, then the four 7E1 settings at `baud`.
fn agree_and_expect_settings(s: &mut TcpStream, baud: u32) {
    assert_eq!(read_n(s, 9), OPENING);
    s.write_all(&[IAC, DO, 44]).expect("write");
    let want = settings_bytes(baud);
    assert_eq!(read_n(s, want.len()), want);
}

#[test]
fn negotiates_7e1_and_moves_data_with_exact_bytes() {
    let (port, h) = fake_server(|mut s| {
        assert_eq!(read_n(&mut s, 9), OPENING);
        // Like pyserial's PortManager: WILL ECHO, WILL SGA, DO BINARY,
        // WILL COM-PORT, then DO COM-PORT.
        s.write_all(&[
            IAC, WILL, 1, IAC, WILL, 3, IAC, DO, 0, IAC, WILL, 44, IAC, DO, 44,
        ])
        .expect("write");
        // The client's answers: DONT ECHO, DO SGA, DO COM-PORT.
        assert_eq!(
            read_n(&mut s, 9),
            vec![IAC, DONT, 1, IAC, DO, 3, IAC, DO, 44]
        );
        let want: Vec<u8> = vec![
            IAC, SB, 44, 1, 0x00, 0x00, 0x4B, 0x00, IAC, SE, // 19200 baud
            IAC, SB, 44, 2, 7, IAC, SE, // 7 data bits
            IAC, SB, 44, 3, 3, IAC, SE, // even parity
            IAC, SB, 44, 4, 1, IAC, SE, // 1 stop bit
        ];
        assert_eq!(settings_bytes(19200), want);
        assert_eq!(read_n(&mut s, want.len()), want);
        // Confirmation, a modem-state notification in between.
        let mut c = confirm(19200, PARITY_EVEN);
        c.extend_from_slice(&[IAC, SB, 44, 107, 0x30, IAC, SE]);
        s.write_all(&c).expect("write");
        // Data: the request, then the reply with a doubled IAC and a
        // notification inside it.
        assert_eq!(read_n(&mut s, 9), b"\x04AA00091\x05");
        s.write_all(&[0x02, b'1', IAC, SB, 44, 107, 0, IAC, SE, IAC, IAC, 0x03])
            .expect("write");
        // discard_input: PURGE-DATA receive buffer.
        assert_eq!(read_n(&mut s, 7), vec![IAC, SB, 44, 12, 1, IAC, SE]);
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
        assert_eq!(rest, Vec::<u8>::new());
    });
    let mut link =
        Rfc2217Link::connect("127.0.0.1", port, 19200, Duration::from_secs(10)).expect("open");
    assert_eq!(link.port(), format!("rfc2217://127.0.0.1:{port}"));
    assert_eq!(link.baud(), 19200);
    link.send(b"\x04AA00091\x05").expect("send");
    let mut got = Vec::new();
    let mut buf = [0u8; 16];
    while got.len() < 4 {
        let n = link
            .recv(&mut buf, RealClock.deadline_in(Duration::from_secs(10)))
            .expect("recv");
        assert!(n > 0, "the reply did not come");
        got.extend_from_slice(&buf[..n]);
    }
    assert_eq!(got, vec![0x02, b'1', 0xFF, 0x03]);
    link.discard_input().expect("discard");
    drop(link);
    h.join().expect("server");
}

#[test]
fn set_baud_sends_set_baudrate_and_needs_the_servers_confirmation() {
    let (port, h) = fake_server(|mut s| {
        agree_and_expect_settings(&mut s, 9600);
        s.write_all(&confirm(9600, PARITY_EVEN)).expect("write");
        // set_baud(57600): SET-BAUDRATE 0x0000E100; confirmed, with a
        // data byte before the confirmation (kept for recv)
        assert_eq!(
            read_n(&mut s, 10),
            vec![IAC, SB, 44, 1, 0x00, 0x00, 0xE1, 0x00, IAC, SE]
        );
        let mut c = vec![b'x'];
        c.extend(com_port_command(101, &57600u32.to_be_bytes()));
        s.write_all(&c).expect("write");
        // set_baud(38400): the server answers 19200
        assert_eq!(
            read_n(&mut s, 10),
            vec![IAC, SB, 44, 1, 0x00, 0x00, 0x96, 0x00, IAC, SE]
        );
        s.write_all(&com_port_command(101, &19200u32.to_be_bytes()))
            .expect("write");
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    });
    let mut link =
        Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_secs(10)).expect("open");
    link.set_baud(57600).expect("57600");
    assert_eq!(link.baud(), 57600);
    let mut buf = [0u8; 4];
    let n = link
        .recv(&mut buf, RealClock.deadline_in(Duration::from_secs(5)))
        .expect("recv");
    assert_eq!(&buf[..n], b"x");
    let err = link.set_baud(38400).expect_err("other rate");
    assert_eq!(
        err.to_string(),
        format!(
            "rfc2217://127.0.0.1:{port}: the server set the baud rate to 19200 instead of 38400: its serial port cannot run at that rate; pick a rate it supports"
        )
    );
    assert_eq!(link.baud(), 57600);
    drop(link);
    h.join().expect("server");
}

#[test]
fn a_server_that_sets_other_parity_is_an_error_naming_both() {
    let (port, h) = fake_server(|mut s| {
        agree_and_expect_settings(&mut s, 9600);
        s.write_all(&confirm(9600, 1)).expect("write");
        let _ = read_n(&mut s, 0);
    });
    let err = Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_secs(10))
        .expect_err("parity NONE");
    assert_eq!(
        err.to_string(),
        format!(
            "rfc2217://127.0.0.1:{port}: the server set the parity to NONE instead of EVEN: its serial port cannot run a 7E1 line at 9600 baud; check the server's port or pick a rate it supports"
        )
    );
    h.join().expect("server");
}

#[test]
fn a_server_refusing_com_port_option_is_an_error() {
    let (port, h) = fake_server(|mut s| {
        assert_eq!(read_n(&mut s, 9), OPENING);
        s.write_all(&[IAC, DONT, 44]).expect("write");
        // The client says nothing more and closes.
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
        assert_eq!(rest, Vec::<u8>::new());
    });
    let err = Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_secs(10))
        .expect_err("refused");
    assert_eq!(
        err.to_string(),
        format!(
            "rfc2217://127.0.0.1:{port}: the server refused the telnet COM-PORT-OPTION (DONT): it does not let driveset set the line; use tcp://127.0.0.1:{port} and set 7E1 at 9600 baud on the server"
        )
    );
    h.join().expect("server");
}

#[test]
fn a_raw_server_times_out_with_advice() {
    let (port, h) = fake_server(|mut s| {
        assert_eq!(read_n(&mut s, 9), OPENING);
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    });
    let err = Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_millis(200))
        .expect_err("silent");
    assert_eq!(
        err.to_string(),
        format!(
            "rfc2217://127.0.0.1:{port}: the server did not accept the telnet COM-PORT-OPTION (RFC 2217) within 200ms; it may be a raw TCP server: use tcp://127.0.0.1:{port} and set 7E1 and the rate on the server"
        )
    );
    h.join().expect("server");
}
