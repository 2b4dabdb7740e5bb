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
//!   by the codec's [`ParameterValue`](driveset_proto::lustbus::ParameterValue) for the schema's PT_* type (VF1000 4
//!   hex digits, MC without leading zeros). A code the schema leaves
//!   untyped is read and written as the type its `width` implies (1 byte
//!   PT_USIGN8, 2 PT_USIGN16, 4 PT_INT32Q16, as the simulator does); with
//!   neither, a read gives the plain hex integer and a write is refused.
//! - The trailing EOT of one exchange is the leading EOT of the next
//!   (section 3: "the Host computer sends the EOT character before and after
//!   each data sequence"): every telegram starts with its EOT and nothing is
//!   sent after a reply; [`DriveClient::finish`](super::DriveClient::finish) sends the final lone EOT.
//! - Replies go through the codec's master-side [`ReplyDecoder`](driveset_proto::lustbus::ReplyDecoder) (parity
//!   masked, resynchronising on garbage); a reply from another address, a
//!   value reply for another CODE or a broken telegram counts as garbled.
//!
//! The answer timeout and retries, the SIOF / SERR handling and the MC
//! EEPROM pacing are in `exchange.rs`; the dataset download in
//! `dataset.rs`; broadcasts in `broadcast.rs`; the CODE and value encoding
//! in `encoding.rs`; the line and its exchange in `line.rs`; the read-only
//! probes in `probe.rs`; schema pull's raw access in `descriptions.rs`;
//! the refusals the client raises ([`LustbusRefusal`]) in `refusal.rs`.
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
use driveset_link::{ByteLink, Instant};
use driveset_proto::lustbus::{Address, Dialect};
use driveset_schema::{BusProtocol, CodeKey, RawValue, Schema};

use super::timing::LinkLatency;
use super::{
    DatasetDownload, Drive, Protocol, SerialLine, Target, client_address, code_name, link_error,
    refuse_read_only, schema_code, write_what, wrong_client,
};
use crate::error::EngineError;
use crate::guard::Permit;
use crate::plan;
use encoding::family_of;

mod broadcast;
mod dataset;
mod descriptions;
mod encoding;
mod exchange;
mod line;
mod probe;
mod refusal;

pub use broadcast::not_broadcast;
pub use encoding::dialect_of;
pub(crate) use encoding::wire_code_text;
pub(crate) use line::LustLine;
pub(crate) use probe::{Heard, probe_code, probe_heard, probe_type};
pub use refusal::{LustbusCodeProblem, LustbusRefusal};

/// 85-SIOF / SERR, the serial interface error word (sections 5.2, 9.2).
pub const SIOF: u32 = 85;
/// MC 416-SCTL1, the LUSTBUS control word (section 7.2).
pub const MC_SCTL1: u32 = 416;
/// VF1000 3-CNTL, the control word (section 7.1).
pub const VF_CNTL: u32 = 3;

/// The minimum reaction time of section 10 (both families), for planning.
const MIN_REACTION: Duration = plan::LUSTBUS_MIN_REACTION;

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

/// A LUSTBUS drive (VF1000 or MC6000/7000) at one address.
#[derive(Debug)]
pub struct LustbusClient<L: ByteLink = Box<dyn ByteLink>> {
    drive: Drive<LustLine<L>>,
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
            return Err(wrong_client(target, &schema, BusProtocol::Lustbus));
        };
        let address = client_address(&target, BusProtocol::Lustbus, |a| {
            Address::new(a).ok_or_else(|| format!("address {a}"))
        })?;
        let mut line = LustLine::new(link);
        line.eot_after_reply = opts.eot_after_reply;
        line.latency = LinkLatency::new(opts.latency);
        Ok(LustbusClient {
            drive: Drive::new(target, schema, line),
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

    /// The options in use.
    pub fn options(&self) -> &LustbusOptions {
        &self.opts
    }

    fn now(&self) -> Instant {
        self.drive.line.link.clock().now()
    }

    fn baud(&self) -> u32 {
        self.drive.line.link.baud()
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
                .saturating_add(self.drive.line.latency.allowance())
        })
    }

    /// The link's measured latency so far.
    pub fn latency(&self) -> &LinkLatency {
        &self.drive.line.latency
    }
}

impl<L: ByteLink> Protocol for LustbusClient<L> {
    type Line = LustLine<L>;

    fn drive(&self) -> &Drive<LustLine<L>> {
        &self.drive
    }

    fn read_key(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        self.read_code(key, what)
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
        if self.dataset_open && code.card_writeable != Some(true) {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::NotCardWriteable {
                    code: code_name(&schema, key),
                },
            ));
        }
        let what = write_what(&schema, key, raw);
        self.select(key, raw, &what, None, permit)
    }

    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        let code = self.drive.schema.code(key.number)?;
        if !self.paced(code) {
            return None;
        }
        self.eeprom_busy_until.filter(|u| *u > self.now())
    }

    fn read_time(&self, key: CodeKey) -> Duration {
        let code = self.drive.schema.code(key.number);
        // EOT ADR CODE ENQ, then ADR STX CODE = VALUE ETX BCC.
        let chars = 8 + 10 + self.value_len(code, false);
        wire_time(chars, self.baud()) + MIN_REACTION
    }

    fn write_time(&self, key: CodeKey) -> Duration {
        let code = self.drive.schema.code(key.number);
        // EOT ADR STX CODE = VALUE ETX BCC, then ADR ACK.
        let chars = 11 + self.value_len(code, false) + 2;
        wire_time(chars, self.baud()) + MIN_REACTION
    }

    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        let Some(ind) = self.drive.schema.running_indicator() else {
            return Ok(None);
        };
        let key = CodeKey::new(ind.code);
        let what = format!("read {} (running?)", code_name(&self.drive.schema, key));
        match self.read_code(key, &what)? {
            RawValue::Int(v) => Ok(Some(v >> ind.bit & 1 == 1)),
            _ => Ok(None),
        }
    }

    fn finish(&mut self) -> Result<(), EngineError> {
        self.drive
            .line
            .finish()
            .map_err(|e| link_error(&self.drive.target, e))
    }

    fn line_rate(&self) -> Option<u32> {
        Some(self.baud())
    }

    fn line(&mut self) -> Option<&mut dyn SerialLine> {
        Some(self)
    }

    /// The MC's SLOAD handshake (`dataset.rs`); the VF1000 has none.
    fn dataset(&mut self) -> Option<&mut dyn DatasetDownload> {
        if self.family == Dialect::Mc {
            Some(self)
        } else {
            None
        }
    }
}

impl<L: ByteLink> SerialLine for LustbusClient<L> {
    fn rate(&self) -> u32 {
        self.baud()
    }

    /// Flushes, sets the link's rate, forgets what was received and the
    /// session's EOT state (the next telegram starts with its own EOT at
    /// the new rate); the latency measured so far stays.
    fn set_rate(&mut self, baud: u32) -> Result<(), EngineError> {
        let target = self.drive.target.clone();
        let line = &mut self.drive.line;
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
}
