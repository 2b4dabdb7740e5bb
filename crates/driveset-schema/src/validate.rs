//! Owns turning one set value (a document node) into a raw value for its
//! code, with findings (docs/file-formats.md, "Parameter sets" and "Types and
//! raw values"), and the cross-code rules of a schema (`[[rule]]`).

use std::cmp::Ordering;

use crate::canonical::{CodeKey, RawValue};
use crate::decimal::Decimal;
use crate::doc::{Document, Node, NodeKind};
use crate::error::{Finding, FindingKind, Location};
use crate::schema::{BitField, Code, Rule, Schema};
use crate::value::{
    self, ConvError, Repr, ValueType, check_vs_text, decimal_to_raw, float_text_to_raw,
    parse_octets, parse_radix_int, raw_to_engineering,
};

/// A value problem before it gets a location.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ValueErr {
    pub kind: FindingKind,
    pub message: String,
    pub help: String,
}

fn verr(kind: FindingKind, message: impl Into<String>, help: impl Into<String>) -> ValueErr {
    ValueErr {
        kind,
        message: message.into(),
        help: help.into(),
    }
}

/// A converted value with where it came from (for rule findings).
#[derive(Debug, Clone)]
pub(crate) struct Placed<'d> {
    pub raw: RawValue,
    /// The file the value is in.
    pub doc: &'d Document,
    /// Span of the value.
    pub span: std::ops::Range<usize>,
    /// Bit-field members given by name, with their value spans.
    pub members: Vec<(String, std::ops::Range<usize>)>,
}

impl Placed<'_> {
    pub fn loc(&self) -> Location {
        self.doc.loc(&self.span)
    }
}

/// Longest user text quoted in full in a message.
const MAX_QUOTED_CHARS: usize = 60;

/// User text quoted for a message (`"..."`, Rust escapes), shortened when long
/// so a huge value does not make a huge message.
struct Quoted<'a>(&'a str);

impl std::fmt::Display for Quoted<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.0.chars().count();
        if n <= MAX_QUOTED_CHARS {
            return write!(f, "{:?}", self.0);
        }
        let head: String = self.0.chars().take(MAX_QUOTED_CHARS).collect();
        write!(f, "{head:?}... ({n} characters)")
    }
}

/// `C0011` (lazily formatted).
struct CodeName<'a>(&'a Schema, u32);

impl std::fmt::Display for CodeName<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0.display_code(self.1, None))
    }
}

/// `C0011 (VD)` (lazily formatted).
struct TypeDesc<'a>(&'a Schema, &'a Code, ValueType);

impl std::fmt::Display for TypeDesc<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({})",
            self.0.display_code(self.1.number, None),
            self.2.name()
        )
    }
}

/// Engineering text of a raw value with unit and label, for messages and diffs.
/// Passwords show as `<secret>` ([`crate::canonical::SECRET`]).
pub fn display_value(schema: &Schema, code: &Code, raw: &RawValue) -> String {
    // labels and units come from schema files: no raw control characters
    let shown = display_value_unescaped(schema, code, raw);
    match crate::error::escape_controls(&shown) {
        std::borrow::Cow::Borrowed(_) => shown,
        std::borrow::Cow::Owned(e) => e,
    }
}

fn display_value_unescaped(schema: &Schema, code: &Code, raw: &RawValue) -> String {
    if schema.is_password(code) {
        return crate::canonical::SECRET.into();
    }
    match raw {
        RawValue::Text(t) => serde_json::to_string(t).unwrap_or_default(),
        RawValue::Octets(o) => {
            let mut s = String::from("0x");
            for b in o {
                s.push_str(&format!("{b:02x}"));
            }
            s
        }
        RawValue::Int(i) => {
            if let Some(label) = schema.enum_label(code, *i) {
                return format!("\"{label}\"");
            }
            if !code.bits.is_empty() {
                let parts: Vec<String> = code
                    .bits
                    .iter()
                    .map(|b| {
                        let v = b.extract(*i);
                        match b
                            .values
                            .as_ref()
                            .and_then(|s| schema.enum_of(s))
                            .and_then(|e| e.label(v))
                        {
                            Some(l) => format!("{} = \"{l}\"", b.name),
                            None => format!("{} = {v}", b.name),
                        }
                    })
                    .collect();
                return format!("{{ {} }}", parts.join(", "));
            }
            let ty = schema.type_of(code).unwrap_or(ValueType::PT_MC_ERROR);
            if schema.type_of(code).is_some()
                && let Some(fields) = value::error_fields(ty, *i)
            {
                return fields;
            }
            let num = raw_to_engineering(ty, *i);
            match &code.unit {
                Some(u) => format!("{num} {u}"),
                None => num,
            }
        }
    }
}

/// Convert a schema fact (min/max/default) to a raw value, or say why not.
pub(crate) fn fact_to_raw(
    schema: &Schema,
    code: &Code,
    value: &NodeKind,
) -> Result<RawValue, String> {
    let Some(ty) = schema.type_of(code) else {
        return Err("the code's type is unknown".into());
    };
    scalar_to_raw(schema, code, ty, value, false).map_err(|e| e.message)
}

/// Split `"60.0 Hz"` into (`60.0`, `Hz`).
fn split_unit(s: &str) -> (&str, &str) {
    let t = s.trim();
    if let Some(i) = t.find(char::is_whitespace) {
        return (t[..i].trim(), t[i..].trim());
    }
    let end = t
        .char_indices()
        .find(|(i, c)| {
            !(c.is_ascii_digit()
                || matches!(c, '.' | '_' | '+' | '-')
                || (*c == 'e' || *c == 'E')
                    && *i > 0
                    && t[i + 1..].starts_with(|n: char| n.is_ascii_digit() || n == '-' || n == '+'))
        })
        .map(|(i, _)| i)
        .unwrap_or(t.len());
    (&t[..end], &t[end..])
}

fn conv_err(schema: &Schema, code: &Code, text: &str, e: ConvError) -> ValueErr {
    let what = schema.display_code(code.number, None);
    match e {
        ConvError::Unrepresentable { step, lower, upper } => verr(
            FindingKind::Unrepresentable,
            format!(
                "{what} = {text} is not representable in steps of {step}; nearest are {lower} and {upper}"
            ),
            format!("write {lower} or {upper}"),
        ),
        ConvError::OutOfRange { min, max } => {
            let negative = text.trim_start().starts_with('-') && min == "0";
            let ty = schema.type_of(code).map(|t| t.name()).unwrap_or("?");
            if negative {
                verr(
                    FindingKind::OutOfRange,
                    format!("{what} = {text} is negative, but {ty} is unsigned"),
                    format!("give a value from {min} to {max}"),
                )
            } else if ty == "PT_FLOAT_IEEE" {
                verr(
                    FindingKind::OutOfRange,
                    format!(
                        "{what} = {text} is outside the f32 range of PT_FLOAT_IEEE ({min} ..= {max})"
                    ),
                    format!("give a value from {min} to {max}"),
                )
            } else {
                verr(
                    FindingKind::OutOfRange,
                    format!("{what} = {text} is outside the range of {ty} ({min} ..= {max})"),
                    format!("give a value from {min} to {max}"),
                )
            }
        }
    }
}

/// Number text (decimal or radix literal) to raw for a type.
fn number_to_raw(schema: &Schema, code: &Code, ty: ValueType, text: &str) -> Result<i64, ValueErr> {
    let what = TypeDesc(schema, code, ty);
    if let Some(r) = parse_radix_int(text) {
        if !ty.accepts_hex() {
            return Err(verr(
                FindingKind::WrongType,
                format!("{what} takes a decimal value, not `{text}`"),
                "hex is only for integer, VH and bit-coded types; write the engineering value",
            ));
        }
        let v = r.map_err(|()| {
            verr(
                FindingKind::WrongType,
                format!("`{text}` is not a valid integer"),
                "write e.g. 0x0900",
            )
        })?;
        return decimal_to_raw(ty, code.width, &Decimal::from_int(v))
            .map_err(|e| conv_err(schema, code, text, e));
    }
    match ty.repr() {
        Repr::Float => float_text_to_raw(text).map_err(|e| match e {
            Some(e) => conv_err(schema, code, text, e),
            None => verr(
                FindingKind::WrongType,
                format!("{what} needs a number, found `{text}`"),
                "write a decimal number",
            ),
        }),
        Repr::Scaled(_) => {
            let d = Decimal::parse(text).map_err(|e| {
                verr(
                    FindingKind::WrongType,
                    format!("{what} needs a number: {e}"),
                    "write a decimal number such as 12.5",
                )
            })?;
            decimal_to_raw(ty, code.width, &d).map_err(|e| conv_err(schema, code, text, e))
        }
        Repr::Text | Repr::Octets => Err(verr(
            FindingKind::WrongType,
            format!("{what} takes text, found the number {text}"),
            "write the value as a string",
        )),
    }
}

/// A scalar node to raw (without the schema min/max check).
fn scalar_to_raw(
    schema: &Schema,
    code: &Code,
    ty: ValueType,
    node: &NodeKind,
    check_unit: bool,
) -> Result<RawValue, ValueErr> {
    let what = TypeDesc(schema, code, ty);
    let enum_def = code.values.as_ref().and_then(|v| schema.enum_of(v));
    match node {
        NodeKind::Num(t) => match ty.repr() {
            Repr::Text | Repr::Octets => Err(verr(
                FindingKind::WrongType,
                format!("{what} takes text, found the number {t}"),
                "write the value as a string",
            )),
            _ => number_to_raw(schema, code, ty, t).map(RawValue::Int),
        },
        NodeKind::Str(s) => {
            match ty.repr() {
                Repr::Text => {
                    return check_vs_text(s)
                        .map(|()| RawValue::Text(s.clone()))
                        .map_err(|m| {
                            verr(
                                FindingKind::OutOfRange,
                                format!("{what}: text {} is not valid VS text: {m}", Quoted(s)),
                                "use at most 20 visible ASCII characters",
                            )
                        });
                }
                Repr::Octets => {
                    return parse_octets(s).map(RawValue::Octets).ok_or_else(|| {
                        verr(
                            FindingKind::WrongType,
                            format!("{what} needs octets as hex, found {}", Quoted(s)),
                            "write an even number of hex digits, e.g. \"0a1b\"",
                        )
                    });
                }
                _ => {}
            }
            if let Some(v) = schema.enum_value(code, s) {
                return Ok(RawValue::Int(v));
            }
            // a quoted radix literal (`C0068 = "0x0900"`, docs/file-formats.md)
            if parse_radix_int(s.trim()).is_some() {
                return number_to_raw(schema, code, ty, s.trim()).map(RawValue::Int);
            }
            let (num, unit) = split_unit(s);
            let looks_numeric = !num.is_empty()
                && (parse_radix_int(num).is_some()
                    || Decimal::parse(num).is_ok()
                    || (ty == ValueType::PT_FLOAT_IEEE
                        && !matches!(float_text_to_raw(num), Err(None))));
            if !looks_numeric {
                if let Some(e) = enum_def {
                    return Err(verr(
                        FindingKind::UnknownEnumLabel,
                        format!(
                            "{} has no label {}",
                            schema.display_code(code.number, None),
                            Quoted(s)
                        ),
                        format!("use one of: {}", quote_list(&e.labels())),
                    ));
                }
                return Err(verr(
                    FindingKind::WrongType,
                    format!("{what} needs a number, found the text {}", Quoted(s)),
                    match &code.unit {
                        Some(u) => {
                            format!("write a number, optionally with its unit, e.g. \"10 {u}\"")
                        }
                        None => "write a number".to_string(),
                    },
                ));
            }
            if check_unit && !unit.is_empty() {
                let ok = code.unit.as_deref() == Some(unit)
                    || code.unit_aliases.iter().any(|a| a == unit);
                if !ok {
                    return Err(match &code.unit {
                        Some(u) => verr(
                            FindingKind::UnitMismatch,
                            format!(
                                "{} is in {u}, not {unit}",
                                schema.display_code(code.number, None)
                            ),
                            format!("write the value in {u}, e.g. \"{num} {u}\""),
                        ),
                        None => verr(
                            FindingKind::UnitMismatch,
                            format!(
                                "{} has no unit, but the value says {unit}",
                                schema.display_code(code.number, None)
                            ),
                            format!("write the plain number {num}"),
                        ),
                    });
                }
            }
            number_to_raw(schema, code, ty, num).map(RawValue::Int)
        }
        other => Err(verr(
            FindingKind::WrongType,
            format!("{what} needs a number, found {}", other.describe()),
            match other {
                NodeKind::Bool(_) => {
                    "booleans are only allowed for single-bit members inside a bit-field table"
                        .to_string()
                }
                NodeKind::Table(_) => {
                    "tables are only for codes with bit fields; write a plain value".to_string()
                }
                _ => "write a plain value".to_string(),
            },
        )),
    }
}

fn quote_list(items: &[&str]) -> String {
    items
        .iter()
        .map(|s| format!("\"{s}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Compare two engineering values of (possibly different) types.
pub(crate) fn eng_cmp(
    ta: ValueType,
    a: &RawValue,
    tb: ValueType,
    b: &RawValue,
) -> Option<Ordering> {
    let (RawValue::Int(a), RawValue::Int(b)) = (a, b) else {
        return None;
    };
    // one integer-raw type: engineering = raw x positive factor, so raw order is
    // engineering order (not so for f32 bit patterns)
    if ta == tb && ta != ValueType::PT_FLOAT_IEEE {
        return Some(a.cmp(b));
    }
    let as_f = |_t: ValueType, r: i64| {
        u32::try_from(r)
            .ok()
            .map(|bits| f64::from(f32::from_bits(bits)))
    };
    match (
        ta == ValueType::PT_FLOAT_IEEE,
        tb == ValueType::PT_FLOAT_IEEE,
    ) {
        (false, false) => {
            let da = value::raw_to_decimal(ta, *a)?;
            let db = value::raw_to_decimal(tb, *b)?;
            Some(da.cmp(&db))
        }
        (true, true) => as_f(ta, *a)?.partial_cmp(&as_f(tb, *b)?),
        (true, false) => {
            let fa = as_f(ta, *a)?;
            let db: f64 = value::raw_to_decimal(tb, *b)?.to_string().parse().ok()?;
            fa.partial_cmp(&db)
        }
        (false, true) => {
            let da: f64 = value::raw_to_decimal(ta, *a)?.to_string().parse().ok()?;
            da.partial_cmp(&as_f(tb, *b)?)
        }
    }
}

/// Convert one set value for a code; findings go to `out`.
pub(crate) fn convert_value<'d>(
    schema: &Schema,
    code: &Code,
    doc: &'d Document,
    node: &Node,
    out: &mut Vec<Finding>,
) -> Option<Placed<'d>> {
    let loc = || doc.loc(&node.span);
    let what = CodeName(schema, code.number);
    let Some(ty) = schema.type_of(code) else {
        out.push(Finding::new(
            FindingKind::UnknownType,
            loc(),
            format!(
                "the type of {what} ({}) is unknown, so it cannot be given a value",
                code.name
            ),
            "remove the value, or state the code's type in a fixture schema if a spec gives it",
        ));
        return None;
    };
    let push = |out: &mut Vec<Finding>, e: ValueErr, loc: Location| {
        out.push(Finding::new(e.kind, loc, e.message, e.help))
    };
    let mut members = Vec::new();
    let raw = if let NodeKind::Table(entries) = &node.kind {
        if code.bits.is_empty() {
            push(
                out,
                scalar_to_raw(schema, code, ty, &node.kind, true).err()?,
                loc(),
            );
            return None;
        }
        let mut raw: i64 = 0;
        let mut ok = true;
        for e in entries {
            let Some(bf) = code.bits.iter().find(|b| b.name == e.key).or_else(|| {
                code.bits
                    .iter()
                    .find(|b| b.name.eq_ignore_ascii_case(&e.key))
            }) else {
                let names: Vec<&str> = code.bits.iter().map(|b| b.name.as_str()).collect();
                out.push(Finding::new(
                    FindingKind::UnknownBitField,
                    doc.loc(&e.key_span),
                    format!("{what} has no bit field `{}`", e.key),
                    format!("use one of: {}", names.join(", ")),
                ));
                ok = false;
                continue;
            };
            match member_value(schema, code, bf, &e.value.kind) {
                Ok(v) => {
                    raw |= v.checked_shl(bf.lsb).unwrap_or(0);
                    members.push((bf.name.clone(), e.value.span.clone()));
                }
                Err(err) => {
                    push(out, err, doc.loc(&e.value.span));
                    ok = false;
                }
            }
        }
        if !ok {
            return None;
        }
        if let Some((lo, hi)) = ty.raw_range(code.width)
            && !(lo..=hi).contains(&raw)
        {
            out.push(Finding::new(
                FindingKind::OutOfRange,
                loc(),
                format!(
                    "{what}: the bit fields make {raw:#x}, outside {} ({lo:#x} ..= {hi:#x})",
                    ty.name()
                ),
                "check the schema's bit positions",
            ));
            return None;
        }
        RawValue::Int(raw)
    } else {
        match scalar_to_raw(schema, code, ty, &node.kind, true) {
            Ok(r) => r,
            Err(e) => {
                push(out, e, loc());
                return None;
            }
        }
    };
    // schema min / max
    let bounds = code.bounds.get_or_init(|| {
        let raw_of = |f: &Option<crate::schema::Fact>| {
            f.as_ref()
                .and_then(|f| fact_to_raw(schema, code, &f.value).ok())
        };
        (raw_of(&code.min), raw_of(&code.max))
    });
    for ((fact, bound), is_min) in [
        ((&code.min, &bounds.0), true),
        ((&code.max, &bounds.1), false),
    ] {
        let (Some(f), Some(bound)) = (fact, bound) else {
            continue;
        };
        let ord = eng_cmp(ty, &raw, ty, bound);
        let bad = if is_min {
            ord == Some(Ordering::Less)
        } else {
            ord == Some(Ordering::Greater)
        };
        if bad {
            let given = display_value(schema, code, &raw);
            let range = match (&code.min, &code.max) {
                (Some(a), Some(b)) => format!(
                    "give a value from {} to {}",
                    fact_to_raw(schema, code, &a.value)
                        .map(|r| display_value(schema, code, &r))
                        .unwrap_or_default(),
                    fact_to_raw(schema, code, &b.value)
                        .map(|r| display_value(schema, code, &r))
                        .unwrap_or_default()
                ),
                _ => format!(
                    "give a value {} {}",
                    if is_min { "of at least" } else { "of at most" },
                    display_value(schema, code, bound)
                ),
            };
            out.push(
                Finding::new(
                    FindingKind::OutOfRange,
                    loc(),
                    format!(
                        "{what} = {given} is {} the {} {}",
                        if is_min { "below" } else { "above" },
                        if is_min { "minimum" } else { "maximum" },
                        display_value(schema, code, bound)
                    ),
                    range,
                )
                .with_related(
                    if is_min {
                        "minimum in the schema"
                    } else {
                        "maximum in the schema"
                    },
                    f.loc.clone(),
                ),
            );
            return None;
        }
    }
    // a complete enumeration: the value must be one it lists
    if code.bits.is_empty()
        && code.values_partial != Some(true)
        && let RawValue::Int(v) = raw
        && let Some(e) = code.values.as_ref().and_then(|src| schema.enum_of(src))
        && schema.enum_label(code, v).is_none()
    {
        // enumeration keys are engineering integers
        let listed: Vec<String> = e
            .entries
            .iter()
            .map(|(value, label, _)| format!("{value} = {}", Quoted(label)))
            .collect();
        out.push(Finding::new(
            FindingKind::NotAnEnumValue,
            loc(),
            format!(
                "{what} = {} is not one of its values",
                display_value(schema, code, &raw)
            ),
            format!("use a label or one of: {}", listed.join(", ")),
        ));
        return None;
    }
    Some(Placed {
        raw,
        doc,
        span: node.span.clone(),
        members,
    })
}

fn member_value(
    schema: &Schema,
    code: &Code,
    bf: &BitField,
    node: &NodeKind,
) -> Result<i64, ValueErr> {
    let what = format!(
        "{} bit field {}",
        schema.display_code(code.number, None),
        bf.name
    );
    let width = bf.width().min(62);
    let max = (1i64 << width) - 1;
    let labels = bf.values.as_ref().and_then(|v| schema.enum_of(v));
    let from_int = |v: i128, text: &str| -> Result<i64, ValueErr> {
        i64::try_from(v)
            .ok()
            .filter(|v| (0..=max).contains(v))
            .ok_or_else(|| {
                verr(
                    FindingKind::OutOfRange,
                    format!("{what} = {text} does not fit in {width} bit(s) (0 ..= {max})"),
                    format!("give a value from 0 to {max}"),
                )
            })
    };
    match node {
        NodeKind::Bool(b) => {
            if width == 1 {
                Ok(i64::from(*b))
            } else {
                Err(verr(
                    FindingKind::WrongType,
                    format!("{what} has {width} bits; true/false is only for single-bit members"),
                    format!("give a number from 0 to {max} or a label"),
                ))
            }
        }
        NodeKind::Num(t) => {
            let v = crate::schema::parse_int_text(t).ok_or_else(|| {
                verr(
                    FindingKind::WrongType,
                    format!("{what} needs an integer, found {t}"),
                    "give a whole number or a label",
                )
            })?;
            from_int(v, t)
        }
        NodeKind::Str(s) => {
            if let Some(v) = labels.and_then(|l| l.value_of(s)) {
                return Ok(v);
            }
            if let Some(v) = crate::schema::parse_int_text(s.trim()) {
                return from_int(v, s);
            }
            match labels {
                Some(l) => Err(verr(
                    FindingKind::UnknownEnumLabel,
                    format!("{what} has no label {}", Quoted(s)),
                    format!("use one of: {}", quote_list(&l.labels())),
                )),
                None => Err(verr(
                    FindingKind::WrongType,
                    format!("{what} has no labels; found {}", Quoted(s)),
                    format!("give a number from 0 to {max}"),
                )),
            }
        }
        other => Err(verr(
            FindingKind::WrongType,
            format!(
                "{what} needs a number, label or boolean, found {}",
                other.describe()
            ),
            "give a plain value",
        )),
    }
}

/// Check the schema's cross-code rules on merged values.
pub(crate) fn check_rules(
    schema: &Schema,
    merged: &crate::fnv::FnvMap<CodeKey, Placed<'_>>,
    out: &mut Vec<Finding>,
) {
    for rule in &schema.rules {
        match rule {
            Rule::DistinctFields {
                code,
                fields,
                message,
                loc,
            } => {
                let (Some(c), Some(p)) = (schema.code(*code), merged.get(&CodeKey::new(*code)))
                else {
                    continue;
                };
                let RawValue::Int(raw) = p.raw else { continue };
                // a bit-field table compares only the members it names (unnamed ones are 0,
                // "not given"); a plain number compares every field of the rule
                let members: Vec<&BitField> = fields
                    .iter()
                    .filter(|f| p.members.is_empty() || p.members.iter().any(|(n, _)| n == *f))
                    .filter_map(|f| c.bits.iter().find(|b| &b.name == f))
                    .collect();
                'outer: for (i, a) in members.iter().enumerate() {
                    for b in members.iter().skip(i + 1) {
                        let (va, vb) = (a.extract(raw), b.extract(raw));
                        if va == vb {
                            let label = a
                                .values
                                .as_ref()
                                .and_then(|v| schema.enum_of(v))
                                .and_then(|e| e.label(va));
                            let shown = match label {
                                Some(l) => format!("{va} (\"{l}\")"),
                                None => va.to_string(),
                            };
                            let at = |name: &str| {
                                p.members
                                    .iter()
                                    .find(|(n, _)| n == name)
                                    .map(|(_, l)| p.doc.loc(l))
                            };
                            let mut f = Finding::new(
                                FindingKind::RuleViolation,
                                at(&b.name).unwrap_or_else(|| p.loc()),
                                format!("{}: {} and {} are both {shown}", message, a.name, b.name),
                                format!("give {} and {} different settings", a.name, b.name),
                            );
                            if let Some(l) = at(&a.name) {
                                f = f.with_related(format!("{} set here", a.name), l);
                            }
                            out.push(f.with_related("rule stated here", loc.clone()));
                            break 'outer;
                        }
                    }
                }
            }
            Rule::LessOrEqual {
                left,
                right,
                message,
                loc,
            } => {
                let (Some(cl), Some(cr)) = (schema.code(*left), schema.code(*right)) else {
                    continue;
                };
                let (Some(pl), Some(pr)) = (
                    merged.get(&CodeKey::new(*left)),
                    merged.get(&CodeKey::new(*right)),
                ) else {
                    continue;
                };
                let (Some(tl), Some(tr)) = (schema.type_of(cl), schema.type_of(cr)) else {
                    continue;
                };
                if eng_cmp(tl, &pl.raw, tr, &pr.raw) == Some(Ordering::Greater) {
                    out.push(
                        Finding::new(
                            FindingKind::RuleViolation,
                            pl.loc(),
                            format!(
                                "{message}: {} = {} is greater than {} = {}",
                                schema.display_code(*left, None),
                                display_value(schema, cl, &pl.raw),
                                schema.display_code(*right, None),
                                display_value(schema, cr, &pr.raw)
                            ),
                            format!(
                                "lower {} or raise {}",
                                schema.display_code(*left, None),
                                schema.display_code(*right, None)
                            ),
                        )
                        .with_related(
                            format!("{} set here", schema.display_code(*right, None)),
                            pr.loc(),
                        )
                        .with_related("rule stated here", loc.clone()),
                    );
                }
            }
        }
    }
}

/// Edit distance (bounded input) for "did you mean" suggestions.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().take(64).flat_map(char::to_lowercase).collect();
    let b: Vec<char> = b.chars().take(64).flat_map(char::to_lowercase).collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev.get(j).copied().unwrap_or(0) + usize::from(ca != cb);
            let del = prev.get(j + 1).copied().unwrap_or(0) + 1;
            let ins = cur.get(j).copied().unwrap_or(0) + 1;
            if let Some(c) = cur.get_mut(j + 1) {
                *c = sub.min(del).min(ins);
            }
        }
        prev = cur;
    }
    prev.last().copied().unwrap_or(0)
}

/// The closest name or alias of the schema, if reasonably close.
pub(crate) fn suggest(schema: &Schema, key: &str) -> Option<String> {
    let mut best: Option<(usize, &str)> = None;
    for c in &schema.codes {
        for n in std::iter::once(c.name.as_str()).chain(c.aliases.iter().map(|a| a.0.as_str())) {
            if n.is_empty() {
                continue;
            }
            let d = edit_distance(key, n);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, n));
            }
        }
    }
    best.filter(|(d, n)| *d <= (n.chars().count() / 3).max(2))
        .map(|(_, n)| n.to_string())
}
