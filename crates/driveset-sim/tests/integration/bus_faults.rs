//! Fault plans: the string grammar, each fault kind with a fixed seed
//! (exact outcome), reproducibility, scheduled power cycles and pulled
//! cables at exact instants.

use crate::bus_support as support;

use std::time::Duration;

use driveset_link::{ByteLink, Clock, Instant, VirtualClock};
use driveset_sim::bus::SimByteBus;
use driveset_sim::faults::{Action, FaultPlan, Scheduled, Trigger};
use driveset_sim::log::EventLog;
use support::{ACK, FakeDrive, NAK, telegram};

const MS: Duration = Duration::from_millis(1);

fn bus_with(plan: &str, seed: u64) -> (SimByteBus, VirtualClock, support::Shared, EventLog) {
    let clock = VirtualClock::new();
    let (drive, seen) = FakeDrive::boxed(1, MS);
    let log = EventLog::memory();
    let bus = SimByteBus::new(&clock, 9600, vec![drive])
        .unwrap()
        .with_faults(FaultPlan::parse(plan).unwrap(), seed)
        .with_log(log.clone());
    (bus, clock, seen, log)
}

/// One request to drive 1 and everything that comes back within 50 ms.
fn exchange(bus: &mut SimByteBus, clock: &VirtualClock) -> Vec<u8> {
    bus.send(&telegram(b'1')).unwrap();
    let deadline = clock.deadline_in(50 * MS);
    let mut got = Vec::new();
    let mut buf = [0u8; 16];
    loop {
        let n = bus.recv(&mut buf, deadline).unwrap();
        if n == 0 {
            return got;
        }
        got.extend_from_slice(&buf[..n]);
    }
}

#[test]
fn the_example_string_round_trips() {
    let s = "flip=0.01,lose=0.02,truncate=0.01,garbage=0.01,power-cycle@120,power-cycle@40:addr=3,cable@300+500ms,seed=7";
    let plan = FaultPlan::parse(s).unwrap();
    assert_eq!(plan.flip, 0.01);
    assert_eq!(plan.lose, 0.02);
    assert_eq!(plan.seed, Some(7));
    assert_eq!(
        plan.events,
        [
            Scheduled {
                at: Trigger::Telegram(120),
                action: Action::PowerCycle {
                    addr: None,
                    off: Duration::from_millis(500)
                }
            },
            Scheduled {
                at: Trigger::Telegram(40),
                action: Action::PowerCycle {
                    addr: Some(3),
                    off: Duration::from_millis(500)
                }
            },
            Scheduled {
                at: Trigger::Telegram(300),
                action: Action::Cable {
                    duration: Duration::from_millis(500)
                }
            },
        ]
    );
    assert_eq!(plan.to_string(), s);
    assert_eq!(FaultPlan::parse(&plan.to_string()).unwrap(), plan);
}

#[test]
fn display_is_canonical() {
    let plan = FaultPlan::parse(
        " seed=1 , garbage=0.5, power-cycle@1500ms:off=2000ms:addr=4, flip=0.25,cable@2s+1500us",
    )
    .unwrap();
    assert_eq!(
        plan.to_string(),
        "flip=0.25,garbage=0.5,power-cycle@1500ms:addr=4:off=2s,cable@2s+1500us,seed=1"
    );
    assert_eq!(FaultPlan::parse(&plan.to_string()).unwrap(), plan);
    assert!(FaultPlan::parse("").unwrap().is_empty());
    assert_eq!(FaultPlan::parse("").unwrap().to_string(), "");
    assert_eq!(FaultPlan::parse("lose=0").unwrap().to_string(), "");
}

#[test]
fn parse_errors_name_the_item_and_list_the_keys() {
    let cases = [
        ("flap=0.1", "flap=0.1", "unknown key `flap`"),
        ("flip=2", "flip=2", "probability 2 is outside 0..=1"),
        ("flip=abc", "flip=abc", "`abc` is not a number"),
        ("cable@300", "cable@300", "a pulled cable needs a duration"),
        ("cable@300+5", "cable@300+5", "`5` has no unit"),
        ("cable@300+5h", "cable@300+5h", "unknown time unit `h`"),
        (
            "power-cycle@0",
            "power-cycle@0",
            "host telegrams count from 1",
        ),
        (
            "power-cycle@x",
            "power-cycle@x",
            "give a host telegram number",
        ),
        (
            "power-cycle@4:foo=1",
            "power-cycle@4:foo=1",
            "unknown power-cycle option `foo=1`",
        ),
        (
            "power-cycle@4:addr=300",
            "power-cycle@4:addr=300",
            "address `300`",
        ),
        ("seed=-1", "seed=-1", "seed `-1` is not an unsigned"),
        ("flip=0.1,,lose=0.1", "", "empty item"),
        ("bogus", "bogus", "unknown item"),
    ];
    for (input, item, reason) in cases {
        let err = FaultPlan::parse(input).unwrap_err();
        assert_eq!(err.item, item, "{input}");
        let msg = err.to_string();
        assert!(msg.contains(reason), "{input}: {msg}");
        assert!(
            msg.contains("valid items: flip=P, lose=P, truncate=P, garbage=P, power-cycle@N"),
            "{msg}"
        );
    }
}

#[test]
fn lose_drops_the_reply() {
    let (mut bus, clock, seen, log) = bus_with("lose=1", 7);
    assert_eq!(exchange(&mut bus, &clock), b"");
    assert_eq!(seen.lock().unwrap().telegrams.len(), 1);
    let ev = log.events();
    assert_eq!(ev[1].fault.as_deref(), Some("lose"));
    assert_eq!(ev[1].hex, "06 31");
}

#[test]
fn truncate_keeps_a_seeded_prefix() {
    // A reply of 2 characters keeps 0 or 1; seed 7 picks 1.
    let (mut bus, clock, _, log) = bus_with("truncate=1", 7);
    assert_eq!(exchange(&mut bus, &clock), [ACK]);
    assert_eq!(
        log.events()[1].detail.as_deref(),
        Some("only the first 1 of 2 characters reached the host")
    );
}

#[test]
fn flip_on_the_host_side_reaches_the_drive_as_a_parity_error() {
    let (mut bus, clock, seen, log) = bus_with("flip=1,seed=3", 0);
    let got = exchange(&mut bus, &clock);
    let seen = seen.lock().unwrap();
    let bad: Vec<_> = seen
        .heard
        .iter()
        .enumerate()
        .filter(|(_, h)| !h.2)
        .map(|(i, h)| (i, h.1))
        .collect();
    assert_eq!(bad.len(), 1, "{bad:?}");
    let (index, byte) = bad[0];
    let sent = telegram(b'1')[index];
    assert_eq!((byte ^ sent).count_ones(), 1);
    let host_line = &log.events()[0];
    assert_eq!(host_line.fault.as_deref(), Some("flip"));
    assert_eq!(
        host_line.detail.as_deref(),
        Some(
            format!(
                "character {index} bit {}: the drives heard 0x{byte:02X} with a parity error",
                (byte ^ sent).trailing_zeros()
            )
            .as_str()
        )
    );
    // The exact seeded outcome.
    assert_eq!((index, byte), (EXPECT_HOST_FLIP.0, EXPECT_HOST_FLIP.1));
    // flip=1 flips a bit of the reply too (NAK + '1' before it).
    assert_eq!(got, EXPECT_HOST_FLIP.2);
}

// Seed 3: character 3 ('0') bit 2 -> '4' with a parity error; the NAK
// reply's character 1 bit 6 flipped ('1' -> 'q').
const EXPECT_HOST_FLIP: (usize, u8, [u8; 2]) = (3, 0x34, [NAK, 0x71]);

#[test]
fn garbage_arrives_right_after_the_host_telegram() {
    // Seed 7: three noise characters 0x28 0x7F 0x1F, one character time
    // apart from the end of the telegram, interleaved in time with the
    // reply (ACK at 10.375 ms, '1' at 11.417 ms).
    let (mut bus, clock, _, log) = bus_with("garbage=1", 7);
    bus.send(&telegram(b'1')).unwrap();
    let mut buf = [0u8; 16];
    let mut got = Vec::new();
    let mut at = Vec::new();
    loop {
        let n = bus.recv(&mut buf, clock.deadline_in(50 * MS)).unwrap();
        if n == 0 {
            break;
        }
        got.extend_from_slice(&buf[..n]);
        at.push(clock.now().as_nanos());
    }
    assert_eq!(got, [0x28, ACK, 0x7F, b'1', 0x1F]);
    assert_eq!(
        at,
        [9_374_999, 10_374_999, 10_416_666, 11_416_666, 11_458_333]
    );
    let ev = log.events();
    assert_eq!(ev[1].fault.as_deref(), Some("garbage"));
    assert_eq!(ev[1].hex, "28 7F 1F");
    assert_eq!(ev[1].t_ns, 8_333_333);
}

#[test]
fn same_seed_same_faults_other_seed_other_faults() {
    let run = |seed: u64| {
        let (mut bus, clock, _, log) = bus_with("flip=0.2,lose=0.2,truncate=0.2,garbage=0.2", seed);
        let replies: Vec<Vec<u8>> = (0..40).map(|_| exchange(&mut bus, &clock)).collect();
        (replies, log.lines())
    };
    let a = run(5);
    let b = run(5);
    assert_eq!(a, b);
    assert!(a.1.iter().any(|l| l.contains("\"fault\":\"lose\"")));
    let c = run(6);
    assert_ne!(a.1, c.1);
}

#[test]
fn power_cycle_at_telegram_n_hits_the_drive_at_the_end_of_it() {
    let (mut bus, clock, seen, log) = bus_with("power-cycle@3:addr=1:off=200ms", 0);
    assert_eq!(exchange(&mut bus, &clock), [ACK, b'1']);
    assert_eq!(exchange(&mut bus, &clock), [ACK, b'1']);
    let t3 = clock.now();
    // Telegram 3: heard, but the power goes at its end: no reply.
    assert_eq!(exchange(&mut bus, &clock), b"");
    let end3 = t3 + Duration::from_nanos(8_333_333);
    assert_eq!(
        seen.lock().unwrap().power,
        [(end3, Duration::from_millis(200))]
    );
    assert_eq!(seen.lock().unwrap().telegrams.len(), 3);
    // Still off (the fake ignores everything until end3 + 200 ms).
    assert_eq!(exchange(&mut bus, &clock), b"");
    clock.advance_to(end3 + Duration::from_millis(200));
    assert_eq!(exchange(&mut bus, &clock), [ACK, b'1']);
    assert!(
        log.lines()
            .iter()
            .any(|l| l.contains("\"fault\":\"power-cycle\"")
                && l.contains(&format!("\"t_ns\":{}", end3.as_nanos())))
    );
}

#[test]
fn power_cycle_of_every_drive_at_a_time() {
    let clock = VirtualClock::new();
    let (a, sa) = FakeDrive::boxed(1, MS);
    let (b, sb) = FakeDrive::boxed(2, MS);
    let mut bus = SimByteBus::new(&clock, 9600, vec![a, b])
        .unwrap()
        .with_faults(FaultPlan::parse("power-cycle@20ms").unwrap(), 0);
    let mut buf = [0u8; 4];
    assert_eq!(bus.recv(&mut buf, clock.deadline_in(30 * MS)).unwrap(), 0);
    let at = Instant::from_nanos(20_000_000);
    assert_eq!(sa.lock().unwrap().power, [(at, Duration::from_millis(500))]);
    assert_eq!(sb.lock().unwrap().power, [(at, Duration::from_millis(500))]);
}

#[test]
fn a_pulled_cable_drops_both_directions_for_its_duration_only() {
    let (mut bus, clock, seen, log) = bus_with("cable@2+100ms", 0);
    assert_eq!(exchange(&mut bus, &clock), [ACK, b'1']);
    let t2 = clock.now();
    // Telegram 2 reaches the drive; the cable goes at its end: the reply is lost.
    assert_eq!(exchange(&mut bus, &clock), b"");
    let pulled = t2 + Duration::from_nanos(8_333_333);
    let heard_before = seen.lock().unwrap().heard.len();
    // 50 ms later (inside the window) the drive hears nothing.
    assert_eq!(exchange(&mut bus, &clock), b"");
    assert_eq!(seen.lock().unwrap().heard.len(), heard_before);
    // After the window everything works again.
    clock.advance_to(pulled + Duration::from_millis(100));
    assert_eq!(exchange(&mut bus, &clock), [ACK, b'1']);
    let lines = log.lines();
    assert!(
        lines
            .iter()
            .any(|l| l.contains("\"fault\":\"cable-pulled\"")
                && l.contains(&format!("\"t_ns\":{}", pulled.as_nanos())))
    );
}

#[test]
fn a_time_triggered_cable_cuts_a_reply_in_flight() {
    // Reply characters arrive at 10.375 ms and 11.417 ms; the cable is out
    // from 11 ms to 12 ms: the host gets the first one only.
    let (mut bus, clock, _, _) = bus_with("cable@11ms+1ms", 0);
    assert_eq!(exchange(&mut bus, &clock), [ACK]);
}
