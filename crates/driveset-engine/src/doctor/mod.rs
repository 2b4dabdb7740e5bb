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
//! decides itself with [`detect_echo`](driveset_link::echo::detect_echo), then strips the echo before
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
//!
//! # Rooms
//!
//! - this file: the options, the report and its findings;
//! - `probe`: one read-only exchange (request bytes, decoding, echo and
//!   parity evidence) and the round-trip statistics;
//! - [`run`]: the check of a serial line ([`run()`]) and of a CAN bus
//!   ([`run_can`]);
//! - [`advice`]: what to change, from the findings ([`advice()`]).

mod advice;
mod probe;
mod run;
#[cfg(test)]
mod tests;

use std::time::Duration;

use driveset_link::{ByteLink, Link, LinkError, PortSpec};
use serde::Serialize;

use crate::scan::{LECOM_BAUDS, LUSTBUS_BAUDS};
use crate::session::SessionError;

pub use advice::advice;
pub use probe::DoctorRefusal;
pub use probe::{ms, rate_order};
pub use run::{run, run_can};

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
    /// Why only the port's own rate can be tried on `spec`, if so
    /// ([`DoctorOptions::fixed_rate`]): a raw `tcp://` device server's line
    /// rate is set on the server (`rfc2217://` lets driveset set it); a
    /// pseudo terminal has none.
    pub fn fixed_rate_of(spec: &PortSpec) -> Option<String> {
        match spec {
            PortSpec::Tcp { .. } => Some(
                "a raw tcp:// device server's line rate is set on the server (rfc2217:// lets driveset set it)".into(),
            ),
            PortSpec::Serial { path, .. } if path.starts_with("/dev/pts/") => {
                Some("a pseudo terminal has no line rate".into())
            }
            _ => None,
        }
    }

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

/// Parity: what the received bytes say (see the module docs). The
/// default is a line with nothing received (and nothing found).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
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

/// A USB serial adapter's latency timer, read by the caller
/// (driveset-link's [`driveset_link::usb::latency_timers`]).
pub use driveset_link::usb::LatencyTimer;

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

    /// The check in one word: nothing answered, or a drive answered with
    /// advice or without.
    pub fn verdict(&self) -> DoctorVerdict {
        if !self.answered() {
            DoctorVerdict::Silent
        } else if self.advice.is_empty() {
            DoctorVerdict::Fine
        } else {
            DoctorVerdict::Advice
        }
    }
}

/// [`DoctorReport::verdict`]: the CLI maps it to its exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DoctorVerdict {
    /// A drive answers and nothing needs changing.
    Fine,
    /// A drive answers, but there is advice.
    Advice,
    /// Nothing answered at any rate.
    Silent,
}

/// The protocol to check on `link` when none is given: CAN SDO on a CAN
/// port; on a character line the drive's, by the read-only probes
/// `identify` and `scan` use ([`crate::session::detect`]) at `address`,
/// else LUSTBUS address 1 and LECOM station 01; the same on every port.
///
/// # Errors
/// [`SessionError`]: nothing answered the probes, or the link failed.
pub fn protocol_on(
    link: &mut Link,
    port: &str,
    address: Option<u8>,
    latency: Option<Duration>,
) -> Result<DoctorProtocol, SessionError> {
    if matches!(link, Link::Frames(_)) {
        return Ok(DoctorProtocol::CanSdo);
    }
    let (family, _) = crate::session::detect(link, port, address.unwrap_or(1), latency)?;
    Ok(family.bus())
}

/// `link`, reopened by the caller for a rate, as [`run`] probes that rate
/// with it: a character line, the host's side set to `baud` whatever
/// transport it is (the drives keep their own rates); a CAN port
/// (`port`) is refused.
///
/// # Errors
/// [`LinkError::Unsupported`] on a CAN port; the rate not set.
pub fn line_at(link: Link, port: &str, baud: u32) -> Result<Box<dyn ByteLink>, LinkError> {
    match link {
        Link::Bytes(mut l) => {
            if l.baud() != baud {
                l.set_baud(baud)?;
            }
            Ok(l)
        }
        Link::Frames(_) => Err(LinkError::Unsupported {
            port: port.to_string(),
            what: "a CAN port".into(),
        }),
    }
}

/// Opens the line at a rate, without echo stripping.
pub type OpenAt<'a> = dyn FnMut(u32) -> Result<Box<dyn ByteLink>, LinkError> + 'a;
