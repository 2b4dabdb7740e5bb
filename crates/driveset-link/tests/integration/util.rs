//! Helpers shared by the link crate's integration-test modules.

use std::time::Duration;

use driveset_link::{ByteLink, Clock, RealClock};

/// Receive on a byte link until `n` bytes arrived (5 s at most).
pub fn recv_n(link: &mut dyn ByteLink, n: usize) -> Vec<u8> {
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
