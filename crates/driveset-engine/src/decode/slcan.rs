//! slcan (Lawicel) captures: one event per line (CR, LF or BELL ends it);
//! frames on the SDO COB-IDs (0x600 + node requests, 0x580 + node
//! responses) are decoded as SDO and their index mapped to the Lenze code
//! (code = 24575 - index).

use driveset_proto::can::{
    CanFrame, CodeNumber, Fix32, Index, SdoRequest, SdoResponse, SlcanCommand, SlcanResponse,
    Subindex, ValueFormat,
};
use driveset_schema::ValueType;

use super::Context;
use super::event::{DRIVE_TO_HOST, Event, HOST_TO_DRIVE};

const HOST_TO_ADAPTER: &str = "host -> adapter";
const ADAPTER_TO_HOST: &str = "adapter -> host";

/// Decodes an slcan capture.
pub fn decode(capture: &[u8], ctx: &Context, out: &mut dyn FnMut(Event)) {
    let mut start = 0usize;
    let mut last_request: Option<(u8, SdoRequest)> = None;
    for (i, &b) in capture.iter().enumerate() {
        if matches!(b, b'\r' | b'\n' | 0x07) {
            let line = &capture[start..i];
            if !(line.is_empty() && b == b'\n') {
                let end = if b == 0x07 && !line.is_empty() {
                    i
                } else {
                    i + 1
                };
                if !line.is_empty() || b == b'\r' {
                    out(line_event(
                        capture,
                        start,
                        end,
                        line,
                        ctx,
                        &mut last_request,
                    ));
                }
                if b == 0x07 {
                    let mut e = Event::new(capture, i as u64, i as u64 + 1, "BELL");
                    e.direction = Some(ADAPTER_TO_HOST);
                    e.meaning = Some("the adapter refused the last command".into());
                    out(e);
                }
            }
            start = i + 1;
        }
    }
    if start < capture.len() {
        let line = &capture[start..];
        let mut e = line_event(capture, start, capture.len(), line, ctx, &mut last_request);
        e.details.push("line not ended by CR".into());
        out(e);
    }
}

fn line_event(
    capture: &[u8],
    start: usize,
    end: usize,
    line: &[u8],
    ctx: &Context,
    last: &mut Option<(u8, SdoRequest)>,
) -> Event {
    let mut e = Event::new(capture, start as u64, end as u64, "");
    if line.is_empty() {
        e.kind = "OK";
        e.direction = Some(ADAPTER_TO_HOST);
        e.meaning = Some("CR: command accepted (or an empty command line)".into());
        return e;
    }
    let first = line[0];
    if matches!(first, b't' | b'T' | b'r' | b'R' | b'x') {
        match SlcanResponse::decode(line) {
            Ok(SlcanResponse::Received { frame, timestamp }) => {
                frame_event(&mut e, &frame, ctx, last);
                if let Some(t) = timestamp {
                    e.details.push(format!("timestamp {t} ms"));
                }
            }
            Ok(_) => {}
            Err(err) => {
                e.kind = "ERROR";
                e.error = Some(format!("{err}: {:?}", String::from_utf8_lossy(line)));
            }
        }
        return e;
    }
    match SlcanCommand::decode(line) {
        Ok(c) => {
            e.direction = Some(HOST_TO_ADAPTER);
            e.kind = "COMMAND";
            e.meaning = Some(match c {
                SlcanCommand::SetBitrate(b) => format!("set bitrate {} bit/s", b.bits_per_second()),
                SlcanCommand::SetBtr { btr0, btr1 } => {
                    format!("set BTR0 0x{btr0:02X} BTR1 0x{btr1:02X}")
                }
                SlcanCommand::Open => "open the channel".into(),
                SlcanCommand::ListenOnly => "open the channel listen-only".into(),
                SlcanCommand::Close => "close the channel".into(),
                SlcanCommand::Transmit(_) => "transmit".into(),
                SlcanCommand::Version => "ask for the version".into(),
                SlcanCommand::SerialNumber => "ask for the serial number".into(),
                SlcanCommand::StatusFlags => "ask for the status flags".into(),
                SlcanCommand::Timestamps(on) => {
                    format!("timestamps {}", if on { "on" } else { "off" })
                }
                SlcanCommand::Empty => "empty line".into(),
            });
        }
        Err(cmd_err) => match SlcanResponse::decode(line) {
            Ok(r) => {
                e.direction = Some(ADAPTER_TO_HOST);
                e.kind = "REPLY";
                e.meaning = Some(match r {
                    SlcanResponse::TransmitAck { extended } => format!(
                        "{} frame queued for transmission",
                        if extended { "extended" } else { "standard" }
                    ),
                    SlcanResponse::Version(v) => {
                        format!("version {}", String::from_utf8_lossy(&v))
                    }
                    SlcanResponse::SerialNumber(v) => {
                        format!("serial number {}", String::from_utf8_lossy(&v))
                    }
                    SlcanResponse::StatusFlags(f) => format!("status flags 0x{f:02X}"),
                    SlcanResponse::Ok => "command accepted".into(),
                    SlcanResponse::Error => "command refused".into(),
                    SlcanResponse::Received { .. } => String::new(),
                });
            }
            Err(_) => {
                e.kind = "ERROR";
                e.error = Some(format!("{cmd_err}: {:?}", String::from_utf8_lossy(line)));
            }
        },
    }
    e
}

fn mux(ctx: &Context, e: &mut Event, index: Index, sub: Subindex) -> Option<CodeNumber> {
    let Ok(code) = CodeNumber::from_index(index) else {
        e.code = Some(format!("index {index}/{sub}"));
        return None;
    };
    let n = u32::from(code.get());
    let subcode = (sub.0 != 0).then_some(u32::from(sub.0));
    e.code = Some(match subcode {
        Some(s) => format!("{code}/{s}"),
        None => code.to_string(),
    });
    let mut name = format!("index {index} subindex {sub}");
    if let Some(s) = &ctx.schema
        && let Some(c) = s.code(n)
        && !c.name.is_empty()
    {
        name = format!("{}, {name}", c.name);
    }
    e.name = Some(name);
    Some(code)
}

fn value_text(ctx: &Context, e: &mut Event, code: Option<CodeNumber>, data: &[u8]) {
    let mut four = [0u8; 4];
    for (d, s) in four.iter_mut().zip(data) {
        *d = *s;
    }
    let raw = u32::from_le_bytes(four);
    e.raw_value = Some(format!("0x{raw:08X}"));
    let Some(code) = code else { return };
    let schema_code = ctx.schema.as_ref().and_then(|s| {
        s.code(u32::from(code.get()))
            .map(|c| (s.clone(), c.clone()))
    });
    if schema_code.as_ref().is_some_and(|(s, c)| s.is_password(c)) {
        e.secret = true;
        return;
    }
    let format = match schema_code.as_ref().and_then(|(s, c)| s.type_of(c)) {
        Some(ValueType::BITCODED) => ValueFormat::BitCoded,
        Some(ValueType::FIX32) => ValueFormat::Fix32,
        _ => code.value_format(),
    };
    let unit = schema_code
        .as_ref()
        .and_then(|(_, c)| c.unit.clone())
        .map(|u| format!(" {u}"))
        .unwrap_or_default();
    e.value = Some(match format {
        ValueFormat::Fix32 => {
            let f = Fix32::from_le_bytes(four);
            format!("{f}{unit} (FIX32 {}/10000)", f.raw())
        }
        ValueFormat::BitCoded => format!("0x{raw:08X} (bit-coded, no factor)"),
    });
}

fn frame_event(
    e: &mut Event,
    frame: &CanFrame,
    ctx: &Context,
    last: &mut Option<(u8, SdoRequest)>,
) {
    let id = frame.id;
    let sdo = !frame.extended && !frame.rtr;
    if sdo && (0x601..=0x67F).contains(&id) {
        let node = (id - 0x600) as u8;
        e.direction = Some(HOST_TO_DRIVE);
        e.address = Some(format!("node {node}"));
        match SdoRequest::decode(frame.payload()) {
            Ok(r) => {
                request_fields(e, &r, ctx);
                *last = Some((node, r));
            }
            Err(err) => {
                e.kind = "ERROR";
                e.error = Some(format!("COB-ID 0x{id:03X}: {err}"));
            }
        }
        return;
    }
    if sdo && (0x581..=0x5FF).contains(&id) {
        let node = (id - 0x580) as u8;
        e.direction = Some(DRIVE_TO_HOST);
        e.address = Some(format!("node {node}"));
        match SdoResponse::decode(frame.payload()) {
            Ok(r) => response_fields(e, &r, ctx, last.filter(|(n, _)| *n == node).map(|x| x.1)),
            Err(err) => {
                e.kind = "ERROR";
                e.error = Some(format!("COB-ID 0x{id:03X}: {err}"));
            }
        }
        return;
    }
    e.kind = "FRAME";
    e.direction = Some("bus");
    let data: Vec<String> = frame.payload().iter().map(|b| format!("{b:02X}")).collect();
    e.meaning = Some(format!(
        "CAN {} id 0x{id:X} [{}] {}: not an SDO frame",
        if frame.extended { "29-bit" } else { "11-bit" },
        frame.len,
        if frame.rtr {
            "remote".to_string()
        } else {
            data.join(" ")
        }
    ));
}

fn request_fields(e: &mut Event, r: &SdoRequest, ctx: &Context) {
    match *r {
        SdoRequest::Write {
            index,
            subindex,
            data,
        } => {
            e.kind = "WRITE";
            let code = mux(ctx, e, index, subindex);
            value_text(ctx, e, code, data.as_bytes());
        }
        SdoRequest::InitiateWrite {
            index,
            subindex,
            size,
        } => {
            e.kind = "WRITE";
            mux(ctx, e, index, subindex);
            e.meaning = Some(match size {
                Some(n) => format!("initiate segmented write of {n} bytes"),
                None => "initiate segmented write".into(),
            });
        }
        SdoRequest::WriteSegment { toggle, data, last } => {
            e.kind = "SEGMENT";
            e.raw_value = Some(super::hex_spaced(data.as_bytes()));
            e.meaning = Some(format!(
                "write segment, toggle {}{}",
                u8::from(toggle),
                if last { ", last" } else { "" }
            ));
        }
        SdoRequest::Read { index, subindex } => {
            e.kind = "READ";
            mux(ctx, e, index, subindex);
        }
        SdoRequest::ReadSegment { toggle } => {
            e.kind = "SEGMENT";
            e.meaning = Some(format!("read segment request, toggle {}", u8::from(toggle)));
        }
        SdoRequest::Abort(a) => {
            e.kind = "ABORT";
            mux(ctx, e, a.index, a.subindex);
            e.meaning = Some(format!("the host aborts the transfer: {}", a.code));
        }
    }
}

fn response_fields(e: &mut Event, r: &SdoResponse, ctx: &Context, req: Option<SdoRequest>) {
    match *r {
        SdoResponse::WriteAck { index, subindex } => {
            e.kind = "WRITE OK";
            let code = mux(ctx, e, index, subindex);
            e.meaning = Some(match (req, code) {
                (Some(SdoRequest::Write { .. } | SdoRequest::InitiateWrite { .. }), Some(c)) => {
                    format!("write of {c} acknowledged")
                }
                _ => "write acknowledged".into(),
            });
        }
        SdoResponse::WriteSegmentAck { toggle } => {
            e.kind = "SEGMENT";
            e.meaning = Some(format!(
                "write segment acknowledged, toggle {}",
                u8::from(toggle)
            ));
        }
        SdoResponse::ReadValue {
            index,
            subindex,
            data,
        } => {
            e.kind = "VALUE";
            let code = mux(ctx, e, index, subindex);
            value_text(ctx, e, code, data.as_bytes());
        }
        SdoResponse::InitiateRead {
            index,
            subindex,
            size,
        } => {
            e.kind = "VALUE";
            mux(ctx, e, index, subindex);
            e.meaning = Some(match size {
                Some(n) => format!("segmented read of {n} bytes follows"),
                None => "segmented read follows".into(),
            });
        }
        SdoResponse::ReadSegment { toggle, data, last } => {
            e.kind = "SEGMENT";
            e.raw_value = Some(super::hex_spaced(data.as_bytes()));
            e.meaning = Some(format!(
                "read segment, toggle {}{}",
                u8::from(toggle),
                if last { ", last" } else { "" }
            ));
        }
        SdoResponse::Abort(a) => {
            e.kind = "ABORT";
            mux(ctx, e, a.index, a.subindex);
            e.meaning = Some(format!("the drive refuses: {}", a.code));
            if let Some(h) = a.code.hint() {
                e.details.push(format!("what to do: {h}"));
            }
        }
    }
}
