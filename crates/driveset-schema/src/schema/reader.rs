//! Reading a document's table with locations (the schema file's
//! [`Reader`]): every key taken once, unknown keys and wrong types reported
//! with the file, line and what to do (docs/file-formats.md, "Schema files").

use crate::doc::{Document, Entry, Node, NodeKind};
use crate::error::{InputError, Location};

use super::{Fact, parse_int_text};

pub(super) struct Reader<'d> {
    pub(super) doc: &'d Document,
    pub(super) entries: &'d [Entry],
    pub(super) used: Vec<bool>,
    pub(super) what: String,
    pub(super) span: std::ops::Range<usize>,
}

impl<'d> Reader<'d> {
    pub(super) fn new(
        doc: &'d Document,
        node: &'d Node,
        what: impl Into<String>,
    ) -> Result<Self, InputError> {
        let what = what.into();
        match &node.kind {
            NodeKind::Table(entries) => Ok(Reader {
                doc,
                entries,
                used: vec![false; entries.len()],
                what,
                span: node.span.clone(),
            }),
            other => Err(doc.error(
                &node.span,
                format!("{what} must be a table, found {}", other.describe()),
                "see docs/file-formats.md, \"Schema files\"",
            )),
        }
    }

    pub(super) fn loc(&self) -> Location {
        self.doc.loc(&self.span)
    }

    pub(super) fn take(&mut self, key: &str) -> Option<&'d Entry> {
        let i = self.entries.iter().position(|e| e.key == key)?;
        if let Some(u) = self.used.get_mut(i) {
            *u = true;
        }
        self.entries.get(i)
    }

    pub(super) fn wrong(&self, e: &Entry, expected: &str) -> InputError {
        self.doc.error(
            &e.value.span,
            format!(
                "`{}` in {} must be {expected}, found {}",
                e.key,
                self.what,
                e.value.kind.describe()
            ),
            format!("write `{}` as {expected}", e.key),
        )
    }

    pub(super) fn string(&mut self, key: &str) -> Result<Option<(String, Location)>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => match &e.value.kind {
                NodeKind::Str(s) => Ok(Some((s.clone(), self.doc.loc(&e.value.span)))),
                _ => Err(self.wrong(e, "a string")),
            },
        }
    }

    pub(super) fn required_string(&mut self, key: &str) -> Result<(String, Location), InputError> {
        match self.string(key)? {
            Some(v) => Ok(v),
            None => Err(self.doc.error(
                &self.span,
                format!("{} has no `{key}`", self.what),
                format!("add `{key} = \"...\"` (docs/file-formats.md)"),
            )),
        }
    }

    pub(super) fn boolean(&mut self, key: &str) -> Result<Option<bool>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => match &e.value.kind {
                NodeKind::Bool(b) => Ok(Some(*b)),
                _ => Err(self.wrong(e, "true or false")),
            },
        }
    }

    pub(super) fn int_node(&self, e: &Entry) -> Result<i128, InputError> {
        match &e.value.kind {
            NodeKind::Num(t) => parse_int_text(t).ok_or_else(|| self.wrong(e, "an integer")),
            _ => Err(self.wrong(e, "an integer")),
        }
    }

    pub(super) fn uint<T: TryFrom<i128>>(
        &mut self,
        key: &str,
    ) -> Result<Option<(T, Location)>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => {
                let v = self.int_node(e)?;
                let loc = self.doc.loc(&e.value.span);
                T::try_from(v).map(|t| Some((t, loc))).map_err(|_| {
                    self.doc.error(
                        &e.value.span,
                        format!("`{}` = {v} is out of range", e.key),
                        "give a small non-negative integer",
                    )
                })
            }
        }
    }

    pub(super) fn string_list(&mut self, key: &str) -> Result<Vec<(String, Location)>, InputError> {
        match self.take(key) {
            None => Ok(Vec::new()),
            Some(e) => match &e.value.kind {
                NodeKind::Array(items) => items
                    .iter()
                    .map(|n| match &n.kind {
                        NodeKind::Str(s) => Ok((s.clone(), self.doc.loc(&n.span))),
                        _ => Err(self.wrong(e, "an array of strings")),
                    })
                    .collect(),
                _ => Err(self.wrong(e, "an array of strings")),
            },
        }
    }

    pub(super) fn fact(&mut self, key: &str) -> Result<Option<Fact>, InputError> {
        match self.take(key) {
            None => Ok(None),
            Some(e) => match &e.value.kind {
                NodeKind::Str(_) | NodeKind::Num(_) => Ok(Some(Fact {
                    value: e.value.kind.clone(),
                    loc: self.doc.loc(&e.value.span),
                })),
                _ => Err(self.wrong(e, "a decimal string or a number")),
            },
        }
    }

    pub(super) fn finish(self) -> Result<(), InputError> {
        for (e, used) in self.entries.iter().zip(&self.used) {
            if !used {
                return Err(self.doc.error(
                    &e.key_span,
                    format!("unknown key `{}` in {}", e.key, self.what),
                    "check the spelling against docs/file-formats.md, \"Schema files\"",
                ));
            }
        }
        Ok(())
    }
}
