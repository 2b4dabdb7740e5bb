//! Machinery shared by the simulated LUSTBUS drives ([`crate::mc6000`],
//! [`crate::vf1000`]): options, the slave-side receive path (the codec's
//! [`RequestDecoder`], addressing, BCC and parity handling), the latched
//! SIOF/SERR word, raw value <-> VALUE conversion through the codec's
//! [`ParameterValue`], parameter descriptions and substitution texts, power
//! cycles and reaction times. This file holds the options, the model
//! contract and the core's state; `receive` the receive path, the reply
//! and the shared [`ByteDrive`] impl; `description` the descriptions and
//! substitution texts.
//!
//! Everything here follows `lustbus-protocol.txt` (section numbers in the
//! item docs); interpretations are listed on the items and in the models'
//! module docs.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::ascii::{EOT, mask7};
use driveset_proto::lustbus::description::{
    Attributes, McExtended, McExtension, McKind, McLayout, McTypeChars, ShortText, UserLevel,
    VfKind, VfStorage,
};
use driveset_proto::lustbus::value::Dialect as WireFamily;
use driveset_proto::lustbus::{
    Address, FrameError, McDescription, ParameterCode, ParameterType, ParameterValue, Reply,
    Request, RequestDecoder, Siof, ValueReply, ValueText, VfDescription,
};
use driveset_schema::ValueType;
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use driveset_schema::family::Keypad;
use driveset_schema::schema::StorageKind;

use crate::catalog::{self, Family};
use crate::describe::DescribeAs;
use crate::drive::{ByteDrive, Heard, ReactionTime, ReadRefusal, Reply as LineReply};
use crate::rng::SimRng;
use crate::table::{Param, ParamTable};

mod description;
mod receive;

use description::printable;

/// 85-SIOF/SERR, the numerically compatible error-status word (section 5.2).
pub const SIOF: u32 = driveset_proto::lustbus::CompatibleParameter::Siof.number() as u32;
/// 81-SIOC/SBAUD, the baud rate (sections 4, 11.5).
pub const BAUD: u32 = driveset_proto::lustbus::CompatibleParameter::Baud.number() as u32;
/// 82-SIOA/SADDR, the drive's own address (section 4.2).
pub const ADDRESS: u32 = driveset_proto::lustbus::CompatibleParameter::Address.number() as u32;

/// How a simulated LUSTBUS drive is built.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LustOptions {
    /// Own bus address 1..=30 (section 4.2), written into 82-SIOA/SADDR.
    /// 0 is allowed (the drive then answers only address 0, '@').
    pub address: u8,
    /// Seed of the drive's [`SimRng`] (reaction times, cut ACKs).
    pub seed: u64,
    /// Whether a KEYPAD KP100 is attached: slower reactions (section 10).
    pub keypad: Keypad,
    /// A reaction-time range replacing the section 10 figures (for exact
    /// timing tests use [`ReactionTime::fixed`]).
    pub reaction: Option<ReactionTime>,
    /// How long the drive does not answer after an error-reset reboot
    /// (VF1000 11-STAT = 000F, section 8.1.1). The spec gives no figure:
    /// FICTIONAL default 1 s.
    pub boot_time: Duration,
    /// MC6000/7000: the layout of the parameter descriptions the drive
    /// sends (errata L22; default [`McLayout::Hex52`]).
    pub description_layout: McLayout,
    /// MC6000/7000: the type characters of its descriptions (errata L23).
    pub type_chars: McTypeChars,
    /// Parameters whose description says something other than the
    /// fixture (`describe=`, [`crate::describe`]).
    pub describe: BTreeMap<u32, DescribeAs>,
}

impl LustOptions {
    /// Options for a drive at `address`, seed 0, without KEYPAD.
    pub fn new(address: u8) -> Self {
        LustOptions {
            address,
            seed: 0,
            keypad: Keypad::Absent,
            reaction: None,
            boot_time: Duration::from_secs(1),
            description_layout: McLayout::Hex52,
            type_chars: McTypeChars::Driveset,
            describe: BTreeMap::new(),
        }
    }

    /// With this seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// With or without a KEYPAD.
    pub fn keypad(mut self, keypad: Keypad) -> Self {
        self.keypad = keypad;
        self
    }

    /// With this reaction-time range.
    pub fn reaction(mut self, reaction: ReactionTime) -> Self {
        self.reaction = Some(reaction);
        self
    }

    /// With this boot time after an error-reset reboot.
    pub fn boot_time(mut self, boot: Duration) -> Self {
        self.boot_time = boot;
        self
    }
}

impl Default for LustOptions {
    fn default() -> Self {
        LustOptions::new(1)
    }
}

/// What a model makes of one host telegram addressed to it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Answer {
    /// ENQUIRY answered with `ADR STX CODE = VALUE ETX BCC` (section 6.1).
    Value(ValueText),
    /// SELECT accepted: `ADR ACK`, `extra` after the normal reaction time
    /// (VF1000 EEPROM write, factory reload).
    Ack { extra: Duration },
    /// SELECT accepted, but the drive reboots at once: the ACK may be cut
    /// after the ADR (sections 8.1.1, 8.1.2).
    AckThenReboot { cut: bool },
    /// SELECT refused: the bits are latched in SIOF/SERR, `ADR NAK`
    /// (sections 6, 9.2).
    Refuse(Siof),
    /// `ADR NAK` without a SIOF/SERR entry (ENQUIRY, section 6.1 note).
    Nak,
}

/// A family model on top of [`LustCore`].
pub(crate) trait LustModel {
    /// The family name logs and dumps use (`"mc6000"`, `"vf1000"`).
    const FAMILY: &'static str;
    /// The control word and its "running" bit (MC 416-SCTL1 bit 0, LUSTBUS
    /// 7.2; VF 3-CNTL bit 7, 7.1.1).
    const RUN_BIT: (u32, i64);
    /// The shared state.
    fn core(&mut self) -> &mut LustCore;
    /// The shared state, read-only.
    fn core_ref(&self) -> &LustCore;
    /// Time-driven state changes due by `now` (SLOAD check end).
    fn tick(&mut self, now: Instant);
    /// An ENQUIRY of `code`.
    fn enquiry(&mut self, now: Instant, code: ParameterCode) -> Answer;
    /// A SELECT of `code` = `value` (only called while SIOF/SERR is clear).
    fn select(&mut self, now: Instant, code: ParameterCode, value: &ValueText) -> Answer;
    /// Power cut at `now`, back after `off`.
    fn power_cycle(&mut self, now: Instant, off: Duration);
}

/// The state every simulated LUSTBUS drive has.
#[derive(Debug, Clone)]
pub(crate) struct LustCore {
    pub table: ParamTable,
    /// Current (RAM) value of every parameter; EEPROM parameters hold the
    /// same value in EEPROM (the MC's background store is modelled as a
    /// busy time, not as a second copy).
    pub values: BTreeMap<CodeKey, RawValue>,
    pub wire: WireFamily,
    decoder: RequestDecoder,
    rng: SimRng,
    reaction: ReactionTime,
    /// No answers before this instant (power off, booting).
    boot_until: Option<Instant>,
    /// ADR of the host telegram being received (after its EOT).
    telegram_adr: Option<Address>,
    prev_byte: u8,
    /// A character of the telegram being received had a parity error.
    parity_bad: bool,
    pub running: bool,
    /// The baud rate in use (81 is only activated by a restart or, on the
    /// MC, 4-PROG = 111; section 11.5).
    pub active_baud: Option<i64>,
    pub baud_change: Option<u32>,
    /// Unit strings: index = the MC description's unit element, text =
    /// the 107-UNIT substitution text (section 11.2.1).
    pub units: Vec<String>,
    pub boot_time: Duration,
    pub description_layout: McLayout,
    pub type_chars: McTypeChars,
    /// Descriptions that disagree with the fixture ([`crate::describe`]).
    pub describe: BTreeMap<u32, DescribeAs>,
    /// Parameters whose ENQUIRY is refused although the table holds them
    /// ([`ByteDrive::refuse_read`]): NAK, with the SIOF/SERR bits latched
    /// when given.
    pub refused_reads: BTreeMap<u32, Option<Siof>>,
    /// 82-SIOA/SADDR was written and acknowledged
    /// ([`ByteDrive::address_assigned`]).
    pub address_assigned: bool,
    /// Parameters the drive answers on the bus as it answers a parameter it
    /// does not have ([`ByteDrive::forget`]: ENQUIRY `ADR NAK`, SELECT NAK
    /// with SIOF/SERR 0x20); the model keeps their values for itself.
    pub hidden: BTreeSet<u32>,
    /// A twin's descriptions and texts as its drive sent them
    /// ([`ByteDrive::describe_as`]): when set, the drive describes only
    /// these, whatever its table holds.
    pub recorded: Option<Recorded>,
}

/// The descriptions and substitution texts a twin's drive sent
/// ([`ByteDrive::describe_as`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct Recorded {
    /// The description of each parameter, by number.
    pub descriptions: BTreeMap<u32, ValueText>,
    /// The substitution texts, by parameter and 108-STEXT index.
    pub texts: BTreeMap<(u32, u8), ValueText>,
}

impl LustCore {
    /// Loads `family`'s table, sets every parameter to its factory value,
    /// 82 to the address and SIOF/SERR to power-on (sections 6, 9.2).
    pub fn new(
        family: Family,
        opts: &LustOptions,
        default_reaction: ReactionTime,
    ) -> Result<Self, String> {
        if opts.address > 30 {
            return Err(format!(
                "LUSTBUS drive address {} is outside 0..=30 (section 4.2)",
                opts.address
            ));
        }
        let table = ParamTable::from_schema(catalog::schema(family)?)?;
        let wire = match family {
            Family::Vf1000 => WireFamily::Vf1000,
            _ => WireFamily::Mc,
        };
        let units: BTreeSet<String> = table
            .iter()
            .filter_map(|p| table.schema().code(p.key.number)?.unit.clone())
            .map(|u| printable(&u))
            .filter(|u| !u.trim().is_empty())
            .collect();
        let mut units: BTreeSet<String> = units;
        units.extend(
            opts.describe
                .values()
                .filter_map(|d| d.unit.as_deref())
                .map(printable)
                .filter(|u| !u.trim().is_empty()),
        );
        let mut units: Vec<String> = units.into_iter().collect();
        units.insert(0, String::new());
        let mut core = LustCore {
            values: table.factory_state(),
            table,
            wire,
            decoder: RequestDecoder::new(),
            rng: SimRng::derive(opts.seed, u64::from(opts.address)),
            reaction: opts.reaction.unwrap_or(default_reaction),
            boot_until: None,
            telegram_adr: None,
            prev_byte: 0,
            parity_bad: false,
            running: false,
            active_baud: None,
            baud_change: None,
            units,
            boot_time: opts.boot_time,
            description_layout: opts.description_layout,
            type_chars: opts.type_chars.clone(),
            describe: opts.describe.clone(),
            refused_reads: BTreeMap::new(),
            address_assigned: false,
            hidden: BTreeSet::new(),
            recorded: None,
        };
        core.set(CodeKey::new(ADDRESS), i64::from(opts.address));
        core.set_siof(Siof::POWER_ON);
        core.active_baud = core.int(BAUD);
        Ok(core)
    }

    /// The refusal of an ENQUIRY of `number`'s value, when its reads are
    /// refused ([`ByteDrive::refuse_read`]).
    pub fn refused_read(&self, number: u32) -> Option<Answer> {
        self.refused_reads
            .get(&number)
            .map(|bits| bits.map_or(Answer::Nak, Answer::Refuse))
    }

    /// The parameter `number` (no subcodes on LUSTBUS).
    pub fn param(&self, number: u32) -> Option<&Param> {
        self.table.get(CodeKey::new(number))
    }

    /// The parameter `number` as the bus sees it: `None` for a parameter
    /// the drive does not have, or hides ([`LustCore::hidden`]).
    pub fn wire_param(&self, number: u32) -> Option<&Param> {
        if self.hidden.contains(&number) {
            return None;
        }
        self.param(number)
    }

    /// Current raw integer of `number`.
    pub fn int(&self, number: u32) -> Option<i64> {
        match self.values.get(&CodeKey::new(number)) {
            Some(RawValue::Int(v)) => Some(*v),
            _ => None,
        }
    }

    /// Sets a raw integer.
    pub fn set(&mut self, key: CodeKey, raw: i64) {
        if self.table.get(key).is_some() {
            self.values.insert(key, RawValue::Int(raw));
        }
    }

    /// The latched SIOF/SERR bits.
    pub fn siof(&self) -> Siof {
        Siof(self.int(SIOF).map_or(0, |v| (v & 0xFF) as u8))
    }

    fn set_siof(&mut self, s: Siof) {
        self.set(CodeKey::new(SIOF), i64::from(s.0));
    }

    /// Latches error bits (section 9.2).
    pub fn latch(&mut self, bits: Siof) {
        let s = self.siof().0 | bits.0;
        self.set_siof(Siof(s));
    }

    /// Reads and clears SIOF/SERR: an ENQUIRY of 85 is the only way to
    /// erase it (sections 6, 9.2).
    pub fn take_siof(&mut self) -> Siof {
        let s = self.siof();
        self.set_siof(Siof(0));
        s
    }

    /// The own address (82-SIOA/SADDR, effective at once).
    pub fn address(&self) -> u8 {
        self.int(ADDRESS)
            .and_then(|a| u8::try_from(a).ok())
            .filter(|a| *a <= 30)
            .unwrap_or(0)
    }

    /// The current state as a resolved set.
    pub fn state(&self) -> ResolvedSet {
        self.table.resolved(&self.values)
    }

    /// Sets one value directly (test hook).
    pub fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        if self.table.get(key).is_none() {
            return Err(format!(
                "{} has no parameter {}",
                self.table.schema().id,
                self.table.schema().display_code(key.number, key.subcode)
            ));
        }
        if !matches!(raw, RawValue::Int(_)) {
            return Err("LUSTBUS parameters hold integers".to_string());
        }
        self.values.insert(key, raw);
        Ok(())
    }

    /// The codec type of a parameter: proto's [`ParameterType::of_code`]
    /// of its schema type and width; a type of another protocol by its
    /// width too, and any other by PT_INT32Q16 (simulator choices for
    /// parameters the schemas leave untyped).
    pub fn wire_type(&self, p: &Param) -> ParameterType {
        let width = p.byte_width();
        let t = ParameterType::of_code(p.ty.map(|t| t.name()), Some(width))
            .or_else(|| ParameterType::of_width(width))
            .unwrap_or(ParameterType::Int32Q16);
        if t.in_family(self.wire) {
            t
        } else if self.wire == WireFamily::Vf1000 {
            ParameterType::Usign16
        } else {
            ParameterType::Usign8
        }
    }

    /// The wire integer of a raw value (two's complement for the signed
    /// types), if it fits the type.
    pub fn to_wire(&self, p: &Param, raw: i64) -> Option<ParameterValue> {
        ParameterValue::from_raw_signed(self.wire_type(p), raw)
    }

    /// The VALUE string of `raw` (section 2.3). VF1000: 4 digits. MC: the
    /// codec's digits, left-padded with zeros to two digits per byte of the
    /// parameter's width, as the only MC reply the spec prints
    /// (`04FA4000`, section 6.1.1.2) does; section 2.3 allows leading zeros.
    pub fn encode_value(&self, p: &Param, raw: i64) -> Option<ValueText> {
        let text = self.to_wire(p, raw)?.encode(self.wire).ok()?;
        if self.wire == WireFamily::Vf1000 {
            return Some(text);
        }
        let digits = usize::from(p.byte_width()).clamp(1, 4) * 2;
        let t = text.as_bytes();
        if t.len() >= digits {
            return Some(text);
        }
        let mut padded = vec![b'0'; digits - t.len()];
        padded.extend_from_slice(t);
        ValueText::new(&padded).ok()
    }

    /// The raw value of a VALUE string, or `None` if it is malformed for
    /// the family and type (section 2.3; SIOF 0x80).
    pub fn decode_value(&self, p: &Param, text: &ValueText) -> Option<i64> {
        let v = ParameterValue::decode(self.wire_type(p), self.wire, text.as_bytes()).ok()?;
        Some(match v {
            ParameterValue::Integer16(i) => i64::from(i),
            ParameterValue::Int32Q16(q) => i64::from(q.0),
            other => i64::from(other.raw()),
        })
    }

    /// Whether `raw` lies within the parameter's min/max. PT_FLOAT_IEEE is
    /// compared as numbers (not as bit patterns); NaN is never in range.
    pub fn in_range(&self, p: &Param, raw: i64) -> bool {
        if p.ty == Some(ValueType::PT_FLOAT_IEEE) {
            let f = |r: i64| u32::try_from(r).ok().map(f32::from_bits);
            let Some(v) = f(raw) else { return false };
            if v.is_nan() {
                return false;
            }
            let lo_ok = p.min.and_then(f).is_none_or(|lo| v >= lo);
            let hi_ok = p.max.and_then(f).is_none_or(|hi| v <= hi);
            return lo_ok && hi_ok;
        }
        p.check_range(raw).is_ok()
    }

    /// The storage kind a VF1000 parameter has now: FSEL/ISEL variables
    /// are RAM while 2-CSEL = 3 (control via SIO) and EEPROM below
    /// (section 11.1; errata schemas-lust E6).
    pub fn effective_kind(&self, p: &Param) -> Option<StorageKind> {
        match p.kind {
            Some(StorageKind::FselIsel) => {
                if self.int(2).unwrap_or(3) >= 3 {
                    Some(StorageKind::RamControl)
                } else {
                    Some(StorageKind::Eeprom)
                }
            }
            k => k,
        }
    }

    /// Every parameter back to its factory value, except the interface
    /// settings 81 (baud) and 82 (address), which the simulator keeps so
    /// the drive stays reachable on its bus (interpretation of the factory
    /// reload, section 10 exception 1). SIOF/SERR is kept too.
    pub fn load_factory(&mut self) {
        let keep: Vec<(CodeKey, RawValue)> = [BAUD, ADDRESS, SIOF]
            .iter()
            .filter_map(|n| {
                let k = CodeKey::new(*n);
                self.values.get(&k).map(|v| (k, v.clone()))
            })
            .collect();
        self.values = self.table.factory_state();
        for (k, v) in keep {
            self.values.insert(k, v);
        }
    }

    /// Time to store every EEPROM parameter at `ms_per_byte` (MC: width x
    /// 3 x 5 ms, section 10.2.2; VF1000: 60 ms a byte, section 10 exception
    /// 4), capped at the 10 s section 10 exception 1 gives as the longest
    /// factory reload: the simulator's factory-reload time.
    pub fn factory_reload_time(&self, ms_per_byte: u64) -> Duration {
        let ms: u64 = self
            .table
            .iter()
            .filter(|p| p.kind == Some(StorageKind::Eeprom))
            .map(|p| u64::from(p.byte_width()) * ms_per_byte)
            .sum();
        Duration::from_millis(ms.min(10_000))
    }

    /// Common power-cycle effects: no answers until `now + off`, RAM values
    /// (actual and control) back to factory, EEPROM values kept, SIOF/SERR
    /// = power on (sections 6, 9.2, 11.2.1 parameter kinds), motor stopped,
    /// receiver reset, a changed baud rate activated (section 11.5).
    pub fn power_cycle(&mut self, now: Instant, off: Duration) {
        self.boot_until = Some(now.saturating_add(off));
        // RAM values are lost; an FSEL/ISEL variable counts as RAM while
        // it is one (2-CSEL = 3, section 11.1).
        let lost: Vec<(CodeKey, RawValue)> = self
            .table
            .iter()
            .filter(|p| {
                matches!(
                    self.effective_kind(p),
                    Some(StorageKind::RamActual) | Some(StorageKind::RamControl)
                )
            })
            .map(|p| (p.key, p.factory.clone()))
            .collect();
        for (k, v) in lost {
            self.values.insert(k, v);
        }
        self.set_siof(Siof::POWER_ON);
        self.running = false;
        self.decoder.reset();
        self.telegram_adr = None;
        self.parity_bad = false;
        self.prev_byte = 0;
        let baud = self.int(BAUD);
        if baud != self.active_baud {
            self.activate_baud();
        }
    }

    /// Makes the value of 81 the active line rate (section 11.5).
    pub fn activate_baud(&mut self) {
        let baud = self.int(BAUD);
        if baud != self.active_baud {
            self.active_baud = baud;
            self.baud_change = baud.and_then(|b| u32::try_from(b).ok());
        }
    }

    /// Whether the drive is off or booting at `now`.
    pub fn booting(&mut self, now: Instant) -> bool {
        match self.boot_until {
            Some(t) if now < t => true,
            Some(_) => {
                self.boot_until = None;
                false
            }
            None => false,
        }
    }

    fn draw(&mut self) -> Duration {
        self.reaction.draw(&mut self.rng)
    }

    /// True with probability `p`, from the drive's generator.
    pub fn chance(&mut self, p: f64) -> bool {
        self.rng.chance(p)
    }
}
