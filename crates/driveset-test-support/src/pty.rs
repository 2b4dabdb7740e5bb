//! Pseudo-terminal pairs for the transports' tests, created under the
//! process's one pty lock.

use std::time::Duration;

use serialport::{SerialPort, TTYPort};

use crate::io::pty_lock;

/// A pty pair: the master end (kept alive: closing it hangs up the slave;
/// reads time out after 5 s), the slave's path for the link under test to
/// open (exclusively: the slave fd of `pair()` has neither TIOCEXCL nor a
/// flock on it), and that first slave fd, which the test keeps open so
/// that the link closing its own fd does not hang up the line: the master
/// can still read what the link wrote last (the slcan close on drop).
pub fn pty_pair() -> (TTYPort, String, TTYPort) {
    let _guard = pty_lock();
    let (mut master, slave) = TTYPort::pair().expect("create a pty pair");
    let path = slave.name().expect("the slave pty has a path");
    master
        .set_timeout(Duration::from_secs(5))
        .expect("master timeout");
    (master, path, slave)
}
