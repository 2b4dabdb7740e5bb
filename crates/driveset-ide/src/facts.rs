//! Owns what an editor shows about one code: the key forms a set may write
//! it with (as `driveset_schema::set` resolves them: number, `C`+number,
//! name, alias, LUSTBUS `NN-NAME`, `/N` subcodes) and its facts as markdown
//! (title, type, unit, range, default, labels, bit fields, storage kind,
//! role, access, spec section, note). The JSON Schema's descriptions and
//! the language server's hover are both this text.

use driveset_schema::Decimal;
use driveset_schema::schema::{Access, Code, CodeStyle, StorageKind};
use driveset_schema::value::{Repr, raw_to_decimal};
use driveset_schema::{RawValue, Schema, ValueType};

/// A code's effective numeric range in engineering units: the schema's
/// `min` / `max` within the type's own range, exact. `None` on a side
/// without a bound (text, octets, a float without a schema bound).
pub fn range(schema: &Schema, code: &Code) -> (Option<Decimal>, Option<Decimal>) {
    let Some(ty) = schema.type_of(code) else {
        return (None, None);
    };
    let fact = |f: &Option<driveset_schema::schema::Fact>| -> Option<i64> {
        match schema.fact_raw(code, f.as_ref()?) {
            Ok(RawValue::Int(r)) => Some(r),
            _ => None,
        }
    };
    match ty.repr() {
        Repr::Scaled(_) => {
            let Some((tlo, thi)) = ty.raw_range(code.width) else {
                return (None, None);
            };
            let lo = fact(&code.min).map_or(tlo, |m| m.max(tlo));
            let hi = fact(&code.max).map_or(thi, |m| m.min(thi));
            (raw_to_decimal(ty, lo), raw_to_decimal(ty, hi))
        }
        // an f32 bound is the schema's text, as written (exact decimal)
        Repr::Float => {
            let text =
                |f: &Option<driveset_schema::schema::Fact>| match f.as_ref().map(|f| &f.value) {
                    Some(
                        driveset_schema::doc::NodeKind::Str(t)
                        | driveset_schema::doc::NodeKind::Num(t),
                    ) => Decimal::parse(t.trim()).ok(),
                    _ => None,
                };
            (text(&code.min), text(&code.max))
        }
        Repr::Text | Repr::Octets => (None, None),
    }
}

/// Whether a set can give the code no value at all, and why: read-only,
/// a command, or a type driveset does not know (`validate` refuses each).
pub fn refused(schema: &Schema, code: &Code) -> Option<&'static str> {
    if code.access == Some(Access::Ro) {
        return Some("read-only: a set cannot write it");
    }
    if code.role == Some(driveset_schema::Role::Command) {
        return Some("a command, not a setting: a set cannot hold it");
    }
    if schema.type_of(code).is_none() {
        return Some("its type is unknown, so a set cannot give it a value");
    }
    None
}

/// Whether the code's enumeration lists every value it takes (then a set
/// must give a listed label or number; `values_partial` says otherwise).
pub fn complete_enum(code: &Code) -> bool {
    code.bits.is_empty() && code.values.is_some() && code.values_partial != Some(true)
}

/// The enumeration of a code as (engineering number, label).
pub fn labels<'a>(schema: &'a Schema, code: &'a Code) -> Vec<(i64, &'a str)> {
    code.values
        .as_ref()
        .and_then(|v| schema.enum_of(v))
        .map(|e| e.entries.iter().map(|(v, l, _)| (*v, l.as_str())).collect())
        .unwrap_or_default()
}

/// The key a set writes the code with by default: `C0011`, LUSTBUS
/// `428-RSIO`; a CiA object kept by index by its name (its number key is
/// 65536 + index, which nobody writes).
pub fn canonical_key(schema: &Schema, code: &Code) -> String {
    if code.index.is_some() && !code.name.is_empty() {
        return code.name.clone();
    }
    match schema.code_style {
        CodeStyle::Lenze => format!("C{:04}", code.number),
        CodeStyle::Lust => schema.display_code(code.number, None),
    }
}

/// Every key of the code without a subcode that a set may name it by,
/// except the number spellings [`number_pattern`] covers: the canonical
/// key first, then the name and aliases (and LUSTBUS `NN-ALIAS`).
pub fn named_keys(schema: &Schema, code: &Code) -> Vec<String> {
    let mut keys = vec![canonical_key(schema, code)];
    let mut push = |k: String| {
        if !k.is_empty() && !keys.contains(&k) {
            keys.push(k);
        }
    };
    push(code.name.clone());
    for (a, _) in &code.aliases {
        push(a.clone());
    }
    if schema.code_style == CodeStyle::Lust {
        for (a, _) in &code.aliases {
            push(format!("{}-{a}", code.number));
        }
        push(code.number.to_string());
    }
    keys
}

/// The regular expression (ECMA 262 and Rust `regex` alike) of the number
/// spellings the set reader takes for a code: `11`, `011`, `C11`, `c0011`.
pub fn number_pattern(code: &Code) -> String {
    format!("[Cc]?0*{}", code.number)
}

/// Escape a literal for a regular expression.
pub fn regex_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if "\\^$.|?*+()[]{}/-".contains(c) {
            out.push('\\');
        }
        out.push(c);
    }
    out
}

fn storage(kind: StorageKind) -> &'static str {
    match kind {
        StorageKind::RamActual => "RAM actual value (ram-actual)",
        StorageKind::RamControl => "RAM control value (ram-control)",
        StorageKind::Eeprom => "EEPROM (eeprom)",
        StorageKind::FselIsel => "FSEL/ISEL variable (fsel-isel)",
    }
}

fn with_unit(d: &Decimal, code: &Code) -> String {
    match &code.unit {
        Some(u) => format!("{d} {u}"),
        None => d.to_string(),
    }
}

/// The default as a set would write it (label, number with unit), or
/// `<secret>` for a password.
pub fn default_text(schema: &Schema, code: &Code) -> Option<String> {
    let f = code.default.as_ref()?;
    match schema.fact_raw(code, f) {
        Ok(raw) => Some(driveset_schema::validate::display_value(schema, code, &raw)),
        Err(_) => None,
    }
}

/// One line of the code's range: `7.5 ..= 480 Hz`.
pub fn range_text(schema: &Schema, code: &Code) -> Option<String> {
    match range(schema, code) {
        (Some(lo), Some(hi)) => Some(format!("{lo} ..= {}", with_unit(&hi, code))),
        (Some(lo), None) => Some(format!("at least {}", with_unit(&lo, code))),
        (None, Some(hi)) => Some(format!("at most {}", with_unit(&hi, code))),
        (None, None) => None,
    }
}

/// The code's facts as markdown, for hover and JSON Schema descriptions.
pub fn markdown(schema: &Schema, code: &Code) -> String {
    let mut out = format!("**{}**", schema.display_code(code.number, None));
    if !code.name.is_empty() && schema.code_style == CodeStyle::Lenze {
        out.push_str(&format!(" `{}`", code.name));
    }
    if let Some(t) = &code.title {
        out.push_str(&format!(" — {t}"));
    }
    out.push_str("\n\n");
    let mut line = |label: &str, value: String| out.push_str(&format!("- {label}: {value}\n"));
    if let Some(why) = refused(schema, code) {
        line("**not in sets**", why.to_string());
    }
    if schema.is_password(code) {
        line(
            "**secret**",
            "a password: never shown in any output, exports write `<secret>`".into(),
        );
    }
    let ty = schema.type_of(code);
    if let Some(ty) = ty {
        let step = match ty.repr() {
            Repr::Scaled(1) | Repr::Text | Repr::Octets => String::new(),
            Repr::Float => " (IEEE 754 single)".into(),
            Repr::Scaled(_) => format!(" (step {})", ty.step_text()),
        };
        line("type", format!("{}{step}", ty.name()));
    }
    if let Some(u) = &code.unit {
        line("unit", u.clone());
    }
    if ty.is_some_and(|t| t == ValueType::VS) {
        line("text", "at most 20 visible ASCII characters".into());
    }
    if let Some(r) = range_text(schema, code) {
        line("range", r);
    }
    if let Some(d) = default_text(schema, code) {
        line("default", d);
    }
    if let Some(n) = code.subcodes {
        line(
            "subcodes",
            format!(
                "1 ..= {n} (`{}`)",
                schema.display_code(code.number, Some(1))
            ),
        );
    }
    let labels = labels(schema, code);
    if !labels.is_empty() {
        let listed: Vec<String> = labels
            .iter()
            .map(|(v, l)| format!("{v} = \"{l}\""))
            .collect();
        let how = if complete_enum(code) {
            "values"
        } else {
            "values (some; others in range too)"
        };
        line(how, listed.join(", "));
    }
    for b in &code.bits {
        let bits = if b.lsb == b.msb {
            format!("bit {}", b.lsb)
        } else {
            format!("bits {}..{}", b.lsb, b.msb)
        };
        let mut text = format!("`{}` ({bits})", b.name);
        if let Some(t) = &b.title {
            text.push_str(&format!(" {t}"));
        }
        if let Some(e) = b.values.as_ref().and_then(|v| schema.enum_of(v)) {
            let l: Vec<String> = e
                .entries
                .iter()
                .map(|(v, l, _)| format!("{v} = \"{l}\""))
                .collect();
            text.push_str(&format!(": {}", l.join(", ")));
        }
        line("bit field", text);
    }
    if let Some(k) = code.kind {
        line("storage", storage(k).into());
    }
    if let Some(r) = code.role {
        line("role", r.to_string());
    }
    match code.access {
        Some(Access::Standstill) => line("access", "writable at standstill only".into()),
        Some(Access::Ro) => line("access", "read-only".into()),
        _ => {}
    }
    if let Some(s) = &code.spec {
        line("spec", s.clone());
    }
    if let Some(n) = &code.note {
        out.push_str(&format!("\n{n}\n"));
    }
    out.push_str(&format!("\nschema `{}` ({})\n", schema.id, schema.path));
    out
}
