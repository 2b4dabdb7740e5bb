//! Writing the imported schema: a code ready to be written ([`Out`]), its
//! name (sanitised, unique), and the schema file's TOML text
//! (docs/file-formats.md, "Imported schemas").

use std::collections::HashSet;
use std::fmt::Write as _;

use crate::eds::reader::EdsFile;
use crate::schema::looks_numeric_key;
use crate::value::ValueType;

use super::{ImportOptions, LENZE_INDEX_BASE, file_name};

/// A code ready to be written.
#[derive(Debug, Clone)]
pub(super) struct Out {
    pub(super) number: u32,
    pub(super) index: Option<u16>,
    pub(super) name: String,
    pub(super) title: String,
    pub(super) spec: String,
    pub(super) ty: ValueType,
    /// The EDS's DataType where the schema type alone does not say it.
    pub(super) data_type: Option<u16>,
    pub(super) access_ro: bool,
    pub(super) subcodes: Option<u32>,
    /// One subindex of a RECORD / ARRAY whose subindexes differ.
    pub(super) subindex: Option<u8>,
    /// A Lenze code (FIX32 / BITCODED / VS / VO from a Lenze data sheet),
    /// whole or one subindex.
    pub(super) lenze_code: bool,
    pub(super) min: Option<String>,
    pub(super) max: Option<String>,
    pub(super) default: Option<String>,
    pub(super) notes: Vec<String>,
    /// Line of the object's section (for lints).
    pub(super) line: usize,
    /// CiA 301 0x1010 sub 1: the store step (role `command`).
    pub(super) store: bool,
}

/// ParameterName -> a schema name: lowercase ASCII letters, digits and `_`,
/// starting with a letter, not shaped like a code number, unique.
pub(super) fn sanitise(name: &str) -> String {
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

pub(super) fn assign_names(outs: &mut [Out]) {
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
pub(super) fn builtin_role(number: u32) -> Option<crate::role::Role> {
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

pub(super) fn render(file: &EdsFile, id: &str, opts: &ImportOptions, outs: &[Out]) -> String {
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
    match outs.iter().find(|o| o.store) {
        Some(o) => {
            let _ = writeln!(
                t,
                "\n[schema.store]\nkeeps = \"on-command\"\ncode = {}\nvalue = 0x{:08X}\nspec = {}",
                o.number,
                super::SAVE_SIGNATURE,
                toml_str(&format!("{} (CiA 301 0x1010 sub 1 \"save\")", o.spec))
            );
        }
        None => {
            let _ = writeln!(
                t,
                "\n[schema.store]\nkeeps = \"unknown\"\nspec = {}",
                toml_str(&format!(
                    "{}: declares no store parameters object (0x1010)",
                    file_name(&opts.file)
                ))
            );
        }
    }
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
        if o.store {
            t.push_str("role = \"command\"\n");
        } else if o.index.is_none()
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
