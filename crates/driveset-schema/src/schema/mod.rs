//! Owns the schema model (docs/file-formats.md, "Schema files"): codes,
//! their types, enumerations, bit fields, roles and rules, identification
//! and what a learned schema was learned from. Its rooms:
//!
//! - this file: the model's types;
//! - `numbers`: code numbers, number lists and integer text;
//! - `lookup`: finding codes by number or name and spelling them for
//!   humans;
//! - `reader`: reading a document's tables with locations (unknown keys,
//!   wrong types are findings with where and what to do);
//! - `parse`: one `[[code]]`, `[[rule]]` or enumeration table;
//! - `load`: a whole schema file, its `extends` and its fingerprint;
//! - `extends`: filling a base's unset facts from a fixture schema;
//! - `floor`: the roles the family's specs give, applied to every schema;
//! - `registry`: the [`Registry`] of built-in and loaded schemas;
//! - `store`: `[schema.store]`, how the drives keep what is written.

mod extends;
mod floor;
mod load;
mod lookup;
mod numbers;
mod parse;
mod reader;
mod registry;
mod store;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use crate::canonical::RawValue;
use crate::doc::NodeKind;
use crate::error::{Finding, Location};
use crate::family::Family;
use crate::role::{BitRole, Role};
use crate::value::ValueType;

pub use load::{parse_schema, schema_fingerprint};
pub use numbers::{
    CIA_NUMBER_BASE, SUBINDEX_NUMBER_BASE, index_number, number_list_text, parse_number_list,
};
pub(crate) use numbers::{looks_numeric_key, parse_int_text};
pub use registry::{BUILTIN_FILES, NamedSchemaError, Registry};
pub use store::{
    DEFAULT_STORE_POLL, DEFAULT_STORE_TIMEOUT, Keeping, Store, StoreCommand, ram_note,
};

/// How codes are spelled (`[schema] code_style`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum CodeStyle {
    /// `C0011`, `C0039/1`.
    Lenze,
    /// `428`, shown as `428-RSIO`.
    Lust,
}

/// Access right of a code (`access`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Access {
    /// Read-write (default).
    #[default]
    Rw,
    /// Read-only: sets cannot give a value.
    Ro,
    /// Writable at standstill only.
    Standstill,
}

/// LUSTBUS storage kind (`kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StorageKind {
    /// RAM actual value.
    RamActual,
    /// RAM control value.
    RamControl,
    /// EEPROM.
    Eeprom,
    /// FSEL/ISEL variable.
    FselIsel,
}

/// A schema fact given as an engineering value (`min`, `max`, `default`).
#[derive(Debug, Clone, PartialEq)]
pub struct Fact {
    /// The value node as written (string or number).
    pub value: NodeKind,
    /// Where.
    pub loc: Location,
}

/// An enumeration: raw value -> label.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EnumDef {
    /// Entries in source order: raw value, label, location of the entry.
    pub entries: Vec<(i64, String, Location)>,
    /// Where the table is.
    pub loc: Option<Location>,
}

impl EnumDef {
    /// Label of a raw value.
    pub fn label(&self, raw: i64) -> Option<&str> {
        self.entries
            .iter()
            .find(|(v, _, _)| *v == raw)
            .map(|(_, l, _)| l.as_str())
    }
    /// Raw value of a label, compared case-insensitively and trimmed.
    pub fn value_of(&self, label: &str) -> Option<i64> {
        let l = label.trim();
        self.entries
            .iter()
            .find(|(_, lab, _)| lab.trim().eq_ignore_ascii_case(l))
            .map(|(v, _, _)| *v)
    }
    /// All labels, for messages.
    pub fn labels(&self) -> Vec<&str> {
        self.entries.iter().map(|(_, l, _)| l.as_str()).collect()
    }
}

/// Labels of a code or bit field: inline or a shared `[enum.X]`.
#[derive(Debug, Clone, PartialEq)]
pub enum EnumSource {
    /// `[code.values]` inline.
    Inline(EnumDef),
    /// `values_ref = "X"`.
    Ref {
        /// The enum name.
        name: String,
        /// Where the reference is.
        loc: Location,
    },
}

/// A bit-field member (`[[code.bits]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct BitField {
    /// Member name used in sets.
    pub name: String,
    /// Title.
    pub title: Option<String>,
    /// Least significant bit.
    pub lsb: u32,
    /// Most significant bit (inclusive).
    pub msb: u32,
    /// Optional labels.
    pub values: Option<EnumSource>,
    /// Where the member is.
    pub loc: Location,
    /// Where `bits` is.
    pub bits_loc: Location,
    /// What the member does in a control or status word (`role`).
    pub role: Option<BitRole>,
    /// Where `role` is written.
    pub role_loc: Option<Location>,
}

impl BitField {
    /// Number of bits.
    pub fn width(&self) -> u32 {
        self.msb.saturating_sub(self.lsb).saturating_add(1)
    }
    /// Extract the member's value from a raw word.
    pub fn extract(&self, raw: i64) -> i64 {
        let w = self.width().min(62);
        if self.lsb >= 63 {
            return 0;
        }
        (raw >> self.lsb) & ((1i64 << w) - 1)
    }
}

/// One code of a schema (`[[code]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Code {
    /// Code number.
    pub number: u32,
    /// Short name used in sets (empty when the file gives none: `schema check` reports it).
    pub name: String,
    /// Other accepted names.
    pub aliases: Vec<(String, Location)>,
    /// Title as the spec words it.
    pub title: Option<String>,
    /// Where the facts come from.
    pub spec: Option<String>,
    /// `type` as written, with location (may be an unknown name).
    pub type_name: Option<(String, Location)>,
    /// Unit.
    pub unit: Option<String>,
    /// Other unit spellings.
    pub unit_aliases: Vec<String>,
    /// Minimum (engineering).
    pub min: Option<Fact>,
    /// Maximum (engineering).
    pub max: Option<Fact>,
    /// Factory default (engineering).
    pub default: Option<Fact>,
    /// Access right.
    pub access: Option<Access>,
    /// Tmd: LECOM access only.
    pub lecom_only: Option<bool>,
    /// Subcodes 1..=n.
    pub subcodes: Option<u32>,
    /// CAN: a CiA 301 object kept by its own SDO index (outside the Lenze
    /// code range, e.g. 0x1017 or 0x6040); its number is
    /// [`CIA_NUMBER_BASE`] + index and its subcodes are subindexes.
    pub index: Option<u16>,
    /// CAN: the one subindex of `index` this code is (`subindex = 1`): a
    /// RECORD / ARRAY entry with facts of its own (an imported 0x1018sub1).
    /// Its number is [`SUBINDEX_NUMBER_BASE`] + index x 256 + subindex; it
    /// has no subcodes.
    pub subindex: Option<u8>,
    /// CAN: the CiA 301 data type number the device's data sheet gives
    /// (`data_type = 0x0007`), where the schema type alone does not say it
    /// (an UNSIGNED32 Lenze code read as FIX32); `show --to dcf` writes it.
    pub data_type: Option<u16>,
    /// Free text.
    pub note: Option<String>,
    /// LUSTBUS storage kind.
    pub kind: Option<StorageKind>,
    /// VF1000 basis parameter.
    pub basis: Option<bool>,
    /// Byte width.
    pub width: Option<u8>,
    /// MC: CardWriteable.
    pub card_writeable: Option<bool>,
    /// What the code is for where it is not an ordinary setting
    /// (`role`, or [`Role::Identify`] for `[schema.identify] codes`); see
    /// [`crate::role`].
    pub role: Option<Role>,
    /// Where `role` is written.
    pub role_loc: Option<Location>,
    /// Control word without bit roles: the values that keep the drive
    /// stopped / inhibited (`stopped = [0]`, Tmd C0040 0 = controller
    /// inhibited).
    pub stopped: Vec<i64>,
    /// Reading clears the code.
    pub read_clears: Option<bool>,
    /// Numerically compatible parameter (LUSTBUS 5.2).
    pub compatible: Option<bool>,
    /// Enumeration labels.
    pub values: Option<EnumSource>,
    /// The enumeration lists only some of the values the code takes (the
    /// spec names a few, e.g. LUSTBUS 84-SIOT 0 = watchdog off): other
    /// values in range are allowed. Without it an enumeration is complete
    /// and a value it does not list is a finding.
    pub values_partial: Option<bool>,
    /// Bit-field members.
    pub bits: Vec<BitField>,
    /// Where the `[[code]]` entry is (its `number`).
    pub loc: Location,
    /// Where `name` is.
    pub name_loc: Option<Location>,
    /// `type_name` resolved (set by the schema's index; `None` for an unknown name).
    pub(crate) resolved_type: Option<ValueType>,
    /// min/max as raw values, computed on first use.
    pub(crate) bounds: std::sync::OnceLock<(Option<RawValue>, Option<RawValue>)>,
}

/// A cross-code rule (`[[rule]]`).
#[derive(Debug, Clone, PartialEq)]
pub enum Rule {
    /// The named bit-field members of `code` must all differ.
    DistinctFields {
        /// Code number.
        code: u32,
        /// Member names.
        fields: Vec<String>,
        /// Message from the schema.
        message: String,
        /// Where the rule is.
        loc: Location,
    },
    /// value(left) <= value(right).
    LessOrEqual {
        /// Left code.
        left: u32,
        /// Right code.
        right: u32,
        /// Message from the schema.
        message: String,
        /// Where the rule is.
        loc: Location,
    },
}

/// `[schema.identify]`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Identify {
    /// Codes read to identify the drive.
    pub codes: Vec<u32>,
    /// LUSTBUS 91-TYPE values.
    pub type_values: Vec<i64>,
    /// Free text.
    pub note: Option<String>,
}

/// A drive family's schema.
#[derive(Debug, Clone, PartialEq)]
pub struct Schema {
    /// Id sets name.
    pub id: String,
    /// Title.
    pub title: String,
    /// The drive family (`[schema] protocol`): its descriptor holds the
    /// protocol, timing and handshake facts.
    pub family: Family,
    /// Code spelling.
    pub code_style: CodeStyle,
    /// Source document.
    pub spec: Option<String>,
    /// Type of codes that give none.
    pub default_type: Option<ValueType>,
    /// Identification.
    pub identify: Option<Identify>,
    /// CAN: SDO index = index_base - code number.
    pub can_index_base: Option<u32>,
    /// `[schema.store]`: how the drives keep what is written over a power
    /// cycle (inherited from the base; `unknown` without one).
    pub store: Store,
    /// Fixture schema.
    pub fictional: bool,
    /// Base schema id of a fixture.
    pub extends: Option<String>,
    /// Codes in file order (base schema's first).
    pub codes: Vec<Code>,
    /// Shared enumerations.
    pub enums: BTreeMap<String, EnumDef>,
    /// Cross-code rules.
    pub rules: Vec<Rule>,
    /// Display path of the file.
    pub path: String,
    /// `sha256:` + hex of the file's text, chained over the base's
    /// fingerprint for a schema that `extends` one
    /// ([`schema_fingerprint`]): a journal records it so that `recover`
    /// converts with the very schema the upload used.
    pub fingerprint: String,
    /// Where `[schema] id` is.
    pub id_loc: Location,
    /// Where `fictional` is, or the `[schema]` table.
    pub fictional_loc: Location,
    /// Problems found while merging a fixture over its base (reported by `check_schema`).
    pub merge_findings: Vec<Finding>,
    /// `[schema.learned]`: the file was learned from a drive's own
    /// descriptions (this file's own table; an extending file does not
    /// inherit it).
    pub learned: Option<LearnedFrom>,
    by_number: BTreeMap<u32, usize>,
    by_name: crate::fnv::FnvMap<String, usize>,
    numeric_names: bool,
}

/// `[schema.learned]` of a schema file learned from a drive's own
/// parameter descriptions (docs/file-formats.md, "Learned schema files").
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LearnedFrom {
    /// The parameters whose descriptions were asked for (`asked`): a
    /// command learns again only for parameters outside this.
    pub asked: BTreeSet<u32>,
    /// The file's own text (a schema learned on top of this one extends
    /// the same base and carries these entries).
    pub text: Arc<str>,
}
