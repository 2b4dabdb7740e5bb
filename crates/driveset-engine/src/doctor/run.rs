//! The doctor's runs: a serial line at every rate ([`run`], LUSTBUS 5.1,
//! LECOM-A/B C0125 rates) and a CAN bus at the port's bit rate
//! ([`run_can`], SDO reads only).

use driveset_link::echo::EchoVerdict;
use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, LinkError};

use super::probe::{Probe, link_err, probe, request, round_trips};
use super::{
    DoctorOptions, DoctorProtocol, DoctorReport, DoctorRules, EchoFinding, LatencyTimer, OpenAt,
    ParityFinding, ProbeResult, RateResult, advice, rate_order,
};
use crate::client::Target;
use crate::error::EngineError;

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
    let mut parity = ParityFinding::default();
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
        ..ScanOptions::default()
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
        parity: ParityFinding::default(),
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
