//! Owns the semantic diff of two resolved sets of one schema, the diff
//! against factory defaults, and the unified diff of canonical forms; what
//! `driveset diff A [B]` compares ([`Compared`]).

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

/// What `driveset diff A [B]` compares ([`Compared::of`]): A (old) and
/// B (new), or, without B, the factory defaults of A's codes (old) and A
/// (new, [`diff_defaults`]); each side named as the output names it.
#[derive(Debug, Clone)]
pub struct Compared {
    /// The old side.
    pub old: ResolvedSet,
    /// The new side.
    pub new: ResolvedSet,
    /// The old side's name (a file, or `factory defaults (<schema id>)`).
    pub old_name: String,
    /// The new side's name.
    pub new_name: String,
    /// Whether the old side is the factory defaults.
    pub defaults: bool,
}

/// Two sets of different schemas: there is nothing to compare.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot diff sets of different schemas: `{a}` and `{b}`")]
pub struct OtherSchemas {
    /// A's schema id.
    pub a: String,
    /// B's schema id.
    pub b: String,
}

impl Compared {
    /// A (named `a_name`, of `schema`) against B (with its name), or
    /// against its factory defaults when there is no B.
    ///
    /// # Errors
    /// [`OtherSchemas`]: B is a set of another schema.
    pub fn of(
        a: &ResolvedSet,
        a_name: String,
        b: Option<(ResolvedSet, String)>,
        schema: &Schema,
    ) -> Result<Compared, OtherSchemas> {
        match b {
            None => Ok(Compared {
                old: defaults_for(a, schema),
                new: a.clone(),
                old_name: format!("factory defaults ({})", schema.id),
                new_name: a_name,
                defaults: true,
            }),
            Some((b, _)) if b.schema != a.schema => Err(OtherSchemas {
                a: a.schema.clone(),
                b: b.schema,
            }),
            Some((b, b_name)) => Ok(Compared {
                old: a.clone(),
                new: b,
                old_name: a_name,
                new_name: b_name,
                defaults: false,
            }),
        }
    }

    /// The semantic diff of the two sides ([`diff`], or [`diff_defaults`]).
    ///
    /// # Errors
    /// [`DiffError`].
    pub fn diff(&self, schema: &Schema) -> Result<Diff, DiffError> {
        if self.defaults {
            diff_defaults(&self.new, schema)
        } else {
            diff(&self.old, &self.new, schema)
        }
    }

    /// The unified diff of the two sides' canonical forms ([`unified_diff`]).
    pub fn unified(&self, schema: &Schema) -> String {
        unified_diff(&self.old, &self.new, schema, &self.old_name, &self.new_name)
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Registry;

    #[test]
    fn a_set_is_compared_with_another_of_its_schema_or_its_defaults() {
        let registry = Registry::builtin().expect("built-in schemas");
        let tmd = registry.get("lenze-tmd").expect("built in");
        let ecs = registry.get("lenze-ecs").expect("built in");
        let mut a = ResolvedSet::new(&tmd);
        a.insert(CodeKey::new(11), RawValue::Int(600_000));
        let default = defaults_for(&ResolvedSet::new(&tmd), &tmd);
        let d = Compared::of(&a, "a.toml".into(), None, &tmd).expect("defaults");
        assert!(d.defaults && d.new == a && d.new_name == "a.toml");
        assert_eq!(d.old_name, "factory defaults (lenze-tmd)");
        assert_eq!(d.diff(&tmd), diff_defaults(&a, &tmd));
        assert!(default.values.is_empty());
        let same =
            Compared::of(&a, "a".into(), Some((a.clone(), "b".into())), &tmd).expect("same schema");
        assert!(!same.defaults && same.diff(&tmd).expect("diffs").is_empty());
        assert!(same.unified(&tmd).is_empty());
        let other = Compared::of(
            &a,
            "a".into(),
            Some((ResolvedSet::new(&ecs), "b".into())),
            &tmd,
        )
        .expect_err("other schema");
        assert_eq!(
            (other.a.as_str(), other.b.as_str()),
            ("lenze-tmd", "lenze-ecs")
        );
    }
}
