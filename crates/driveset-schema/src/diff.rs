//! Owns the semantic diff of two resolved sets of one schema, the diff
//! against factory defaults, and the unified diff of canonical forms.

use std::fmt;

use crate::canonical::{CodeKey, RawValue, ResolvedSet};
use crate::schema::Schema;
use crate::validate::display_value;

/// What happened to a code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiffKind {
    /// Only in the new set.
    Added,
    /// Only in the old set.
    Removed,
    /// In both, different.
    Changed,
}

/// One difference, with a human line (`C0011 max_output_frequency: 50 Hz -> 60 Hz`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DiffEntry {
    /// Code.
    pub key: CodeKey,
    /// Kind.
    pub kind: DiffKind,
    /// Old raw value.
    pub old: Option<RawValue>,
    /// New raw value.
    pub new: Option<RawValue>,
    /// Human line (passwords redacted).
    pub text: String,
}

/// A semantic diff.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Diff {
    /// Entries sorted by code.
    pub entries: Vec<DiffEntry>,
}

impl Diff {
    /// Whether the sets are equal.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

impl fmt::Display for Diff {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for e in &self.entries {
            writeln!(f, "{}", e.text)?;
        }
        Ok(())
    }
}

/// Diff errors.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DiffError {
    /// The two sets (or a set and the schema) are of different schemas.
    #[error(
        "cannot diff sets of different schemas: `{left}` and `{right}` (compare sets of one drive family)"
    )]
    DifferentSchemas {
        /// Left schema id.
        left: String,
        /// Right schema id.
        right: String,
    },
}

fn show(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => display_value(schema, c, raw),
        None => format!("{raw:?}"),
    }
}

/// Semantic diff `a -> b`.
pub fn diff(a: &ResolvedSet, b: &ResolvedSet, schema: &Schema) -> Result<Diff, DiffError> {
    for s in [a, b] {
        if s.schema != schema.id {
            return Err(DiffError::DifferentSchemas {
                left: s.schema.clone(),
                right: schema.id.clone(),
            });
        }
    }
    let mut entries = Vec::new();
    let keys: std::collections::BTreeSet<&CodeKey> =
        a.values.keys().chain(b.values.keys()).collect();
    for &key in keys {
        let (old, new) = (a.values.get(&key), b.values.get(&key));
        let (kind, text) = match (old, new) {
            (Some(o), Some(n)) if o == n => continue,
            // secrets are compared directly, but never shown
            (Some(_), Some(_)) if a.is_secret(&key) || b.is_secret(&key) => (
                DiffKind::Changed,
                format!("{}: differs (secret)", schema.code_label(key)),
            ),
            (Some(o), Some(n)) => (
                DiffKind::Changed,
                format!(
                    "{}: {} -> {}",
                    schema.code_label(key),
                    show(schema, key, o),
                    show(schema, key, n)
                ),
            ),
            (None, Some(n)) => (
                DiffKind::Added,
                format!(
                    "{}: (unset) -> {}",
                    schema.code_label(key),
                    show(schema, key, n)
                ),
            ),
            (Some(o), None) => (
                DiffKind::Removed,
                format!(
                    "{}: {} -> (unset)",
                    schema.code_label(key),
                    show(schema, key, o)
                ),
            ),
            (None, None) => continue,
        };
        entries.push(DiffEntry {
            key,
            kind,
            old: old.cloned(),
            new: new.cloned(),
            text,
        });
    }
    Ok(Diff { entries })
}

/// The schema's factory defaults for the codes a set gives (codes without a
/// known default are left out).
pub fn defaults_for(set: &ResolvedSet, schema: &Schema) -> ResolvedSet {
    let mut out = ResolvedSet::new(schema);
    for key in set.values.keys() {
        if let Some(c) = schema.code(key.number)
            && let Some(d) = &c.default
            && let Ok(raw) = schema.fact_raw(c, d)
        {
            out.insert(*key, raw);
        }
    }
    out
}

/// What a set changes from the factory defaults: `Changed` entries where a
/// default is known, `Added` (`(unset)` old) where the schema gives none.
pub fn diff_defaults(set: &ResolvedSet, schema: &Schema) -> Result<Diff, DiffError> {
    let mut d = diff(&defaults_for(set, schema), set, schema)?;
    for e in &mut d.entries {
        if e.kind == DiffKind::Added {
            e.text = e.text.replacen("(unset)", "(no factory default known)", 1);
        }
    }
    // whether a secret equals its (public) factory default would tell its
    // value: every secret the set gives is listed, never compared
    d.entries.retain(|e| !set.is_secret(&e.key));
    for (key, v) in &set.values {
        if set.is_secret(key) {
            d.entries.push(DiffEntry {
                key: *key,
                kind: DiffKind::Changed,
                old: None,
                new: Some(v.clone()),
                text: format!(
                    "{}: {} (a secret: not compared with the factory default)",
                    schema.code_label(*key),
                    crate::canonical::SECRET
                ),
            });
        }
    }
    d.entries.sort_by_key(|e| e.key);
    Ok(d)
}

/// Unified text diff of the canonical forms. Secrets are `<secret>` there
/// (present, not their value); a secret that differs between the two sets
/// shows as `<secret: old value>` / `<secret: new value>`, so the diff says
/// that it differs without what it is.
pub fn unified_diff(
    a: &ResolvedSet,
    b: &ResolvedSet,
    _schema: &Schema,
    a_name: &str,
    b_name: &str,
) -> String {
    let (ca, cb) = (marked_canonical(a, b, "old"), marked_canonical(b, a, "new"));
    similar::TextDiff::from_lines(&ca, &cb)
        .unified_diff()
        .header(a_name, b_name)
        .to_string()
}

/// `set`'s canonical form, with the secrets that differ from `other`'s
/// marked `<secret: {side} value>`.
fn marked_canonical(set: &ResolvedSet, other: &ResolvedSet, side: &str) -> String {
    let mut text = set.canonical();
    for (k, v) in &set.values {
        if set.is_secret(k) && other.values.get(k).is_some_and(|o| o != v) {
            let code = k.canonical(set.code_style);
            let line = format!("\n{code} {}\n", crate::canonical::SECRET);
            let repl = format!("\n{code} <secret: {side} value>\n");
            text = text.replacen(&line, &repl, 1);
        }
    }
    text
}
