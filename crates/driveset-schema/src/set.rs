//! Owns loading parameter-set files (TOML, YAML; docs/file-formats.md,
//! "Parameter sets"): top-level keys, `schema` resolution, `extends` chains,
//! key resolution (number, `C`+number, `/subcode`, name, alias), merging
//! base then overlay, and the resulting [`LoadedSet`].

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::canonical::{CodeKey, RawValue, ResolvedSet};
use crate::doc::{self, Document, Entry, Node, NodeKind, Syntax};
use crate::error::{
    Finding, FindingKind, InputError, InputErrorKind, Location, SourceFile, read_text_file,
};
use crate::fnv::FnvMap;
use crate::schema::{Access, Code, CodeStyle, Registry, Schema};
use crate::validate::{Placed, check_rules, convert_value, suggest};

/// Longest `extends` chain followed.
pub const MAX_EXTENDS_DEPTH: usize = 32;

/// The outcome of loading a set: the resolved raw values (when the schema is
/// known) and every finding, in file order (bases first).
#[derive(Debug, Clone)]
pub struct LoadedSet {
    /// The schema the set names, when known.
    pub schema: Option<Arc<Schema>>,
    /// The valid values after merging `extends` (values with findings are left out).
    pub resolved: Option<ResolvedSet>,
    /// The set's `title`.
    pub title: Option<String>,
    /// Findings.
    pub findings: Vec<Finding>,
    /// Where the set gives its bus address and line rate codes (roles
    /// [`crate::Role::is_bus_link`]), at the key of the layer whose value
    /// stands: `validate MANIFEST` names the place when the value
    /// disagrees with the manifest.
    pub bus_codes: Vec<(CodeKey, Location)>,
}

struct Layer {
    doc: Document,
    dir: PathBuf,
    schema_ref: Option<(String, Location)>,
    values: Option<Node>,
    title: Option<String>,
}

/// Load and validate a set file (`.toml`, or `.yaml`/`.yml`/`.json` read as YAML).
/// Schema paths the set names are loaded into `registry`.
pub fn load_set(path: &Path, registry: &mut Registry) -> Result<LoadedSet, InputError> {
    let source = read_text_file(path)?;
    load_source(source, Syntax::from_path(path), path, registry)
}

/// Load and validate a set given as text; `path` names it in messages and
/// anchors relative `schema`/`extends` paths.
pub fn load_set_str(
    path: &Path,
    text: &str,
    registry: &mut Registry,
) -> Result<LoadedSet, InputError> {
    let source = crate::error::source_from_str(&path.display().to_string(), text)?;
    load_source(source, Syntax::from_path(path), path, registry)
}

fn load_source(
    source: SourceFile,
    syntax: Syntax,
    path: &Path,
    registry: &mut Registry,
) -> Result<LoadedSet, InputError> {
    let mut findings = Vec::new();
    let mut layers = Vec::new();
    let mut stack = Vec::new();
    let top = parse_layer(source, syntax, path).map_err(|e| mask_secret_line(e, registry))?;
    collect(top, path, &mut stack, &mut layers, &mut findings)
        .map_err(|e| mask_secret_line(e, registry))?;
    let Some(top) = layers.last() else {
        return Ok(LoadedSet {
            schema: None,
            resolved: None,
            title: None,
            findings,
            bus_codes: Vec::new(),
        });
    };
    let title = top.title.clone();

    // the schema: named by the top file, else by the nearest base
    let Some((sref, sloc, sdir)) = layers.iter().rev().find_map(|l| {
        l.schema_ref
            .as_ref()
            .map(|(s, loc)| (s.clone(), loc.clone(), l.dir.clone()))
    }) else {
        findings.push(Finding::new(
            FindingKind::UnknownSchema,
            top.doc.loc(&(0..0)),
            "the set names no schema",
            "add `schema = \"<id>\"` (e.g. lenze-tmd) at the top of the file",
        ));
        return Ok(LoadedSet {
            schema: None,
            resolved: None,
            title,
            findings,
            bus_codes: Vec::new(),
        });
    };
    let Some(schema) = resolve_schema(&sref, &sloc, &sdir, registry, &mut findings)? else {
        return Ok(LoadedSet {
            schema: None,
            resolved: None,
            title,
            findings,
            bus_codes: Vec::new(),
        });
    };
    for l in &layers {
        if let Some((r, loc)) = &l.schema_ref
            && (r != &sref || loc.file != sloc.file)
        {
            let mut tmp = Vec::new();
            let other = resolve_schema(r, loc, &l.dir, registry, &mut tmp)?;
            if other.as_ref().is_none_or(|o| o.id != schema.id) {
                findings.push(
                    Finding::new(
                        FindingKind::BadExtends,
                        loc.clone(),
                        format!(
                            "this base names schema `{r}`, but the set uses `{}`",
                            schema.id
                        ),
                        "a set and its bases must name the same schema",
                    )
                    .with_related("the set's schema", sloc.clone()),
                );
            }
        }
    }

    let mut merged: FnvMap<CodeKey, Placed> = FnvMap::default();
    let mut bus_codes: Vec<(CodeKey, Location)> = Vec::new();
    // where secret values are written (file, byte span): masked in every
    // finding's snippet at the end, whatever the finding is about
    let mut secret_spans: Vec<(String, std::ops::Range<usize>)> = Vec::new();
    for l in &layers {
        let Some(values) = &l.values else { continue };
        let mut seen: FnvMap<CodeKey, (&str, std::ops::Range<usize>)> = FnvMap::default();
        seen.reserve(values.entries().len());
        merged.reserve(values.entries().len());
        for e in values.entries() {
            let (named, resolved) = resolve_key(&schema, &l.doc, e, &mut findings);
            if named.is_some_and(|c| schema.is_password(c)) {
                // also when the key is wrong (`"C0094/1"`): the value
                // written beside a password's code is masked all the same
                secret_spans.push((l.doc.loc(&e.value.span).file, e.value.span.clone()));
            }
            let Some((code, key)) = resolved else {
                continue;
            };
            let kloc = || l.doc.loc(&e.key_span);
            if let Some((first, fspan)) = seen.get(&key) {
                let floc = l.doc.loc(fspan);
                findings.push(
                    Finding::new(
                        FindingKind::DuplicateCode,
                        kloc(),
                        format!(
                            "{} is given twice in this file: as `{first}` (line {}) and as `{}`",
                            schema.display_code(key.number, key.subcode),
                            floc.line,
                            e.key
                        ),
                        "keep one of them",
                    )
                    .with_related("first given here", floc.clone()),
                );
                continue;
            }
            seen.insert(key, (e.key.as_str(), e.key_span.clone()));
            if code.access == Some(Access::Ro) {
                findings.push(Finding::new(
                    FindingKind::ReadOnly,
                    kloc(),
                    format!(
                        "{} ({}) is read-only; a set cannot write it",
                        schema.display_code(key.number, key.subcode),
                        code.name
                    ),
                    "remove this line",
                ));
                merged.remove(&key);
                continue;
            }
            let secret = schema.is_password(code);
            if secret && matches!(&e.value.kind, NodeKind::Str(t) if t == crate::canonical::SECRET)
            {
                findings.push(Finding::new(
                    FindingKind::SecretNotGiven,
                    l.doc.loc(&e.value.span),
                    format!(
                        "{} ({}) is a secret whose value this file does not hold (`{}` is what exports and pulled sets write)",
                        schema.display_code(key.number, key.subcode),
                        code.name,
                        crate::canonical::SECRET
                    ),
                    "give the password's value, or remove this line to leave the drive's password as it is",
                ));
                merged.remove(&key);
                continue;
            }
            let before = findings.len();
            let converted = convert_value(&schema, code, &l.doc, &e.value, &mut findings);
            if secret {
                // a value problem of a secret: say what, never the value
                for f in findings.iter_mut().skip(before) {
                    f.message = format!(
                        "{} ({}) = {}: the value is not valid for this code ({})",
                        schema.display_code(key.number, key.subcode),
                        code.name,
                        crate::canonical::SECRET,
                        f.kind
                    );
                    f.help =
                        "give a valid password (the value is not shown: it is a secret)".into();
                    // which schema fact it broke would narrow the value down
                    f.related.clear();
                }
            }
            match converted {
                Some(p) => {
                    if let Some((kind, message, help)) =
                        crate::role::refusal(&schema, code, key, &p.raw).or_else(|| {
                            crate::schema::ram_note(&schema, code, key).map(|m| {
                                (
                                    crate::FindingKind::RamCode,
                                    format!("{m}, so the set would not survive a power cycle"),
                                    "remove this line: a RAM value comes back as its reference value after power-up; set it from the machine's control at run time".to_string(),
                                )
                            })
                        })
                    {
                        findings.push(Finding::new(kind, p.loc(), message, help));
                        merged.remove(&key);
                        continue;
                    }
                    if code.role().is_some_and(crate::Role::is_bus_link) {
                        bus_codes.retain(|(k, _)| *k != key);
                        bus_codes.push((key, kloc()));
                    }
                    merged.insert(key, p);
                }
                None => {
                    merged.remove(&key);
                }
            }
        }
    }
    check_rules(&schema, &merged, &mut findings);
    for f in &mut findings {
        for (file, span) in &secret_spans {
            if &f.location.file == file {
                f.location.mask_secret(span);
            }
            for (_, r) in &mut f.related {
                if &r.file == file {
                    r.mask_secret(span);
                }
            }
        }
    }
    let mut resolved = ResolvedSet::new(&schema);
    let mut sorted: Vec<(CodeKey, RawValue)> =
        merged.into_iter().map(|(k, p)| (k, p.raw)).collect();
    sorted.sort_unstable_by_key(|(k, _)| *k);
    // built in bulk from sorted keys
    resolved.values = sorted.into_iter().collect();
    bus_codes.retain(|(k, _)| resolved.values.contains_key(k));
    Ok(LoadedSet {
        schema: Some(schema),
        resolved: Some(resolved),
        title,
        findings,
        bus_codes,
    })
}

fn parse_layer(
    source: SourceFile,
    syntax: Syntax,
    path: &Path,
) -> Result<(Layer, Option<Node>), InputError> {
    let mut doc = doc::parse(source, syntax)?;
    let mut schema_ref = None;
    let mut values = None;
    let mut title = None;
    let mut extends = None;
    // move the entries out of the document (the tree is not needed twice)
    let root = std::mem::replace(&mut doc.root.kind, NodeKind::Table(Vec::new()));
    let NodeKind::Table(entries) = root else {
        return Err(doc.error(
            &doc.root.span,
            "the document is not a table",
            "start with `schema = \"...\"`",
        ));
    };
    for e in entries {
        let want_str = |e: &Entry| match &e.value.kind {
            NodeKind::Str(s) => Ok(s.clone()),
            other => Err(doc.error(
                &e.value.span,
                format!("`{}` must be a string, found {}", e.key, other.describe()),
                format!("write `{} = \"...\"`", e.key),
            )),
        };
        match e.key.as_str() {
            "schema" => schema_ref = Some((want_str(&e)?, doc.loc(&e.value.span))),
            "title" => title = Some(want_str(&e)?),
            "extends" => extends = Some(e.value),
            "drive" => {
                if !matches!(e.value.kind, NodeKind::Table(_)) {
                    return Err(doc.error(
                        &e.value.span,
                        format!("`drive` must be a table, found {}", e.value.kind.describe()),
                        "write `[drive]` with e.g. `address = 3`",
                    ));
                }
            }
            "values" => match &e.value.kind {
                NodeKind::Table(_) => values = Some(e.value),
                NodeKind::Null => {}
                other => {
                    return Err(doc.error(
                        &e.value.span,
                        format!("`values` must be a table, found {}", other.describe()),
                        "write `[values]` followed by `CODE = value` lines",
                    ));
                }
            },
            other => {
                return Err(doc.error(
                    &e.key_span,
                    format!("unknown top-level key `{other}`"),
                    "a set has schema, extends, title, [drive] and [values]; code values go under [values]",
                ));
            }
        }
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    Ok((
        Layer {
            doc,
            dir,
            schema_ref,
            values,
            title,
        },
        extends,
    ))
}

fn collect(
    (layer, extends): (Layer, Option<Node>),
    path: &Path,
    stack: &mut Vec<PathBuf>,
    layers: &mut Vec<Layer>,
    findings: &mut Vec<Finding>,
) -> Result<(), InputError> {
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    stack.push(key);
    if let Some(ext) = extends {
        let items: Vec<&Node> = match &ext.kind {
            NodeKind::Str(_) => vec![&ext],
            NodeKind::Array(items) => items.iter().collect(),
            other => {
                return Err(layer.doc.error(
                    &ext.span,
                    format!(
                        "`extends` must be a path or a list of paths, found {}",
                        other.describe()
                    ),
                    "write `extends = \"base.toml\"`",
                ));
            }
        };
        for item in items {
            let NodeKind::Str(rel) = &item.kind else {
                return Err(layer.doc.error(
                    &item.span,
                    "`extends` entries must be strings",
                    "write `extends = [\"a.toml\", \"b.toml\"]`",
                ));
            };
            let loc = layer.doc.loc(&item.span);
            let base_path = layer.dir.join(rel);
            let canon = std::fs::canonicalize(&base_path).unwrap_or_else(|_| base_path.clone());
            if stack.contains(&canon) {
                findings.push(Finding::new(
                    FindingKind::BadExtends,
                    loc,
                    format!(
                        "`extends = \"{rel}\"` forms a cycle: {} is already being loaded",
                        base_path.display()
                    ),
                    "remove the extends that leads back to this file",
                ));
                continue;
            }
            if stack.len() >= MAX_EXTENDS_DEPTH {
                findings.push(Finding::new(
                    FindingKind::BadExtends,
                    loc,
                    format!("`extends` chain deeper than {MAX_EXTENDS_DEPTH} files"),
                    "flatten the chain",
                ));
                continue;
            }
            let source = match read_text_file(&base_path) {
                Ok(s) => s,
                Err(e) if e.kind == InputErrorKind::Unreadable => {
                    findings.push(Finding::new(
                        FindingKind::BadExtends,
                        loc,
                        format!(
                            "base set {} cannot be read: {}",
                            base_path.display(),
                            e.message
                        ),
                        "check the path; it is relative to the file that names it",
                    ));
                    continue;
                }
                Err(e) => return Err(e),
            };
            let parsed = parse_layer(source, Syntax::from_path(&base_path), &base_path)?;
            collect(parsed, &base_path, stack, layers, findings)?;
        }
    }
    stack.pop();
    layers.push(layer);
    Ok(())
}

fn resolve_schema(
    sref: &str,
    loc: &Location,
    dir: &Path,
    registry: &mut Registry,
    findings: &mut Vec<Finding>,
) -> Result<Option<Arc<Schema>>, InputError> {
    if let Some(s) = registry.get(sref) {
        return Ok(Some(s));
    }
    let is_path = sref.contains('/') || sref.contains('\\') || sref.ends_with(".toml");
    if is_path {
        let p = dir.join(sref);
        return match registry.load_file(&p) {
            Ok(s) => Ok(Some(s)),
            Err(e) if e.kind == InputErrorKind::Unreadable => {
                findings.push(Finding::new(
                    FindingKind::UnknownSchema,
                    loc.clone(),
                    format!("schema file {} cannot be read", p.display()),
                    "check the path; it is relative to the set file",
                ));
                Ok(None)
            }
            Err(e) => Err(e),
        };
    }
    let ids: Vec<String> = registry.schemas().map(|s| s.id.clone()).collect();
    if let Some(file) = registry.withheld(sref) {
        // The simulator's fixture schemas are not a user's (issue 9): a set
        // that means one names its file.
        findings.push(Finding::new(
            FindingKind::UnknownSchema,
            loc.clone(),
            format!("schema `{sref}` is a fictional fixture of the simulator; a set cannot name it by id"),
            format!(
                "name its file instead (schema = \"PATH\", relative to this set; in driveset's sources it is {file}), or a schema of a real drive: {}",
                ids.join(", ")
            ),
        ));
        return Ok(None);
    }
    let close = ids
        .iter()
        .min_by_key(|i| crate::validate::edit_distance(sref, i));
    findings.push(Finding::new(
        FindingKind::UnknownSchema,
        loc.clone(),
        format!("unknown schema `{sref}`"),
        match close {
            Some(c) => format!("did you mean `{c}`? known schemas: {}", ids.join(", ")),
            None => "no schemas are loaded".to_string(),
        },
    ));
    Ok(None)
}

/// Parse a code number key: `428`, `C0011`, `C11` (with optional `/N`).
fn parse_number_key(s: &str) -> Option<u32> {
    let digits = s.strip_prefix(['C', 'c']).unwrap_or(s);
    if digits.is_empty() || digits.len() > 9 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// Split a lust key in the spec's notation, `428-RSIO`, into (428, "RSIO").
fn split_lust_key(s: &str) -> Option<(u32, &str)> {
    let (num, name) = s.split_once('-')?;
    if name.is_empty()
        || num.is_empty()
        || num.len() > 9
        || !num.bytes().all(|b| b.is_ascii_digit())
    {
        return None;
    }
    Some((num.parse().ok()?, name))
}

/// A syntax error's snippet can show a line whose value is a password
/// (`C0094 = 12` given twice, `C0094 = 7771 x`): the file's schema is not
/// known yet, so the line's key is compared with the password codes of
/// every schema `registry` knows (by name, number or display spelling)
/// and, when it names one, the value part of the line (and its text in
/// the message) is masked.
pub fn mask_secret_line(mut e: InputError, registry: &Registry) -> InputError {
    let loc = &mut *e.location;
    if loc.line == 0 || loc.line_text.is_empty() {
        return e;
    }
    let text = loc.line_text.clone();
    let Some(sep) = text.find(['=', ':']) else {
        return e;
    };
    let key = text[..sep].trim().trim_matches(['"', '\'']);
    let base = key.split_once('/').map_or(key, |(b, _)| b);
    let names_secret = registry.schemas().any(|s| {
        s.codes.iter().filter(|c| s.is_password(c)).any(|c| {
            base == c.name
                || base == s.display_code(c.number, None)
                || base == c.number.to_string()
                || base.strip_prefix(&format!("{}-", c.number)).is_some()
                || parse_number_key(base) == Some(c.number)
        })
    });
    if !names_secret {
        return e;
    }
    let value = text[sep + 1..].trim();
    if !value.is_empty() && e.message.contains(value) {
        e.message = e.message.replace(value, crate::canonical::SECRET);
    }
    let from = sep + 1 + (text[sep + 1..].len() - text[sep + 1..].trim_start().len());
    e.location.mask_line_from(from);
    e
}

/// The code a `[values]` key of `doc` names, as the set reader resolves it
/// (number, `C`+number, name, alias, LUSTBUS `NN-NAME`, `/N` subcode);
/// `None` where loading the set reports a finding for the key instead.
/// For editors (hover, completion, go to definition).
pub fn code_of_key<'s>(
    schema: &'s Schema,
    doc: &Document,
    entry: &Entry,
) -> Option<(&'s Code, CodeKey)> {
    resolve_key(schema, doc, entry, &mut Vec::new()).1
}

fn resolve_key<'s>(
    schema: &'s Schema,
    doc: &Document,
    e: &Entry,
    out: &mut Vec<Finding>,
) -> (Option<&'s Code>, Option<(&'s Code, CodeKey)>) {
    let loc = || doc.loc(&e.key_span);
    let (base, sub) = match e.key.split_once('/') {
        Some((b, s)) => (b, Some(s)),
        None => (e.key.as_str(), None),
    };
    let subcode = match sub {
        None => None,
        Some(s) => match s.parse::<u32>() {
            Ok(v) if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) => Some(v),
            _ => {
                out.push(Finding::new(
                    FindingKind::UnknownCode,
                    loc(),
                    format!("`{}`: subcode `{s}` is not a number", e.key),
                    "write e.g. `C0039/1`",
                ));
                return (None, None);
            }
        },
    };
    let code = match schema.code_by_name_fast(base) {
        Some(c) => c,
        None => match parse_number_key(base) {
            None if schema.code_style == CodeStyle::Lust
                && let Some((num, name)) = split_lust_key(base) =>
            {
                match schema.code(num) {
                    Some(c) if c.name == name || c.aliases.iter().any(|(a, _)| a == name) => c,
                    Some(c) => {
                        out.push(Finding::new(
                            FindingKind::UnknownCode,
                            loc(),
                            format!(
                                "`{base}`: parameter {num} is {}, not {name}",
                                schema.display_code(num, None)
                            ),
                            format!(
                                "write `{}`, `{num}` or `{}`",
                                schema.display_code(num, None),
                                c.name
                            ),
                        ));
                        return (Some(c), None);
                    }
                    None => {
                        out.push(Finding::new(
                            FindingKind::UnknownCode,
                            loc(),
                            format!("{num} is not a code of {}", schema.id),
                            match schema.code_by_name(name) {
                                Some(c) => format!(
                                    "`{name}` is {}; write `{}`",
                                    schema.display_code(c.number, None),
                                    schema.display_code(c.number, None)
                                ),
                                None => {
                                    format!("check the number against the schema ({})", schema.path)
                                }
                            },
                        ));
                        return (None, None);
                    }
                }
            }
            Some(n) => match schema.code(n) {
                Some(c) => c,
                // `C5020/2` where the schema keeps that subindex as a code of
                // its own (`[[code]] index` + `subindex`, an imported ARRAY
                // whose subindexes differ): that code
                None if let Some(c) = subcode.and_then(|s| schema.lenze_subindex_code(n, s)) => {
                    return (Some(c), Some((c, CodeKey::new(c.number))));
                }
                None => {
                    out.push(Finding::new(
                        FindingKind::UnknownCode,
                        loc(),
                        format!(
                            "{} is not a code of {}",
                            schema.display_code(n, subcode),
                            schema.id
                        ),
                        format!("check the number against the schema ({})", schema.path),
                    ));
                    return (None, None);
                }
            },
            None => {
                out.push(Finding::new(
                    FindingKind::UnknownCode,
                    loc(),
                    format!("`{base}` is not a code name of {}", schema.id),
                    match suggest(schema, base) {
                        Some(s) => format!("did you mean `{s}`?"),
                        None => format!(
                            "use a code number or a name from the schema ({})",
                            schema.path
                        ),
                    },
                ));
                return (None, None);
            }
        },
    };
    match (code.subcodes, subcode) {
        (Some(n), Some(s)) if (1..=n).contains(&s) => {}
        (Some(n), _) => {
            out.push(Finding::new(
                FindingKind::UnknownCode,
                loc(),
                format!(
                    "{} has subcodes 1..={n}; `{}` names none of them",
                    schema.display_code(code.number, None),
                    e.key
                ),
                format!("write e.g. `{}`", schema.display_code(code.number, Some(1))),
            ));
            return (Some(code), None);
        }
        (None, Some(_)) => {
            out.push(Finding::new(
                FindingKind::UnknownCode,
                loc(),
                format!("{} has no subcodes", schema.display_code(code.number, None)),
                format!(
                    "write `{}` without `/N`",
                    schema.display_code(code.number, None)
                ),
            ));
            return (Some(code), None);
        }
        (None, None) => {}
    }
    (
        Some(code),
        Some((
            code,
            CodeKey {
                number: code.number,
                subcode,
            },
        )),
    )
}
