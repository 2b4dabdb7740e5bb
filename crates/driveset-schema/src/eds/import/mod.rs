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
//!
//! Rooms: this file holds the options, results, lints and the walk over
//! the file's objects ([`import`]); [`objects`] classifies an object (its
//! area, CiA 301 data type, access, the vendor); [`facts`] converts one
//! variable's type, access and limits; [`render`] names the codes and
//! writes the schema file.

mod facts;
mod objects;
mod render;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use crate::eds::reader::{self, IntValue, ObjectName, Section, parse_int};
use crate::error::SourceFile;
use crate::schema::{Registry, index_number};
use crate::value::ValueType;

use facts::{Facts, order_facts, var_facts};
use objects::{Acc, Area, Var, area, data_type_name, lenze_vendor, obj_text, value_type};
use render::{Out, assign_names, render};

pub use objects::LENZE_VENDOR_ID;

/// The Lenze index base (p. 454: index = 24575 - code).
pub const LENZE_INDEX_BASE: u32 = 24575;

/// CiA 301 0x1010 "store parameters": sub 1 "save all parameters" stores
/// when written with the signature "save" (0x65766173, CiA 301 §7.5.2.13).
pub const STORE_INDEX: u16 = 0x1010;

/// The "save" signature (ASCII `s a v e`, little-endian: 0x65766173).
pub const SAVE_SIGNATURE: i64 = 0x6576_6173;

/// 0x1010 with a writable UNSIGNED32 sub 1: the schema's store step
/// (`[schema.store] keeps = "on-command"`), kept as a code with role
/// `command` (a set never writes it; the upload's store step does).
fn store_step(
    cx: &mut Ctx,
    spec_file: &str,
    main: &Section,
    subs: &[(u8, &Section)],
) -> Option<Out> {
    let (_, sec) = subs.iter().find(|(s, _)| *s == 1)?;
    let dt = sec.get("DataType").and_then(|e| parse_int(&e.value))?.value;
    let acc = sec
        .get("AccessType")
        .map(|e| e.value.trim().to_ascii_lowercase())
        .unwrap_or_default();
    if dt != 0x0007 || !matches!(acc.as_str(), "rw" | "wo" | "rww" | "rwr") {
        return None;
    }
    cx.lint(
        main.line,
        obj_text(STORE_INDEX, None),
        "store parameters: sub 1 (save all parameters) kept as the store step, [schema.store] keeps = \"on-command\" with \"save\" = 0x65766173 (CiA 301); a set cannot write it",
    );
    Some(Out {
        number: index_number(STORE_INDEX, Some(1)),
        index: Some(STORE_INDEX),
        name: "store_parameters".into(),
        title: {
            let name = |s: &Section| {
                s.get("ParameterName")
                    .map(|e| e.value.trim().to_string())
                    .filter(|n| !n.is_empty())
            };
            match (name(main), name(sec)) {
                (Some(m), Some(s)) => format!("{m}: {s}"),
                (None, Some(s)) => s,
                (Some(m), None) => format!("{m} sub1"),
                (None, None) => "Store parameters: save all parameters".into(),
            }
        },
        spec: format!("{spec_file} [1010sub1] line {}", sec.line),
        ty: ValueType::UNSIGNED32,
        data_type: None,
        access_ro: false,
        subcodes: None,
        subindex: Some(1),
        lenze_code: false,
        min: None,
        max: None,
        default: None,
        notes: vec![
            "CiA 301 0x1010 sub 1: writing \"save\" (0x65766173) stores every parameter; a read gives the storage functionality (bit 0: on command)".into(),
        ],
        line: sec.line,
        store: true,
    })
}

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
pub(super) fn file_name(path: &str) -> &str {
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

pub(super) struct Ctx {
    pub(super) lints: Vec<ImportLint>,
}

impl Ctx {
    pub(super) fn lint(&mut self, line: usize, object: String, message: impl Into<String>) {
        self.lints.push(ImportLint {
            line,
            object,
            message: message.into(),
        });
    }
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
        if index == STORE_INDEX
            && let Some(out) = store_step(&mut cx, spec_file, sec, my_subs)
        {
            outs.push(out);
            continue;
        }
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
                store: false,
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
