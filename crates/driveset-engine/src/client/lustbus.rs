//! [`LustbusClient`]: LUSTBUS (`lustbus-protocol.txt`) for Lust SMARTDRIVE
//! VF1000 inverters and MASTERCONTROL MC6000/7000 servocontrollers, the
//! family taken from the schema's protocol (`lustbus-vf1000` /
//! `lustbus-mc`).
//!
//! # Telegrams
//!
//! - Read: ENQUIRY `EOT ADR CODE ENQ` (section 6.1). CODE is `001pp` on the
//!   VF1000 (specifier 0, data set 0, device number 1 as section 2.4.1 says;
//!   [`LustbusOptions::vf_device`]), `20ppp` on the MC (specifier 2, 2.4.2),
//!   and `000pp` for the numerically compatible parameters 81..85 and 91 on
//!   both (5.2; the schema's `compatible = true`, or those numbers).
//! - Write: SELECT `EOT ADR STX CODE = VALUE ETX BCC` (6.2), VALUE encoded
//!   by the codec's [`ParameterValue`] for the schema's PT_* type (VF1000 4
//!   hex digits, MC without leading zeros). A code the schema leaves
//!   untyped is read and written as the type its `width` implies (1 byte
//!   PT_USIGN8, 2 PT_USIGN16, 4 PT_INT32Q16, as the simulator does); with
//!   neither, a read gives the plain hex integer and a write is refused.
//! - The trailing EOT of one exchange is the leading EOT of the next
//!   (section 3: "the Host computer sends the EOT character before and after
//!   each data sequence"): every telegram starts with its EOT and nothing is
//!   sent after a reply; [`DriveClient::finish`] sends the final lone EOT.
//! - Replies go through the codec's master-side [`ReplyDecoder`] (parity
//!   masked, resynchronising on garbage); a reply from another address, a
//!   value reply for another CODE or a broken telegram counts as garbled.
//!
//! # Answer timeout and retries
//!
//! From the end of the request: the longest reaction time of section 10
//! (MC 30 ms / VF1000 60 ms with KEYPAD, 25 / 30 ms without:
//! [`LustbusOptions::keypad`], default with) + the reply's wire time at 10
//! bits a character + the link's allowance ([`super::timing`]: measured
//! from the session's round trips, at least 10 ms, at most 1 s, 200 ms
//! before the first reply; at least the port's `?latency=` plus 10 ms,
//! [`LustbusOptions::latency`]). A VF1000 SELECT to an EEPROM parameter
//! (kind `eeprom`, `fsel-isel` or unknown) adds the ACK delay of section 10
//! exception 4: 60 ms for a one-byte, 120 ms for a wider parameter.
//! [`LustbusOptions::answer_timeout`] replaces the computed figure. No
//! answer or a garbled one: the client listens as long again for a late
//! reply (counted and dropped, [`ClientStats::late`]), then the telegram is
//! sent again (input discarded first), [`LustbusOptions::tries`] times in
//! all (default 3), then [`EngineError::NoAnswer`]. A value reply from
//! another address or for another CODE is a late reply too and never taken
//! for the answer.
//!
//! # SIOF / SERR (85)
//!
//! Read before the first SELECT of a session: that read clears the power-on
//! bit every start sets (section 6) and whatever else is latched. After
//! that, SIOF is read after every NAK to a SELECT (6.2 note, 9.2) and
//! decoded with the codec's [`Siof`]:
//!
//! - 0x04 EEPROM busy: wait (MC: the rest of the store time the client
//!   tracks, at least [`LustbusOptions::eeprom_busy_wait`], default 61 ms,
//!   since 9.2 says "> 60 ms") and repeat, at most
//!   [`LustbusOptions::busy_repeats`] times;
//! - 0x08 checksum: repeat (counts against `tries`);
//! - 0x01 power on: [`EngineError::Restarted`] (the drive restarted since
//!   the session began; what was written is void);
//! - 0x02, 0x20, 0x40, 0x80 and undocumented bits: [`EngineError::Device`]
//!   with the 9.2 cause, the raw word and the remedy;
//! - a NAK with nothing latched: repeated like a checksum error, then
//!   `Device`.
//!
//! A NAK to an ENQUIRY means "no such parameter or read-protected in the
//! current operating state" (6.1 note) and is a `Device` error; it latches
//! nothing. A public [`DriveClient::read`] of 85 goes through the same
//! bookkeeping (the read clears the word, so the client must interpret it).
//!
//! # MC6000/7000 EEPROM pacing (sections 3, 10.2.2)
//!
//! After an ACKed SELECT to an EEPROM parameter the servo stores it in the
//! background for width x 3 x 5 ms from the ACK. [`DriveClient::ready_for_write`]
//! reports that instant for the next EEPROM write; reads and RAM writes are
//! never held back. [`DriveClient::write`] of an EEPROM parameter waits on
//! the link's clock only for what is left of it, so a caller that used the
//! gap for reads waits nothing. (An unknown width counts as 4 bytes.)
//!
//! # MC6000/7000 dataset download (section 11.4)
//!
//! [`DriveClient::dataset_begin`] writes 80-SLOAD = -1 (a NAK with 0x40:
//! the drive is not at standstill). While the download is open, writes of
//! CardWriteable codes are staged by the drive (no EEPROM pacing); a write
//! of any other code is refused before sending, since the drive would ACK
//! it and silently not take it. [`DriveClient::dataset_commit`] writes
//! SLOAD = -2 and polls SLOAD until it leaves -1 / -2: 0 accepted, > 0
//! rejected at that parameter; still checking when the timeout passes is a
//! `Device` error (11.4: repeat the transfer or restart the drive). Polls
//! start at most every [`crate::plan::SLOAD_POLL_INTERVAL`] (50 ms) or one
//! measured round trip, whichever is longer, sleeping on the link's clock
//! in between; the count is [`ClientStats::sload_polls`].
//!
//! # running()
//!
//! The schema's running indicator (`Schema::running_indicator`: a status
//! bit of role `running`, else the control word's `start` bit): MC bit 0
//! ("start") of 416-SCTL1 (section 7.2.1); VF1000 bit 7 of 3-CNTL (7.1.1,
//! CNTL = 128 "start clockwise"). `None` when the schema has none.

use std::sync::Arc;
use std::time::Duration;

use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, Clock, Instant, LinkError};
use driveset_proto::lustbus::{
    Address, Dialect, Enquiry, ParameterCode, ParameterType, ParameterValue, Reply, ReplyDecoder,
    Siof, SiofAction, ValueText,
};
use driveset_schema::schema::StorageKind;
use driveset_schema::{Code, CodeKey, Family, RawValue, Schema, ValueType};

use super::timing::LinkLatency;
use super::{
    ClientStats, DatasetOutcome, DriveClient, IdentCode, IdentProtocol, IdentValue, Identity,
    Target, code_name, device, link_error, refuse_read_only, schema_code, shown_value, write_what,
};
use crate::error::{
    DeviceCause, EngineError, LustbusCodeProblem, Refusal, SiofRegister, SiofVerdict,
};
use crate::guard::{self, Permit};
use crate::plan;

/// 80-SLOAD, the dataset download handshake (MC, section 11.4).
pub const SLOAD: u32 = 80;
/// 85-SIOF / SERR, the serial interface error word (sections 5.2, 9.2).
pub const SIOF: u32 = 85;
/// 91-TYPE, the device type (section 5.2).
pub const TYPE: u32 = 91;
/// MC 416-SCTL1, the LUSTBUS control word (section 7.2).
pub const MC_SCTL1: u32 = 416;
/// VF1000 3-CNTL, the control word (section 7.1).
pub const VF_CNTL: u32 = 3;

/// The minimum reaction time of section 10 (both families), for planning.
const MIN_REACTION: Duration = plan::LUSTBUS_MIN_REACTION;

/// The numerically compatible parameters (section 5.2), CODE `000xx`.
const COMPATIBLE: [u32; 6] = [81, 82, 83, 84, 85, 91];

/// Why the value of `code` is never broadcast to address 31 (`None`: it
/// may be, inside open dataset downloads): a numerically compatible code
/// (81..85, 91, section 5.2; a VF1000 executes CODE `000xx` as its own), a
/// code with a role, one that is not CardWriteable (section 11.4), the
/// dataset handshake itself. [`LustbusClient::broadcast`] refuses by it and
/// the line runner chooses its values by it.
pub fn not_broadcast(schema: &Schema, code: &driveset_schema::Code) -> Option<String> {
    if COMPATIBLE.contains(&code.number) || code.compatible == Some(true) {
        return Some(
            "a numerically compatible code (81..85, 91; section 5.2) is never broadcast".into(),
        );
    }
    if let Some(role) = schema.role_of(code.number) {
        return Some(format!(
            "a code with role `{}` is never broadcast",
            role.as_str()
        ));
    }
    if code.card_writeable != Some(true) {
        return Some(
            "not CardWriteable: only values a dataset download stages are broadcast (section 11.4)"
                .into(),
        );
    }
    if schema.family.descriptor().dataset.map(|h| h.code) == Some(code.number) {
        return Some("the dataset handshake (80-SLOAD) is never broadcast".into());
    }
    None
}

/// Options of a [`LustbusClient`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LustbusOptions {
    /// Times a telegram is sent before giving up on no (or a garbled)
    /// answer, and before giving up on a SELECT NAKed for a checksum error.
    /// Default 3; 0 counts as 1.
    pub tries: u32,
    /// Whether a KEYPAD may be attached: the longest reaction time of
    /// section 10 is then MC 30 ms / VF1000 60 ms, else 25 / 30 ms.
    /// Default `true` (the safe assumption).
    pub keypad: bool,
    /// The round-trip delay the transport adds (the port's `?latency=`):
    /// the least allowance is this plus 10 ms from the first telegram on,
    /// and measurement can only raise it ([`super::timing`]). Default
    /// `None`: measured, 200 ms before the first reply.
    pub latency: Option<Duration>,
    /// Replaces the computed answer timeout (still plus the VF1000 EEPROM
    /// ACK delay for such writes); no allowance is added.
    pub answer_timeout: Option<Duration>,
    /// Shortest wait after a SELECT refused with "EEPROM busy" (section
    /// 9.2: "> 60 ms"). Default 61 ms.
    pub eeprom_busy_wait: Duration,
    /// How often a SELECT refused with "EEPROM busy" is repeated. Default 10.
    pub busy_repeats: u32,
    /// VF1000 device number, the third CODE digit (section 2.4.1: "always
    /// 1"). Default 1.
    pub vf_device: u8,
    /// Send a lone EOT after every reply as well as before every telegram
    /// (the naive reading of section 3; costs one character time per
    /// exchange). Default `false`: the trailing EOT of one exchange is the
    /// leading EOT of the next. For benchmarks.
    pub eot_after_reply: bool,
}

impl Default for LustbusOptions {
    fn default() -> Self {
        LustbusOptions {
            tries: 3,
            keypad: true,
            latency: None,
            answer_timeout: None,
            eeprom_busy_wait: Duration::from_millis(61),
            busy_repeats: 10,
            vf_device: 1,
            eot_after_reply: false,
        }
    }
}

/// What one exchange gave.
#[derive(Debug)]
enum Outcome {
    Reply(Reply),
    NoAnswer,
    Garbled(String),
}

/// The line: link, reply decoder, counters, the link's latency. Shared by
/// the client and scan.
#[derive(Debug)]
pub(crate) struct LustLine<L> {
    pub(crate) link: L,
    decoder: ReplyDecoder,
    pub(crate) stats: ClientStats,
    /// A telegram went out since the last lone EOT.
    open: bool,
    /// Send a lone EOT after every reply ([`LustbusOptions::eot_after_reply`]).
    pub(crate) eot_after_reply: bool,
    /// The link's measured latency ([`super::timing`]).
    pub(crate) latency: LinkLatency,
    /// Listen for a late reply after a timeout (scan probes do not: they
    /// move on to another address, whose reply tells itself apart).
    pub(crate) wait_late: bool,
}

impl<L: ByteLink> LustLine<L> {
    pub(crate) fn new(link: L) -> Self {
        LustLine {
            link,
            decoder: ReplyDecoder::new(),
            stats: ClientStats::default(),
            open: false,
            eot_after_reply: false,
            latency: LinkLatency::new(None),
            wait_late: true,
        }
    }

    /// Send one telegram: drop unread input first (a late answer to an
    /// earlier request is not this one's reply), send, wait until it has
    /// left, count it.
    fn send_telegram(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.link.discard_input()?;
        self.link.send(bytes)?;
        self.link.flush()?;
        self.open = true;
        self.stats.telegrams += 1;
        self.stats.sent += bytes.len() as u64;
        Ok(())
    }

    /// Sends `bytes` (a complete telegram, leading EOT included) and waits
    /// `timeout` from the end of the send for a reply from `address`
    /// (`expect_code`: the CODE a value reply must carry). `known_delay`
    /// is what the drive is known to add to its reaction (VF1000 EEPROM ACK
    /// delay), left out of the latency sample. After a timeout, listens
    /// for a late reply for as long again (see [`super::timing`]).
    fn exchange(
        &mut self,
        bytes: &[u8],
        address: Address,
        expect_code: Option<ParameterCode>,
        timeout: Duration,
        known_delay: Duration,
    ) -> Result<Outcome, LinkError> {
        self.decoder.reset();
        self.send_telegram(bytes)?;
        let start = self.link.clock().now();
        let deadline = start + timeout;
        let mut late_until: Option<Instant> = None;
        let mut garbled: Option<String> = None;
        let mut received = 0usize;
        let mut buf = [0u8; 128];
        loop {
            let n = self.link.recv(&mut buf, late_until.unwrap_or(deadline))?;
            if n == 0 {
                if late_until.is_none() {
                    self.latency.timed_out();
                    if self.wait_late {
                        // Timed out: a reply may still be on its way.
                        // Listen as long again so that it cannot be taken
                        // for the answer to the next telegram.
                        late_until = Some(deadline + self.latency.late_window(timeout));
                        continue;
                    }
                }
                for ev in self.decoder.finish() {
                    if let Err(e) = ev.result {
                        garbled = Some(e.to_string());
                    }
                }
                return Ok(match garbled {
                    Some(g) => Outcome::Garbled(g),
                    None => Outcome::NoAnswer,
                });
            }
            let got = buf.get(..n).unwrap_or(&[]);
            self.stats.received += got.len() as u64;
            received += got.len();
            for ev in self.decoder.feed(got) {
                match ev.result {
                    Ok(reply) => {
                        if address != Address::ALL && reply.address() != address {
                            // A late reply of another drive (or a drive
                            // with a wrong address): never this answer.
                            self.stats.late += 1;
                            garbled = Some(format!(
                                "a reply from address {} (a late reply, or another drive with a wrong address?)",
                                reply.address()
                            ));
                            continue;
                        }
                        if let (Reply::Value(v), Some(code)) = (&reply, expect_code)
                            && v.code != code
                        {
                            // A late reply to an earlier ENQUIRY.
                            self.stats.late += 1;
                            garbled = Some(format!(
                                "a value reply for CODE {} instead of {code} (late, discarded)",
                                v.code
                            ));
                            continue;
                        }
                        let elapsed = self.link.clock().now().saturating_duration_since(start);
                        let expected = wire_time(received, self.link.baud())
                            .saturating_add(MIN_REACTION)
                            .saturating_add(known_delay);
                        self.latency.observe(elapsed, expected);
                        if late_until.is_some() {
                            // The answer to this telegram, after its
                            // timeout: dropped, the telegram is repeated.
                            self.stats.late += 1;
                            return Ok(Outcome::Garbled(format!(
                                "a reply {} ms after the request, later than the answer timeout of {} ms (late, discarded)",
                                elapsed.as_millis(),
                                timeout.as_millis()
                            )));
                        }
                        if self.eot_after_reply {
                            self.link.send(&[driveset_proto::ascii::EOT])?;
                            self.link.flush()?;
                            self.stats.sent += 1;
                        }
                        return Ok(Outcome::Reply(reply));
                    }
                    Err(e) => garbled = Some(e.to_string()),
                }
            }
        }
    }

    /// Forget a partly decoded reply (after a rate change).
    pub(crate) fn reset_decoder(&mut self) {
        self.decoder.reset();
    }

    /// The lone EOT that ends a session, if a telegram went out.
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

/// Wire family of a LUSTBUS schema.
fn family_of(schema: &Schema) -> Option<Dialect> {
    dialect_of(schema.family)
}

/// The LUSTBUS dialect a family speaks (sections 2.3, 2.4): `None` for
/// the families on other buses. The one mapping from the family
/// descriptor to the codec's dialect.
pub fn dialect_of(family: Family) -> Option<Dialect> {
    match family {
        Family::Vf1000 => Some(Dialect::Vf1000),
        Family::Mc6000 => Some(Dialect::Mc),
        Family::Tmd | Family::Ecs => None,
    }
}

/// The codec type of a code (see the module docs for untyped codes).
fn wire_type(schema: &Schema, code: &Code, family: Dialect) -> Option<ParameterType> {
    let t = match schema.type_of(code) {
        Some(ValueType::PT_USIGN8) => ParameterType::Usign8,
        Some(ValueType::PT_BINARY8) => ParameterType::Binary8,
        Some(ValueType::PT_USIGN16) => ParameterType::Usign16,
        Some(ValueType::PT_PASSWORD) => ParameterType::Password,
        Some(ValueType::PT_INTEGER16) => ParameterType::Integer16,
        Some(ValueType::PT_FIXPOINT16) => ParameterType::Fixpoint16,
        Some(ValueType::PT_INT32Q16) => ParameterType::Int32Q16,
        Some(ValueType::PT_FLOAT_IEEE) => ParameterType::FloatIeee,
        Some(ValueType::PT_VF_ERROR) => ParameterType::VfError,
        Some(ValueType::PT_MC_ERROR) => ParameterType::McError,
        Some(_) => return None,
        None => match code.width {
            Some(1) => ParameterType::Usign8,
            Some(2) => ParameterType::Usign16,
            Some(4) => ParameterType::Int32Q16,
            _ => return None,
        },
    };
    t.in_family(family).then_some(t)
}

/// The raw integer of a typed value (signed types sign-extended).
fn raw_of(v: &ParameterValue) -> i64 {
    match *v {
        ParameterValue::Integer16(i) => i64::from(i),
        ParameterValue::Int32Q16(q) => i64::from(q.0),
        other => i64::from(other.raw()),
    }
}

/// The typed value of a raw integer, if the type can carry it.
fn value_of(ty: ParameterType, raw: i64) -> Option<ParameterValue> {
    let wire = match ty {
        ParameterType::Integer16 => i16::try_from(raw).ok()? as u16 as u32,
        ParameterType::Int32Q16 => i32::try_from(raw).ok()? as u32,
        _ => u32::try_from(raw).ok()?,
    };
    ParameterValue::from_raw(ty, wire)
}

/// Plain hex of an untyped reply.
fn parse_hex(text: &[u8]) -> Option<i64> {
    if text.is_empty() || text.len() > 8 {
        return None;
    }
    let s = std::str::from_utf8(text).ok()?;
    u32::from_str_radix(s, 16).ok().map(i64::from)
}

/// A LUSTBUS drive (VF1000 or MC6000/7000) at one address.
#[derive(Debug)]
pub struct LustbusClient<L: ByteLink = Box<dyn ByteLink>> {
    line: LustLine<L>,
    schema: Arc<Schema>,
    target: Target,
    family: Dialect,
    address: Address,
    opts: LustbusOptions,
    /// SIOF/SERR has been read (and so cleared) in this session.
    siof_checked: bool,
    /// MC: the EEPROM is storing until then.
    eeprom_busy_until: Option<Instant>,
    /// MC: SLOAD = -1 was accepted and not yet committed.
    dataset_open: bool,
}

impl<L: ByteLink> LustbusClient<L> {
    /// A client for the drive at `address` (0 = whichever single drive is
    /// on the line, 1..=30 a drive's own address; 31 is the broadcast
    /// address and refused) with default options.
    pub fn new(link: L, schema: Arc<Schema>, address: u8) -> Result<Self, EngineError> {
        Self::with_options(link, schema, address, LustbusOptions::default())
    }

    /// As [`LustbusClient::new`] with `opts`.
    pub fn with_options(
        link: L,
        schema: Arc<Schema>,
        address: u8,
        opts: LustbusOptions,
    ) -> Result<Self, EngineError> {
        let target = Target {
            port: link.port().to_string(),
            address,
        };
        let Some(family) = family_of(&schema) else {
            return Err(EngineError::refused(
                target,
                Refusal::WrongClient {
                    schema: schema.id.clone(),
                    family: schema.family.to_string(),
                    protocol: driveset_schema::BusProtocol::Lustbus,
                },
            ));
        };
        let address = match crate::error::AddressRefused::check_client(
            driveset_schema::BusProtocol::Lustbus,
            address,
        )
        .and_then(|()| {
            Address::new(address).ok_or(Refusal::Encode {
                what: None,
                detail: format!("address {address}"),
            })
        }) {
            Ok(a) => a,
            Err(refusal) => return Err(EngineError::refused(target, refusal)),
        };
        let mut line = LustLine::new(link);
        line.eot_after_reply = opts.eot_after_reply;
        line.latency = LinkLatency::new(opts.latency);
        Ok(LustbusClient {
            line,
            schema,
            target,
            family,
            address,
            opts,
            siof_checked: false,
            eeprom_busy_until: None,
            dataset_open: false,
        })
    }

    /// The link.
    pub fn link(&self) -> &L {
        &self.line.link
    }

    /// The link, mutably (tests, reopening).
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.line.link
    }

    /// The link back (without sending the final EOT: call
    /// [`DriveClient::finish`] first).
    pub fn into_link(self) -> L {
        self.line.link
    }

    /// The options in use.
    pub fn options(&self) -> &LustbusOptions {
        &self.opts
    }

    fn now(&self) -> Instant {
        self.line.link.clock().now()
    }

    fn baud(&self) -> u32 {
        self.line.link.baud()
    }

    fn tries(&self) -> u32 {
        self.opts.tries.max(1)
    }

    fn max_reaction(&self) -> Duration {
        match (self.family, self.opts.keypad) {
            (Dialect::Mc, true) => plan::MC_MAX_REACTION_KEYPAD,
            (Dialect::Mc, false) => plan::MC_MAX_REACTION,
            (Dialect::Vf1000, true) => plan::VF_MAX_REACTION_KEYPAD,
            (Dialect::Vf1000, false) => plan::VF_MAX_REACTION,
        }
    }

    /// The answer timeout now for a reply of `reply_chars` characters:
    /// the longest reaction + the reply's wire time + the link's allowance
    /// (module docs).
    fn timeout(&self, reply_chars: usize) -> Duration {
        self.opts.answer_timeout.unwrap_or_else(|| {
            self.max_reaction()
                .saturating_add(wire_time(reply_chars, self.baud()))
                .saturating_add(self.line.latency.allowance())
        })
    }

    /// The link's measured latency so far.
    pub fn latency(&self) -> &LinkLatency {
        &self.line.latency
    }

    /// CODE of a parameter number.
    fn code_for(&self, key: CodeKey, code: Option<&Code>) -> Result<ParameterCode, EngineError> {
        let refuse = |problem: LustbusCodeProblem| {
            EngineError::refused(
                self.target.clone(),
                Refusal::LustbusCode {
                    code: code_name(&self.schema, key),
                    problem,
                },
            )
        };
        if key.subcode.is_some() {
            return Err(refuse(LustbusCodeProblem::HasSubcode));
        }
        let compatible =
            code.and_then(|c| c.compatible) == Some(true) || COMPATIBLE.contains(&key.number);
        if compatible && key.number < 100 {
            return ParameterCode::new(key.number)
                .ok_or_else(|| refuse(LustbusCodeProblem::NotAddressable));
        }
        match self.family {
            Dialect::Vf1000 => u8::try_from(key.number)
                .ok()
                .and_then(|p| ParameterCode::vf_value(self.opts.vf_device, p))
                .ok_or_else(|| refuse(LustbusCodeProblem::AboveVf1000Range)),
            Dialect::Mc => u16::try_from(key.number)
                .ok()
                .and_then(ParameterCode::mc_value)
                .ok_or_else(|| refuse(LustbusCodeProblem::AboveMcRange)),
        }
    }

    /// Hex digits of a value reply of `code`: VF1000 4, MC 2 per byte of
    /// width (8 if unknown; `max`: the longest the codec allows, 8).
    fn value_len(&self, code: Option<&Code>, max: bool) -> usize {
        match self.family {
            Dialect::Vf1000 => 4,
            Dialect::Mc if max => 8,
            Dialect::Mc => code
                .and_then(|c| c.width)
                .map_or(8, |w| usize::from(w).clamp(1, 4) * 2),
        }
    }

    /// One ENQUIRY with retries: `Ok(Some(text))` for a value, `Ok(None)`
    /// for NAK.
    fn enquire(
        &mut self,
        code: ParameterCode,
        value_len: usize,
        what: &str,
    ) -> Result<Option<ValueText>, EngineError> {
        let bytes = Enquiry::new(self.address, code).encode();
        let mut last = String::new();
        for attempt in 0..self.tries() {
            if attempt > 0 {
                self.line.stats.retries += 1;
            }
            // ADR STX CODE(5) '=' VALUE ETX BCC
            let timeout = self.timeout(10 + value_len);
            let out = self
                .line
                .exchange(&bytes, self.address, Some(code), timeout, Duration::ZERO)
                .map_err(|e| link_error(&self.target, e))?;
            match out {
                Outcome::Reply(Reply::Value(v)) => return Ok(Some(v.value)),
                Outcome::Reply(Reply::Nak(_)) => return Ok(None),
                Outcome::Reply(Reply::Ack(_)) => last = "ACK to an ENQUIRY".into(),
                Outcome::Garbled(g) => last = g,
                Outcome::NoAnswer => last.clear(),
            }
        }
        Err(self.no_answer(what, &last))
    }

    fn no_answer(&self, what: &str, last: &str) -> EngineError {
        let what = if last.is_empty() {
            what.to_string()
        } else {
            format!("{what} (last answer: {last})")
        };
        EngineError::no_answer(self.target.clone(), what, self.tries())
    }

    /// One SELECT with retries on no answer: `Ok(true)` ACK, `Ok(false)`
    /// NAK. `known_delay`: the drive's known extra reaction (VF1000 EEPROM
    /// ACK delay), added to the timeout.
    fn select_once(
        &mut self,
        bytes: &[u8],
        known_delay: Duration,
        what: &str,
    ) -> Result<bool, EngineError> {
        let mut last = String::new();
        for attempt in 0..self.tries() {
            if attempt > 0 {
                self.line.stats.retries += 1;
            }
            // ADR ACK / ADR NAK
            let timeout = self.timeout(2).saturating_add(known_delay);
            let out = self
                .line
                .exchange(bytes, self.address, None, timeout, known_delay)
                .map_err(|e| link_error(&self.target, e))?;
            match out {
                Outcome::Reply(Reply::Ack(_)) => return Ok(true),
                Outcome::Reply(Reply::Nak(_)) => return Ok(false),
                Outcome::Reply(Reply::Value(v)) => {
                    last = format!("a value reply ({}) to a SELECT", v.code);
                }
                Outcome::Garbled(g) => last = g,
                Outcome::NoAnswer => last.clear(),
            }
        }
        Err(self.no_answer(what, &last))
    }

    fn siof_name(&self) -> &'static str {
        match self.family {
            Dialect::Vf1000 => "SIOF",
            Dialect::Mc => "SERR",
        }
    }

    /// [`DeviceCause::Siof`] of this family's register.
    fn siof_cause(&self, what: &str, bits: Siof, verdict: SiofVerdict) -> EngineError {
        let register = match self.family {
            Dialect::Vf1000 => SiofRegister::Siof,
            Dialect::Mc => SiofRegister::Serr,
        };
        device(
            &self.target,
            what,
            DeviceCause::Siof {
                register,
                bits,
                verdict,
            },
        )
    }

    /// Reads (and so clears) SIOF/SERR. A power-on bit after the first
    /// read of the session is [`EngineError::Restarted`].
    fn read_siof(&mut self, during: &str) -> Result<Siof, EngineError> {
        let what = format!("read 85-{} after {during}", self.siof_name());
        let code = ParameterCode::new(SIOF).unwrap_or(ParameterCode::POSMOD);
        let text = self
            .enquire(code, 4, &what)?
            .ok_or_else(|| device(&self.target, &what, DeviceCause::SiofUnreadable))?;
        let v = ParameterValue::decode(ParameterType::Usign16, self.family, text.as_bytes())
            .ok()
            .and_then(|v| u8::try_from(v.raw()).ok())
            .ok_or_else(|| {
                EngineError::protocol(
                    self.target.clone(),
                    what.clone(),
                    format!("SIOF/SERR value `{text}` is not an 8-bit hex word"),
                )
            })?;
        let siof = Siof(v);
        let first = !self.siof_checked;
        self.siof_checked = true;
        if !first && siof.contains(Siof::POWER_ON) {
            self.eeprom_busy_until = None;
            self.dataset_open = false;
            return Err(EngineError::restarted(
                self.target.clone(),
                during.to_string(),
            ));
        }
        Ok(siof)
    }

    fn ensure_session(&mut self, during: &str) -> Result<(), EngineError> {
        if !self.siof_checked {
            // The start-of-session read: whatever was latched (power on
            // after every start, section 6) is cleared by it.
            self.read_siof(during)?;
        }
        Ok(())
    }

    /// Whether `code` is stored in EEPROM (MC pacing, VF1000 ACK delay).
    /// Unknown kinds count as EEPROM on the VF1000 (a longer timeout only)
    /// and as RAM on the MC pacing unless the code is typed as EEPROM.
    fn is_eeprom(code: &Code) -> bool {
        matches!(code.kind, Some(StorageKind::Eeprom))
    }

    fn store_time(code: &Code) -> Duration {
        let w = code.width.map_or(4, |w| u32::from(w).clamp(1, 4));
        Duration::from_millis(u64::from(
            driveset_proto::lustbus::timing::mc_eeprom_store_ms(w),
        ))
    }

    /// Whether the MC pacing applies to a write of `code` now.
    fn paced(&self, code: &Code) -> bool {
        self.family == Dialect::Mc && Self::is_eeprom(code) && !self.dataset_open
    }

    /// The SELECT path: the write guard ([`guard::check`] under
    /// `permit`), encode, pace, send, handle NAK via SIOF.
    fn select(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        what: &str,
        nak_40_cause: Option<SiofVerdict>,
        permit: Permit,
    ) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.schema);
        let code = schema_code(&schema, &self.target, key)?;
        let cleared = guard::check(&schema, &self.target, key, raw, permit)?;
        let pcode = self.code_for(key, Some(code))?;
        let ty = if key.number == SLOAD && schema.type_of(code).is_none() {
            // 11.4 writes -1 / -2: a signed type, whatever the schema gives.
            Some(ParameterType::Integer16)
        } else {
            wire_type(&schema, code, self.family)
        };
        let Some(ty) = ty else {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::NoWireType {
                    code: code_name(&schema, key),
                    schema: schema.id.clone(),
                    family: self.family.to_string(),
                },
            ));
        };
        let RawValue::Int(n) = raw else {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::NotInteger {
                    code: code_name(&schema, key),
                    value: shown_value(&schema, key, raw),
                },
            ));
        };
        let value = value_of(ty, *n)
            .and_then(|v| v.encode(self.family).ok())
            .ok_or_else(|| {
                EngineError::refused(
                    self.target.clone(),
                    Refusal::DoesNotFit {
                        code: code_name(&schema, key),
                        value: shown_value(&schema, key, raw),
                        ty: ty.name().to_string(),
                    },
                )
            })?;
        let bytes = guard::lustbus_select(&cleared, self.address, pcode, value);
        // Section 10 exception 4 (VF1000: 60 ms one-byte, 120 ms two-byte
        // when the value changes): the family descriptor's one rule, the
        // planner's too. Whether the value changes is not known here, so
        // the answer timeout allows for it.
        let known_delay = schema.family.descriptor().ack_delay(code, true);
        self.ensure_session(what)?;
        let paced = self.paced(code);
        let mut checksum_repeats = 0u32;
        let mut busy_repeats = 0u32;
        loop {
            if paced
                && let Some(until) = self.eeprom_busy_until
                && until > self.now()
            {
                self.line.link.clock().sleep_until(until);
            }
            if self.select_once(&bytes, known_delay, what)? {
                if paced {
                    self.eeprom_busy_until = Some(self.now() + Self::store_time(code));
                }
                return Ok(());
            }
            let siof = self.read_siof(what)?;
            match siof.action() {
                SiofAction::RepeatAfter { wait_ms } => {
                    busy_repeats += 1;
                    if busy_repeats > self.opts.busy_repeats {
                        return Err(self.siof_cause(
                            what,
                            siof,
                            SiofVerdict::EepromBusy {
                                repeats: self.opts.busy_repeats,
                            },
                        ));
                    }
                    let now = self.now();
                    let rest = self
                        .eeprom_busy_until
                        .map_or(Duration::ZERO, |u| u.saturating_duration_since(now));
                    // The rest of the store time this client tracks; if
                    // it knows of none (another session wrote), the
                    // section 9.2 "> 60 ms".
                    let wait = if rest.is_zero() {
                        self.opts
                            .eeprom_busy_wait
                            .max(Duration::from_millis(u64::from(wait_ms)))
                    } else {
                        rest
                    };
                    self.line.link.clock().sleep(wait);
                    self.line.stats.retries += 1;
                }
                SiofAction::Repeat | SiofAction::None => {
                    checksum_repeats += 1;
                    if checksum_repeats >= self.tries() {
                        let verdict = if siof.is_empty() {
                            SiofVerdict::Unrecorded
                        } else {
                            SiofVerdict::Checksum
                        };
                        return Err(self.siof_cause(what, siof, verdict));
                    }
                    self.line.stats.retries += 1;
                }
                SiofAction::RestartTransaction => {
                    // read_siof reports a power-on bit itself; kept for
                    // completeness.
                    return Err(EngineError::restarted(
                        self.target.clone(),
                        what.to_string(),
                    ));
                }
                SiofAction::Fail => {
                    let verdict = match nak_40_cause {
                        Some(v) if siof.contains(Siof::NO_CHANGE) => v,
                        _ => SiofVerdict::Failed,
                    };
                    return Err(self.siof_cause(what, siof, verdict));
                }
            }
        }
    }

    /// Reads a code; `what` names the operation.
    fn read_key(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        let schema = Arc::clone(&self.schema);
        let code = schema_code(&schema, &self.target, key)?;
        if key.number == SIOF && key.subcode.is_none() {
            let s = self.read_siof("a read of SIOF/SERR")?;
            return Ok(RawValue::Int(i64::from(s.0)));
        }
        let pcode = self.code_for(key, Some(code))?;
        let len = self.value_len(Some(code), true);
        let text = self.enquire(pcode, len, what)?.ok_or_else(|| {
            device(
                &self.target,
                what,
                DeviceCause::NoSuchParameter {
                    parameter: pcode.to_string(),
                },
            )
        })?;
        let ty = if key.number == SLOAD && schema.type_of(code).is_none() {
            Some(ParameterType::Integer16)
        } else {
            wire_type(&schema, code, self.family)
        };
        let raw = match ty {
            Some(ty) => ParameterValue::decode(ty, self.family, text.as_bytes())
                .map(|v| raw_of(&v))
                .map_err(|e| e.to_string()),
            None => parse_hex(text.as_bytes()).ok_or_else(|| "not a hex number".to_string()),
        }
        .map_err(|e| {
            EngineError::protocol(
                self.target.clone(),
                what.to_string(),
                if schema.is_password(code) {
                    format!("the VALUE (password, not shown) does not decode: {e}")
                } else {
                    format!("VALUE `{text}` does not decode: {e}")
                },
            )
        })?;
        Ok(RawValue::Int(raw))
    }
}

impl<L: ByteLink> DriveClient for LustbusClient<L> {
    fn target(&self) -> &Target {
        &self.target
    }

    fn bus_id(&self) -> String {
        self.line.link.bus_id()
    }

    fn schema(&self) -> &Arc<Schema> {
        &self.schema
    }

    fn clock(&self) -> &dyn Clock {
        self.line.link.clock()
    }

    fn identify(&mut self) -> Result<Identity, EngineError> {
        let codes = self
            .schema
            .identify
            .as_ref()
            .map(|i| i.codes.clone())
            .filter(|c| !c.is_empty())
            .unwrap_or_else(|| vec![TYPE]);
        let mut out = Identity::of(IdentProtocol::Family(match self.family {
            Dialect::Vf1000 => Family::Vf1000,
            Dialect::Mc => Family::Mc6000,
        }));
        for n in codes {
            let key = CodeKey::new(n);
            let name = code_name(&self.schema, key);
            let raw = self.read_key(key, &format!("identify: read {name}"))?;
            if let RawValue::Int(v) = raw {
                out.codes
                    .push(IdentCode::new(key, name, IdentValue::Int(v)));
            }
        }
        Ok(out)
    }

    fn read(&mut self, key: CodeKey) -> Result<RawValue, EngineError> {
        let what = format!("read {}", code_name(&self.schema, key));
        self.read_key(key, &what)
    }

    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        permit: Permit,
    ) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.schema);
        let code = schema_code(&schema, &self.target, key)?;
        refuse_read_only(&schema, &self.target, key, code)?;
        if self.dataset_open && code.card_writeable != Some(true) {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::NotCardWriteable {
                    code: code_name(&schema, key),
                },
            ));
        }
        let what = write_what(&schema, key, raw);
        self.select(key, raw, &what, None, permit)
    }

    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        let code = self.schema.code(key.number)?;
        if !self.paced(code) {
            return None;
        }
        self.eeprom_busy_until.filter(|u| *u > self.now())
    }

    fn read_time(&self, key: CodeKey) -> Duration {
        let code = self.schema.code(key.number);
        // EOT ADR CODE ENQ, then ADR STX CODE = VALUE ETX BCC.
        let chars = 8 + 10 + self.value_len(code, false);
        wire_time(chars, self.baud()) + MIN_REACTION
    }

    fn write_time(&self, key: CodeKey) -> Duration {
        let code = self.schema.code(key.number);
        // EOT ADR STX CODE = VALUE ETX BCC, then ADR ACK.
        let chars = 11 + self.value_len(code, false) + 2;
        wire_time(chars, self.baud()) + MIN_REACTION
    }

    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        let Some(ind) = self.schema.running_indicator() else {
            return Ok(None);
        };
        let key = CodeKey::new(ind.code);
        let what = format!("read {} (running?)", code_name(&self.schema, key));
        match self.read_key(key, &what)? {
            RawValue::Int(v) => Ok(Some(v >> ind.bit & 1 == 1)),
            _ => Ok(None),
        }
    }

    fn stats(&self) -> ClientStats {
        self.line.stats
    }

    fn finish(&mut self) -> Result<(), EngineError> {
        self.line.finish().map_err(|e| link_error(&self.target, e))
    }

    fn line_rate(&self) -> Option<u32> {
        Some(self.baud())
    }

    /// Flushes, sets the link's rate, forgets what was received and the
    /// session's EOT state (the next telegram starts with its own EOT at
    /// the new rate); the latency measured so far stays.
    fn set_line_rate(&mut self, baud: u32) -> Result<(), EngineError> {
        let target = self.target.clone();
        let line = &mut self.line;
        line.link.flush().map_err(|e| link_error(&target, e))?;
        line.link
            .set_baud(baud)
            .map_err(|e| link_error(&target, e))?;
        line.link
            .discard_input()
            .map_err(|e| link_error(&target, e))?;
        line.reset_decoder();
        Ok(())
    }

    fn has_dataset_download(&self) -> bool {
        self.family == Dialect::Mc
    }

    fn dataset_begin(&mut self) -> Result<(), EngineError> {
        if self.family != Dialect::Mc {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::Vf1000NoDataset,
            ));
        }
        // A download left open by a failed transfer (no answer, cable) is
        // started over: SLOAD = -1 again discards what the drive staged
        // (section 11.4), so a roll back or recover can stage the backup.
        self.dataset_open = false;
        self.sload_present()?;
        let key = CodeKey::new(SLOAD);
        self.select(
            key,
            &RawValue::Int(-1),
            "dataset download: write 80-SLOAD = -1",
            Some(SiofVerdict::NotAtStandstill),
            Permit::DATASET_BEGIN,
        )?;
        self.dataset_open = true;
        Ok(())
    }

    fn dataset_commit(&mut self, timeout: Duration) -> Result<DatasetOutcome, EngineError> {
        let ended = self.dataset_end()?;
        self.dataset_await(ended, timeout)
    }

    fn dataset_end(&mut self) -> Result<Instant, EngineError> {
        if !self.dataset_open {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::NoDatasetOpen,
            ));
        }
        let key = CodeKey::new(SLOAD);
        let what = "dataset download: write 80-SLOAD = -2";
        let r = self.select(key, &RawValue::Int(-2), what, None, Permit::DATASET_COMMIT);
        self.dataset_open = false;
        r?;
        Ok(self.now())
    }

    fn dataset_await(
        &mut self,
        ended: Instant,
        timeout: Duration,
    ) -> Result<DatasetOutcome, EngineError> {
        self.sload_present()?;
        let key = CodeKey::new(SLOAD);
        let deadline = ended + timeout;
        loop {
            let poll_start = self.now();
            self.line.stats.sload_polls += 1;
            let v = match self.read_key(key, "dataset download: poll 80-SLOAD")? {
                RawValue::Int(v) => v,
                _ => -1,
            };
            match v {
                0 => return Ok(DatasetOutcome::Accepted),
                p if p > 0 => {
                    return Ok(DatasetOutcome::Rejected {
                        parameter: u32::try_from(p).unwrap_or(u32::MAX),
                    });
                }
                -1 | -2 => {
                    // Still checking. The poll that started at the
                    // deadline (section 11.4: 10 s) was the last.
                    if poll_start >= deadline {
                        return Err(device(
                            &self.target,
                            "dataset download: poll 80-SLOAD",
                            DeviceCause::DatasetStillChecking {
                                timeout_ms: u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX),
                                sload: v,
                            },
                        ));
                    }
                    // The next poll at most every 50 ms or one measured
                    // round trip, whichever is longer, and not after the
                    // deadline.
                    let interval = self
                        .line
                        .latency
                        .round_trip()
                        .unwrap_or(Duration::ZERO)
                        .max(plan::SLOAD_POLL_INTERVAL);
                    let next = (poll_start + interval).min(deadline);
                    if next > self.now() {
                        self.line.link.clock().sleep_until(next);
                    }
                }
                other => {
                    return Err(EngineError::protocol(
                        self.target.clone(),
                        "dataset download: poll 80-SLOAD",
                        format!(
                            "SLOAD = {other}: section 11.4 knows only -1, 0 and parameter numbers"
                        ),
                    ));
                }
            }
        }
    }
}

impl<L: ByteLink> LustbusClient<L> {
    /// A raw ENQUIRY of any CODE (parameter descriptions `10dpp` / `30ppp`,
    /// substitution texts `61ppp`, section 11), for `driveset schema
    /// pull`: the VALUE text, or `None` when the drive answers NAK (no such
    /// parameter or text). `value_len` is the longest VALUE expected (for
    /// the answer timeout). Retries like a read; nothing is interpreted and
    /// nothing is written.
    pub fn enquire_code(
        &mut self,
        code: ParameterCode,
        value_len: usize,
    ) -> Result<Option<ValueText>, EngineError> {
        let what = format!("ENQUIRY {code}");
        self.enquire(code, value_len, &what)
    }

    /// MC6000/7000 only: SELECT 108-STEXT = `index` (section 11.3), which
    /// picks the substitution text a following ENQUIRY `61ppp` returns.
    /// STEXT is a RAM selector with no effect on the drive's operation; a
    /// NAK is returned as the decoded [`EngineError::Device`] cause (SERR is
    /// read and so cleared, as after any refused SELECT).
    pub fn select_stext(&mut self, index: u8) -> Result<(), EngineError> {
        if self.family != Dialect::Mc {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::StextMcOnly,
            ));
        }
        let code = ParameterCode::mc_value(driveset_proto::lustbus::description::STEXT)
            .unwrap_or(ParameterCode::POSMOD);
        let value = ParameterValue::Usign8(index)
            .encode(Dialect::Mc)
            .map_err(|e| {
                EngineError::protocol(self.target.clone(), "write 108-STEXT", e.to_string())
            })?;
        let what = format!("write 108-STEXT = {index}");
        let cleared = guard::check(
            &self.schema,
            &self.target,
            CodeKey::new(u32::from(driveset_proto::lustbus::description::STEXT)),
            &RawValue::Int(i64::from(index)),
            Permit::TEXT_SELECTOR,
        )?;
        self.ensure_session(&what)?;
        let bytes = guard::lustbus_select(&cleared, self.address, code, value);
        if self.select_once(&bytes, Duration::ZERO, &what)? {
            return Ok(());
        }
        let siof = self.read_siof(&what)?;
        Err(self.siof_cause(&what, siof, SiofVerdict::NoSubstitutionTexts))
    }

    /// MC6000/7000: SELECT `key` = `raw` to address 31, the broadcast
    /// address (sections 2.1, 4.2): every device on the bus executes it and
    /// none replies (9.1), so nothing is awaited. The value is encoded as
    /// [`DriveClient::write`] encodes it for this client's schema. Then the
    /// client waits the family's longest reaction time (section 10: 30 ms
    /// with KEYPAD), so every device has taken the telegram before the next
    /// one starts (the spec gives no figure for a broadcast; this is the
    /// longest any device takes to process a telegram).
    ///
    /// Only for values staged in open dataset downloads (section 11.4):
    /// refused before sending for a code that is not CardWriteable, for the
    /// numerically compatible codes 81..85 and 91 (CODE `000xx`, which a
    /// VF1000 on the same bus executes as its own SIOC, SIOA, ...), and for
    /// a code with a role (address, baud rate, control, command, mode ...).
    /// Address 31 reaches every device on the bus, listed anywhere or not.
    pub fn broadcast(&mut self, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.schema);
        let code = schema_code(&schema, &self.target, key)?;
        let refuse = |why: String| {
            EngineError::refused(
                self.target.clone(),
                Refusal::Broadcast {
                    code: code_name(&schema, key),
                    why,
                },
            )
        };
        if self.family != Dialect::Mc {
            return Err(refuse(
                "broadcasts go into MC6000/7000 dataset downloads only".into(),
            ));
        }
        if let Some(why) = not_broadcast(&schema, code) {
            return Err(refuse(why));
        }
        let pcode = self.code_for(key, Some(code))?;
        let Some(ty) = wire_type(&schema, code, self.family) else {
            return Err(refuse(format!(
                "schema `{}` gives no type or width, so the value cannot be encoded",
                schema.id
            )));
        };
        let RawValue::Int(n) = raw else {
            return Err(refuse("LUSTBUS parameters hold integers".into()));
        };
        let value = value_of(ty, *n)
            .and_then(|v| v.encode(self.family).ok())
            .ok_or_else(|| {
                refuse(format!(
                    "{} does not fit {}",
                    shown_value(&schema, key, raw),
                    ty.name()
                ))
            })?;
        let cleared = guard::check(&schema, &self.target, key, raw, Permit::SETTING)?;
        let bytes = guard::lustbus_select(&cleared, Address::BROADCAST, pcode, value);
        self.line
            .send_telegram(&bytes)
            .map_err(|e| link_error(&self.target, e))?;
        let wait = self.max_reaction();
        self.line.link.clock().sleep(wait);
        Ok(())
    }

    /// MC6000/7000: go on with a dataset download that this drive's
    /// transaction opened (SLOAD = -1 ACKed) through another client of the
    /// same drive, e.g. after the line runner's broadcast. Reads SERR first,
    /// as any session does (section 6: the read clears what a broadcast
    /// SELECT may have latched) and returns it; a power-on bit means the
    /// drive restarted and lost its staged values: [`EngineError::Restarted`].
    pub fn resume_dataset(&mut self) -> Result<Siof, EngineError> {
        self.sload_present()?;
        if self.family != Dialect::Mc {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::Vf1000NoDataset,
            ));
        }
        let siof = self.read_siof("resuming the dataset download")?;
        if siof.contains(Siof::POWER_ON) {
            return Err(EngineError::restarted(
                self.target.clone(),
                "the dataset download (SERR has the power-on bit)",
            ));
        }
        self.dataset_open = true;
        Ok(siof)
    }

    fn sload_present(&self) -> Result<(), EngineError> {
        if self.schema.code(SLOAD).is_none() {
            return Err(EngineError::refused(
                self.target.clone(),
                Refusal::NoSload {
                    schema: self.schema.id.clone(),
                },
            ));
        }
        Ok(())
    }
}

/// Reads 91-TYPE (CODE `00091`, section 5.2) at `address` on `line`: the
/// scan probe. `Ok(None)` when nothing answers, `Ok(Some(None))` when a
/// drive answers NAK, `Ok(Some(Some(type)))` with a value.
pub(crate) fn probe_type<L: ByteLink>(
    line: &mut LustLine<L>,
    address: Address,
    timeout: Duration,
    tries: u32,
) -> Result<Option<Option<i64>>, LinkError> {
    let code = ParameterCode::new(TYPE).unwrap_or(ParameterCode::POSMOD);
    probe_code(line, address, code, timeout, tries)
}

/// What one read-only ENQUIRY probe heard (`driveset address`'s lone
/// device check, [`crate::assign`]): unlike [`probe_code`] it tells
/// garbage (several devices answering at once, §4.2) from silence.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Heard {
    /// A value reply (`None`: not a hex number).
    Value(Option<i64>),
    /// A NAK (or ACK) reply.
    Nak,
    /// Something arrived that does not decode.
    Garbled(String),
    /// Nothing.
    Nothing,
}

/// An ENQUIRY of `code` at `address`, up to `tries` times: the first
/// reply that decodes, else whether garbage arrived.
pub(crate) fn probe_heard<L: ByteLink>(
    line: &mut LustLine<L>,
    address: Address,
    code: ParameterCode,
    timeout: Duration,
    tries: u32,
) -> Result<Heard, LinkError> {
    let bytes = Enquiry::new(address, code).encode();
    let mut garbled = None;
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            line.stats.retries += 1;
        }
        match line.exchange(&bytes, address, Some(code), timeout, Duration::ZERO)? {
            Outcome::Reply(Reply::Value(v)) => {
                return Ok(Heard::Value(parse_hex(v.value.as_bytes())));
            }
            Outcome::Reply(_) => return Ok(Heard::Nak),
            Outcome::Garbled(g) => garbled = Some(g),
            Outcome::NoAnswer => {}
        }
    }
    Ok(garbled.map_or(Heard::Nothing, Heard::Garbled))
}

/// The CODE a code of `schema` goes out with (for a dry run's listing):
/// the numerically compatible parameters `000xx` (§5.2), else the family's
/// form.
pub(crate) fn wire_code_text(schema: &Schema, key: CodeKey) -> String {
    let compatible = schema.code(key.number).and_then(|c| c.compatible) == Some(true)
        || COMPATIBLE.contains(&key.number);
    let code = if compatible && key.number < 100 {
        ParameterCode::new(key.number)
    } else if schema.family == Family::Mc6000 {
        u16::try_from(key.number)
            .ok()
            .and_then(ParameterCode::mc_value)
    } else {
        u8::try_from(key.number)
            .ok()
            .and_then(|p| ParameterCode::vf_value(LustbusOptions::default().vf_device, p))
    };
    code.map_or_else(|| key.number.to_string(), |c| c.to_string())
}

/// An ENQUIRY of `code` at `address` (a read-only probe): `Ok(None)` when
/// nothing answers, `Ok(Some(None))` for a NAK, `Ok(Some(Some(value)))`.
pub(crate) fn probe_code<L: ByteLink>(
    line: &mut LustLine<L>,
    address: Address,
    code: ParameterCode,
    timeout: Duration,
    tries: u32,
) -> Result<Option<Option<i64>>, LinkError> {
    let bytes = Enquiry::new(address, code).encode();
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            line.stats.retries += 1;
        }
        match line.exchange(&bytes, address, Some(code), timeout, Duration::ZERO)? {
            Outcome::Reply(Reply::Value(v)) => return Ok(Some(parse_hex(v.value.as_bytes()))),
            Outcome::Reply(_) => return Ok(Some(None)),
            // Garbage at the right time: something is there (two drives on
            // one address, a drive at another rate); a retry may tell more.
            Outcome::Garbled(_) | Outcome::NoAnswer => {}
        }
    }
    Ok(None)
}
