//! LECOM-A/B captures: [`driveset_proto::lecom::BusSniffer`] events annotated
//! with the Tmd schema (code names, VD values with units), C0068 / C1962
//! values and the meaning of `?`, `STX C1 C2 EOT`, ACK and NAK replies.
//!
//! The decoder follows each controller's C0249 code bank and C0248 input
//! selection as the capture writes them (sections 8.B, 8.C): a SEND of
//! C0249 = 7 that the controller ACKs, or a BROADCAST of it, makes a later
//! standard-addressed C0173 name C1923, through the same
//! [`StandardAddressing`] the simulated Tmd resolves telegrams with.
//! Replies the protocol rules out are errors (exit 1): any reply to a
//! telegram for a broadcast or group address (8.J: none acknowledges).

use driveset_proto::lecom::{
    AddressKind, BusSniffer, CodeAddress, ControllerAddress, Direction, ExchangeFailure,
    ExtendedError, Frame, FrameError, HostFrame, OperatingStatus, Response, StandardAddressing,
    StreamError, Telegram, Value,
};
use driveset_schema::{RawValue, ValueType, validate::display_value};

use super::event::{Bcc, DRIVE_TO_HOST, Event, HOST_TO_DRIVE, slice};
use super::{Context, garbage_event};

fn address_text(a: ControllerAddress) -> String {
    match a.kind() {
        AddressKind::All => format!("{a} (broadcast to all)"),
        AddressKind::Group(t) => format!("{a} (multicast to {t}1..{t}9)"),
        AddressKind::Station => a.to_string(),
    }
}

fn direction(d: Direction) -> Option<&'static str> {
    match d {
        Direction::HostToController => Some(HOST_TO_DRIVE),
        Direction::ControllerToHost => Some(DRIVE_TO_HOST),
        Direction::Unknown => None,
    }
}

/// C0249 / C0248 of every controller as far as the capture shows them
/// (power-on state until a write is seen).
#[derive(Default)]
struct Selectors {
    /// What a BROADCAST to 00 set.
    all: StandardAddressing,
    /// What a multicast to x0 set, by tens digit.
    groups: [Option<StandardAddressing>; 10],
    /// What a SEND to one station set (once ACKed).
    stations: std::collections::BTreeMap<u8, StandardAddressing>,
}

impl Selectors {
    /// The state a telegram to `a` is resolved with.
    fn get(&self, a: ControllerAddress) -> StandardAddressing {
        let n = a.get();
        let group = || self.groups[usize::from(n / 10)].unwrap_or(self.all);
        match a.kind() {
            AddressKind::All => self.all,
            AddressKind::Group(_) => group(),
            AddressKind::Station => self.stations.get(&n).copied().unwrap_or_else(group),
        }
    }

    /// `code = value` reached `a` (an ACKed SEND or a BROADCAST).
    fn written(&mut self, a: ControllerAddress, code: CodeAddress, value: &Value) {
        let Value::Decimal(d) = value else { return };
        let Some(v) = d.as_integer() else { return };
        let n = a.get();
        match a.kind() {
            AddressKind::All => {
                if let Some(next) = self.all.after_write(code, v) {
                    self.all = next;
                    self.groups = [None; 10];
                    self.stations.clear();
                }
            }
            AddressKind::Group(t) => {
                if let Some(next) = self.get(a).after_write(code, v) {
                    self.groups[usize::from(t)] = Some(next);
                    self.stations.retain(|s, _| s / 10 != t);
                }
            }
            AddressKind::Station => {
                if let Some(next) = self.get(a).after_write(code, v) {
                    self.stations.insert(n, next);
                }
            }
        }
    }
}

/// The code a field names under `sel`: number and subcode.
fn target(sel: StandardAddressing, code: CodeAddress) -> (u16, u8) {
    sel.resolve(code)
}

fn code_fields(ctx: &Context, ev: &mut Event, code: CodeAddress, sel: StandardAddressing) {
    let (number, sub) = target(sel, code);
    ev.code = Some(if sub == 0 {
        format!("C{number:04}")
    } else {
        format!("C{number:04}/{sub}")
    });
    if let CodeAddress::Standard(c) = code
        && (number != c.get() || sub != 0)
    {
        ev.details.push(format!(
            "sent as {c} with code bank {} (C0249) and input selection {} (C0248): {} (8.B, 8.C)",
            sel.bank.get(),
            sel.input_selection,
            ev.code.as_deref().unwrap_or("")
        ));
    }
    if let Some(s) = &ctx.schema
        && let Some(c) = s.code(u32::from(number))
        && !c.name.is_empty()
    {
        ev.name = Some(c.name.clone());
    }
}

fn value_fields(ctx: &Context, ev: &mut Event, number: u16, value: &Value) {
    ev.raw_value = Some(value.to_string());
    match number {
        68 => {
            if let Ok(s) = OperatingStatus::from_value(value) {
                for (name, state) in s.describe() {
                    ev.details.push(format!("{name}: {state}"));
                }
                let c = s.last_communication_error();
                if c.nibble() != 0 {
                    ev.meaning = Some(format!("last communication error: {}", c.text()));
                }
            }
        }
        1962 => {
            if let Ok(x) = ExtendedError::from_value(value) {
                ev.meaning = Some(format!("error {}: {}", x.code(), x.text()));
            }
        }
        _ => {}
    }
    let Some(schema) = &ctx.schema else { return };
    let Some(c) = schema.code(u32::from(number)) else {
        return;
    };
    if schema.is_password(c) {
        ev.secret = true;
        return;
    }
    let ty = schema.type_of(c);
    let (raw, fits) = match value {
        Value::Decimal(d) => (RawValue::Int(d.raw()), ty == Some(ValueType::VD)),
        Value::Hex(h) => (RawValue::Int(i64::from(h.get())), ty == Some(ValueType::VH)),
        Value::String(s) => (
            RawValue::Text(s.as_str().to_string()),
            ty == Some(ValueType::VS),
        ),
        Value::Octets(o) => (
            RawValue::Octets(o.as_bytes().to_vec()),
            ty == Some(ValueType::VO),
        ),
    };
    if !fits {
        if let Some(t) = ty {
            ev.details.push(format!(
                "the schema gives {} as {}; this value is in another format",
                schema.display_code(c.number, None),
                t.name()
            ));
        }
        return;
    }
    if !c.bits.is_empty() && number == 68 {
        return;
    }
    let shown = display_value(schema, c, &raw);
    ev.value = Some(shown);
}

/// Decodes a LECOM-A/B capture.
pub fn decode(capture: &[u8], ctx: &Context, out: &mut dyn FnMut(Event)) {
    let mut last: Option<(Telegram, StandardAddressing)> = None;
    // whether the last telegram had a bad BCC (the controller discarded it)
    let mut last_bad = false;
    let mut selectors = Selectors::default();
    // each frame is annotated as the sniffer finds it (no list of the
    // capture's frames is kept)
    let mut on = |ev: driveset_proto::lecom::stream::Event<Frame>| {
        let (start, end) = (ev.range.start, ev.range.end);
        let bytes = slice(capture, start, end);
        let mut bad_bcc = None;
        let frame = match ev.result {
            Ok(f) => f,
            Err(StreamError::Garbage { len }) => {
                out(garbage_event(capture, start, end, len));
                return;
            }
            Err(StreamError::Frame(FrameError::BadBcc { expected, found })) => {
                let mut fixed = bytes.to_vec();
                if let Some(l) = fixed.last_mut() {
                    *l = expected;
                }
                let redone = match ev.direction {
                    Direction::HostToController => Telegram::decode(&fixed)
                        .ok()
                        .map(|t| Frame::Host(HostFrame::Telegram(t))),
                    _ => Response::decode(&fixed).ok().map(Frame::Controller),
                };
                match redone {
                    Some(f) => {
                        bad_bcc = Some((found, expected));
                        f
                    }
                    None => {
                        out(Event::error(
                            capture,
                            start,
                            end,
                            direction(ev.direction),
                            StreamError::Frame(FrameError::BadBcc { expected, found }).to_string(),
                        ));
                        return;
                    }
                }
            }
            Err(err) => {
                out(Event::error(
                    capture,
                    start,
                    end,
                    direction(ev.direction),
                    err.to_string(),
                ));
                return;
            }
        };
        let mut e = Event::new(capture, start, end, "");
        e.direction = direction(ev.direction);
        let mut has_bcc = false;
        match frame {
            Frame::Host(HostFrame::EndOfTransmission) => {
                e.kind = "EOT";
                e.direction = Some(HOST_TO_DRIVE);
                e.meaning = Some("end of transmission".into());
            }
            Frame::Host(HostFrame::Telegram(t)) => {
                e.direction = Some(HOST_TO_DRIVE);
                e.address = Some(address_text(t.address()));
                let sel = selectors.get(t.address());
                code_fields(ctx, &mut e, t.code(), sel);
                let (number, _) = target(sel, t.code());
                match t {
                    Telegram::Receive(_) => e.kind = "RECEIVE",
                    Telegram::Send(s) => {
                        e.kind = "SEND";
                        value_fields(ctx, &mut e, number, &s.value);
                        has_bcc = true;
                    }
                    Telegram::Broadcast(b) => {
                        e.kind = "BROADCAST";
                        value_fields(ctx, &mut e, number, &b.value);
                        e.meaning = Some("no controller answers a broadcast".into());
                        has_bcc = true;
                        if bad_bcc.is_none() {
                            selectors.written(b.address, b.code, &b.value);
                        }
                    }
                }
                last = Some((t, sel));
                last_bad = bad_bcc.is_some();
            }
            Frame::Controller(r) => {
                e.direction = Some(DRIVE_TO_HOST);
                if let Some((t, _)) = last {
                    e.address = Some(address_text(t.address()));
                    if t.address().kind() != AddressKind::Station {
                        e.error = Some(format!(
                            "no controller answers a telegram to {} (broadcast / multicast, 8.J): this reply cannot come from it",
                            address_text(t.address())
                        ));
                    }
                }
                let sel = last.map(|(_, s)| s).unwrap_or_default();
                match r {
                    Response::Value { code, value } => {
                        e.kind = "VALUE";
                        code_fields(ctx, &mut e, code, sel);
                        let (number, _) = target(sel, code);
                        value_fields(ctx, &mut e, number, &value);
                        has_bcc = true;
                        if let Some((t, _)) = last
                            && t.code() != code
                        {
                            e.meaning =
                                Some(format!("answers {}, but {} was asked", code, t.code()));
                        }
                    }
                    Response::ChecksumFault { code } => {
                        e.kind = "?";
                        code_fields(ctx, &mut e, code, sel);
                        e.meaning = Some(ExchangeFailure::ChecksumFaultReply.text().into());
                        has_bcc = true;
                    }
                    Response::NoSuchCode { code } => {
                        e.kind = "NO CODE";
                        code_fields(ctx, &mut e, code, sel);
                        e.meaning = Some(ExchangeFailure::NoSuchCode.text().into());
                    }
                    Response::Ack => {
                        e.kind = "ACK";
                        e.meaning = Some(match last {
                            Some((Telegram::Send(s), sel)) => {
                                let (n, sub) = target(sel, s.code);
                                if !last_bad && e.error.is_none() {
                                    selectors.written(s.address, s.code, &s.value);
                                }
                                if StandardAddressing::is_selector(s.code) {
                                    let now = selectors.get(s.address);
                                    e.details.push(format!(
                                        "from now on standard addressing of {} uses code bank {} (C0249) and input selection {} (C0248)",
                                        s.address,
                                        now.bank.get(),
                                        now.input_selection
                                    ));
                                }
                                if sub == 0 {
                                    format!("SEND of C{n:04} carried out")
                                } else {
                                    format!("SEND of C{n:04}/{sub} carried out")
                                }
                            }
                            _ => "carried out".into(),
                        });
                    }
                    Response::Nak => {
                        e.kind = "NAK";
                        e.meaning = Some(match last {
                            Some((Telegram::Send(s), sel)) => {
                                let (n, sub) = target(sel, s.code);
                                let shown = if sub == 0 {
                                    format!("C{n:04}")
                                } else {
                                    format!("C{n:04}/{sub}")
                                };
                                format!(
                                    "SEND of {shown} not carried out, the value is unchanged; read C0068 bits 4..7 or C1962 for the reason"
                                )
                            }
                            _ => ExchangeFailure::Nak.text().into(),
                        });
                    }
                }
            }
        }
        if has_bcc {
            e.bcc = match bad_bcc {
                Some((found, expected)) => {
                    e.error = Some("BCC mismatch: the receiver discards this telegram".into());
                    Some(Bcc::mismatch(found, expected))
                }
                None => Bcc::of_telegram(bytes),
            };
        }
        out(e);
    };
    let mut sniffer = BusSniffer::new();
    sniffer.feed(capture, &mut on);
    sniffer.finish(&mut on);
}
