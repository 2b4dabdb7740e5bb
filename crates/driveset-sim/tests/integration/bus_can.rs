//! SimCanBus: frame timing from the proto crate's bit counts, arbitration
//! by time then identifier, CAN faults.

use crate::bus_support as support;

use std::time::Duration;

use driveset_link::mem::{bits_time, can_frame_time};
use driveset_link::{CanFrame, Clock, FrameLink, Instant, VirtualClock};
use driveset_sim::can_bus::{ERROR_FRAME_BITS, SimCanBus, candump};
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::EventLog;
use support::FakeNode;

const MS: Duration = Duration::from_millis(1);
const RATE: u32 = 500_000;

fn sdo(id: u32) -> CanFrame {
    CanFrame::new(id, &[0x40, 0x18, 0x10, 0x00, 0, 0, 0, 0]).unwrap()
}

#[test]
fn request_and_answer_at_exact_instants() {
    let clock = VirtualClock::new();
    let (node, h) = FakeNode::boxed(1, MS);
    let mut bus = SimCanBus::new(&clock, RATE, vec![node]).unwrap();
    let req = sdo(0x601);
    let ft = can_frame_time(&req, RATE).unwrap();
    bus.send(&req).unwrap();
    assert_eq!(clock.now(), Instant::ZERO + ft);
    assert_eq!(h.seen.lock().unwrap()[0].0, Instant::ZERO + ft);
    let got = bus.recv(clock.deadline_in(10 * MS)).unwrap().unwrap();
    assert_eq!(got.id, 0x581);
    assert_eq!(got.payload(), req.payload());
    let answer_time = can_frame_time(&got, RATE).unwrap();
    assert_eq!(clock.now(), Instant::ZERO + ft + MS + answer_time);
    // Nothing more: clock to the deadline.
    let deadline = clock.deadline_in(5 * MS);
    assert_eq!(bus.recv(deadline).unwrap(), None);
    assert_eq!(clock.now(), deadline);
}

#[test]
fn answers_ready_together_go_lowest_identifier_first() {
    let clock = VirtualClock::new();
    let (n5, _) = FakeNode::boxed(5, MS);
    let (n2, _) = FakeNode::boxed(2, MS);
    let mut bus = SimCanBus::new(&clock, RATE, vec![n5, n2]).unwrap();
    let req = CanFrame::new(0, &[1, 2]).unwrap();
    bus.send(&req).unwrap();
    let end = clock.now();
    let a = bus.recv(clock.deadline_in(10 * MS)).unwrap().unwrap();
    let t_a = clock.now();
    let b = bus.recv(clock.deadline_in(10 * MS)).unwrap().unwrap();
    let t_b = clock.now();
    assert_eq!((a.id, b.id), (0x582, 0x585));
    let fa = can_frame_time(&a, RATE).unwrap();
    let fb = can_frame_time(&b, RATE).unwrap();
    assert_eq!(t_a, end + MS + fa);
    // The loser waits for the bus and goes right after.
    assert_eq!(t_b, t_a + fb);
}

#[test]
fn an_earlier_answer_wins_whatever_its_identifier() {
    let clock = VirtualClock::new();
    let (n5, _) = FakeNode::boxed(5, Duration::from_micros(100));
    let (n2, _) = FakeNode::boxed(2, MS);
    let mut bus = SimCanBus::new(&clock, RATE, vec![n2, n5]).unwrap();
    bus.send(&CanFrame::new(0, &[1]).unwrap()).unwrap();
    let a = bus.recv(clock.deadline_in(10 * MS)).unwrap().unwrap();
    let b = bus.recv(clock.deadline_in(10 * MS)).unwrap().unwrap();
    assert_eq!((a.id, b.id), (0x585, 0x582));
}

#[test]
fn a_flipped_frame_is_retransmitted_after_an_error_frame() {
    let clock = VirtualClock::new();
    let (node, h) = FakeNode::boxed(1, MS);
    let log = EventLog::memory();
    let mut bus = SimCanBus::new(&clock, RATE, vec![node])
        .unwrap()
        .with_faults(FaultPlan::parse("flip=1").unwrap(), 1)
        .with_log(log.clone());
    let req = sdo(0x601);
    let ft = can_frame_time(&req, RATE).unwrap();
    let err = bits_time(ERROR_FRAME_BITS, RATE);
    bus.send(&req).unwrap();
    let end = Instant::ZERO + ft + err + ft;
    assert_eq!(clock.now(), end);
    assert_eq!(h.seen.lock().unwrap()[0].0, end);
    let got = bus.recv(clock.deadline_in(10 * MS)).unwrap().unwrap();
    let at = can_frame_time(&got, RATE).unwrap();
    assert_eq!(clock.now(), end + MS + at + err + at);
    let faults: Vec<_> = log.events().into_iter().filter_map(|e| e.fault).collect();
    assert_eq!(faults, ["flip", "flip"]);
}

#[test]
fn a_lost_answer_and_a_power_cycle() {
    let clock = VirtualClock::new();
    let (node, h) = FakeNode::boxed(1, MS);
    let mut bus = SimCanBus::new(&clock, RATE, vec![node])
        .unwrap()
        .with_faults(FaultPlan::parse("lose=1,power-cycle@2:addr=1").unwrap(), 1);
    bus.send(&sdo(0x601)).unwrap();
    assert_eq!(bus.recv(clock.deadline_in(10 * MS)).unwrap(), None);
    bus.send(&sdo(0x601)).unwrap();
    let end2 = clock.now();
    assert_eq!(
        h.power.lock().unwrap().as_slice(),
        [(end2, Duration::from_millis(500))]
    );
}

#[test]
fn the_log_shows_frames_as_candump_does() {
    let clock = VirtualClock::new();
    let (node, _) = FakeNode::boxed(1, MS);
    let log = EventLog::memory();
    let mut bus = SimCanBus::new(&clock, RATE, vec![node])
        .unwrap()
        .with_log(log.clone());
    bus.send(&CanFrame::new(0x601, &[0x40, 0x18]).unwrap())
        .unwrap();
    bus.recv(clock.deadline_in(10 * MS)).unwrap();
    let ev = log.events();
    assert_eq!(ev[0].text, "601#4018");
    assert_eq!(ev[0].hex, "40 18");
    assert_eq!(ev[1].text, "581#4018");
    assert_eq!(ev[1].addr, Some(1));
    assert_eq!(candump(&CanFrame::new_remote(0x701, 0).unwrap()), "701#R");
    let dump = bus.state_dump();
    assert_eq!(dump["drives"][0]["family"], "fake-can");
    assert_eq!(dump["bitrate"], RATE);
    assert!(SimCanBus::new(&clock, 123, vec![]).is_err());
}
