//! A journal's raw values (docs/journals.md, "The file": `{"int": N}`,
//! `{"text": "..."}`, `{"octets": "0aff"}`, raw, in the drive's units):
//! [`JournalValue`], the one conversion between a drive's raw value and its
//! JSON form, both ways, its text for messages (its `Display`), and
//! [`raw_values`], the one reading of a list of
//! journal entries into codes and raw values (backup, plan, unchanged).

use std::fmt;

use driveset_schema::{CodeKey, RawValue};
use serde::{Deserialize, Serialize};

/// A raw value in the journal: `{"int": 5}`, `{"text": "abc"}`, `{"octets": "0aff"}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JournalValue {
    /// [`RawValue::Int`].
    Int(i64),
    /// [`RawValue::Text`].
    Text(String),
    /// [`RawValue::Octets`], lowercase hex.
    Octets(String),
}

impl From<&RawValue> for JournalValue {
    fn from(v: &RawValue) -> Self {
        match v {
            RawValue::Int(i) => JournalValue::Int(*i),
            RawValue::Text(t) => JournalValue::Text(t.clone()),
            RawValue::Octets(o) => {
                JournalValue::Octets(o.iter().map(|b| format!("{b:02x}")).collect())
            }
        }
    }
}

impl JournalValue {
    /// The raw value, or `None` for malformed octets.
    pub fn to_raw(&self) -> Option<RawValue> {
        Some(match self {
            JournalValue::Int(i) => RawValue::Int(*i),
            JournalValue::Text(t) => RawValue::Text(t.clone()),
            JournalValue::Octets(h) => {
                if h.len() % 2 != 0 || !h.is_ascii() {
                    return None;
                }
                let mut out = Vec::with_capacity(h.len() / 2);
                for i in (0..h.len()).step_by(2) {
                    out.push(u8::from_str_radix(h.get(i..i + 2)?, 16).ok()?);
                }
                RawValue::Octets(out)
            }
        })
    }
}

/// A journal value as messages show it, raw: the integer in decimal, the
/// text as it is, the octets as their lowercase hex (the JSON form's
/// content without its key).
impl fmt::Display for JournalValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            JournalValue::Int(i) => write!(f, "{i}"),
            JournalValue::Text(t) | JournalValue::Octets(t) => f.write_str(t),
        }
    }
}

/// The code and raw value of each entry (`(code, its spelling, its
/// value)`), in order; the first malformed value is an error naming the
/// code: `{what} of {code} is malformed`.
pub(super) fn raw_values<'a>(
    entries: impl Iterator<Item = (CodeKey, &'a str, &'a JournalValue)>,
    what: &str,
) -> Result<Vec<(CodeKey, RawValue)>, String> {
    entries
        .map(|(key, code, v)| {
            v.to_raw()
                .map(|v| (key, v))
                .ok_or_else(|| format!("{what} of {code} is malformed"))
        })
        .collect()
}
