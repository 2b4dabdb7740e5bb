//! Owns what the language server computes from one document's text: its
//! diagnostics (the findings `driveset validate` gives the same file: a set
//! through `driveset_schema::load_set_str`, a line manifest through
//! `validate_manifest_str`, a schema file through the `schema check`
//! rules), each at its span with its help, and the mechanical fix a
//! finding has (carried in the diagnostic's `data` for the code action).

use std::path::Path;
use std::sync::Arc;

use driveset_schema::doc::{self, Document, Entry, NodeKind, Syntax};
use driveset_schema::error::source_from_str;
use driveset_schema::{Finding, FindingKind, InputError, Registry, Schema};
use lsp_types::{
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString,
    Position, Range,
};
use serde_json::{Value, json};

use super::text::Text;
use super::uri;

/// What one analysis of a document found.
pub struct Analysis {
    /// The diagnostics, in file order.
    pub diagnostics: Vec<Diagnostic>,
    /// The schema the set names, when known (hover, completion, definition).
    pub schema: Option<Arc<Schema>>,
}

/// What kind of driveset file a text is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// A parameter set.
    Set,
    /// A line manifest (`[line]`, `[[bus]]`).
    Manifest,
    /// A schema file (`[schema]` table).
    Schema,
}

/// The kind of a parsed document, as `driveset validate` tells them apart.
pub fn kind_of(d: &Document) -> FileKind {
    if driveset_engine::line::manifest::is_manifest_doc(d) {
        FileKind::Manifest
    } else if d
        .root
        .get("schema")
        .is_some_and(|e| matches!(e.value.kind, NodeKind::Table(_)))
    {
        FileKind::Schema
    } else {
        FileKind::Set
    }
}

/// Parse a document's text as the file at `path` would be read.
pub fn parse(path: &Path, text: &str) -> Result<Document, InputError> {
    let source = source_from_str(&path.display().to_string(), text)?;
    doc::parse(source, Syntax::from_path(path))
}

/// Analyse `text` as the file at `path`.
pub fn analyse(path: &Path, text: &Text, registry: &mut Registry) -> Analysis {
    let display = path.display().to_string();
    let parsed = match parse(path, text.as_str()) {
        Ok(d) => d,
        Err(e) => {
            return Analysis {
                diagnostics: vec![input_error(&display, text, &e)],
                schema: None,
            };
        }
    };
    // an editor starts the server for every TOML / YAML file (Cargo.toml,
    // CI files): one that is no driveset file is left alone
    let kind = kind_of(&parsed);
    if kind == FileKind::Set
        && parsed.root.get("schema").is_none()
        && parsed.root.get("values").is_none()
    {
        return Analysis {
            diagnostics: Vec::new(),
            schema: None,
        };
    }
    // each finding with the kind its diagnostic's code names
    type Found = (Vec<(Finding, String)>, Option<Arc<Schema>>);
    let own = |fs: Vec<Finding>| -> Vec<(Finding, String)> {
        fs.into_iter()
            .map(|f| {
                let k = f.kind.as_str().to_string();
                (f, k)
            })
            .collect()
    };
    let findings: Result<Found, InputError> = match kind {
        FileKind::Manifest => driveset_engine::line::manifest::validate_manifest_str(
            path,
            text.as_str(),
            &crate::port::openers(),
        )
        .map(|fs| {
            // the manifest's own kind (`duplicate-address`, ...) names the diagnostic
            let findings = fs
                .iter()
                .map(|f| (f.to_finding(), f.kind.clone()))
                .collect();
            (findings, None)
        }),
        FileKind::Schema => source_from_str(&display, text.as_str()).and_then(|s| {
            driveset_schema::check::check_schema_source(s, registry, &[])
                .map(|(_, f)| (own(f), None))
        }),
        FileKind::Set => driveset_schema::load_set_str(path, text.as_str(), registry)
            .map(|l| (own(l.findings), l.schema)),
    };
    match findings {
        Err(e) => Analysis {
            diagnostics: vec![input_error(&display, text, &e)],
            schema: None,
        },
        Ok((findings, schema)) => {
            let diagnostics = findings
                .iter()
                .map(|(f, kind)| diagnostic(&display, text, &parsed, schema.as_deref(), f, kind))
                .collect();
            Analysis {
                diagnostics,
                schema,
            }
        }
    }
}

fn input_error(display: &str, text: &Text, e: &InputError) -> Diagnostic {
    let range = if e.location.file == display && e.location.line > 0 {
        text.range(e.location.span.clone())
    } else {
        Range::default()
    };
    Diagnostic {
        range,
        severity: Some(DiagnosticSeverity::ERROR),
        code: Some(NumberOrString::String("input-error".into())),
        source: Some("driveset".into()),
        message: format!("{}\nhelp: {}", e.message, e.help),
        ..Diagnostic::default()
    }
}

/// An LSP location of a finding's place in another file (line and column
/// as the finding gives them).
fn other_location(loc: &driveset_schema::Location) -> Option<Location> {
    let path = std::path::absolute(&loc.file).ok()?;
    let line = loc.line.saturating_sub(1) as u32;
    let col = loc.column.saturating_sub(1) as u32;
    Some(Location {
        uri: uri::from_path(&path)?,
        range: Range::new(Position::new(line, col), Position::new(line, col)),
    })
}

fn diagnostic(
    display: &str,
    text: &Text,
    parsed: &Document,
    schema: Option<&Schema>,
    f: &Finding,
    kind: &str,
) -> Diagnostic {
    let help = &f.help;
    let here = f.location.file == display;
    let (range, message) = if here {
        (
            text.range(f.location.span.clone()),
            format!("{}\nhelp: {help}", f.message),
        )
    } else {
        // a finding in a base set (`extends`): shown at the top, naming its place
        (
            Range::default(),
            format!("{}: {}\nhelp: {help}", f.location, f.message),
        )
    };
    let related: Vec<DiagnosticRelatedInformation> = f
        .related
        .iter()
        .filter_map(|(label, loc)| {
            let location = if loc.file == display {
                Location {
                    uri: uri::from_path(&std::path::absolute(display).ok()?)?,
                    range: text.range(loc.span.clone()),
                }
            } else {
                other_location(loc)?
            };
            Some(DiagnosticRelatedInformation {
                location,
                message: label.clone(),
            })
        })
        .collect();
    Diagnostic {
        range,
        severity: Some(DiagnosticSeverity::ERROR),
        code: Some(NumberOrString::String(kind.to_string())),
        source: Some("driveset".into()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        data: if here {
            fix(text, parsed, schema, f)
        } else {
            None
        },
        ..Diagnostic::default()
    }
}

/// The entry of `[values]` whose key or value holds byte `offset`.
pub fn values_entry(d: &Document, offset: usize) -> Option<&Entry> {
    let values = &d.root.get("values")?.value;
    values
        .entries()
        .iter()
        .find(|e| e.key_span.contains(&offset) || span_holds(&e.value.span, offset))
}

fn span_holds(span: &std::ops::Range<usize>, offset: usize) -> bool {
    span.start <= offset && offset <= span.end.max(span.start + 1)
}

/// A value as the file's syntax writes a string (`"..."`, JSON escapes,
/// which TOML basic strings and YAML double-quoted scalars share).
pub fn quoted(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_default()
}

/// The mechanical fix of a finding, as `{"title", "edits": [{range, newText}]}`.
fn fix(text: &Text, parsed: &Document, schema: Option<&Schema>, f: &Finding) -> Option<Value> {
    let span = f.location.span.clone();
    let edit = |range: Range, new: &str| json!({"range": range, "newText": new});
    if f.help.starts_with("remove this line") || f.kind == FindingKind::DuplicateCode {
        let line = text.line_span(span.start);
        return Some(json!({
            "title": "remove this line",
            "edits": [edit(text.range(line), "")],
        }));
    }
    if f.kind == FindingKind::UnknownCode
        && let Some(rest) = f.help.strip_prefix("did you mean `")
        && let Some(name) = rest.strip_suffix("`?")
    {
        return Some(json!({
            "title": format!("replace with `{name}`"),
            "edits": [edit(text.range(span), name)],
        }));
    }
    if f.kind == FindingKind::UnknownEnumLabel {
        let schema = schema?;
        let e = values_entry(parsed, span.start)?;
        if e.value.span != span {
            return None; // a bit-field member's label: not offered
        }
        let NodeKind::Str(given) = &e.value.kind else {
            return None;
        };
        let (code, _) = driveset_schema::set::code_of_key(schema, parsed, e)?;
        let labels = crate::editor::facts::labels(schema, code);
        let (_, best) = labels
            .iter()
            .min_by_key(|(_, l)| driveset_schema::validate::edit_distance(given, l))?;
        return Some(json!({
            "title": format!("replace with {}", quoted(best)),
            "edits": [edit(text.range(span), &quoted(best))],
        }));
    }
    None
}
