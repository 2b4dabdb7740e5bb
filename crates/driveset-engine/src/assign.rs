//! Owns `driveset address`: giving one drive, alone on its line, its bus
//! address (and with `--baud` its line rate) in stand-alone operation, the
//! journal record of that change ([`AssignRecord`]) and its recovery.
//!
//! **LUSTBUS** (`lustbus-protocol.txt` §4.1, §4.2, §5.1, §5.2, §11.5):
//!
//! 1. the address asked for is checked by
//!    [`BusProtocol::check_address`] (one rule: 1..30);
//! 2. the drive is sought at address 0 ("every device answers on this
//!    address", §4.2), at 9600 baud first and then at every other LUSTBUS
//!    rate (§5.1: "the connection will be attempted using all possible
//!    transfer rates"): an ENQUIRY of 91-TYPE. An answer at address 0 that
//!    does not decode is several devices answering at once: refused;
//! 3. the family: the MC CODE 20091 answers on a servocontroller, an
//!    inverter NAKs it (as [`crate::scan::detect_protocol`]);
//! 4. the network list of §5.2 (an ENQUIRY of 91-TYPE to 1..30): more than
//!    one answer is more than one device on the line: refused; an answer at
//!    the address asked for from another device: refused ("no address is
//!    assigned twice", §4.2);
//! 5. journal, then 82-SIOA/SADDR = N at address 0 (permit
//!    [`Permit::BUS_ADDRESS`]); verified at N (82 = N, 91 = the TYPE read
//!    at 0) and, when the drive had another own address before, that
//!    nothing answers there any more;
//! 6. `--baud B` last, at N: 81-SBAUD/SIOC = B (permit
//!    [`Permit::LINE_RATE`]); an MC6000/7000 activates it at once with
//!    4-PROG = 111 (§11.5, permit `ACTIVATE_RATE`; its ACK still comes at
//!    the old rate), the host follows and verifies 81, 82 and 91 at B; a
//!    VF1000 only at its next restart (§11.5): 81 is read back and the
//!    report says when it takes effect.
//!
//! **LECOM** (`lecom-ab-tmd-manual.txt` §4c, §4d, §4e, Table 1): the drive
//! at `--from M` (default 1, the factory C0009); refused when another
//! device answers at N; C0001 must allow LECOM writes (2 or 3, §4e): the
//! refusal gives the advice an upload's refused write gives
//! ([`crate::error::LECOM_PROGRAMMING_ADVICE`]); C0009 = N at M, verified
//! at N; `--baud`: C0125 = the code of the rate (Table 1: 0 = 9600,
//! 1 = 4800, 2 = 2400, 3 = 1200), read back; the Tmd takes it at its next
//! power-up (the manual says it must be set "prior to attempting to
//! communicate", §4d, and names no online activation).
//!
//! **Order: the address first, the rate last.** A lone LUSTBUS drive
//! answers at address 0 whatever its own address, so a cut around the
//! address write never loses it; a cut around the rate change can (the
//! drive may run at either rate). With the address written and verified
//! first, at the rate the drive was found at (for a new drive the factory
//! 9600 baud, where a human with a keypad or any tool looks first), the
//! only step that can leave the drive at an unexpected rate is the last
//! one, after which both its addresses are known: recover (and a human)
//! search the rates at two addresses only. The VF1000 and the Tmd take a
//! new rate only at a restart, so for them the rate must be the last step
//! anyway: everything else is verified at the rate the drive still runs at.
//!
//! **Never half-done.** The journal ([`AssignRecord`] in a
//! [`crate::journal::Journal`] bound to the bus id and the new address N)
//! is on disk before the first write. [`recover`] finds the drive (at N
//! and at the old address, at the recorded rates and then every rate of
//! the family) and finishes the change: every step is idempotent (a value
//! already in place is not written again), so a cut at any telegram ends
//! fully switched once recover ran.
//!
//! **Dry run** ([`plan`]): every probe and read above, the refusals, and
//! the writes it would send (telegram, code, value, address, rate);
//! nothing is written and no journal is made.

use std::fmt;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, Link, LinkError};
use driveset_proto::lecom::ControllerAddress;
use driveset_proto::lustbus::{Address, ParameterCode};
use driveset_schema::value::{decimal_to_raw, raw_to_decimal};
use driveset_schema::{BusProtocol, CodeKey, Decimal, Family, RawValue, Registry, Role, Schema};
use serde::{Deserialize, Serialize};

use crate::client::lecom::LecomLine;
use crate::client::lustbus::{Heard, LustLine, TYPE};
use crate::client::{BorrowedByteLink, Identity, Target};
use crate::connect::connect_on;
use crate::error::{EngineError, ErrorKind, Refusal};
use crate::guard::Permit;
use crate::journal::{
    JOURNAL_VERSION, Journal, JournalFile, JournalIdentity, JournalTarget, SchemaSource, TxnState,
};
use crate::plan::code_label;
use crate::scan::{Found, ScanOptions, lustbus_addresses, scan_lecom, scan_lustbus};

/// LUSTBUS rates in the order §5.1 tries them: the standard 9600 first,
/// then every other rate a LUSTBUS device runs at (§4), highest first.
pub const LUSTBUS_SEARCH: [u32; 6] = [9600, 57600, 38400, 19200, 4800, 2400];
/// LECOM rates of the Tmd (C0125), the factory 9600 first.
pub const LECOM_SEARCH: [u32; 4] = [9600, 4800, 2400, 1200];

/// What `driveset address` asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AssignRequest {
    /// The bus protocol of the line (LUSTBUS or LECOM).
    pub protocol: BusProtocol,
    /// The address to give the drive.
    pub to: u8,
    /// LECOM: the address the drive answers at now (default 1, the
    /// factory C0009). LUSTBUS: unused (the drive is reached at address 0).
    pub from: Option<u8>,
    /// The line rate to give the drive too.
    pub baud: Option<u32>,
    /// Probe timeouts and tries of the searches and the scan.
    pub scan: ScanOptions,
    /// Write the address code even when the drive holds the address
    /// already ([`AssignRequest::always_write_address`]).
    pub always_write_address: bool,
}

impl AssignRequest {
    /// A request for address `to` on a `protocol` line.
    pub fn new(protocol: BusProtocol, to: u8) -> Self {
        AssignRequest {
            protocol,
            to,
            from: None,
            baud: None,
            scan: ScanOptions::default(),
            always_write_address: false,
        }
    }

    /// The same, writing the address code even when the drive holds the
    /// address already: the line's first contact (`commission --assign`,
    /// `replace`) gives every unit its place explicitly, a factory-fresh
    /// unit whose manifest address is the factory one included (the write
    /// is stored; the simulator's service bench takes it as the cue that
    /// this unit is done).
    pub fn always_write_address(mut self) -> Self {
        self.always_write_address = true;
        self
    }

    /// The same with `--from`.
    pub fn from(mut self, from: u8) -> Self {
        self.from = Some(from);
        self
    }

    /// The same with `--baud`.
    pub fn baud(mut self, baud: u32) -> Self {
        self.baud = Some(baud);
        self
    }
}

/// The schema used for each family's drive (the LUSTBUS family is known
/// only once the drive answered).
#[derive(Debug, Clone, Default)]
pub struct Schemas {
    by_family: Vec<Arc<Schema>>,
}

impl Schemas {
    /// No schemas.
    pub fn new() -> Self {
        Schemas::default()
    }

    /// Each serial family's built-in schema from `registry` (by the
    /// descriptor's `schema_id`).
    pub fn from_registry(registry: &Registry) -> Self {
        let mut s = Schemas::new();
        for f in [Family::Mc6000, Family::Vf1000, Family::Tmd] {
            if let Some(schema) = registry.get(f.descriptor().schema_id) {
                s = s.with(schema);
            }
        }
        s
    }

    /// The same, `schema` used for its family.
    pub fn with(mut self, schema: Arc<Schema>) -> Self {
        self.by_family.retain(|s| s.family != schema.family);
        self.by_family.push(schema);
        self
    }

    /// The schema of `family`.
    pub fn get(&self, family: Family) -> Option<Arc<Schema>> {
        self.by_family.iter().find(|s| s.family == family).cloned()
    }
}

/// Why `address` refuses before anything is written (wrapped into
/// [`Refusal::Assign`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "assign", rename_all = "snake_case")]
pub enum AssignRefusal {
    /// The address asked for is not a drive's own address.
    InvalidAddress {
        /// The address.
        address: i64,
        /// `--to` or `--from`.
        option: String,
        /// The protocol's rule, from [`BusProtocol::check_address`].
        rule: String,
    },
    /// `--baud` is not a rate of the drive's family (or of the protocol).
    InvalidRate {
        /// The rate asked for.
        baud: u32,
        /// Who runs at which rates.
        who: String,
        /// The rates.
        rates: String,
    },
    /// Answers at address 0 that do not decode: several devices answer.
    Collision {
        /// The rate they were heard at.
        baud: u32,
        /// What was heard.
        heard: String,
    },
    /// The network list (1..30) found more than one device.
    MoreThanOne {
        /// Who answered where.
        found: String,
    },
    /// Another device answers at the address asked for.
    Taken {
        /// The address.
        address: u8,
        /// What answered there.
        answer: String,
    },
    /// C0001 does not let LECOM write (§4e).
    LecomReadOnly {
        /// C0001 as read.
        c0001: String,
    },
    /// The schema cannot write the code (no type for it).
    SchemaLacks {
        /// Schema id.
        schema: String,
        /// The code.
        code: String,
    },
    /// The port is not a character line.
    NotSerial {
        /// The protocol asked for.
        protocol: String,
    },
    /// No schema for the family the drive identified as.
    NoSchema {
        /// The family.
        family: String,
    },
    /// The journal belongs to `driveset address`: recover it with
    /// [`recover`], not the upload's recover.
    AssignJournal {
        /// The journal file.
        journal: String,
    },
    /// The journal does not fit the drive found (another TYPE / identity).
    NotTheDrive {
        /// What differs.
        detail: String,
    },
}

impl fmt::Display for AssignRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AssignRefusal::InvalidAddress {
                address,
                option,
                rule,
            } => write!(
                f,
                "{option} {address}: {rule}; nothing was sent. Give an address the rule allows"
            ),
            AssignRefusal::InvalidRate { baud, who, rates } => write!(
                f,
                "--baud {baud}: {who} runs at {rates} baud (lustbus-protocol.txt §4, lecom-ab-tmd-manual.txt C0125); nothing was written. Pick one of these"
            ),
            AssignRefusal::Collision { baud, heard } => write!(
                f,
                "the answers at address 0 at {baud} baud do not decode ({heard}): more than one device answers (lustbus-protocol.txt §4.2: every device answers at address 0); nothing was written. Connect the drive alone and run again"
            ),
            AssignRefusal::MoreThanOne { found } => write!(
                f,
                "the line holds more than one device (the network list of lustbus-protocol.txt §5.2 finds {found}); nothing was written. Connect the drive alone and run again"
            ),
            AssignRefusal::Taken { address, answer } => write!(
                f,
                "address {address} is taken: another device answers there ({answer}); nothing was written. No address may be assigned twice (lustbus-protocol.txt §4.2, lecom-ab-tmd-manual.txt §4c): pick a free address or disconnect that device"
            ),
            AssignRefusal::LecomReadOnly { c0001 } => write!(
                f,
                "C0001 = {c0001}: LECOM may read but not write (lecom-ab-tmd-manual.txt §4e, §4f); nothing was written; {}",
                crate::error::LECOM_PROGRAMMING_ADVICE
            ),
            AssignRefusal::SchemaLacks { schema, code } => write!(
                f,
                "schema `{schema}` gives no type for {code}, so its value cannot be written; nothing was written. Give --schema with a schema that types it (one learned from the drive by `driveset schema pull`)"
            ),
            AssignRefusal::NotSerial { protocol } => write!(
                f,
                "{protocol} addresses are set over a character line, and this port is a CAN bus; nothing was sent"
            ),
            AssignRefusal::NoSchema { family } => write!(
                f,
                "no schema for the {family} the drive identifies as; nothing was written. Give --schema"
            ),
            AssignRefusal::AssignJournal { journal } => write!(
                f,
                "journal {journal} records a `driveset address` change; nothing was sent. Run `driveset recover {journal}` (it finishes the address change)"
            ),
            AssignRefusal::NotTheDrive { detail } => write!(
                f,
                "{detail}; nothing was written. Connect the drive the journal belongs to"
            ),
        }
    }
}

/// How a new line rate takes effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RateEffect {
    /// Activated at once (MC6000/7000 4-PROG = 111, §11.5) and verified at
    /// the new rate.
    Online,
    /// Stored; active after the drive's next restart (VF1000 §11.5, Tmd
    /// C0125).
    AtRestart,
}

/// One write `address` sends (or, dry, would send).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PlannedWrite {
    /// The telegram, for humans (`LUSTBUS SELECT to address 0 (@), CODE 00082`).
    pub telegram: String,
    /// The code (`82-SADDR`).
    pub code: String,
    /// The value as shown.
    pub value: String,
    /// The address it is sent to.
    pub address: u8,
    /// The line rate it is sent at.
    pub baud: u32,
    #[serde(skip)]
    key: CodeKey,
    #[serde(skip)]
    raw: RawValue,
    #[serde(skip)]
    step: Step,
}

/// Which step a write is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Address,
    Rate,
    Activate,
}

/// What [`plan`] found: the drive, the checks passed, the writes.
#[derive(Debug, Clone, Serialize)]
pub struct AssignPlan {
    /// The port.
    pub port: String,
    /// The bus id.
    pub bus: String,
    /// The protocol.
    #[serde(serialize_with = "ser_name")]
    pub protocol: BusProtocol,
    /// The drive's family.
    #[serde(serialize_with = "ser_name")]
    pub family: Family,
    /// The schema id used.
    pub schema_id: String,
    #[serde(skip)]
    schema: Arc<Schema>,
    /// What the drive identified as.
    pub identity: Identity,
    /// LUSTBUS 91-TYPE as read (`None`: NAK, or LECOM).
    pub type_value: Option<i64>,
    /// The address the drive was reached at (LUSTBUS 0, LECOM `--from`).
    pub reached_at: u8,
    /// Its own address before (82 / C0009), where it reads as one.
    pub old_address: Option<i64>,
    /// The address asked for.
    pub to: u8,
    /// The rate the drive was found at.
    pub rate: u32,
    /// The rate asked for (`None`: keep).
    pub baud: Option<u32>,
    /// How the new rate takes effect (when one is written).
    pub rate_effect: Option<RateEffect>,
    /// The network list / the probe of N: who answered.
    pub scan: Vec<Found>,
    /// Virtual (link clock) time of the 1..30 scan (LUSTBUS).
    #[serde(serialize_with = "ser_ms")]
    pub scan_time: Duration,
    /// Link clock time of the whole discovery.
    #[serde(serialize_with = "ser_ms")]
    pub elapsed: Duration,
    /// The writes, in order.
    pub writes: Vec<PlannedWrite>,
    /// The probe options of the request (for the verification probes).
    #[serde(skip)]
    scan_opts: ScanOptions,
}

fn ser_name<T: fmt::Display, S: serde::Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&v.to_string())
}

fn ser_ms<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64() * 1000.0)
}

/// What [`run`] did.
#[derive(Debug, Clone, Serialize)]
pub struct AssignReport {
    /// The plan it carried out.
    pub plan: AssignPlan,
    /// Writes sent (acknowledged).
    pub written: Vec<String>,
    /// What was verified, for humans.
    pub verified: Vec<String>,
    /// The rate the drive runs at now.
    pub rate_now: u32,
    /// When a stored rate becomes active (VF1000, Tmd).
    pub rate_note: Option<String>,
    /// The journal file.
    pub journal: String,
    /// Link clock time of the whole command (discovery included).
    #[serde(serialize_with = "ser_ms")]
    pub elapsed: Duration,
}

/// Where an address change stands ([`AssignRecord::step`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AssignStep {
    /// Journalled; nothing written yet.
    Planned,
    /// The address write is under way (it may have landed).
    Address,
    /// The address is verified at the new address.
    AddressVerified,
    /// The rate change is under way: the drive may run at either rate.
    Rate,
    /// Everything written and verified.
    Done,
}

/// The journal's record of an address change (`driveset address`),
/// enough for [`recover`] to find the drive and finish.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AssignRecord {
    /// `lustbus` or `lecom` (an unknown name is a journal error, never a guess).
    pub protocol: BusProtocol,
    /// The family name.
    pub family: String,
    /// The address the drive was reached at (LUSTBUS 0, LECOM `--from`).
    pub from: u8,
    /// Its own address before, where known.
    pub old_address: Option<i64>,
    /// The new address.
    pub to: u8,
    /// The rate the drive ran at.
    pub old_rate: u32,
    /// The new rate (`None`: unchanged).
    pub rate: Option<u32>,
    /// LUSTBUS 91-TYPE the drive answered with.
    pub type_value: Option<i64>,
    /// Where it stands.
    pub step: AssignStep,
}

/// What [`recover`] found and did.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct AssignRecovered {
    /// The journal file.
    pub journal: String,
    /// The step the journal was at.
    pub found_step: AssignStep,
    /// Where the drive answered (address, rate).
    pub found_at: (u8, u32),
    /// Writes recover sent to finish.
    pub written: Vec<String>,
    /// The final state, for humans.
    pub state: String,
}

// ---------------------------------------------------------------------
// small helpers

fn target(port: &str, address: u8) -> Target {
    Target {
        port: port.to_string(),
        address,
    }
}

fn refuse(port: &str, address: u8, r: AssignRefusal) -> EngineError {
    EngineError::refused(target(port, address), Refusal::from(r))
}

fn link_err(port: &str, address: u8, e: LinkError) -> EngineError {
    EngineError::link(target(port, address), e)
}

fn bytes(link: &mut Link, protocol: BusProtocol) -> Result<&mut dyn ByteLink, EngineError> {
    match link {
        Link::Bytes(b) => Ok(b.as_mut()),
        Link::Frames(f) => Err(refuse(
            f.port(),
            0,
            AssignRefusal::NotSerial {
                protocol: protocol.title().to_string(),
            },
        )),
    }
}

fn list(rates: &[u32]) -> String {
    let mut r = rates.to_vec();
    r.sort_unstable();
    r.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}

fn check_address(
    protocol: BusProtocol,
    port: &str,
    option: &str,
    a: u8,
) -> Result<(), EngineError> {
    protocol.check_address(i64::from(a)).map_err(|refusal| {
        refuse(
            port,
            a,
            AssignRefusal::InvalidAddress {
                address: i64::from(a),
                option: option.to_string(),
                rule: refusal.rule.to_string(),
            },
        )
    })
}

/// The family's bus-address code (its floor role `bus-address`).
pub fn address_code(family: Family) -> Option<CodeKey> {
    family
        .descriptor()
        .floor
        .iter()
        .find(|f| f.role == Role::BusAddress)
        .map(|f| CodeKey::new(f.code))
}

/// The family's rate code.
pub fn rate_code(family: Family) -> Option<CodeKey> {
    family.descriptor().line_rates.code.map(CodeKey::new)
}

/// The family's address and rate codes (its descriptor's role floor and
/// line rates): refused, not guessed, for a family that has none.
fn bus_codes(
    family: Family,
    schema: &Schema,
    port: &str,
) -> Result<(CodeKey, CodeKey), EngineError> {
    let lacks = |what: &str| {
        refuse(
            port,
            0,
            AssignRefusal::SchemaLacks {
                schema: schema.id.clone(),
                code: format!("the {what} code of {}", family.descriptor().title),
            },
        )
    };
    let address = address_code(family).ok_or_else(|| lacks("bus-address"))?;
    let rate = rate_code(family).ok_or_else(|| lacks("line-rate"))?;
    Ok((address, rate))
}

/// The raw value of the address code meaning address `a` (a scaled
/// type's raw, e.g. Tmd C0009 VD: a x 10000).
pub fn address_raw(schema: &Schema, key: CodeKey, a: u8) -> Option<RawValue> {
    let code = schema.code(key.number)?;
    let ty = schema.type_of(code)?;
    decimal_to_raw(ty, code.width, &Decimal::from_int(i128::from(a)))
        .ok()
        .map(RawValue::Int)
}

/// The address a raw value of the address code means (`None`: not a
/// whole number, or the code has no scaled type).
pub fn address_of_raw(schema: &Schema, key: CodeKey, raw: &RawValue) -> Option<i64> {
    let code = schema.code(key.number)?;
    let RawValue::Int(r) = raw else {
        return None;
    };
    match schema.type_of(code) {
        Some(ty) => {
            let d = raw_to_decimal(ty, *r)?;
            let text = d.to_string();
            text.parse::<i64>().ok()
        }
        None => Some(*r),
    }
}

/// The raw value of the rate code meaning `baud`: an enumerated code
/// (Tmd C0125: `1 = "4800 bps ..."`) by the label that starts with the
/// figure, else the figure itself (LUSTBUS 81, unit Baud).
pub fn rate_raw(schema: &Schema, key: CodeKey, baud: u32) -> Option<RawValue> {
    let code = schema.code(key.number)?;
    if let Some(src) = &code.values {
        let e = schema.enum_of(src)?;
        let label = e
            .entries
            .iter()
            .find(|(_, label, _)| label_rate(label) == Some(baud))
            .map(|(_, l, _)| l.clone())?;
        return schema.enum_value(code, &label).map(RawValue::Int);
    }
    Some(RawValue::Int(i64::from(baud)))
}

/// The rate a raw value of the rate code means ([`rate_raw`] backwards).
pub fn rate_of_raw(schema: &Schema, key: CodeKey, raw: &RawValue) -> Option<u32> {
    let code = schema.code(key.number)?;
    let RawValue::Int(v) = raw else {
        return None;
    };
    if code.values.is_some() {
        return label_rate(schema.enum_label(code, *v)?);
    }
    u32::try_from(*v).ok()
}

fn label_rate(label: &str) -> Option<u32> {
    label
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .and_then(|d| d.parse().ok())
}

fn shown(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => driveset_schema::validate::display_value(schema, c, raw),
        None => format!("{raw:?}"),
    }
}

fn lust_timeout(link: &dyn ByteLink, opts: &ScanOptions) -> Duration {
    opts.timeout
        .unwrap_or_else(|| Duration::from_millis(65) + wire_time(14, link.baud()))
}

/// An ENQUIRY of `code` at `address`, reporting garbage too.
fn lust_probe(
    link: &mut dyn ByteLink,
    address: Address,
    code: ParameterCode,
    opts: &ScanOptions,
) -> Result<Heard, LinkError> {
    let timeout = lust_timeout(link, opts);
    let mut line = LustLine::new(BorrowedByteLink(link));
    line.wait_late = false;
    let h =
        crate::client::lustbus::probe_heard(&mut line, address, code, timeout, opts.tries.max(2))?;
    line.finish()?;
    Ok(h)
}

fn set_rate(link: &mut Link, baud: u32) -> Result<bool, EngineError> {
    let port = match link {
        Link::Bytes(b) => b.port().to_string(),
        Link::Frames(f) => f.port().to_string(),
    };
    let Link::Bytes(b) = link else {
        return Ok(false);
    };
    if b.baud() == baud {
        return Ok(true);
    }
    match b.set_baud(baud) {
        Ok(()) => Ok(true),
        Err(LinkError::UnsupportedBaud { .. }) => Ok(false),
        Err(e) => Err(link_err(&port, 0, e)),
    }
}

fn baud_of(link: &Link) -> u32 {
    match link {
        Link::Bytes(b) => b.baud(),
        Link::Frames(f) => f.bitrate(),
    }
}

fn now(link: &Link) -> driveset_link::Instant {
    match link {
        Link::Bytes(b) => b.clock().now(),
        Link::Frames(f) => f.clock().now(),
    }
}

fn port_of(link: &Link) -> String {
    match link {
        Link::Bytes(b) => b.port().to_string(),
        Link::Frames(f) => f.port().to_string(),
    }
}

fn bus_of(link: &Link) -> String {
    match link {
        Link::Bytes(b) => b.bus_id(),
        Link::Frames(f) => f.bus_id(),
    }
}

fn found_text(found: &[Found]) -> String {
    found
        .iter()
        .map(|f| {
            let codes: Vec<String> = f
                .identity
                .codes
                .iter()
                .map(|c| format!("{} = {}", c.name, c.value))
                .collect();
            format!("address {}: {}", f.address, codes.join(", "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The family's rates check for `--baud`.
fn check_family_rate(port: &str, family: Family, baud: u32) -> Result<(), EngineError> {
    let d = family.descriptor();
    if d.line_rates.rates.contains(&baud) {
        return Ok(());
    }
    Err(refuse(
        port,
        0,
        AssignRefusal::InvalidRate {
            baud,
            who: format!("a {}", d.title),
            rates: list(d.line_rates.rates),
        },
    ))
}

fn need_type(schema: &Schema, port: &str, key: CodeKey) -> Result<(), EngineError> {
    let typed = schema
        .code(key.number)
        .is_some_and(|c| schema.type_of(c).is_some());
    if typed {
        Ok(())
    } else {
        Err(refuse(
            port,
            0,
            AssignRefusal::SchemaLacks {
                schema: schema.id.clone(),
                code: code_label(schema, key),
            },
        ))
    }
}

// ---------------------------------------------------------------------
// plan

/// Find the drive, run every check and list the writes; nothing is
/// written (the dry run, and the first half of [`assign`]).
pub fn plan(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
) -> Result<AssignPlan, EngineError> {
    match req.protocol {
        BusProtocol::Lustbus => plan_lustbus(link, req, schemas),
        BusProtocol::Lecom => plan_lecom(link, req, schemas),
        BusProtocol::CanSdo => Err(refuse(
            &port_of(link),
            req.to,
            AssignRefusal::NotSerial {
                protocol: "CAN SDO node ids".into(),
            },
        )),
    }
}

fn plan_lustbus(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
) -> Result<AssignPlan, EngineError> {
    let port = port_of(link);
    let protocol = BusProtocol::Lustbus;
    check_address(protocol, &port, "--to", req.to)?;
    if let Some(b) = req.baud
        && !LUSTBUS_SEARCH.contains(&b)
    {
        return Err(refuse(
            &port,
            0,
            AssignRefusal::InvalidRate {
                baud: b,
                who: "a LUSTBUS device".into(),
                rates: list(&LUSTBUS_SEARCH),
            },
        ));
    }
    bytes(link, protocol)?;
    let start = now(link);
    let opts = &req.scan;
    let type_code = ParameterCode::new(TYPE).unwrap_or(ParameterCode::POSMOD);
    // §5.1: address 0 at 9600, then every rate
    let mut garbled: Option<(u32, String)> = None;
    let mut hit: Option<(u32, Option<i64>)> = None;
    let first_rate = baud_of(link);
    for r in LUSTBUS_SEARCH {
        if !set_rate(link, r)? {
            continue;
        }
        let b = bytes(link, protocol)?;
        match lust_probe(b, Address::ALL, type_code, opts).map_err(|e| link_err(&port, 0, e))? {
            Heard::Value(v) => {
                hit = Some((r, v));
                break;
            }
            Heard::Nak => {
                hit = Some((r, None));
                break;
            }
            Heard::Garbled(g) => {
                if garbled.is_none() {
                    garbled = Some((r, g));
                }
            }
            Heard::Nothing => {}
        }
    }
    let Some((rate, type_value)) = hit else {
        let _ = set_rate(link, first_rate);
        if let Some((baud, heard)) = garbled {
            return Err(refuse(&port, 0, AssignRefusal::Collision { baud, heard }));
        }
        return Err(EngineError::no_answer(
            target(&port, 0),
            format!(
                "an ENQUIRY of 91-TYPE at address 0 at every LUSTBUS rate ({}; lustbus-protocol.txt §5.1)",
                list(&LUSTBUS_SEARCH)
            ),
            opts.tries.max(2),
        ));
    };
    // a collision heard at the rate that answered (the other devices at
    // another rate would not answer there)
    if let Some((baud, heard)) = garbled.filter(|(b, _)| *b == rate) {
        return Err(refuse(&port, 0, AssignRefusal::Collision { baud, heard }));
    }
    // the family: the MC CODE 20091 (§5.2: the numerically compatible
    // parameters are the same; MC codes above them are not)
    let mc_code = ParameterCode::mc_value(91).unwrap_or(ParameterCode::POSMOD);
    let b = bytes(link, protocol)?;
    let family =
        match lust_probe(b, Address::ALL, mc_code, opts).map_err(|e| link_err(&port, 0, e))? {
            Heard::Value(_) => Family::Mc6000,
            Heard::Garbled(g) => {
                return Err(refuse(
                    &port,
                    0,
                    AssignRefusal::Collision {
                        baud: rate,
                        heard: g,
                    },
                ));
            }
            _ => Family::Vf1000,
        };
    if let Some(b) = req.baud {
        check_family_rate(&port, family, b)?;
    }
    // §5.2: the network list
    let scan_start = now(link);
    let b = bytes(link, protocol)?;
    let found = scan_lustbus(b, &lustbus_addresses(), opts)?;
    let scan_time = now(link) - scan_start;
    let schema = schemas.get(family).ok_or_else(|| {
        refuse(
            &port,
            0,
            AssignRefusal::NoSchema {
                family: family.descriptor().title.into(),
            },
        )
    })?;
    if found.len() > 1 {
        if let Some(at) = found.iter().find(|f| f.address == req.to) {
            return Err(refuse(
                &port,
                0,
                AssignRefusal::Taken {
                    address: req.to,
                    answer: format!(
                        "{}; and the line holds {} devices",
                        found_text(std::slice::from_ref(at)),
                        found.len()
                    ),
                },
            ));
        }
        return Err(refuse(
            &port,
            0,
            AssignRefusal::MoreThanOne {
                found: found_text(&found),
            },
        ));
    }
    let (addr_key, rate_key) = bus_codes(family, &schema, &port)?;
    need_type(&schema, &port, addr_key)?;
    if req.baud.is_some_and(|b| b != rate) {
        need_type(&schema, &port, rate_key)?;
    }
    // read at address 0
    let (identity, old_raw, rate_raw_now) = {
        let mut c = connect_on(link, schema.clone(), 0)?;
        let identity = c.identify()?;
        let old = c.read(addr_key)?;
        let r = if req.baud.is_some() {
            Some(c.read(rate_key)?)
        } else {
            None
        };
        c.finish()?;
        (identity, old, r)
    };
    let old_address = address_of_raw(&schema, addr_key, &old_raw);
    // the one device of the list is at N, but 82 says otherwise: another
    // device (a lone device answers at 0 and at its own address only)
    if let Some(f) = found.first()
        && f.address == req.to
        && old_address != Some(i64::from(req.to))
    {
        return Err(refuse(
            &port,
            0,
            AssignRefusal::Taken {
                address: req.to,
                answer: found_text(&found),
            },
        ));
    }
    let mut writes = Vec::new();
    if old_address != Some(i64::from(req.to)) || req.always_write_address {
        let raw =
            address_raw(&schema, addr_key, req.to).unwrap_or(RawValue::Int(i64::from(req.to)));
        writes.push(lust_write(&schema, 0, rate, addr_key, raw, Step::Address));
    }
    let mut rate_effect = None;
    if let Some(b) = req.baud {
        let want = rate_raw(&schema, rate_key, b).unwrap_or(RawValue::Int(i64::from(b)));
        let online = family.descriptor().line_rates.online;
        if b != rate || rate_raw_now.as_ref() != Some(&want) {
            writes.push(lust_write(
                &schema,
                req.to,
                rate,
                rate_key,
                want,
                Step::Rate,
            ));
            rate_effect = Some(RateEffect::AtRestart);
        }
        if let Some(o) = online
            && b != rate
        {
            writes.push(lust_write(
                &schema,
                req.to,
                rate,
                CodeKey::new(o.command),
                RawValue::Int(o.activate),
                Step::Activate,
            ));
            rate_effect = Some(RateEffect::Online);
        }
    }
    Ok(AssignPlan {
        port: port.clone(),
        bus: bus_of(link),
        protocol,
        family,
        schema_id: schema.id.clone(),
        schema,
        identity,
        type_value,
        reached_at: 0,
        old_address,
        to: req.to,
        rate,
        baud: req.baud,
        rate_effect,
        scan: found,
        scan_time,
        elapsed: now(link) - start,
        writes,
        scan_opts: req.scan.clone(),
    })
}

fn lust_write(
    schema: &Schema,
    address: u8,
    baud: u32,
    key: CodeKey,
    raw: RawValue,
    step: Step,
) -> PlannedWrite {
    let at = if address == 0 {
        "0 (@)".to_string()
    } else {
        address.to_string()
    };
    let code = crate::client::lustbus::wire_code_text(schema, key);
    PlannedWrite {
        telegram: format!("LUSTBUS SELECT to address {at}, CODE {code}"),
        code: code_label(schema, key),
        value: shown(schema, key, &raw),
        address,
        baud,
        key,
        raw,
        step,
    }
}

fn lecom_write(
    schema: &Schema,
    address: u8,
    baud: u32,
    key: CodeKey,
    raw: RawValue,
    step: Step,
) -> PlannedWrite {
    PlannedWrite {
        telegram: format!("LECOM SEND to controller {address:02}, C{:04}", key.number),
        code: code_label(schema, key),
        value: shown(schema, key, &raw),
        address,
        baud,
        key,
        raw,
        step,
    }
}

fn lecom_timeout(link: &dyn ByteLink, opts: &ScanOptions) -> Duration {
    opts.timeout
        .unwrap_or_else(|| Duration::from_millis(40) + wire_time(24, link.baud()))
}

/// Whether anything answers a LECOM RECEIVE of `key` at `address`.
fn lecom_probe(
    link: &mut dyn ByteLink,
    address: u8,
    key: CodeKey,
    opts: &ScanOptions,
) -> Result<Option<String>, LinkError> {
    let Some(ad) = ControllerAddress::new(address) else {
        return Ok(None);
    };
    let timeout = lecom_timeout(link, opts);
    let mut line = LecomLine::new(BorrowedByteLink(link));
    let got = crate::client::lecom::probe(&mut line, ad, key, timeout, opts.tries.max(1))?;
    line.finish()?;
    Ok(got)
}

fn plan_lecom(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
) -> Result<AssignPlan, EngineError> {
    let port = port_of(link);
    let protocol = BusProtocol::Lecom;
    let family = Family::Tmd;
    let from = req.from.unwrap_or(1);
    check_address(protocol, &port, "--to", req.to)?;
    check_address(protocol, &port, "--from", from)?;
    if let Some(b) = req.baud {
        check_family_rate(&port, family, b)?;
    }
    bytes(link, protocol)?;
    let schema = schemas.get(family).ok_or_else(|| {
        refuse(
            &port,
            from,
            AssignRefusal::NoSchema {
                family: family.descriptor().title.into(),
            },
        )
    })?;
    let (addr_key, rate_key) = bus_codes(family, &schema, &port)?;
    need_type(&schema, &port, addr_key)?;
    let start = now(link);
    let opts = &req.scan;
    let probe_key = CodeKey::new(
        schema
            .identify
            .as_ref()
            .and_then(|i| i.codes.first().copied())
            .unwrap_or(crate::client::lecom::C0093),
    );
    // the drive at M: the port's rate first, then every Tmd rate
    let first_rate = baud_of(link);
    let mut order = vec![first_rate];
    order.extend(LECOM_SEARCH.iter().copied().filter(|r| *r != first_rate));
    let mut rate = None;
    for r in order {
        if !set_rate(link, r)? {
            continue;
        }
        let b = bytes(link, protocol)?;
        if lecom_probe(b, from, probe_key, opts)
            .map_err(|e| link_err(&port, from, e))?
            .is_some()
        {
            rate = Some(r);
            break;
        }
    }
    let Some(rate) = rate else {
        let _ = set_rate(link, first_rate);
        return Err(EngineError::no_answer(
            target(&port, from),
            format!(
                "a RECEIVE of C{:04} at controller {from:02} at every LECOM rate ({})",
                probe_key.number,
                list(&LECOM_SEARCH)
            ),
            opts.tries.max(1),
        ));
    };
    // another device at N?
    let scan_start = now(link);
    let mut found = Vec::new();
    if req.to != from {
        let b = bytes(link, protocol)?;
        found = scan_lecom(b, Some(&schema), &[req.to], opts)?;
        if !found.is_empty() {
            return Err(refuse(
                &port,
                from,
                AssignRefusal::Taken {
                    address: req.to,
                    answer: found_text(&found),
                },
            ));
        }
    }
    let scan_time = now(link) - scan_start;
    let (identity, c0001, old_raw, rate_now) = {
        let mut c = connect_on(link, schema.clone(), from)?;
        let identity = c.identify()?;
        let c0001 = c.read(CodeKey::new(1))?;
        let old = c.read(addr_key)?;
        let r = if req.baud.is_some() {
            Some(c.read(rate_key)?)
        } else {
            None
        };
        c.finish()?;
        (identity, c0001, old, r)
    };
    // §4e: 0 and 1 read only; 2 and 3 write
    let program = address_of_raw(&schema, CodeKey::new(1), &c0001);
    if !matches!(program, Some(2 | 3)) {
        return Err(refuse(
            &port,
            from,
            AssignRefusal::LecomReadOnly {
                c0001: shown(&schema, CodeKey::new(1), &c0001),
            },
        ));
    }
    let old_address = address_of_raw(&schema, addr_key, &old_raw);
    let mut writes = Vec::new();
    if req.to != from || old_address != Some(i64::from(req.to)) || req.always_write_address {
        let raw =
            address_raw(&schema, addr_key, req.to).unwrap_or(RawValue::Int(i64::from(req.to)));
        writes.push(lecom_write(
            &schema,
            from,
            rate,
            addr_key,
            raw,
            Step::Address,
        ));
    }
    let mut rate_effect = None;
    if let Some(b) = req.baud {
        need_type(&schema, &port, rate_key)?;
        let want = rate_raw(&schema, rate_key, b).ok_or_else(|| {
            refuse(
                &port,
                from,
                AssignRefusal::InvalidRate {
                    baud: b,
                    who: format!("schema `{}`'s C0125", schema.id),
                    rates: list(family.descriptor().line_rates.rates),
                },
            )
        })?;
        if rate_now.as_ref() != Some(&want) {
            writes.push(lecom_write(
                &schema,
                req.to,
                rate,
                rate_key,
                want,
                Step::Rate,
            ));
            rate_effect = Some(RateEffect::AtRestart);
        }
    }
    Ok(AssignPlan {
        port: port.clone(),
        bus: bus_of(link),
        protocol,
        family,
        schema_id: schema.id.clone(),
        schema,
        identity,
        type_value: None,
        reached_at: from,
        old_address,
        to: req.to,
        rate,
        baud: req.baud,
        rate_effect,
        scan: found,
        scan_time,
        elapsed: now(link) - start,
        writes,
        scan_opts: req.scan.clone(),
    })
}

// ---------------------------------------------------------------------
// run

/// [`plan`], then [`run`].
pub fn assign(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
    journal: &Path,
) -> Result<AssignReport, EngineError> {
    let p = plan(link, req, schemas)?;
    run(link, &p, journal)
}

fn record_of(p: &AssignPlan) -> AssignRecord {
    AssignRecord {
        protocol: p.protocol,
        family: p.family.name().to_string(),
        from: p.reached_at,
        old_address: p.old_address,
        to: p.to,
        old_rate: p.rate,
        rate: p.baud.filter(|b| *b != p.rate || p.rate_effect.is_some()),
        type_value: p.type_value,
        step: AssignStep::Planned,
    }
}

fn new_journal(p: &AssignPlan, at_ns: u64, record: AssignRecord) -> Journal {
    let mut j = Journal {
        journal_version: JOURNAL_VERSION,
        state: TxnState::Planned,
        target: JournalTarget {
            port: p.port.clone(),
            address: p.to,
            bus: Some(p.bus.clone()),
        },
        identity: JournalIdentity::from(&p.identity),
        schema: p.schema.id.clone(),
        schema_source: SchemaSource::of(&p.schema),
        set_fingerprint: String::new(),
        fingerprint_before: String::new(),
        dataset: false,
        attempt: 0,
        backup: Vec::new(),
        plan: Vec::new(),
        unchanged: Vec::new(),
        written: Vec::new(),
        broadcast: Vec::new(),
        transitions: Vec::new(),
        failure: None,
        failure_cause: None,
        holding: Vec::new(),
        transfer: None,
        assign: Some(record),
    };
    j.transition(
        TxnState::Planned,
        at_ns,
        Some(format!(
            "address: the drive at address {} to address {}{}",
            p.reached_at,
            p.to,
            p.baud.map_or_else(String::new, |b| format!(
                ", line rate {} to {b} baud",
                p.rate
            ))
        )),
    );
    j
}

fn set_step(jf: &mut JournalFile, step: AssignStep) -> Result<(), EngineError> {
    if let Some(r) = &mut jf.journal.assign {
        r.step = step;
    }
    jf.persist()
}

/// Carry out `p` (from [`plan`] on the same link): journal at `journal`
/// first, then the writes, each verified (module docs).
pub fn run(link: &mut Link, p: &AssignPlan, journal: &Path) -> Result<AssignReport, EngineError> {
    let start = now(link);
    if let Some(dir) = journal.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::journal::ensure_dir(dir)?;
    }
    // an unfinished transaction of this drive (at its new address or the
    // one it is reached at) is settled first
    let dir = match journal.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    for a in [p.to, p.reached_at] {
        let found = crate::journal::unfinished_for(dir, &p.bus, &p.port, a)?;
        if !found.is_empty() {
            return Err(crate::journal::unfinished_error(
                &target(&p.port, a),
                &found,
            ));
        }
    }
    let at_ns = now(link).as_nanos();
    let mut jf = JournalFile::create(journal, new_journal(p, at_ns, record_of(p)))?;
    let result = finish(link, p, &mut jf);
    match result {
        Ok((written, verified, rate_now, rate_note)) => {
            set_step(&mut jf, AssignStep::Done)?;
            let t = now(link).as_nanos();
            jf.journal.written = written.clone();
            jf.journal.transition(
                TxnState::Complete,
                t,
                Some("address set and verified".into()),
            );
            jf.persist()?;
            Ok(AssignReport {
                plan: p.clone(),
                written,
                verified,
                rate_now,
                rate_note,
                journal: journal.display().to_string(),
                elapsed: p.elapsed + (now(link) - start),
            })
        }
        Err(e) => {
            let t = now(link).as_nanos();
            let msg = format!(
                "{e}; journal {j}: run `driveset recover {j}` (it finds the drive and finishes the change)",
                j = journal.display()
            );
            jf.journal.failure = Some(msg.clone());
            jf.journal.failure_cause = Some(crate::journal::FailureCause::of(&e));
            jf.journal.transition(TxnState::Failed, t, Some(msg));
            let _ = jf.persist();
            Err(with_journal(e, journal))
        }
    }
}

fn with_journal(mut e: EngineError, journal: &Path) -> EngineError {
    let note = format!(
        "journal {j}: run `driveset recover {j}`",
        j = journal.display()
    );
    match &mut *e.kind {
        ErrorKind::NoAnswer { what, .. } | ErrorKind::Device { what, .. } => {
            what.push_str(&format!(" ({note})"));
            e
        }
        ErrorKind::Protocol { detail, .. } => {
            detail.push_str(&format!("; {note}"));
            e
        }
        _ => {
            let t = e.target.clone().unwrap_or_else(|| target("", 0));
            EngineError::protocol(t, "the address change", format!("{e}; {note}"))
        }
    }
}

type Done = (Vec<String>, Vec<String>, u32, Option<String>);

/// The writes of `p` and their verification; also [`recover`]'s way to
/// finish (every write is skipped when its value is in place already).
fn finish(link: &mut Link, p: &AssignPlan, jf: &mut JournalFile) -> Result<Done, EngineError> {
    let schema = p.schema.clone();
    let port = p.port.clone();
    let mut written = Vec::new();
    let mut verified = Vec::new();
    let (addr_key, rate_key) = bus_codes(p.family, &schema, &port)?;
    let lustbus = p.protocol == BusProtocol::Lustbus;
    // 1. the address
    if let Some(w) = p.writes.iter().find(|w| w.step == Step::Address) {
        set_step(jf, AssignStep::Address)?;
        let mut c = connect_on(link, schema.clone(), w.address)?;
        c.write_named(w.key, &w.raw, Permit::BUS_ADDRESS)?;
        c.finish()?;
        written.push(format!("{} = {} at address {}", w.code, w.value, w.address));
    }
    // verify at N
    {
        let mut c = connect_on(link, schema.clone(), p.to)?;
        let got = c.read(addr_key)?;
        if address_of_raw(&schema, addr_key, &got) != Some(i64::from(p.to)) {
            return Err(EngineError::protocol(
                target(&port, p.to),
                format!("verify {}", code_label(&schema, addr_key)),
                format!(
                    "reads {} instead of {}",
                    shown(&schema, addr_key, &got),
                    p.to
                ),
            ));
        }
        let id = c.identify()?;
        if id.codes != p.identity.codes {
            return Err(EngineError::protocol(
                target(&port, p.to),
                "verify the identity at the new address",
                format!(
                    "the drive at {} identifies as {} instead of {}",
                    p.to,
                    pairs(&id),
                    pairs(&p.identity)
                ),
            ));
        }
        c.finish()?;
        verified.push(format!(
            "address {}: {} = {}, {}",
            p.to,
            code_label(&schema, addr_key),
            p.to,
            pairs(&id)
        ));
    }
    // nothing at the old own address any more
    if lustbus
        && let Some(old) = p.old_address.and_then(|a| u8::try_from(a).ok())
        && old != p.to
        && (1..=30).contains(&old)
    {
        let b = bytes(link, p.protocol)?;
        let found = scan_lustbus(b, &[old], &p.scan_opts())?;
        if !found.is_empty() {
            return Err(EngineError::protocol(
                target(&port, old),
                "verify the old address is free",
                format!(
                    "a device still answers at address {old}: {}",
                    found_text(&found)
                ),
            ));
        }
        verified.push(format!("nothing answers at the old address {old}"));
    }
    set_step(jf, AssignStep::AddressVerified)?;
    // 2. the rate
    let mut rate_now = p.rate;
    let mut rate_note = None;
    if let Some(w) = p.writes.iter().find(|w| w.step == Step::Rate) {
        set_step(jf, AssignStep::Rate)?;
        let mut c = connect_on(link, schema.clone(), p.to)?;
        c.write_named(w.key, &w.raw, Permit::LINE_RATE)?;
        written.push(format!("{} = {} at address {}", w.code, w.value, w.address));
        c.finish()?;
    }
    if let Some(a) = p.writes.iter().find(|w| w.step == Step::Activate) {
        let target_rate = p.baud.unwrap_or(p.rate);
        {
            let mut c = connect_on(link, schema.clone(), p.to)?;
            c.write_named(a.key, &a.raw, Permit::ACTIVATE_RATE)?;
            c.finish()?;
        }
        written.push(format!("{} = {} at address {}", a.code, a.value, a.address));
        set_rate(link, target_rate)?;
        rate_now = target_rate;
    }
    if let (Some(b), Some(effect)) = (p.baud, p.rate_effect) {
        let want = rate_raw(&schema, rate_key, b).unwrap_or(RawValue::Int(i64::from(b)));
        let mut c = connect_on(link, schema.clone(), p.to)?;
        let got = c.read(rate_key)?;
        if got != want {
            return Err(EngineError::protocol(
                target(&port, p.to),
                format!("verify {}", code_label(&schema, rate_key)),
                format!(
                    "reads {} at {} baud instead of {}",
                    shown(&schema, rate_key, &got),
                    rate_now,
                    shown(&schema, rate_key, &want)
                ),
            ));
        }
        match effect {
            RateEffect::Online => {
                let a = c.read(addr_key)?;
                let id = c.identify()?;
                if address_of_raw(&schema, addr_key, &a) != Some(i64::from(p.to))
                    || id.codes != p.identity.codes
                {
                    return Err(EngineError::protocol(
                        target(&port, p.to),
                        format!("verify at {b} baud"),
                        format!(
                            "{} reads {}, {}",
                            code_label(&schema, addr_key),
                            shown(&schema, addr_key, &a),
                            pairs(&id)
                        ),
                    ));
                }
                verified.push(format!(
                    "at {b} baud: {} = {}, {} = {}, {}",
                    code_label(&schema, rate_key),
                    shown(&schema, rate_key, &got),
                    code_label(&schema, addr_key),
                    p.to,
                    pairs(&id)
                ));
            }
            RateEffect::AtRestart => {
                verified.push(format!(
                    "{} = {} (read back at {} baud)",
                    code_label(&schema, rate_key),
                    shown(&schema, rate_key, &got),
                    rate_now
                ));
                rate_note = Some(format!(
                    "the {} takes the new rate {b} baud at its next restart ({}); until then it answers at {} baud",
                    p.family.descriptor().title,
                    if lustbus {
                        "lustbus-protocol.txt §11.5: only a servocontroller activates a rate online"
                    } else {
                        "lecom-ab-tmd-manual.txt C0125, §4d"
                    },
                    rate_now
                ));
            }
        }
        c.finish()?;
    }
    Ok((written, verified, rate_now, rate_note))
}

fn pairs(id: &Identity) -> String {
    id.codes
        .iter()
        .map(|c| format!("{} = {}", c.name, c.value))
        .collect::<Vec<_>>()
        .join(", ")
}

impl AssignPlan {
    fn scan_opts(&self) -> ScanOptions {
        self.scan_opts.clone()
    }

    /// Whether there is nothing to write.
    pub fn is_noop(&self) -> bool {
        self.writes.is_empty()
    }
}

// ---------------------------------------------------------------------
// recover

/// Whether `journal` records a `driveset address` change.
pub fn is_assign_journal(journal: &Journal) -> bool {
    journal.assign.is_some()
}

/// The refusal the upload's recover gives for an address journal.
pub(crate) fn not_for_upload_recover(target: Target, journal: &Path) -> EngineError {
    EngineError::refused(
        target,
        Refusal::from(AssignRefusal::AssignJournal {
            journal: journal.display().to_string(),
        }),
    )
}

/// Finish the address change the journal at `journal_path` records, on
/// `link` (the journal's bus): find the drive at the new and the old
/// address, at the recorded rates and then every rate of its family;
/// refuse another bus or another drive (TYPE / identity); then every step
/// not in effect yet is done and verified, and the journal marked
/// complete.
pub fn recover(
    link: &mut Link,
    journal_path: &Path,
    schemas: &Schemas,
) -> Result<AssignRecovered, EngineError> {
    let mut jf = JournalFile::open(journal_path)?;
    let name = journal_path.display().to_string();
    let port = port_of(link);
    let Some(rec) = jf.journal.assign.clone() else {
        return Err(EngineError::journal(
            name,
            "it records no `driveset address` change".to_string(),
        ));
    };
    let bus = bus_of(link);
    if jf.journal.target.bus.as_deref() != Some(bus.as_str()) {
        return Err(EngineError::not_journal_drive(
            target(&port, rec.to),
            name.clone(),
            crate::error::Mismatch::Bus,
            format!(
                "it belongs to bus `{}`, but this port reaches bus `{bus}`; nothing was sent. Recover through a port to that bus",
                jf.journal.target.bus.clone().unwrap_or_default()
            ),
        ));
    }
    if jf.journal.is_finished() {
        return Ok(AssignRecovered {
            journal: name,
            found_step: rec.step,
            found_at: (rec.to, rec.rate.unwrap_or(rec.old_rate)),
            written: Vec::new(),
            state: format!("the journal is already {}", jf.journal.state.as_str()),
        });
    }
    let protocol = rec.protocol;
    let family = Family::parse(&rec.family).map_err(|_| {
        EngineError::journal(name.clone(), format!("unknown family `{}`", rec.family))
    })?;
    let schema = schemas.get(family).ok_or_else(|| {
        refuse(
            &port,
            rec.to,
            AssignRefusal::NoSchema {
                family: family.descriptor().title.into(),
            },
        )
    })?;
    let (addr_key, rate_key) = bus_codes(family, &schema, &port)?;
    // search: addresses N then the old one; rates: new, old, then all
    let mut rates = Vec::new();
    for r in rec
        .rate
        .into_iter()
        .chain([rec.old_rate])
        .chain(family.descriptor().line_rates.rates.iter().copied())
    {
        if !rates.contains(&r) {
            rates.push(r);
        }
    }
    let addresses: Vec<u8> = if rec.from == rec.to {
        vec![rec.to]
    } else {
        vec![rec.to, rec.from]
    };
    let mut found_at = None;
    'search: for r in &rates {
        if !set_rate(link, *r)? {
            continue;
        }
        for a in &addresses {
            let mut c = connect_on(link, schema.clone(), *a)?;
            let got = c.read(addr_key);
            let _ = c.finish();
            match got {
                Ok(v) => {
                    found_at = Some((*a, *r, v));
                    break 'search;
                }
                Err(e) => match e.kind() {
                    ErrorKind::NoAnswer { .. } | ErrorKind::Protocol { .. } => {}
                    _ => return Err(e),
                },
            }
        }
    }
    let Some((at, rate, addr_now)) = found_at else {
        return Err(EngineError::no_answer(
            target(&port, rec.to),
            format!(
                "the search for the drive of journal {name} at address {} at {} baud",
                addresses
                    .iter()
                    .map(u8::to_string)
                    .collect::<Vec<_>>()
                    .join(" and "),
                list(&rates)
            ),
            1,
        ));
    };
    // the same drive?
    let identity = {
        let mut c = connect_on(link, schema.clone(), at)?;
        let id = c.identify()?;
        c.finish()?;
        id
    };
    let jid = JournalIdentity::from(&identity);
    if jid.codes != jf.journal.identity.codes {
        return Err(EngineError::not_journal_drive(
            target(&port, at),
            name.clone(),
            crate::error::Mismatch::Identity,
            AssignRefusal::NotTheDrive {
                detail: format!(
                    "the drive at address {at} identifies as {} but the journal was written for {}",
                    pairs(&identity),
                    jf.journal
                        .identity
                        .codes
                        .iter()
                        .map(|(n, v)| format!("{n} = {v}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }
            .to_string(),
        ));
    }
    // rebuild the plan from where the drive is
    let old_address = address_of_raw(&schema, addr_key, &addr_now);
    let mut writes = Vec::new();
    let write = |addr: u8, key: CodeKey, raw: RawValue, step: Step| match protocol {
        BusProtocol::Lecom => lecom_write(&schema, addr, rate, key, raw, step),
        _ => lust_write(&schema, addr, rate, key, raw, step),
    };
    if old_address != Some(i64::from(rec.to)) {
        let raw =
            address_raw(&schema, addr_key, rec.to).unwrap_or(RawValue::Int(i64::from(rec.to)));
        writes.push(write(at, addr_key, raw, Step::Address));
    }
    let mut rate_effect = None;
    if let Some(b) = rec.rate {
        let want = rate_raw(&schema, rate_key, b).unwrap_or(RawValue::Int(i64::from(b)));
        let holds = {
            let mut c = connect_on(link, schema.clone(), at)?;
            let v = c.read(rate_key)?;
            c.finish()?;
            v
        };
        if holds != want {
            writes.push(write(rec.to, rate_key, want, Step::Rate));
        }
        rate_effect = Some(RateEffect::AtRestart);
        if let Some(o) = family.descriptor().line_rates.online {
            rate_effect = Some(RateEffect::Online);
            if rate != b {
                writes.push(write(
                    rec.to,
                    CodeKey::new(o.command),
                    RawValue::Int(o.activate),
                    Step::Activate,
                ));
            }
        }
    }
    let p = AssignPlan {
        port: port.clone(),
        bus,
        protocol,
        family,
        schema_id: schema.id.clone(),
        schema: schema.clone(),
        identity,
        type_value: rec.type_value,
        reached_at: at,
        old_address,
        to: rec.to,
        rate,
        baud: rec.rate,
        rate_effect,
        scan: Vec::new(),
        scan_time: Duration::ZERO,
        elapsed: Duration::ZERO,
        writes,
        scan_opts: ScanOptions::default(),
    };
    let (written, verified, rate_now, note) = finish(link, &p, &mut jf)?;
    set_step(&mut jf, AssignStep::Done)?;
    let t = now(link).as_nanos();
    jf.journal.written.extend(written.iter().cloned());
    jf.journal.transition(
        TxnState::Complete,
        t,
        Some("recover: address change finished and verified".into()),
    );
    jf.persist()?;
    let mut state = format!(
        "the drive answers at address {} at {rate_now} baud; {}",
        rec.to,
        verified.join("; ")
    );
    if let Some(n) = note {
        state.push_str("; ");
        state.push_str(&n);
    }
    Ok(AssignRecovered {
        journal: name,
        found_step: rec.step,
        found_at: (at, rate),
        written,
        state,
    })
}
