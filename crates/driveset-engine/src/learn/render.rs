//! Owns the learned file's text: the header (where the descriptions come
//! from, the merge rule, MC layouts and type characters), `[schema]`,
//! `[schema.identify]`, `[schema.learned]`, and one `[[code]]` entry per
//! learned code with its `# learned:` / `# drive says:` markers (module
//! docs of [`super`]; docs/file-formats.md, "Learned schemas"); or, on top
//! of a learned schema, that file's text with the new entries appended.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use driveset_proto::lustbus::CompatibleParameter;
use driveset_proto::lustbus::description::McTypeChars;
use driveset_schema::family::TYPE;
use driveset_schema::schema::{StorageKind, number_list_text};
use driveset_schema::value::raw_to_engineering;
use driveset_schema::{Family, Schema, ValueType};

use super::bounds::width_of;
use super::contradict::{contradictions, kind_name, spec_source};
use super::file::LearnSource;
use super::model::{Learned, LearnedCode};
use super::{description_section, dialect, speaks_mc};
use crate::client::IdentValue;

fn q(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

/// The file text and the line range of each learned code's entry.
pub(super) fn render_text(
    learned: &Learned,
    base: &Schema,
    id: &str,
    source: &LearnSource,
    dropped: &BTreeSet<u32>,
) -> (String, Vec<(u32, std::ops::Range<usize>)>) {
    let mc = speaks_mc(learned.protocol);
    let section = description_section(learned.protocol);
    if let Some(prev) = &base.learned {
        return render_on_learned(learned, base, prev, id, source, dropped);
    }
    let mut out = String::new();
    let ident: Vec<String> = source
        .identity
        .codes
        .iter()
        .map(|c| format!("{} = {}", c.name, c.value))
        .collect();
    let _ = writeln!(
        out,
        "# Schema learned by driveset from the drive's own parameter descriptions\n# (LUSTBUS section {}){}.",
        section,
        if mc {
            " and substitution texts (section 11.3)"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "# Drive: {}{}{}.",
        source.drive,
        if ident.is_empty() { "" } else { ", " },
        ident.join(", ")
    );
    let _ = writeln!(
        out,
        "# Merge rule: extends `{}`; the built-in schema's spec facts stand, the\n# drive's descriptions fill in what it leaves unset. `# learned:` lists the\n# facts taken from the drive, `guessed:` what is a guess.",
        base.id
    );
    if mc {
        let _ = writeln!(
            out,
            "# Description layout(s): {}; type characters: {}{}.",
            learned
                .layouts
                .iter()
                .map(|l| l.name())
                .collect::<Vec<_>>()
                .join(", "),
            learned
                .type_chars
                .as_ref()
                .map_or_else(|| "-".to_string(), McTypeChars::name),
            if learned.type_chars_guessed {
                " (guessed from the content)"
            } else {
                " (given)"
            }
        );
    }
    let _ = writeln!(out, "\n[schema]");
    let _ = writeln!(out, "id = {}", q(id));
    let _ = writeln!(
        out,
        "title = {}",
        q(&format!(
            "{} learned from {}",
            if mc { "MC6000/7000" } else { "VF1000" },
            source.drive
        ))
    );
    let _ = writeln!(out, "extends = {}", q(&base.id));
    let _ = writeln!(
        out,
        "protocol = {}",
        q(Family::from_dialect(dialect(learned.protocol))
            .descriptor()
            .schema_protocol)
    );
    let _ = writeln!(
        out,
        "spec = {}",
        q(&format!(
            "learned from the drive's descriptions ({}); spec facts from {}",
            source.drive, base.id
        ))
    );
    let type_code = Family::from_dialect(dialect(learned.protocol))
        .descriptor()
        .type_code
        .unwrap_or(TYPE);
    let ty_value = source
        .identity
        .value_of(type_code)
        .and_then(IdentValue::as_int);
    let _ = writeln!(out, "\n[schema.identify]\ncodes = [{type_code}]");
    if let Some(t) = ty_value {
        let _ = writeln!(out, "type_values = [{t}]");
    }
    let _ = writeln!(
        out,
        "note = {}",
        q("learned: the TYPE the drive reported when its descriptions were read")
    );
    let _ = writeln!(
        out,
        "\n[schema.learned]\nasked = {}",
        q(&number_list_text(&learned.asked_params))
    );
    let (out, spans) = render_entries(out, learned, base, dropped);
    (out, spans)
}

/// Appends the entries of the learned codes (not in `dropped`) to `out`;
/// returns the text and the line range of each entry.
fn render_entries(
    mut out: String,
    learned: &Learned,
    base: &Schema,
    dropped: &BTreeSet<u32>,
) -> (String, Vec<(u32, std::ops::Range<usize>)>) {
    let section = description_section(learned.protocol);
    let mut names: BTreeSet<String> = base.codes.iter().map(|c| c.name.clone()).collect();
    let mut spans = Vec::new();
    for c in &learned.codes {
        if dropped.contains(&c.number) {
            continue;
        }
        let start = out.lines().count() + 1;
        render_code(&mut out, c, base, &mut names, section);
        let end = out.lines().count() + 1;
        spans.push((c.number, start..end));
    }
    (out, spans)
}

/// A schema learned on top of a learned one (`prev`, the file `base` was
/// read from): that file's own text with the new `id` and the union of
/// the parameters asked for, and the newly learned codes' entries
/// appended, so the result extends the same base as `prev` (a schema id
/// every reader resolves) and carries every entry of both.
fn render_on_learned(
    learned: &Learned,
    base: &Schema,
    prev: &driveset_schema::schema::LearnedFrom,
    id: &str,
    source: &LearnSource,
    dropped: &BTreeSet<u32>,
) -> (String, Vec<(u32, std::ops::Range<usize>)>) {
    let asked: BTreeSet<u32> = prev.asked.union(&learned.asked_params).copied().collect();
    let mut out = String::new();
    let mut table = "";
    for line in prev.text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            table = if t == "[schema]" {
                "schema"
            } else if t == "[schema.learned]" {
                "learned"
            } else {
                "other"
            };
        }
        if table == "schema" && t.starts_with("id ") | t.starts_with("id=") {
            let _ = writeln!(out, "id = {}", q(id));
        } else if table == "learned" && t.starts_with("asked") {
            let _ = writeln!(out, "asked = {}", q(&number_list_text(&asked)));
        } else {
            let _ = writeln!(out, "{line}");
        }
    }
    let _ = writeln!(
        out,
        "\n# Learned on top of `{}` from {}: parameters {}.",
        base.id,
        source.drive,
        number_list_text(&learned.asked_params)
    );
    render_entries(out, learned, base, dropped)
}

fn render_code(
    out: &mut String,
    c: &LearnedCode,
    base: &Schema,
    names: &mut BTreeSet<String>,
    section: &str,
) {
    let b = base.code(c.number);
    let mut learned_facts: Vec<&str> = Vec::new();
    let mut lines: Vec<String> = Vec::new();
    let mut comments: Vec<String> = Vec::new();
    lines.push(format!("number = {}", c.number));
    match b {
        Some(b) if !b.name.is_empty() => lines.push(format!("name = {}", q(&b.name))),
        _ => {
            let mut name: String = c
                .name
                .chars()
                .filter(|ch| ch.is_ascii_alphanumeric() || *ch == '_' || *ch == '-')
                .collect();
            if name.is_empty()
                || name.chars().all(|ch| ch.is_ascii_digit())
                || name.starts_with(['C', 'c']) && name[1..].chars().all(|ch| ch.is_ascii_digit())
            {
                name = format!("P{}", c.number);
            }
            if names.contains(&name) {
                name = format!("{name}_{}", c.number);
            }
            names.insert(name.clone());
            lines.push(format!("name = {}", q(&name)));
        }
    }
    if b.is_none_or(|b| b.title.is_none()) && !c.name.is_empty() {
        lines.push(format!("title = {}", q(&c.name)));
    }
    if b.is_none_or(|b| b.spec.is_none()) {
        lines.push(format!(
            "spec = {}",
            q(&format!(
                "learned from the drive's description (LUSTBUS section {section})"
            ))
        ));
    }
    let base_type = b.and_then(|b| base.type_of(b));
    let against = b.map(|b| contradictions(c, b, base)).unwrap_or_default();
    if !against.is_empty() {
        // The drive's facts as a guess beside the spec's (docs/file-formats.md,
        // "Learned schema files").
        let mut said: Vec<String> = Vec::new();
        let mut stands: Vec<String> = Vec::new();
        if let Some(r) = against.role {
            said.push(format!("kind = {}", q(kind_name(c.kind))));
            stands.push(format!("role = {}", q(r.as_str())));
        }
        for d in &against.facts {
            said.push(format!("{} = {}", d.fact, q(&d.drive)));
            stands.push(format!("{} = {}", d.fact, q(&d.spec)));
        }
        comments.push(format!(
            "# drive says: {} (a guess; the spec's {} stands, {})",
            said.join(", "),
            stands.join(", "),
            b.map(|b| spec_source(b, base)).unwrap_or_default()
        ));
    }
    let ty_ok = !against.facts.iter().any(|d| d.fact == "type");
    if let (None, Some(t)) = (base_type, c.ty) {
        lines.push(format!("type = {}", q(t.name())));
        learned_facts.push("type");
    }
    let eff_type = base_type.or_else(|| c.ty.and_then(|t| ValueType::from_name(t.name())));
    if let Some(u) = &c.unit
        && b.is_none_or(|b| b.unit.is_none())
    {
        lines.push(format!("unit = {}", q(u)));
        learned_facts.push("unit");
    }
    if let (Some(vt), true) = (eff_type, ty_ok) {
        let e = |raw: i64| q(&raw_to_engineering(vt, raw));
        if let (Some(min), Some(max)) = (c.min, c.max)
            && b.is_none_or(|b| b.min.is_none() && b.max.is_none())
        {
            lines.push(format!("min = {}", e(min)));
            lines.push(format!("max = {}", e(max)));
            learned_facts.push("min");
            learned_facts.push("max");
        }
        if let Some(d) = c.default
            && b.is_none_or(|b| b.default.is_none() && b.min.is_none() && b.max.is_none())
        {
            lines.push(format!("default = {}", e(d)));
            learned_facts.push("default");
        }
    }
    let role_stands = against.role.is_some();
    if c.kind == StorageKind::RamActual && !role_stands && b.is_none_or(|b| b.access.is_none()) {
        lines.push("access = \"ro\"".into());
        learned_facts.push("access");
    }
    if !role_stands && b.is_none_or(|b| b.kind.is_none()) {
        lines.push(format!("kind = {}", q(kind_name(c.kind))));
        learned_facts.push("kind");
    }
    if let Some(basis) = c.basis
        && b.is_none_or(|b| b.basis.is_none())
    {
        lines.push(format!("basis = {basis}"));
        learned_facts.push("basis");
    }
    if let Some(t) = c.ty
        && ty_ok
        && b.is_none_or(|b| b.width.is_none())
    {
        lines.push(format!("width = {}", width_of(t)));
        learned_facts.push("width");
    }
    if let Some(cw) = c.card_writeable
        && b.is_none_or(|b| b.card_writeable.is_none())
    {
        lines.push(format!("card_writeable = {cw}"));
        learned_facts.push("card_writeable");
    }
    if c.password && b.is_none_or(|b| b.role.is_none()) {
        lines.push("role = \"password\"".into());
        learned_facts.push("role");
    }
    // The numerically compatible parameters (section 5.2) from proto's one
    // table, and the one of them whose reading clears it (85-SIOF/SERR).
    let compatible = u16::try_from(c.number)
        .ok()
        .and_then(CompatibleParameter::from_number);
    if b.is_none() && compatible.is_some() {
        lines.push("compatible = true".into());
    }
    if b.is_none() && compatible == Some(CompatibleParameter::Siof) {
        lines.push("read_clears = true".into());
    }
    if !c.guessed.is_empty() {
        let text = format!("guessed: {}", c.guessed.join("; "));
        if b.is_none_or(|b| b.note.is_none()) {
            lines.push(format!("note = {}", q(&text)));
        } else {
            comments.push(format!("# {}", text.replace('\n', " ")));
        }
    }
    let texts = !c.texts.is_empty() && ty_ok && b.is_none_or(|b| b.values.is_none());
    if texts {
        lines.push("values_partial = true".into());
        learned_facts.push("values");
    }
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "# learned: {}",
        if learned_facts.is_empty() {
            "nothing (the spec gives every fact)".to_string()
        } else {
            learned_facts.join(", ")
        }
    );
    for cm in &comments {
        let _ = writeln!(out, "{cm}");
    }
    let _ = writeln!(out, "[[code]]");
    for l in &lines {
        let _ = writeln!(out, "{l}");
    }
    if texts {
        let _ = writeln!(out, "\n[code.values]");
        for (k, v) in &c.texts {
            let _ = writeln!(out, "{k} = {}", q(v));
        }
    }
}
