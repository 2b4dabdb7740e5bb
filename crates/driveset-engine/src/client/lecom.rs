//! [`LecomClient`]: Lenze LECOM-A/B (`lecom-ab-tmd-manual.txt` section 8)
//! for Lenze Tmd inverters.
//!
//! # Telegrams
//!
//! - Read: RECEIVE `EOT AD1 AD2 C1 C2 ENQ` (8.H), write: SEND
//!   `EOT AD1 AD2 STX C1 C2 V1..Vn ETX BCC` (8.I). The code field is the
//!   codec's [`CodeAddress::select`]: standard C1 C2 for codes up to 6229
//!   without subcode, extended addressing `!CCCCSS` (8.D) otherwise; the
//!   client never touches the code bank C0249 or input selection C0248, so
//!   they stay at their power-on 0.
//! - Values per the schema type (8.E): VD (raw = value x 10000), VH (2, 4
//!   or 8 hex digits from the schema's `width`, 2 bytes when unset), VS,
//!   VO.
//! - Answers through the codec's [`ResponseDecoder`]: the value; `?`
//!   (checksum fault seen by the drive: repeat); `STX C1 C2 EOT` (no such
//!   code: [`DeviceFailure::Refused`](crate::error::DeviceFailure::Refused)); ACK; NAK.
//! - A NAK to a SEND: the client reads C0068 and decodes bits 4..7 with the
//!   codec's [`CommunicationError`](driveset_proto::lecom::status::CommunicationError) (8.J c). Checksum, protocol frame and
//!   "interrupted by a new telegram" repeat the SEND (within
//!   [`LecomOptions::tries`]); every other cause is a `Device` error, with
//!   C1962 (extended fault number, Table 1) read and added where the drive
//!   has it.
//! - Only station addresses are targets: 00 and the group addresses x0 are
//!   BROADCAST / MULTICAST addresses (8.J) that no drive answers and are
//!   refused. [`LecomClient::broadcast`] / [`LecomClient::multicast`] send
//!   an unacknowledged SEND to all drives or a group, separately.
//! - Every telegram starts with EOT (the end of the previous transmission),
//!   so nothing is sent after an answer; [`DriveClient::finish`](super::DriveClient::finish) sends the
//!   final EOT.
//!
//! # Answer monitoring and retries
//!
//! 8.J b: "The monitoring time in the master should be approx. twice as
//! long as the maximum response time"; the manual gives no response time.
//! Default: 2 x [`LecomOptions::max_reaction`] (20 ms, the simulator's
//! assumed Tmd figure) + the wire time of the longest answer the code's
//! format allows + the link's allowance ([`super::timing`]: measured from
//! the session's round trips, at least 10 ms, at most 1 s, 200 ms before
//! the first answer; at least the port's `?latency=` plus 10 ms,
//! [`LecomOptions::latency`]); [`LecomOptions::answer_timeout`] replaces
//! it. No answer or a garbled one: the client listens as long again for a
//! late answer (counted and dropped, [`ClientStats::late`]: an ACK or NAK
//! is told apart by its sequence, arriving in the window of the telegram
//! it answers), then repeats (input discarded first),
//! [`LecomOptions::tries`] (3) sends in all, then
//! [`LinkFailure::NoAnswer`](crate::error::LinkFailure::NoAnswer). An answer for another code (a late answer to
//! an earlier RECEIVE, the C0068 read after a NAK included) is never taken
//! for the answer.
//!
//! # running()
//!
//! The schema's running indicator (`Schema::running_indicator`): C0150
//! bit 1 "power stage transistors energized" (Table 1, role `running`).
//! `None` when the schema names none.

use std::sync::Arc;
use std::time::Duration;

use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, LinkError};
use driveset_proto::lecom::{
    Advice, CodeAddress, ControllerAddress, Decimal, ExtendedError, Hex, OctetString,
    OperatingStatus, Receive, Response, ResponseDecoder, Telegram, Value, VisibleString,
};
use driveset_schema::{BusProtocol, Code, CodeKey, RawValue, Schema, ValueType};

use super::timing::{AnswerWait, LinkLatency};
use super::{
    ClientStats, Drive, IdentValue, Protocol, Target, client_address, code_name, device,
    link_error, refuse_read_only, schema_code, shown_value, write_what, wrong_client,
};
use crate::error::{DeviceCause, EngineError, Refusal};
use crate::guard::{self, Permit};
use crate::plan;

/// C0068, operating status (bits 4..7: last communication error).
pub const C0068: u32 = 68;
/// C0150, controller status word.
pub const C0150: u32 = 150;
/// C1962, extended fault number.
pub const C1962: u32 = 1962;
/// C0093, drive identification.
pub const C0093: u32 = 93;
/// C0099, software version.
pub const C0099: u32 = 99;

/// The minimum reaction time assumed for planning (the manual gives none).
const MIN_REACTION: Duration = plan::TMD_MIN_REACTION;

/// Options of a [`LecomClient`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LecomOptions {
    /// Sends of one telegram before giving up (no answer, garbled answer,
    /// "?" answer, NAK for a repeatable cause). Default 3; 0 counts as 1.
    pub tries: u32,
    /// The drive's longest reaction time. The manual gives none; default
    /// 20 ms (FICTIONAL, as the simulator's Tmd). The monitoring time is
    /// twice this plus the answer's wire time (8.J b).
    pub max_reaction: Duration,
    /// Replaces the computed monitoring time (no allowance is added).
    pub answer_timeout: Option<Duration>,
    /// The round-trip delay the transport adds (the port's `?latency=`):
    /// the least allowance is this plus 10 ms from the first telegram on
    /// ([`super::timing`]). Default `None`: measured.
    pub latency: Option<Duration>,
}

impl Default for LecomOptions {
    fn default() -> Self {
        LecomOptions {
            tries: 3,
            max_reaction: plan::TMD_MAX_REACTION,
            answer_timeout: None,
            latency: None,
        }
    }
}

#[derive(Debug)]
enum Outcome {
    Answer(Response),
    NoAnswer,
    Garbled(String),
}

/// The line: link, answer decoder, counters. Shared with scan.
#[derive(Debug)]
pub struct LecomLine<L> {
    pub(crate) link: L,
    pub(crate) stats: ClientStats,
    open: bool,
    /// The link's measured latency ([`super::timing`]).
    pub(crate) latency: LinkLatency,
    /// Listen for a late answer after a timeout (not in scan probes).
    pub(crate) wait_late: bool,
}

impl<L: ByteLink> LecomLine<L> {
    pub(crate) fn new(link: L) -> Self {
        LecomLine {
            link,
            stats: ClientStats::default(),
            open: false,
            latency: LinkLatency::new(None),
            wait_late: true,
        }
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.link.discard_input()?;
        self.link.send(bytes)?;
        self.link.flush()?;
        self.open = true;
        self.stats.telegrams += 1;
        self.stats.sent += bytes.len() as u64;
        Ok(())
    }

    /// Sends a telegram and waits `timeout` from the end of the send for
    /// the answer (a RECEIVE answer must echo `code`). After a timeout,
    /// listens for a late answer for as long again ([`super::timing`]).
    fn exchange(
        &mut self,
        bytes: &[u8],
        code: Option<CodeAddress>,
        timeout: Duration,
    ) -> Result<Outcome, LinkError> {
        self.send(bytes)?;
        let mut wait = AnswerWait::begin(self.link.clock().now(), timeout);
        let mut decoder = ResponseDecoder::new();
        let mut garbled: Option<String> = None;
        let mut buf = [0u8; 128];
        let mut events = Vec::new();
        loop {
            let n = self.link.recv(&mut buf, wait.until())?;
            if n == 0 {
                // Timed out: an answer may still be on its way; listen as
                // long again so that the next telegram cannot take it for
                // its own.
                if wait.nothing_came(&mut self.latency, self.wait_late) {
                    continue;
                }
                decoder.finish(|e| events.push(e));
            } else {
                let got = buf.get(..n).unwrap_or(&[]);
                self.stats.received += got.len() as u64;
                wait.came(got.len());
                decoder.feed(got, |e| events.push(e));
            }
            for ev in events.drain(..) {
                match ev.result {
                    Ok(r) => match (r.code(), code) {
                        (Some(got), Some(want)) if got != want => {
                            // A late answer to an earlier RECEIVE.
                            self.stats.late += 1;
                            garbled = Some(format!(
                                "an answer for {got} instead of {want} (late, discarded)"
                            ));
                        }
                        _ => {
                            let elapsed = wait.answered(
                                &mut self.latency,
                                self.link.clock().now(),
                                self.link.baud(),
                                MIN_REACTION,
                            );
                            if wait.is_late() {
                                self.stats.late += 1;
                                return Ok(Outcome::Garbled(format!(
                                    "an answer {} ms after the request, later than the monitoring time of {} ms (late, discarded)",
                                    elapsed.as_millis(),
                                    wait.timeout().as_millis()
                                )));
                            }
                            return Ok(Outcome::Answer(r));
                        }
                    },
                    Err(e) => garbled = Some(e.to_string()),
                }
            }
            if n == 0 {
                return Ok(match garbled {
                    Some(g) => Outcome::Garbled(g),
                    None => Outcome::NoAnswer,
                });
            }
        }
    }

    pub(crate) fn finish(&mut self) -> Result<(), LinkError> {
        if self.open {
            self.link.send(&[driveset_proto::ascii::EOT])?;
            self.link.flush()?;
            self.stats.sent += 1;
            self.open = false;
        }
        Ok(())
    }
}

/// Longest answer to a RECEIVE of a code of `ty`: STX, code, value, ETX, BCC.
fn answer_len(code: CodeAddress, ty: Option<ValueType>) -> usize {
    let value = match ty {
        Some(ValueType::VD) | None => 12,
        Some(ValueType::VH) => 9,
        Some(ValueType::VS) => 1 + VisibleString::MAX_LEN,
        _ => Value::MAX_WIRE_LEN,
    };
    3 + code.wire_len() + value
}

/// The code field of a key.
fn code_address(key: CodeKey) -> Option<CodeAddress> {
    let code = u16::try_from(key.number).ok()?;
    let sub = u8::try_from(key.subcode.unwrap_or(0)).ok()?;
    Some(CodeAddress::select(code, sub))
}

/// The raw value of an answer of a code of type `ty`.
pub(crate) fn raw_of(ty: Option<ValueType>, value: &Value) -> Option<RawValue> {
    Some(match (ty, value) {
        (Some(ValueType::VD) | None, Value::Decimal(d)) => RawValue::Int(d.raw()),
        (Some(ValueType::VH), Value::Hex(h)) => RawValue::Int(i64::from(h.get())),
        (Some(ValueType::VH), Value::Decimal(d)) => RawValue::Int(d.as_integer()?),
        (Some(ValueType::VS), Value::String(s)) => RawValue::Text(s.as_str().to_string()),
        (Some(ValueType::VO), Value::Octets(o)) => RawValue::Octets(o.as_bytes().to_vec()),
        _ => return None,
    })
}

/// The LECOM value of a raw value of `code`.
fn value_of(schema: &Schema, code: &Code, raw: &RawValue) -> Result<Value, String> {
    let ty = schema.type_of(code);
    match (ty, raw) {
        (Some(ValueType::VD), RawValue::Int(n)) => Decimal::from_raw(*n)
            .map(Value::Decimal)
            .map_err(|e| e.to_string()),
        (Some(ValueType::VH), RawValue::Int(n)) => {
            let v = u32::try_from(*n).map_err(|_| "negative value for VH".to_string())?;
            let hex = match code.width.unwrap_or(2) {
                1 => u8::try_from(v).ok().map(Hex::Byte),
                2 => u16::try_from(v).ok().map(Hex::Word),
                4 => Some(Hex::Dword(v)),
                w => return Err(format!("VH width {w} is not 1, 2 or 4 bytes")),
            };
            hex.map(Value::Hex)
                .ok_or_else(|| "value does not fit the code's VH width".to_string())
        }
        (Some(ValueType::VS), RawValue::Text(t)) => VisibleString::new(t.as_bytes())
            .map(Value::String)
            .map_err(|e| e.to_string()),
        (Some(ValueType::VO), RawValue::Octets(o)) => OctetString::new(o)
            .map(Value::Octets)
            .map_err(|e| e.to_string()),
        (Some(t), _) => Err(format!("a {} code cannot take this value", t.name())),
        (None, _) => Err("the schema gives no LECOM format".into()),
    }
}

/// How a LECOM identification value shows: a VD value (8.E: raw = value
/// x 10000; a code the schema leaves untyped is VD) in engineering
/// notation (`C0093 = 33.0000`), any other as every client shows it.
fn ident_value(schema: &Schema, key: CodeKey, raw: RawValue) -> IdentValue {
    if let RawValue::Int(v) = raw
        && matches!(
            schema.code(key.number).and_then(|c| schema.type_of(c)),
            Some(ValueType::VD) | None
        )
    {
        return IdentValue::Text(driveset_schema::value::raw_to_engineering(ValueType::VD, v));
    }
    super::identify::shown(schema, key, raw)
}

/// A Lenze Tmd on LECOM-A/B at one station address.
#[derive(Debug)]
pub struct LecomClient<L: ByteLink = Box<dyn ByteLink>> {
    drive: Drive<LecomLine<L>>,
    address: ControllerAddress,
    opts: LecomOptions,
}

impl<L: ByteLink> LecomClient<L> {
    /// A client for the station at `address` (01..99 without the group
    /// addresses x0) with default options.
    pub fn new(link: L, schema: Arc<Schema>, address: u8) -> Result<Self, EngineError> {
        Self::with_options(link, schema, address, LecomOptions::default())
    }

    /// As [`LecomClient::new`] with `opts`.
    pub fn with_options(
        link: L,
        schema: Arc<Schema>,
        address: u8,
        opts: LecomOptions,
    ) -> Result<Self, EngineError> {
        let target = Target {
            port: link.port().to_string(),
            address,
        };
        if !BusProtocol::Lecom.carries(schema.family) {
            return Err(wrong_client(target, &schema, BusProtocol::Lecom));
        }
        let address = client_address(&target, BusProtocol::Lecom, |a| {
            ControllerAddress::new(a).ok_or_else(|| format!("address {a}"))
        })?;
        let mut line = LecomLine::new(link);
        line.latency = LinkLatency::new(opts.latency);
        Ok(LecomClient {
            drive: Drive::new(target, schema, line),
            address,
            opts,
        })
    }

    /// The link.
    pub fn link(&self) -> &L {
        &self.drive.line.link
    }

    /// The link, mutably (tests, reopening).
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.drive.line.link
    }

    /// The link back (without sending what [`DriveClient::finish`]
    /// sends: call it first).
    ///
    /// [`DriveClient::finish`]: crate::client::DriveClient::finish
    pub fn into_link(self) -> L {
        self.drive.line.link
    }

    fn tries(&self) -> u32 {
        self.opts.tries.max(1)
    }

    fn baud(&self) -> u32 {
        self.drive.line.link.baud()
    }

    /// The monitoring time now for an answer of `answer_chars`
    /// characters: 8.J b's twice the longest response time + the answer's
    /// wire time + the link's allowance (module docs).
    fn timeout(&self, answer_chars: usize) -> Duration {
        self.opts.answer_timeout.unwrap_or_else(|| {
            self.opts
                .max_reaction
                .saturating_mul(plan::LECOM_MONITORING_FACTOR)
                .saturating_add(wire_time(answer_chars, self.baud()))
                .saturating_add(self.drive.line.latency.allowance())
        })
    }

    /// The link's measured latency so far.
    pub fn latency(&self) -> &super::timing::LinkLatency {
        &self.drive.line.latency
    }

    fn refused(&self, refusal: Refusal) -> EngineError {
        EngineError::refused(self.drive.target.clone(), refusal)
    }

    fn encode_refused(&self, what: Option<&str>, e: impl std::fmt::Display) -> EngineError {
        self.refused(Refusal::Encode {
            what: what.map(str::to_string),
            detail: e.to_string(),
        })
    }

    fn field(&self, key: CodeKey) -> Result<CodeAddress, EngineError> {
        code_address(key).ok_or_else(|| {
            self.refused(
                super::LecomRefusal::Unaddressable {
                    code: code_name(&self.drive.schema, key),
                }
                .into(),
            )
        })
    }

    fn no_answer(&self, what: &str, last: &str) -> EngineError {
        let what = if last.is_empty() {
            what.to_string()
        } else {
            format!("{what} (last answer: {last})")
        };
        EngineError::no_answer(self.drive.target.clone(), what, self.tries())
    }

    /// RECEIVE with retries; the value as the codec decoded it.
    fn receive(
        &mut self,
        key: CodeKey,
        ty: Option<ValueType>,
        what: &str,
    ) -> Result<Value, EngineError> {
        let code = self.field(key)?;
        let t = Telegram::Receive(Receive {
            address: self.address,
            code,
        });
        let bytes = t
            .to_bytes()
            .map_err(|e| self.encode_refused(Some(what), e))?;
        let mut last = String::new();
        for attempt in 0..self.tries() {
            if attempt > 0 {
                self.drive.line.stats.retries += 1;
            }
            let timeout = self.timeout(answer_len(code, ty));
            let out = self
                .drive
                .line
                .exchange(&bytes, Some(code), timeout)
                .map_err(|e| link_error(&self.drive.target, e))?;
            match out {
                Outcome::Answer(Response::Value { value, .. }) => return Ok(value),
                Outcome::Answer(Response::NoSuchCode { .. }) => {
                    return Err(device(
                        &self.drive.target,
                        what,
                        DeviceCause::NoSuchCode {
                            code: code.to_string(),
                        },
                    ));
                }
                Outcome::Answer(Response::ChecksumFault { .. }) => {
                    last = "\"?\": the drive saw a checksum (parity) fault".into();
                }
                Outcome::Answer(r) => last = format!("{r} to a RECEIVE"),
                Outcome::Garbled(g) => last = g,
                Outcome::NoAnswer => last.clear(),
            }
        }
        Err(self.no_answer(what, &last))
    }

    fn read_code(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        let ty = schema.type_of(code);
        let value = self.receive(key, ty, what)?;
        raw_of(ty, &value).ok_or_else(|| {
            EngineError::protocol(
                self.drive.target.clone(),
                what.to_string(),
                format!(
                    "the drive sent {}, which is not the {} format the schema gives",
                    if schema.is_password(code) {
                        "a value (password, not shown)".to_string()
                    } else {
                        format!("`{value}`")
                    },
                    ty.map_or("VD", ValueType::name)
                ),
            )
        })
    }

    /// After a NAK: C0068 bits 4..7, and C1962 for causes that fail.
    fn nak_cause(
        &mut self,
        what: &str,
    ) -> Result<(OperatingStatus, Option<ExtendedError>), EngineError> {
        let v = self.receive(
            CodeKey::new(C0068),
            Some(ValueType::VH),
            &format!("read C0068 after NAK to {what}"),
        )?;
        let status = OperatingStatus::from_value(&v).map_err(|e| {
            EngineError::protocol(
                self.drive.target.clone(),
                format!("read C0068 after NAK to {what}"),
                e.to_string(),
            )
        })?;
        let comm = status.last_communication_error();
        let mut extended = None;
        if comm.advice() == Advice::Fail && self.drive.schema.code(C1962).is_some() {
            // Best effort: C1962 only adds detail.
            if let Ok(v) = self.receive(
                CodeKey::new(C1962),
                None,
                &format!("read C1962 after NAK to {what}"),
            ) && let Ok(x) = ExtendedError::from_value(&v)
            {
                extended = Some(x);
            }
        }
        Ok((status, extended))
    }

    fn encode(&self, key: CodeKey, raw: &RawValue) -> Result<(CodeAddress, Value), EngineError> {
        let code = schema_code(&self.drive.schema, &self.drive.target, key)?;
        let field = self.field(key)?;
        let value = value_of(&self.drive.schema, code, raw).map_err(|e| {
            self.refused(
                super::LecomRefusal::Value {
                    code: code_name(&self.drive.schema, key),
                    value: shown_value(&self.drive.schema, key, raw),
                    detail: e,
                }
                .into(),
            )
        })?;
        Ok((field, value))
    }

    /// BROADCAST (8.J) of `key` = `raw` to every drive on the line
    /// (address 00). **Unacknowledged**: no drive answers, so nothing tells
    /// whether any took it; read back from each station to know.
    pub fn broadcast(&mut self, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        self.send_broadcast(ControllerAddress::ALL, key, raw)
    }

    /// MULTICAST (8.J) to the group `tens`1..`tens`9 (address `tens`0,
    /// `tens` = 1..=9). **Unacknowledged**, like [`LecomClient::broadcast`].
    pub fn multicast(&mut self, tens: u8, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        let to = ControllerAddress::group(tens)
            .ok_or_else(|| self.refused(super::LecomRefusal::Group { tens }.into()))?;
        self.send_broadcast(to, key, raw)
    }

    fn send_broadcast(
        &mut self,
        to: ControllerAddress,
        key: CodeKey,
        raw: &RawValue,
    ) -> Result<(), EngineError> {
        let code = schema_code(&self.drive.schema, &self.drive.target, key)?;
        refuse_read_only(&self.drive.schema, &self.drive.target, key, code)?;
        let cleared = guard::check(
            &self.drive.schema,
            &self.drive.target,
            key,
            raw,
            Permit::SETTING,
        )?;
        let (field, value) = self.encode(key, raw)?;
        let t = guard::lecom_broadcast(&cleared, to, field, value)
            .map_err(|e| self.encode_refused(None, e))?;
        let bytes = t.to_bytes().map_err(|e| self.encode_refused(None, e))?;
        self.drive
            .line
            .send(&bytes)
            .map_err(|e| link_error(&self.drive.target, e))
    }
}

impl<L: ByteLink> Protocol for LecomClient<L> {
    type Line = LecomLine<L>;

    fn drive(&self) -> &Drive<LecomLine<L>> {
        &self.drive
    }

    fn read_key(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        self.read_code(key, what)
    }

    /// The one identify loop, VD values in engineering notation
    /// (`ident_value`).
    fn identify(&mut self) -> Result<super::Identity, EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        super::identify::identify(&schema, |key, what| self.read_code(key, what), ident_value)
    }

    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        permit: Permit,
    ) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        refuse_read_only(&schema, &self.drive.target, key, code)?;
        let cleared = guard::check(&schema, &self.drive.target, key, raw, permit)?;
        let what = write_what(&schema, key, raw);
        let (field, value) = self.encode(key, raw)?;
        let t = guard::lecom_send(&cleared, self.address, field, value)
            .map_err(|e| self.encode_refused(None, e))?;
        let bytes = t.to_bytes().map_err(|e| self.encode_refused(None, e))?;
        let mut last = String::new();
        let mut sends = 0u32;
        while sends < self.tries() {
            if sends > 0 {
                self.drive.line.stats.retries += 1;
            }
            sends += 1;
            // ACK / NAK
            let timeout = self.timeout(1);
            let out = self
                .drive
                .line
                .exchange(&bytes, None, timeout)
                .map_err(|e| link_error(&self.drive.target, e))?;
            match out {
                Outcome::Answer(Response::Ack) => return Ok(()),
                Outcome::Answer(Response::Nak) => {
                    let (status, extended) = self.nak_cause(&what)?;
                    let comm = status.last_communication_error();
                    match comm.advice() {
                        Advice::Repeat if sends < self.tries() => {
                            last = format!("NAK: {}", comm.text());
                        }
                        _ => {
                            let cause = DeviceCause::LecomNak { status, extended };
                            return Err(device(&self.drive.target, &what, cause));
                        }
                    }
                }
                Outcome::Answer(r) => last = format!("{r} to a SEND"),
                Outcome::Garbled(g) => last = g,
                Outcome::NoAnswer => last.clear(),
            }
        }
        Err(self.no_answer(&what, &last))
    }

    fn read_time(&self, key: CodeKey) -> Duration {
        let ty = self
            .drive
            .schema
            .code(key.number)
            .and_then(|c| self.drive.schema.type_of(c));
        let Some(code) = code_address(key) else {
            return Duration::ZERO;
        };
        // EOT AD1 AD2 code ENQ, then the answer (VD: a typical 6 characters).
        let answer = match ty {
            Some(ValueType::VH) => 3 + code.wire_len() + 5,
            Some(ValueType::VD) | None => 3 + code.wire_len() + 6,
            _ => answer_len(code, ty),
        };
        wire_time(4 + code.wire_len() + answer, self.baud()) + MIN_REACTION
    }

    fn write_time(&self, key: CodeKey) -> Duration {
        let Some(code) = code_address(key) else {
            return Duration::ZERO;
        };
        // EOT AD1 AD2 STX code value ETX BCC, then ACK.
        let value = 6;
        wire_time(6 + code.wire_len() + value + 1, self.baud()) + MIN_REACTION
    }

    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        let Some(ind) = self.drive.schema.running_indicator() else {
            return Ok(None);
        };
        let key = CodeKey::new(ind.code);
        let what = format!("read {} (running?)", code_name(&self.drive.schema, key));
        let v = self.receive(key, Some(ValueType::VH), &what)?;
        let word = match v {
            Value::Hex(h) => i64::from(h.get()),
            Value::Decimal(d) => d.as_integer().unwrap_or(0),
            _ => 0,
        };
        Ok(Some(word >> ind.bit & 1 == 1))
    }

    fn finish(&mut self) -> Result<(), EngineError> {
        self.drive
            .line
            .finish()
            .map_err(|e| link_error(&self.drive.target, e))
    }
}

/// RECEIVE of `key` at `address` on `line` (the scan probe): `Ok(None)`
/// when nothing answers, `Ok(Some(value text))` for any answer (a value,
/// "?" or "no such code": a drive is there).
pub(crate) fn probe<L: ByteLink>(
    line: &mut LecomLine<L>,
    address: ControllerAddress,
    key: CodeKey,
    timeout: Duration,
    tries: u32,
) -> Result<Option<String>, LinkError> {
    let Some(code) = code_address(key) else {
        return Ok(None);
    };
    let Ok(bytes) = Telegram::Receive(Receive { address, code }).to_bytes() else {
        return Ok(None);
    };
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            line.stats.retries += 1;
        }
        match line.exchange(&bytes, Some(code), timeout)? {
            Outcome::Answer(Response::Value { value, .. }) => return Ok(Some(value.to_string())),
            Outcome::Answer(Response::NoSuchCode { .. }) => {
                return Ok(Some("(no such code)".into()));
            }
            Outcome::Answer(_) | Outcome::Garbled(_) | Outcome::NoAnswer => {}
        }
    }
    Ok(None)
}
