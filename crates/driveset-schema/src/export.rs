//! Owns writing a resolved set back as TOML, YAML or JSON in engineering
//! units with labels (docs/file-formats.md, "Parameter sets"), such that
//! reading it back gives the same fingerprint; the set file `driveset
//! pull` writes around it ([`pulled`]).

pub mod pulled;

use std::fmt::Write;

use crate::canonical::{RawValue, ResolvedSet};
use crate::schema::Schema;
use crate::value::{Repr, raw_to_engineering};

/// Output syntax.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// TOML.
    Toml,
    /// YAML (flow style values).
    Yaml,
    /// JSON (also readable as YAML by [`crate::load_set`] with a `.json` name).
    Json,
}

impl Format {
    /// The syntax a set file written to `path` takes by its extension:
    /// `.yaml` / `.yml` YAML, anything else TOML (what `driveset pull`
    /// writes without `--to`).
    pub fn by_extension(path: &std::path::Path) -> Format {
        match path.extension().and_then(|e| e.to_str()) {
            Some("yaml" | "yml") => Format::Yaml,
            _ => Format::Toml,
        }
    }
}

/// What `driveset show` prints of a set ([`shown`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shown {
    /// The canonical form the fingerprint is computed from.
    Canonical,
    /// The set in a set file syntax ([`export`]).
    As(Format),
    /// A CiA 306 DCF (CANopen families only; [`crate::eds::write_dcf`]),
    /// with `[DeviceComissioning] NodeID` when given.
    Dcf {
        /// The node id written.
        node_id: Option<u8>,
    },
}

/// `set` of `schema` (its title `title`) as `driveset show` prints it;
/// `file` is the set's file, whose stem names a DCF (`<stem>.dcf`,
/// `set.dcf` without one).
///
/// # Errors
/// [`crate::eds::DcfError`]: a DCF of a set that is not a CANopen family's.
pub fn shown(
    set: &ResolvedSet,
    schema: &Schema,
    title: Option<&str>,
    file: &std::path::Path,
    shown: Shown,
) -> Result<String, crate::eds::DcfError> {
    Ok(match shown {
        Shown::Canonical => set.canonical(),
        Shown::As(format) => export(set, schema, title, format),
        Shown::Dcf { node_id } => {
            let name = file
                .file_stem()
                .map(|s| format!("{}.dcf", s.to_string_lossy()))
                .unwrap_or_else(|| "set.dcf".into());
            crate::eds::write_dcf(set, schema, title, &name, node_id)?
        }
    })
}

/// A scalar or inline table, already spelled for the output.
enum Out {
    /// Bare number text.
    Num(String),
    /// String (quoted on output).
    Str(String),
    /// Bit-field members.
    Members(Vec<(String, Out)>),
    /// Boolean.
    Bool(bool),
}

fn q(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

fn render(o: &Out, fmt: Format) -> String {
    match o {
        Out::Num(n) => n.clone(),
        Out::Str(s) => q(s),
        Out::Bool(b) => b.to_string(),
        Out::Members(m) => {
            let (sep, open, close) = match fmt {
                Format::Toml => (" = ", "{ ", " }"),
                Format::Yaml | Format::Json => (": ", "{", "}"),
            };
            if m.is_empty() {
                return "{}".into();
            }
            let parts: Vec<String> = m
                .iter()
                .map(|(k, v)| {
                    let key = if fmt == Format::Toml
                        && k.bytes()
                            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
                    {
                        k.clone()
                    } else {
                        q(k)
                    };
                    format!("{key}{sep}{}", render(v, fmt))
                })
                .collect();
            format!("{open}{}{close}", parts.join(", "))
        }
    }
}

fn value_out(schema: &Schema, key: crate::canonical::CodeKey, raw: &RawValue) -> Out {
    let code = schema.code(key.number);
    if code.is_some_and(|c| schema.is_password(c)) {
        // an export never holds a secret's value (loading it back gives a
        // `secret-not-given` finding that asks for the value)
        return Out::Str(crate::canonical::SECRET.into());
    }
    match raw {
        RawValue::Text(t) => Out::Str(t.clone()),
        RawValue::Octets(o) => Out::Str(o.iter().map(|b| format!("{b:02x}")).collect()),
        RawValue::Int(i) => {
            let Some(code) = code else {
                return Out::Num(i.to_string());
            };
            if let Some(l) = schema.enum_label(code, *i) {
                // a label that also reads as another value would be ambiguous; labels win on read
                return Out::Str(l.to_string());
            }
            if !code.bits.is_empty() {
                let mut covered: i64 = 0;
                let mut members = Vec::new();
                for b in &code.bits {
                    let v = b.extract(*i);
                    covered |= (if b.width() >= 63 {
                        -1
                    } else {
                        (1i64 << b.width()) - 1
                    })
                    .checked_shl(b.lsb)
                    .unwrap_or(0);
                    if v == 0 {
                        continue;
                    }
                    let labels = b.values.as_ref().and_then(|s| schema.enum_of(s));
                    let o = match labels.and_then(|e| e.label(v)) {
                        Some(l) => Out::Str(l.to_string()),
                        None if b.width() == 1 => Out::Bool(true),
                        None => Out::Num(v.to_string()),
                    };
                    members.push((b.name.clone(), o));
                }
                // bits no member covers cannot be written as a table: keep the number
                if *i & !covered == 0 {
                    return Out::Members(members);
                }
                return Out::Num(i.to_string());
            }
            let Some(ty) = schema.type_of(code) else {
                return Out::Num(i.to_string());
            };
            let num = raw_to_engineering(ty, *i);
            match (&code.unit, ty.repr()) {
                (Some(u), Repr::Scaled(_) | Repr::Float) => Out::Str(format!("{num} {u}")),
                _ => Out::Num(num),
            }
        }
    }
}

/// Write a set in the given format. `title` is written when given. A
/// secret's value is written as `"<secret>"`, never its value.
pub fn export(set: &ResolvedSet, schema: &Schema, title: Option<&str>, format: Format) -> String {
    let mut out = String::new();
    let entries: Vec<(String, String)> = set
        .values
        .iter()
        .map(|(k, v)| {
            (
                k.canonical(schema.code_style),
                render(&value_out(schema, *k, v), format),
            )
        })
        .collect();
    match format {
        Format::Toml => {
            let _ = writeln!(out, "schema = {}", q(&set.schema));
            if let Some(t) = title {
                let _ = writeln!(out, "title = {}", q(t));
            }
            out.push_str("\n[values]\n");
            for (k, v) in entries {
                let key = if k.contains('/') { q(&k) } else { k };
                let _ = writeln!(out, "{key} = {v}");
            }
        }
        Format::Yaml => {
            let _ = writeln!(out, "schema: {}", q(&set.schema));
            if let Some(t) = title {
                let _ = writeln!(out, "title: {}", q(t));
            }
            if entries.is_empty() {
                out.push_str("values: {}\n");
            } else {
                out.push_str("values:\n");
                for (k, v) in entries {
                    let _ = writeln!(out, "  {}: {v}", q(&k));
                }
            }
        }
        Format::Json => {
            let _ = write!(out, "{{\n  \"schema\": {}", q(&set.schema));
            if let Some(t) = title {
                let _ = write!(out, ",\n  \"title\": {}", q(t));
            }
            out.push_str(",\n  \"values\": {");
            let n = entries.len();
            for (i, (k, v)) in entries.into_iter().enumerate() {
                let _ = write!(
                    out,
                    "\n    {}: {v}{}",
                    q(&k),
                    if i + 1 < n { "," } else { "" }
                );
            }
            out.push_str(if n > 0 { "\n  }\n}\n" } else { "}\n}\n" });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::Registry;

    #[test]
    fn show_prints_the_canonical_form_a_syntax_or_a_dcf() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut registry = Registry::builtin().unwrap();
        let ecs = root.join("parameter-sets/ecs/axis-1.toml");
        let loaded = crate::load_set(&ecs, &mut registry).unwrap();
        let (set, schema) = (loaded.resolved.unwrap(), loaded.schema.unwrap());
        let show = |s| shown(&set, &schema, Some("t"), &ecs, s);
        assert_eq!(show(Shown::Canonical).unwrap(), set.canonical());
        assert_eq!(
            show(Shown::As(Format::Yaml)).unwrap(),
            export(&set, &schema, Some("t"), Format::Yaml)
        );
        assert_eq!(
            show(Shown::Dcf { node_id: Some(3) }).unwrap(),
            crate::eds::write_dcf(&set, &schema, Some("t"), "axis-1.dcf", Some(3)).unwrap()
        );
        let tmd = root.join("parameter-sets/tmd/conveyor-3.toml");
        let loaded = crate::load_set(&tmd, &mut registry).unwrap();
        let (set, schema) = (loaded.resolved.unwrap(), loaded.schema.unwrap());
        assert!(shown(&set, &schema, None, &tmd, Shown::Dcf { node_id: None }).is_err());
    }
}
