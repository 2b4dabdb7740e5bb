//! Simulated Lenze ECS servo axis on the system bus (CAN): an SDO server.
//!
//! Source of truth: `lenze-system-bus-can-sdo.txt` (ECS manual EDBCSXA064
//! EN 3.2, page 454) and, for what that page leaves out, CiA DS301 V4.02 as
//! `docs/errata/can.md` records it. Everything protocol-side is the codec's
//! ([`driveset_proto::can`]): this module only decides what the drive
//! holds and which abort a request earns.
//!
//! - **COB-IDs** (not on page 454): DS301 predefined connection set,
//!   requests on `0x600 + node`, responses on `0x580 + node`
//!   ([`NodeId::request_cob_id`], [`NodeId::response_cob_id`]). Every other
//!   frame (other ids, extended ids, remote frames) is ignored.
//! - **Addressing** (page 454): `Index = 24575 - code`
//!   ([`CodeNumber::from_index`]). Codes without subcodes answer on
//!   subindex 0 only; subcode `n` is subindex `n` (an assumption, see the
//!   errata). Subindex 0 of a code that has subcodes is not a Lenze
//!   address and aborts like any other missing subindex.
//! - **Values** (page 454 note): FIX32 codes travel as the signed raw
//!   integer (value x 10000), C0135 / C0150 (`BITCODED` in the schema)
//!   as an unsigned 32-bit field without factor, both 4 bytes
//!   little-endian (expedited, read response `0x43`). The schema's type
//!   decides per code; a code without a type takes the page 454 default
//!   ([`CodeNumber::value_format`]). A write must carry exactly 4 bytes:
//!   page 454 gives no other width for these formats.
//! - **Aborts** (page 454: "error codes are standardised acc. to DS301,
//!   V4.02"; which code for which refusal is our choice, as DS301 lists
//!   them):
//!   - index above 0x5FFF or no such code: 0x06020000;
//!   - code exists, subindex does not: 0x06090011;
//!   - write to a read-only code: 0x06010002 (checked before the length);
//!   - write of other than 4 bytes (expedited or segmented): 0x06070010;
//!   - value above the schema's max: 0x06090031; below min: 0x06090032
//!     (more precise than the general 0x06090030, which DS301 also
//!     allows); an integer that is not one of a code's enumerated values:
//!     0x06090030;
//!   - protocol errors (bad command byte, toggle bit, segment sizes) are
//!     the codec's [`SdoServer`] aborts (0x05040001, 0x05030000, ...).
//! - **Segmented transfers** run through [`SdoServer`]; every ECS value is
//!   4 bytes, so an upload is always expedited; a segmented download of
//!   exactly 4 bytes is taken like an expedited one, any other length ends
//!   in 0x06070010 after its last segment.
//! - **Power cycle**: the drive answers nothing while it is off; the SDO
//!   server's transfer state is lost. What the parameter values do is the
//!   table's schema's `[schema.store]` (docs/file-formats.md): `on-command`
//!   (the FICTIONAL demo fixture, CiA 301 0x1010 sub 1 "save"): they come
//!   back as last stored; a write of the store code with its value copies
//!   what the drive holds into what it has stored (any other value aborts
//!   0x08000020, a read gives 1: "saves on command"); a schema whose store
//!   step is polled (`done`, a Lenze device command) reads the command's
//!   value back while the store runs ([`STORE_RUNS`], FICTIONAL) and `done`
//!   once it has stored, and a power cycle before then loses it; `every-write` and
//!   `unknown` (the excerpt says nothing of storage): they are kept, but a
//!   device from a data sheet without 0x1010 ([`crate::eds`]) keeps
//!   nothing written. A code the table marks as non-persistent (a RAM
//!   actual / control value) goes back to its factory value.
//! - **Objects kept by index** (`[[code]] index`, CiA 301 objects and the
//!   manufacturer objects of another vendor's data sheet): addressed by
//!   their own index and subindex, their CiA 301 integer types little-endian
//!   at their own width. No DS301 boot-up message is sent (the
//!   [`FrameDrive`] contract has no unsolicited frames, and page 454 does
//!   not mention one).
//! - **Reaction time**: the excerpt gives no figure; the default is the
//!   FICTIONAL reaction of the family descriptor (`ReactionTime::of`), drawn per answer from the
//!   drive's seeded [`SimRng`], configurable with
//!   [`EcsDrive::with_reaction`].

use std::collections::BTreeMap;
use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::can::{
    AbortCode, CanFrame, CodeNumber, Index, NodeId, ObjectDictionary, SdoServer, Subindex,
    ValueFormat,
};
use driveset_schema::ValueType;
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use driveset_schema::value::Repr;

use crate::catalog::{self, Family};
use crate::drive::{FrameDrive, FrameReply, ReactionTime, ReadRefusal};
use crate::rng::SimRng;
use crate::table::{Param, ParamTable, Refusal};

/// How a code's value travels in the SDO data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wire {
    /// Page 454 formats, 4 bytes little-endian.
    Lenze(ValueFormat),
    /// A text code (`VS`): its UTF-8 bytes (segmented when over 4 bytes).
    Text,
    /// An octet code (`VO`): the bytes themselves.
    Octets,
    /// A CiA 301 basic integer type of an object kept by index
    /// (UNSIGNED8/16/32, INTEGER8/16/32), little-endian, its own width.
    Int { bytes: usize, signed: bool },
}

fn wire_of(p: &Param, code: CodeNumber) -> Wire {
    cia_wire(p).unwrap_or_else(|| match p.ty {
        Some(ValueType::FIX32) => Wire::Lenze(ValueFormat::Fix32),
        Some(ValueType::BITCODED) => Wire::Lenze(ValueFormat::BitCoded),
        Some(ValueType::VS) => Wire::Text,
        Some(ValueType::VO) => Wire::Octets,
        _ => Wire::Lenze(code.value_format()),
    })
}

/// The wire of a code by its CiA 301 type, if it has one.
fn cia_wire(p: &Param) -> Option<Wire> {
    let (bytes, signed) = match p.ty? {
        ValueType::UNSIGNED8 => (1, false),
        ValueType::UNSIGNED16 => (2, false),
        ValueType::UNSIGNED32 => (4, false),
        ValueType::INTEGER8 => (1, true),
        ValueType::INTEGER16 => (2, true),
        ValueType::INTEGER32 => (4, true),
        _ => return None,
    };
    Some(Wire::Int { bytes, signed })
}

/// The wire of an object kept by index (`[[code]] index`): its CiA type,
/// text or octets; FIX32 / BITCODED as the Lenze formats.
fn indexed_wire(p: &Param) -> Wire {
    cia_wire(p).unwrap_or(match p.ty {
        Some(ValueType::VS) => Wire::Text,
        Some(ValueType::VO) => Wire::Octets,
        Some(ValueType::BITCODED) => Wire::Lenze(ValueFormat::BitCoded),
        _ => Wire::Lenze(ValueFormat::Fix32),
    })
}

/// Whether `raw` fits an integer wire of `bytes` (signed or not).
fn int_fits(bytes: usize, signed: bool, raw: i64) -> bool {
    let bits = 8 * bytes as u32;
    let (lo, hi) = if signed {
        (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
    } else {
        (0, (1i64 << bits) - 1)
    };
    (lo..=hi).contains(&raw)
}

/// The raw integer range a 4-byte Lenze format can carry.
fn fits(format: ValueFormat, raw: i64) -> bool {
    match format {
        ValueFormat::Fix32 => i32::try_from(raw).is_ok(),
        ValueFormat::BitCoded => u32::try_from(raw).is_ok(),
    }
}

/// The drive's values as the codec's [`SdoServer`] sees them.
struct Dictionary<'a> {
    table: &'a ParamTable,
    values: &'a mut BTreeMap<CodeKey, RawValue>,
    refused_reads: &'a BTreeMap<CodeKey, AbortCode>,
    hidden: &'a std::collections::BTreeSet<CodeKey>,
    /// Objects kept by index (`[[code]] index`), by index and subindex.
    by_index: &'a BTreeMap<(u16, u8), CodeKey>,
    /// How the drive keeps writes ([`Storing`]); set when the store
    /// command was written.
    storing: &'a mut Storing,
    /// Out-of-range writes abort with the general 0x06090030 (a device
    /// from its data sheet) rather than 0x06090031 / 0x06090032.
    general_range_abort: bool,
}

/// How long a store whose schema says when it is done (`[schema.store]
/// done`, a device command whose progress is read back) runs after its
/// acknowledgement. FICTIONAL: no document at hand gives an ECS figure (the
/// Lenze 8400 manual's device commands take "usually 2.5 s"); a third of a
/// second keeps tests quick and is still several polls. A CiA 301 0x1010
/// store is done when acknowledged.
pub const STORE_RUNS: Duration = Duration::from_millis(300);

/// What a drive keeps over a power cycle (`[schema.store]` of its table's
/// schema).
#[derive(Debug, Clone, PartialEq, Eq)]
enum Storing {
    /// Every write is kept (`every-write`, and `unknown`: the simulator
    /// keeps what it is not told it loses).
    Kept,
    /// Nothing written is kept: a power cycle brings the factory values
    /// back (a device from a data sheet that declares no way to store,
    /// [`EcsDrive::with_volatile_writes`]).
    Volatile,
    /// Writes stay in RAM until the store command (`on-command`): what
    /// was stored last, and whether a store was just asked for.
    OnCommand {
        code: u32,
        value: i64,
        stored: BTreeMap<CodeKey, RawValue>,
        asked: bool,
        /// What the store code reads once stored (`[schema.store] done`):
        /// the store then runs [`STORE_RUNS`] after its acknowledgement.
        done: Option<i64>,
        /// A store running until the instant, with the values it stores.
        running: Option<(Instant, BTreeMap<CodeKey, RawValue>)>,
    },
}

impl Storing {
    /// A running store that has finished by `now` becomes what is stored.
    fn settle(&mut self, now: Instant) {
        if let Storing::OnCommand {
            stored, running, ..
        } = self
            && running.as_ref().is_some_and(|(until, _)| now >= *until)
            && let Some((_, values)) = running.take()
        {
            *stored = values;
        }
    }
}

impl Dictionary<'_> {
    /// The parameter at `index`/`subindex`, with its wire format.
    fn param(&self, index: Index, subindex: Subindex) -> Result<(&Param, Wire), AbortCode> {
        if let Some(p) = self
            .by_index
            .get(&(index.0, subindex.0))
            .filter(|k| !self.hidden.contains(*k))
            .and_then(|k| self.table.get(*k))
        {
            return Ok((p, indexed_wire(p)));
        }
        if self
            .by_index
            .iter()
            .any(|((i, _), k)| *i == index.0 && !self.hidden.contains(k))
        {
            return Err(AbortCode::NO_SUCH_SUBINDEX);
        }
        let code = CodeNumber::from_index(index).map_err(|_| AbortCode::NO_SUCH_OBJECT)?;
        let number = u32::from(code.get());
        let key = match subindex.0 {
            0 => CodeKey::new(number),
            s => CodeKey::sub(number, u32::from(s)),
        };
        let seen = |k: &CodeKey| !self.hidden.contains(k);
        if let Some(p) = self.table.get(key).filter(|_| seen(&key)) {
            return Ok((p, wire_of(p, code)));
        }
        if self
            .table
            .iter()
            .any(|p| p.key.number == number && seen(&p.key))
        {
            Err(AbortCode::NO_SUCH_SUBINDEX)
        } else {
            Err(AbortCode::NO_SUCH_OBJECT)
        }
    }
}

impl ObjectDictionary for Dictionary<'_> {
    fn read(&mut self, index: Index, subindex: Subindex) -> Result<Vec<u8>, AbortCode> {
        let (p, wire) = self.param(index, subindex)?;
        if let Some(abort) = self.refused_reads.get(&p.key) {
            return Err(*abort);
        }
        let progress;
        let value = match &*self.storing {
            Storing::OnCommand {
                code,
                value,
                done,
                running,
                ..
            } if p.key.number == *code => match done {
                // CiA 301 0x1010: a read gives the storage functionality,
                // bit 0 "saves parameters on command"
                None => return Ok(1u32.to_le_bytes().to_vec()),
                // a device command: its value while it runs, then `done`
                Some(done) => {
                    progress = RawValue::Int(if running.is_some() { *value } else { *done });
                    &progress
                }
            },
            _ => self.values.get(&p.key).unwrap_or(&p.factory),
        };
        match (wire, value) {
            (Wire::Int { bytes, .. }, RawValue::Int(v)) => Ok(v.to_le_bytes()[..bytes].to_vec()),
            (Wire::Lenze(ValueFormat::Fix32), RawValue::Int(v)) => i32::try_from(*v)
                .map(|v| v.to_le_bytes().to_vec())
                .map_err(|_| AbortCode::GENERAL_ERROR),
            (Wire::Lenze(ValueFormat::BitCoded), RawValue::Int(v)) => u32::try_from(*v)
                .map(|v| v.to_le_bytes().to_vec())
                .map_err(|_| AbortCode::GENERAL_ERROR),
            (Wire::Text, RawValue::Text(t)) => Ok(t.as_bytes().to_vec()),
            (Wire::Octets, RawValue::Octets(o)) => Ok(o.clone()),
            // A stored value of the wrong shape cannot arise through SDO or
            // `poke`; report it rather than invent bytes.
            _ => Err(AbortCode::GENERAL_ERROR),
        }
    }

    fn write(&mut self, index: Index, subindex: Subindex, data: &[u8]) -> Result<(), AbortCode> {
        let (p, wire) = self.param(index, subindex)?;
        if !p.writable() {
            return Err(AbortCode::READ_ONLY);
        }
        let raw = match wire {
            Wire::Int { bytes, signed } => {
                if data.len() != bytes {
                    return Err(AbortCode::LENGTH_MISMATCH);
                }
                let negative = signed && data.last().is_some_and(|b| b & 0x80 != 0);
                let mut b = if negative { [0xFF; 8] } else { [0; 8] };
                b[..bytes].copy_from_slice(data);
                RawValue::Int(i64::from_le_bytes(b))
            }
            Wire::Lenze(format) => {
                let bytes: [u8; 4] = data.try_into().map_err(|_| AbortCode::LENGTH_MISMATCH)?;
                RawValue::Int(match format {
                    ValueFormat::Fix32 => i64::from(i32::from_le_bytes(bytes)),
                    ValueFormat::BitCoded => i64::from(u32::from_le_bytes(bytes)),
                })
            }
            Wire::Text => RawValue::Text(
                String::from_utf8(data.to_vec()).map_err(|_| AbortCode::LENGTH_MISMATCH)?,
            ),
            Wire::Octets => RawValue::Octets(data.to_vec()),
        };
        let key = p.key;
        if let Storing::OnCommand {
            code, value, asked, ..
        } = self.storing
            && key.number == *code
        {
            // CiA 301 0x1010: only the signature stores; the write is
            // acknowledged once stored (the caller copies the values)
            if raw != RawValue::Int(*value) {
                return Err(AbortCode::CANNOT_STORE);
            }
            *asked = true;
            return Ok(());
        }
        check_value(self.table, key, &raw).map_err(|a| {
            let range = [AbortCode::VALUE_TOO_HIGH, AbortCode::VALUE_TOO_LOW];
            if self.general_range_abort && range.contains(&a) {
                AbortCode::VALUE_RANGE_EXCEEDED
            } else {
                a
            }
        })?;
        self.values.insert(key, raw);
        Ok(())
    }
}

/// The table's write checks plus enumerations, as DS301 abort codes.
fn check_value(table: &ParamTable, key: CodeKey, raw: &RawValue) -> Result<(), AbortCode> {
    let p = table.check_write(key, raw).map_err(|r| match r {
        Refusal::NoSuchCode => AbortCode::NO_SUCH_OBJECT,
        Refusal::ReadOnly => AbortCode::READ_ONLY,
        Refusal::OutOfRange { raw, max, .. } if raw > max => AbortCode::VALUE_TOO_HIGH,
        Refusal::OutOfRange { .. } => AbortCode::VALUE_TOO_LOW,
        Refusal::WrongType => AbortCode::LENGTH_MISMATCH,
        Refusal::NotNow => AbortCode::DEVICE_STATE,
    })?;
    if let RawValue::Int(v) = raw
        && !p.enum_values.is_empty()
        && !enum_member(p, *v)
    {
        return Err(AbortCode::VALUE_RANGE_EXCEEDED);
    }
    Ok(())
}

/// Whether raw `v` is one of the code's enumerated values. Schema enum keys
/// are engineering integers: for a scaled type (FIX32) the raw value is the
/// key times the factor.
fn enum_member(p: &Param, v: i64) -> bool {
    match p.ty.map(ValueType::repr) {
        Some(Repr::Scaled(f)) if f > 1 => {
            let f = i64::from(f);
            v % f == 0 && p.enum_values.contains(&(v / f))
        }
        _ => p.enum_values.contains(&v),
    }
}

/// A simulated Lenze ECS servo axis: an SDO server at one node id.
#[derive(Debug, Clone)]
pub struct EcsDrive {
    node: NodeId,
    table: ParamTable,
    values: BTreeMap<CodeKey, RawValue>,
    server: SdoServer,
    rng: SimRng,
    reaction: ReactionTime,
    /// Answers nothing before this instant (power cut).
    off_until: Option<Instant>,
    /// Codes whose SDO upload is aborted with this code although the
    /// table holds them ([`FrameDrive::refuse_read`]).
    refused_reads: BTreeMap<CodeKey, AbortCode>,
    /// Objects kept by index, by index and subindex.
    by_index: BTreeMap<(u16, u8), CodeKey>,
    /// What the drive keeps over a power cycle.
    storing: Storing,
    /// A device from its data sheet: out of range is 0x06090030.
    general_range_abort: bool,
    /// Codes answered as objects the node does not have
    /// ([`FrameDrive::forget`]); the model keeps their values for itself.
    hidden: std::collections::BTreeSet<CodeKey>,
}

impl EcsDrive {
    /// A drive at `node` with the simulator's ECS table
    /// ([`Family::Ecs`]: `schemas/lenze-ecs.toml` extended by the FICTIONAL
    /// `parameter-sets/fixtures/fictional-ecs-demo.toml`), every code at its
    /// factory value, reaction from the family descriptor, random choices
    /// from `seed`.
    pub fn new(node: NodeId, seed: u64) -> Result<Self, String> {
        let table = ParamTable::from_schema(catalog::schema(Family::Ecs)?)?;
        Ok(Self::with_table(node, table, seed))
    }

    /// A drive with a table of its own (tests, other fixture schemas).
    pub fn with_table(node: NodeId, table: ParamTable, seed: u64) -> Self {
        let values = table.factory_state();
        let schema = table.schema().clone();
        let mut by_index = BTreeMap::new();
        for p in table.iter() {
            let Some(code) = schema.code(p.key.number) else {
                continue;
            };
            if let Some(index) = code.index {
                let sub = code
                    .subindex
                    .or_else(|| p.key.subcode.and_then(|s| u8::try_from(s).ok()))
                    .unwrap_or(0);
                by_index.insert((index, sub), p.key);
            }
        }
        let storing = match schema.store.command() {
            Some(c) => Storing::OnCommand {
                code: c.code,
                value: c.value,
                stored: values.clone(),
                asked: false,
                done: c.done,
                running: None,
            },
            None => Storing::Kept,
        };
        EcsDrive {
            node,
            table,
            values,
            server: SdoServer::new(),
            rng: SimRng::derive(seed, u64::from(node.get())),
            reaction: ReactionTime::of(
                driveset_schema::Family::Ecs,
                driveset_schema::family::Keypad::Absent,
            ),
            off_until: None,
            refused_reads: BTreeMap::new(),
            by_index,
            storing,
            general_range_abort: false,
            hidden: std::collections::BTreeSet::new(),
        }
    }

    /// The same drive answering an out-of-range write with the general
    /// DS301 abort 0x06090030 (a device simulated from its data sheet,
    /// which gives limits but not which abort).
    pub fn with_general_range_abort(mut self) -> Self {
        self.general_range_abort = true;
        self
    }

    /// The same drive keeping nothing written over a power cycle (a data
    /// sheet that declares no store parameters object: what the device
    /// keeps is not known, and the simulator shows the worst case its
    /// upload report names, "not stored: lost at power off"). A drive that
    /// stores on command keeps its store step.
    pub fn with_volatile_writes(mut self) -> Self {
        if self.storing == Storing::Kept {
            self.storing = Storing::Volatile;
        }
        self
    }

    /// What the drive has stored, where it keeps writes only on command
    /// (`[schema.store] keeps = "on-command"`); `None` where every write
    /// is kept.
    pub fn stored(&self) -> Option<ResolvedSet> {
        match &self.storing {
            Storing::OnCommand { stored, .. } => Some(self.table.resolved(stored)),
            Storing::Kept | Storing::Volatile => None,
        }
    }

    /// The same drive with another reaction time (e.g.
    /// [`ReactionTime::fixed`] for exact-timing tests).
    pub fn with_reaction(mut self, reaction: ReactionTime) -> Self {
        self.reaction = reaction;
        self
    }

    /// The node id.
    pub fn node(&self) -> NodeId {
        self.node
    }

    /// The parameter table.
    pub fn table(&self) -> &ParamTable {
        &self.table
    }

    /// The raw value of one code, if the drive has it.
    pub fn value(&self, key: CodeKey) -> Option<&RawValue> {
        self.values.get(&key)
    }

    /// Whether the drive is without power at `now`.
    pub fn is_off(&self, now: Instant) -> bool {
        self.off_until.is_some_and(|t| now < t)
    }
}

impl FrameDrive for EcsDrive {
    fn family(&self) -> &'static str {
        Family::Ecs.name()
    }

    /// An SDO upload of `key` is aborted with the given code (DS301 table
    /// 22), the only refusal an upload has.
    fn refuse_read(&mut self, key: CodeKey, answer: ReadRefusal) -> Result<(), String> {
        let display = self.table.schema().display_code(key.number, key.subcode);
        let ReadRefusal::SdoAbort(code) = answer else {
            return Err(format!(
                "{display}: an ECS node refuses an upload with an SDO abort only, not `{}`",
                answer.text()
            ));
        };
        if self.table.get(key).is_none() {
            return Err(format!("{display}: no such code on an ECS node"));
        }
        self.refused_reads.insert(key, AbortCode(code));
        Ok(())
    }

    /// From now on an upload or download of `key` is aborted as for any
    /// object the node does not have (DS301 table 22).
    fn forget(&mut self, key: CodeKey) -> Result<(), String> {
        if self.table.get(key).is_none() {
            let display = self.table.schema().display_code(key.number, key.subcode);
            return Err(format!("{display}: no such code on an ECS node"));
        }
        self.hidden.insert(key);
        Ok(())
    }

    fn node_id(&self) -> u8 {
        self.node.get()
    }

    /// Answers an SDO request on `0x600 + node` (standard id, data frame)
    /// with the codec's [`SdoServer`]; an undecodable request (wrong length,
    /// unknown command byte) gets the codec's abort 0x05040001, a client
    /// abort gets no answer.
    fn hear(&mut self, now: Instant, frame: &CanFrame) -> Option<FrameReply> {
        if self.is_off(now) {
            return None;
        }
        self.off_until = None;
        self.storing.settle(now);
        if frame.extended || frame.rtr || frame.id != self.node.request_cob_id() {
            return None;
        }
        let mut od = Dictionary {
            table: &self.table,
            values: &mut self.values,
            refused_reads: &self.refused_reads,
            by_index: &self.by_index,
            storing: &mut self.storing,
            general_range_abort: self.general_range_abort,
            hidden: &self.hidden,
        };
        let response = self.server.on_frame_data(frame.payload(), &mut od);
        if let Storing::OnCommand {
            stored,
            asked,
            done,
            running,
            ..
        } = &mut self.storing
            && *asked
        {
            *asked = false;
            match done {
                None => stored.clone_from(&self.values),
                Some(_) => *running = Some((now + STORE_RUNS, self.values.clone())),
            }
        }
        let response = response?;
        Some(FrameReply {
            frame: response.to_can(self.node),
            reaction: self.reaction.draw(&mut self.rng),
        })
    }

    /// Off from `now` for `off`: no answers, a running segmented transfer
    /// is lost, values are kept (see the module docs) or, where the
    /// schema keeps writes only on command, come back as last stored;
    /// non-persistent codes go back to factory values.
    fn power_cycle(&mut self, now: Instant, off: Duration) {
        self.off_until = Some(now + off);
        self.server = SdoServer::new();
        // a store still running when the power goes is lost
        self.storing.settle(now);
        if let Storing::OnCommand { running, .. } = &mut self.storing {
            *running = None;
        }
        match &self.storing {
            Storing::OnCommand { stored, .. } => self.values.clone_from(stored),
            Storing::Volatile => self.values = self.table.factory_state(),
            Storing::Kept => {}
        }
        for p in self.table.iter() {
            if !p.persistent() {
                self.values.insert(p.key, p.factory.clone());
            }
        }
    }

    fn state(&self) -> ResolvedSet {
        self.table.resolved(&self.values)
    }

    fn stored_state(&self) -> Option<ResolvedSet> {
        self.stored()
    }

    /// Every value must be a code of the table.
    fn restore_stored(&mut self, values: BTreeMap<CodeKey, RawValue>) -> Result<(), String> {
        if let Some(k) = values.keys().find(|k| self.table.get(**k).is_none()) {
            return Err(format!("ECS node {}: no code {k:?}", self.node.get()));
        }
        if let Storing::OnCommand { stored, .. } = &mut self.storing {
            *stored = values;
        }
        Ok(())
    }

    /// Sets a value without the protocol. Refused for an unknown code, a
    /// value of the wrong shape, or an integer the code's wire format
    /// cannot carry (FIX32: i32, bit-coded: u32). Range and read-only are
    /// not checked: a test may put any representable value.
    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        let p = self
            .table
            .get(key)
            .ok_or_else(|| format!("ECS node {}: no code {key:?}", self.node.get()))?;
        let wire = match self.table.schema().code(key.number).and_then(|c| c.index) {
            Some(_) => indexed_wire(p),
            None => wire_of(p, CodeNumber::new(key.number).map_err(|e| e.to_string())?),
        };
        let ok = match (wire, &raw) {
            (Wire::Lenze(format), RawValue::Int(v)) => fits(format, *v),
            (Wire::Int { bytes, signed }, RawValue::Int(v)) => int_fits(bytes, signed, *v),
            (Wire::Text, RawValue::Text(_)) | (Wire::Octets, RawValue::Octets(_)) => true,
            _ => false,
        };
        if !ok {
            return Err(format!(
                "ECS node {}: {raw:?} does not fit code {key:?}",
                self.node.get()
            ));
        }
        self.values.insert(key, raw);
        Ok(())
    }

    /// The running bit of the schema's running indicator (FICTIONAL
    /// `fictional-ecs-demo`: C0150 bit 1); the real `lenze-ecs` schema
    /// names none, so such a node never reports running.
    fn running(&self) -> bool {
        let Some(ind) = self.table.schema().running_indicator() else {
            return false;
        };
        matches!(
            self.values.get(&CodeKey::new(ind.code)),
            Some(RawValue::Int(v)) if v >> ind.bit & 1 == 1
        )
    }

    fn set_running(&mut self, running: bool) -> Result<(), String> {
        let ind = self.table.schema().running_indicator().ok_or_else(|| {
            format!(
                "ECS node {}: schema `{}` names no running bit",
                self.node.get(),
                self.table.schema().id
            )
        })?;
        let key = CodeKey::new(ind.code);
        let word = match self.values.get(&key) {
            Some(RawValue::Int(v)) => *v,
            _ => 0,
        };
        let bit = 1i64 << ind.bit;
        self.values.insert(
            key,
            RawValue::Int(if running { word | bit } else { word & !bit }),
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive() -> EcsDrive {
        EcsDrive::new(NodeId::new(1).unwrap(), 7).unwrap()
    }

    #[test]
    fn enum_values_are_engineering_integers_scaled_for_fix32() {
        let d = drive();
        let p = d.table().get(CodeKey::new(5016)).unwrap();
        assert_eq!(p.enum_values, vec![0, 1, 2]);
        assert!(enum_member(p, 20_000));
        assert!(!enum_member(p, 15_000));
        assert!(!enum_member(p, 2));
    }

    /// An expedited 4-byte download of `data` to `index`/`sub`, and the
    /// reply's first data byte and abort code (0 for a confirmation).
    fn download(d: &mut EcsDrive, at: Instant, index: u16, sub: u8, data: [u8; 4]) -> (u8, u32) {
        let [lo, hi] = index.to_le_bytes();
        let q = CanFrame::new(
            0x601,
            &[0x23, lo, hi, sub, data[0], data[1], data[2], data[3]],
        )
        .unwrap();
        let r = d.hear(at, &q).expect("an answer").frame;
        let p = r.payload();
        (p[0], u32::from_le_bytes([p[4], p[5], p[6], p[7]]))
    }

    #[test]
    fn demo_writes_are_lost_at_power_off_until_saved_to_0x1010() {
        let mut d = drive().with_reaction(ReactionTime::fixed(Duration::from_millis(1)));
        let c5001 = CodeKey::new(5001);
        let factory = d.value(c5001).cloned().unwrap();
        let t = Instant::from_nanos(1_000_000);
        // C5001 (index 0x4C76) = 5000 rpm, raw 50_000_000
        assert_eq!(
            download(&mut d, t, 0x4C76, 0, 50_000_000i32.to_le_bytes()),
            (0x60, 0)
        );
        d.power_cycle(t, Duration::from_millis(1));
        assert_eq!(d.value(c5001), Some(&factory), "not stored: lost");
        let t = t + Duration::from_millis(10);
        assert_eq!(
            download(&mut d, t, 0x4C76, 0, 50_000_000i32.to_le_bytes()),
            (0x60, 0)
        );
        // a wrong signature: 0x08000020, nothing stored
        assert_eq!(
            download(&mut d, t, 0x1010, 1, *b"evas"),
            (0x80, 0x0800_0020)
        );
        // "save" (0x65766173, bytes s a v e)
        assert_eq!(download(&mut d, t, 0x1010, 1, *b"save"), (0x60, 0));
        d.power_cycle(t, Duration::from_millis(1));
        assert_eq!(
            d.value(c5001),
            Some(&RawValue::Int(50_000_000)),
            "stored: kept"
        );
        // a read of 0x1010 sub 1: bit 0, "saves on command"
        let t = t + Duration::from_millis(10);
        let q = CanFrame::new(0x601, &[0x40, 0x10, 0x10, 0x01, 0, 0, 0, 0]).unwrap();
        let r = d.hear(t, &q).unwrap().frame;
        assert_eq!(r.payload(), &[0x43, 0x10, 0x10, 0x01, 1, 0, 0, 0]);
    }

    /// The demo drive storing by a device command whose status is read
    /// back (`[schema.store] done`): C5990 = 1 (raw 10000) stores, reads
    /// 10000 while the store runs and 0 once done ([`STORE_RUNS`] after
    /// its acknowledgement); a power cycle before then loses the store.
    #[test]
    fn a_device_command_store_runs_and_a_power_cycle_before_it_is_done_loses_it() {
        let schema = crate::catalog::registry()
            .unwrap()
            .add_source(driveset_schema::error::SourceFile::new(
                "t.toml",
                "[schema]\nid = \"t\"\ntitle = \"t\"\nextends = \"fictional-ecs-demo\"\nfictional = true\n\n[schema.store]\nkeeps = \"on-command\"\ncode = 5990\nvalue = 10000\ndone = 0\n\n[[code]]\nnumber = 5990\nname = \"save\"\ntitle = \"t\"\nspec = \"t\"\ntype = \"FIX32\"\nrole = \"command\"\n".to_string(),
            ))
            .unwrap();
        let table = ParamTable::from_schema(schema).unwrap();
        let mut d = EcsDrive::with_table(NodeId::new(1).unwrap(), table, 7)
            .with_reaction(ReactionTime::fixed(Duration::from_millis(1)));
        let c5001 = CodeKey::new(5001);
        let factory = d.value(c5001).cloned().unwrap();
        let status = |d: &mut EcsDrive, at: Instant| {
            // C5990: index 24575 - 5990 = 0x4899
            let q = CanFrame::new(0x601, &[0x40, 0x99, 0x48, 0, 0, 0, 0, 0]).unwrap();
            let p = d.hear(at, &q).unwrap().frame;
            i32::from_le_bytes([
                p.payload()[4],
                p.payload()[5],
                p.payload()[6],
                p.payload()[7],
            ])
        };
        let t = Instant::from_nanos(1_000_000);
        let speed = 50_000_000i32.to_le_bytes();
        assert_eq!(download(&mut d, t, 0x4C76, 0, speed), (0x60, 0));
        assert_eq!(
            download(&mut d, t, 0x4899, 0, 10_000i32.to_le_bytes()),
            (0x60, 0)
        );
        assert_eq!(
            status(&mut d, t + Duration::from_millis(100)),
            10_000,
            "runs"
        );
        d.power_cycle(t + Duration::from_millis(200), Duration::from_millis(1));
        assert_eq!(d.value(c5001), Some(&factory), "cut before done: lost");

        let t = t + Duration::from_secs(1);
        assert_eq!(download(&mut d, t, 0x4C76, 0, speed), (0x60, 0));
        assert_eq!(
            download(&mut d, t, 0x4899, 0, 10_000i32.to_le_bytes()),
            (0x60, 0)
        );
        assert_eq!(status(&mut d, t + STORE_RUNS), 0, "done");
        d.power_cycle(t + STORE_RUNS, Duration::from_millis(1));
        assert_eq!(
            d.value(c5001),
            Some(&RawValue::Int(50_000_000)),
            "stored: kept"
        );
    }

    #[test]
    fn power_cycle_blocks_answers_until_back() {
        let mut d = drive().with_reaction(ReactionTime::fixed(Duration::from_millis(1)));
        let q = CanFrame::new(0x601, &[0x40, 0x88, 0x4A, 0, 0, 0, 0, 0]).unwrap();
        let t0 = Instant::from_nanos(1_000_000);
        d.power_cycle(t0, Duration::from_millis(100));
        assert!(d.hear(t0, &q).is_none());
        assert!(d.hear(t0 + Duration::from_millis(99), &q).is_none());
        assert!(d.hear(t0 + Duration::from_millis(100), &q).is_some());
    }
}
