//! Capturing a drive for a twin (docs/twins.md): read-only, through the
//! clients' read, identify and description calls only. Owns [`capture`]
//! (identity, every code of the schema the drive answers, the codes it
//! refuses to read, the running state, the line rate and the reaction
//! times it showed) and [`describe`] (what a LUSTBUS drive describes, as it
//! sent it: its parameter descriptions, LUSTBUS 11.1 / 11.2, in its own
//! layout and type characters, errata L22 / L23, and its substitution
//! texts, 11.3; the schema learned from them as `pull` learns it). The
//! simulator's `twin` module owns the file.
//!
//! What is never read: password codes (listed in [`Capture::secrets`], no
//! value kept) and codes whose reading clears them (85-SIOF/SERR, listed
//! in [`Capture::unread`]): reading would unlatch the drive's error state.
//! Unlike `pull`, commands and control words are read too (reading them
//! changes nothing; the twin must answer them as the drive did).

use std::collections::BTreeMap;
use std::time::Duration;

use std::sync::Arc;

use driveset_link::ByteLink;
use driveset_proto::lustbus::Dialect;
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::{BusProtocol, CodeKey, RawValue, Registry, Schema};

use crate::client::{DriveClient, Identity, LustbusClient};
use crate::connect::ConnectOptions;
use crate::error::{DeviceCause, DeviceFailure, EngineError, ErrorKind, LinkFailure};
use crate::learn::{
    LearnOptions, PullSchemaError, PulledSchema, default_params, needs_learning, pull_descriptions,
};

/// What a capture read from one drive.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Capture {
    /// Who answered.
    pub identity: Identity,
    /// Every code it answered, raw.
    pub values: BTreeMap<CodeKey, RawValue>,
    /// Codes it refused to read (or did not answer for), with the cause.
    pub refused: BTreeMap<CodeKey, String>,
    /// What the drive answered to each read it refused (the codes of
    /// `refused` it answered at all), so a twin refuses them alike.
    pub answers: BTreeMap<CodeKey, DeviceCause>,
    /// Password codes: not read.
    pub secrets: Vec<CodeKey>,
    /// Codes not read on purpose: reading clears them (85-SIOF/SERR).
    pub clears: Vec<CodeKey>,
    /// Codes without a type in the schema: not read.
    pub unread: Vec<CodeKey>,
    /// Whether the motor ran (`None`: the drive does not say).
    pub running: Option<bool>,
    /// The line rate (baud) the client talked at, when it knows it.
    pub rate: Option<u32>,
    /// The shortest and longest reaction time seen: per read, the time to
    /// the answer less the telegrams' wire time ([`DriveClient::read_time`]
    /// less the family's planning minimum).
    pub reaction: Option<(Duration, Duration)>,
}

/// Read every code of the client's schema, read-only (module docs).
pub fn capture(client: &mut dyn DriveClient) -> Result<Capture, EngineError> {
    let schema = client.schema().clone();
    let identity = client.identify()?;
    let min_reaction = schema.family.descriptor().reaction.min;
    let mut out = Capture {
        identity,
        values: BTreeMap::new(),
        refused: BTreeMap::new(),
        answers: BTreeMap::new(),
        secrets: Vec::new(),
        clears: Vec::new(),
        unread: Vec::new(),
        running: None,
        rate: client.line_rate(),
        reaction: None,
    };
    for code in &schema.codes {
        for key in code_keys(code) {
            if schema.is_password(code) {
                out.secrets.push(key);
                continue;
            }
            if code.read_clears == Some(true) {
                out.clears.push(key);
                continue;
            }
            if schema.type_of(code).is_none() {
                out.unread.push(key);
                continue;
            }
            let before = client.clock().now();
            match client.read(key) {
                Ok(v) => {
                    let took = client.clock().now() - before;
                    let wire = client.read_time(key).saturating_sub(min_reaction);
                    let reaction = took.saturating_sub(wire);
                    out.reaction = Some(match out.reaction {
                        Some((lo, hi)) => (lo.min(reaction), hi.max(reaction)),
                        None => (reaction, reaction),
                    });
                    out.values.insert(key, v);
                }
                Err(e) => match &*e.kind {
                    ErrorKind::Device(DeviceFailure::Refused { cause, .. }) => {
                        out.refused
                            .insert(key, format!("{} ({})", cause.cause(), cause.raw()));
                        out.answers.insert(key, cause.clone());
                    }
                    ErrorKind::Link(LinkFailure::Protocol { detail, .. }) => {
                        out.refused
                            .insert(key, format!("answer does not fit the type: {detail}"));
                    }
                    ErrorKind::Link(LinkFailure::NoAnswer { tries, .. }) => {
                        out.refused
                            .insert(key, format!("no answer ({tries} tries)"));
                    }
                    _ => return Err(e),
                },
            }
        }
    }
    out.running = client.running()?;
    client.finish()?;
    Ok(out)
}

/// Every key of `code`: each subcode of a code that has subcodes, else the
/// code itself.
pub fn code_keys(code: &driveset_schema::Code) -> Vec<CodeKey> {
    match code.subcodes {
        Some(n) if n > 0 => (1..=n).map(|s| CodeKey::sub(code.number, s)).collect(),
        _ => vec![CodeKey::new(code.number)],
    }
}

/// What a LUSTBUS drive says of its parameters, as it said it: every
/// description it sent (VF1000 section 11.1, MC6000/7000 section 11.2) and
/// every substitution text (MC section 11.3: the value texts and the
/// 107-UNIT strings, by 108-STEXT index), and the layout and type
/// characters they read in (errata L22, L23). A twin serves them as they
/// came, so learning from the twin learns what learning from the drive did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Described {
    /// The VALUE characters of each description, by parameter.
    pub descriptions: BTreeMap<u32, Vec<u8>>,
    /// The VALUE characters of each substitution text, by (parameter,
    /// 108-STEXT index); a text the drive refused is not here.
    pub texts: BTreeMap<(u32, u8), Vec<u8>>,
    /// MC: the layout of its descriptions (the first, when they mix).
    pub layout: Option<McLayout>,
    /// MC: the type-character reading that fits them.
    pub types: Option<McTypeChars>,
}

/// A LUSTBUS drive read for a twin ([`describe`]).
pub struct DescribedDrive<L: ByteLink> {
    /// The client, speaking `schema`.
    pub client: LustbusClient<L>,
    /// The schema the capture reads with: the one given, or the one
    /// learned from the descriptions when it lacks facts.
    pub schema: Arc<Schema>,
    /// The descriptions and texts as sent.
    pub described: Described,
    /// The learned schema, when `base` needed learning.
    pub learned: Option<PulledSchema>,
}

/// Read everything a LUSTBUS drive describes, as `pull` learns it
/// ([`pull_descriptions`]: identify, every parameter of the family's range
/// asked for its description, the MC texts; only the RAM selector
/// 108-STEXT is written, and set back), whatever `base` is: a twin must
/// answer the descriptions any later command asks for. When `base` lacks
/// facts ([`needs_learning`]) the schema is learned from them and rendered
/// as `pull` renders it (`drive` names the drive in it; `registry` holds
/// `base`), and the client connected again speaking it (`connect`: the
/// port's options).
pub fn describe<L: ByteLink>(
    mut client: LustbusClient<L>,
    base: Arc<Schema>,
    opts: &LearnOptions,
    registry: &Registry,
    drive: String,
    connect: &ConnectOptions,
) -> Result<DescribedDrive<L>, PullSchemaError> {
    let opts = LearnOptions {
        params: Some(default_params(base.family)),
        ..opts.clone()
    };
    let read = pull_descriptions(&mut client, &base, &opts)?;
    let described = Described {
        descriptions: read
            .learned
            .raw
            .iter()
            .map(|r| (r.number, r.text.clone()))
            .collect(),
        texts: read.learned.raw_texts.clone(),
        layout: read.learned.layouts.iter().next().copied(),
        types: read.learned.type_chars.clone(),
    };
    if !needs_learning(&base) {
        return Ok(DescribedDrive {
            client,
            schema: base,
            described,
            learned: None,
        });
    }
    let id = read.id(&base);
    let pulled = read.render(&base, &id, drive, registry)?;
    let schema = pulled.rendered.schema.clone();
    let address = client.target().address;
    let client = crate::connect::lustbus(client.into_link(), schema.clone(), address, connect)?;
    Ok(DescribedDrive {
        client,
        schema,
        described,
        learned: Some(pulled),
    })
}

/// What a recorded LECOM or LUSTBUS session (`driveset decode`'s events)
/// showed of one drive: the values it answered to a read, the values
/// written to it by a write it acknowledged, and the codes it refused to
/// read ([`lecom_session`], [`lustbus_session`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Session {
    /// Values seen, raw (the last one seen wins).
    pub values: BTreeMap<CodeKey, RawValue>,
    /// Codes whose read it refused (LECOM "no such code", LUSTBUS NAK),
    /// with the reason as a capture writes it.
    pub refused: BTreeMap<CodeKey, String>,
    /// CAN: the SDO abort code each refused read was answered with.
    pub aborts: BTreeMap<CodeKey, u32>,
}

/// Per station address, what a decoded LECOM session showed
/// ([`Session`]); events with an error (bad BCC, garbage) are passed over,
/// as is a value the schema's type cannot hold.
pub fn lecom_session(
    events: &[crate::decode::Event],
    schema: &driveset_schema::Schema,
) -> BTreeMap<u8, Session> {
    let raw = |key: CodeKey, text: &str| -> Option<RawValue> {
        let value = driveset_proto::lecom::Value::parse(text.as_bytes()).ok()?;
        let ty = schema.code(key.number).and_then(|c| schema.type_of(c));
        crate::client::lecom::raw_of(ty, &value)
    };
    let mut out: BTreeMap<u8, Session> = BTreeMap::new();
    let mut sent: Option<(u8, CodeKey, Option<RawValue>)> = None;
    for e in events {
        if e.error.is_some() {
            sent = None;
            continue;
        }
        let address = e.address.as_deref().and_then(|a| a.parse::<u8>().ok());
        let key = e.code.as_deref().and_then(lenze_key);
        match (e.kind, address, key) {
            ("RECEIVE", Some(a), Some(k)) => sent = Some((a, k, None)),
            ("SEND", Some(a), Some(k)) => {
                sent = Some((a, k, e.raw_value.as_deref().and_then(|v| raw(k, v))));
            }
            ("VALUE", Some(a), Some(k)) => {
                if let Some(v) = e.raw_value.as_deref().and_then(|v| raw(k, v)) {
                    out.entry(a).or_default().values.insert(k, v);
                }
                sent = None;
            }
            ("ACK", _, _) => {
                if let Some((a, k, Some(v))) = sent.take() {
                    out.entry(a).or_default().values.insert(k, v);
                }
            }
            ("NO CODE", Some(a), Some(k)) => {
                let why = e.meaning.clone().unwrap_or_else(|| "no such code".into());
                out.entry(a).or_default().refused.insert(k, why);
                sent = None;
            }
            _ => {}
        }
    }
    out
}

/// The Lenze code a decoded event names (`C0011`, `C0039/2`).
fn lenze_key(code: &str) -> Option<CodeKey> {
    let c = code.strip_prefix('C')?;
    match c.split_once('/') {
        Some((n, s)) => Some(CodeKey::sub(n.parse().ok()?, s.parse().ok()?)),
        None => Some(CodeKey::new(c.parse().ok()?)),
    }
}

/// Per CAN node, what a decoded slcan session showed of one ECS drive
/// ([`Session`]): the values of its expedited SDO uploads (VALUE,
/// lenze-system-bus-can-sdo.txt "Reading parameters"), the values of the
/// expedited downloads it acknowledged (WRITE OK; the last one wins), and
/// the codes whose upload it aborted, with the abort code. Objects that are
/// no Lenze code (`index 0x1018/1`), segmented transfers, events with an
/// error and a value the schema does not know are passed over.
pub fn can_session(
    events: &[crate::decode::Event],
    schema: &driveset_schema::Schema,
) -> BTreeMap<u8, Session> {
    let node_of = |e: &crate::decode::Event| -> Option<u8> {
        e.address.as_deref()?.strip_prefix("node ")?.parse().ok()
    };
    let key_of = |e: &crate::decode::Event| -> Option<CodeKey> {
        let k = lenze_key(e.code.as_deref()?)?;
        schema.code(k.number)?;
        Some(k)
    };
    // the four data bytes as the SDO client reads them: FIX32 signed
    let raw = |e: &crate::decode::Event, key: CodeKey| -> Option<RawValue> {
        let hex = e.raw_value.as_deref()?.strip_prefix("0x")?;
        let v = u32::from_str_radix(hex, 16).ok()?;
        let fix32 = schema
            .code(key.number)
            .and_then(|c| schema.type_of(c))
            .is_some_and(|t| t == driveset_schema::ValueType::FIX32);
        Some(RawValue::Int(if fix32 {
            i64::from(v as i32)
        } else {
            i64::from(v)
        }))
    };
    // "the drive refuses: 0x06020000 Object does not exist ..."
    let abort_of = |e: &crate::decode::Event| -> Option<u32> {
        let m = e.meaning.as_deref()?;
        let at = m.find("0x")?;
        u32::from_str_radix(m.get(at + 2..at + 10)?, 16).ok()
    };
    let mut out: BTreeMap<u8, Session> = BTreeMap::new();
    // the request a response answers: READ (no value) or WRITE (its value)
    let mut asked: Option<(u8, CodeKey, Option<RawValue>)> = None;
    for e in events {
        if e.error.is_some() {
            asked = None;
            continue;
        }
        match (e.kind, node_of(e), key_of(e)) {
            ("READ", Some(n), Some(k)) => asked = Some((n, k, None)),
            ("WRITE", Some(n), Some(k)) => asked = raw(e, k).map(|v| (n, k, Some(v))),
            ("VALUE", Some(n), Some(k)) => {
                if let Some(v) = raw(e, k) {
                    let s = out.entry(n).or_default();
                    s.refused.remove(&k);
                    s.aborts.remove(&k);
                    s.values.insert(k, v);
                }
                asked = None;
            }
            ("WRITE OK", Some(n), Some(k)) => {
                if let Some((a, ak, Some(v))) = asked.take()
                    && (a, ak) == (n, k)
                {
                    out.entry(n).or_default().values.insert(k, v);
                }
            }
            ("ABORT", Some(n), Some(k)) if e.direction == Some(crate::decode::DRIVE_TO_HOST) => {
                if let Some((a, ak, None)) = asked.take()
                    && (a, ak) == (n, k)
                {
                    let s = out.entry(n).or_default();
                    s.values.remove(&k);
                    s.refused
                        .insert(k, e.meaning.clone().unwrap_or_else(|| "SDO abort".into()));
                    if let Some(code) = abort_of(e) {
                        s.aborts.insert(k, code);
                    }
                }
            }
            _ => {}
        }
    }
    out
}

/// Per bus address, what a decoded LUSTBUS session showed of one drive of
/// `schema`'s family ([`Session`]): the values it answered to an ENQUIRY
/// (VALUE, section 6.1), the values a SELECT wrote and the drive
/// acknowledged (ACK, section 6.2; the last one wins), and the parameters
/// whose ENQUIRY it answered with NAK. Events with an error, broadcasts and
/// a value the schema's type cannot hold are passed over.
pub fn lustbus_session(
    events: &[crate::decode::Event],
    schema: &driveset_schema::Schema,
) -> BTreeMap<u8, Session> {
    use driveset_proto::lustbus::{ParameterCode, ParameterValue};
    // The family's dialect (its descriptor's); a schema off LUSTBUS is read
    // as MC, as before the descriptor was asked.
    let dialect = schema.family.descriptor().dialect.unwrap_or(Dialect::Mc);
    // "4 'D'": the number before the address character
    let address_of = |e: &crate::decode::Event| -> Option<u8> {
        let a = e
            .address
            .as_deref()?
            .split(' ')
            .next()?
            .parse::<u8>()
            .ok()?;
        // not the group address 0 nor the broadcast address 31 (section 4.2)
        (!BusProtocol::Lustbus.is_group_address(i64::from(a))).then_some(a)
    };
    let key_of = |e: &crate::decode::Event| -> Option<CodeKey> {
        let code = ParameterCode::new(e.code.as_deref()?.parse().ok()?)?;
        // a CODE of the other family's layout (a probe) is not this drive's
        if crate::decode::lustbus::family_of(code).is_some_and(|f| f != dialect) {
            return None;
        }
        let number = crate::decode::lustbus::value_parameter(code)?;
        schema.code(number)?;
        Some(CodeKey::new(number))
    };
    let raw = |e: &crate::decode::Event, key: CodeKey| -> Option<RawValue> {
        let ty = crate::decode::lustbus::wire_type(schema, key.number)?;
        let text = e.raw_value.as_deref()?;
        let v = ParameterValue::decode(ty, dialect, text.as_bytes()).ok()?;
        Some(RawValue::Int(v.raw_signed()))
    };
    let mut out: BTreeMap<u8, Session> = BTreeMap::new();
    // the request a reply answers: ENQUIRY (no value) or SELECT (its value)
    let mut asked: Option<(u8, CodeKey, Option<RawValue>, String)> = None;
    for e in events {
        if e.error.is_some() {
            asked = None;
            continue;
        }
        match e.kind {
            "ENQUIRY" => {
                asked = address_of(e)
                    .zip(key_of(e))
                    .map(|(a, k)| (a, k, None, e.code.clone().unwrap_or_default()));
            }
            "SELECT" => {
                asked = address_of(e).zip(key_of(e)).and_then(|(a, k)| {
                    let v = raw(e, k)?;
                    Some((a, k, Some(v), String::new()))
                });
            }
            "VALUE" => {
                if let (Some(a), Some(k)) = (address_of(e), key_of(e))
                    && let Some(v) = raw(e, k)
                {
                    let s = out.entry(a).or_default();
                    s.refused.remove(&k);
                    s.values.insert(k, v);
                }
                asked = None;
            }
            "ACK" => {
                if let Some((a, k, Some(v), _)) = asked.take()
                    && address_of(e) == Some(a)
                {
                    out.entry(a).or_default().values.insert(k, v);
                }
            }
            "NAK" => {
                if let Some((a, k, None, code)) = asked.take()
                    && address_of(e) == Some(a)
                {
                    let why = format!(
                        "no such parameter, or read-protected in the current operating state (NAK to ENQUIRY {code})"
                    );
                    let s = out.entry(a).or_default();
                    s.values.remove(&k);
                    s.refused.insert(k, why);
                }
            }
            _ => {}
        }
    }
    out
}
