//! Owns the JSON Schema (draft-07, the draft both taplo and
//! yaml-language-server read) of the set files of one driveset schema
//! (docs/editors.md): the top-level keys the set reader takes (`schema`,
//! `extends`, `title`, `[drive]`, `[values]`), and under `[values]` every
//! key form of every code (canonical key and names as `properties` for
//! completion, number spellings, aliases and `/N` subcodes as
//! `patternProperties`), each code's value limited as `validate` limits it
//! (range, enumeration, bit-field members, text length, octets), its facts
//! as the description; unknown keys refused.
//!
//! Bounds are exact decimals written as JSON numbers from their decimal
//! text (never through a binary float).

use driveset_schema::schema::Code;
use driveset_schema::value::Repr;
use driveset_schema::{Decimal, Registry, Schema};
use serde_json::{Map, Value, json};

use crate::facts;

/// The JSON Schema draft written (`$schema`).
pub const DRAFT: &str = "http://json-schema.org/draft-07/schema#";

/// Marks a decimal number in the value tree until [`to_text`] writes it.
const NUM_MARK: &str = "\u{1}decimal:";

/// The file a schema's JSON Schema is written to (`schema json-schema
/// --all`, `git-setup --json-schemas`): `ID.schema.json`.
pub fn file_name(id: &str) -> String {
    format!("{id}.schema.json")
}

/// The JSON Schema of `schema`'s set files, as pretty JSON text (ends in a newline).
pub fn json_schema(schema: &Schema) -> String {
    to_text(&build(schema))
}

/// The JSON Schema of every schema of `registry`, in the order of their
/// ids: each file's name ([`file_name`]) and text (`schema json-schema
/// --all`).
pub fn every(registry: &Registry) -> Vec<(String, String)> {
    let mut schemas: Vec<&Schema> = registry.schemas().map(|s| &**s).collect();
    schemas.sort_by(|a, b| a.id.cmp(&b.id));
    schemas
        .into_iter()
        .map(|s| (file_name(&s.id), json_schema(s)))
        .collect()
}

fn num(d: &Decimal) -> Value {
    match d.to_integer().and_then(|i| i64::try_from(i).ok()) {
        Some(i) => Value::from(i),
        None => Value::String(format!("{NUM_MARK}{d}")),
    }
}

/// Pretty JSON with the marked decimals written as numbers, exactly.
fn to_text(v: &Value) -> String {
    let text = serde_json::to_string_pretty(v).unwrap_or_default();
    let mark = "\"\\u0001decimal:";
    let mut out = String::with_capacity(text.len());
    let mut rest = text.as_str();
    while let Some(i) = rest.find(mark) {
        out.push_str(&rest[..i]);
        let after = &rest[i + mark.len()..];
        let end = after.find('"').unwrap_or(after.len());
        out.push_str(&after[..end]);
        rest = after.get(end + 1..).unwrap_or("");
    }
    out.push_str(rest);
    out.push('\n');
    out
}

/// Case-insensitive regular expression of one of the labels, trimmed as
/// the set reader compares them (`EnumDef::value_of`).
fn labels_pattern(labels: &[&str]) -> String {
    let alts: Vec<String> = labels
        .iter()
        .map(|l| {
            l.trim()
                .chars()
                .map(|c| {
                    if c.is_ascii_alphabetic() {
                        format!("[{}{}]", c.to_ascii_uppercase(), c.to_ascii_lowercase())
                    } else {
                        facts::regex_escape(&c.to_string())
                    }
                })
                .collect()
        })
        .collect();
    format!("^\\s*(?:{})\\s*$", alts.join("|"))
}

/// A number as a string, optionally with the code's unit (`"60 Hz"`).
fn number_string(code: &Code) -> Value {
    let mut units: Vec<String> = code.unit.iter().cloned().collect();
    units.extend(code.unit_aliases.iter().cloned());
    let unit = if units.is_empty() {
        String::new()
    } else {
        let u: Vec<String> = units.iter().map(|u| facts::regex_escape(u)).collect();
        format!("\\s*(?:{})?", u.join("|"))
    };
    json!({
        "type": "string",
        "pattern": format!(
            "^\\s*[-+]?(?:[0-9][0-9_]*(?:\\.[0-9_]*)?|\\.[0-9]+)(?:[eE][-+]?[0-9]+)?{unit}\\s*$"
        ),
    })
}

/// A quoted radix literal (`"0x0900"`), for the types that take hex.
fn radix_string() -> Value {
    json!({"type": "string", "pattern": "^\\s*[-+]?0(?:[xX][0-9A-Fa-f_]+|[oO][0-7_]+|[bB][01_]+)\\s*$"})
}

fn label_branches(labels: &[&str]) -> Vec<Value> {
    if labels.is_empty() {
        return Vec::new();
    }
    vec![
        json!({"type": "string", "enum": labels}),
        json!({"type": "string", "pattern": labels_pattern(labels)}),
    ]
}

/// One bit-field member's value: a boolean (one bit), 0 ..= 2^width - 1, a label.
fn member_schema(schema: &Schema, b: &driveset_schema::schema::BitField) -> Value {
    let width = b.width().min(62);
    let max = (1i64 << width) - 1;
    let labels: Vec<&str> = b
        .values
        .as_ref()
        .and_then(|v| schema.enum_of(v))
        .map(|e| e.labels())
        .unwrap_or_default();
    let mut any = vec![json!({"type": "integer", "minimum": 0, "maximum": max})];
    any.push(json!({"type": "string", "pattern": "^\\s*[0-9]+\\s*$"}));
    if width == 1 {
        any.push(json!({"type": "boolean"}));
    }
    any.extend(label_branches(&labels));
    let mut desc = format!("bits {}..{} (0 ..= {max})", b.lsb, b.msb);
    if let Some(t) = &b.title {
        desc = format!("{t}: {desc}");
    }
    if !labels.is_empty() {
        desc.push_str(&format!("; labels: {}", labels.join(", ")));
    }
    json!({"title": b.name, "description": desc, "anyOf": any})
}

/// The value schema of one code, as `validate` accepts its values.
fn value_schema(schema: &Schema, code: &Code) -> Value {
    let md = facts::markdown(schema, code);
    let mut out = Map::new();
    out.insert(
        "title".into(),
        Value::String(code.title.clone().unwrap_or_else(|| code.name.clone())),
    );
    out.insert("description".into(), Value::String(md.clone()));
    out.insert("markdownDescription".into(), Value::String(md));
    if let Some(why) = facts::refused(schema, code) {
        if code.access == Some(driveset_schema::schema::Access::Ro) {
            out.insert("readOnly".into(), Value::Bool(true));
        }
        out.insert("not".into(), json!({}));
        out.insert("errorMessage".into(), Value::String(why.into()));
        return Value::Object(out);
    }
    let Some(ty) = schema.type_of(code) else {
        return Value::Object(out);
    };
    let mut any: Vec<Value> = Vec::new();
    match ty.repr() {
        Repr::Text => any.push(json!({"type": "string", "maxLength": 20, "pattern": "^[ -~]*$"})),
        Repr::Octets => {
            any.push(json!({"type": "string", "pattern": "^\\s*(?:0x)?(?:[0-9A-Fa-f]{2})*\\s*$"}))
        }
        Repr::Scaled(_) | Repr::Float => {
            let labels = facts::labels(schema, code);
            let names: Vec<&str> = labels.iter().map(|(_, l)| *l).collect();
            if facts::complete_enum(code) {
                let numbers: Vec<i64> = labels.iter().map(|(v, _)| *v).collect();
                any.push(json!({"type": "number", "enum": numbers}));
            } else {
                let mut n = Map::new();
                n.insert("type".into(), Value::String("number".into()));
                let (lo, hi) = facts::range(schema, code);
                if let Some(lo) = lo {
                    n.insert("minimum".into(), num(&lo));
                }
                if let Some(hi) = hi {
                    n.insert("maximum".into(), num(&hi));
                }
                any.push(Value::Object(n));
                any.push(number_string(code));
                if ty.accepts_hex() {
                    any.push(radix_string());
                }
            }
            any.extend(label_branches(&names));
            if !code.bits.is_empty() {
                let props: Map<String, Value> = code
                    .bits
                    .iter()
                    .map(|b| (b.name.clone(), member_schema(schema, b)))
                    .collect();
                any.push(json!({
                    "type": "object",
                    "properties": props,
                    "additionalProperties": false,
                }));
            }
        }
    }
    out.insert("anyOf".into(), Value::Array(any));
    if schema.is_password(code) {
        out.insert("writeOnly".into(), Value::Bool(true));
        out.insert(
            "not".into(),
            json!({"const": driveset_schema::canonical::SECRET}),
        );
    }
    Value::Object(out)
}

/// The definition name of a code (`#/definitions/NAME`).
fn def_name(schema: &Schema, code: &Code) -> String {
    schema.display_code(code.number, None).replace('/', "_")
}

fn build(schema: &Schema) -> Value {
    let mut defs = Map::new();
    let mut props = Map::new();
    let mut patterns = Map::new();
    for code in &schema.codes {
        let name = def_name(schema, code);
        if defs.contains_key(&name) {
            continue;
        }
        defs.insert(name.clone(), value_schema(schema, code));
        let r = json!({"$ref": format!("#/definitions/{name}")});
        let named = facts::named_keys(schema, code);
        let mut alts: Vec<String> = vec![facts::number_pattern(code)];
        alts.extend(named.iter().map(|k| facts::regex_escape(k)));
        let alts = alts.join("|");
        match code.subcodes {
            None => {
                props.insert(named[0].clone(), r.clone());
                if let Some(n) = named.get(1) {
                    props.insert(n.clone(), r.clone());
                }
                patterns.insert(format!("^(?:{alts})$"), r);
            }
            Some(n) => {
                for s in 1..=n {
                    props.insert(format!("{}/{s}", named[0]), r.clone());
                }
                let subs: Vec<String> = (1..=n).map(|s| s.to_string()).collect();
                patterns.insert(format!("^(?:{alts})/0*(?:{})$", subs.join("|")), r);
            }
        }
    }
    let id = &schema.id;
    json!({
        "$schema": DRAFT,
        "title": format!("driveset parameter set ({id})"),
        "description": format!(
            "A parameter set of {} (driveset schema `{id}`, {}): docs/file-formats.md, \"Parameter sets\". Written by `driveset schema json-schema {id}`.",
            schema.title, schema.path
        ),
        "type": "object",
        "additionalProperties": false,
        "properties": {
            "schema": {
                "type": "string",
                "description": format!("The schema the set is written against: `{id}`, or a schema file's path relative to the set (a learned or imported schema)."),
                "examples": [id],
            },
            "extends": {
                "description": "Base sets (paths relative to this file) whose values this set starts from.",
                "anyOf": [
                    {"type": "string"},
                    {"type": "array", "items": {"type": "string"}},
                ],
            },
            "title": {"type": "string", "description": "What the set is for."},
            "drive": {"type": "object", "description": "The drive the set is meant for (e.g. `address`)."},
            "values": {
                "description": format!("Code = value lines of {}.", schema.title),
                "type": ["object", "null"],
                "properties": props,
                "patternProperties": patterns,
                "additionalProperties": false,
            },
        },
        "definitions": defs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmd() -> std::sync::Arc<Schema> {
        driveset_schema::Registry::builtin()
            .unwrap()
            .get("lenze-tmd")
            .unwrap()
    }

    #[test]
    fn fractional_bounds_are_written_from_their_decimal_text() {
        let v = json!({"a": num(&Decimal::parse("0.1").unwrap()), "b": num(&Decimal::parse("480").unwrap())});
        assert_eq!(to_text(&v), "{\n  \"a\": 0.1,\n  \"b\": 480\n}\n");
    }

    #[test]
    fn labels_match_case_insensitively_and_trimmed() {
        assert_eq!(
            labels_pattern(&["On", "a.b"]),
            "^\\s*(?:[Oo][Nn]|[Aa]\\.[Bb])\\s*$"
        );
    }

    #[test]
    fn tmd_c0011_is_limited_to_its_range() {
        let s = tmd();
        let v: Value = serde_json::from_str(&json_schema(&s)).unwrap();
        let c11 = &v["definitions"]["C0011"];
        assert_eq!(c11["anyOf"][0]["type"], "number");
        let code = s.code(11).unwrap();
        let (lo, hi) = facts::range(&s, code);
        assert_eq!(
            c11["anyOf"][0]["minimum"].to_string(),
            lo.unwrap().to_string()
        );
        assert_eq!(
            c11["anyOf"][0]["maximum"].to_string(),
            hi.unwrap().to_string()
        );
        let values = &v["properties"]["values"];
        assert_eq!(values["properties"]["C0011"]["$ref"], "#/definitions/C0011");
        assert_eq!(values["additionalProperties"], false);
    }
}
