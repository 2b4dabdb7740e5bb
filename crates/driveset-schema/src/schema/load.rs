//! Loading one schema file ([`parse_schema`]): the `[schema]` head,
//! identification, CAN and learned tables, codes, enumerations and rules,
//! `extends` of a base schema, and the schema's fingerprint.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::doc::{self, NodeKind, Syntax};
use crate::error::{Finding, FindingKind, InputError, InputErrorKind, SourceFile};
use crate::family::Family;
use crate::value::ValueType;

use super::extends::fill_unset;
use super::parse::{parse_code, parse_enum_table, parse_rule};
use super::reader::Reader;
use super::{CodeStyle, Identify, LearnedFrom, Schema, parse_int_text, parse_number_list};

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
    let store = match h.take("store") {
        None => None,
        Some(e) => Some(super::store::StoreTable::read(Reader::new(
            &doc,
            &e.value,
            "[schema.store]",
        )?)?),
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
                store: super::Store::default(),
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
    if let Some(table) = store {
        schema.store = table.resolve(&schema)?;
    }
    Ok(schema)
}
