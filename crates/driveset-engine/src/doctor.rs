//! `driveset doctor`: what an engineer runs first on a new line. Owns the
//! read-only line check [`run`] and its [`DoctorReport`]: does anything
//! answer and at which rates, the round-trip time distribution, echo,
//! parity trouble, the USB adapter's latency timer (read by the caller,
//! passed in as [`LatencyTimer`]s), and advice lines.
//!
//! Read-only: the only telegrams sent are reads of an identification code
//! that every drive of the protocol has, so nothing in a drive changes:
//!
//! - LUSTBUS: ENQUIRY of 91-TYPE (CODE `00091`, numerically compatible on
//!   inverters and servocontrollers, section 5.2). Without an address the
//!   probe goes to address 0, which every drive answers (sections 4.1 and
//!   5.1, stand-alone operation; on a line with several drives give the
//!   address: they would answer at once). Rates: the port's first, then
//!   every other LUSTBUS rate highest first ("the connection will be
//!   attempted using all possible transfer rates", section 5.1).
//! - LECOM-A/B: RECEIVE of C0093 (the controller type) at station 01 (the
//!   factory C0009) or the address given; rates: the port's, then the
//!   Tmd's C0125 rates highest first.
//!
//! Every rate is tried (not just until the first answer), so a drive set
//! to another rate than the port shows as such. The link must be opened
//! without echo stripping (`echo=off`): the doctor sees the raw bytes and
//! decides itself with [`detect_echo`], then strips the echo before
//! decoding.
//!
//! Parity: a 7E1 line read by a port set to 8 data bits (an adapter or
//! device server left at 8N1) delivers the parity bit as bit 7: every byte
//! then has an even number of one bits over all 8, and those with an odd
//! 7-bit weight have bit 7 set. The doctor counts the received bytes with
//! bit 7 set and whether all bytes have even 8-bit weight; codecs mask
//! bit 7, so such a line may even work, but the drive sees the master's
//! characters with a wrong parity bit (bit 7 = 0 is read as the parity of
//! an odd-weight character) and ignores or NAKs them. Bad BCCs and
//! garbled answers are counted too: they are what parity and rate trouble
//! look like after masking.
//!
//! Round trips are measured on the link's clock, from the start of the
//! send to the last character of the decoded answer, over
//! [`DoctorOptions::probes`] probes at the answering rate, and set against
//! the wire time (10 bits a character) of request and answer.

use std::time::Duration;

use driveset_link::echo::{EchoVerdict, detect_echo};
use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, Instant, LinkError};
use driveset_proto::lecom::{ControllerAddress, Receive, Response, ResponseDecoder, Telegram};
use driveset_proto::lustbus::{Address, Enquiry, ParameterCode, Reply, ReplyDecoder};
use serde::Serialize;

use crate::client::Target;
use crate::error::{EngineError, Refusal};
use crate::scan::{LECOM_BAUDS, LUSTBUS_BAUDS};

/// The protocol the doctor speaks: the family descriptor's bus protocol.
pub use driveset_schema::BusProtocol as DoctorProtocol;

/// What the doctor needs to know of a bus protocol beyond its descriptor.
pub trait DoctorRules {
    /// The rates the protocol's drives can run at, highest first.
    fn rates(self) -> &'static [u32];
    /// The address probed when none is given (see the module docs).
    fn default_address(self) -> u8;
    /// The read-only probe, for the report.
    fn probe_name(self) -> &'static str;
}

fn serialize_bus<S: serde::Serializer>(p: &DoctorProtocol, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.name())
}

impl DoctorRules for DoctorProtocol {
    /// The rates the protocol's drives can run at, highest first.
    fn rates(self) -> &'static [u32] {
        match self {
            DoctorProtocol::Lustbus => &LUSTBUS_BAUDS,
            DoctorProtocol::Lecom => &LECOM_BAUDS,
            DoctorProtocol::CanSdo => &[],
        }
    }

    /// The address probed when none is given (see the module docs).
    fn default_address(self) -> u8 {
        match self {
            DoctorProtocol::Lustbus => 0,
            DoctorProtocol::Lecom | DoctorProtocol::CanSdo => 1,
        }
    }

    /// What is read, for reports.
    fn probe_name(self) -> &'static str {
        match self {
            DoctorProtocol::Lustbus => "91-TYPE (ENQUIRY 00091)",
            DoctorProtocol::Lecom => "C0093 (RECEIVE)",
            DoctorProtocol::CanSdo => "the schema's first identification code (SDO upload)",
        }
    }
}

/// How to check.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DoctorOptions {
    /// The protocol.
    pub protocol: DoctorProtocol,
    /// The drive's address; `None`: [`DoctorRules::default_address`].
    pub address: Option<u8>,
    /// Round-trip probes at the answering rate. Default 20.
    pub probes: u32,
    /// How long to wait for an answer, from the end of the request.
    /// Default 300 ms (generous: a device server adds tens of ms each way).
    pub timeout: Duration,
    /// Why only the port's rate is tried, if so: the rate is not
    /// driveset's to change (a raw `tcp://` device server's line is set on
    /// the server; a pseudo terminal has none). `None`: every rate.
    pub fixed_rate: Option<String>,
}

impl DoctorOptions {
    /// Defaults for `protocol`.
    pub fn new(protocol: DoctorProtocol) -> Self {
        DoctorOptions {
            protocol,
            address: None,
            probes: 20,
            timeout: Duration::from_millis(300),
            fixed_rate: None,
        }
    }
}

/// What one probe got back.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ProbeResult {
    /// A decoded answer (`value` as the drive sent it, or `NAK`, `?`,
    /// `no such code`).
    Answer {
        /// The answer.
        value: String,
    },
    /// Bytes came back but no answer decoded from them.
    Garbled {
        /// The decoder's complaint.
        detail: String,
    },
    /// Nothing came back.
    Silent,
}

/// One probe: the request, what came back, when.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Probe {
    result: ProbeResult,
    /// Raw bytes received (echo included).
    received: Vec<u8>,
    echo: EchoVerdict,
    /// Bytes of the answer (after the echo).
    answer_len: usize,
    bad_bcc: bool,
    round_trip: Option<Duration>,
}

/// The outcome at one rate.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RateResult {
    /// The rate.
    pub baud: u32,
    /// What the first probe at this rate got.
    #[serde(flatten)]
    pub result: ProbeResult,
}

/// Round-trip times over the probes at the answering rate.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RoundTrips {
    /// The rate measured at.
    pub baud: u32,
    /// Probes sent.
    pub probes: u32,
    /// Of those, answered.
    pub answered: u32,
    /// Shortest, in microseconds.
    pub min_us: u64,
    /// Median (the lower middle of an even count), in microseconds.
    pub median_us: u64,
    /// 95th percentile (nearest rank), in microseconds.
    pub p95_us: u64,
    /// Longest, in microseconds.
    pub max_us: u64,
    /// Wire time of request and answer at this rate (10 bits a
    /// character), in microseconds: what the line alone takes.
    pub wire_us: u64,
}

/// Echo of the master's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct EchoFinding {
    /// Whether any exchange came back starting with the request.
    pub echo: bool,
    /// Exchanges that decided (bytes came back).
    pub exchanges: u32,
    /// Of those, with echo.
    pub echoed: u32,
}

/// Parity: what the received bytes say (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ParityFinding {
    /// Answer bytes received (echo not counted).
    pub bytes: u64,
    /// Of those, with bit 7 set.
    pub high_bit: u64,
    /// Of those, with an odd number of one bits over all 8.
    pub odd_weight: u64,
    /// Answers with a bad BCC.
    pub bad_bcc: u32,
    /// Probes that came back garbled (bad BCC included).
    pub garbled: u32,
    /// Whether the bytes look like a 7E1 line read with 8 data bits: some
    /// bytes have bit 7 set and every byte has even 8-bit weight.
    pub read_as_8_bits: bool,
}

/// A USB serial adapter's latency timer as Linux shows it
/// (`/sys/bus/usb-serial/devices/DEVICE/latency_timer`), read by the
/// caller.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LatencyTimer {
    /// The device (`ttyUSB0`).
    pub device: String,
    /// The file it was read from.
    pub path: String,
    /// The timer in milliseconds.
    pub ms: u32,
    /// Whether it is the port's adapter.
    pub this_port: bool,
}

/// Everything the doctor found.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct DoctorReport {
    /// The port.
    pub port: String,
    /// The protocol.
    #[serde(serialize_with = "serialize_bus")]
    pub protocol: DoctorProtocol,
    /// The address probed.
    pub address: u8,
    /// What was read.
    pub probe: &'static str,
    /// The port's own rate.
    pub port_baud: u32,
    /// Every rate tried, in the order tried.
    pub rates: Vec<RateResult>,
    /// The rates at which a drive answered.
    pub answering: Vec<u32>,
    /// Why only the port's rate was tried, if so.
    pub fixed_rate: Option<String>,
    /// Round trips at the answering rate (the port's, if it answers).
    pub round_trips: Option<RoundTrips>,
    /// Echo.
    pub echo: EchoFinding,
    /// Parity.
    pub parity: ParityFinding,
    /// USB adapters' latency timers found (empty: none, or not Linux).
    pub latency_timers: Vec<LatencyTimer>,
    /// What to change; empty when nothing needs changing.
    pub advice: Vec<String>,
}

impl DoctorReport {
    /// Whether a drive answered at some rate.
    pub fn answered(&self) -> bool {
        !self.answering.is_empty()
    }
}

/// Opens the line at a rate, without echo stripping.
pub type OpenAt<'a> = dyn FnMut(u32) -> Result<Box<dyn ByteLink>, LinkError> + 'a;

fn link_err(port: &str, address: u8, source: LinkError) -> EngineError {
    EngineError::link(
        Target {
            port: port.to_string(),
            address,
        },
        source,
    )
}

/// The request bytes.
fn request(protocol: DoctorProtocol, address: u8) -> Result<Vec<u8>, Refusal> {
    match protocol {
        DoctorProtocol::Lustbus => {
            let ad = Address::new(address)
                .filter(|a| a.number() <= 30)
                .ok_or(Refusal::DoctorLustbusAddress { address })?;
            let code = ParameterCode::new(91).ok_or(Refusal::Encode {
                what: None,
                detail: "CODE 00091".into(),
            })?;
            Ok(Enquiry::new(ad, code).encode().to_vec())
        }
        DoctorProtocol::Lecom => {
            let ad = ControllerAddress::new(address)
                .filter(|a| !a.is_broadcast())
                .ok_or(Refusal::DoctorLecomAddress { address })?;
            let code = driveset_proto::lecom::CodeAddress::select(93, 0);
            Telegram::Receive(Receive { address: ad, code })
                .to_bytes()
                .map_err(|e| Refusal::Encode {
                    what: None,
                    detail: e.to_string(),
                })
        }
        DoctorProtocol::CanSdo => Err(Refusal::DoctorCanPort),
    }
}

/// Decode `bytes` (echo removed) as an answer. `Ok(Some)` for an answer,
/// `Err(detail, bad_bcc)` for garbage so far, `Ok(None)` for nothing yet.
fn decode(
    protocol: DoctorProtocol,
    bytes: &[u8],
    end: bool,
) -> Result<Option<String>, (String, bool)> {
    let mut complaint: Option<(String, bool)> = None;
    match protocol {
        DoctorProtocol::Lustbus => {
            let mut d = ReplyDecoder::new();
            let mut events: Vec<_> = d.feed(bytes).collect();
            if end {
                events.extend(d.finish());
            }
            for ev in events {
                match ev.result {
                    Ok(Reply::Value(v)) => {
                        return Ok(Some(
                            String::from_utf8_lossy(v.value.as_bytes()).into_owned(),
                        ));
                    }
                    Ok(Reply::Nak(_)) => return Ok(Some("NAK".into())),
                    Ok(Reply::Ack(_)) => return Ok(Some("ACK".into())),
                    Err(e) => {
                        let bcc = matches!(e, driveset_proto::lustbus::FrameError::BadBcc { .. });
                        complaint = Some((e.to_string(), bcc));
                    }
                }
            }
        }
        DoctorProtocol::CanSdo => return Ok(None),
        DoctorProtocol::Lecom => {
            let mut d = ResponseDecoder::new();
            let mut events = Vec::new();
            d.feed(bytes, |e| events.push(e));
            if end {
                d.finish(|e| events.push(e));
            }
            for ev in events {
                match ev.result {
                    Ok(Response::Value { value, .. }) => return Ok(Some(value.to_string())),
                    Ok(Response::NoSuchCode { .. }) => return Ok(Some("no such code".into())),
                    Ok(Response::ChecksumFault { .. }) => return Ok(Some("?".into())),
                    Ok(Response::Ack) => return Ok(Some("ACK".into())),
                    Ok(Response::Nak) => return Ok(Some("NAK".into())),
                    Err(e) => {
                        let bcc = matches!(
                            e,
                            driveset_proto::lecom::StreamError::Frame(
                                driveset_proto::lecom::FrameError::BadBcc { .. }
                            )
                        );
                        complaint = Some((e.to_string(), bcc));
                    }
                }
            }
        }
    }
    match complaint {
        Some(c) if end => Err(c),
        _ => Ok(None),
    }
}

/// One exchange on `link`.
fn probe(
    link: &mut dyn ByteLink,
    protocol: DoctorProtocol,
    req: &[u8],
    timeout: Duration,
) -> Result<Probe, LinkError> {
    link.discard_input()?;
    let start = link.clock().now();
    link.send(req)?;
    link.flush()?;
    let deadline: Instant = link.clock().now() + timeout;
    let mut received = Vec::new();
    let mut buf = [0u8; 256];
    loop {
        let n = link.recv(&mut buf, deadline)?;
        let end = n == 0;
        received.extend_from_slice(&buf[..n]);
        let now = link.clock().now();
        let mut echo = detect_echo(req, &received);
        if end && echo == EchoVerdict::Undecided && !received.is_empty() {
            echo = EchoVerdict::NoEcho;
        }
        let answer: &[u8] = match echo {
            EchoVerdict::Echo => &received[req.len()..],
            EchoVerdict::NoEcho => &received,
            EchoVerdict::Undecided => &[],
        };
        match decode(protocol, answer, end) {
            Ok(Some(value)) => {
                return Ok(Probe {
                    result: ProbeResult::Answer { value },
                    answer_len: answer.len(),
                    received,
                    echo,
                    bad_bcc: false,
                    round_trip: Some(now - start),
                });
            }
            Err((detail, bad_bcc)) => {
                return Ok(Probe {
                    result: ProbeResult::Garbled { detail },
                    answer_len: answer.len(),
                    received,
                    echo,
                    bad_bcc,
                    round_trip: None,
                });
            }
            Ok(None) if end => {
                let result = if answer.is_empty() {
                    ProbeResult::Silent
                } else {
                    ProbeResult::Garbled {
                        detail: "an incomplete answer".into(),
                    }
                };
                return Ok(Probe {
                    result,
                    answer_len: answer.len(),
                    received,
                    echo,
                    bad_bcc: false,
                    round_trip: None,
                });
            }
            Ok(None) => {}
        }
    }
}

/// The rates to try: the port's first, then the protocol's others,
/// highest first.
pub fn rate_order(protocol: DoctorProtocol, port_baud: u32) -> Vec<u32> {
    let mut rates = vec![port_baud];
    rates.extend(protocol.rates().iter().copied().filter(|&b| b != port_baud));
    rates
}

/// Statistics of the round trips (see [`RoundTrips`]).
fn round_trips(
    baud: u32,
    probes: u32,
    mut times: Vec<Duration>,
    wire: Duration,
) -> Option<RoundTrips> {
    if times.is_empty() {
        return None;
    }
    times.sort_unstable();
    let n = times.len();
    let us = |d: Duration| u64::try_from(d.as_micros()).unwrap_or(u64::MAX);
    // Nearest rank: ceil(0.95 n), 1-based.
    let p95 = (n * 95).div_ceil(100).max(1) - 1;
    Some(RoundTrips {
        baud,
        probes,
        answered: n as u32,
        min_us: us(times[0]),
        median_us: us(times[(n - 1) / 2]),
        p95_us: us(times[p95]),
        max_us: us(times[n - 1]),
        wire_us: us(wire),
    })
}

/// Milliseconds with three decimals, from microseconds.
pub fn ms(us: u64) -> String {
    format!("{}.{:03} ms", us / 1000, us % 1000)
}

/// Check the line (see the module docs). `open` opens the port at a rate
/// (echo stripping off); `port_baud` is the port's own rate;
/// `latency_timers` what the caller found in sysfs.
pub fn run(
    port: &str,
    port_baud: u32,
    open: &mut OpenAt<'_>,
    options: &DoctorOptions,
    latency_timers: Vec<LatencyTimer>,
) -> Result<DoctorReport, EngineError> {
    let protocol = options.protocol;
    let address = options.address.unwrap_or(protocol.default_address());
    let req = request(protocol, address).map_err(|refusal| {
        EngineError::refused(
            Target {
                port: port.to_string(),
                address,
            },
            refusal,
        )
    })?;
    let mut rates = Vec::new();
    let mut answering = Vec::new();
    let mut all: Vec<Probe> = Vec::new();
    let order = if options.fixed_rate.is_some() {
        vec![port_baud]
    } else {
        rate_order(protocol, port_baud)
    };
    for baud in order {
        let mut link = match open(baud) {
            Ok(l) => l,
            Err(LinkError::UnsupportedBaud { .. }) => continue,
            Err(e) => return Err(link_err(port, address, e)),
        };
        let mut first = probe(link.as_mut(), protocol, &req, options.timeout)
            .map_err(|e| link_err(port, address, e))?;
        if matches!(first.result, ProbeResult::Silent) {
            // One more try before calling a rate silent.
            first = probe(link.as_mut(), protocol, &req, options.timeout)
                .map_err(|e| link_err(port, address, e))?;
        }
        if matches!(first.result, ProbeResult::Answer { .. }) {
            answering.push(baud);
        }
        rates.push(RateResult {
            baud,
            result: first.result.clone(),
        });
        all.push(first);
    }
    // Round trips at the answering rate, the port's if it answers.
    let mut rtt = None;
    let mut measured = Vec::new();
    if let Some(&baud) = answering
        .iter()
        .find(|&&b| b == port_baud)
        .or(answering.first())
    {
        let mut link = open(baud).map_err(|e| link_err(port, address, e))?;
        let mut times = Vec::new();
        let mut answer_len = 0;
        for _ in 0..options.probes.max(1) {
            let p = probe(link.as_mut(), protocol, &req, options.timeout)
                .map_err(|e| link_err(port, address, e))?;
            if let (Some(t), ProbeResult::Answer { .. }) = (p.round_trip, &p.result) {
                times.push(t);
                answer_len = p.answer_len;
            }
            measured.push(p);
        }
        let wire = wire_time(req.len() + answer_len, baud);
        rtt = round_trips(baud, options.probes.max(1), times, wire);
        let _ = finish(link.as_mut(), protocol);
    }
    all.extend(measured.iter().cloned());
    let echo = EchoFinding {
        echo: all.iter().any(|p| p.echo == EchoVerdict::Echo),
        exchanges: all.iter().filter(|p| !p.received.is_empty()).count() as u32,
        echoed: all.iter().filter(|p| p.echo == EchoVerdict::Echo).count() as u32,
    };
    // Parity from the probes at rates that answered (bytes at a wrong rate
    // are framing garbage, not a parity finding).
    let mut parity = ParityFinding {
        bytes: 0,
        high_bit: 0,
        odd_weight: 0,
        bad_bcc: 0,
        garbled: 0,
        read_as_8_bits: false,
    };
    let at_answering: Vec<&Probe> = all
        .iter()
        .zip(
            rates
                .iter()
                .map(|r| Some(r.baud))
                .chain(std::iter::repeat(rtt.as_ref().map(|r| r.baud))),
        )
        .filter(|(_, b)| b.is_some_and(|b| answering.contains(&b)))
        .map(|(p, _)| p)
        .collect();
    for p in &at_answering {
        let skip = if p.echo == EchoVerdict::Echo {
            req.len()
        } else {
            0
        };
        for &b in p.received.iter().skip(skip) {
            parity.bytes += 1;
            parity.high_bit += u64::from(b & 0x80 != 0);
            parity.odd_weight += u64::from(b.count_ones() % 2 == 1);
        }
        parity.bad_bcc += u32::from(p.bad_bcc);
        parity.garbled += u32::from(matches!(p.result, ProbeResult::Garbled { .. }));
    }
    parity.read_as_8_bits = parity.high_bit > 0 && parity.odd_weight == 0;
    let mut report = DoctorReport {
        port: port.to_string(),
        protocol,
        address,
        probe: protocol.probe_name(),
        port_baud,
        rates,
        answering,
        fixed_rate: options.fixed_rate.clone(),
        round_trips: rtt,
        echo,
        parity,
        latency_timers,
        advice: Vec::new(),
    };
    report.advice = advice(&report);
    Ok(report)
}

/// Check a CAN bus (`--protocol can`): SDO reads of the schema's first
/// identification code from node `options.address` (default 1) at the
/// port's bit rate, [`DoctorOptions::probes`] times for the round trips.
/// Nothing is written; echo and parity do not apply (the CAN controller
/// checks every frame's CRC), the rate is the port's (`?bitrate=`).
pub fn run_can(
    link: &mut dyn driveset_link::FrameLink,
    schema: &std::sync::Arc<driveset_schema::Schema>,
    options: &DoctorOptions,
) -> Result<DoctorReport, EngineError> {
    use crate::scan::{ScanOptions, scan_can};
    let port = link.port().to_string();
    let node = options.address.unwrap_or(1);
    let scan = ScanOptions {
        timeout: Some(options.timeout),
        tries: 1,
    };
    let bitrate = link.bitrate();
    let mut times = Vec::new();
    let mut first = None;
    for _ in 0..options.probes.max(1) + 1 {
        let start = link.clock().now();
        let found = scan_can(link, schema, &[node], &scan)?;
        let took = link.clock().now() - start;
        let result = match found.first() {
            Some(f) => ProbeResult::Answer {
                value: f
                    .identity
                    .codes
                    .first()
                    .map(|c| format!("{} = {}", c.name, c.value))
                    .unwrap_or_default(),
            },
            None => ProbeResult::Silent,
        };
        let answered = matches!(result, ProbeResult::Answer { .. });
        if first.is_none() {
            first = Some(result);
            continue;
        }
        if answered {
            times.push(took);
        }
    }
    let first = first.unwrap_or(ProbeResult::Silent);
    let answering = if matches!(first, ProbeResult::Answer { .. }) || !times.is_empty() {
        vec![bitrate]
    } else {
        Vec::new()
    };
    // An expedited SDO request and its answer: two 8-byte data frames of
    // at most 135 bits each with worst-case stuffing (CAN 2.0A).
    let wire = driveset_link::mem::bits_time(2 * 135, bitrate);
    let mut report = DoctorReport {
        port,
        protocol: DoctorProtocol::CanSdo,
        address: node,
        probe: DoctorProtocol::CanSdo.probe_name(),
        port_baud: bitrate,
        rates: vec![RateResult {
            baud: bitrate,
            result: first,
        }],
        answering,
        fixed_rate: Some("a CAN bus runs at the port's bit rate (?bitrate=)".into()),
        round_trips: round_trips(bitrate, options.probes.max(1), times, wire),
        echo: EchoFinding {
            echo: false,
            exchanges: 0,
            echoed: 0,
        },
        parity: ParityFinding {
            bytes: 0,
            high_bit: 0,
            odd_weight: 0,
            bad_bcc: 0,
            garbled: 0,
            read_as_8_bits: false,
        },
        latency_timers: Vec::new(),
        advice: Vec::new(),
    };
    report.advice = advice(&report);
    Ok(report)
}

/// End the session: LUSTBUS / LECOM take a lone EOT.
fn finish(link: &mut dyn ByteLink, _protocol: DoctorProtocol) -> Result<(), LinkError> {
    link.send(&[driveset_proto::ascii::EOT])?;
    link.flush()
}

/// What to change, from the findings.
pub fn advice(r: &DoctorReport) -> Vec<String> {
    let mut out = Vec::new();
    let who = if r.address == 0 {
        "any drive (address 0)".to_string()
    } else {
        format!("address {}", r.address)
    };
    if r.answering.is_empty() && r.protocol == DoctorProtocol::CanSdo {
        out.push(format!(
            "no SDO answer from node {} at {} bit/s: check the bit rate (?bitrate= must match the drives' system bus rate), the termination (120 ohm at both ends of the bus), the node id (--address) and that the drives are powered",
            r.address, r.port_baud
        ));
    } else if r.answering.is_empty() {
        let garbled: Vec<String> = r
            .rates
            .iter()
            .filter(|x| matches!(x.result, ProbeResult::Garbled { .. }))
            .map(|x| x.baud.to_string())
            .collect();
        let mut line = format!(
            "nothing answered {who} at {} ({}): check the wiring (A/B swapped?), the termination, that the drive is powered and set to this address, and that the port runs 7E1 (on a tcp:// device server set 7E1 there, or use rfc2217:// so driveset sets it)",
            if r.fixed_rate.is_some() {
                "the port's rate"
            } else {
                "any rate"
            },
            r.rates
                .iter()
                .map(|x| x.baud.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        if !garbled.is_empty() {
            line.push_str(&format!(
                "; bytes came back garbled at {} baud: a drive at another rate, or several drives answering address 0 at once (give --address)",
                garbled.join(", ")
            ));
        }
        out.push(line);
    } else if !r.answering.contains(&r.port_baud) && r.protocol != DoctorProtocol::CanSdo {
        out.push(format!(
            "the drive answers at {} baud, not at the port's {}: add ?baud={} to the port (or set the drive to {} baud)",
            r.answering[0], r.port_baud, r.answering[0], r.port_baud
        ));
    }
    if r.answering.len() > 1 {
        out.push(format!(
            "answers at several rates ({} baud): drives on this line run at different rates; set them all to one",
            r.answering.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
        ));
    }
    if r.echo.echo {
        out.push(format!(
            "the line returns every byte driveset sends ({} of {} exchanges): a 2-wire RS-485 adapter without echo suppression; driveset strips it with ?echo=auto (the default) or ?echo=on, or switch the adapter's local echo off",
            r.echo.echoed, r.echo.exchanges
        ));
    }
    if r.parity.read_as_8_bits {
        out.push(format!(
            "{} of {} answer bytes have the parity bit in bit 7: the port reads 8 data bits on a 7E1 line (an adapter or device server left at 8N1); set it to 7 data bits, even parity, 1 stop bit (rfc2217:// sets it on the server); the drives may see driveset's characters with a wrong parity bit",
            r.parity.high_bit, r.parity.bytes
        ));
    } else if r.parity.high_bit > 0 {
        out.push(format!(
            "{} of {} answer bytes have bit 7 set with an odd weight: noise or a framing mismatch; check the termination, the shielding and that both ends run 7E1",
            r.parity.high_bit, r.parity.bytes
        ));
    }
    if r.parity.garbled > 0 && !r.answering.is_empty() {
        out.push(format!(
            "{} answers at the drive's rate were garbled ({} with a bad BCC): parity trouble (7E1 talked to as 8N1) or noise; check the port's framing, the termination and the cable",
            r.parity.garbled, r.parity.bad_bcc
        ));
    }
    if let Some(rt) = &r.round_trips {
        if rt.answered < rt.probes {
            out.push(format!(
                "{} of {} probes got no answer at {} baud: an unreliable line (termination, noise) or timeouts too short for its latency",
                rt.probes - rt.answered,
                rt.probes,
                rt.baud
            ));
        }
        // The drives react within 1 ms at the fastest (LUSTBUS 10); what
        // even the fastest round trip takes beyond the wire time and that
        // is the link's own latency. Jitter is not judged: the drives'
        // reaction times alone spread over tens of ms.
        let beyond = rt.min_us.saturating_sub(rt.wire_us);
        if beyond > 10_000 {
            out.push(format!(
                "even the fastest round trip took {} more than the wire time ({} against {}): the link adds latency (a device server's buffering, a USB adapter's latency timer); uploads take longer, and every answer timeout must cover it",
                ms(beyond),
                ms(rt.min_us),
                ms(rt.wire_us)
            ));
        }
    }
    for t in r.latency_timers.iter().filter(|t| t.this_port && t.ms > 1) {
        out.push(format!(
            "{}: the USB adapter's latency timer is {} ms, so every answer waits up to {} ms in the adapter: set it to 1 (echo 1 > {}, or a udev rule ATTR{{latency_timer}}=\"1\")",
            t.device, t.ms, t.ms, t.path
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
                value: "0000".into()
            }
        );
        assert!(!matches!(r.rates[0].result, ProbeResult::Answer { .. }));
        let rt = r.round_trips.clone().expect("round trips");
        assert_eq!((rt.baud, rt.probes, rt.answered), (19200, 20, 20));
        // Request `EOT A 00091 ENQ` (8) + answer `A STX 00091=0000 ETX
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
        // 21 answers of 14 bytes: `@ STX 00091=0000 ETX BCC`.
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
}
