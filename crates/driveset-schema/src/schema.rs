//! Owns the schema model (docs/file-formats.md, "Schema files"), its loading
//! from TOML with locations, fixture-schema `extends`, and the [`Registry`]
//! of built-in and loaded schemas.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::canonical::RawValue;
use crate::doc::{self, Document, Entry, Node, NodeKind, Syntax};
use crate::error::{
    Finding, FindingKind, InputError, InputErrorKind, Location, SourceFile, read_text_file,
};
use crate::family::Family;
use crate::role::{BitRole, Role};
use crate::value::ValueType;

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

/// Parses a list of parameter numbers and ranges, `1-99` or
/// `1,5,100-120`, into the numbers (the form of `--params` and of
/// `[schema.learned] asked`).
pub fn parse_number_list(text: &str) -> Result<BTreeSet<u32>, String> {
    let mut out = BTreeSet::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (a.trim(), b.trim()),
            None => (part, part),
        };
        let num = |s: &str| {
            s.parse::<u32>()
                .map_err(|_| format!("`{part}` is not a number or a range like 1-99"))
        };
        let (a, b) = (num(a)?, num(b)?);
        if a > b {
            return Err(format!("`{part}`: a range goes up"));
        }
        out.extend(a..=b);
    }
    if out.is_empty() {
        return Err("names no parameter".into());
    }
    Ok(out)
}

/// The shortest [`parse_number_list`] text of `numbers` (`1-99,101`).
pub fn number_list_text(numbers: &BTreeSet<u32>) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut it = numbers.iter().copied().peekable();
    while let Some(a) = it.next() {
        let mut b = a;
        while it.peek() == Some(&(b + 1)) {
            b += 1;
            it.next();
        }
        parts.push(if a == b {
            a.to_string()
        } else {
            format!("{a}-{b}")
        });
    }
    parts.join(",")
}

/// Code numbers of CiA 301 objects kept by index (`[[code]] index`):
/// number = 65536 + index, above every Lenze code (index = 24575 - code).
pub const CIA_NUMBER_BASE: u32 = 0x1_0000;

/// Code numbers of single subindexes kept by index (`[[code]] index` and
/// `subindex`): number = 16777216 + index x 256 + subindex, above every
/// whole object's number.
pub const SUBINDEX_NUMBER_BASE: u32 = 0x100_0000;

/// The code number of an object kept by index: 65536 + index, or with a
/// subindex 16777216 + index x 256 + subindex.
pub fn index_number(index: u16, subindex: Option<u8>) -> u32 {
    match subindex {
        None => CIA_NUMBER_BASE + u32::from(index),
        Some(s) => SUBINDEX_NUMBER_BASE + (u32::from(index) << 8) + u32::from(s),
    }
}

/// `C` + digits or digits only: the shape of a code-number key.
pub(crate) fn looks_numeric_key(key: &str) -> bool {
    let d = key.strip_prefix(['C', 'c']).unwrap_or(key);
    !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit())
}

impl Schema {
    /// Code by number.
    pub fn code(&self, number: u32) -> Option<&Code> {
        self.by_number.get(&number).and_then(|&i| self.codes.get(i))
    }

    /// Like [`Schema::code_by_name`], but skips the hash lookup for keys
    /// shaped like code numbers (`C0011`, `428`) unless some name has that shape.
    pub(crate) fn code_by_name_fast(&self, key: &str) -> Option<&Code> {
        if !self.numeric_names && looks_numeric_key(key) {
            return None;
        }
        self.code_by_name(key)
    }

    /// Code by name or alias (exact).
    pub fn code_by_name(&self, name: &str) -> Option<&Code> {
        self.by_name.get(name).and_then(|&i| self.codes.get(i))
    }

    /// Resolved type of a code: its own known type, or `default_type` when it gives none.
    /// `None` when the type is unknown (or an unknown name).
    pub fn type_of(&self, code: &Code) -> Option<ValueType> {
        match &code.type_name {
            Some(_) => code.resolved_type,
            None => self.default_type,
        }
    }

    /// Labels of an enum source.
    pub fn enum_of<'a>(&'a self, src: &'a EnumSource) -> Option<&'a EnumDef> {
        match src {
            EnumSource::Inline(e) => Some(e),
            EnumSource::Ref { name, .. } => self.enums.get(name),
        }
    }

    /// The single-subindex code (`[[code]] index` + `subindex`) at Lenze
    /// code `number`'s index (`index_base - number`) and `subcode`: what
    /// `C5020/2` names when the schema keeps that subindex as its own code.
    pub fn lenze_subindex_code(&self, number: u32, subcode: u32) -> Option<&Code> {
        let base = self.can_index_base?;
        let index = u16::try_from(base.checked_sub(number)?).ok()?;
        let sub = u8::try_from(subcode).ok()?;
        self.code(index_number(index, Some(sub)))
            .filter(|c| c.index == Some(index) && c.subindex == Some(sub))
    }

    /// Code as spelled for humans: `C0011`, `C0039/1`; lust `428-RSIO` (with name).
    pub fn display_code(&self, number: u32, subcode: Option<u32>) -> String {
        let mut s = match self.code_style {
            CodeStyle::Lenze => match self.code(number).map(|c| (c.index, c.subindex)) {
                Some((Some(i), Some(s))) => format!("0x{i:04X}sub{s}"),
                Some((Some(i), None)) => format!("0x{i:04X}"),
                _ => format!("C{number:04}"),
            },
            CodeStyle::Lust => match self.code(number) {
                Some(c) if !c.name.is_empty() => format!("{number}-{}", c.name),
                _ => number.to_string(),
            },
        };
        if let Some(sc) = subcode {
            s.push_str(&format!("/{sc}"));
        }
        s
    }

    /// A code as humans read it in reports, plans and diffs: the display
    /// code ([`Schema::display_code`]), and on Lenze codes the name after it
    /// (`C0011 nmax`; Lust codes carry their name already: `428-RSIO`). A
    /// schema file's name is shown to people, so control characters are
    /// escaped.
    pub fn code_label(&self, key: crate::canonical::CodeKey) -> String {
        let code = self.display_code(key.number, key.subcode);
        match self.code(key.number) {
            Some(c) if !c.name.is_empty() && self.code_style == CodeStyle::Lenze => {
                format!("{code} {}", crate::error::escape_controls(&c.name))
            }
            _ => code,
        }
    }

    /// Label of a code's raw value. Enumeration keys are engineering integers
    /// (so `1 = "..."` on a VD code means raw 10000; docs/file-formats.md).
    pub fn enum_label<'a>(&'a self, code: &'a Code, raw: i64) -> Option<&'a str> {
        let e = self.enum_of(code.values.as_ref()?)?;
        let factor = self.enum_factor(code);
        if raw % factor != 0 {
            return None;
        }
        e.label(raw / factor)
    }

    /// Raw value of a code's label (case-insensitive).
    pub fn enum_value(&self, code: &Code, label: &str) -> Option<i64> {
        let e = self.enum_of(code.values.as_ref()?)?;
        e.value_of(label)?.checked_mul(self.enum_factor(code))
    }

    fn enum_factor(&self, code: &Code) -> i64 {
        match self.type_of(code).map(ValueType::repr) {
            Some(crate::value::Repr::Scaled(f)) => i64::from(f),
            _ => 1,
        }
    }

    /// Whether a code's values are secrets (`role = "password"` or type
    /// PT_PASSWORD): masked in every output and in the canonical form.
    pub fn is_password(&self, code: &Code) -> bool {
        code.role == Some(Role::Password) || self.type_of(code) == Some(ValueType::PT_PASSWORD)
    }

    /// Convert a schema fact (min/max/default) to a raw value.
    pub fn fact_raw(&self, code: &Code, fact: &Fact) -> Result<RawValue, String> {
        crate::validate::fact_to_raw(self, code, &fact.value)
    }

    fn reindex(&mut self) {
        self.by_number.clear();
        self.by_name.clear();
        for c in &mut self.codes {
            c.resolved_type = c
                .type_name
                .as_ref()
                .and_then(|(n, _)| ValueType::from_name(n));
        }
        if let Some(ident) = &self.identify {
            for c in &mut self.codes {
                if c.role.is_none() && ident.codes.contains(&c.number) {
                    c.role = Some(Role::Identify);
                }
            }
        }
        for (i, c) in self.codes.iter().enumerate() {
            self.by_number.entry(c.number).or_insert(i);
            if !c.name.is_empty() {
                self.by_name.entry(c.name.clone()).or_insert(i);
            }
            for (a, _) in &c.aliases {
                self.by_name.entry(a.clone()).or_insert(i);
            }
        }
        self.numeric_names = self.by_name.keys().any(|k| looks_numeric_key(k));
    }
}

// ---------------------------------------------------------------------------
// Reading nodes with locations

struct Reader<'d> {
    doc: &'d Document,
    entries: &'d [Entry],
    used: Vec<bool>,
    what: String,
    span: std::ops::Range<usize>,
}

impl<'d> Reader<'d> {
    fn new(doc: &'d Document, node: &'d Node, what: impl Into<String>) -> Result<Self, InputError> {
        let what = what.into();
        match &node.kind {
            NodeKind::Table(entries) => Ok(Reader {
                doc,
                entries,
                used: vec![false; entries.len()],
                what,
                span: node.span.clone(),
            }),
            other => Err(doc.error(
                &node.span,
                format!("{what} must be a table, found {}", other.describe()),
                "see docs/file-formats.md, \"Schema files\"",
            )),
        }
    }

    fn loc(&self) -> Location {
        self.doc.loc(&self.span)
    }

    fn take(&mut self, key: &str) -> Option<&'d Entry> {
        let i = self.entries.iter().position(|e| e.key == key)?;
        if let Some(u) = self.used.get_mut(i) {
            *u = true;
        }
        self.entries.get(i)
    }

    fn wrong(&self, e: &Entry, expected: &str) -> InputError {
        self.doc.error(
            &e.value.span,
            format!(
                "`{}` in {} must be {expected}, found {}",
                e.key,
                self.what,
                e.value.kind.describe()
            ),
            format!("write `{}` as {expected}", e.key),
        )
    }

    fn string(&mut self, key: &str) -> Result<Option<(String, Location)>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => match &e.value.kind {
                NodeKind::Str(s) => Ok(Some((s.clone(), self.doc.loc(&e.value.span)))),
                _ => Err(self.wrong(e, "a string")),
            },
        }
    }

    fn required_string(&mut self, key: &str) -> Result<(String, Location), InputError> {
        match self.string(key)? {
            Some(v) => Ok(v),
            None => Err(self.doc.error(
                &self.span,
                format!("{} has no `{key}`", self.what),
                format!("add `{key} = \"...\"` (docs/file-formats.md)"),
            )),
        }
    }

    fn boolean(&mut self, key: &str) -> Result<Option<bool>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => match &e.value.kind {
                NodeKind::Bool(b) => Ok(Some(*b)),
                _ => Err(self.wrong(e, "true or false")),
            },
        }
    }

    fn int_node(&self, e: &Entry) -> Result<i128, InputError> {
        match &e.value.kind {
            NodeKind::Num(t) => parse_int_text(t).ok_or_else(|| self.wrong(e, "an integer")),
            _ => Err(self.wrong(e, "an integer")),
        }
    }

    fn uint<T: TryFrom<i128>>(&mut self, key: &str) -> Result<Option<(T, Location)>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => {
                let v = self.int_node(e)?;
                let loc = self.doc.loc(&e.value.span);
                T::try_from(v).map(|t| Some((t, loc))).map_err(|_| {
                    self.doc.error(
                        &e.value.span,
                        format!("`{}` = {v} is out of range", e.key),
                        "give a small non-negative integer",
                    )
                })
            }
        }
    }

    fn string_list(&mut self, key: &str) -> Result<Vec<(String, Location)>, InputError> {
        match self.take(key) {
            None => Ok(Vec::new()),
            Some(e) => match &e.value.kind {
                NodeKind::Array(items) => items
                    .iter()
                    .map(|n| match &n.kind {
                        NodeKind::Str(s) => Ok((s.clone(), self.doc.loc(&n.span))),
                        _ => Err(self.wrong(e, "an array of strings")),
                    })
                    .collect(),
                _ => Err(self.wrong(e, "an array of strings")),
            },
        }
    }

    fn fact(&mut self, key: &str) -> Result<Option<Fact>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => match &e.value.kind {
                NodeKind::Str(_) | NodeKind::Num(_) => Ok(Some(Fact {
                    value: e.value.kind.clone(),
                    loc: self.doc.loc(&e.value.span),
                })),
                _ => Err(self.wrong(e, "a decimal string or a number")),
            },
        }
    }

    fn finish(self) -> Result<(), InputError> {
        for (e, used) in self.entries.iter().zip(&self.used) {
            if !used {
                return Err(self.doc.error(
                    &e.key_span,
                    format!("unknown key `{}` in {}", e.key, self.what),
                    "check the spelling against docs/file-formats.md, \"Schema files\"",
                ));
            }
        }
        Ok(())
    }
}

/// Integer literal text (decimal, `0x`, `0o`, `0b`, `_` separators).
pub(crate) fn parse_int_text(t: &str) -> Option<i128> {
    match crate::value::parse_radix_int(t) {
        Some(r) => r.ok(),
        None => crate::decimal::Decimal::parse(t).ok()?.to_integer(),
    }
}

fn parse_enum_table(doc: &Document, node: &Node, what: &str) -> Result<EnumDef, InputError> {
    let NodeKind::Table(entries) = &node.kind else {
        return Err(doc.error(
            &node.span,
            format!("{what} must be a table of value = \"label\""),
            "write e.g. `0 = \"Off\"`",
        ));
    };
    let mut def = EnumDef {
        entries: Vec::new(),
        loc: Some(doc.loc(&node.span)),
    };
    for e in entries {
        let v = parse_int_text(&e.key)
            .and_then(|v| i64::try_from(v).ok())
            .ok_or_else(|| {
                doc.error(
                    &e.key_span,
                    format!("enumeration key `{}` in {what} is not an integer", e.key),
                    "enumeration keys are raw values, e.g. `0 = \"Off\"`",
                )
            })?;
        let NodeKind::Str(label) = &e.value.kind else {
            return Err(doc.error(
                &e.value.span,
                format!("label of {} in {what} must be a string", e.key),
                "write e.g. `0 = \"Off\"`",
            ));
        };
        def.entries.push((v, label.clone(), doc.loc(&e.key_span)));
    }
    Ok(def)
}

fn parse_values(r: &mut Reader<'_>, what: &str) -> Result<Option<EnumSource>, InputError> {
    let inline = r.take("values");
    let reference = r.string("values_ref")?;
    match (inline, reference) {
        (Some(e), Some(_)) => Err(r.doc.error(
            &e.key_span,
            format!("{what} has both `values` and `values_ref`"),
            "keep one of them",
        )),
        (Some(e), None) => Ok(Some(EnumSource::Inline(parse_enum_table(
            r.doc, &e.value, what,
        )?))),
        (None, Some((name, loc))) => Ok(Some(EnumSource::Ref { name, loc })),
        (None, None) => Ok(None),
    }
}

fn parse_code(doc: &Document, node: &Node) -> Result<Code, InputError> {
    let mut r = Reader::new(doc, node, "[[code]]")?;
    let index = r.uint::<u16>("index")?;
    let subindex = r.uint::<u8>("subindex")?;
    if let (Some((_, l)), None) = (&subindex, &index) {
        return Err(InputError::new(
            InputErrorKind::Structure,
            l.clone(),
            "`subindex` without `index`",
            "add the object's `index` (docs/file-formats.md, \"CiA 301 objects\")",
        ));
    }
    let sub = subindex.as_ref().map(|s| s.0);
    let (number, loc) = match (r.uint::<u32>("number")?, &index) {
        (Some((n, l)), Some((i, _))) if n != index_number(*i, sub) => {
            return Err(InputError::new(
                InputErrorKind::Structure,
                l,
                match sub {
                    None => format!(
                        "code with `index` = 0x{i:04X} has number {n}, not {} (65536 + index)",
                        index_number(*i, None)
                    ),
                    Some(s) => format!(
                        "code with `index` = 0x{i:04X}, `subindex` = {s} has number {n}, not {} (16777216 + index x 256 + subindex)",
                        index_number(*i, sub)
                    ),
                },
                "leave `number` out or write the number `index` gives (docs/file-formats.md, \"CiA 301 objects\")",
            ));
        }
        (Some(nl), _) => nl,
        (None, Some((i, l))) => (index_number(*i, sub), l.clone()),
        (None, None) => {
            return Err(doc.error(&node.span, "[[code]] has no `number`", "add `number = ...`"));
        }
    };
    let index = index.map(|i| i.0);
    let what = format!("code {number}");
    r.what = what.clone();
    let name = r.string("name")?;
    let type_name = r.string("type")?;
    let access = match r.string("access")? {
        None => None,
        Some((a, l)) => Some(match a.as_str() {
            "rw" => Access::Rw,
            "ro" => Access::Ro,
            "standstill" => Access::Standstill,
            _ => {
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown access `{a}` in {what}"),
                    "use rw, ro or standstill",
                ));
            }
        }),
    };
    let kind = match r.string("kind")? {
        None => None,
        Some((k, l)) => Some(match k.as_str() {
            "ram-actual" => StorageKind::RamActual,
            "ram-control" => StorageKind::RamControl,
            "eeprom" => StorageKind::Eeprom,
            "fsel-isel" => StorageKind::FselIsel,
            _ => {
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown kind `{k}` in {what}"),
                    "use ram-actual, ram-control, eeprom or fsel-isel",
                ));
            }
        }),
    };
    let values = parse_values(&mut r, &what)?;
    if let Some(e) = r.take("password") {
        return Err(doc.error(
            &e.key_span,
            format!("`password` in {what} is now a role"),
            "write `role = \"password\"` instead",
        ));
    }
    let (role, role_loc) = match r.string("role")? {
        None => (None, None),
        Some((t, l)) => match Role::parse(&t) {
            Some(x) => (Some(x), Some(l)),
            None => {
                let help = if t == "identify" {
                    "identify codes are listed in `[schema.identify] codes`, not by a role key"
                        .to_string()
                } else {
                    format!(
                        "use one of: {}",
                        Role::ALL
                            .into_iter()
                            .filter(|r| *r != Role::Identify)
                            .map(Role::as_str)
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                };
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown role `{t}` in {what}"),
                    help,
                ));
            }
        },
    };
    let stopped = match r.take("stopped") {
        None => Vec::new(),
        Some(e) => match &e.value.kind {
            NodeKind::Array(items) => items
                .iter()
                .map(|n| match &n.kind {
                    NodeKind::Num(t) => parse_int_text(t)
                        .and_then(|v| i64::try_from(v).ok())
                        .ok_or_else(|| r.wrong(e, "an array of integers (raw values)")),
                    _ => Err(r.wrong(e, "an array of integers (raw values)")),
                })
                .collect::<Result<Vec<_>, _>>()?,
            _ => return Err(r.wrong(e, "an array of integers (raw values)")),
        },
    };
    let mut bits = Vec::new();
    if let Some(e) = r.take("bits") {
        let NodeKind::Array(items) = &e.value.kind else {
            return Err(r.wrong(e, "an array of tables ([[code.bits]])"));
        };
        for item in items {
            let mut br = Reader::new(doc, item, format!("a bit field of {what}"))?;
            let (bname, bloc) = br.required_string("name")?;
            br.what = format!("bit field {bname} of {what}");
            let title = br.string("title")?.map(|t| t.0);
            let Some(be) = br.take("bits") else {
                return Err(doc.error(
                    &item.span,
                    format!("bit field {bname} of {what} has no `bits`"),
                    "add `bits = [lsb, msb]`",
                ));
            };
            let pair: Option<Vec<u32>> = match &be.value.kind {
                NodeKind::Array(v) if v.len() == 2 => v
                    .iter()
                    .map(|n| match &n.kind {
                        NodeKind::Num(t) => parse_int_text(t).and_then(|x| u32::try_from(x).ok()),
                        _ => None,
                    })
                    .collect(),
                _ => None,
            };
            let Some([lsb, msb]) = pair.as_deref().and_then(|p| <[u32; 2]>::try_from(p).ok())
            else {
                return Err(br.wrong(be, "[lsb, msb] (two non-negative integers)"));
            };
            let bits_loc = doc.loc(&be.value.span);
            let values = parse_values(&mut br, &format!("bit field {bname}"))?;
            let (brole, brole_loc) = match br.string("role")? {
                None => (None, None),
                Some((t, l)) => match BitRole::parse(&t) {
                    Some(r) => (Some(r), Some(l)),
                    None => {
                        return Err(InputError::new(
                            InputErrorKind::Structure,
                            l,
                            format!("unknown role `{t}` of bit field {bname} of {what}"),
                            format!(
                                "use one of: {}",
                                BitRole::ALL.map(BitRole::as_str).join(", ")
                            ),
                        ));
                    }
                },
            };
            br.finish()?;
            bits.push(BitField {
                name: bname,
                title,
                lsb,
                msb,
                values,
                loc: bloc,
                bits_loc,
                role: brole,
                role_loc: brole_loc,
            });
        }
    }
    let code = Code {
        number,
        name_loc: name.as_ref().map(|n| n.1.clone()),
        name: name.map(|n| n.0).unwrap_or_default(),
        aliases: r.string_list("aliases")?,
        title: r.string("title")?.map(|t| t.0),
        spec: r.string("spec")?.map(|t| t.0),
        type_name,
        unit: r.string("unit")?.map(|t| t.0),
        unit_aliases: r
            .string_list("unit_aliases")?
            .into_iter()
            .map(|t| t.0)
            .collect(),
        min: r.fact("min")?,
        max: r.fact("max")?,
        default: r.fact("default")?,
        access,
        lecom_only: r.boolean("lecom_only")?,
        subcodes: r.uint::<u32>("subcodes")?.map(|t| t.0),
        index,
        subindex: sub,
        data_type: r.uint::<u16>("data_type")?.map(|t| t.0),
        note: r.string("note")?.map(|t| t.0),
        kind,
        basis: r.boolean("basis")?,
        width: r.uint::<u8>("width")?.map(|t| t.0),
        card_writeable: r.boolean("card_writeable")?,
        role,
        role_loc,
        stopped,
        read_clears: r.boolean("read_clears")?,
        compatible: r.boolean("compatible")?,
        values_partial: r.boolean("values_partial")?,
        values,
        bits,
        loc,
        resolved_type: None,
        bounds: std::sync::OnceLock::new(),
    };
    r.finish()?;
    Ok(code)
}

fn parse_rule(doc: &Document, node: &Node) -> Result<Rule, InputError> {
    let mut r = Reader::new(doc, node, "[[rule]]")?;
    let (kind, kloc) = r.required_string("kind")?;
    let loc = kloc.clone();
    let message = r.required_string("message")?.0;
    let _spec = r.string("spec")?;
    let _note = r.string("note")?;
    let rule = match kind.as_str() {
        "distinct-fields" => {
            let code = r
                .uint::<u32>("code")?
                .ok_or_else(|| doc.error(&node.span, "rule has no `code`", "add `code = ...`"))?
                .0;
            let fields = r.string_list("fields")?.into_iter().map(|f| f.0).collect();
            Rule::DistinctFields {
                code,
                fields,
                message,
                loc,
            }
        }
        "less-or-equal" => {
            let left = r
                .uint::<u32>("left")?
                .ok_or_else(|| doc.error(&node.span, "rule has no `left`", "add `left = ...`"))?
                .0;
            let right = r
                .uint::<u32>("right")?
                .ok_or_else(|| doc.error(&node.span, "rule has no `right`", "add `right = ...`"))?
                .0;
            Rule::LessOrEqual {
                left,
                right,
                message,
                loc,
            }
        }
        other => {
            return Err(InputError::new(
                InputErrorKind::Structure,
                kloc,
                format!("unknown rule kind `{other}`"),
                "use distinct-fields or less-or-equal",
            ));
        }
    };
    r.finish()?;
    Ok(rule)
}

/// A schema's fingerprint ([`Schema::fingerprint`]): `sha256:` + hex of
/// the file's text; for a schema that extends a base, of the base's
/// fingerprint, a newline and the text (so an edited base changes it too).
pub fn schema_fingerprint(base: Option<&str>, text: &str) -> String {
    use sha2::{Digest, Sha256};
    use std::fmt::Write as _;
    let mut h = Sha256::new();
    if let Some(b) = base {
        h.update(b.as_bytes());
        h.update(b"\n");
    }
    h.update(text.as_bytes());
    let mut s = String::from("sha256:");
    for b in h.finalize().iter() {
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// Parse one schema file's text. `base` resolves `extends` (a schema id).
pub fn parse_schema(
    source: SourceFile,
    base: &dyn Fn(&str) -> Option<Arc<Schema>>,
) -> Result<Schema, InputError> {
    let doc = doc::parse(source, Syntax::Toml)?;
    let mut top = Reader::new(&doc, &doc.root, "the schema file")?;
    let Some(head) = top.take("schema") else {
        return Err(doc.error(
            &(0..0),
            "the schema file has no [schema] table",
            "start the file with `[schema]`",
        ));
    };
    let mut h = Reader::new(&doc, &head.value, "[schema]")?;
    let (id, id_loc) = h.required_string("id")?;
    let title = h.required_string("title")?.0;
    let extends = h.string("extends")?;
    let fictional = h.boolean("fictional")?;
    let fictional_loc = h
        .take("fictional")
        .map(|e| doc.loc(&e.value.span))
        .unwrap_or_else(|| h.loc());
    let protocol = match h.string("protocol")? {
        None => None,
        Some((p, l)) => Some(Family::from_schema_protocol(&p).ok_or_else(|| {
            InputError::new(
                InputErrorKind::Structure,
                l,
                format!("unknown protocol `{p}`"),
                format!("use one of {}", Family::schema_protocols()),
            )
        })?),
    };
    let code_style = match h.string("code_style")? {
        None => None,
        Some((s, l)) => Some(match s.as_str() {
            "lenze" => CodeStyle::Lenze,
            "lust" => CodeStyle::Lust,
            _ => {
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    l,
                    format!("unknown code_style `{s}`"),
                    "use lenze or lust",
                ));
            }
        }),
    };
    let spec = h.string("spec")?.map(|s| s.0);
    let default_type = match h.string("default_type")? {
        None => None,
        Some((t, l)) => Some(ValueType::from_name(&t).ok_or_else(|| {
            InputError::new(
                InputErrorKind::Structure,
                l,
                format!("unknown default_type `{t}`"),
                "use a type name from docs/file-formats.md, \"Types and raw values\"",
            )
        })?),
    };
    let identify = match h.take("identify") {
        None => None,
        Some(e) => {
            let mut ir = Reader::new(&doc, &e.value, "[schema.identify]")?;
            let ints = |ir: &mut Reader<'_>, key: &str| -> Result<Vec<i128>, InputError> {
                match ir.take(key) {
                    None => Ok(Vec::new()),
                    Some(e) => match &e.value.kind {
                        NodeKind::Array(items) => items
                            .iter()
                            .map(|n| match &n.kind {
                                NodeKind::Num(t) => parse_int_text(t)
                                    .ok_or_else(|| ir.wrong(e, "an array of integers")),
                                _ => Err(ir.wrong(e, "an array of integers")),
                            })
                            .collect(),
                        _ => Err(ir.wrong(e, "an array of integers")),
                    },
                }
            };
            let codes = ints(&mut ir, "codes")?
                .into_iter()
                .filter_map(|v| u32::try_from(v).ok())
                .collect();
            let type_values = ints(&mut ir, "type_values")?
                .into_iter()
                .filter_map(|v| i64::try_from(v).ok())
                .collect();
            let note = ir.string("note")?.map(|n| n.0);
            ir.finish()?;
            Some(Identify {
                codes,
                type_values,
                note,
            })
        }
    };
    let can_index_base = match h.take("can") {
        None => None,
        Some(e) => {
            let mut cr = Reader::new(&doc, &e.value, "[schema.can]")?;
            let b = cr.uint::<u32>("index_base")?.map(|b| b.0);
            cr.finish()?;
            b
        }
    };
    let learned = match h.take("learned") {
        None => None,
        Some(e) => {
            let mut lr = Reader::new(&doc, &e.value, "[schema.learned]")?;
            let (asked, loc) = lr.required_string("asked")?;
            let asked = parse_number_list(&asked).map_err(|m| {
                InputError::new(
                    InputErrorKind::Structure,
                    loc,
                    format!("[schema.learned] asked: {m}"),
                    "list the parameters whose descriptions were asked for, e.g. \"1-99\" or \"1,5,100-120\"",
                )
            })?;
            lr.finish()?;
            Some(LearnedFrom {
                asked,
                text: doc.source.text.clone(),
            })
        }
    };
    let head_loc = h.loc();
    h.finish()?;

    let mut codes = Vec::new();
    if let Some(e) = top.take("code") {
        let NodeKind::Array(items) = &e.value.kind else {
            return Err(top.wrong(e, "an array of tables ([[code]])"));
        };
        for item in items {
            codes.push(parse_code(&doc, item)?);
        }
    }
    let mut enums = BTreeMap::new();
    if let Some(e) = top.take("enum") {
        let mut er = Reader::new(&doc, &e.value, "[enum]")?;
        for en in er.entries {
            enums.insert(
                en.key.clone(),
                parse_enum_table(&doc, &en.value, &format!("[enum.{}]", en.key))?,
            );
        }
        er.used.iter_mut().for_each(|u| *u = true);
        er.finish()?;
    }
    let mut rules = Vec::new();
    if let Some(e) = top.take("rule") {
        let NodeKind::Array(items) = &e.value.kind else {
            return Err(top.wrong(e, "an array of tables ([[rule]])"));
        };
        for item in items {
            rules.push(parse_rule(&doc, item)?);
        }
    }
    top.finish()?;

    let mut schema = match &extends {
        Some((base_id, bloc)) => {
            let Some(b) = base(base_id) else {
                return Err(InputError::new(
                    InputErrorKind::Structure,
                    bloc.clone(),
                    format!("base schema `{base_id}` is not known"),
                    "extend one of the built-in schemas (lenze-tmd, lenze-ecs, lust-vf1000, lust-mc6000) or a schema loaded before this one",
                ));
            };
            let mut s = (*b).clone();
            s.merge_findings.clear();
            s
        }
        None => {
            let missing = |what: &str| {
                doc.error(
                    &head.value.span,
                    format!("[schema] has no `{what}`"),
                    format!("add `{what} = \"...\"`"),
                )
            };
            Schema {
                id: String::new(),
                title: String::new(),
                family: protocol.ok_or_else(|| missing("protocol"))?,
                code_style: code_style.ok_or_else(|| missing("code_style"))?,
                spec: None,
                default_type: None,
                identify: None,
                can_index_base: None,
                fictional: false,
                extends: None,
                codes: Vec::new(),
                enums: BTreeMap::new(),
                rules: Vec::new(),
                path: String::new(),
                fingerprint: String::new(),
                id_loc: id_loc.clone(),
                fictional_loc: head_loc.clone(),
                merge_findings: Vec::new(),
                learned: None,
                by_number: BTreeMap::new(),
                by_name: Default::default(),
                numeric_names: false,
            }
        }
    };
    schema.id = id;
    schema.title = title;
    schema.id_loc = id_loc;
    schema.fictional = fictional.unwrap_or(false);
    schema.fictional_loc = fictional_loc;
    schema.learned = learned;
    schema.extends = extends.map(|e| e.0);
    schema.path = doc.source.path.clone();
    let base_fingerprint = schema.extends.is_some().then(|| schema.fingerprint.clone());
    schema.fingerprint = schema_fingerprint(base_fingerprint.as_deref(), &doc.source.text);
    if let Some(p) = protocol {
        schema.family = p;
    }
    if let Some(c) = code_style {
        schema.code_style = c;
    }
    if spec.is_some() {
        schema.spec = spec;
    }
    if default_type.is_some() {
        schema.default_type = default_type;
    }
    if identify.is_some() {
        schema.identify = identify;
    }
    if can_index_base.is_some() {
        schema.can_index_base = can_index_base;
    }
    let base_codes = schema.codes.len();
    schema.reindex();
    for code in codes {
        match schema
            .by_number
            .get(&code.number)
            .copied()
            .filter(|&i| i < base_codes)
        {
            Some(i) => {
                if let Some(existing) = schema.codes.get_mut(i) {
                    let conflicts = fill_unset(existing, code);
                    schema.merge_findings.extend(conflicts);
                }
            }
            None => schema.codes.push(code),
        }
    }
    for (name, def) in enums {
        if let Some(prev) = schema.enums.get(&name) {
            if let Some(loc) = def.loc.clone() {
                schema.merge_findings.push(Finding::new(
                    FindingKind::SchemaError,
                    loc,
                    format!("[enum.{name}] is already defined by the base schema"),
                    "give the fixture's enumeration another name",
                ));
            }
            let _ = prev;
            continue;
        }
        schema.enums.insert(name, def);
    }
    schema.rules.extend(rules);
    schema.apply_floor();
    schema.reindex();
    Ok(schema)
}

impl Schema {
    /// Give the codes the roles the family's specs give them
    /// ([`crate::family::FloorRole`], the descriptor's `floor`): the one
    /// place every schema passes when it is loaded (built-in, by path,
    /// `extends`, learned, imported from an EDS, `--schemas DIR`), so a
    /// schema file can add roles but never drop them. A code the schema
    /// does not list stays unlisted (a client never writes it).
    fn apply_floor(&mut self) {
        let floor = self.family.descriptor().floor;
        for code in &mut self.codes {
            let Some(f) = floor.iter().find(|f| f.code == code.number) else {
                continue;
            };
            code.role = Some(f.role);
            if f.role != Role::ControlWord {
                continue;
            }
            // Only the floor's inhibit bits make a value safe.
            for b in &mut code.bits {
                if b.role == Some(crate::role::BitRole::Inhibit)
                    && !f
                        .bits
                        .iter()
                        .any(|fb| fb.bit == b.lsb && fb.role == crate::role::BitRole::Inhibit)
                {
                    b.role = None;
                    b.role_loc = None;
                }
            }
            for fb in f.bits {
                match code
                    .bits
                    .iter_mut()
                    .find(|b| b.lsb == fb.bit && b.msb == fb.bit)
                {
                    Some(b) => b.role = Some(fb.role),
                    None => {
                        // A wider member over the bit: a start, enable,
                        // release or reset bit makes the member count as
                        // one when any of its bits is set (more values are
                        // refused, none is let through); an inhibit bit
                        // stays unnamed (no value is made safe by it).
                        if let Some(b) = code
                            .bits
                            .iter_mut()
                            .find(|b| b.lsb <= fb.bit && fb.bit <= b.msb)
                        {
                            if fb.role != BitRole::Inhibit {
                                b.role = Some(fb.role);
                            }
                            continue;
                        }
                        code.bits.push(BitField {
                            name: fb.name.to_string(),
                            title: None,
                            lsb: fb.bit,
                            msb: fb.bit,
                            values: None,
                            loc: code.loc.clone(),
                            bits_loc: code.loc.clone(),
                            role: Some(fb.role),
                            role_loc: None,
                        });
                    }
                }
            }
            if f.stopped.is_empty() {
                code.stopped.clear();
            } else {
                code.stopped.retain(|v| f.stopped.contains(v));
                if code.stopped.is_empty() {
                    code.stopped = f.stopped.to_vec();
                }
            }
        }
    }
}

/// Fill the unset facts of a base code from a fixture's code of the same
/// number; a fact both give differently is a finding.
fn fill_unset(base: &mut Code, over: Code) -> Vec<Finding> {
    let mut out = Vec::new();
    let number = base.number;
    macro_rules! fill {
        ($field:ident) => {
            match (&base.$field, over.$field) {
                (None, Some(v)) => base.$field = Some(v),
                (Some(a), Some(b)) if *a != b => out.push(Finding::new(
                    FindingKind::SchemaError,
                    over.loc.clone(),
                    format!("fixture changes `{}` of code {number}, which the base schema already gives", stringify!($field)),
                    "a fixture may only fill facts the base leaves unset; remove it from the fixture",
                )),
                _ => {}
            }
        };
    }
    if base.name.is_empty() {
        base.name = over.name;
        base.name_loc = over.name_loc;
    } else if !over.name.is_empty() && over.name != base.name {
        out.push(Finding::new(
            FindingKind::SchemaError,
            over.name_loc.clone().unwrap_or_else(|| over.loc.clone()),
            format!(
                "fixture renames code {number} from `{}` to `{}`",
                base.name, over.name
            ),
            "add the new name to `aliases` instead",
        ));
    }
    base.aliases.extend(over.aliases);
    base.unit_aliases.extend(over.unit_aliases);
    fill!(title);
    fill!(spec);
    fill!(unit);
    fill!(access);
    fill!(lecom_only);
    fill!(subcodes);
    fill!(index);
    fill!(subindex);
    fill!(data_type);
    fill!(note);
    fill!(kind);
    fill!(basis);
    fill!(width);
    fill!(card_writeable);
    if base.stopped.is_empty() {
        base.stopped = over.stopped;
    }
    if base.role.is_none() {
        base.role = over.role;
        base.role_loc = over.role_loc;
    } else if over.role.is_some() && over.role != base.role {
        out.push(Finding::new(
            FindingKind::SchemaError,
            over.role_loc.clone().unwrap_or_else(|| over.loc.clone()),
            format!("fixture changes `role` of code {number}, which the base schema already gives"),
            "a fixture may only fill facts the base leaves unset; remove it from the fixture",
        ));
    }
    fill!(read_clears);
    fill!(compatible);
    fill!(values_partial);
    // facts with locations: compare by value only
    macro_rules! fill_loc {
        ($field:ident, $eq:expr) => {
            match (&base.$field, over.$field) {
                (None, Some(v)) => base.$field = Some(v),
                (Some(a), Some(b)) if !$eq(a, &b) => out.push(Finding::new(
                    FindingKind::SchemaError,
                    over.loc.clone(),
                    format!("fixture changes `{}` of code {number}, which the base schema already gives", stringify!($field)),
                    "a fixture may only fill facts the base leaves unset; remove it from the fixture",
                )),
                _ => {}
            }
        };
    }
    fill_loc!(
        type_name,
        |a: &(String, Location), b: &(String, Location)| a.0 == b.0
    );
    fill_loc!(min, |a: &Fact, b: &Fact| a.value == b.value);
    fill_loc!(max, |a: &Fact, b: &Fact| a.value == b.value);
    fill_loc!(default, |a: &Fact, b: &Fact| a.value == b.value);
    fill_loc!(values, |_: &EnumSource, _: &EnumSource| false);
    if base.bits.is_empty() {
        base.bits = over.bits;
    } else if !over.bits.is_empty() {
        out.push(Finding::new(
            FindingKind::SchemaError,
            over.loc.clone(),
            format!("fixture redefines the bit fields of code {number}"),
            "a fixture may only fill facts the base leaves unset; remove them from the fixture",
        ));
    }
    out
}

/// The schema file names embedded in the crate (docs: "one file per drive family").
pub const BUILTIN_FILES: [(&str, &str); 4] = [
    (
        "schemas/lenze-tmd.toml",
        include_str!("../../../schemas/lenze-tmd.toml"),
    ),
    (
        "schemas/lenze-ecs.toml",
        include_str!("../../../schemas/lenze-ecs.toml"),
    ),
    (
        "schemas/lust-vf1000.toml",
        include_str!("../../../schemas/lust-vf1000.toml"),
    ),
    (
        "schemas/lust-mc6000.toml",
        include_str!("../../../schemas/lust-mc6000.toml"),
    ),
];

/// Known schemas by id: the built-ins plus files loaded by path or directory.
#[derive(Debug, Clone, Default)]
pub struct Registry {
    schemas: BTreeMap<String, Arc<Schema>>,
    by_path: HashMap<PathBuf, String>,
    /// The source text each schema was parsed from, by id: the same file
    /// reached twice (embedded and on disk, or by two relative paths) is one
    /// schema, not a clash.
    texts: HashMap<String, Arc<str>>,
    /// Schema ids a set may not name by id, with the file that holds each
    /// (the simulator's fictional fixtures): see [`Registry::withhold`].
    withheld: BTreeMap<String, String>,
}

impl Registry {
    /// Withhold `id` from sets that name it by id: such a set gets a
    /// finding that names `file`, where the schema is (the simulator's
    /// fictional fixture schemas, which belong to the simulator and the
    /// examples, not to a user's registry). A schema of that id added
    /// later (`--schemas DIR`, a set naming the file) is known as usual.
    ///
    /// `text` is the fixture's own text: a schema of that id with any other
    /// text is refused when added ([`Registry::add_source`]), so no file
    /// (`--schemas DIR`, a set naming a file) can take a fixture's id and
    /// give its codes other facts.
    pub fn withhold(&mut self, id: &str, file: &str, text: &str) {
        self.withheld.insert(id.to_string(), file.to_string());
        self.texts.insert(id.to_string(), Arc::from(text));
    }

    /// The file of a withheld schema id ([`Registry::withhold`]).
    pub fn withheld(&self, id: &str) -> Option<&str> {
        self.withheld.get(id).map(String::as_str)
    }

    /// An empty registry.
    pub fn new() -> Self {
        Registry::default()
    }

    /// The four built-in schemas (`schemas/*.toml`, embedded at build time).
    pub fn builtin() -> Result<Self, InputError> {
        let mut r = Registry::new();
        for (path, text) in BUILTIN_FILES {
            r.add_source(SourceFile::new(path, text))?;
        }
        Ok(r)
    }

    /// Add a schema from text (`extends` resolves against schemas already here).
    /// A second schema with an id already known is an error.
    pub fn add_source(&mut self, source: SourceFile) -> Result<Arc<Schema>, InputError> {
        let text = source.text.clone();
        let schema = {
            let lookup = |id: &str| self.schemas.get(id).cloned();
            parse_schema(source, &lookup)?
        };
        if let (Some(file), None) = (self.withheld.get(&schema.id), self.schemas.get(&schema.id))
            && self.texts.get(&schema.id).is_some_and(|t| **t != *text)
        {
            return Err(InputError::new(
                InputErrorKind::Structure,
                schema.id_loc.clone(),
                format!(
                    "schema id `{}` is the id of the simulator's fixture schema {file}",
                    schema.id
                ),
                "give each schema file its own id (a schema file cannot reuse a built-in or fixture id)",
            ));
        }
        if let Some(prev) = self.schemas.get(&schema.id) {
            if self.texts.get(&schema.id).is_some_and(|t| **t == *text) {
                return Ok(prev.clone());
            }
            return Err(InputError::new(
                InputErrorKind::Structure,
                schema.id_loc.clone(),
                format!(
                    "schema id `{}` is already defined by {}",
                    schema.id, prev.path
                ),
                "give each schema file its own id (a schema file cannot reuse a built-in or fixture id)",
            ));
        }
        let schema = Arc::new(schema);
        self.schemas.insert(schema.id.clone(), schema.clone());
        self.texts.insert(schema.id.clone(), text);
        Ok(schema)
    }

    /// Make `id` name `schema` (replacing what it named): a set naming a
    /// built-in schema is then resolved against a schema learned from the
    /// drive that extends it (driveset-engine's `learn`).
    pub fn insert_as(&mut self, id: &str, schema: Arc<Schema>) {
        self.schemas.insert(id.to_string(), schema);
        self.texts.remove(id);
    }

    /// Load a schema file by path (cached: loading the same file twice returns the first).
    pub fn load_file(&mut self, path: &Path) -> Result<Arc<Schema>, InputError> {
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some(s) = self.by_path.get(&key).and_then(|id| self.schemas.get(id)) {
            return Ok(s.clone());
        }
        let source = read_text_file(path)?;
        let s = self.add_source(source)?;
        self.by_path.insert(key, s.id.clone());
        Ok(s)
    }

    /// Load every `*.toml` of a directory (sorted by name; fixtures whose base
    /// is in the same directory load after it).
    pub fn load_dir(&mut self, dir: &Path) -> Result<Vec<Arc<Schema>>, InputError> {
        let rd = std::fs::read_dir(dir).map_err(|e| {
            InputError::new(
                InputErrorKind::Unreadable,
                Location::file_only(dir.display().to_string()),
                format!("cannot read directory {}: {e}", dir.display()),
                "check the path",
            )
        })?;
        let mut paths: Vec<PathBuf> = rd
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        let mut out = Vec::new();
        let mut pending = paths;
        // retry files whose base is not loaded yet, as long as progress is made
        loop {
            let mut next = Vec::new();
            let mut last_err = None;
            let before = pending.len();
            for p in pending {
                match self.load_file(&p) {
                    Ok(s) => out.push(s),
                    Err(e) => {
                        last_err = Some(e);
                        next.push(p);
                    }
                }
            }
            if next.is_empty() {
                return Ok(out);
            }
            if next.len() == before {
                return Err(last_err.unwrap_or_else(|| {
                    InputError::new(
                        InputErrorKind::Structure,
                        Location::file_only(dir.display().to_string()),
                        "cannot load schemas",
                        "",
                    )
                }));
            }
            pending = next;
        }
    }

    /// Schema by id.
    pub fn get(&self, id: &str) -> Option<Arc<Schema>> {
        self.schemas.get(id).cloned()
    }

    /// All schemas, by id.
    pub fn schemas(&self) -> impl Iterator<Item = &Arc<Schema>> {
        self.schemas.values()
    }
}

#[cfg(test)]
mod tests {
    use super::{number_list_text, parse_number_list};

    #[test]
    fn number_lists_parse_and_print_back() {
        let n = parse_number_list("1-3, 7,5,100-102").unwrap();
        assert_eq!(
            n.iter().copied().collect::<Vec<_>>(),
            [1, 2, 3, 5, 7, 100, 101, 102]
        );
        assert_eq!(number_list_text(&n), "1-3,5,7,100-102");
        assert_eq!(
            number_list_text(&parse_number_list("1-999").unwrap()),
            "1-999"
        );
        assert_eq!(
            parse_number_list("5-1").unwrap_err(),
            "`5-1`: a range goes up"
        );
        assert_eq!(
            parse_number_list("x").unwrap_err(),
            "`x` is not a number or a range like 1-99"
        );
        assert_eq!(parse_number_list(" , ").unwrap_err(), "names no parameter");
    }

    #[test]
    fn a_learned_table_is_read_and_not_inherited() {
        use crate::error::SourceFile;
        let mut reg = super::Registry::builtin().unwrap();
        let text = "[schema]\nid = \"l\"\ntitle = \"t\"\nextends = \"lust-vf1000\"\n\n[schema.learned]\nasked = \"1-9,11\"\n";
        let s = reg.add_source(SourceFile::new("l.toml", text)).unwrap();
        let l = s.learned.as_ref().unwrap();
        assert_eq!(number_list_text(&l.asked), "1-9,11");
        assert_eq!(&*l.text, text);
        let over = "[schema]\nid = \"m\"\ntitle = \"t\"\nextends = \"l\"\n";
        let m = reg.add_source(SourceFile::new("m.toml", over)).unwrap();
        assert!(m.learned.is_none());
        let bad = "[schema]\nid = \"b\"\ntitle = \"t\"\nextends = \"lust-vf1000\"\n\n[schema.learned]\nasked = \"9-1\"\n";
        let e = reg.add_source(SourceFile::new("b.toml", bad)).unwrap_err();
        assert_eq!(e.message, "[schema.learned] asked: `9-1`: a range goes up");
        assert_eq!(e.location.line, 7);
    }
}
