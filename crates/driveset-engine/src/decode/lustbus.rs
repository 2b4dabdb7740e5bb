//! LUSTBUS captures: [`driveset_proto::lustbus::Sniffer`] events annotated
//! with the schema of the device family (code names, typed values), the
//! meaning of ACK / NAK / EOT and the 85-SIOF/SERR bits.

use std::sync::Arc;

use driveset_proto::lustbus::{
    Address, CodeMeaning, CompatibleParameter, Dialect, Direction, FrameError, ParameterCode,
    ParameterType, ParameterValue, Reply, Request, Siof, Sniffer, Telegram, codec,
};
use driveset_schema::{RawValue, Schema, validate::display_value};

use super::event::{Bcc, DRIVE_TO_HOST, Event, HOST_TO_DRIVE, slice};
use super::{Context, garbage_event};

/// Schema id of the built-in schema of the family speaking `family`
/// (the descriptor's `schema_id`).
pub fn family_schema_id(family: Dialect) -> &'static str {
    driveset_schema::Family::from_dialect(family)
        .descriptor()
        .schema_id
}

/// The family a CODE belongs to, when its layout says so.
pub fn family_of(code: ParameterCode) -> Option<Dialect> {
    if code.compatible_parameter().is_some() {
        return None;
    }
    match code.meaning() {
        CodeMeaning::VfValue { .. } | CodeMeaning::VfDescription { .. } => Some(Dialect::Vf1000),
        CodeMeaning::McValue { .. }
        | CodeMeaning::McDescription { .. }
        | CodeMeaning::SubstitutionText { .. }
        | CodeMeaning::PosMod => Some(Dialect::Mc),
        CodeMeaning::Other => None,
    }
}

/// The schema code number a CODE reads or writes (the parameter number), if
/// it is a value access.
pub fn value_parameter(code: ParameterCode) -> Option<u32> {
    if let Some(c) = code.compatible_parameter() {
        return Some(u32::from(c.number()));
    }
    match code.meaning() {
        CodeMeaning::VfValue { parameter, .. } => Some(u32::from(parameter)),
        CodeMeaning::McValue { parameter } => Some(u32::from(parameter)),
        _ => None,
    }
}

/// The wire type of a schema code (`PT_FIXPOINT16` ...): proto's one
/// table, [`ParameterType::of_code`], over the code's resolved type (its
/// own, else the schema's `default_type`). A code the schema gives no type
/// at all is not annotated: a capture shows only what the schema says,
/// where the client would fall back on the code's width.
pub fn wire_type(schema: &Schema, number: u32) -> Option<ParameterType> {
    let code = schema.code(number)?;
    let ty = schema.type_of(code)?;
    ParameterType::of_code(Some(ty.name()), code.width)
}

struct State<'a> {
    ctx: &'a Context,
    family: Option<Dialect>,
    last: Option<Request>,
    /// Whether the last SELECT had a wrong BCC.
    last_bad_bcc: bool,
}

impl State<'_> {
    fn schema(&self) -> Option<Arc<Schema>> {
        if let Some(s) = &self.ctx.schema {
            return Some(s.clone());
        }
        self.ctx.registry.get(family_schema_id(self.family?))
    }

    fn see(&mut self, code: ParameterCode) {
        if self.ctx.family.is_none()
            && self.ctx.schema.is_none()
            && let Some(f) = family_of(code)
        {
            self.family = Some(f);
        }
    }

    fn code_fields(&self, ev: &mut Event, code: ParameterCode) {
        ev.code = Some(code.to_string());
        let schema = self.schema();
        let named = |n: u32| -> Option<String> {
            let s = schema.as_ref()?;
            s.code(n).map(|_| s.display_code(n, None))
        };
        ev.name = match code.meaning() {
            _ if code.compatible_parameter().is_some() => {
                let n = code.number();
                Some(named(n).unwrap_or_else(|| compatible_name(code)))
            }
            CodeMeaning::VfValue { parameter, .. } => named(u32::from(parameter)),
            CodeMeaning::McValue { parameter } => named(u32::from(parameter)),
            CodeMeaning::VfDescription { parameter, .. } => Some(format!(
                "description of {}",
                named(u32::from(parameter)).unwrap_or_else(|| parameter.to_string())
            )),
            CodeMeaning::McDescription { parameter } => Some(format!(
                "description of {}",
                named(u32::from(parameter)).unwrap_or_else(|| parameter.to_string())
            )),
            CodeMeaning::SubstitutionText { parameter } => Some(format!(
                "value substitution text of {}",
                named(u32::from(parameter)).unwrap_or_else(|| parameter.to_string())
            )),
            CodeMeaning::PosMod => Some("PosMOD1 user data".into()),
            CodeMeaning::Other => None,
        };
    }

    fn value_fields(&self, ev: &mut Event, code: ParameterCode, text: &[u8]) {
        ev.raw_value = Some(text.escape_ascii().to_string());
        if code.compatible_parameter() == Some(CompatibleParameter::Siof) {
            siof_fields(ev, text);
            return;
        }
        let (Some(schema), Some(number), Some(family)) =
            (self.schema(), value_parameter(code), self.family)
        else {
            return;
        };
        if schema.code(number).is_some_and(|c| schema.is_password(c)) {
            ev.secret = true;
            return;
        }
        let (Some(code_def), Some(ty)) = (schema.code(number), wire_type(&schema, number)) else {
            return;
        };
        match ParameterValue::decode(ty, family, text) {
            Ok(v) => {
                ev.value = Some(display_value(
                    &schema,
                    code_def,
                    &RawValue::Int(v.raw_signed()),
                ));
            }
            Err(e) => ev
                .details
                .push(format!("VALUE does not decode as {}: {e}", ty.name())),
        }
    }
}

fn compatible_name(code: ParameterCode) -> String {
    match code.compatible_parameter() {
        Some(CompatibleParameter::Baud) => "81 baud rate",
        Some(CompatibleParameter::Address) => "82 device address",
        Some(CompatibleParameter::Dummy) => "83 watchdog dummy",
        Some(CompatibleParameter::Watchdog) => "84 watchdog time",
        Some(CompatibleParameter::Siof) => "85 SIOF/SERR",
        Some(CompatibleParameter::Type) => "91 TYPE",
        None => "",
    }
    .to_string()
}

/// SIOF/SERR: the bits with cause and remedy (section 9.2).
fn siof_fields(ev: &mut Event, text: &[u8]) {
    let parsed = std::str::from_utf8(text)
        .ok()
        .filter(|t| !t.is_empty() && t.len() <= 8)
        .and_then(|t| u32::from_str_radix(t, 16).ok());
    let Some(n) = parsed else {
        ev.details
            .push("VALUE is not a hex number; SIOF/SERR cannot be decoded".into());
        return;
    };
    let Ok(bits) = u8::try_from(n) else {
        ev.details
            .push(format!("0x{n:X} does not fit the 8 SIOF/SERR bits"));
        return;
    };
    let siof = Siof::from_bits_retain(bits);
    ev.value = Some(format!("0x{bits:02X}"));
    if siof.is_empty() {
        ev.meaning = Some("no error bit set".into());
        return;
    }
    let labels: Vec<String> = siof.causes().map(|c| c.descriptor.to_string()).collect();
    ev.meaning = Some(format!("{} (reading 85 cleared it)", labels.join(", ")));
    for c in siof.causes() {
        ev.details.push(format!(
            "bit {} {}: {}; what to do: {}",
            c.bit, c.descriptor, c.cause, c.remedy
        ));
    }
}

fn address_text(a: Address) -> String {
    let note = if a == Address::ALL {
        " (all devices)"
    } else if !a.expects_reply() {
        " (broadcast)"
    } else {
        ""
    };
    format!("{} '{}'{note}", a.number(), a.to_byte() as char)
}

fn direction(d: Option<Direction>) -> Option<&'static str> {
    d.map(|d| match d {
        Direction::Host => HOST_TO_DRIVE,
        Direction::Device => DRIVE_TO_HOST,
    })
}

/// Decodes a LUSTBUS capture.
pub fn decode(capture: &[u8], ctx: &Context, out: &mut dyn FnMut(Event)) {
    let mut sniffer = Sniffer::new();
    let mut st = State {
        ctx,
        family: ctx.family,
        last: None,
        last_bad_bcc: false,
    };
    // each frame is annotated as the sniffer finds it (no list of the
    // capture's frames is kept)
    let mut on = |ev: driveset_proto::lustbus::StreamEvent| {
        let (start, end) = (ev.span.start, ev.span.end);
        let bytes = slice(capture, start, end);
        let mut bad_bcc = None;
        let telegram = match ev.result {
            Ok(t) => t,
            Err(FrameError::Garbage { len, .. }) => {
                out(garbage_event(capture, start, end, len));
                return;
            }
            Err(FrameError::BadBcc {
                received, computed, ..
            }) => {
                // Decode what is inside with the BCC it should have had.
                let mut fixed = bytes.to_vec();
                if let Some(last) = fixed.last_mut() {
                    *last = computed;
                }
                match codec::decode_telegram(&fixed) {
                    Ok(t) => {
                        bad_bcc = Some((received, computed));
                        t
                    }
                    Err(_) => {
                        out(Event::error(
                            capture,
                            start,
                            end,
                            direction(ev.direction),
                            format!(
                                "BCC is 0x{received:02X} but the text XORs to 0x{computed:02X}"
                            ),
                        ));
                        return;
                    }
                }
            }
            Err(e) => {
                out(Event::error(
                    capture,
                    start,
                    end,
                    direction(ev.direction),
                    e.to_string(),
                ));
                return;
            }
        };
        let mut e = Event::new(capture, start, end, "");
        e.direction = Some(match telegram {
            Telegram::Request(_) => HOST_TO_DRIVE,
            Telegram::Reply(_) => DRIVE_TO_HOST,
        });
        match telegram {
            Telegram::Request(Request::Eot) => {
                e.kind = "EOT";
                e.meaning = Some("end of transaction, every receiver resets".into());
            }
            Telegram::Request(r @ Request::Enquiry(q)) => {
                st.see(q.code);
                e.kind = "ENQUIRY";
                e.address = Some(address_text(q.address));
                st.code_fields(&mut e, q.code);
                if !q.address.expects_reply() {
                    e.meaning = Some("to the broadcast address: no device answers".into());
                }
                st.last = Some(r);
                st.last_bad_bcc = false;
            }
            Telegram::Request(r @ Request::Select(s)) => {
                st.see(s.code);
                e.kind = "SELECT";
                e.address = Some(address_text(s.address));
                st.code_fields(&mut e, s.code);
                st.value_fields(&mut e, s.code, s.value.as_bytes());
                if s.code.compatible_parameter() == Some(CompatibleParameter::Siof) {
                    e.value = None;
                    e.details.clear();
                    e.meaning = None;
                }
                if !s.address.expects_reply() && bad_bcc.is_none() {
                    e.meaning = Some("broadcast: every device acts on it, none replies".into());
                }
                st.last = Some(r);
                st.last_bad_bcc = bad_bcc.is_some();
            }
            Telegram::Reply(Reply::Value(v)) => {
                e.error = impossible_reply(st.last, v.address);
                st.see(v.code);
                e.kind = "VALUE";
                e.address = Some(address_text(v.address));
                st.code_fields(&mut e, v.code);
                st.value_fields(&mut e, v.code, v.value.as_bytes());
            }
            Telegram::Reply(Reply::Ack(a)) => {
                e.error = impossible_reply(st.last, a);
                if e.error.is_some() {
                    st.last = None;
                }
                st.last = st.last.filter(|r| answers(r, a));
                e.kind = "ACK";
                e.address = Some(address_text(a));
                e.meaning = Some(match st.last {
                    Some(Request::Select(s)) => format!("SELECT of {} accepted", s.code),
                    _ => "accepted".into(),
                });
            }
            Telegram::Reply(Reply::Nak(a)) => {
                e.error = impossible_reply(st.last, a);
                if e.error.is_some() {
                    st.last = None;
                }
                st.last = st.last.filter(|r| answers(r, a));
                e.kind = "NAK";
                e.address = Some(address_text(a));
                e.meaning = Some(match st.last {
                    Some(Request::Select(s)) if st.last_bad_bcc => format!(
                        "SELECT of {} refused: its BCC was wrong (SERR bit 3, 08h, checksum error; §3, §9.2); read 85 to unlatch the device, then repeat it",
                        s.code
                    ),
                    Some(Request::Select(s)) => format!(
                        "SELECT of {} refused; read 85 (SIOF/SERR) for the cause, which also unlatches the device",
                        s.code
                    ),
                    Some(Request::Enquiry(q)) => format!(
                        "ENQUIRY of {} refused: no such parameter or read-protected (sets no SIOF bit)",
                        q.code
                    ),
                    _ => "refused".into(),
                });
            }
        }
        if matches!(
            telegram,
            Telegram::Request(Request::Select(_)) | Telegram::Reply(Reply::Value(_))
        ) {
            e.bcc = match bad_bcc {
                Some((found, expected)) => {
                    e.error = Some(match telegram {
                        // §3: "ADR NAK: occurs with wrong BCC"; §9.2 bit 3
                        Telegram::Request(Request::Select(s)) if !s.address.expects_reply() => {
                            "BCC mismatch: every device refuses it and sets SERR bit 3 (08h, checksum error; §9.2); none answers a broadcast".into()
                        }
                        Telegram::Request(Request::Select(_)) => {
                            "BCC mismatch: the drive answers NAK and sets SERR bit 3 (08h, checksum error; §3, §9.2); read 85 to unlatch it, then repeat the telegram".into()
                        }
                        _ => "BCC mismatch: the host discards this reply; repeat the ENQUIRY".into(),
                    });
                    Some(Bcc::mismatch(found, expected))
                }
                None => Bcc::of_telegram(bytes),
            };
        }
        out(e);
    };
    for ev in sniffer.feed(capture) {
        on(ev);
    }
    for ev in sniffer.finish() {
        on(ev);
    }
}

/// Why a reply from `a` cannot answer `last` (the spec rules it out), if
/// it cannot: no device answers address 31 (§4.2: "without giving a
/// receipt"; §9.1: "There is no answer using bus address 31"), and only the
/// addressed device answers (§3: the device tests "the slave-address";
/// wrong address: "No answer"); every device answers address 0 (§4.2).
fn impossible_reply(last: Option<Request>, a: Address) -> Option<String> {
    let (kind, to) = match last? {
        Request::Eot => return None,
        Request::Enquiry(q) => ("ENQUIRY", q.address),
        Request::Select(s) => ("SELECT", s.address),
    };
    if !to.expects_reply() {
        return Some(format!(
            "no device answers address 31 (broadcast; §4.2, §9.1): this reply cannot answer the {kind} to {}",
            address_text(to)
        ));
    }
    if to != a && to != Address::ALL {
        return Some(format!(
            "reply from address {}, but the {kind} asked address {}: only the addressed device answers (§3)",
            address_text(a),
            address_text(to)
        ));
    }
    None
}

/// Whether a reply from `a` can answer `r` (same address, or address 0).
fn answers(r: &Request, a: Address) -> bool {
    let to = match r {
        Request::Eot => return false,
        Request::Enquiry(q) => q.address,
        Request::Select(s) => s.address,
    };
    to == a || to == Address::ALL
}

#[cfg(test)]
mod tests {
    use driveset_proto::lustbus::value::{McError, VfError};
    use driveset_schema::ValueType;
    use driveset_schema::value::error_fields;

    /// The schema crate's display and the codec's types split the raw
    /// values the same way (errata L17, L19).
    #[test]
    fn error_fields_agree_with_the_codec() {
        for raw in [0u16, 0x0312, 0x0F00, 0xFF07, 0xFFFF] {
            let v = VfError::from_raw(raw);
            let none = if v.is_no_error() { " (no error)" } else { "" };
            assert_eq!(
                error_fields(ValueType::PT_VF_ERROR, i64::from(raw)).unwrap(),
                format!("{{ number = {}, time = {} }}{none}", v.number, v.time)
            );
        }
        for raw in [0u32, 0x0502_012C, 0xFFFF_FFFF] {
            let v = McError::from_raw(raw);
            assert_eq!(
                error_fields(ValueType::PT_MC_ERROR, i64::from(raw)).unwrap(),
                format!(
                    "{{ number = {}, location = {}, time = {} }}",
                    v.number, v.location, v.time
                )
            );
        }
        assert_eq!(error_fields(ValueType::PT_USIGN16, 5), None);
        assert_eq!(error_fields(ValueType::PT_VF_ERROR, 0x1_0000), None);
    }
}
