//! Tests of the doctor: exact request bytes, the percentiles, and whole runs
//! against the simulated drives (nothing but reads is sent).

use super::probe::{request, round_trips};
use super::*;
use driveset_link::Instant;

#[test]
fn percentiles_by_nearest_rank() {
    let times: Vec<Duration> = (1..=20).map(Duration::from_millis).collect();
    let r = round_trips(9600, 20, times, Duration::from_millis(1)).expect("stats");
    assert_eq!(
        (r.min_us, r.median_us, r.p95_us, r.max_us),
        (1000, 10_000, 19_000, 20_000)
    );
    let r = round_trips(9600, 3, vec![Duration::from_micros(7)], Duration::ZERO).expect("one");
    assert_eq!(
        (r.min_us, r.median_us, r.p95_us, r.max_us, r.answered),
        (7, 7, 7, 7, 1)
    );
    assert_eq!(round_trips(9600, 3, Vec::new(), Duration::ZERO), None);
    assert_eq!(ms(16_042), "16.042 ms");
}

#[test]
fn requests_are_reads_with_exact_bytes() {
    assert_eq!(
        request(DoctorProtocol::Lustbus, 1).expect("enquiry"),
        b"\x04A00091\x05"
    );
    assert_eq!(
        request(DoctorProtocol::Lustbus, 0).expect("enquiry"),
        b"\x04@00091\x05"
    );
    assert_eq!(
        request(DoctorProtocol::Lustbus, 31)
            .expect_err("broadcast")
            .to_string(),
        "31 is not a LUSTBUS drive address: use 1..30, or 0 (every drive answers, stand-alone operation, section 4.1)"
    );
    let lecom = request(DoctorProtocol::Lecom, 1).expect("receive");
    assert_eq!(lecom.first(), Some(&0x04));
    assert_eq!(lecom.last(), Some(&0x05));
    assert!(!lecom.contains(&0x02), "a RECEIVE carries no STX");
    assert!(request(DoctorProtocol::Lecom, 10).is_err());
    assert_eq!(
        rate_order(DoctorProtocol::Lustbus, 9600),
        vec![9600, 57600, 38400, 19200, 4800, 2400]
    );
    assert_eq!(
        rate_order(DoctorProtocol::Lecom, 1200),
        vec![1200, 9600, 4800, 2400]
    );
}

use driveset_link::{Clock, VirtualClock};
use driveset_sim::catalog::Family;
use driveset_sim::log::EventLog;
use driveset_sim::open::{SimBus, SimConfig, SimLink, open_sim_with};

fn sim(family: Family, baud: u32, log: &EventLog) -> SimLink {
    let clock = VirtualClock::new();
    let mut config = SimConfig::new(family, vec![1]);
    config.baud = baud;
    open_sim_with(&config, &clock, "sim://test", log.clone()).expect("sim")
}

/// The host side of `sim` reopened at a rate (the drives keep theirs).
fn opener(sim: &SimLink) -> impl FnMut(u32) -> Result<Box<dyn ByteLink>, LinkError> + '_ {
    move |baud| {
        sim.with_bus(|b| match b {
            SimBus::Bytes(b) => b.set_baud(baud).expect("rate"),
            SimBus::Frames(_) => panic!("not a byte bus"),
        });
        Ok(sim.byte_link().expect("byte link"))
    }
}

/// A line that returns every byte sent (before the drive's answer), and
/// optionally reads 7E1 as 8 data bits (parity in bit 7).
#[derive(Debug)]
struct Line {
    inner: Box<dyn ByteLink>,
    echo: bool,
    eight_bits: bool,
    pending: std::collections::VecDeque<u8>,
}

impl ByteLink for Line {
    fn port(&self) -> &str {
        self.inner.port()
    }
    fn bus_id(&self) -> String {
        self.inner.bus_id()
    }
    fn baud(&self) -> u32 {
        self.inner.baud()
    }
    fn clock(&self) -> &dyn driveset_link::Clock {
        self.inner.clock()
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        if self.echo {
            self.pending.extend(bytes.iter().copied());
        }
        self.inner.send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        let n = if self.pending.is_empty() {
            self.inner.recv(buf, deadline)?
        } else {
            let n = buf.len().min(self.pending.len());
            for (slot, b) in buf.iter_mut().zip(self.pending.drain(..n)) {
                *slot = b;
            }
            n
        };
        if self.eight_bits {
            for b in &mut buf[..n] {
                if b.count_ones() % 2 == 1 {
                    *b |= 0x80;
                }
            }
        }
        Ok(n)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.pending.clear();
        self.inner.discard_input()
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        self.inner.flush()
    }
}

fn host_telegrams_are_reads(log: &EventLog) -> usize {
    let host: Vec<_> = log
        .events()
        .into_iter()
        .filter(|e| matches!(e.dir, driveset_sim::log::Dir::Host))
        .collect();
    for e in &host {
        // SELECT (LUSTBUS) and SEND (LECOM) carry STX; reads never do.
        assert!(!e.hex.split(' ').any(|h| h == "02"), "a write: {}", e.text);
    }
    host.len()
}

#[test]
fn a_clean_mc6000_line_answers_at_its_rate_only_and_nothing_is_written() {
    let log = EventLog::memory();
    let sim = sim(Family::Mc6000, 19200, &log);
    let mut options = DoctorOptions::new(DoctorProtocol::Lustbus);
    options.address = Some(1);
    let mut open = opener(&sim);
    let r = run("sim://test", 9600, &mut open, &options, Vec::new()).expect("doctor");
    assert_eq!(r.address, 1);
    assert_eq!(r.answering, vec![19200]);
    let order: Vec<u32> = r.rates.iter().map(|x| x.baud).collect();
    assert_eq!(order, vec![9600, 57600, 38400, 19200, 4800, 2400]);
    assert_eq!(
        r.rates[3].result,
        ProbeResult::Answer {
            // the simulated MC6000's 91-TYPE, 6000
            value: "1770".into()
        }
    );
    assert!(!matches!(r.rates[0].result, ProbeResult::Answer { .. }));
    let rt = r.round_trips.clone().expect("round trips");
    assert_eq!((rt.baud, rt.probes, rt.answered), (19200, 20, 20));
    // Request `EOT A 00091 ENQ` (8) + answer `A STX 00091=1770 ETX
    // BCC` (14) characters, 10 bits each, at 19200 baud.
    assert_eq!(rt.wire_us, 11_458);
    assert!(rt.min_us > rt.wire_us, "{rt:?}");
    assert!(rt.min_us <= rt.median_us && rt.median_us <= rt.p95_us && rt.p95_us <= rt.max_us);
    // MC6000 reactions are 1..25 ms (LUSTBUS 10).
    assert!(rt.max_us <= rt.wire_us + 25_000, "{rt:?}");
    assert_eq!(
        r.echo,
        EchoFinding {
            echo: false,
            exchanges: r.echo.exchanges,
            echoed: 0
        }
    );
    assert!(!r.parity.read_as_8_bits);
    assert_eq!((r.parity.high_bit, r.parity.bad_bcc), (0, 0));
    assert_eq!(
        r.advice,
        vec![
            "the drive answers at 19200 baud, not at the port's 9600: add ?baud=19200 to the port (or set the drive to 9600 baud)".to_string()
        ]
    );
    // 6 rates (a second try at each silent one) + 20 probes + EOT.
    assert!(host_telegrams_are_reads(&log) >= 26);
}

#[test]
fn echo_and_parity_in_bit_7_are_found_and_explained() {
    let log = EventLog::memory();
    let sim = sim(Family::Mc6000, 9600, &log);
    let options = DoctorOptions::new(DoctorProtocol::Lustbus);
    let mut open = |baud: u32| -> Result<Box<dyn ByteLink>, LinkError> {
        sim.with_bus(|b| match b {
            SimBus::Bytes(b) => b.set_baud(baud).expect("rate"),
            SimBus::Frames(_) => panic!("not a byte bus"),
        });
        Ok(Box::new(Line {
            inner: sim.byte_link().expect("link"),
            echo: true,
            eight_bits: true,
            pending: Default::default(),
        }))
    };
    let r = run("sim://test", 9600, &mut open, &options, Vec::new()).expect("doctor");
    assert_eq!(r.address, 0);
    assert_eq!(r.answering, vec![9600]);
    assert!(r.echo.echo);
    assert_eq!(r.echo.echoed, r.echo.exchanges);
    assert_eq!(r.round_trips.as_ref().map(|t| t.answered), Some(20));
    // 21 answers of 14 bytes: `@ STX 00091=1770 ETX BCC`.
    assert_eq!(r.parity.bytes, 21 * 14);
    assert!(r.parity.read_as_8_bits);
    assert_eq!(r.parity.odd_weight, 0);
    assert_eq!(
        r.advice[0],
        format!(
            "the line returns every byte driveset sends ({} of {} exchanges): a 2-wire RS-485 adapter without echo suppression; driveset strips it with ?echo=auto (the default) or ?echo=on, or switch the adapter's local echo off",
            r.echo.echoed, r.echo.exchanges
        )
    );
    assert_eq!(
        r.advice[1],
        format!(
            "{} of 294 answer bytes have the parity bit in bit 7: the port reads 8 data bits on a 7E1 line (an adapter or device server left at 8N1); set it to 7 data bits, even parity, 1 stop bit (rfc2217:// sets it on the server); the drives may see driveset's characters with a wrong parity bit",
            r.parity.high_bit
        )
    );
    assert_eq!(r.advice.len(), 2, "{:?}", r.advice);
    host_telegrams_are_reads(&log);
}

#[test]
fn a_tmd_over_lecom_and_the_usb_latency_timer() {
    let log = EventLog::memory();
    let sim = sim(Family::Tmd, 9600, &log);
    let mut options = DoctorOptions::new(DoctorProtocol::Lecom);
    options.probes = 5;
    let timers = vec![
        LatencyTimer {
            device: "ttyUSB0".into(),
            path: "/sys/bus/usb-serial/devices/ttyUSB0/latency_timer".into(),
            ms: 16,
            this_port: true,
        },
        LatencyTimer {
            device: "ttyUSB1".into(),
            path: "/sys/bus/usb-serial/devices/ttyUSB1/latency_timer".into(),
            ms: 16,
            this_port: false,
        },
    ];
    let mut open = opener(&sim);
    let r = run("sim://test", 9600, &mut open, &options, timers).expect("doctor");
    assert_eq!(r.answering, vec![9600]);
    assert_eq!(r.rates.len(), 4);
    assert!(matches!(r.rates[0].result, ProbeResult::Answer { .. }));
    assert_eq!(
        r.round_trips.as_ref().map(|t| (t.probes, t.answered)),
        Some((5, 5))
    );
    assert_eq!(
        r.advice,
        vec!["ttyUSB0: the USB adapter's latency timer is 16 ms, so every answer waits up to 16 ms in the adapter: set it to 1 (echo 1 > /sys/bus/usb-serial/devices/ttyUSB0/latency_timer, or a udev rule ATTR{latency_timer}=\"1\")".to_string()]
    );
    host_telegrams_are_reads(&log);
}

#[test]
fn a_silent_line_says_what_to_check() {
    let log = EventLog::memory();
    let sim = sim(Family::Mc6000, 9600, &log);
    let mut options = DoctorOptions::new(DoctorProtocol::Lustbus);
    options.address = Some(7);
    options.timeout = Duration::from_millis(100);
    let mut open = opener(&sim);
    let before = sim.clock().now();
    let r = run("sim://test", 9600, &mut open, &options, Vec::new()).expect("doctor");
    assert!(!r.answered());
    assert_eq!(r.round_trips, None);
    assert!(r.rates.iter().all(|x| x.result == ProbeResult::Silent));
    assert_eq!(
        r.advice,
        vec!["nothing answered address 7 at any rate (9600, 57600, 38400, 19200, 4800, 2400): check the wiring (A/B swapped?), the termination, that the drive is powered and set to this address, and that the port runs 7E1 (on a tcp:// device server set 7E1 there, or use rfc2217:// so driveset sets it)".to_string()]
    );
    // Two tries of 100 ms after each request at six rates, in virtual time.
    assert!(sim.clock().now() - before >= Duration::from_millis(1200));
}

/// The refusal is a `Refusal` whose JSON is the flat kind journals have
/// always held, and reads back to the same refusal.
#[test]
fn the_doctor_refusal_keeps_its_json_kind_and_reads_back() {
    crate::error::assert_refusal_json(&DoctorRefusal::CanPort, r#"{"kind":"doctor_can_port"}"#);
}

#[test]
fn the_protocol_is_the_drives_on_a_character_line_and_can_on_a_can_port() {
    let log = EventLog::off();
    let mut tmd = sim(Family::Tmd, 9600, &log).link();
    assert_eq!(
        protocol_on(&mut tmd, "sim://test", None, None).expect("tmd"),
        DoctorProtocol::Lecom
    );
    let mut mc = sim(Family::Mc6000, 9600, &log).link();
    assert_eq!(
        protocol_on(&mut mc, "sim://test", Some(1), None).expect("mc6000"),
        DoctorProtocol::Lustbus
    );
    let clock = VirtualClock::new();
    let config = SimConfig::new(Family::Ecs, vec![1]);
    let mut ecs = open_sim_with(&config, &clock, "sim://test", log.clone())
        .expect("sim")
        .link();
    assert_eq!(
        protocol_on(&mut ecs, "sim://test", None, None).expect("ecs"),
        DoctorProtocol::CanSdo
    );
}

#[test]
fn the_verdict_says_silent_fine_or_advice() {
    let log = EventLog::off();
    let s = sim(Family::Mc6000, 9600, &log);
    let mut open = opener(&s);
    let mut r = run(
        "sim://test",
        9600,
        &mut open,
        &DoctorOptions::new(DoctorProtocol::Lustbus),
        Vec::new(),
    )
    .expect("run");
    r.advice.clear();
    assert_eq!(r.verdict(), DoctorVerdict::Fine);
    r.advice.push("change something".into());
    assert_eq!(r.verdict(), DoctorVerdict::Advice);
    r.answering.clear();
    assert_eq!(r.verdict(), DoctorVerdict::Silent);
}

#[test]
fn a_line_is_set_to_the_rate_probed_and_a_can_port_refused() {
    let log = EventLog::off();
    let s = sim(Family::Tmd, 9600, &log);
    let l = line_at(s.link(), "sim://test", 4800).expect("a line");
    assert_eq!(l.baud(), 4800);
    let clock = VirtualClock::new();
    let ecs = open_sim_with(
        &SimConfig::new(Family::Ecs, vec![1]),
        &clock,
        "sim://e",
        log,
    )
    .expect("sim");
    let e = line_at(ecs.link(), "sim://e", 9600).expect_err("CAN");
    assert!(
        matches!(&e, LinkError::Unsupported { port, what } if port == "sim://e" && what == "a CAN port"),
        "{e}"
    );
}
