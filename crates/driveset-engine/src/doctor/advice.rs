//! The doctor's advice lines: what to change (rate, address, parity, echo,
//! the USB adapter's latency timer), from the findings of a
//! [`DoctorReport`].

use super::{DoctorProtocol, DoctorReport, ProbeResult, ms};

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
