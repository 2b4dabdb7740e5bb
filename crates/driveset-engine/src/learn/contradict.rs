//! Owns the merge rule's contradictions (module docs of [`super`]): where a
//! drive's description of a code contradicts a fact its base schema gives
//! (kind, type, unit, min, max, default; an actual value where the spec has
//! a command, control word or setpoint), and the report's sentence for it.

use driveset_schema::schema::StorageKind;
use driveset_schema::value::raw_to_engineering;
use driveset_schema::{Code, Role, Schema, ValueType};

use super::bounds::show_char;
use super::model::LearnedCode;

/// One fact on which a drive's description contradicts its base schema
/// (whose fact stands; module docs, merge rule).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Disagreement {
    /// The schema key (`kind`, `type`, `min`, `max`, `default`, `unit`).
    pub fact: &'static str,
    /// The drive's value, as a schema file spells it.
    pub drive: String,
    /// The base schema's value, as its file spells it.
    pub spec: String,
}

/// What a drive's description of `c` contradicts in its base code `b`:
/// the facts the base gives otherwise, and the role (a command, control
/// word or setpoint the drive calls an actual value).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(super) struct Contradictions {
    /// The facts the base gives otherwise.
    pub facts: Vec<Disagreement>,
    /// The base's role where the drive describes a read-only actual value
    /// of a code that role must write.
    pub role: Option<Role>,
}

impl Contradictions {
    /// Whether the drive contradicts nothing.
    pub fn is_empty(&self) -> bool {
        self.facts.is_empty() && self.role.is_none()
    }
}

/// A storage kind as schema files spell it (`kind = "..."`).
pub(super) fn kind_name(k: StorageKind) -> &'static str {
    match k {
        StorageKind::RamActual => "ram-actual",
        StorageKind::RamControl => "ram-control",
        StorageKind::Eeprom => "eeprom",
        StorageKind::FselIsel => "fsel-isel",
    }
}

fn kind_words(k: StorageKind) -> &'static str {
    match k {
        StorageKind::RamActual => "an actual value",
        StorageKind::RamControl => "a RAM control value",
        StorageKind::Eeprom => "an EEPROM value",
        StorageKind::FselIsel => "an FSEL/ISEL variable",
    }
}

fn fact_text(f: &driveset_schema::schema::Fact) -> String {
    match &f.value {
        driveset_schema::doc::NodeKind::Str(t) | driveset_schema::doc::NodeKind::Num(t) => {
            t.clone()
        }
        other => format!("{other:?}"),
    }
}

/// Whether a drive's unit string says the spec's (VF1000 descriptions
/// carry at most 6 characters: a cut spec unit agrees).
fn same_unit(drive: &str, spec: &str) -> bool {
    let (d, s) = (drive.trim(), spec.trim());
    d.eq_ignore_ascii_case(s)
        || (d.chars().count() == 6 && s.to_ascii_lowercase().starts_with(&d.to_ascii_lowercase()))
}

pub(super) fn contradictions(c: &LearnedCode, b: &Code, base: &Schema) -> Contradictions {
    let mut out = Contradictions::default();
    let base_type = base.type_of(b);
    if let (Some(bt), Some(t)) = (base_type, c.ty)
        && bt.name() != t.name()
    {
        out.facts.push(Disagreement {
            fact: "type",
            drive: t.name().into(),
            spec: bt.name().into(),
        });
    }
    let write_role = b.role.filter(|r| {
        matches!(r, Role::ControlWord | Role::Command | Role::Setpoint)
            && b.access != Some(driveset_schema::schema::Access::Ro)
    });
    match b.kind {
        Some(k) if k != c.kind => out.facts.push(Disagreement {
            fact: "kind",
            drive: kind_name(c.kind).into(),
            spec: kind_name(k).into(),
        }),
        None if c.kind == StorageKind::RamActual && write_role.is_some() => {
            out.role = write_role;
        }
        _ => {}
    }
    if let (Some(u), Some(bu)) = (&c.unit, &b.unit)
        && !same_unit(u, bu)
    {
        out.facts.push(Disagreement {
            fact: "unit",
            drive: u.clone(),
            spec: bu.clone(),
        });
    }
    // Bounds compare raw, in the spec's type, else the drive's (a type
    // disagreement says the rest).
    let vt = base_type.or_else(|| c.ty.and_then(|t| ValueType::from_name(t.name())));
    if let Some(vt) = vt
        && c.ty.is_none_or(|t| t.name() == vt.name())
    {
        for (fact, drive, spec) in [
            ("min", c.min, b.min.as_ref()),
            ("max", c.max, b.max.as_ref()),
            ("default", c.default, b.default.as_ref()),
        ] {
            let (Some(d), Some(f)) = (drive, spec) else {
                continue;
            };
            // The spec's fact in raw units: as the schema converts it,
            // or (a code the spec gives no type) in the drive's type.
            let spec_raw = match base.fact_raw(b, f) {
                Ok(driveset_schema::canonical::RawValue::Int(raw)) => Some(raw),
                Ok(_) => None,
                Err(_) => driveset_schema::Decimal::parse(&fact_text(f))
                    .ok()
                    .and_then(|v| driveset_schema::value::decimal_to_raw(vt, b.width, &v).ok()),
            };
            if let Some(raw) = spec_raw
                && raw != d
            {
                out.facts.push(Disagreement {
                    fact,
                    drive: raw_to_engineering(vt, d),
                    spec: fact_text(f),
                });
            }
        }
    }
    out
}

/// Where the base schema's facts of `b` come from, as reports cite it
/// (`lustbus-protocol.txt section 8.1.1`).
pub(super) fn spec_source(b: &Code, base: &Schema) -> String {
    b.spec
        .clone()
        .or_else(|| base.spec.clone())
        .unwrap_or_else(|| format!("schema {}", base.id))
        .replace('§', "section ")
}

/// The report's sentence for a contradiction (issue 18's wording).
pub(super) fn contradiction_message(
    c: &LearnedCode,
    b: &Code,
    base: &Schema,
    x: &Contradictions,
) -> String {
    let code = base.display_code(c.number, None);
    let spec = spec_source(b, base);
    let ty = c.ty.map_or_else(
        || "an unknown type".to_string(),
        |t| t.name().trim_start_matches("PT_").to_string(),
    );
    let mut parts = Vec::new();
    if let Some(role) = x.role {
        let role = role.as_str().replace('-', " ");
        parts.push(format!(
            "the drive describes {} (kind {}, {ty}); {spec} makes it a {role}: kept as a {role}{}",
            kind_words(c.kind),
            show_char(c.kind_char).trim_matches('\''),
            if x.role.is_some_and(Role::left_out_of_pulled_sets) {
                ", left out of the set"
            } else {
                ""
            }
        ));
    }
    if !x.facts.is_empty() {
        parts.push(format!(
            "the drive describes {}; {spec} gives {}: the spec's {} (the drive's recorded in the learned file)",
            x.facts
                .iter()
                .map(|d| format!("{} {}", d.fact, d.drive))
                .collect::<Vec<_>>()
                .join(", "),
            x.facts
                .iter()
                .map(|d| format!("{} {}", d.fact, d.spec))
                .collect::<Vec<_>>()
                .join(", "),
            if x.facts.len() == 1 { "stands" } else { "stand" }
        ));
    }
    format!("{code}: {}", parts.join("; "))
}
