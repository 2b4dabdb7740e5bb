//! "At factory settings (a new or exchanged unit?)": whether a drive that
//! differs from its set holds its schema's factory defaults where it
//! differs, so `status` and `commission` can say so instead of plain drift
//! (issue 20: a spare swapped in at 3 a.m. knows nothing of the line).
//!
//! **The rule** ([`at_factory_settings`]): among the set's codes whose
//! value on the drive differs from the set's, the ones that *count* are
//! those whose schema gives a `default` (the factory default of the
//! manuals' code tables), that are not a password (the drive's value is
//! not shown), and that are not the bus address or line rate (role
//! `bus-address` / `baud-rate`: the drive answers at the manifest's address
//! and rate whatever it held at the factory). The drive is *at factory
//! settings* when at least one code counts and the drive holds the default
//! of every code that counts. Codes without a default neither prove nor
//! disprove it. A drive that holds its set is never "at factory settings".

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use crate::plan::value_text;

/// The words the CLI and the reports use.
pub const FACTORY_WORDS: &str = "at factory settings (a new or exchanged unit?)";

/// One code where the drive differs from its set: its key and the drive's
/// value as display text ([`crate::plan::value_text`]), `None` when unknown.
pub type Differing<'a> = (CodeKey, Option<&'a str>);

/// Module docs, "The rule": `differing` lists the codes where the drive
/// differs from its set, with the drive's value as display text.
pub fn at_factory_settings<'a>(
    schema: &Schema,
    differing: impl IntoIterator<Item = Differing<'a>>,
) -> bool {
    let mut counted = 0usize;
    for (key, drive_text) in differing {
        let Some(code) = schema.code(key.number) else {
            continue;
        };
        if schema.is_password(code) || code.role().is_some_and(driveset_schema::Role::is_bus_link) {
            continue;
        }
        let Some(fact) = &code.default else { continue };
        let Ok(default) = schema.fact_raw(code, fact) else {
            continue;
        };
        match drive_text {
            Some(t) if t == value_text(schema, key, &default) => counted += 1,
            _ => return false,
        }
    }
    counted > 0
}

/// [`at_factory_settings`] of the values read from a drive (`live`) against
/// its set (`status`).
pub fn live_at_factory_settings(schema: &Schema, live: &ResolvedSet, set: &ResolvedSet) -> bool {
    let texts: Vec<(CodeKey, Option<String>)> = set
        .values
        .iter()
        .filter(|(k, v)| live.values.get(k) != Some(*v))
        .map(|(k, _)| {
            let text = live
                .values
                .get(k)
                .map(|raw: &RawValue| value_text(schema, *k, raw));
            (*k, text)
        })
        .collect();
    at_factory_settings(schema, texts.iter().map(|(k, t)| (*k, t.as_deref())))
}

/// [`at_factory_settings`] of what an upload found before writing
/// (`commission`): the codes it wrote, with their old values.
pub fn upload_at_factory_settings(schema: &Schema, codes: &[crate::upload::CodeReport]) -> bool {
    at_factory_settings(
        schema,
        codes
            .iter()
            .filter(|c| c.outcome != crate::upload::CodeOutcome::Unchanged)
            .map(|c| {
                let key = CodeKey {
                    number: c.number,
                    subcode: c.subcode,
                };
                (key, Some(c.old.as_str()))
            }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use driveset_schema::Registry;

    fn tmd() -> std::sync::Arc<Schema> {
        Registry::builtin()
            .unwrap()
            .get("lenze-tmd")
            .expect("built-in tmd schema")
    }

    fn text(schema: &Schema, n: u32, raw: i64) -> String {
        value_text(schema, CodeKey::new(n), &RawValue::Int(raw))
    }

    fn default_text(schema: &Schema, n: u32) -> String {
        let c = schema.code(n).unwrap();
        let d = schema.fact_raw(c, c.default.as_ref().unwrap()).unwrap();
        value_text(schema, CodeKey::new(n), &d)
    }

    #[test]
    fn every_counted_code_at_its_default_is_factory() {
        let s = tmd();
        let d11 = default_text(&s, 11);
        let d12 = default_text(&s, 12);
        assert!(at_factory_settings(
            &s,
            [
                (CodeKey::new(11), Some(d11.as_str())),
                (CodeKey::new(12), Some(d12.as_str()))
            ]
        ));
    }

    #[test]
    fn one_code_off_its_default_is_plain_drift() {
        let s = tmd();
        let d11 = default_text(&s, 11);
        let other = text(&s, 11, 550_000);
        assert_ne!(other, d11);
        let d12 = default_text(&s, 12);
        assert!(!at_factory_settings(
            &s,
            [
                (CodeKey::new(11), Some(other.as_str())),
                (CodeKey::new(12), Some(d12.as_str()))
            ]
        ));
        assert!(!at_factory_settings(&s, [(CodeKey::new(12), None)]));
    }

    #[test]
    fn nothing_counted_is_not_factory() {
        let s = tmd();
        assert!(!at_factory_settings(&s, []));
        // the bus address does not count
        let d9 = default_text(&s, 9);
        assert!(!at_factory_settings(
            &s,
            [(CodeKey::new(9), Some(d9.as_str()))]
        ));
    }
}
