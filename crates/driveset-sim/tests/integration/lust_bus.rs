//! The simulated LUSTBUS drives on the simulated line (`bus::ByteLine`):
//! an MC6000 and a VF1000 at their own addresses answer only their own
//! telegrams, with wire timing.

use std::time::Duration;

use driveset_link::Instant;
use driveset_sim::bus::ByteLine;
use driveset_sim::drive::{ByteDrive, ReactionTime};
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::vf1000::Vf1000;

use crate::lust_support::{enq, val};

fn ask(line: &mut ByteLine, t: &mut Instant, bytes: &[u8]) -> Vec<u8> {
    let end = line.host_send_paced(*t, bytes);
    let until = end + Duration::from_millis(100);
    line.advance(until);
    let mut buf = [0u8; 64];
    let n = line.take_arrived(until, &mut buf);
    *t = until;
    buf[..n].to_vec()
}

#[test]
fn mc_and_vf_share_a_line() {
    let fixed = ReactionTime::fixed(Duration::from_millis(2));
    let drives: Vec<Box<dyn ByteDrive>> = vec![
        Box::new(Mc6000::new(LustOptions::new(1).reaction(fixed)).unwrap()),
        Box::new(Vf1000::new(LustOptions::new(2).reaction(fixed)).unwrap()),
    ];
    let mut line = ByteLine::new(9600, drives).unwrap();
    let mut t = Instant::ZERO;
    assert_eq!(ask(&mut line, &mut t, &enq(1, 85)), val(1, 85, "01"));
    assert_eq!(ask(&mut line, &mut t, &enq(2, 85)), val(2, 85, "0001"));
    assert_eq!(ask(&mut line, &mut t, &enq(3, 85)), b"");
    // 85 via the MC CODE; 91-TYPE via the compatible CODE on both families.
    assert_eq!(ask(&mut line, &mut t, &enq(1, 20085)), val(1, 20085, "00"));
    assert!(ask(&mut line, &mut t, &enq(2, 91)).starts_with(b"B\x0200091="));
}
