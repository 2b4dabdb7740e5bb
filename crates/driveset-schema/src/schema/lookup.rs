//! Looking codes up in a [`Schema`] (by number, by name, by Lenze
//! subindex), their types and enumerations, and spelling them for humans
//! (`C0011 nmax`, `428-RSIO`, `0x1018sub1`).

use crate::canonical::RawValue;
use crate::role::Role;
use crate::value::ValueType;

use super::{Code, CodeStyle, EnumDef, EnumSource, Fact, Schema, index_number, looks_numeric_key};

impl Schema {
    /// Code by number.
    pub fn code(&self, number: u32) -> Option<&Code> {
        self.by_number.get(&number).and_then(|&i| self.codes.get(i))
    }

    /// Like [`Schema::code_by_name`], but skips the hash lookup for keys
    /// shaped like code numbers (`C0011`, `428`) unless some name has that shape.
    pub(crate) fn code_by_name_fast(&self, key: &str) -> Option<&Code> {
        if !self.numeric_names && looks_numeric_key(key) {
            return None;
        }
        self.code_by_name(key)
    }

    /// Code by name or alias (exact).
    pub fn code_by_name(&self, name: &str) -> Option<&Code> {
        self.by_name.get(name).and_then(|&i| self.codes.get(i))
    }

    /// Resolved type of a code: its own known type, or `default_type` when it gives none.
    /// `None` when the type is unknown (or an unknown name).
    pub fn type_of(&self, code: &Code) -> Option<ValueType> {
        match &code.type_name {
            Some(_) => code.resolved_type,
            None => self.default_type,
        }
    }

    /// Labels of an enum source.
    pub fn enum_of<'a>(&'a self, src: &'a EnumSource) -> Option<&'a EnumDef> {
        match src {
            EnumSource::Inline(e) => Some(e),
            EnumSource::Ref { name, .. } => self.enums.get(name),
        }
    }

    /// The single-subindex code (`[[code]] index` + `subindex`) at Lenze
    /// code `number`'s index (`index_base - number`) and `subcode`: what
    /// `C5020/2` names when the schema keeps that subindex as its own code.
    pub fn lenze_subindex_code(&self, number: u32, subcode: u32) -> Option<&Code> {
        let base = self.can_index_base?;
        let index = u16::try_from(base.checked_sub(number)?).ok()?;
        let sub = u8::try_from(subcode).ok()?;
        self.code(index_number(index, Some(sub)))
            .filter(|c| c.index == Some(index) && c.subindex == Some(sub))
    }

    /// Code as spelled for humans: `C0011`, `C0039/1`; lust `428-RSIO` (with name).
    pub fn display_code(&self, number: u32, subcode: Option<u32>) -> String {
        let mut s = match self.code_style {
            CodeStyle::Lenze => match self.code(number).map(|c| (c.index, c.subindex)) {
                Some((Some(i), Some(s))) => format!("0x{i:04X}sub{s}"),
                Some((Some(i), None)) => format!("0x{i:04X}"),
                _ => format!("C{number:04}"),
            },
            CodeStyle::Lust => match self.code(number) {
                Some(c) if !c.name.is_empty() => format!("{number}-{}", c.name),
                _ => number.to_string(),
            },
        };
        if let Some(sc) = subcode {
            s.push_str(&format!("/{sc}"));
        }
        s
    }

    /// A code as humans read it in reports, plans and diffs: the display
    /// code ([`Schema::display_code`]), and on Lenze codes the name after it
    /// (`C0011 nmax`; Lust codes carry their name already: `428-RSIO`). A
    /// schema file's name is shown to people, so control characters are
    /// escaped.
    pub fn code_label(&self, key: crate::canonical::CodeKey) -> String {
        let code = self.display_code(key.number, key.subcode);
        match self.code(key.number) {
            Some(c) if !c.name.is_empty() && self.code_style == CodeStyle::Lenze => {
                format!("{code} {}", crate::error::escape_controls(&c.name))
            }
            _ => code,
        }
    }

    /// Label of a code's raw value. Enumeration keys are engineering integers
    /// (so `1 = "..."` on a VD code means raw 10000; docs/file-formats.md).
    pub fn enum_label<'a>(&'a self, code: &'a Code, raw: i64) -> Option<&'a str> {
        let e = self.enum_of(code.values.as_ref()?)?;
        let factor = self.enum_factor(code);
        if raw % factor != 0 {
            return None;
        }
        e.label(raw / factor)
    }

    /// Raw value of a code's label (case-insensitive).
    pub fn enum_value(&self, code: &Code, label: &str) -> Option<i64> {
        let e = self.enum_of(code.values.as_ref()?)?;
        e.value_of(label)?.checked_mul(self.enum_factor(code))
    }

    fn enum_factor(&self, code: &Code) -> i64 {
        match self.type_of(code).map(ValueType::repr) {
            Some(crate::value::Repr::Scaled(f)) => i64::from(f),
            _ => 1,
        }
    }

    /// Whether a code's values are secrets (`role = "password"` or type
    /// PT_PASSWORD): masked in every output and in the canonical form.
    pub fn is_password(&self, code: &Code) -> bool {
        code.role == Some(Role::Password) || self.type_of(code) == Some(ValueType::PT_PASSWORD)
    }

    /// Convert a schema fact (min/max/default) to a raw value.
    pub fn fact_raw(&self, code: &Code, fact: &Fact) -> Result<RawValue, String> {
        crate::validate::fact_to_raw(self, code, &fact.value)
    }

    pub(super) fn reindex(&mut self) {
        self.by_number.clear();
        self.by_name.clear();
        for c in &mut self.codes {
            c.resolved_type = c
                .type_name
                .as_ref()
                .and_then(|(n, _)| ValueType::from_name(n));
        }
        if let Some(ident) = &self.identify {
            for c in &mut self.codes {
                if c.role.is_none() && ident.codes.contains(&c.number) {
                    c.role = Some(Role::Identify);
                }
            }
        }
        for (i, c) in self.codes.iter().enumerate() {
            self.by_number.entry(c.number).or_insert(i);
            if !c.name.is_empty() {
                self.by_name.entry(c.name.clone()).or_insert(i);
            }
            for (a, _) in &c.aliases {
                self.by_name.entry(a.clone()).or_insert(i);
            }
        }
        self.numeric_names = self.by_name.keys().any(|k| looks_numeric_key(k));
    }
}
