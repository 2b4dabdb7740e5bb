//! Owns one document open in an editor as the analysis sees it: its text
//! (edited in place, positions in [`LineCol`]), the file it is (its path
//! names its syntax and the `extends` and schema files it reads) and the
//! schema its last analysis found, which hover, go to definition,
//! completion and a code's facts answer with (docs/editors.md). What it
//! gives is plain data in byte spans of its text; the language server
//! turns them into its positions ([`Text::range`]).

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_link::Openers;
use driveset_schema::doc::Syntax;
use driveset_schema::{Location, Registry, Schema};

use crate::analysis::{self, Diagnostic};
use crate::facts;
use crate::navigate::{self, Completion, Cursor, Hover};
use crate::text::{LineCol, Text};

/// One open document.
#[derive(Debug, Clone)]
pub struct OpenDocument {
    text: Text,
    path: PathBuf,
    /// The schema the set named when last analysed (kept while the text
    /// names none that loads, so hover and completion go on while typing).
    schema: Option<Arc<Schema>>,
}

impl OpenDocument {
    /// The document at `path` with its full `text`, not yet analysed.
    pub fn new(path: PathBuf, text: String) -> Self {
        OpenDocument {
            text: Text::new(text),
            path,
            schema: None,
        }
    }

    /// Its text.
    pub fn text(&self) -> &Text {
        &self.text
    }

    /// Its file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Replace `range` (or the whole text, for `None`) with `new`.
    pub fn edit(&mut self, range: Option<Range<LineCol>>, new: &str) {
        self.text.apply(range, new);
    }

    /// The diagnostics of the text as it is now (a manifest's ports against
    /// `openers`, as `validate` checks them); the schema a set names is
    /// kept for hover, completion and definition.
    pub fn analyse(&mut self, registry: &mut Registry, openers: &Openers) -> Vec<Diagnostic> {
        let a = analysis::analyse(&self.path, self.text.as_str(), registry, openers);
        self.schema = a.schema.or(self.schema.take());
        a.diagnostics
    }

    /// The parsed text, its schema and the byte offset of `at`.
    fn at(&self, at: LineCol) -> Option<(driveset_schema::doc::Document, &Schema, usize)> {
        let parsed = analysis::parse(&self.path, self.text.as_str()).ok()?;
        let schema = self.schema.as_deref()?;
        Some((parsed, schema, self.text.offset(at)))
    }

    /// The facts of the code written at `at` and its key's span.
    pub fn hover(&self, at: LineCol) -> Option<Hover> {
        let (parsed, schema, offset) = self.at(at)?;
        navigate::hover(schema, &parsed, offset)
    }

    /// Where the schema defines the code written at `at` (its schema
    /// file, line and column, 1-based; a built-in schema's file as the
    /// binary holds it).
    pub fn definition(&self, at: LineCol) -> Option<Location> {
        let (parsed, schema, offset) = self.at(at)?;
        navigate::definition(schema, &parsed, offset).cloned()
    }

    /// Completion at `at`: `[values]` keys and values with the document's
    /// schema, the schema ids of `registry` after `schema =`.
    pub fn complete(&self, at: LineCol, registry: &Registry) -> Option<Vec<Completion>> {
        let cursor = Cursor {
            line: at.line as usize,
            line_start: self.text.offset(LineCol::new(at.line, 0)),
            offset: self.text.offset(at),
        };
        navigate::complete(
            self.text.as_str(),
            cursor,
            Syntax::from_path(&self.path),
            self.schema.as_deref(),
            registry,
        )
    }

    /// The facts of code `number` of the document's schema, as markdown
    /// (what a completion of its key shows once chosen).
    pub fn facts(&self, number: u32) -> Option<String> {
        let schema = self.schema.as_deref()?;
        Some(facts::markdown(schema, schema.code(number)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_open_set_answers_at_its_positions_and_keeps_its_schema_while_edited() {
        let mut registry = Registry::builtin().unwrap();
        let openers = Openers::none();
        let text = "schema = \"lenze-tmd\"\n\n[values]\nC0011 = 50\n".to_string();
        let mut doc = OpenDocument::new(PathBuf::from("s.toml"), text);
        assert_eq!(doc.analyse(&mut registry, &openers), Vec::new());
        // hover and definition at C0011's key (line 3)
        let h = doc.hover(LineCol::new(3, 2)).unwrap();
        assert_eq!(&doc.text().as_str()[h.span.clone()], "C0011");
        assert_eq!(
            doc.text().range(h.span),
            LineCol::new(3, 0)..LineCol::new(3, 5)
        );
        let loc = doc.definition(LineCol::new(3, 2)).unwrap();
        assert_eq!(
            (loc.file.as_str(), loc.line),
            ("schemas/lenze-tmd.toml", 211)
        );
        assert!(doc.facts(11).unwrap().contains("Maximum output frequency"));
        // an unknown code after an edit; the schema stays while the
        // schema line is broken
        doc.edit(Some(LineCol::new(3, 0)..LineCol::new(3, 5)), "C9999");
        let d = doc.analyse(&mut registry, &openers);
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].code, "unknown-code");
        doc.edit(Some(LineCol::new(0, 0)..LineCol::new(0, 6)), "schem");
        let _ = doc.analyse(&mut registry, &openers);
        let keys = doc.complete(LineCol::new(3, 0), &registry).unwrap();
        assert!(keys.iter().any(|c| c.code == Some(11)));
    }

    #[test]
    fn a_builtin_schema_file_is_copied_read_only_once() {
        let dir = tempfile::tempdir().unwrap();
        let copy = navigate::schema_file("schemas/lenze-tmd.toml", dir.path()).unwrap();
        assert_eq!(copy, dir.path().join("schemas/lenze-tmd.toml"));
        let text = std::fs::read_to_string(&copy).unwrap();
        assert_eq!(text, driveset_schema::schema::BUILTIN_FILES[0].1);
        assert!(std::fs::metadata(&copy).unwrap().permissions().readonly());
        assert_eq!(
            navigate::schema_file("schemas/lenze-tmd.toml", dir.path()),
            Some(copy)
        );
        let other = navigate::schema_file("learned.toml", dir.path()).unwrap();
        assert!(other.is_absolute() && other.ends_with("learned.toml"));
    }
}
