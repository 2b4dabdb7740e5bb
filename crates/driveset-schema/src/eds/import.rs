//! Owns `schema import`: turning a CiA 306 EDS / DCF ([`super::reader`])
//! into a Lenze ECS schema file (docs/file-formats.md, "Imported schemas")
//! with a lint for every object it skipped or downgraded.
//!
//! Mapping (`lenze-system-bus-can-sdo.txt`, ECS manual p. 454):
//! - index 0x2000..=0x5FFF is Lenze code 24575 - index; INTEGER32 (and,
//!   with a lint, UNSIGNED32) objects are FIX32 (value x 10000), C0135 /
//!   C0150 are BITCODED ("bit-coded and without a factor"), VISIBLE_STRING
//!   is VS, OCTET_STRING is VO; other types are skipped (the excerpt
//!   transmits Lenze codes as 4-byte FIX32);
//! - CiA 301 objects (0x1000..=0x1FFF, 0x6000..=0xFFFF) are kept by index
//!   (`index = 0x1017`, number 65536 + index) with their own CANopen type;
//!   PDO, SDO-channel and store/restore objects are bus configuration or
//!   commands and are skipped;
//! - subindexes 1..=n are subcodes (sub 0, the number of entries, is not a
//!   setting); an ARRAY / RECORD whose subindexes differ in type or access
//!   is skipped, since one code has one type;
//! - AccessType ro / const -> `ro`; rw / rwr / rww -> `rw`; wo is skipped
//!   (driveset verifies every write by reading it back); ObjFlags bit 0
//!   (refuse write on download) -> `ro`, bit 1 (refuse read on scan) ->
//!   skipped;
//! - DefaultValue / LowLimit / HighLimit -> `default` / `min` / `max` in
//!   engineering units, exact (FIX32 raw / 10000 as a decimal); empty,
//!   `$NODEID`-relative, unparsable or out-of-range values are left unset.

use std::collections::{BTreeMap, HashSet};
use std::fmt::Write as _;

use super::reader::{self, EdsFile, IntValue, ObjectName, Section, parse_int, parse_octets};
use crate::decimal::Decimal;
use crate::error::SourceFile;
use crate::schema::{Registry, index_number, looks_numeric_key};
use crate::value::{ValueType, check_vs_text};

/// The Lenze index base (p. 454: index = 24575 - code).
pub const LENZE_INDEX_BASE: u32 = 24575;

/// One thing the importer skipped or downgraded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImportLint {
    /// Line in the EDS / DCF (0: the whole file).
    pub line: usize,
    /// The object (`0x1600sub1`, `0x5FF4`) or empty for file-level lints.
    pub object: String,
    /// What and what was done.
    pub message: String,
}

impl ImportLint {
    /// `FILE:LINE: OBJECT: MESSAGE`.
    pub fn render(&self, file: &str) -> String {
        let at = if self.line > 0 {
            format!("{file}:{}", self.line)
        } else {
            file.to_string()
        };
        if self.object.is_empty() {
            format!("{at}: {}", self.message)
        } else {
            format!("{at}: {}: {}", self.object, self.message)
        }
    }
}

/// What `schema import` made.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Imported {
    /// The schema file text (TOML).
    pub toml: String,
    /// Schema id.
    pub id: String,
    /// Lenze codes written (a subindex kept as its own code counts once).
    pub lenze_codes: usize,
    /// Other objects written (kept by index with their own CiA types).
    pub cia_objects: usize,
    /// Every object skipped or downgraded, in file order.
    pub lints: Vec<ImportLint>,
}

/// Why a file cannot be imported (exit 2).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImportError {
    /// Line (0: the whole file).
    pub line: usize,
    /// Column (0: none).
    pub column: usize,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
}

/// `schema import` options.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImportOptions {
    /// Schema id (default: derived from the file name, see [`default_id`]).
    pub id: Option<String>,
    /// The file as named in messages and `spec` fields.
    pub file: String,
}

/// The file name of a path (`/home/x/axis.eds` -> `axis.eds`): what `spec`
/// fields name, so a schema in git does not carry where it was imported.
fn file_name(path: &str) -> &str {
    path.rsplit(['/', '\\']).next().unwrap_or(path)
}

/// `FILE.eds` -> `file`: lowercase letters, digits and `-`.
pub fn default_id(file: &str) -> String {
    let name = file.rsplit(['/', '\\']).next().unwrap_or(file);
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
    let mut id = String::new();
    for c in stem.chars() {
        let c = c.to_ascii_lowercase();
        if c.is_ascii_alphanumeric() {
            id.push(c);
        } else if !id.ends_with('-') && !id.is_empty() {
            id.push('-');
        }
    }
    let id = id.trim_end_matches('-').to_string();
    if id.is_empty() {
        "imported-eds".into()
    } else {
        id
    }
}

/// CiA 301 data types (CiA 301 §7.4.7.1, Table 44) by number.
fn data_type_name(dt: u16) -> String {
    let n = match dt {
        0x0001 => "BOOLEAN",
        0x0002 => "INTEGER8",
        0x0003 => "INTEGER16",
        0x0004 => "INTEGER32",
        0x0005 => "UNSIGNED8",
        0x0006 => "UNSIGNED16",
        0x0007 => "UNSIGNED32",
        0x0008 => "REAL32",
        0x0009 => "VISIBLE_STRING",
        0x000A => "OCTET_STRING",
        0x000B => "UNICODE_STRING",
        0x000C => "TIME_OF_DAY",
        0x000D => "TIME_DIFFERENCE",
        0x000F => "DOMAIN",
        0x0010 => "INTEGER24",
        0x0011 => "REAL64",
        0x0012 => "INTEGER40",
        0x0013 => "INTEGER48",
        0x0014 => "INTEGER56",
        0x0015 => "INTEGER64",
        0x0016 => "UNSIGNED24",
        0x0018 => "UNSIGNED40",
        0x0019 => "UNSIGNED48",
        0x001A => "UNSIGNED56",
        0x001B => "UNSIGNED64",
        _ => return format!("0x{dt:04X}"),
    };
    format!("{n} (0x{dt:04X})")
}

/// The CiA 301 type a CiA object keeps (BOOLEAN travels as one byte).
fn cia_type(dt: u16) -> Option<ValueType> {
    Some(match dt {
        0x0001 | 0x0005 => ValueType::UNSIGNED8,
        0x0002 => ValueType::INTEGER8,
        0x0003 => ValueType::INTEGER16,
        0x0004 => ValueType::INTEGER32,
        0x0006 => ValueType::UNSIGNED16,
        0x0007 => ValueType::UNSIGNED32,
        0x0009 => ValueType::VS,
        0x000A => ValueType::VO,
        _ => return None,
    })
}

/// CiA 306 AccessType.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Acc {
    Ro,
    Wo,
    Rw,
    Const,
}

/// One variable: a VAR / DOMAIN object or one subindex.
#[derive(Debug, Clone)]
struct Var<'a> {
    sub: u8,
    /// Where its keys are (the main section for CompactSubObj entries).
    section: &'a Section,
}

impl Var<'_> {
    fn key(&self, k: &str) -> Option<&reader::Entry> {
        self.section.get(k)
    }
    fn line(&self) -> usize {
        self.section.line
    }
}

fn obj_text(index: u16, sub: Option<u8>) -> String {
    match sub {
        Some(s) => format!("0x{index:04X}sub{s}"),
        None => format!("0x{index:04X}"),
    }
}

/// Where an object sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Area {
    /// Lenze code = 24575 - index.
    Lenze(u32),
    /// CiA 301 object kept by index.
    Cia,
    /// Skipped, with why.
    Skip(&'static str),
}

/// Lenze's CiA vendor ID (the CiA vendor-ID list: 0x0000003B, Lenze SE).
pub const LENZE_VENDOR_ID: i128 = 0x3B;

/// Highest Lenze code number (codes are C0000..C9999, four digits).
const LENZE_CODE_MAX: u32 = 9999;

fn area(index: u16, lenze: bool) -> Area {
    match index {
        0x0000..=0x0FFF => {
            Area::Skip("data type definition area (CiA 301 §7.4.3), not a parameter")
        }
        0x1010 | 0x1011 => {
            Area::Skip("store / restore parameters: a command (signature write), not a setting")
        }
        0x1200..=0x12FF => Area::Skip(
            "SDO channel parameter: bus configuration ($NODEID COB-IDs), not a drive setting",
        ),
        0x1400..=0x1BFF => Area::Skip(
            "PDO communication / mapping parameter: configured by the CANopen master, not a drive setting",
        ),
        0x2000..=0x5FFF if lenze && LENZE_INDEX_BASE - u32::from(index) <= LENZE_CODE_MAX => {
            Area::Lenze(LENZE_INDEX_BASE - u32::from(index))
        }
        _ => Area::Cia,
    }
}

/// Whether the data sheet is Lenze's (its manufacturer objects are Lenze
/// codes), and the lint that says what decided: `VendorNumber` (Lenze's
/// CiA vendor ID 0x3B) first, else `VendorName` naming Lenze.
fn lenze_vendor(file: &EdsFile, cx: &mut Ctx) -> bool {
    let info = file.section("DeviceInfo");
    let number = info.and_then(|s| s.get("VendorNumber"));
    let name = info.and_then(|s| s.get("VendorName"));
    let number_value = number
        .and_then(|e| parse_int(&e.value))
        .filter(|v| !v.plus_node_id);
    let name_says = name.is_some_and(|e| e.value.to_ascii_lowercase().contains("lenze"));
    let line = |e: Option<&reader::Entry>| e.map_or(0, |e| e.line);
    match (number_value, name_says) {
        (Some(v), _) if v.value == LENZE_VENDOR_ID => {
            cx.lint(
                line(number),
                String::new(),
                format!(
                    "VendorNumber {} is Lenze's CiA vendor ID (0x3B): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types",
                    number.map_or("", |e| e.value.as_str())
                ),
            );
            true
        }
        (Some(v), true) => {
            cx.lint(
                line(number),
                String::new(),
                format!(
                    "VendorNumber 0x{:08X} is not Lenze's (0x3B) though VendorName `{}` names Lenze: the VendorNumber decides; manufacturer objects kept by index with their own CiA types (no x 10000 scaling)",
                    v.value,
                    name.map_or("", |e| e.value.as_str())
                ),
            );
            false
        }
        (None, true) => {
            cx.lint(
                line(name),
                String::new(),
                format!(
                    "VendorName `{}` names Lenze (no VendorNumber to tell): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types",
                    name.map_or("", |e| e.value.as_str())
                ),
            );
            true
        }
        (v, false) => {
            cx.lint(
                line(number.or(name)),
                String::new(),
                format!(
                    "not a Lenze data sheet (VendorNumber {}, VendorName {}): manufacturer objects 0x2000..0x5FFF kept by index with their own CiA types (no x 10000 scaling)",
                    v.map_or_else(|| "not given".to_string(), |v| format!("0x{:08X}", v.value)),
                    name.map_or_else(|| "not given".to_string(), |e| format!("`{}`", e.value))
                ),
            );
            false
        }
    }
}

/// A code ready to be written.
#[derive(Debug, Clone)]
struct Out {
    number: u32,
    index: Option<u16>,
    name: String,
    title: String,
    spec: String,
    ty: ValueType,
    /// The EDS's DataType where the schema type alone does not say it.
    data_type: Option<u16>,
    access_ro: bool,
    subcodes: Option<u32>,
    /// One subindex of a RECORD / ARRAY whose subindexes differ.
    subindex: Option<u8>,
    /// A Lenze code (FIX32 / BITCODED / VS / VO from a Lenze data sheet),
    /// whole or one subindex.
    lenze_code: bool,
    min: Option<String>,
    max: Option<String>,
    default: Option<String>,
    notes: Vec<String>,
    /// Line of the object's section (for lints).
    line: usize,
}

struct Ctx {
    lints: Vec<ImportLint>,
}

impl Ctx {
    fn lint(&mut self, line: usize, object: String, message: impl Into<String>) {
        self.lints.push(ImportLint {
            line,
            object,
            message: message.into(),
        });
    }
}

/// The facts one variable gives, converted.
struct Facts {
    dt: u16,
    acc: Acc,
    min: Option<String>,
    max: Option<String>,
    default: Option<String>,
}

/// Import an EDS / DCF given as bytes.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    let file = reader::parse(bytes).map_err(|e| ImportError {
        line: e.line,
        column: e.column,
        message: e.message,
        help: e.help,
    })?;
    let mut cx = Ctx {
        lints: file
            .lints
            .iter()
            .map(|l| ImportLint {
                line: l.line,
                object: String::new(),
                message: l.message.clone(),
            })
            .collect(),
    };
    let lenze = lenze_vendor(&file, &mut cx);
    let spec_file = file_name(&opts.file);
    let objects = file.objects();
    let mut outs: Vec<Out> = Vec::new();
    let mut parameter_values = 0usize;
    // subindex sections by index
    let mut subs: BTreeMap<u16, Vec<(u8, &Section)>> = BTreeMap::new();
    for (name, sec) in &objects {
        if let ObjectName::Sub(i, s) = name {
            subs.entry(*i).or_default().push((*s, sec));
        }
    }
    for (i, list) in &subs {
        if !objects.contains_key(&ObjectName::Main(*i)) {
            for (s, sec) in list {
                cx.lint(
                    sec.line,
                    obj_text(*i, Some(*s)),
                    format!("no main section [{i:04X}]; skipped"),
                );
            }
        }
    }
    for (name, sec) in &objects {
        let ObjectName::Main(index) = *name else {
            continue;
        };
        let obj = obj_text(index, None);
        let line = sec.line;
        let my_subs: &[(u8, &Section)] = subs.get(&index).map_or(&[], |v| v.as_slice());
        parameter_values += std::iter::once(*sec)
            .chain(my_subs.iter().map(|(_, s)| *s))
            .filter(|s| s.get("ParameterValue").is_some_and(|e| !e.value.is_empty()))
            .count();
        let ar = area(index, lenze);
        if let Area::Skip(why) = ar {
            cx.lint(line, obj, format!("{why}; skipped"));
            continue;
        }
        let ot = match sec.get("ObjectType") {
            None => 7,
            Some(e) if e.value.is_empty() => 7,
            Some(e) => match parse_int(&e.value) {
                Some(IntValue {
                    value,
                    plus_node_id: false,
                    ..
                }) => value,
                _ => {
                    cx.lint(
                        e.line,
                        obj,
                        format!("ObjectType `{}` is not a number; skipped", e.value),
                    );
                    continue;
                }
            },
        };
        let mut vars: Vec<Var<'_>> = Vec::new();
        match ot {
            2 | 7 => {
                if !my_subs.is_empty() {
                    cx.lint(
                        line,
                        obj.clone(),
                        format!(
                            "a {} object has no subindexes; {} [{index:04X}subN] sections ignored",
                            if ot == 2 { "DOMAIN" } else { "VAR" },
                            my_subs.len()
                        ),
                    );
                }
                vars.push(Var {
                    sub: 0,
                    section: sec,
                });
            }
            8 | 9 => {
                let compact = sec
                    .get("CompactSubObj")
                    .and_then(|e| parse_int(&e.value))
                    .map_or(0, |v| v.value);
                if compact > 0 {
                    let n = compact.min(254) as u8;
                    for s in 1..=n {
                        vars.push(Var {
                            sub: s,
                            section: sec,
                        });
                    }
                } else {
                    if let Some(e) = sec.get("SubNumber")
                        && !matches!(parse_int(&e.value), Some(n) if !n.plus_node_id && (0..=0xFF).contains(&n.value))
                    {
                        cx.lint(
                            e.line,
                            obj.clone(),
                            format!(
                                "SubNumber `{}` is not a number of entries (0..255); the {} [{index:04X}subN] sections are used",
                                e.value,
                                my_subs.len()
                            ),
                        );
                    } else if let Some(e) = sec.get("SubNumber")
                        && let Some(n) = parse_int(&e.value)
                        && n.value != my_subs.len() as i128
                    {
                        cx.lint(
                            e.line,
                            obj.clone(),
                            format!(
                                "SubNumber={} but {} [{index:04X}subN] sections found; the sections are used",
                                e.value,
                                my_subs.len()
                            ),
                        );
                    }
                    for (s, ss) in my_subs {
                        vars.push(Var {
                            sub: *s,
                            section: ss,
                        });
                    }
                }
                if vars.is_empty() {
                    cx.lint(line, obj, "ARRAY / RECORD without subindexes; skipped");
                    continue;
                }
            }
            5 | 6 => {
                cx.lint(
                    line,
                    obj,
                    "DEFTYPE / DEFSTRUCT: a type definition, not a parameter; skipped",
                );
                continue;
            }
            other => {
                cx.lint(
                    line,
                    obj,
                    format!("ObjectType {other} is not VAR (7), ARRAY (8), RECORD (9) or DOMAIN (2); skipped"),
                );
                continue;
            }
        }
        let name = sec
            .get("ParameterName")
            .map(|e| e.value.trim().to_string())
            .unwrap_or_default();
        let is_bitcoded = matches!(ar, Area::Lenze(135 | 150));
        let has_subs = ot == 8 || ot == 9;
        // variables -> facts, each subindex its own
        let mut kept: Vec<(u8, Facts, &Section)> = Vec::new();
        for v in &vars {
            let vobj = obj_text(index, has_subs.then_some(v.sub));
            if let Some(f) = var_facts(&mut cx, v, &vobj, ar, is_bitcoded, ot) {
                kept.push((v.sub, f, v.section));
            }
        }
        if kept.is_empty() {
            continue;
        }
        let ro = |a: Acc| matches!(a, Acc::Ro | Acc::Const);
        let title_of = |what: &str| {
            if what.is_empty() {
                match ar {
                    Area::Lenze(c) => format!("C{c:04} (the EDS gives no ParameterName)"),
                    _ => format!("{obj} (the EDS gives no ParameterName)"),
                }
            } else {
                what.to_string()
            }
        };
        let make = |cx: &mut Ctx, sub: Option<u8>, f: &Facts, sec_line: usize, title: String| {
            // None: var_facts linted why the type cannot be carried
            let ty = value_type(ar, is_bitcoded, f.dt)?;
            let vobj = obj_text(index, sub);
            let (mut min, mut max, mut default) = (f.min.clone(), f.max.clone(), f.default.clone());
            order_facts(cx, sec_line, &vobj, ty, &mut min, &mut max, &mut default);
            let mut notes = Vec::new();
            if ty == ValueType::FIX32 && f.dt == 0x0007 {
                notes.push(
                    "UNSIGNED32 in the EDS, FIX32 as page 454 says of Lenze codes".to_string(),
                );
            }
            let by_index = ar == Area::Cia || sub.is_some();
            Some(Out {
                number: match (ar, by_index) {
                    (Area::Lenze(c), false) => c,
                    _ => index_number(index, sub),
                },
                index: by_index.then_some(index),
                name: title.clone(),
                title,
                spec: match sub {
                    Some(s) => format!("{spec_file} [{index:04X}sub{s:X}] line {sec_line}"),
                    None => format!("{spec_file} [{index:04X}] line {line}"),
                },
                ty,
                data_type: (super::dcf::data_type(ty) != Some(f.dt)).then_some(f.dt),
                access_ro: ro(f.acc),
                subcodes: None,
                subindex: sub,
                lenze_code: matches!(ar, Area::Lenze(_)),
                min,
                max,
                default,
                notes,
                line: sec_line,
            })
        };
        if !has_subs {
            outs.extend(make(&mut cx, None, &kept[0].1, line, title_of(&name)));
            continue;
        }
        // An ARRAY / RECORD is one code with `subcodes = n` only when its
        // subindexes 1..=n are all kept and say the same (type, access,
        // limits, default); otherwise each kept subindex is a code of its
        // own and a left-out subindex cannot be named.
        let top = kept.iter().map(|(s, _, _)| *s).max().unwrap_or(0);
        let all_there = kept.len() == usize::from(top) && kept.iter().all(|(s, _, _)| *s >= 1);
        let f0 = &kept[0].1;
        let uniform = all_there
            && kept.iter().all(|(_, f, _)| {
                f.dt == f0.dt
                    && ro(f.acc) == ro(f0.acc)
                    && f.min == f0.min
                    && f.max == f0.max
                    && f.default == f0.default
            });
        if uniform {
            if let Some(mut o) = make(&mut cx, None, f0, line, title_of(&name)) {
                o.subcodes = Some(u32::from(top));
                outs.push(o);
            }
            continue;
        }
        let missing: Vec<String> = (1..=top)
            .filter(|s| !kept.iter().any(|(k, _, _)| k == s))
            .map(|s| s.to_string())
            .collect();
        let gaps = !missing.is_empty();
        let list = |v: Vec<String>| v.join(", ");
        let same_facts = kept.iter().all(|(_, f, _)| {
            f.dt == f0.dt
                && ro(f.acc) == ro(f0.acc)
                && f.min == f0.min
                && f.max == f0.max
                && f.default == f0.default
        });
        let why = match (same_facts, missing.is_empty()) {
            (false, true) => format!(
                "subindexes {} differ in type, access, limits or default",
                list(kept.iter().map(|(s, _, _)| s.to_string()).collect())
            ),
            (false, false) => format!(
                "subindexes {} differ in type, access, limits or default, and {} are not kept",
                list(kept.iter().map(|(s, _, _)| s.to_string()).collect()),
                list(missing)
            ),
            _ => format!("subindexes {} are not kept", list(missing)),
        };
        cx.lint(
            line,
            obj.clone(),
            format!(
                "{why}: each kept subindex is a code of its own (index 0x{index:04X} + subindex) with the facts of its own section{}",
                if gaps {
                    "; a set cannot name the others"
                } else {
                    ""
                }
            ),
        );
        for (sub, f, ssec) in &kept {
            let own = ssec
                .get("ParameterName")
                .map(|e| e.value.trim().to_string())
                .filter(|n| !n.is_empty() && !std::ptr::eq(*ssec, *sec));
            let title = match own {
                Some(n) if !name.is_empty() => format!("{name}: {n}"),
                Some(n) => n,
                None => format!("{} sub{sub}", title_of(&name)),
            };
            outs.extend(make(&mut cx, Some(*sub), f, ssec.line, title));
        }
    }
    if parameter_values > 0 {
        cx.lint(
            0,
            String::new(),
            format!(
                "{parameter_values} ParameterValue entries ignored: a schema holds defaults and limits, not a configuration"
            ),
        );
    }
    if outs.is_empty() {
        return Err(ImportError {
            line: 0,
            column: 0,
            message: "no object of the file could be imported".into(),
            help: "see the lints above for why each object was skipped".into(),
        });
    }
    outs.sort_by_key(|o| o.number);
    assign_names(&mut outs);
    let id = opts.id.clone().unwrap_or_else(|| default_id(&opts.file));
    if crate::schema::BUILTIN_FILES.iter().any(|(path, _)| {
        path.strip_prefix("schemas/")
            .and_then(|f| f.strip_suffix(".toml"))
            == Some(id.as_str())
    }) {
        return Err(ImportError {
            line: 0,
            column: 0,
            message: format!("schema id `{id}` is a built-in schema"),
            help: "give the imported schema its own id with --id".into(),
        });
    }
    let toml = render(&file, &id, opts, &outs);
    // self-check: the written schema must load and pass `schema check`
    let mut reg = Registry::new();
    let schema = reg
        .add_source(SourceFile::new(format!("{id}.toml"), toml.clone()))
        .map_err(|e| ImportError {
            line: 0,
            column: 0,
            message: format!(
                "internal error: the imported schema does not load: {}",
                e.message
            ),
            help: "report this with the EDS file".into(),
        })?;
    if let Some(f) = crate::check::check_schema(&schema).first() {
        return Err(ImportError {
            line: 0,
            column: 0,
            message: format!(
                "internal error: the imported schema fails `schema check`: {} (line {})",
                f.message, f.location.line
            ),
            help: "report this with the EDS file".into(),
        });
    }
    cx.lints.sort_by_key(|l| l.line);
    let cia = outs.iter().filter(|o| !o.lenze_code).count();
    Ok(Imported {
        toml,
        id,
        lenze_codes: outs.len() - cia,
        cia_objects: cia,
        lints: cx.lints,
    })
}

fn value_type(ar: Area, bitcoded: bool, dt: u16) -> Option<ValueType> {
    match ar {
        Area::Lenze(_) if bitcoded => match dt {
            0x0002..=0x0007 => Some(ValueType::BITCODED),
            _ => None,
        },
        Area::Lenze(_) => match dt {
            0x0004 | 0x0007 => Some(ValueType::FIX32),
            0x0009 => Some(ValueType::VS),
            0x000A => Some(ValueType::VO),
            _ => None,
        },
        Area::Cia => cia_type(dt),
        Area::Skip(_) => None,
    }
}

/// The facts of one variable, or `None` (with a lint) when it is skipped.
fn var_facts(
    cx: &mut Ctx,
    v: &Var<'_>,
    obj: &str,
    ar: Area,
    bitcoded: bool,
    ot: i128,
) -> Option<Facts> {
    let line = v.line();
    let obj = obj.to_string();
    let dt_entry = v.key("DataType");
    let dt = match dt_entry.map(|e| (e, parse_int(&e.value))) {
        None => {
            cx.lint(line, obj, "no DataType; skipped");
            return None;
        }
        Some((
            _,
            Some(IntValue {
                value,
                plus_node_id: false,
                ..
            }),
        )) if (0..=0xFFFF).contains(&value) => value as u16,
        Some((e, _)) => {
            cx.lint(
                e.line,
                obj,
                format!("DataType `{}` is not a type number; skipped", e.value),
            );
            return None;
        }
    };
    let acc = match v.key("AccessType") {
        None => {
            cx.lint(line, obj, "no AccessType; skipped");
            return None;
        }
        Some(e) => match e.value.to_ascii_lowercase().as_str() {
            "ro" => Acc::Ro,
            "const" => Acc::Const,
            "wo" => Acc::Wo,
            "rw" | "rwr" | "rww" => Acc::Rw,
            _ => {
                cx.lint(
                    e.line,
                    obj,
                    format!(
                        "AccessType `{}` is not ro, wo, rw, rwr, rww or const; skipped",
                        e.value
                    ),
                );
                return None;
            }
        },
    };
    // sub 0 of an ARRAY / RECORD: the number of entries
    if (ot == 8 || ot == 9) && v.sub == 0 {
        if dt == 0x0005 && matches!(acc, Acc::Ro | Acc::Const) {
            return None;
        }
        cx.lint(
            line,
            obj,
            format!(
                "number of entries is {} {}; it is the structure, not a setting; skipped",
                data_type_name(dt),
                if matches!(acc, Acc::Ro | Acc::Const) {
                    "read-only"
                } else {
                    "writable"
                }
            ),
        );
        return None;
    }
    if dt == 0x000F || ot == 2 {
        cx.lint(line, obj, "DOMAIN object (no fixed size or type); skipped");
        return None;
    }
    let Some(ty) = value_type(ar, bitcoded, dt) else {
        let why = match ar {
            Area::Lenze(c) if bitcoded => format!(
                "DataType {} for C{c:04}, which page 454 says is bit-coded (an integer type); skipped",
                data_type_name(dt)
            ),
            Area::Lenze(_) => format!(
                "DataType {} in the Lenze code range: page 454 transmits Lenze codes as FIX32 (4 bytes); skipped",
                data_type_name(dt)
            ),
            _ => format!(
                "DataType {} is not a type driveset carries; skipped",
                data_type_name(dt)
            ),
        };
        cx.lint(line, obj, why);
        return None;
    };
    if acc == Acc::Wo {
        cx.lint(
            v.key("AccessType").map_or(line, |e| e.line),
            obj,
            "write-only (wo): driveset reads back every value it writes; skipped",
        );
        return None;
    }
    let mut acc = acc;
    if let Some(e) = v.key("ObjFlags")
        && !e.value.is_empty()
    {
        match parse_int(&e.value) {
            Some(f) if f.value & 2 != 0 => {
                cx.lint(e.line, obj, "ObjFlags bit 1 (refuse read on scan): driveset reads every code it holds; skipped");
                return None;
            }
            Some(f) if f.value & 1 != 0 && acc == Acc::Rw => {
                cx.lint(
                    e.line,
                    obj.clone(),
                    "ObjFlags bit 0 (refuse write on download): kept read-only",
                );
                acc = Acc::Ro;
            }
            Some(_) => {}
            None => cx.lint(
                e.line,
                obj.clone(),
                format!("ObjFlags `{}` is not a number; ignored", e.value),
            ),
        }
    }
    if ty == ValueType::BITCODED && dt != 0x0007 {
        cx.lint(
            line,
            obj.clone(),
            format!(
                "DataType {}: typed BITCODED (u32) as page 454 says of C0135 / C0150",
                data_type_name(dt)
            ),
        );
    }
    if ty == ValueType::FIX32 && dt == 0x0007 {
        cx.lint(line, obj.clone(), "DataType UNSIGNED32 (0x0007) read as FIX32 (page 454: Lenze codes are FIX32, value x 10000)");
    }
    if dt == 0x0001 {
        cx.lint(
            line,
            obj.clone(),
            "BOOLEAN kept as UNSIGNED8 (one byte, 0 or 1)",
        );
    }
    let mut fact = |key: &str| -> Option<String> {
        let e = v.key(key)?;
        convert(cx, e.line, &obj, key, &e.value, ty)
    };
    let mut min = fact("LowLimit");
    let mut max = fact("HighLimit");
    let default = fact("DefaultValue");
    if dt == 0x0001 {
        min.get_or_insert_with(|| "0".into());
        max.get_or_insert_with(|| "1".into());
    }
    Some(Facts {
        dt,
        acc,
        min,
        max,
        default,
    })
}

/// An EDS value text -> engineering text for `ty`, or `None` with a lint.
fn convert(
    cx: &mut Ctx,
    line: usize,
    obj: &str,
    key: &str,
    text: &str,
    ty: ValueType,
) -> Option<String> {
    let obj = obj.to_string();
    if text.trim().is_empty() {
        cx.lint(line, obj, format!("empty {key}; left unset"));
        return None;
    }
    match ty {
        ValueType::VS => {
            if key != "DefaultValue" {
                return None;
            }
            match check_vs_text(text) {
                Ok(()) => Some(text.to_string()),
                Err(m) => {
                    cx.lint(
                        line,
                        obj,
                        format!("{key} {text:?} is not VS text ({m}); left unset"),
                    );
                    None
                }
            }
        }
        ValueType::VO => {
            if key != "DefaultValue" {
                return None;
            }
            match parse_octets(text) {
                Some(_) => Some(text.trim().to_ascii_lowercase()),
                None => {
                    cx.lint(
                        line,
                        obj,
                        format!("{key} `{text}` is not hex octets; left unset"),
                    );
                    None
                }
            }
        }
        _ => {
            let Some(v) = parse_int(text) else {
                cx.lint(
                    line,
                    obj,
                    format!("{key} `{text}` is not an integer; left unset"),
                );
                return None;
            };
            if v.plus_node_id {
                cx.lint(
                    line,
                    obj,
                    format!("{key} `{text}` depends on the node id; left unset"),
                );
                return None;
            }
            if let Some(o) = v.octal_differs {
                cx.lint(
                    line,
                    obj.clone(),
                    format!("{key} `{text}` read as decimal {} (a leading 0 means octal in C, giving {o})", v.value),
                );
            }
            let (lo, hi) = ty.raw_range(None).unwrap_or((0, 0));
            let mut raw = v.value;
            // a hex pattern for a signed type is two's complement
            if v.hex && lo < 0 && raw > i128::from(hi) && raw <= 2 * i128::from(hi) + 1 {
                raw -= 2 * i128::from(hi) + 2;
            }
            if raw < i128::from(lo) || raw > i128::from(hi) {
                cx.lint(
                    line,
                    obj,
                    format!(
                        "{key} `{text}` is outside {} ({lo}..={hi}); left unset",
                        ty.name()
                    ),
                );
                return None;
            }
            let factor = match ty.repr() {
                crate::value::Repr::Scaled(f) => f,
                _ => 1,
            };
            Decimal::from_ratio(raw, factor).map(|d| d.to_string())
        }
    }
}

fn order_facts(
    cx: &mut Ctx,
    line: usize,
    obj: &str,
    ty: ValueType,
    min: &mut Option<String>,
    max: &mut Option<String>,
    default: &mut Option<String>,
) {
    if matches!(ty, ValueType::VS | ValueType::VO) {
        return;
    }
    let d = |s: &Option<String>| s.as_deref().and_then(|t| Decimal::parse(t).ok());
    if let (Some(a), Some(b)) = (d(min), d(max))
        && a > b
    {
        cx.lint(
            line,
            obj.to_string(),
            format!(
                "LowLimit {} is above HighLimit {}; both left unset",
                min.as_deref().unwrap_or(""),
                max.as_deref().unwrap_or("")
            ),
        );
        *min = None;
        *max = None;
    }
    if let Some(v) = d(default) {
        let below = d(min).is_some_and(|m| v < m);
        let above = d(max).is_some_and(|m| v > m);
        if below || above {
            cx.lint(
                line,
                obj.to_string(),
                format!(
                    "DefaultValue {} is outside LowLimit..HighLimit; left unset",
                    default.as_deref().unwrap_or("")
                ),
            );
            *default = None;
        }
    }
}

/// ParameterName -> a schema name: lowercase ASCII letters, digits and `_`,
/// starting with a letter, not shaped like a code number, unique.
fn sanitise(name: &str) -> String {
    let mut s = String::new();
    for c in name.chars() {
        let t: &str = match c {
            'ä' | 'Ä' => "ae",
            'ö' | 'Ö' => "oe",
            'ü' | 'Ü' => "ue",
            'ß' => "ss",
            _ => "",
        };
        if !t.is_empty() {
            s.push_str(t);
        } else if c.is_ascii_alphanumeric() {
            s.push(c.to_ascii_lowercase());
        } else if !s.ends_with('_') {
            s.push('_');
        }
    }
    let mut s: String = s.trim_matches('_').chars().take(48).collect();
    while s.ends_with('_') {
        s.pop();
    }
    s
}

fn assign_names(outs: &mut [Out]) {
    let mut used: HashSet<String> = HashSet::new();
    for o in outs.iter_mut() {
        let tag = match (o.index, o.subindex) {
            (Some(i), Some(s)) => format!("obj_{i:04x}sub{s}"),
            (Some(i), None) => format!("obj_{i:04x}"),
            _ => format!("code_{:04}", o.number),
        };
        let mut base = sanitise(&o.name);
        if base.is_empty() || looks_numeric_key(&base) {
            base = tag.clone();
        } else if !base.starts_with(|c: char| c.is_ascii_lowercase()) {
            base = format!("{tag}_{base}");
        }
        let mut name = base.clone();
        if used.contains(&name) {
            name = format!("{base}_{tag}");
        }
        let mut n = 2;
        while used.contains(&name) {
            name = format!("{base}_{tag}_{n}");
            n += 1;
        }
        used.insert(name.clone());
        o.name = name;
    }
}

/// A TOML basic string.
pub(crate) fn toml_str(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if (c as u32) < 0x20 || c as u32 == 0x7F => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The role of Lenze code `number` in the built-in `lenze-ecs` schema.
fn builtin_role(number: u32) -> Option<crate::role::Role> {
    static ECS: std::sync::OnceLock<Option<std::sync::Arc<crate::Schema>>> =
        std::sync::OnceLock::new();
    ECS.get_or_init(|| {
        // the family on CAN SDO (ECS) is the one a CiA 306 file describes
        let family = crate::BusProtocol::CanSdo.families().next()?;
        crate::Registry::builtin()
            .ok()
            .and_then(|r| r.get(family.descriptor().schema_id))
    })
    .as_ref()
    .and_then(|s| s.role_of(number))
}

fn render(file: &EdsFile, id: &str, opts: &ImportOptions, outs: &[Out]) -> String {
    let info = |sec: &str, key: &str| {
        file.section(sec)
            .and_then(|s| s.get(key))
            .map(|e| e.value.clone())
            .filter(|v| !v.is_empty())
    };
    let fictional = id.starts_with("fictional-");
    let vendor = info("DeviceInfo", "VendorName");
    let product = info("DeviceInfo", "ProductName");
    let what = match (&vendor, &product) {
        (Some(v), Some(p)) => format!("{v} {p}"),
        (None, Some(p)) => p.clone(),
        (Some(v), None) => v.clone(),
        (None, None) => "CANopen device".into(),
    };
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Imported by `driveset schema import` from {} (CiA 306 EDS / DCF).",
        file_name(&opts.file)
    );
    t.push_str(
        "# Lenze codes (a Lenze data sheet only): index = 24575 - code (lenze-system-bus-can-sdo.txt,\n\
         # p. 454), FIX32 (value x 10000) except the bit-coded C0135 / C0150. Other objects are\n\
         # kept by `index` (number = 65536 + index) with their own CiA 301 type; a RECORD / ARRAY\n\
         # entry with facts of its own by `index` + `subindex`. Facts come from the file, not\n\
         # from a Lenze manual.\n\n",
    );
    t.push_str("[schema]\n");
    let _ = writeln!(t, "id = {}", toml_str(id));
    let title = format!(
        "{}{what}, imported from {}",
        if fictional { "FICTIONAL: " } else { "" },
        file_name(&opts.file)
    );
    let _ = writeln!(t, "title = {}", toml_str(&title));
    t.push_str("protocol = \"lenze-can-sdo\"\ncode_style = \"lenze\"\n");
    let _ = writeln!(t, "spec = {}", toml_str(file_name(&opts.file)));
    if fictional {
        t.push_str("fictional = true\n");
    }
    let _ = writeln!(t, "\n[schema.can]\nindex_base = {LENZE_INDEX_BASE}");
    let mut sorted: Vec<&Out> = outs.iter().collect();
    sorted.sort_by_key(|o| o.number);
    for o in sorted {
        t.push_str("\n[[code]]\n");
        let _ = writeln!(t, "number = {}", o.number);
        if let Some(i) = o.index {
            let _ = writeln!(t, "index = 0x{i:04X}");
        }
        if let Some(s) = o.subindex {
            let _ = writeln!(t, "subindex = {s}");
        }
        let _ = writeln!(t, "name = {}", toml_str(&o.name));
        let _ = writeln!(t, "title = {}", toml_str(&o.title));
        let _ = writeln!(t, "spec = {}", toml_str(&o.spec));
        let _ = writeln!(t, "type = {}", toml_str(o.ty.name()));
        if let Some(dt) = o.data_type {
            let _ = writeln!(t, "data_type = 0x{dt:04X}");
        }
        if let Some(s) = o.subcodes {
            let _ = writeln!(t, "subcodes = {s}");
        }
        for (k, v) in [("min", &o.min), ("max", &o.max), ("default", &o.default)] {
            if let Some(v) = v {
                let _ = writeln!(t, "{k} = {}", toml_str(v));
            }
        }
        let _ = writeln!(
            t,
            "access = {}",
            if o.access_ro { "\"ro\"" } else { "\"rw\"" }
        );
        // The role a Lenze code has in the built-in lenze-ecs schema (C0135
        // control word, C0150 status word): an imported schema keeps it, so
        // a set against it cannot start a motor either.
        if o.index.is_none()
            && let Some(role) = builtin_role(o.number)
        {
            let _ = writeln!(t, "role = \"{}\"", role.as_str());
        }
        if !o.notes.is_empty() {
            let _ = writeln!(t, "note = {}", toml_str(&o.notes.join("; ")));
        }
        let _ = o.line;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> ImportOptions {
        ImportOptions {
            id: Some("ecs-test".into()),
            file: "t.eds".into(),
        }
    }

    fn lints(i: &Imported) -> Vec<String> {
        i.lints.iter().map(|l| l.render("t.eds")).collect()
    }

    /// The code block of `number` in the written schema.
    fn block(toml: &str, number: u32) -> String {
        let start = toml
            .find(&format!("[[code]]\nnumber = {number}\n"))
            .unwrap_or_else(|| panic!("no code {number} in\n{toml}"));
        let rest = &toml[start..];
        let end = rest[1..].find("\n[[code]]").map_or(rest.len(), |e| e + 1);
        rest[..end].trim_end().to_string()
    }

    /// What python-canopen's users report (issues #313, #385, #49/#50):
    /// empty PDOMapping, `$NODEID+0x580`, `001`, no [FileInfo] /
    /// [DeviceInfo], duplicate keys, lowercase keys, hex in any case.
    const MALFORMED: &str = "\
[5FF4]
parametername=Max speed
ObjectType=0x7
datatype=0x0004
AccessType=RW
DefaultValue=001
LowLimit=0X0
HighLimit=0x1a
HighLimit=99
PDOMapping=

[1200]
ParameterName=Server SDO parameter
ObjectType=0x9
SubNumber=2

[1200sub1]
ParameterName=COB-ID server to client
DataType=0x0007
AccessType=ro
DefaultValue=$NODEID+0x580

[1014]
ParameterName=COB-ID EMCY
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x80+$NODEID
PDOMapping=

[5FF5]
ParameterName=Jog speed
DataType=0x0004
AccessType=rww
DefaultValue=010
LowLimit=
HighLimit=00100000

[5FF6sub1]
ParameterName=orphan
DataType=0x0004
AccessType=rw
[DeviceInfo]
VendorNumber=0x0000003B
";

    /// Appended to a test file: a Lenze data sheet (lint at `line`).
    const LENZE: &str = "[DeviceInfo]\nVendorName=Lenze\n";

    fn lenze_lint(line: usize) -> String {
        format!(
            "t.eds:{line}: VendorName `Lenze` names Lenze (no VendorNumber to tell): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types"
        )
    }

    #[test]
    fn malformed_vendor_file_exact_lints_and_codes() {
        let i = import(MALFORMED.as_bytes(), &opts()).unwrap();
        assert_eq!(
            lints(&i),
            vec![
                "t.eds:9: key HighLimit given twice in [5FF4] (first at line 8); the first value is kept",
                "t.eds:12: 0x1200: SDO channel parameter: bus configuration ($NODEID COB-IDs), not a drive setting; skipped",
                "t.eds:28: 0x1014: DefaultValue `0x80+$NODEID` depends on the node id; left unset",
                "t.eds:35: 0x5FF5: DefaultValue `010` read as decimal 10 (a leading 0 means octal in C, giving 8)",
                "t.eds:36: 0x5FF5: empty LowLimit; left unset",
                "t.eds:37: 0x5FF5: HighLimit `00100000` read as decimal 100000 (a leading 0 means octal in C, giving 32768)",
                "t.eds:39: 0x5FF6sub1: no main section [5FF6]; skipped",
                "t.eds:44: VendorNumber 0x0000003B is Lenze's CiA vendor ID (0x3B): objects 0x38F0..0x5FFF are Lenze codes C9999..C0000 (code = 24575 - index, FIX32 value x 10000), 0x2000..0x38EF kept by index with their own types",
            ]
        );
        assert_eq!((i.lenze_codes, i.cia_objects), (2, 1));
        assert_eq!(
            block(&i.toml, 11),
            "[[code]]\nnumber = 11\nname = \"max_speed\"\ntitle = \"Max speed\"\nspec = \"t.eds [5FF4] line 1\"\ntype = \"FIX32\"\nmin = \"0\"\nmax = \"0.0026\"\ndefault = \"0.0001\"\naccess = \"rw\""
        );
        assert_eq!(
            block(&i.toml, 10),
            "[[code]]\nnumber = 10\nname = \"jog_speed\"\ntitle = \"Jog speed\"\nspec = \"t.eds [5FF5] line 31\"\ntype = \"FIX32\"\nmax = \"10\"\ndefault = \"0.001\"\naccess = \"rw\""
        );
        assert_eq!(
            block(&i.toml, 0x1_1014),
            "[[code]]\nnumber = 69652\nindex = 0x1014\nname = \"cob_id_emcy\"\ntitle = \"COB-ID EMCY\"\nspec = \"t.eds [1014] line 23\"\ntype = \"UNSIGNED32\"\naccess = \"ro\""
        );
        assert!(
            i.toml.contains("[schema]\nid = \"ecs-test\"\n"),
            "{}",
            i.toml
        );
    }

    #[test]
    fn fix32_bitcoded_limits_and_twos_complement() {
        let text = "\
[5F78]
ParameterName=C0135
DataType=0x0004
AccessType=rw
DefaultValue=0x0401
[5FFE]
ParameterName=Offset
DataType=0x0004
AccessType=rw
DefaultValue=0xFFFFFFFF
LowLimit=-2147483648
HighLimit=2147483647
[5FFD]
ParameterName=Offset
DataType=0x0004
AccessType=const
DefaultValue=5
LowLimit=9
HighLimit=1
";
        let text = format!("{text}{LENZE}");
        let i = import(text.as_bytes(), &opts()).unwrap();
        assert_eq!(
            lints(&i),
            vec![
                "t.eds:1: 0x5F78: DataType INTEGER32 (0x0004): typed BITCODED (u32) as page 454 says of C0135 / C0150".to_string(),
                "t.eds:13: 0x5FFD: LowLimit 0.0009 is above HighLimit 0.0001; both left unset".to_string(),
                lenze_lint(21),
            ]
        );
        assert_eq!(
            block(&i.toml, 135),
            "[[code]]\nnumber = 135\nname = \"code_0135\"\ntitle = \"C0135\"\nspec = \"t.eds [5F78] line 1\"\ntype = \"BITCODED\"\ndata_type = 0x0004\ndefault = \"1025\"\naccess = \"rw\"\nrole = \"control-word\""
        );
        assert_eq!(
            block(&i.toml, 1),
            "[[code]]\nnumber = 1\nname = \"offset\"\ntitle = \"Offset\"\nspec = \"t.eds [5FFE] line 6\"\ntype = \"FIX32\"\nmin = \"-214748.3648\"\nmax = \"214748.3647\"\ndefault = \"-0.0001\"\naccess = \"rw\""
        );
        // a name used twice gets the code appended
        assert_eq!(
            block(&i.toml, 2),
            "[[code]]\nnumber = 2\nname = \"offset_code_0002\"\ntitle = \"Offset\"\nspec = \"t.eds [5FFD] line 13\"\ntype = \"FIX32\"\ndefault = \"0.0005\"\naccess = \"ro\""
        );
    }

    #[test]
    fn compact_sub_obj_and_mixed_records() {
        let text = "\
[4C63]
ParameterName=Setpoints
ObjectType=0x8
CompactSubObj=3
DataType=0x0004
AccessType=rw
DefaultValue=10000
[6000]
ParameterName=Mixed
ObjectType=0x9
SubNumber=2
[6000sub1]
ParameterName=a
DataType=0x0007
AccessType=rw
[6000sub2]
ParameterName=b
DataType=0x0005
AccessType=rw
[6001]
ParameterName=Flag
DataType=0x0001
AccessType=rw
DefaultValue=1
";
        let text = format!("{text}{LENZE}");
        let i = import(text.as_bytes(), &opts()).unwrap();
        assert_eq!(
            lints(&i),
            vec![
                "t.eds:8: 0x6000: subindexes 1, 2 differ in type, access, limits or default: each kept subindex is a code of its own (index 0x6000 + subindex) with the facts of its own section".to_string(),
                "t.eds:20: 0x6001: BOOLEAN kept as UNSIGNED8 (one byte, 0 or 1)".to_string(),
                lenze_lint(26),
            ]
        );
        // a record whose subindexes differ in type: each its own code
        assert_eq!(
            block(&i.toml, 0x100_0000 + 0x6000 * 256 + 1),
            "[[code]]\nnumber = 23068673\nindex = 0x6000\nsubindex = 1\nname = \"mixed_a\"\ntitle = \"Mixed: a\"\nspec = \"t.eds [6000sub1] line 12\"\ntype = \"UNSIGNED32\"\naccess = \"rw\""
        );
        assert_eq!(
            block(&i.toml, 0x100_0000 + 0x6000 * 256 + 2),
            "[[code]]\nnumber = 23068674\nindex = 0x6000\nsubindex = 2\nname = \"mixed_b\"\ntitle = \"Mixed: b\"\nspec = \"t.eds [6000sub2] line 16\"\ntype = \"UNSIGNED8\"\naccess = \"rw\""
        );
        assert_eq!(
            block(&i.toml, 5020),
            "[[code]]\nnumber = 5020\nname = \"setpoints\"\ntitle = \"Setpoints\"\nspec = \"t.eds [4C63] line 1\"\ntype = \"FIX32\"\nsubcodes = 3\ndefault = \"1\"\naccess = \"rw\""
        );
        assert_eq!(
            block(&i.toml, 0x1_6001),
            "[[code]]\nnumber = 90113\nindex = 0x6001\nname = \"flag\"\ntitle = \"Flag\"\nspec = \"t.eds [6001] line 20\"\ntype = \"UNSIGNED8\"\ndata_type = 0x0001\nmin = \"0\"\nmax = \"1\"\ndefault = \"1\"\naccess = \"rw\""
        );
    }

    #[test]
    fn nothing_importable_and_not_an_eds_are_errors() {
        let e = import(b"[1400]\nParameterName=x\n", &opts()).unwrap_err();
        assert_eq!(e.message, "no object of the file could be imported");
        let e = import(b"hello\n", &opts()).unwrap_err();
        assert_eq!(
            e.message,
            "no object section ([1000], [5FF4], [1018sub1], ...): not a CiA 306 EDS / DCF"
        );
    }

    #[test]
    fn builtin_ids_are_refused() {
        let o = ImportOptions {
            id: Some("lenze-ecs".into()),
            file: "t.eds".into(),
        };
        let e = import(MALFORMED.as_bytes(), &o).unwrap_err();
        assert_eq!(e.message, "schema id `lenze-ecs` is a built-in schema");
    }

    #[test]
    fn default_ids() {
        assert_eq!(default_id("dir/ECS Axis_v1.2.eds"), "ecs-axis-v1-2");
        assert_eq!(default_id("x/.eds"), "imported-eds");
        assert_eq!(default_id("fictional-ecs-axis.eds"), "fictional-ecs-axis");
    }

    const FIXTURE: &[u8] = include_bytes!("../../../../tests/data/eds/fictional-ecs-axis.eds");

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Never panics on any input; an imported schema always passes
        /// `schema check` (import() checks it itself and errs otherwise).
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..600)) {
            let _ = import(&bytes, &opts());
        }

        /// The vendor fixture with one line replaced by random text.
        #[test]
        fn mutated_fixture_never_fails_internally(line in 0usize..700, junk in "[ -~]{0,40}") {
            let text = String::from_utf8_lossy(FIXTURE);
            let mut lines: Vec<&str> = text.lines().collect();
            if line < lines.len() {
                lines[line] = &junk;
            }
            let joined = lines.join("\n");
            if let Err(e) = import(joined.as_bytes(), &opts()) {
                proptest::prop_assert!(!e.message.starts_with("internal error"), "{}", e.message);
            }
        }
    }
}
