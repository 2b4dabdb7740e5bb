//! Owns the language server's view of the editor's analysis
//! (`driveset_ide`): LSP positions as its plain ones and back, its
//! diagnostics as LSP diagnostics, byte spans as LSP ranges of the
//! document's text, other files' places as file URIs, and a finding's fix
//! carried in the diagnostic's `data` for the code action.

use driveset_ide::analysis::{self as ide, Fix, Place};
use driveset_ide::document::OpenDocument;
use driveset_ide::text::{LineCol, Text};
use driveset_schema::Registry;
use lsp_types::{
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString,
    Position, Range,
};
use serde_json::Value;

use super::uri;

/// driveset-ide's position of an LSP position (both count UTF-16 units).
pub fn line_col(p: Position) -> LineCol {
    LineCol::new(p.line, p.character)
}

/// The LSP position of driveset-ide's.
pub fn position(p: LineCol) -> Position {
    Position::new(p.line, p.col)
}

/// The LSP range of a byte span of `text`.
pub fn range(text: &Text, span: std::ops::Range<usize>) -> Range {
    let r = text.range(span);
    Range::new(position(r.start), position(r.end))
}

/// Analyse a document (a manifest's ports against the CLI's openers, as
/// `validate` checks them): its diagnostics, for the client.
pub fn diagnostics(doc: &mut OpenDocument, registry: &mut Registry) -> Vec<Diagnostic> {
    let display = doc.path().display().to_string();
    doc.analyse(registry, &crate::port::openers())
        .into_iter()
        .map(|d| diagnostic(&display, doc.text(), d))
        .collect()
}

/// The LSP location of the file `path` at `loc`'s line and column
/// (1-based, as findings and schemas give them).
pub fn location(path: &std::path::Path, loc: &driveset_schema::Location) -> Option<Location> {
    let line = loc.line.saturating_sub(1) as u32;
    let col = loc.column.saturating_sub(1) as u32;
    Some(Location {
        uri: uri::from_path(path)?,
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
                    range: range(text, span.clone()),
                },
                Place::Elsewhere(loc) => location(&std::path::absolute(&loc.file).ok()?, loc)?,
            };
            Some(DiagnosticRelatedInformation {
                location,
                message: r.message.clone(),
            })
        })
        .collect();
    Diagnostic {
        range: d.span.map(|s| range(text, s)).unwrap_or_default(),
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
                range: range(text, e.span.clone()),
            })
            .collect(),
        title: &f.title,
    };
    serde_json::to_value(data).unwrap_or_default()
}
