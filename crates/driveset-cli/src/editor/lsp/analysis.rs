//! Owns the language server's view of one analysis (`driveset_ide::analysis`):
//! its diagnostics as LSP diagnostics, byte spans as LSP ranges of the
//! document's text, other files' places as file URIs, and a finding's fix
//! carried in the diagnostic's `data` for the code action.

use std::path::Path;
use std::sync::Arc;

use driveset_ide::analysis::{self as ide, Fix, Place};
use driveset_schema::{Registry, Schema};
use lsp_types::{
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString,
    Position, Range,
};
use serde_json::Value;

use super::text::Text;
use super::uri;

/// What one analysis of a document found, for the client.
pub struct Analysis {
    /// The diagnostics, in file order.
    pub diagnostics: Vec<Diagnostic>,
    /// The schema the set names, when known (hover, completion, definition).
    pub schema: Option<Arc<Schema>>,
}

/// Analyse `text` as the file at `path` (a manifest's ports against the
/// CLI's openers, as `validate` checks them).
pub fn analyse(path: &Path, text: &Text, registry: &mut Registry) -> Analysis {
    let display = path.display().to_string();
    let a = ide::analyse(path, text.as_str(), registry, &crate::port::openers());
    Analysis {
        diagnostics: a
            .diagnostics
            .into_iter()
            .map(|d| diagnostic(&display, text, d))
            .collect(),
        schema: a.schema,
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

fn diagnostic(display: &str, text: &Text, d: ide::Diagnostic) -> Diagnostic {
    let related: Vec<DiagnosticRelatedInformation> = d
        .related
        .iter()
        .filter_map(|r| {
            let location = match &r.place {
                Place::Here(span) => Location {
                    uri: uri::from_path(&std::path::absolute(display).ok()?)?,
                    range: text.range(span.clone()),
                },
                Place::Elsewhere(loc) => other_location(loc)?,
            };
            Some(DiagnosticRelatedInformation {
                location,
                message: r.message.clone(),
            })
        })
        .collect();
    Diagnostic {
        range: d.span.map(|s| text.range(s)).unwrap_or_default(),
        severity: Some(DiagnosticSeverity::ERROR),
        code: Some(NumberOrString::String(d.code)),
        source: Some("driveset".into()),
        message: d.message,
        related_information: (!related.is_empty()).then_some(related),
        data: d.fix.map(|f| fix_data(text, &f)),
        ..Diagnostic::default()
    }
}

/// A fix as the diagnostic's `data`: `{"title", "edits": [{range, newText}]}`
/// (the code action reads it back).
#[derive(serde::Serialize)]
struct FixData<'a> {
    edits: Vec<EditData<'a>>,
    title: &'a str,
}

/// One edit of a fix, as LSP's `TextEdit`.
#[derive(serde::Serialize)]
struct EditData<'a> {
    #[serde(rename = "newText")]
    new_text: &'a str,
    range: Range,
}

fn fix_data(text: &Text, f: &Fix) -> Value {
    let data = FixData {
        edits: f
            .edits
            .iter()
            .map(|e| EditData {
                new_text: &e.new_text,
                range: text.range(e.span.clone()),
            })
            .collect(),
        title: &f.title,
    };
    serde_json::to_value(data).unwrap_or_default()
}
