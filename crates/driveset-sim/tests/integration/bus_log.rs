//! The event log: exact JSON lines for a small exchange, in memory and
//! through a writer.

use crate::bus_support as support;

use std::io::Write;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use driveset_link::{ByteLink, Clock, VirtualClock};
use driveset_sim::bus::SimByteBus;
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::{EventLog, text};
use support::{FakeDrive, telegram};

const MS: Duration = Duration::from_millis(1);

fn exchange(log: EventLog, plan: &str) {
    let clock = VirtualClock::new();
    let (drive, _) = FakeDrive::boxed(1, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![drive])
        .unwrap()
        .with_faults(FaultPlan::parse(plan).unwrap(), 0)
        .with_log(log);
    bus.send(&telegram(b'1')).unwrap();
    let mut buf = [0u8; 8];
    while bus.recv(&mut buf, clock.deadline_in(20 * MS)).unwrap() > 0 {}
    bus.send(&telegram(b'1')).unwrap();
    while bus.recv(&mut buf, clock.deadline_in(20 * MS)).unwrap() > 0 {}
}

#[test]
fn a_small_exchange_gives_exact_lines() {
    let log = EventLog::memory();
    exchange(log.clone(), "lose=0,power-cycle@2:addr=1:off=100ms");
    let lines = log.lines();
    assert_eq!(
        lines,
        [
            r#"{"t_ns":0,"dir":"host","addr":null,"hex":"04 31 30 30 31 31 32 05","text":"<EOT>100112<ENQ>","fault":null,"detail":null}"#,
            r#"{"t_ns":9333333,"dir":"drive","addr":1,"hex":"06 31","text":"<ACK>1","fault":null,"detail":null}"#,
            r#"{"t_ns":31416666,"dir":"host","addr":null,"hex":"04 31 30 30 31 31 32 05","text":"<EOT>100112<ENQ>","fault":null,"detail":null}"#,
            r#"{"t_ns":40749999,"dir":"drive","addr":1,"hex":"06 31","text":"<ACK>1","fault":null,"detail":null}"#,
            r#"{"t_ns":39749999,"dir":"event","addr":1,"hex":"","text":"","fault":"power-cycle","detail":"power off for 100ms; a reply still on the line is cut"}"#,
        ]
    );
}

#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);

impl Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_writer_log_gets_the_same_lines_newline_terminated() {
    let out = Shared::default();
    let log = EventLog::writer(out.clone());
    exchange(log.clone(), "");
    log.check().unwrap();
    let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
    let memory = EventLog::memory();
    exchange(memory.clone(), "");
    let expected: String = memory.lines().iter().map(|l| format!("{l}\n")).collect();
    assert_eq!(text, expected);
    assert_eq!(text.lines().count(), 4);
}

struct Failing;

impl Write for Failing {
    fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
        Err(std::io::Error::other("disk full"))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_failing_writer_is_reported_not_panicked() {
    let log = EventLog::writer(Failing);
    exchange(log.clone(), "");
    let err = log.check().unwrap_err();
    assert_eq!(
        err.to_string(),
        "cannot write the event log: disk full; check the --log path and free disk space"
    );
    assert!(log.check().is_err(), "the log stays stopped");
}

#[test]
fn text_names_control_characters() {
    assert_eq!(
        text(&[0x02, b'A', 0x03, 0x7F, 0x15, 0x90]),
        "<STX>A<ETX><DEL><NAK><0x90>"
    );
}
