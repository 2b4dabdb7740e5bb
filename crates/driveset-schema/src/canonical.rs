//! Owns [`ResolvedSet`] (the one model set files, pulled sets and live
//! drives share), its canonical text and fingerprint (docs/file-formats.md,
//! "Canonical form and fingerprint").

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;

use sha2::{Digest, Sha256};

use crate::schema::{CodeStyle, Schema};

/// A raw value as the device holds it.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RawValue {
    /// Every integer-raw type (scaled, VH, bit-coded, f32 bit pattern).
    Int(i64),
    /// VS text.
    Text(String),
    /// VO octets.
    Octets(Vec<u8>),
}

/// A code and optional subcode; sorts by (number, subcode), no subcode first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CodeKey {
    /// Code number.
    pub number: u32,
    /// Subcode (`C0039/1`), if any.
    pub subcode: Option<u32>,
}

impl CodeKey {
    /// A code without subcode.
    pub fn new(number: u32) -> Self {
        CodeKey {
            number,
            subcode: None,
        }
    }
    /// A code with a subcode.
    pub fn sub(number: u32, subcode: u32) -> Self {
        CodeKey {
            number,
            subcode: Some(subcode),
        }
    }
    /// Canonical spelling: lenze `C0011`, `C0039/1`; lust `428`, `428/1`.
    pub fn canonical(&self, style: CodeStyle) -> String {
        let mut s = String::with_capacity(8);
        self.write_canonical(style, &mut s);
        s
    }

    fn write_canonical(&self, style: CodeStyle, out: &mut String) {
        if style == CodeStyle::Lenze {
            out.push('C');
            for p in [1000, 100, 10] {
                if self.number < p {
                    out.push('0');
                }
            }
        }
        push_int(out, i64::from(self.number));
        if let Some(sc) = self.subcode {
            out.push('/');
            push_int(out, i64::from(sc));
        }
    }
}

/// Append a decimal integer (the canonical form's hot path; no formatter).
fn push_int(out: &mut String, v: i64) {
    let mut buf = [0u8; 20];
    let mut n = v.unsigned_abs();
    let mut i = buf.len();
    loop {
        i -= 1;
        if let Some(d) = buf.get_mut(i) {
            *d = b'0' + (n % 10) as u8;
        }
        n /= 10;
        if n == 0 || i == 0 {
            break;
        }
    }
    if v < 0 {
        out.push('-');
    }
    out.push_str(std::str::from_utf8(buf.get(i..).unwrap_or(&[])).unwrap_or(""));
}

/// A set reduced to raw values: schema id + code -> raw value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResolvedSet {
    /// Schema id.
    pub schema: String,
    /// Code spelling of the schema (for the canonical form).
    pub code_style: CodeStyle,
    /// Values.
    pub values: BTreeMap<CodeKey, RawValue>,
    /// Code numbers whose values are secrets (the schema's passwords, see
    /// `Schema::is_password`): the canonical form and the fingerprint hold
    /// them only as present ([`SECRET`]), never by value.
    pub secrets: BTreeSet<u32>,
}

/// How the canonical form writes a secret's value.
pub const SECRET: &str = "<secret>";

impl ResolvedSet {
    /// An empty set for a schema (the engine fills it from values read off a bus).
    pub fn new(schema: &Schema) -> Self {
        ResolvedSet {
            schema: schema.id.clone(),
            code_style: schema.code_style,
            values: BTreeMap::new(),
            secrets: schema
                .codes
                .iter()
                .filter(|c| schema.is_password(c))
                .map(|c| c.number)
                .collect(),
        }
    }

    /// Whether `key`'s value is a secret.
    pub fn is_secret(&self, key: &CodeKey) -> bool {
        self.secrets.contains(&key.number)
    }

    /// Set a value.
    pub fn insert(&mut self, key: CodeKey, raw: RawValue) {
        self.values.insert(key, raw);
    }

    /// The canonical text: `driveset-canonical 1`, `schema <id>`, then one
    /// line per value sorted by (number, subcode); every line ends with `\n`.
    /// A secret's value is written as [`SECRET`]: the text (and so the
    /// fingerprint) says that the set holds it, not what it is, so nobody
    /// can recover it by trying values against a published fingerprint.
    pub fn canonical(&self) -> String {
        self.canonical_text(false)
    }

    /// The canonical text with the secrets' values: only for what stays as
    /// private as the drive itself (the simulator's state files). Never
    /// print it, fingerprint it or put it in a report.
    pub fn canonical_with_secrets(&self) -> String {
        self.canonical_text(true)
    }

    fn canonical_text(&self, with_secrets: bool) -> String {
        let mut out = String::with_capacity(32 + self.values.len() * 16);
        out.push_str("driveset-canonical 1\n");
        let _ = writeln!(out, "schema {}", self.schema);
        for (k, v) in &self.values {
            k.write_canonical(self.code_style, &mut out);
            out.push(' ');
            if !with_secrets && self.is_secret(k) {
                out.push_str(SECRET);
                out.push('\n');
                continue;
            }
            match v {
                RawValue::Int(i) => push_int(&mut out, *i),
                RawValue::Text(t) => {
                    out.push('s');
                    out.push_str(&serde_json::to_string(t).unwrap_or_else(|_| "\"\"".into()));
                }
                RawValue::Octets(o) => {
                    out.push('o');
                    for b in o {
                        let _ = write!(out, "{b:02x}");
                    }
                }
            }
            out.push('\n');
        }
        out
    }

    /// `sha256:` + lowercase hex sha256 of [`ResolvedSet::canonical`].
    pub fn fingerprint(&self) -> String {
        let digest = Sha256::digest(self.canonical().as_bytes());
        const HEX: &[u8; 16] = b"0123456789abcdef";
        let mut s = String::with_capacity(71);
        s.push_str("sha256:");
        for b in digest.iter() {
            s.push(char::from(HEX[usize::from(b >> 4)]));
            s.push(char::from(HEX[usize::from(b & 15)]));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_text_and_fingerprint() {
        let mut s = ResolvedSet {
            schema: "lenze-tmd".into(),
            code_style: CodeStyle::Lenze,
            values: BTreeMap::new(),
            secrets: BTreeSet::new(),
        };
        s.insert(CodeKey::new(200), RawValue::Text("33STMD-M_12000".into()));
        s.insert(CodeKey::new(11), RawValue::Int(500000));
        s.insert(CodeKey::new(7), RawValue::Int(17185));
        s.insert(CodeKey::sub(39, 1), RawValue::Int(200000));
        s.insert(CodeKey::new(39), RawValue::Octets(vec![0x0a, 0xff]));
        assert_eq!(
            s.canonical(),
            "driveset-canonical 1\nschema lenze-tmd\nC0007 17185\nC0011 500000\nC0039 o0aff\nC0039/1 200000\nC0200 s\"33STMD-M_12000\"\n"
        );
        let mut empty = ResolvedSet {
            schema: "x".into(),
            code_style: CodeStyle::Lust,
            values: BTreeMap::new(),
            secrets: BTreeSet::new(),
        };
        // sha256 of "driveset-canonical 1\nschema x\n"
        assert_eq!(empty.fingerprint().len(), 71);
        empty.insert(CodeKey::new(428), RawValue::Int(-5));
        assert!(empty.canonical().ends_with("\n428 -5\n"));
        // a secret is present / absent, never its value
        empty.secrets.insert(70);
        empty.insert(CodeKey::new(70), RawValue::Int(1234));
        let fp = empty.fingerprint();
        assert_eq!(
            empty.canonical(),
            "driveset-canonical 1\nschema x\n70 <secret>\n428 -5\n"
        );
        assert_eq!(
            empty.canonical_with_secrets(),
            "driveset-canonical 1\nschema x\n70 1234\n428 -5\n"
        );
        empty.insert(CodeKey::new(70), RawValue::Int(4321));
        assert_eq!(empty.fingerprint(), fp);
        empty.values.remove(&CodeKey::new(70));
        assert_ne!(empty.fingerprint(), fp);
    }
}
