//! Real-time serving over a real pty pair and TCP loopback, and stopping
//! on the flag. Real time is only used with generous bounds: the exact
//! timing is tested in virtual time elsewhere.

#[path = "bus_support.rs"]
mod support;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use driveset_sim::bus::ByteLine;
use driveset_sim::log::EventLog;
use driveset_sim::serve;
use support::{ACK, FakeDrive, telegram};

/// Read exactly `n` bytes or fail after `within`.
fn read_n(r: &mut impl Read, n: usize, within: Duration) -> Vec<u8> {
    let give_up = std::time::Instant::now() + within;
    let mut got = Vec::new();
    let mut buf = [0u8; 16];
    while got.len() < n {
        assert!(std::time::Instant::now() < give_up, "only got {got:?}");
        match r.read(&mut buf) {
            Ok(0) => panic!("closed after {got:?}"),
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) => {}
            Err(e) => panic!("read: {e}"),
        }
    }
    got
}

fn line(log: &EventLog) -> ByteLine {
    let (drive, _) = FakeDrive::boxed(1, Duration::from_millis(1));
    ByteLine::new(9600, vec![drive])
        .unwrap()
        .with_log(log.clone())
}

#[cfg(unix)]
#[test]
fn serves_a_fake_drive_on_a_pty() {
    use serialport::SerialPort;
    let log = EventLog::memory();
    let mut line = line(&log);
    let pty = serve::open_pty().unwrap();
    assert!(pty.path.starts_with("/dev/"), "{}", pty.path);
    let serve::Pty {
        mut master,
        mut slave,
        ..
    } = pty;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let server = std::thread::spawn(move || {
        let r = serve::serve_pty(&mut line, &mut master, &flag);
        (r, line)
    });
    slave.set_timeout(Duration::from_millis(100)).unwrap();
    // Parity bit set as a 8N1 pty may deliver it: the server masks it.
    let mut t = telegram(b'1');
    t[0] |= 0x80;
    slave.write_all(&t).unwrap();
    assert_eq!(read_n(&mut slave, 2, Duration::from_secs(5)), [ACK, b'1']);
    // A second telegram on the same session.
    slave.write_all(&telegram(b'1')).unwrap();
    assert_eq!(read_n(&mut slave, 2, Duration::from_secs(5)), [ACK, b'1']);
    stop.store(true, Ordering::SeqCst);
    let (r, line) = server.join().unwrap();
    r.unwrap();
    assert_eq!(line.telegrams(), 2);
    assert_eq!(line.state_dump()["drives"][0]["address"], 1);
    let lines = log.lines();
    assert_eq!(lines.len(), 4, "{lines:?}");
    assert!(lines[1].contains("\"dir\":\"drive\""));
}

#[test]
fn serves_tcp_clients_one_after_the_other_and_stops_promptly() {
    let log = EventLog::memory();
    let mut line = line(&log);
    let listener = serve::bind_loopback(0).unwrap();
    let addr = listener.local_addr().unwrap();
    assert!(addr.ip().is_loopback());
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let server = std::thread::spawn(move || {
        let r = serve::serve_tcp(&mut line, &listener, &flag);
        (r, line)
    });
    for _ in 0..2 {
        let mut client = TcpStream::connect(addr).unwrap();
        client
            .set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        client.write_all(&telegram(b'1')).unwrap();
        assert_eq!(read_n(&mut client, 2, Duration::from_secs(5)), [ACK, b'1']);
    }
    // Stop while a client is connected and idle.
    let _idle = TcpStream::connect(addr).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    let asked = std::time::Instant::now();
    stop.store(true, Ordering::SeqCst);
    let (r, line) = server.join().unwrap();
    r.unwrap();
    // The loop looks at the flag every 50 ms; allow for a loaded machine.
    assert!(
        asked.elapsed() < Duration::from_secs(2),
        "{:?}",
        asked.elapsed()
    );
    assert_eq!(line.telegrams(), 2);
    let kinds: Vec<String> = log.events().into_iter().filter_map(|e| e.fault).collect();
    assert_eq!(
        kinds,
        [
            "connect",
            "disconnect",
            "connect",
            "disconnect",
            "connect",
            "disconnect"
        ]
    );
    assert_eq!(line.into_drives().len(), 1);
}

#[test]
fn binding_a_taken_port_says_what_to_do() {
    let first = serve::bind_loopback(0).unwrap();
    let port = first.local_addr().unwrap().port();
    let err = serve::bind_loopback(port).unwrap_err();
    assert!(err.to_string().contains("pick another --tcp port"), "{err}");
}
