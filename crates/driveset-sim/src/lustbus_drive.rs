//! Machinery shared by the simulated LUSTBUS drives ([`crate::mc6000`],
//! [`crate::vf1000`]): options, the slave-side receive path (the codec's
//! [`RequestDecoder`], addressing, BCC and parity handling), the latched
//! SIOF/SERR word, raw value <-> VALUE conversion through the codec's
//! [`ParameterValue`], parameter descriptions and substitution texts, power
//! cycles and reaction times.
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
use driveset_schema::schema::StorageKind;

use crate::catalog::{self, Family};
use crate::describe::DescribeAs;
use crate::drive::{ByteDrive, Heard, ReactionTime, ReadRefusal, Reply as LineReply};
use crate::rng::SimRng;
use crate::table::{Param, ParamTable};

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
    pub keypad: bool,
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
            keypad: false,
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
    pub fn keypad(mut self, keypad: bool) -> Self {
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

    /// The codec type of a parameter: from the schema, else from its width
    /// (a simulator choice for parameters the schemas leave untyped).
    pub fn wire_type(&self, p: &Param) -> ParameterType {
        let t =
            p.ty.and_then(|t| ParameterType::from_name(t.name()))
                .or_else(|| ParameterType::of_width(p.byte_width()))
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

    /// A VF1000 parameter description (section 11.1, 26 characters).
    /// Name: the schema name upper-cased, characters outside
    /// `A-Z 0-9 _ -` dropped, at most 6; unit at most 6 characters. Kind
    /// characters '4'..'7' for parameters the schema marks `basis = false`.
    pub fn vf_description(&self, p: &Param) -> Option<ValueText> {
        let storage = match p.kind {
            Some(StorageKind::RamActual) => VfStorage::RamActual,
            Some(StorageKind::Eeprom) => VfStorage::Eeprom,
            Some(StorageKind::FselIsel) => VfStorage::FselIsel,
            Some(StorageKind::RamControl) => VfStorage::RamControl,
            None if p.writable() => VfStorage::RamControl,
            None => VfStorage::RamActual,
        };
        let code = self.table.schema().code(p.key.number);
        let unit = code.and_then(|c| c.unit.clone()).unwrap_or_default();
        let w = |r: Option<i64>| {
            r.and_then(|r| self.to_wire(p, r))
                .map_or(0, |v| (v.raw() & 0xFFFF) as u16)
        };
        let factory = match p.factory {
            RawValue::Int(v) => Some(v),
            _ => None,
        };
        let mut d = VfDescription {
            name: ShortText::new(&short_name(&p.name, 6)).unwrap_or_default(),
            unit: ShortText::new(&truncate(&printable(&unit), 6)).unwrap_or_default(),
            kind: VfKind {
                storage,
                inverter_specific: code.and_then(|c| c.basis) == Some(false),
            },
            ty: self.wire_type(p),
            min: w(p.min),
            max: w(p.max),
            default: w(factory),
        };
        if let Some(o) = self.describe.get(&p.key.number) {
            let raw = |v: i64| (v & 0xFFFF) as u16;
            d.kind.storage = match o.kind {
                Some(StorageKind::RamActual) => VfStorage::RamActual,
                Some(StorageKind::RamControl) => VfStorage::RamControl,
                Some(StorageKind::Eeprom) => VfStorage::Eeprom,
                Some(StorageKind::FselIsel) => VfStorage::FselIsel,
                None => d.kind.storage,
            };
            d.ty = o.ty.unwrap_or(d.ty);
            d.min = o.min.map_or(d.min, raw);
            d.max = o.max.map_or(d.max, raw);
            d.default = o.default.map_or(d.default, raw);
            if let Some(u) = &o.unit {
                d.unit = ShortText::new(&truncate(&printable(u), 6)).unwrap_or_default();
            }
        }
        d.encode().ok()
    }

    /// An MC parameter description (section 11.2) in the layout and with
    /// the type characters of [`LustOptions::description_layout`] /
    /// [`LustOptions::type_chars`] (default the codec's 52-character layout,
    /// errata L22, L23). Unit: index into [`Self::units`]
    /// (0 = no unit). Simulator choices for the KEYPAD elements: levels 0,
    /// filters 0, attribute ShowText for PT_USIGN8 parameters with value
    /// texts and Password for PT_PASSWORD, subject area SIO (9) for the
    /// compatible parameters 81..85 and 0 (CONF) otherwise, activity area
    /// SC_DRIVE (5) for CardWriteable parameters and 0 otherwise.
    pub fn mc_description(&self, p: &Param) -> Option<ValueText> {
        let kind = match p.kind {
            Some(StorageKind::RamActual) => McKind::RamActual,
            Some(StorageKind::RamControl) => McKind::RamControl,
            Some(StorageKind::Eeprom) | Some(StorageKind::FselIsel) => McKind::Eeprom,
            None if p.writable() => McKind::RamControl,
            None => McKind::RamActual,
        };
        let over = self.describe.get(&p.key.number);
        let kind = match over.and_then(|o| o.kind) {
            Some(StorageKind::RamActual) => McKind::RamActual,
            Some(StorageKind::RamControl) => McKind::RamControl,
            Some(StorageKind::Eeprom | StorageKind::FselIsel) => McKind::Eeprom,
            None => kind,
        };
        let ty = over.and_then(|o| o.ty).unwrap_or_else(|| self.wire_type(p));
        let fixture = |r: Option<i64>| r.and_then(|r| self.to_wire(p, r)).map_or(0, |v| v.raw());
        let given = |v: i64| match ty {
            ParameterType::Integer16 => u32::from(v as i16 as u16),
            _ => v as u32,
        };
        let factory = match p.factory {
            RawValue::Int(v) => Some(v),
            _ => None,
        };
        let (min, max, default) = (
            over.and_then(|o| o.min).map_or(fixture(p.min), given),
            over.and_then(|o| o.max).map_or(fixture(p.max), given),
            over.and_then(|o| o.default).map_or(fixture(factory), given),
        );
        let mut attributes = Attributes(0);
        if ty == ParameterType::Usign8 && !p.enum_values.is_empty() {
            attributes = Attributes(attributes.0 | Attributes::SHOW_TEXT.0);
        }
        if ty == ParameterType::Password {
            attributes = Attributes(attributes.0 | Attributes::PASSWORD.0);
        }
        let d = McDescription {
            name: ShortText::new(&short_name(&p.name, 5)).unwrap_or_default(),
            unit: self.unit_index(p),
            kind,
            ty,
            min,
            max,
            default,
            extended: McExtended::Decoded(McExtension {
                level: UserLevel::default(),
                attributes,
                subject: if (81..=85).contains(&p.key.number) {
                    9
                } else {
                    0
                },
                activity: if p.card_writeable { 5 } else { 0 },
                ..McExtension::default()
            }),
        };
        d.encode_as(self.description_layout, &self.type_chars).ok()
    }

    fn unit_index(&self, p: &Param) -> u8 {
        let unit = self
            .describe
            .get(&p.key.number)
            .and_then(|d| d.unit.clone())
            .or_else(|| self.table.schema().code(p.key.number)?.unit.clone())
            .map(|u| printable(&u))
            .unwrap_or_default();
        self.units
            .iter()
            .position(|u| *u == unit)
            .and_then(|i| u8::try_from(i).ok())
            .unwrap_or(0)
    }

    /// The value substitution text number `index` of parameter `number`
    /// (section 11.3): the enumeration label of that value from the schema,
    /// or for 107-UNIT the unit string of that index (index 0, no unit, is
    /// a single blank, which readers trim). `None` (NAK) if the parameter
    /// does not exist, has no texts, `index` exceeds its maximum, or that
    /// value has no label.
    pub fn substitution_text(&self, number: u32, index: i64) -> Option<ValueText> {
        let p = self.param(number)?;
        if p.max.is_some_and(|m| index > m) {
            return None;
        }
        let text = if number == 107 {
            let t = self.units.get(usize::try_from(index).ok()?)?.clone();
            if t.is_empty() { " ".to_string() } else { t }
        } else {
            let code = self.table.schema().code(number)?;
            let e = self.table.schema().enum_of(code.values.as_ref()?)?;
            printable(e.label(index)?)
        };
        let text = truncate(&text, 100);
        if text.is_empty() {
            return None;
        }
        ValueText::new(text.as_bytes()).ok()
    }
}

/// Printable 7-bit ASCII of `s` (others become '?').
fn printable(s: &str) -> String {
    s.chars()
        .map(|c| if (' '..='~').contains(&c) { c } else { '?' })
        .collect()
}

fn truncate(s: &str, n: usize) -> String {
    s.chars().take(n).collect()
}

/// A description name: upper case, only `A-Z 0-9 _ -`, at most `n`.
fn short_name(name: &str, n: usize) -> String {
    name.chars()
        .map(|c| c.to_ascii_uppercase())
        .filter(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == '_' || *c == '-')
        .take(n)
        .collect()
}

/// One character from the line into a model (section 3: the receiver is a
/// state machine reset by EOT, without timeouts).
///
/// - Off or booting: nothing is heard (section 8.1).
/// - Address (sections 4.2, 9.1): the own address and 0 ('@') are executed
///   and answered (the reply carries the address the host used); 31 (`_`,
///   broadcast) SELECTs are executed without a reply, broadcast ENQUIRYs
///   ignored; other addresses ignored.
/// - A SELECT with a wrong BCC is refused with NAK and SIOF/SERR 0x08
///   (sections 3, 9.2); so is a SELECT with an empty VALUE (0x80). A
///   telegram with a character that had a parity error is treated as a
///   transfer error: a SELECT gets NAK + 0x08, an ENQUIRY no answer
///   (section 3: improper telegram). Other malformed telegrams get no
///   answer (section 3).
/// - While any SIOF/SERR bit is set, every SELECT is refused with NAK
///   (sections 6, 9.2), without new bits.
pub(crate) fn hear<M: LustModel>(m: &mut M, now: Instant, byte: u8, parity_ok: bool) -> Heard {
    let b = mask7(byte);
    if m.core().booting(now) {
        let c = m.core();
        c.decoder.reset();
        c.telegram_adr = None;
        c.prev_byte = 0;
        return Heard::Nothing;
    }
    let (events, bad, adr) = {
        let c = m.core();
        if c.prev_byte == EOT
            && let Some(a) = Address::from_byte(b)
        {
            c.telegram_adr = Some(a);
        }
        c.prev_byte = b;
        let bad = c.parity_bad || !parity_ok;
        let events: Vec<_> = c.decoder.push(b).collect();
        c.parity_bad = if b == EOT {
            !parity_ok
        } else if events.is_empty() {
            bad
        } else {
            false
        };
        (events, bad, c.telegram_adr)
    };
    let mut heard = Heard::Nothing;
    for ev in events {
        let h = match ev.result {
            Ok(Request::Eot) => Heard::Nothing,
            Ok(Request::Enquiry(e)) => {
                let reply = if !answers(m.core(), e.address) || bad {
                    None
                } else {
                    m.tick(now);
                    let a = m.enquiry(now, e.code);
                    finish(m, now, e.address, e.code, a)
                };
                Heard::Telegram { reply }
            }
            Ok(Request::Select(s)) => {
                let reply = if !executes(m.core(), s.address) {
                    None
                } else {
                    m.tick(now);
                    let a = if bad {
                        Answer::Refuse(Siof::CHECKSUM)
                    } else if m.core().siof().0 != 0 {
                        Answer::Nak
                    } else {
                        m.select(now, s.code, &s.value)
                    };
                    finish(m, now, s.address, s.code, a)
                };
                Heard::Telegram { reply }
            }
            Err(FrameError::Garbage { .. }) => Heard::Nothing,
            Err(e @ (FrameError::BadBcc { .. } | FrameError::EmptyValue { .. })) => {
                let reply = match adr {
                    Some(a) if executes(m.core(), a) => {
                        let bits = if matches!(e, FrameError::BadBcc { .. }) || bad {
                            Siof::CHECKSUM
                        } else {
                            Siof::INVALID_VALUE
                        };
                        finish(m, now, a, ParameterCode::POSMOD, Answer::Refuse(bits))
                    }
                    _ => None,
                };
                Heard::Telegram { reply }
            }
            Err(_) => Heard::Telegram { reply: None },
        };
        if !matches!(h, Heard::Nothing) {
            heard = h;
        }
    }
    heard
}

/// Whether a telegram to `adr` is executed (own, 0, broadcast).
fn executes(c: &LustCore, adr: Address) -> bool {
    adr == Address::ALL || adr == Address::BROADCAST || adr.number() == c.address()
}

/// Whether a telegram to `adr` is answered (own or 0).
fn answers(c: &LustCore, adr: Address) -> bool {
    adr != Address::BROADCAST && executes(c, adr)
}

/// Builds the reply bytes for an answer and applies its side effects.
fn finish<M: LustModel>(
    m: &mut M,
    now: Instant,
    adr: Address,
    code: ParameterCode,
    a: Answer,
) -> Option<LineReply> {
    let (reply, extra, reboot) = match a {
        Answer::Value(value) => (
            Reply::Value(ValueReply {
                address: adr,
                code,
                value,
            })
            .encode()
            .to_vec(),
            Duration::ZERO,
            false,
        ),
        Answer::Ack { extra } => (Reply::Ack(adr).encode().to_vec(), extra, false),
        Answer::AckThenReboot { cut } => {
            let mut b = Reply::Ack(adr).encode().to_vec();
            if cut {
                b.truncate(1);
            }
            (b, Duration::ZERO, true)
        }
        Answer::Refuse(bits) => {
            m.core().latch(bits);
            (Reply::Nak(adr).encode().to_vec(), Duration::ZERO, false)
        }
        Answer::Nak => (Reply::Nak(adr).encode().to_vec(), Duration::ZERO, false),
    };
    let reaction = m.core().draw().saturating_add(extra);
    let wanted = adr != Address::BROADCAST;
    if reboot {
        // The reset happens right after the (possibly cut) ACK has gone out;
        // the bus sends the reply, then the drive is deaf while it boots.
        let boot = m.core().boot_time;
        m.power_cycle(now.saturating_add(reaction), boot);
    }
    if !wanted {
        return None;
    }
    Some(LineReply {
        bytes: reply,
        reaction,
    })
}

/// Both LUSTBUS families are [`ByteDrive`]s through their shared core; what
/// differs (telegram handling, the running bit) comes from [`LustModel`].
impl<M: LustModel + Send + std::fmt::Debug> ByteDrive for M {
    fn family(&self) -> &'static str {
        M::FAMILY
    }

    fn address(&self) -> u8 {
        self.core_ref().address()
    }

    fn secret_codes(&self) -> Vec<u32> {
        self.core_ref().table.secret_codes()
    }

    fn hear(&mut self, now: Instant, byte: u8, parity_ok: bool) -> Heard {
        hear(self, now, byte, parity_ok)
    }

    fn power_cycle(&mut self, now: Instant, off: Duration) {
        LustModel::power_cycle(self, now, off);
    }

    fn state(&self) -> ResolvedSet {
        self.core_ref().state()
    }

    /// An ENQUIRY of `key`'s value is answered `ADR NAK`, with the bits
    /// of [`ReadRefusal::NakSiof`] latched in SIOF/SERR (LUSTBUS 9.2).
    fn refuse_read(&mut self, key: CodeKey, answer: ReadRefusal) -> Result<(), String> {
        let core = self.core();
        let bits = match answer {
            ReadRefusal::Nak => None,
            ReadRefusal::NakSiof(b) => Some(Siof::from_bits_retain(b)),
            other => {
                return Err(format!(
                    "{}: a LUSTBUS drive refuses an ENQUIRY with NAK only, not `{}`",
                    key.number,
                    other.text()
                ));
            }
        };
        if key.subcode.is_some() || core.param(key.number).is_none() {
            return Err(format!(
                "{}: no such parameter on a {}",
                key.number,
                M::FAMILY
            ));
        }
        core.refused_reads.insert(key.number, bits);
        Ok(())
    }

    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        let (word, bit) = M::RUN_BIT;
        let core = self.core();
        core.poke(key, raw)?;
        if key == CodeKey::new(word) {
            core.running = core.int(word).is_some_and(|v| v & bit != 0);
        }
        Ok(())
    }

    fn running(&self) -> bool {
        self.core_ref().running
    }

    fn set_running(&mut self, running: bool) {
        let (word, bit) = M::RUN_BIT;
        let core = self.core();
        core.running = running;
        let w = core.int(word).unwrap_or(0);
        core.set(CodeKey::new(word), if running { w | bit } else { w & !bit });
    }

    fn take_baud_change(&mut self) -> Option<u32> {
        // The MC activates a new baud rate at 4-PROG = 111 (section 11.5);
        // both families at a restart (power cycle, STAT / error reset).
        self.core().baud_change.take()
    }

    fn active_rate(&self) -> Option<u32> {
        // only a rate 81 does not say (activated online, 81 changed since)
        let core = self.core_ref();
        if core.active_baud == core.int(BAUD) {
            return None;
        }
        core.active_baud.and_then(|b| u32::try_from(b).ok())
    }

    fn restore_rate(&mut self, baud: u32) {
        let core = self.core();
        if core.active_baud != Some(i64::from(baud)) {
            core.active_baud = Some(i64::from(baud));
            core.baud_change = Some(baud);
        }
    }
}
