//! Real-time serving over a real pty pair and TCP loopback, and stopping
//! on the flag. Real time is only used with generous bounds: the exact
//! timing is tested in virtual time elsewhere.

use crate::bus_support as support;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use driveset_sim::bus::ByteLine;
use driveset_sim::log::EventLog;
use driveset_sim::serve;
use driveset_test_support::read_n_within;
use support::{ACK, FakeDrive, telegram};

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
    let pty = {
        let _guard = driveset_test_support::pty_lock();
        serve::open_pty().unwrap()
    };
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
    assert_eq!(
        read_n_within(&mut slave, 2, Duration::from_secs(5)),
        [ACK, b'1']
    );
    // A second telegram on the same session.
    slave.write_all(&telegram(b'1')).unwrap();
    assert_eq!(
        read_n_within(&mut slave, 2, Duration::from_secs(5)),
        [ACK, b'1']
    );
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
    for i in 0..2 {
        let mut client = TcpStream::connect(addr).unwrap();
        client
            .set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        client.write_all(&telegram(b'1')).unwrap();
        assert_eq!(
            read_n_within(&mut client, 2, Duration::from_secs(5)),
            [ACK, b'1']
        );
        drop(client);
        // The next client comes once this one is gone (else it would wait).
        wait_for_kinds(&log, 2 * (i + 1));
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

/// The event kinds (`fault`) of the log's bus events so far.
fn kinds(log: &EventLog) -> Vec<String> {
    log.events().into_iter().filter_map(|e| e.fault).collect()
}

/// Wait (hang guard 10 s) until the log holds `n` bus events.
fn wait_for_kinds(log: &EventLog, n: usize) -> Vec<String> {
    let give_up = std::time::Instant::now() + Duration::from_secs(10);
    loop {
        let k = kinds(log);
        if k.len() >= n {
            return k;
        }
        assert!(std::time::Instant::now() < give_up, "only {k:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_second_tcp_client_waits_for_the_first_then_is_served_and_idle_ones_are_dropped() {
    let log = EventLog::memory();
    let mut line = line(&log);
    let listener = serve::bind_loopback(0).unwrap();
    let addr = listener.local_addr().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let reported = Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let sink = Arc::clone(&reported);
    let server = std::thread::spawn(move || {
        let options = serve::TcpServeOptions {
            idle_timeout: Some(Duration::from_millis(1000)),
        };
        let r = serve::serve_tcp_with(&mut line, &listener, &flag, &options, &mut |e| {
            sink.lock()
                .unwrap()
                .push(e.fault.clone().unwrap_or_default())
        });
        (r, line)
    });
    let connect = || {
        let c = TcpStream::connect(addr).unwrap();
        c.set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        c
    };
    let mut first = connect();
    first.write_all(&telegram(b'1')).unwrap();
    assert_eq!(
        read_n_within(&mut first, 2, Duration::from_secs(5)),
        [ACK, b'1']
    );
    let first_addr = first.local_addr().unwrap();
    // The second connects while the first holds the line: it waits.
    let mut second = connect();
    let second_addr = second.local_addr().unwrap();
    second.write_all(&telegram(b'1')).unwrap();
    let k = wait_for_kinds(&log, 2);
    assert_eq!(k, ["connect", "wait"]);
    // Nothing for the second while the first is connected and busy.
    first.write_all(&telegram(b'1')).unwrap();
    assert_eq!(
        read_n_within(&mut first, 2, Duration::from_secs(5)),
        [ACK, b'1']
    );
    let mut none = [0u8; 4];
    assert!(matches!(
        second.read(&mut none),
        Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock)
    ));
    // The first leaves; the second's telegram (sent while it waited) is
    // served.
    drop(first);
    assert_eq!(
        read_n_within(&mut second, 2, Duration::from_secs(5)),
        [ACK, b'1']
    );
    // Then it says nothing: dropped after the idle timeout.
    let k = wait_for_kinds(&log, 5);
    assert_eq!(k, ["connect", "wait", "disconnect", "connect", "idle"]);
    let mut rest = Vec::new();
    second
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    assert_eq!(second.read_to_end(&mut rest).unwrap(), 0);
    stop.store(true, Ordering::SeqCst);
    let (r, line) = server.join().unwrap();
    r.unwrap();
    assert_eq!(line.telegrams(), 3);
    let details: Vec<String> = log.events().into_iter().filter_map(|e| e.detail).collect();
    assert_eq!(details[0], format!("host connected from {first_addr}"));
    assert_eq!(
        details[1],
        format!("host {second_addr} waits: the line is in use by {first_addr}")
    );
    assert_eq!(
        details[2],
        format!("host {first_addr} closed the connection")
    );
    assert!(
        details[3].starts_with(&format!("host connected from {second_addr} (waited ")),
        "{}",
        details[3]
    );
    assert_eq!(
        details[4],
        format!("host {second_addr} dropped: sent nothing for 1000 ms (idle timeout)")
    );
    assert_eq!(*reported.lock().unwrap(), kinds(&log));
}

#[test]
fn binding_a_taken_port_says_what_to_do() {
    let first = serve::bind_loopback(0).unwrap();
    let port = first.local_addr().unwrap().port();
    let err = serve::bind_loopback(port).unwrap_err();
    assert!(err.to_string().contains("pick another --tcp port"), "{err}");
}
