//! Owns `schema check`: validation of schema files themselves
//! (docs/file-formats.md, "Schema files" and "Fixture schemas").

use std::cmp::Ordering;
use std::collections::HashMap;
use std::sync::Arc;

use crate::error::{Finding, FindingKind, InputError, Location};
use crate::role::Role;
use crate::schema::{Code, EnumDef, EnumSource, Registry, Rule, Schema};
use crate::validate::{eng_cmp, fact_to_raw};
use crate::value::ValueType;

fn f(loc: &Location, message: String, help: impl Into<String>) -> Finding {
    Finding::new(FindingKind::SchemaError, loc.clone(), message, help)
}

/// What checking one schema file gave: its findings, or the input error
/// that kept it from being read.
pub type Checked = Result<Vec<Finding>, InputError>;

/// Checks one file `driveset validate` meets that is not a line manifest
/// (the engine's to check): a schema file (a TOML document with a
/// top-level `[schema]` table, e.g. a fixture) by `schema check`'s rules
/// ([`check_schema_source`]), anything else as a set.
pub fn check_set_or_schema(path: &std::path::Path, registry: &mut Registry) -> Checked {
    use crate::doc::{self, NodeKind, Syntax};
    let source = crate::error::read_text_file(path)?;
    if Syntax::from_path(path) == Syntax::Toml {
        match doc::parse(source.clone(), Syntax::Toml) {
            Err(e) => return Err(crate::set::mask_secret_line(e, registry)),
            Ok(d)
                if d.root
                    .get("schema")
                    .is_some_and(|e| matches!(e.value.kind, NodeKind::Table(_))) =>
            {
                return check_schema_source(source, registry, &[]).map(|(_, findings)| findings);
            }
            Ok(_) => {}
        }
    }
    crate::set::load_set_str(path, &source.text, registry).map(|l| l.findings)
}

/// `schema check` with no file: the built-in schemas, each by its file
/// (`schemas/lenze-tmd.toml`) and the findings of the schema of its id in
/// `registry` (an error when the file name and the id disagree).
pub fn check_builtin_schemas(registry: &Registry) -> Vec<(&'static str, Checked)> {
    crate::schema::BUILTIN_FILES
        .iter()
        .map(|&(path, _)| {
            let id = path
                .rsplit('/')
                .next()
                .and_then(|f| f.strip_suffix(".toml"))
                .unwrap_or(path);
            let checked = match registry.get(id) {
                Some(s) => Ok(check_schema(&s)),
                None => Err(InputError {
                    kind: crate::InputErrorKind::Structure,
                    message: format!("built-in schema {path} has no id `{id}`"),
                    help: "the file name and the id of a built-in schema agree".into(),
                    location: Box::new(Location::file_only(path)),
                }),
            };
            (path, checked)
        })
        .collect()
}

/// Check schema files, each against `registry` and the files checked
/// before it; a fixture whose base comes later among `files` is retried
/// after it (docs/file-formats.md, "Fixture schemas"). One result per
/// file, in the order given.
pub fn check_schema_files(files: &[std::path::PathBuf], registry: &Registry) -> Vec<Checked> {
    let mut loaded: Vec<Arc<Schema>> = Vec::new();
    let mut results: Vec<Option<Checked>> = files.iter().map(|_| None).collect();
    let mut pending: Vec<usize> = (0..files.len()).collect();
    loop {
        let mut retry = Vec::new();
        let before = pending.len();
        for &i in &pending {
            let checked = crate::error::read_text_file(&files[i]).and_then(|source| {
                check_schema_source(source, registry, &loaded).map(|(s, findings)| {
                    loaded.push(s);
                    findings
                })
            });
            if let Err(e) = &checked {
                let unknown_base =
                    e.message.starts_with("base schema `") && e.message.ends_with("` is not known");
                if unknown_base {
                    retry.push(i);
                }
            }
            results[i] = Some(checked);
        }
        if retry.is_empty() || retry.len() == before {
            break;
        }
        pending = retry;
    }
    results
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Ok(Vec::new())))
        .collect()
}

/// Parse a schema file and check it; its `extends` base is looked up in
/// `extra` (the last one of an id wins), then in `registry`.
pub fn check_schema_source(
    source: crate::error::SourceFile,
    registry: &Registry,
    extra: &[Arc<Schema>],
) -> Result<(Arc<Schema>, Vec<Finding>), InputError> {
    let lookup = |id: &str| {
        extra
            .iter()
            .rev()
            .find(|s| s.id == id)
            .cloned()
            .or_else(|| registry.get(id))
    };
    let schema = Arc::new(crate::schema::parse_schema(source, &lookup)?);
    let findings = check_schema(&schema);
    Ok((schema, findings))
}

/// Check a schema; every problem is a finding with its location.
pub fn check_schema(schema: &Schema) -> Vec<Finding> {
    let mut out = schema.merge_findings.clone();
    // fictional marking
    let prefixed = schema.id.starts_with("fictional-");
    if prefixed != schema.fictional {
        out.push(f(
            &schema.fictional_loc,
            if prefixed {
                format!("schema `{}` is named fictional- but not marked `fictional = true`", schema.id)
            } else {
                format!("schema `{}` is marked fictional but its id does not start with `fictional-`", schema.id)
            },
            "fixture schemas have an id and title starting with `fictional-`/`FICTIONAL` and `fictional = true`; real schemas neither",
        ));
    }
    if schema.fictional && !schema.title.to_ascii_lowercase().starts_with("fictional") {
        out.push(f(
            &schema.id_loc,
            format!(
                "fixture schema `{}` has a title not starting with FICTIONAL",
                schema.id
            ),
            "start the title with `FICTIONAL:`",
        ));
    }
    check_can_indexes(schema, &mut out);
    let mut numbers: HashMap<u32, &Location> = HashMap::new();
    let mut names: HashMap<&str, (&Location, u32)> = HashMap::new();
    for c in &schema.codes {
        if let Some(first) = numbers.get(&c.number) {
            out.push(
                f(
                    &c.loc,
                    format!("code {} is defined twice", c.number),
                    "merge the two [[code]] entries",
                )
                .with_related("first defined here", (*first).clone()),
            );
        } else {
            numbers.insert(c.number, &c.loc);
        }
        if c.name.is_empty() {
            out.push(f(
                &c.loc,
                format!("code {} has no `name`", c.number),
                "add `name = \"...\"`",
            ));
        }
        if c.title.is_none() {
            out.push(f(
                &c.loc,
                format!("code {} has no `title`", c.number),
                "add the title as the spec words it",
            ));
        }
        if c.spec.is_none() {
            out.push(f(
                &c.loc,
                format!("code {} has no `spec`", c.number),
                "add where the facts come from, e.g. `spec = \"... §7 Table 1\"`",
            ));
        }
        let name_loc = c.name_loc.clone().unwrap_or_else(|| c.loc.clone());
        let all_names = std::iter::once((c.name.as_str(), name_loc))
            .chain(c.aliases.iter().map(|(a, l)| (a.as_str(), l.clone())));
        for (n, l) in all_names {
            if n.is_empty() {
                continue;
            }
            match names.get(n) {
                Some((first, num)) => out.push(
                    f(
                        &l,
                        format!(
                            "name `{n}` of code {} is already used by code {num}",
                            c.number
                        ),
                        "names and aliases must be unique in a schema",
                    )
                    .with_related("first used here", (*first).clone()),
                ),
                None => {
                    names.insert(n, (c.loc_for_name(n), c.number));
                }
            }
        }
        check_code(schema, c, &mut out);
    }
    for (name, def) in &schema.enums {
        check_enum_labels(def, &format!("[enum.{name}]"), &mut out);
    }
    for rule in &schema.rules {
        match rule {
            Rule::DistinctFields {
                code, fields, loc, ..
            } => match schema.code(*code) {
                None => out.push(f(
                    loc,
                    format!("rule refers to unknown code {code}"),
                    "fix the code number",
                )),
                Some(c) => {
                    for fl in fields {
                        if !c.bits.iter().any(|b| &b.name == fl) {
                            out.push(f(
                                loc,
                                format!("rule refers to unknown bit field `{fl}` of code {code}"),
                                "fix the field name",
                            ));
                        }
                    }
                }
            },
            Rule::LessOrEqual {
                left, right, loc, ..
            } => {
                for n in [left, right] {
                    if schema.code(*n).is_none() {
                        out.push(f(
                            loc,
                            format!("rule refers to unknown code {n}"),
                            "fix the code number",
                        ));
                    }
                }
            }
        }
    }
    out
}

impl Code {
    fn loc_for_name(&self, n: &str) -> &Location {
        if n == self.name {
            self.name_loc.as_ref().unwrap_or(&self.loc)
        } else {
            self.aliases
                .iter()
                .find(|(a, _)| a == n)
                .map(|(_, l)| l)
                .unwrap_or(&self.loc)
        }
    }
}

fn check_enum_labels(def: &EnumDef, what: &str, out: &mut Vec<Finding>) {
    let mut seen: HashMap<String, &Location> = HashMap::new();
    let mut values: HashMap<i64, &Location> = HashMap::new();
    for (v, label, loc) in &def.entries {
        let key = label.trim().to_ascii_lowercase();
        if let Some(first) = seen.get(&key) {
            out.push(
                f(
                    loc,
                    format!("label {label:?} appears twice in {what}"),
                    "labels must differ (compared ignoring case)",
                )
                .with_related("first here", (*first).clone()),
            );
        } else {
            seen.insert(key, loc);
        }
        if let Some(first) = values.get(v) {
            out.push(
                f(
                    loc,
                    format!("value {v} appears twice in {what}"),
                    "remove one",
                )
                .with_related("first here", (*first).clone()),
            );
        } else {
            values.insert(*v, loc);
        }
    }
}

fn check_enum_source(
    schema: &Schema,
    src: &EnumSource,
    what: &str,
    range: Option<(i64, i64)>,
    ty: Option<ValueType>,
    out: &mut Vec<Finding>,
) {
    let def = match src {
        EnumSource::Inline(d) => {
            check_enum_labels(d, what, out);
            d
        }
        EnumSource::Ref { name, loc } => match schema.enums.get(name) {
            Some(d) => d,
            None => {
                out.push(f(
                    loc,
                    format!("{what} refers to unknown enumeration `{name}`"),
                    format!("define [enum.{name}] or fix the name"),
                ));
                return;
            }
        },
    };
    if let Some((lo, hi)) = range {
        for (v, label, loc) in &def.entries {
            if *v < lo || *v > hi {
                let _ = ty;
                let shown = |r: i64| r.to_string();
                out.push(f(
                    loc,
                    format!(
                        "{what}: value {v} ({label:?}) is outside the raw range {} ..= {}",
                        shown(lo),
                        shown(hi)
                    ),
                    "fix the value",
                ));
            }
        }
    }
}

fn check_code(schema: &Schema, c: &Code, out: &mut Vec<Finding>) {
    let what = format!("code {}", c.number);
    if let Some((name, loc)) = &c.type_name
        && ValueType::from_name(name).is_none()
    {
        out.push(f(
            loc,
            format!("{what}: unknown type `{name}`"),
            "use a type from docs/file-formats.md, \"Types and raw values\"",
        ));
    }
    let ty = schema.type_of(c);
    if ty == Some(ValueType::VH) && !matches!(c.width, None | Some(1 | 2 | 4)) {
        out.push(f(
            &c.loc,
            format!("{what}: VH width {} is not 1, 2 or 4", c.width.unwrap_or(0)),
            "fix `width`",
        ));
    }
    let mut raws = Vec::new();
    for (name, fact) in [("min", &c.min), ("max", &c.max), ("default", &c.default)] {
        let Some(fact) = fact else {
            raws.push(None);
            continue;
        };
        match ty {
            // the spec gives the fact but not the type: honest, not an error; the
            // fact just cannot be range-checked (sets cannot set the code either)
            None => raws.push(None),
            Some(_) => match fact_to_raw(schema, c, &fact.value) {
                Ok(r) => raws.push(Some(r)),
                Err(m) => {
                    out.push(f(
                        &fact.loc,
                        format!("{what}: `{name}` is invalid: {m}"),
                        "give a value the type can hold exactly",
                    ));
                    raws.push(None);
                }
            },
        }
    }
    if let (Some(t), [min, max, default]) = (ty, raws.as_slice()) {
        if let (Some(a), Some(b)) = (min, max)
            && eng_cmp(t, a, t, b) == Some(Ordering::Greater)
            && let Some(ml) = c.min.as_ref()
        {
            out.push(f(
                &ml.loc,
                format!("{what}: min is greater than max"),
                "swap or fix them",
            ));
        }
        if let (Some(d), Some(dl)) = (default, c.default.as_ref()) {
            let below = min
                .as_ref()
                .is_some_and(|m| eng_cmp(t, d, t, m) == Some(Ordering::Less));
            let above = max
                .as_ref()
                .is_some_and(|m| eng_cmp(t, d, t, m) == Some(Ordering::Greater));
            if below || above {
                out.push(f(
                    &dl.loc,
                    format!("{what}: default is outside [min, max]"),
                    "fix the default or the range",
                ));
            }
        }
    }
    // enumeration keys are engineering integers: compare them with the engineering range
    let range = ty.and_then(|t| {
        let (lo, hi) = t.raw_range(c.width)?;
        match t.repr() {
            crate::value::Repr::Scaled(f) => {
                Some((lo.div_euclid(i64::from(f)), hi.div_euclid(i64::from(f))))
            }
            _ => Some((lo, hi)),
        }
    });
    if let Some(v) = &c.values {
        check_enum_source(schema, v, &what, range, ty, out);
    }
    let width = ty.and_then(|t| t.bit_width(c.width));
    // an untyped code may carry bit fields the spec documents; only a known
    // type without a bit width (VD, VS, ...) cannot hold them
    if !c.bits.is_empty() && ty.is_some() && width.is_none() {
        out.push(f(
            &c.loc,
            format!("{what} has bit fields but its type is not an integer type of known width"),
            "give the code a VH, BITCODED or PT_BINARY8 type",
        ));
    }
    for (i, b) in c.bits.iter().enumerate() {
        if b.msb < b.lsb {
            out.push(f(
                &b.bits_loc,
                format!(
                    "{what} bit field {}: msb {} is below lsb {}",
                    b.name, b.msb, b.lsb
                ),
                "write bits = [lsb, msb]",
            ));
            continue;
        }
        if let Some(w) = width
            && b.msb >= w
        {
            out.push(f(
                &b.bits_loc,
                format!(
                    "{what} bit field {}: bit {} is outside the {w}-bit value",
                    b.name, b.msb
                ),
                format!("use bits 0..={}", w.saturating_sub(1)),
            ));
        }
        for other in c.bits.iter().take(i) {
            if other.name == b.name {
                out.push(
                    f(
                        &b.loc,
                        format!("{what}: bit field name `{}` is used twice", b.name),
                        "rename one",
                    )
                    .with_related("first here", other.loc.clone()),
                );
            }
            if b.lsb <= other.msb && other.lsb <= b.msb {
                out.push(
                    f(
                        &b.bits_loc,
                        format!("{what}: bit field {} overlaps {}", b.name, other.name),
                        "fix the bit positions",
                    )
                    .with_related("overlapping field", other.bits_loc.clone()),
                );
            }
        }
        if let Some(v) = &b.values {
            let max = if b.width() >= 63 {
                i64::MAX
            } else {
                (1i64 << b.width()) - 1
            };
            check_enum_source(
                schema,
                v,
                &format!("{what} bit field {}", b.name),
                Some((0, max)),
                None,
                out,
            );
        }
    }
    check_roles(schema, c, &what, out);
}

/// Roles (docs/file-formats.md, "Code roles"): bit roles only on a code of
/// the matching role and only on one-bit members; a password is not also
/// something else; a control word is not read-only.
fn check_roles(schema: &Schema, c: &Code, what: &str, out: &mut Vec<Finding>) {
    let role_loc = c.role_loc.clone().unwrap_or_else(|| c.loc.clone());
    for b in &c.bits {
        let (Some(br), Some(loc)) = (b.role, b.role_loc.as_ref()) else {
            continue;
        };
        let want = br.code_role();
        if c.role != Some(want) {
            out.push(f(
                loc,
                format!(
                    "{what} bit field {} has role `{br}`, which belongs to a `{want}` code, but the code's role is {}",
                    b.name,
                    c.role.map_or("not set".to_string(), |r| format!("`{r}`"))
                ),
                format!("give the code `role = \"{want}\"`, or remove the bit field's role"),
            ));
        }
        if b.width() != 1 {
            out.push(f(
                loc,
                format!(
                    "{what} bit field {} has role `{br}` but is {} bits wide",
                    b.name,
                    b.width()
                ),
                "a bit role names one bit: give it bits = [n, n]",
            ));
        }
    }
    if !c.stopped.is_empty() && c.role != Some(Role::ControlWord) {
        out.push(f(
            &c.loc,
            format!("{what} has `stopped` values but is not a control word"),
            "`stopped` lists the values of a `control-word` code that keep the drive stopped; give the role or remove it",
        ));
    }
    if c.role == Some(Role::Password) && !c.bits.is_empty() {
        out.push(f(
            &role_loc,
            format!("{what} is a password but has bit fields"),
            "a password is one secret value; remove the bit fields or the role",
        ));
    }
    if let Some(r) = c.role
        && r != Role::Password
        && schema.type_of(c) == Some(ValueType::PT_PASSWORD)
    {
        out.push(f(
            &role_loc,
            format!("{what} has type PT_PASSWORD (a secret) but role `{r}`"),
            "a PT_PASSWORD code is a password; remove the role",
        ));
    }
    if matches!(
        c.role,
        Some(Role::ControlWord | Role::Command | Role::Setpoint)
    ) && c.access == Some(crate::schema::Access::Ro)
    {
        out.push(f(
            &role_loc,
            format!(
                "{what} has role `{}` but is read-only",
                c.role.map(Role::as_str).unwrap_or("")
            ),
            "a control word, command or setpoint is written; fix the access or the role",
        ));
    }
}

/// `[[code]] index` (objects kept by index, docs/file-formats.md "CiA 301
/// objects"): only on lenze-can-sdo schemas, one code per SDO object
/// (a whole object and a single `subindex` of it are one object twice),
/// `subindex` without `subcodes`, `data_type` a CiA 301 type of the code's
/// width. An `index` in the Lenze code range is an object of its own CiA
/// type (a non-Lenze device's manufacturer object, or a Lenze object whose
/// subindexes differ), not a FIX32 Lenze code: the clash rule keeps it apart
/// from the code number `index_base - index`.
fn check_can_indexes(schema: &Schema, out: &mut Vec<Finding>) {
    let base = schema.can_index_base.unwrap_or(24575);
    // (index, subindex or None for the whole object) -> code number
    let mut seen: HashMap<(u32, Option<u8>), u32> = HashMap::new();
    let mut whole: HashMap<u32, u32> = HashMap::new();
    let mut parts: HashMap<u32, u32> = HashMap::new();
    for c in &schema.codes {
        if let Some(dt) = c.data_type
            && !data_type_fits(schema.type_of(c), dt)
        {
            out.push(f(
                &c.loc,
                format!(
                    "code {}: data_type 0x{dt:04X} does not carry type {}",
                    c.number,
                    schema.type_of(c).map_or("?", ValueType::name)
                ),
                "give the CiA 301 type number of the code's width (0x0004 / 0x0007 for 32-bit codes)",
            ));
        }
        let index = match c.index {
            Some(i) => {
                if !schema.family.descriptor().on_can() {
                    out.push(f(
                        &c.loc,
                        format!(
                            "code {}: `index` is for lenze-can-sdo schemas only",
                            c.number
                        ),
                        "remove `index`",
                    ));
                    continue;
                }
                if c.subindex.is_some() && c.subcodes.is_some() {
                    out.push(f(
                        &c.loc,
                        format!("code {}: one `subindex` has no `subcodes`", c.number),
                        "remove `subcodes`, or `subindex` to keep the whole object",
                    ));
                }
                u32::from(i)
            }
            None if schema.family.descriptor().on_can() => match base.checked_sub(c.number) {
                Some(i) => i,
                None => continue,
            },
            None => continue,
        };
        let key = (index, c.subindex.filter(|_| c.index.is_some()));
        let other = match key.1 {
            None => seen
                .insert(key, c.number)
                .or_else(|| parts.get(&index).copied()),
            Some(_) => seen
                .insert(key, c.number)
                .or_else(|| whole.get(&index).copied()),
        };
        match key.1 {
            None => whole.insert(index, c.number),
            Some(_) => parts.insert(index, c.number),
        };
        if let Some(other) = other
            && other != c.number
        {
            out.push(f(
                &c.loc,
                format!(
                    "code {} reaches SDO index 0x{index:04X}, as code {other} does",
                    c.number
                ),
                "keep one code per object",
            ));
        }
    }
}

/// Whether CiA 301 data type `dt` carries values of `ty` on CAN (same width
/// and signedness class as the SDO transfer moves them).
fn data_type_fits(ty: Option<ValueType>, dt: u16) -> bool {
    match ty {
        Some(
            ValueType::FIX32 | ValueType::BITCODED | ValueType::INTEGER32 | ValueType::UNSIGNED32,
        ) => {
            matches!(dt, 0x0004 | 0x0007)
        }
        Some(ValueType::UNSIGNED16 | ValueType::INTEGER16) => matches!(dt, 0x0003 | 0x0006),
        Some(ValueType::UNSIGNED8 | ValueType::INTEGER8) => matches!(dt, 0x0001 | 0x0002 | 0x0005),
        Some(ValueType::VS) => dt == 0x0009,
        Some(ValueType::VO) => dt == 0x000A,
        _ => false,
    }
}

#[cfg(test)]
mod files_tests {
    use super::*;

    #[test]
    fn validate_reads_a_schema_file_as_a_schema_and_a_set_as_a_set() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut registry = Registry::builtin().unwrap();
        let fixture = root.join("parameter-sets/fixtures/fictional-vf1000-demo.toml");
        assert!(
            check_set_or_schema(&fixture, &mut registry)
                .expect("a schema")
                .is_empty()
        );
        let set = root.join("parameter-sets/tmd/conveyor-3.toml");
        assert!(
            check_set_or_schema(&set, &mut registry)
                .expect("a set")
                .is_empty()
        );
        assert!(check_set_or_schema(&root.join("no-such.toml"), &mut registry).is_err());
    }

    #[test]
    fn the_builtin_schemas_check_clean() {
        let registry = Registry::builtin().unwrap();
        let checked = check_builtin_schemas(&registry);
        assert_eq!(checked.len(), crate::schema::BUILTIN_FILES.len());
        for (path, c) in checked {
            assert_eq!(c.as_ref().map(Vec::len).ok(), Some(0), "{path}: {c:?}");
        }
    }

    #[test]
    fn a_missing_file_is_an_input_error_in_its_place() {
        let registry = Registry::builtin().unwrap();
        let checked = check_schema_files(
            &[std::path::PathBuf::from(
                "/nonexistent/driveset-schema.toml",
            )],
            &registry,
        );
        assert_eq!(checked.len(), 1);
        assert!(checked[0].is_err());
    }
}
