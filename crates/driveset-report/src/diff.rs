//! The semantic diff of two sets (or a set and a drive) as `driveset diff`
//! prints it: one line per code for people (`~ C0011
//! max_output_frequency: 50 Hz -> 60 Hz`, then a count) or one JSON
//! document (docs/file-formats.md: a password shows as the secret marker),
//! and `--unified`'s canonical text diff in colour. The diff itself is the
//! schema crate's ([`driveset_schema::diff()`]); printing is the caller's.

use std::fmt::Write;

use driveset_schema::validate::display_value;
use driveset_schema::{CodeKey, Diff, DiffKind, RawValue, Schema};

use crate::style::{Style, plural};

/// The names of the two sides of a diff, as its header gives them
/// (`--- OLD`, `+++ NEW`).
#[derive(Clone, Copy, Debug)]
pub struct Sides<'a> {
    /// The old side (a set's path, `factory defaults (lenze-tmd)`).
    pub old: &'a str,
    /// The new side.
    pub new: &'a str,
}

fn code_name(schema: &Schema, key: CodeKey) -> String {
    schema
        .code(key.number)
        .map(|c| driveset_schema::error::escape_controls(&c.name).into_owned())
        .unwrap_or_default()
}

fn shown(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => display_value(schema, c, raw),
        None => format!("{raw:?}"),
    }
}

/// A raw value in `diff`'s JSON: a number, or text (octets as hex, a
/// password as the secret marker).
#[derive(serde::Serialize)]
#[serde(untagged)]
enum RawShown {
    Int(i64),
    Text(String),
}

fn raw_json(schema: &Schema, key: CodeKey, raw: Option<&RawValue>) -> Option<RawShown> {
    let redact = schema
        .code(key.number)
        .is_some_and(|c| schema.is_password(c));
    match raw? {
        _ if redact => Some(RawShown::Text(driveset_schema::canonical::SECRET.into())),
        RawValue::Int(i) => Some(RawShown::Int(*i)),
        RawValue::Text(t) => Some(RawShown::Text(t.clone())),
        RawValue::Octets(o) => Some(RawShown::Text(
            o.iter().map(|b| format!("{b:02x}")).collect::<String>(),
        )),
    }
}

/// `diff --format json`'s document (keys in alphabetical order, as it
/// always had them).
#[derive(serde::Serialize)]
struct DiffDoc<'a> {
    added: usize,
    changed: usize,
    entries: Vec<EntryDoc<'a>>,
    equal: bool,
    new: &'a str,
    old: &'a str,
    removed: usize,
    schema: &'a str,
}

/// One difference.
#[derive(serde::Serialize)]
struct EntryDoc<'a> {
    code: String,
    key: String,
    kind: &'static str,
    name: String,
    new: Option<String>,
    new_raw: Option<RawShown>,
    old: Option<String>,
    old_raw: Option<RawShown>,
    text: &'a str,
}

fn count(d: &Diff, k: DiffKind) -> usize {
    d.entries.iter().filter(|e| e.kind == k).count()
}

/// For people: `--- old`, `+++ new`, one line per code (`~` changed, `+`
/// added, `-` removed; green / red / yellow in colour), then `no
/// differences` or `N differences (c changed, a added, r removed)`.
pub fn human(d: &Diff, sides: Sides<'_>, style: Style) -> String {
    let summary = format!(
        "{} changed, {} added, {} removed",
        count(d, DiffKind::Changed),
        count(d, DiffKind::Added),
        count(d, DiffKind::Removed)
    );
    let mut out = String::new();
    let _ = writeln!(out, "{}", style.bold(&format!("--- {}", sides.old)));
    let _ = writeln!(out, "{}", style.bold(&format!("+++ {}", sides.new)));
    for e in &d.entries {
        let line = match e.kind {
            DiffKind::Added => style.added(&format!("+ {}", e.text)),
            DiffKind::Removed => style.removed(&format!("- {}", e.text)),
            DiffKind::Changed => style.changed(&format!("~ {}", e.text)),
        };
        let _ = writeln!(out, "{line}");
    }
    if d.is_empty() {
        let _ = writeln!(out, "no differences");
    } else {
        let _ = writeln!(
            out,
            "{} ({summary})",
            plural(d.entries.len(), "difference", "differences")
        );
    }
    out
}

/// One JSON document (and a newline): the counts, whether the sides are
/// equal, and every entry with its code, key, kind, name, shown and raw
/// values.
pub fn json(d: &Diff, schema: &Schema, sides: Sides<'_>) -> String {
    let entries: Vec<EntryDoc> = d
        .entries
        .iter()
        .map(|e| EntryDoc {
            code: schema.display_code(e.key.number, e.key.subcode),
            key: e.key.canonical(schema.code_style),
            kind: match e.kind {
                DiffKind::Added => "added",
                DiffKind::Removed => "removed",
                DiffKind::Changed => "changed",
            },
            name: code_name(schema, e.key),
            new: e.new.as_ref().map(|r| shown(schema, e.key, r)),
            new_raw: raw_json(schema, e.key, e.new.as_ref()),
            old: e.old.as_ref().map(|r| shown(schema, e.key, r)),
            old_raw: raw_json(schema, e.key, e.old.as_ref()),
            text: &e.text,
        })
        .collect();
    let doc = DiffDoc {
        added: count(d, DiffKind::Added),
        changed: count(d, DiffKind::Changed),
        entries,
        equal: d.is_empty(),
        new: sides.new,
        old: sides.old,
        removed: count(d, DiffKind::Removed),
        schema: &schema.id,
    };
    format!(
        "{}\n",
        serde_json::to_string_pretty(&doc).unwrap_or_default()
    )
}

/// `--unified`'s text diff of the canonical forms, each line ended, in
/// colour: headers bold, added lines green, removed lines red.
pub fn unified(text: &str, style: Style) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let l = if line.starts_with("+++") || line.starts_with("---") {
            style.bold(line)
        } else if line.starts_with('+') {
            style.added(line)
        } else if line.starts_with('-') {
            style.removed(line)
        } else {
            line.to_string()
        };
        let _ = writeln!(out, "{l}");
    }
    out
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use driveset_schema::{Registry, load_set_str};

    use super::*;

    fn set(text: &str, r: &mut Registry) -> driveset_schema::LoadedSet {
        let l = load_set_str(Path::new("s.toml"), text, r).unwrap();
        assert!(l.findings.is_empty(), "{:?}", l.findings);
        l
    }

    #[test]
    fn a_change_for_people_and_as_json() {
        let mut r = Registry::builtin().unwrap();
        let a = set("schema = \"lenze-tmd\"\n[values]\nC0011 = 50\n", &mut r);
        let b = set("schema = \"lenze-tmd\"\n[values]\nC0011 = 60\n", &mut r);
        let schema = a.schema.clone().unwrap();
        let d = driveset_schema::diff(
            a.resolved.as_ref().unwrap(),
            b.resolved.as_ref().unwrap(),
            &schema,
        )
        .unwrap();
        let sides = Sides { old: "a", new: "b" };
        let text = human(&d, sides, Style::PLAIN);
        assert!(text.starts_with("--- a\n+++ b\n~ C0011"), "{text}");
        assert!(
            text.ends_with("1 difference (1 changed, 0 added, 0 removed)\n"),
            "{text}"
        );
        let doc: serde_json::Value = serde_json::from_str(&json(&d, &schema, sides)).unwrap();
        assert_eq!(doc["changed"], 1);
        assert_eq!(doc["equal"], false);
        assert_eq!(doc["entries"][0]["kind"], "changed");
        assert_eq!(doc["entries"][0]["old_raw"], 500000); // 50 Hz, in 1/10000 Hz
    }

    #[test]
    fn no_differences_and_unified_colours() {
        let d = Diff::default();
        let sides = Sides { old: "a", new: "b" };
        assert_eq!(
            human(&d, sides, Style::PLAIN),
            "--- a\n+++ b\nno differences\n"
        );
        assert_eq!(unified("--- a\n+x\n y\n", Style::PLAIN), "--- a\n+x\n y\n");
        assert_eq!(unified("+x\n", Style::COLOUR), "\x1b[32m+x\x1b[0m\n");
    }
}
