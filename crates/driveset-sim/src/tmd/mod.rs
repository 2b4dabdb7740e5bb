//! A simulated Lenze Tmd vector inverter on LECOM-A/B, the slave side of
//! section 8 of `lecom-ab-tmd-manual.txt`, with the parameter table of
//! Table 1 (loaded from the real `schemas/lenze-tmd.toml`).
//!
//! What it does, by manual section:
//!
//! - 8.H RECEIVE: the value in the code's format (VD shortest form, VH with
//!   the code's width, VS text), echoing the code field as the host sent it
//!   (C1 C2 or `!CCCCSS`); `STX C1 C2 ? ETX BCC` when a character of the
//!   request arrived with a parity error; `STX C1 C2 EOT` for a code (or
//!   subcode) that does not exist.
//! - 8.I SEND: ACK when the value is valid and stored, NAK otherwise, with
//!   the cause in C0068 bits 4..7 and the matching C1962 error number
//!   (Table 1 C0068, C1962; 8.J c).
//! - 8.J BROADCAST / MULTICAST to `00` and to the drive's group `x0`:
//!   executed, never answered.
//! - 8.B / 8.C code bank C0249 and input selection C0248 for standard
//!   addressing, 8.D extended addressing (ignores both).
//! - 8.F / 8.J b addressing: answers its own address C0009 only; no answer
//!   to other addresses, broadcasts, bad frames.
//! - §4e / §4f / §5 the program source of C0001 decides which codes LECOM
//!   may write; §5 the power-up state (C1920); Table 1 C0068 / C0150 status
//!   words, C0161..C0164 faults, C0043 / C0135 fault reset.
//!
//! Every choice the manual leaves open is listed on [`TmdDrive`]. The
//! telegram bytes come from `driveset_proto::lecom` (slave-side
//! [`TelegramDecoder`], [`Response`] encoding); this module never builds a
//! frame by hand.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::ascii::{self, ENQ, EOT, STX};
use driveset_proto::lecom::codec::MAX_TEXT;
use driveset_proto::lecom::{
    CodeAddress, CodeBank, CommunicationError, ControllerAddress, ExtendedError, FrameError,
    HostFrame, OperatingStatus, Response, StandardAddressing, StreamError, Telegram,
    TelegramDecoder, Value, ValueError,
};
use driveset_proto::lecom::{Decimal, Hex, OctetString, VisibleString};
use driveset_schema::ValueType;
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use driveset_schema::schema::{Access, Rule};

use crate::catalog::{self, Family};
use crate::drive::{ByteDrive, Heard, ReactionTime, ReadRefusal, Reply};
use crate::rng::SimRng;
use crate::table::{ParamTable, Refusal};

mod telegrams;
mod values;

/// Raw units of one VD unit (8.E: four decimals).
const VD: i64 = 10_000;

const C0001: u32 = 1;
const C0002: u32 = 2;
const C0009: u32 = 9;
const C0017: u32 = 17;
const C0040: u32 = 40;
const C0043: u32 = 43;
const C0050: u32 = 50;
const C0068: u32 = 68;
const C0099: u32 = 99;
const C0125: u32 = 125;
const C0135: u32 = 135;
const C0150: u32 = 150;
const C0161: u32 = 161;
const C0162: u32 = 162;
const C0163: u32 = 163;
const C0164: u32 = 164;
const C0200: u32 = 200;
const C0201: u32 = 201;
const C0248: u32 = 248;
const C0249: u32 = 249;
const C1810: u32 = 1810;
const C1811: u32 = 1811;
const C1920: u32 = 1920;
const C1962: u32 = 1962;

/// C0135 bits (Table 1).
const CW_ROTATION_CCW: i64 = 1 << 2;
const CW_QUICK_STOP: i64 = 1 << 3;
const CW_INHIBIT: i64 = 1 << 9;
const CW_TRIP_RESET: i64 = 1 << 11;

/// Table 2: configuration fault "CFG".
pub const FAULT_CFG: u16 = 71;

/// Bytes of the line kept to look back at a finished frame: the longest
/// host frame (EOT AD1 AD2 STX text ETX BCC) and some slack.
const HISTORY: usize = MAX_TEXT + 16;

/// What the drive does with a SEND that makes two of E1..E4 in C0007 equal
/// (Table 1 C0007: "cannot have the same settings, otherwise "CFG" fault
/// will be triggered").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CfgReaction {
    /// NAK, cause 5 (invalid variable), C1962 14; the value is not stored.
    /// The default: a transaction engine gets a clean refusal and the
    /// drive keeps a valid set.
    #[default]
    Refuse,
    /// The manual's literal reading: ACK, the value is stored and the drive
    /// trips with "CFG" (fault 71 in C0161, C0068 bit 15, motor stops).
    /// Resetting the fault (C0043 0 -> 1, C0135 bit 11 edge) clears it only
    /// once C0007 is valid again.
    Trip,
}

/// Construction options of a [`TmdDrive`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TmdOptions {
    /// LECOM address, C0009 (§4c: 1..=99, not 10, 20, ... 90).
    pub address: u8,
    /// C0001 as set at the keypad before LECOM use (§4e). Default 0, the
    /// factory setting of Table 1, in which LECOM may only read (and write
    /// C0040, C0043, C0248, C0249); 2 lets LECOM write parameters, 3 also
    /// the control word (§4f). Tests and the demo line set what they need
    /// ([`TmdOptions::c0001`], the `sim://tmd?c0001=3` port option).
    pub control_source: u8,
    /// Seed of the drive's random generator (reaction times).
    pub seed: u64,
    /// Reaction time. The manual gives no figure:
    /// the FICTIONAL default of the family descriptor (`ReactionTime::of`).
    pub reaction: ReactionTime,
    /// What a SEND that breaks the C0007 rule does.
    pub cfg_reaction: CfgReaction,
    /// Boot time after power returns, during which the drive answers
    /// nothing. The manual gives no figure; the default 0 is fictional.
    pub boot: Duration,
}

impl Default for TmdOptions {
    fn default() -> Self {
        TmdOptions {
            address: 1,
            control_source: 0,
            seed: 0,
            reaction: ReactionTime::of(Family::Tmd, driveset_schema::family::Keypad::Absent),
            cfg_reaction: CfgReaction::Refuse,
            boot: Duration::ZERO,
        }
    }
}

impl TmdOptions {
    /// Default options at `address`.
    pub fn at(address: u8) -> Self {
        TmdOptions {
            address,
            ..TmdOptions::default()
        }
    }

    /// These options with C0001 = `c0001` (as set at the keypad, §4e; 3 =
    /// LECOM may program and control the drive).
    #[must_use]
    pub fn c0001(self, c0001: u8) -> Self {
        TmdOptions {
            control_source: c0001,
            ..self
        }
    }
}

/// Why a write was refused: the C0068 nibble and the C1962 number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Nak {
    cause: CommunicationError,
    ext: ExtendedError,
}

impl Nak {
    const fn new(cause: CommunicationError, ext: ExtendedError) -> Self {
        Nak { cause, ext }
    }
    const CHECKSUM: Nak = Nak::new(
        CommunicationError::ChecksumError,
        ExtendedError::ChecksumError,
    );
    const PARITY: Nak = Nak::new(
        CommunicationError::ChecksumError,
        ExtendedError::ParityError,
    );
    const FRAME: Nak = Nak::new(
        CommunicationError::ProtocolFrameError,
        ExtendedError::InvalidEntry,
    );
    const NO_CODE: Nak = Nak::new(
        CommunicationError::InvalidCodeNumber,
        ExtendedError::InvalidCode,
    );
    const NO_SUBCODE: Nak = Nak::new(
        CommunicationError::InvalidCodeNumber,
        ExtendedError::InvalidSubcode,
    );
    const INVALID: Nak = Nak::new(
        CommunicationError::InvalidVariable,
        ExtendedError::InvalidVariable,
    );
    const DATA_TYPE: Nak = Nak::new(
        CommunicationError::InvalidVariable,
        ExtendedError::InvalidDataType,
    );
    const TOO_LONG: Nak = Nak::new(
        CommunicationError::InvalidVariable,
        ExtendedError::DataBlockTooLong,
    );
    const READ_ONLY: Nak = Nak::new(
        CommunicationError::NoAccessPermission,
        ExtendedError::ReadOnly,
    );
    const NO_ACCESS: Nak = Nak::new(
        CommunicationError::NoAccessPermission,
        ExtendedError::NoAccessPermission,
    );
    const INTERRUPTED: Nak = Nak::new(
        CommunicationError::InterruptedByNewTelegram,
        ExtendedError::TelegramInterruption,
    );
    const GENERAL: Nak = Nak::new(
        CommunicationError::GeneralFault,
        ExtendedError::GeneralFault,
    );

    /// Every cause a refusal records.
    const ALL: [Nak; 12] = [
        Nak::CHECKSUM,
        Nak::PARITY,
        Nak::FRAME,
        Nak::NO_CODE,
        Nak::NO_SUBCODE,
        Nak::INVALID,
        Nak::DATA_TYPE,
        Nak::TOO_LONG,
        Nak::READ_ONLY,
        Nak::NO_ACCESS,
        Nak::INTERRUPTED,
        Nak::GENERAL,
    ];

    fn of_value_error(e: ValueError) -> Nak {
        match e {
            ValueError::UnknownFormat { .. } | ValueError::WrongFormat { .. } => Nak::DATA_TYPE,
            ValueError::StringTooLong { .. } | ValueError::OctetsTooLong { .. } => Nak::TOO_LONG,
            _ => Nak::INVALID,
        }
    }
}

/// A simulated Lenze Tmd on LECOM-A/B.
///
/// Construct with [`TmdDrive::new`] and [`TmdOptions`]; feed it the line
/// with [`ByteDrive::hear`].
///
/// Choices where the manual is silent (each also documented where it is
/// implemented):
///
/// - **Program source (C0001, §4e/§4f, §5).** Modelled. LECOM writes are
///   refused (cause 6, C1962 8) unless C0001 is 2 or 3; C0040 (§5) and
///   C0043 (same Table 1 wording) may be written with C0001 = 0..3; the
///   control word C0135 only with C0001 = 3 (§4f); the protocol registers
///   C0248 / C0249 always (they are needed to read at all with a V1.0
///   driver). C0001 = 4..11 select another program source: the simulator
///   keeps answering reads and refuses all writes but C0248 / C0249. The
///   drive leaves the factory with Table 1's C0001 = 0 (LECOM reads only);
///   [`TmdOptions::c0001`] / `sim://tmd?c0001=3` stand for the keypad
///   setting §4e asks for before LECOM programming.
/// - **C0007 rule.** [`CfgReaction`]: refuse (default) or accept and trip.
/// - **C0010 <= C0011.** A SEND breaking it is refused (cause 5, C1962 14);
///   the manual does not even state the rule (erratum E14).
/// - **Running drive.** Refuses only C0002 (loading a whole Lenze setting
///   under a running motor) and codes marked `standstill` in the schema
///   (none in the Tmd schema): cause 6, C1962 8.
/// - **Enumerated codes** (C0001, C0014, ...) refuse values with no label
///   (e.g. C0001 = 2.5), and C0009 / C0248 / C0249 refuse fractions: cause
///   5. Other VD codes take any value in range to 4 decimals (the manual
///   gives no resolution).
/// - **C0009.** 10, 20, ... 90 are refused (§4c "must not be used"); values
///   above 99 (Table 1 allows 1..247, the Modbus range) are stored, and the
///   drive is then only reached by a broadcast to 00.
/// - **C0002.** 1 loads Table 1's factory values (the 50 Hz setting) except
///   the communication settings C0001, C0009, C0125 (so the drive stays
///   reachable); 2 (60 Hz) and 3 (OEM) are refused with cause 15 since the
///   manual gives neither set. C0002 reads 0 afterwards ("loading
///   complete").
/// - **C0125** (baud) takes effect at the next power-up
///   ([`ByteDrive::take_baud_change`] reports it then).
/// - **C0068 bits 4..7 / C1962** hold the cause of the last failed
///   telegram addressed to the drive (broadcasts included); an ACKed SEND
///   (or an executed broadcast) clears them; RECEIVEs leave them alone
///   except a `?` (cause 1, C1962 214) and a "no such code" answer (cause
///   4). Frame errors that get no answer still set them (cause 2 / 7).
/// - **Parity errors** (8.H a vs 8.J b): a RECEIVE for this drive with a
///   parity error in any character before ENQ is answered with `?`; with
///   a parity error on ENQ itself it gets no answer (8.J b names ENQ). A
///   SEND with a parity error gets NAK (8.I a: "lateral parity"), cause 1,
///   C1962 214; a bad BCC NAK, cause 1, C1962 210.
/// - **Code field that does not decode** (C1 C2 outside the 8.A formula,
///   a bad `!` field): SEND gets NAK cause 4; RECEIVE no answer (there is
///   no code to echo), cause 4 recorded.
/// - **Formats.** VD codes take VD only, VH codes VH only (any width whose
///   value fits): another format is cause 5, C1962 3.
/// - **Status words.** The simulator has no motor model: C0068 bits 13, 14
///   and C0150 bits 2, 4 (current limit, setpoint reached) stay 0;
///   "frequency above threshold" compares C0050 with C0017, "0 Hz" tests
///   C0050 (both can be poked). Power stage energized = running.
/// - **Running.** Controller inhibit (C0040 = 0 or C0135 bit 9) and quick
///   stop (C0135 bit 3) stop the motor; nothing starts it over the
///   protocol (no terminal 28 model): [`ByteDrive::set_running`] does.
/// - **Faults.** A reset moves C0161 into the history (C0162..C0164). A
///   power cycle resets a trip (C0170 = 0: "mains switching"), and a CFG
///   trips again at once while C0007 is still invalid.
/// - **Storage.** The Tmd stores its parameters: a power cycle keeps every
///   value but C0248 / C0249 (0, Table 1), the communication error, the
///   control state of §5 (C0135 quick stop bit after power-up in mode 3
///   with C1920 = 0, C0040 = 0 with C1920 = 1), C0043 (0) and the trip.
/// - **Identification strings** C0099, C0200, C0201, C1810, C1811 hold the
///   manual's examples ("1.20", "33STMD-M_12000", ...). C0093 has no
///   documented value and keeps the table's 0 (and, as the schema leaves
///   its access unset, is writable).
/// - **Watchdog** (§5.A, C1922 / C1923) is not simulated.
pub struct TmdDrive {
    table: ParamTable,
    values: BTreeMap<CodeKey, RawValue>,
    options: TmdOptions,
    rng: SimRng,
    decoder: TelegramDecoder,
    /// Recent line bytes (parity-masked) with their parity flag; the first
    /// entry is at decoder position `history_start`.
    history: VecDeque<(u8, bool)>,
    history_start: u64,
    running: bool,
    comm_error: CommunicationError,
    ext_error: ExtendedError,
    /// Power is off (or the drive boots) until this instant.
    deaf_until: Option<Instant>,
    /// The C0125 setting the line runs at.
    active_baud: i64,
    baud_change: Option<u32>,
    /// Codes whose RECEIVE is answered "no such code" although the table
    /// holds them (a twin's `[refused]`, [`ByteDrive::refuse_read`]).
    refused_reads: std::collections::BTreeSet<CodeKey>,
    /// Codes answered as codes the Tmd does not have ([`ByteDrive::forget`]);
    /// the model keeps their values for itself.
    hidden: std::collections::BTreeSet<CodeKey>,
    /// C0009 was written and acknowledged ([`ByteDrive::address_assigned`]).
    address_assigned: bool,
}

impl std::fmt::Debug for TmdDrive {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TmdDrive")
            .field("address", &self.vd(C0009))
            .field("control_source", &self.control_source())
            .field("running", &self.running)
            .field("comm_error", &self.comm_error)
            .field("ext_error", &self.ext_error)
            .field("decoder_position", &self.decoder.position())
            .field("deaf_until", &self.deaf_until)
            .finish_non_exhaustive()
    }
}

impl TmdDrive {
    /// A drive with Table 1's factory values, `options.address` in C0009
    /// and `options.control_source` in C0001, in its power-up state (§5).
    ///
    /// # Errors
    /// The schema does not load, the address is not a LECOM station
    /// address (1..=99, not x0; §4c, §8.J), or C0001 is outside 0..=11.
    pub fn new(options: TmdOptions) -> Result<Self, String> {
        let table = ParamTable::from_schema(catalog::schema(Family::Tmd)?)?;
        if !is_station(i64::from(options.address)) || options.address > 99 {
            return Err(format!(
                "Tmd address {} is not a LECOM station address: use 1..=99 except 10, 20, ... 90 (§4c, §8.J)",
                options.address
            ));
        }
        if options.control_source > 11 {
            return Err(format!(
                "C0001 = {} is outside 0..=11 (Table 1)",
                options.control_source
            ));
        }
        let mut values = table.factory_state();
        values.insert(
            CodeKey::new(C0009),
            RawValue::Int(i64::from(options.address) * VD),
        );
        values.insert(
            CodeKey::new(C0001),
            RawValue::Int(i64::from(options.control_source) * VD),
        );
        for (code, text) in [
            (C0099, "1.20"),
            (C0200, "33STMD-M_12000"),
            (C0201, "2005-01-15"),
            (C1810, "S33SLECOMM_10000"),
            (C1811, "2005-01-15"),
        ] {
            values.insert(CodeKey::new(code), RawValue::Text(text.to_string()));
        }
        let active_baud = values
            .get(&CodeKey::new(C0125))
            .and_then(as_int)
            .unwrap_or(0);
        let mut d = TmdDrive {
            table,
            values,
            rng: SimRng::new(options.seed),
            options,
            decoder: TelegramDecoder::new(),
            history: VecDeque::with_capacity(HISTORY),
            history_start: 0,
            running: false,
            comm_error: CommunicationError::NoFault,
            ext_error: ExtendedError::NoFault,
            deaf_until: None,
            active_baud,
            baud_change: None,
            refused_reads: std::collections::BTreeSet::new(),
            hidden: std::collections::BTreeSet::new(),
            address_assigned: false,
        };
        d.power_up();
        Ok(d)
    }

    /// A drive with default options at `address`.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn at(address: u8) -> Result<Self, String> {
        Self::new(TmdOptions::at(address))
    }

    /// The options the drive was built with.
    pub fn options(&self) -> &TmdOptions {
        &self.options
    }

    /// Change the reaction time (e.g. a fixed one for timing tests).
    pub fn set_reaction(&mut self, reaction: ReactionTime) {
        self.options.reaction = reaction;
    }

    /// The drive's parameter table.
    pub fn table(&self) -> &ParamTable {
        &self.table
    }

    /// The raw value of one code.
    pub fn value(&self, key: CodeKey) -> Option<&RawValue> {
        self.values.get(&key)
    }

    /// C0068 as the drive would answer it now.
    pub fn operating_status(&self) -> OperatingStatus {
        OperatingStatus(self.c0068())
    }

    /// C0068 bits 4..7: the last communication error.
    pub fn last_error(&self) -> CommunicationError {
        self.comm_error
    }

    /// C1962: the last error as extended code number.
    pub fn extended_error(&self) -> ExtendedError {
        self.ext_error
    }

    /// Trip with a fault number of Table 2 (test hook): C0161 = `fault`,
    /// the motor stops. 0 is ignored.
    pub fn trip(&mut self, fault: u16) {
        if fault == 0 {
            return;
        }
        self.set_int(C0161, i64::from(fault) * VD);
        self.running = false;
        self.refresh();
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Violation {
    Distinct,
    LessOrEqual,
}

fn as_int(v: &RawValue) -> Option<i64> {
    match v {
        RawValue::Int(i) => Some(*i),
        _ => None,
    }
}

/// A LECOM station address (not 0, not a group address x0); §4c, §8.J.
fn is_station(n: i64) -> bool {
    n >= 1 && n % 10 != 0
}

/// Table 1 C0125: 0 9600, 1 4800, 2 2400, 3 1200 bps.
fn baud_rate(setting: i64) -> Option<u32> {
    match setting / VD {
        0 => Some(9600),
        1 => Some(4800),
        2 => Some(2400),
        3 => Some(1200),
        _ => None,
    }
}

/// A raw value in LECOM format `ty` (8.E); `None` if it cannot be sent.
fn to_wire(ty: ValueType, width: Option<u8>, raw: &RawValue) -> Option<Value> {
    match (ty, raw) {
        (ValueType::VH, RawValue::Int(v)) => {
            let v = u32::try_from(*v).ok()?;
            Some(Value::Hex(match width {
                Some(1) => Hex::Byte(u8::try_from(v).ok()?),
                Some(2) | None => Hex::Word(u16::try_from(v).ok()?),
                _ => Hex::Dword(v),
            }))
        }
        (ValueType::VS, RawValue::Text(t)) => {
            VisibleString::new(t.as_bytes()).ok().map(Value::String)
        }
        (ValueType::VO, RawValue::Octets(o)) => OctetString::new(o).ok().map(Value::Octets),
        (_, RawValue::Int(v)) => Decimal::from_raw(*v).ok().map(Value::Decimal),
        _ => None,
    }
}

/// A received value as the raw value of a code of format `ty`; another
/// format than the code's is cause 5 (C1962 3, invalid data type).
fn from_wire(ty: ValueType, value: &Value) -> Result<RawValue, Nak> {
    match (ty, value) {
        (ValueType::VH, Value::Hex(h)) => Ok(RawValue::Int(i64::from(h.get()))),
        (ValueType::VS, Value::String(s)) => Ok(RawValue::Text(s.as_str().to_string())),
        (ValueType::VO, Value::Octets(o)) => Ok(RawValue::Octets(o.as_bytes().to_vec())),
        (ValueType::VH | ValueType::VS | ValueType::VO, _) => Err(Nak::DATA_TYPE),
        (_, Value::Decimal(d)) => Ok(RawValue::Int(d.raw())),
        _ => Err(Nak::DATA_TYPE),
    }
}

impl ByteDrive for TmdDrive {
    fn family(&self) -> &'static str {
        "tmd"
    }

    fn address_assigned(&self) -> bool {
        self.address_assigned
    }

    fn restore_address_assigned(&mut self) {
        self.address_assigned = true;
    }

    fn coded_rate(&self) -> Option<u32> {
        baud_rate(self.int(C0125))
    }

    /// A RECEIVE of `key` is answered `STX code EOT` (8.H a), the only
    /// refusal a RECEIVE has.
    fn refuse_read(&mut self, key: CodeKey, answer: ReadRefusal) -> Result<(), String> {
        let display = self.table.schema().display_code(key.number, key.subcode);
        if answer != ReadRefusal::NoSuchCode {
            return Err(format!(
                "{display}: a Tmd refuses a RECEIVE with EOT only (LECOM 8.H), not `{}`",
                answer.text()
            ));
        }
        if self.table.get(key).is_none() {
            return Err(format!("{display}: no such code on a Tmd"));
        }
        self.refused_reads.insert(key);
        Ok(())
    }

    /// From now on a RECEIVE of `key` is answered `STX code EOT` and a
    /// SEND refused as for any code the Tmd does not have (8.H).
    fn forget(&mut self, key: CodeKey) -> Result<(), String> {
        if self.table.get(key).is_none() {
            let display = self.table.schema().display_code(key.number, key.subcode);
            return Err(format!("{display}: no such code on a Tmd"));
        }
        self.hidden.insert(key);
        Ok(())
    }

    fn secret_codes(&self) -> Vec<u32> {
        self.table.secret_codes()
    }

    /// C0009 (two digits on LECOM; a value above 99 is returned as stored,
    /// saturated to 255).
    fn address(&self) -> u8 {
        u8::try_from(self.vd(C0009)).unwrap_or(u8::MAX)
    }

    fn hear(&mut self, now: Instant, byte: u8, parity_ok: bool) -> Heard {
        if let Some(until) = self.deaf_until {
            if now < until {
                return Heard::Nothing;
            }
            self.deaf_until = None;
            self.decoder = TelegramDecoder::new();
            self.history.clear();
        }
        self.remember(byte, parity_ok);
        let mut events = Vec::new();
        self.decoder.feed(&[byte], |e| events.push(e));
        let mut heard = Heard::Nothing;
        for e in events {
            // A complete frame (decoded or not); a frame cut off by the
            // next telegram, garbage and a lone EOT complete nothing.
            let ends_host_frame = matches!(
                e.result,
                Ok(HostFrame::Telegram(_)) | Err(StreamError::Frame(_))
            );
            let bytes = self.frame_bytes(&e.range);
            let response = self.on_frame(&bytes, e.result);
            if ends_host_frame {
                let reply = response.map(|r| Reply {
                    bytes: r.to_bytes(),
                    reaction: self.options.reaction.draw(&mut self.rng),
                });
                heard = Heard::Telegram { reply };
            }
        }
        heard
    }

    /// The drive is deaf from `now` for `off` plus the boot time; values
    /// are kept (the Tmd stores its parameters), C0248 / C0249 go to 0,
    /// the §5 power-up state is entered (see [`TmdDrive`]).
    fn power_cycle(&mut self, now: Instant, off: Duration) {
        self.deaf_until = Some(now.saturating_add(off).saturating_add(self.options.boot));
        self.power_up();
    }

    fn state(&self) -> ResolvedSet {
        self.table.resolved(&self.values)
    }

    /// Sets any code of the table, read-only ones included (actual values,
    /// faults). Refused: unknown codes, values of the wrong kind or that
    /// cannot be sent in the code's format, the status words C0068 / C0150
    /// / C1962 (derived from the drive state: poke C0161, C0040, C0050 ...
    /// instead), and a C0009 that is not a station address.
    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        let display = self.table.schema().display_code(key.number, key.subcode);
        let p = self
            .table
            .get(key)
            .ok_or_else(|| format!("{display}: no such code on a Tmd"))?;
        // A saved state's C1962 (the last refusal, 8.J c) restores the
        // cause it records; C0068 bits 4..7 follow from it.
        if key.number == C1962
            && let RawValue::Int(v) = raw
        {
            if v == 0 {
                self.record(None);
                return Ok(());
            }
            if let Some(nak) = Nak::ALL
                .into_iter()
                .find(|n| i64::from(n.ext.code()) * VD == v)
            {
                self.record(Some(nak));
                return Ok(());
            }
        }
        if matches!(key.number, C0068 | C0150 | C1962) {
            return Err(format!(
                "{display} is derived from the drive state; poke the codes it reflects instead"
            ));
        }
        if to_wire(p.ty.unwrap_or(ValueType::VD), p.width, &raw).is_none() {
            return Err(format!(
                "{display}: {raw:?} cannot be represented in the code's LECOM format"
            ));
        }
        if key.number == C0009
            && !matches!(raw, RawValue::Int(v) if v % VD == 0 && is_station(v / VD) && v / VD <= 247)
        {
            return Err(format!(
                "{display}: {raw:?} is not a station address (1..=247, not 10, 20, ... 90)"
            ));
        }
        if key.number == C0161 {
            self.running = false;
        }
        self.values.insert(key, raw);
        self.refresh();
        Ok(())
    }

    fn running(&self) -> bool {
        self.running
    }

    /// `true`: enable the controller (C0040 = 1, C0135 bits 3 and 9
    /// cleared) and run the motor; ignored while a fault is present.
    /// `false`: stop the motor (the enable state stays).
    fn set_running(&mut self, running: bool) {
        if running {
            if self.fault() != 0 {
                return;
            }
            self.set_int(C0040, VD);
            let cw = self.int(C0135);
            self.set_int(C0135, cw & !(CW_QUICK_STOP | CW_INHIBIT));
        }
        self.running = running;
        self.refresh();
    }

    fn take_baud_change(&mut self) -> Option<u32> {
        self.baud_change.take()
    }

    /// The rate of the C0125 setting in effect when C0125 has been changed
    /// since the last power-up (it takes effect only then, Table 1): a
    /// state file keeps it, so the drive stays at that rate between
    /// commands as a powered drive does.
    fn active_rate(&self) -> Option<u32> {
        if self.active_baud == self.int(C0125) {
            return None;
        }
        baud_rate(self.active_baud)
    }

    fn restore_rate(&mut self, baud: u32) {
        let Some(setting) = (0..=3)
            .map(|s| s * VD)
            .find(|s| baud_rate(*s) == Some(baud))
        else {
            return;
        };
        if setting != self.active_baud {
            self.active_baud = setting;
            self.baud_change = Some(baud);
        }
    }
}
