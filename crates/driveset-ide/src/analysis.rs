//! Owns what the editor computes from one document's text: its diagnostics
//! (the findings `driveset validate` gives the same file: a set through
//! `driveset_schema::load_set_str`, a line manifest through
//! `validate_manifest_str`, a schema file through the `schema check`
//! rules), each at its byte span with its help, and the mechanical fix a
//! finding has (docs/editors.md). Spans are byte offsets into the text; the
//! language server turns them into its positions.

use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

use driveset_link::Openers;
use driveset_schema::doc::{self, Document, Entry, NodeKind, Syntax};
use driveset_schema::error::source_from_str;
use driveset_schema::{Finding, FindingKind, InputError, Location, Registry, Schema};

/// What one analysis of a document found.
pub struct Analysis {
    /// The diagnostics, in file order.
    pub diagnostics: Vec<Diagnostic>,
    /// The schema the set names, when known (hover, completion, definition).
    pub schema: Option<Arc<Schema>>,
}

/// One finding of a document, as an editor shows it (always an error).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// Where in the document; `None`: at its top (a finding of a base set
    /// it `extends`, an input error without a place in this text).
    pub span: Option<Range<usize>>,
    /// What kind of finding (`unknown-code`, a manifest's
    /// `duplicate-address`, `input-error`).
    pub code: String,
    /// The message and its help, on two lines.
    pub message: String,
    /// The other places the finding names, with their labels.
    pub related: Vec<Related>,
    /// The mechanical fix, when the finding has one.
    pub fix: Option<Fix>,
}

/// Another place a finding names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Related {
    /// Its label.
    pub message: String,
    /// Where.
    pub place: Place,
}

/// A place in this document or in another file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Place {
    /// A byte span of this document.
    Here(Range<usize>),
    /// Another file, at the line and column the finding gives.
    Elsewhere(Location),
}

/// A finding's mechanical fix: edits of this document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fix {
    /// What it does (`remove this line`, ``replace with `X` ``).
    pub title: String,
    /// The edits, in order.
    pub edits: Vec<Edit>,
}

/// One edit: a byte span of the document and its new text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Edit {
    /// The span replaced.
    pub span: Range<usize>,
    /// Its new text.
    pub new_text: String,
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

/// Analyse `text` as the file at `path`; a manifest's ports are checked
/// against `openers` (the schemes the front end registers, as `validate`).
pub fn analyse(path: &Path, text: &str, registry: &mut Registry, openers: &Openers) -> Analysis {
    let display = path.display().to_string();
    let parsed = match parse(path, text) {
        Ok(d) => d,
        Err(e) => {
            return Analysis {
                diagnostics: vec![input_error(&display, &e)],
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
        FileKind::Manifest => {
            driveset_engine::line::manifest::validate_manifest_str(path, text, openers).map(|fs| {
                // the manifest's own kind (`duplicate-address`, ...) names the diagnostic
                let findings = fs
                    .iter()
                    .map(|f| (f.to_finding(), f.kind.clone()))
                    .collect();
                (findings, None)
            })
        }
        FileKind::Schema => source_from_str(&display, text).and_then(|s| {
            driveset_schema::check::check_schema_source(s, registry, &[])
                .map(|(_, f)| (own(f), None))
        }),
        FileKind::Set => {
            driveset_schema::load_set_str(path, text, registry).map(|l| (own(l.findings), l.schema))
        }
    };
    match findings {
        Err(e) => Analysis {
            diagnostics: vec![input_error(&display, &e)],
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

fn input_error(display: &str, e: &InputError) -> Diagnostic {
    let span = (e.location.file == display && e.location.line > 0).then(|| e.location.span.clone());
    Diagnostic {
        span,
        code: "input-error".into(),
        message: format!("{}\nhelp: {}", e.message, e.help),
        related: Vec::new(),
        fix: None,
    }
}

fn diagnostic(
    display: &str,
    text: &str,
    parsed: &Document,
    schema: Option<&Schema>,
    f: &Finding,
    kind: &str,
) -> Diagnostic {
    let help = &f.help;
    let here = f.location.file == display;
    let (span, message) = if here {
        (
            Some(f.location.span.clone()),
            format!("{}\nhelp: {help}", f.message),
        )
    } else {
        // a finding in a base set (`extends`): shown at the top, naming its place
        (None, format!("{}: {}\nhelp: {help}", f.location, f.message))
    };
    let related = f
        .related
        .iter()
        .map(|(label, loc)| Related {
            message: label.clone(),
            place: if loc.file == display {
                Place::Here(loc.span.clone())
            } else {
                Place::Elsewhere(loc.clone())
            },
        })
        .collect();
    Diagnostic {
        span,
        code: kind.to_string(),
        message,
        related,
        fix: if here {
            fix(text, parsed, schema, f)
        } else {
            None
        },
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

/// The byte span of the whole line of `text` holding `offset`, its newline
/// included.
pub fn line_span(text: &str, offset: usize) -> Range<usize> {
    let b = text.as_bytes();
    let offset = offset.min(b.len());
    let start = b[..offset]
        .iter()
        .rposition(|&c| c == b'\n')
        .map_or(0, |i| i + 1);
    let end = b[offset..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(b.len(), |i| offset + i + 1);
    start..end
}

/// The mechanical fix of a finding.
fn fix(text: &str, parsed: &Document, schema: Option<&Schema>, f: &Finding) -> Option<Fix> {
    let span = f.location.span.clone();
    let one = |title: String, span: Range<usize>, new: &str| Fix {
        title,
        edits: vec![Edit {
            span,
            new_text: new.to_string(),
        }],
    };
    if f.help.starts_with("remove this line") || f.kind == FindingKind::DuplicateCode {
        return Some(one(
            "remove this line".into(),
            line_span(text, span.start),
            "",
        ));
    }
    if f.kind == FindingKind::UnknownCode
        && let Some(rest) = f.help.strip_prefix("did you mean `")
        && let Some(name) = rest.strip_suffix("`?")
    {
        return Some(one(format!("replace with `{name}`"), span, name));
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
        let labels = crate::facts::labels(schema, code);
        let (_, best) = labels
            .iter()
            .min_by_key(|(_, l)| driveset_schema::validate::edit_distance(given, l))?;
        return Some(one(
            format!("replace with {}", quoted(best)),
            span,
            &quoted(best),
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_span_holds_its_newline() {
        let t = "a = 1\nbé = 2\nc";
        assert_eq!(line_span(t, 0), 0..6);
        assert_eq!(line_span(t, 5), 0..6);
        assert_eq!(line_span(t, 6), 6..14);
        assert_eq!(line_span(t, 8), 6..14);
        assert_eq!(line_span(t, 14), 14..15);
        assert_eq!(line_span(t, 99), 14..15);
    }
}
