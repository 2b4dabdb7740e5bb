//! One read-only probe of the doctor (module docs of [`super`]): the request
//! bytes (LUSTBUS ENQUIRY of 91-TYPE, section 5.2; LECOM RECEIVE of C0093),
//! the raw answer with its echo and parity evidence, and the round-trip
//! statistics over the probes at the answering rate.

use std::time::Duration;

use driveset_link::echo::{EchoVerdict, detect_echo};
use driveset_link::{ByteLink, Instant, LinkError};
use driveset_proto::lecom::{ControllerAddress, Receive, Response, ResponseDecoder, Telegram};
use driveset_proto::lustbus::{Address, Enquiry, ParameterCode, Reply, ReplyDecoder};
use driveset_schema::BusProtocol;

use super::{DoctorProtocol, DoctorRules, ProbeResult, RoundTrips};
use crate::client::Target;
use crate::error::{AddressRefused, EngineError, Refusal};

/// What `doctor` refuses before it probes (beside the address rule,
/// [`AddressRefused`]). Gathered into [`Refusal`] as `Refusal::Doctor`,
/// with the JSON kind journals hold (`doctor_can_port`).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize, thiserror::Error)]
#[serde(tag = "kind")]
pub enum DoctorRefusal {
    /// A CAN port given to the character-line check.
    #[error("CAN ports are checked by run_can")]
    #[serde(rename = "doctor_can_port")]
    CanPort,
}

/// One probe: the request, what came back, when.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Probe {
    pub(super) result: ProbeResult,
    /// Raw bytes received (echo included).
    pub(super) received: Vec<u8>,
    pub(super) echo: EchoVerdict,
    /// Bytes of the answer (after the echo).
    pub(super) answer_len: usize,
    pub(super) bad_bcc: bool,
    pub(super) round_trip: Option<Duration>,
}

pub(super) fn link_err(port: &str, address: u8, source: LinkError) -> EngineError {
    EngineError::link(
        Target {
            port: port.to_string(),
            address,
        },
        source,
    )
}

/// The request bytes.
pub(super) fn request(protocol: DoctorProtocol, address: u8) -> Result<Vec<u8>, Refusal> {
    match protocol {
        DoctorProtocol::Lustbus => {
            AddressRefused::check_doctor(BusProtocol::Lustbus, address)?;
            let ad = Address::new(address).ok_or_else(|| address_encode(address))?;
            let code = ParameterCode::new(91).ok_or(Refusal::Encode {
                what: None,
                detail: "CODE 00091".into(),
            })?;
            Ok(Enquiry::new(ad, code).encode().to_vec())
        }
        DoctorProtocol::Lecom => {
            AddressRefused::check_doctor(BusProtocol::Lecom, address)?;
            let ad = ControllerAddress::new(address).ok_or_else(|| address_encode(address))?;
            let code = driveset_proto::lecom::CodeAddress::select(93, 0);
            Telegram::Receive(Receive { address: ad, code })
                .to_bytes()
                .map_err(|e| Refusal::Encode {
                    what: None,
                    detail: e.to_string(),
                })
        }
        DoctorProtocol::CanSdo => Err(DoctorRefusal::CanPort.into()),
    }
}

/// The codec could not carry an address the rule took (it takes only
/// addresses the codec carries).
fn address_encode(address: u8) -> Refusal {
    Refusal::Encode {
        what: None,
        detail: format!("address {address}"),
    }
}

/// Decode `bytes` (echo removed) as an answer. `Ok(Some)` for an answer,
/// `Err(detail, bad_bcc)` for garbage so far, `Ok(None)` for nothing yet.
pub(super) fn decode(
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
pub(super) fn probe(
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
pub(super) fn round_trips(
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
