//! Reads from sockets, ptys and byte links that end: a byte count, a
//! deadline or the peer closing; and the one pty lock of a test process.

use std::io::{ErrorKind, Read};
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

/// Tests run in parallel threads of one binary: ptys are created one at a
/// time, under this lock, by every module of that binary.
static PTY_LOCK: Mutex<()> = Mutex::new(());

/// Hold while creating a pty (`TTYPort::pair`, `serve::open_pty`,
/// `SlcanServer::spawn`); a test that panicked while holding it does not
/// poison it for the others.
pub fn pty_lock() -> MutexGuard<'static, ()> {
    PTY_LOCK.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Read exactly `n` bytes (`read_exact`; the reader's own timeout bounds
/// it).
pub fn read_exact_n(r: &mut impl Read, n: usize) -> Vec<u8> {
    let mut buf = vec![0; n];
    r.read_exact(&mut buf)
        .unwrap_or_else(|e| panic!("reading {n} bytes: {e}"));
    buf
}

/// Whether a read error only means "nothing yet": the reader's timeout
/// passed, or a signal interrupted it.
fn nothing_yet(kind: ErrorKind) -> bool {
    matches!(
        kind,
        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
    )
}

/// Read until `n` bytes arrived, the peer closed or `within` passed; what
/// arrived by then (the caller asserts on it).
pub fn read_until(r: &mut impl Read, n: usize, within: Duration) -> Vec<u8> {
    let give_up = Instant::now() + within;
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    while got.len() < n && Instant::now() < give_up {
        match r.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) if nothing_yet(e.kind()) => {}
            Err(e) => panic!("read: {e}"),
        }
    }
    got
}

/// Read exactly `n` bytes; panics naming what arrived when the peer closes
/// first or `within` passes.
pub fn read_n_within(r: &mut impl Read, n: usize, within: Duration) -> Vec<u8> {
    let give_up = Instant::now() + within;
    let mut got = Vec::new();
    let mut buf = [0u8; 16];
    while got.len() < n {
        assert!(
            Instant::now() < give_up,
            "only got {got:?} of {n} bytes within {within:?}"
        );
        match r.read(&mut buf[..(n - got.len()).min(16)]) {
            Ok(0) => panic!("closed after {got:?}"),
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(e) if nothing_yet(e.kind()) => {}
            Err(e) => panic!("read: {e}"),
        }
    }
    got
}

/// Receive on a byte link until `n` bytes arrived or it went quiet (5 s at
/// most).
#[cfg(feature = "link")]
pub fn recv_n(link: &mut dyn driveset_link::ByteLink, n: usize) -> Vec<u8> {
    use driveset_link::{Clock, RealClock};
    let deadline = RealClock.deadline_in(Duration::from_secs(5));
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    while got.len() < n {
        let k = link.recv(&mut buf, deadline).expect("recv");
        if k == 0 {
            break;
        }
        got.extend_from_slice(&buf[..k]);
    }
    got
}
