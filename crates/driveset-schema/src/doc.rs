//! Owns the small spanned document tree that TOML and YAML files (schemas and
//! sets) are read into, so every key and value has file:line:column and the
//! literal text of numbers (docs/file-formats.md: "Numbers are taken from the
//! file's text, never through a binary float").

use std::ops::Range;

use crate::error::{InputError, InputErrorKind, Location, SourceFile};

/// Deepest nesting accepted in a document.
pub const MAX_DEPTH: usize = 64;

/// A value node with its byte span in the source.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// The value.
    pub kind: NodeKind,
    /// Byte span in the source.
    pub span: Range<usize>,
}

/// The kinds of value a document holds.
#[derive(Debug, Clone, PartialEq)]
pub enum NodeKind {
    /// A string (TOML string, YAML quoted or non-numeric plain scalar).
    Str(String),
    /// A number, as the literal source text (`0.1`, `1_000`, `0x0341`, `-0`).
    Num(String),
    /// A boolean.
    Bool(bool),
    /// A table / mapping, in source order.
    Table(Vec<Entry>),
    /// An array / sequence.
    Array(Vec<Node>),
    /// YAML null.
    Null,
    /// A TOML date/time (never valid in driveset files).
    Datetime,
}

/// One key of a table.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The key text.
    pub key: String,
    /// Byte span of the key.
    pub key_span: Range<usize>,
    /// The value.
    pub value: Node,
}

impl NodeKind {
    /// A short name of the kind for messages ("a table", "a string", ...).
    pub fn describe(&self) -> &'static str {
        match self {
            NodeKind::Str(_) => "a string",
            NodeKind::Num(_) => "a number",
            NodeKind::Bool(_) => "a boolean",
            NodeKind::Table(_) => "a table",
            NodeKind::Array(_) => "an array",
            NodeKind::Null => "null",
            NodeKind::Datetime => "a date/time",
        }
    }
}

impl Node {
    /// Look a key up in a table node.
    pub fn get(&self, key: &str) -> Option<&Entry> {
        match &self.kind {
            NodeKind::Table(entries) => entries.iter().find(|e| e.key == key),
            _ => None,
        }
    }

    /// The entries of a table node (empty for other kinds).
    pub fn entries(&self) -> &[Entry] {
        match &self.kind {
            NodeKind::Table(entries) => entries,
            _ => &[],
        }
    }
}

/// A parsed file: its source and root node.
#[derive(Debug, Clone)]
pub struct Document {
    /// The file.
    pub source: SourceFile,
    /// The root table.
    pub root: Node,
}

impl Document {
    /// Location of a span in this document.
    pub fn loc(&self, span: &Range<usize>) -> Location {
        self.source.location(span.clone())
    }

    /// An input error at a span.
    pub fn error(
        &self,
        span: &Range<usize>,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> InputError {
        InputError::new(InputErrorKind::Structure, self.loc(span), message, help)
    }
}

/// The syntax a file is read as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Syntax {
    /// TOML.
    Toml,
    /// YAML 1.2 (also reads JSON).
    Yaml,
}

impl Syntax {
    /// By file extension: `.yaml`, `.yml` and `.json` are YAML, anything else TOML.
    pub fn from_path(path: &std::path::Path) -> Syntax {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("yaml" | "yml" | "json") => Syntax::Yaml,
            _ => Syntax::Toml,
        }
    }
}

/// Parse a source file in the given syntax; the root must be a table.
pub fn parse(source: SourceFile, syntax: Syntax) -> Result<Document, InputError> {
    let root = match syntax {
        Syntax::Toml => parse_toml(&source)?,
        Syntax::Yaml => parse_yaml(&source)?,
    };
    if !matches!(root.kind, NodeKind::Table(_)) {
        return Err(InputError::new(
            InputErrorKind::Structure,
            source.location(root.span.clone()),
            format!(
                "the document is {}, not a table of keys",
                root.kind.describe()
            ),
            "start the file with `schema = \"...\"` (TOML) or `schema: ...` (YAML)",
        ));
    }
    Ok(Document { source, root })
}

fn syntax_error(source: &SourceFile, span: Range<usize>, msg: &str, lang: &str) -> InputError {
    let first = msg
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or(msg)
        .trim();
    InputError::new(
        InputErrorKind::Syntax,
        source.location(span),
        format!("malformed {lang}: {first}"),
        format!("fix the {lang} syntax at this position"),
    )
}

fn parse_toml(source: &SourceFile) -> Result<Node, InputError> {
    crate::toml_reader::parse(source)
}

/// YAML 1.2 core schema resolution of a plain scalar.
fn resolve_plain(s: &str) -> Result<NodeKind, ()> {
    match s {
        "" | "~" | "null" | "Null" | "NULL" => return Ok(NodeKind::Null),
        "true" | "True" | "TRUE" => return Ok(NodeKind::Bool(true)),
        "false" | "False" | "FALSE" => return Ok(NodeKind::Bool(false)),
        ".nan" | ".NaN" | ".NAN" => return Err(()),
        _ => {}
    }
    let body = s.strip_prefix(['-', '+']).unwrap_or(s);
    if matches!(body, ".inf" | ".Inf" | ".INF") {
        return Err(());
    }
    let is_hex = s
        .strip_prefix("0x")
        .is_some_and(|h| !h.is_empty() && h.bytes().all(|b| b.is_ascii_hexdigit()));
    let is_oct = s
        .strip_prefix("0o")
        .is_some_and(|h| !h.is_empty() && h.bytes().all(|b| (b'0'..=b'7').contains(&b)));
    if is_hex || is_oct || is_yaml_float(body) {
        return Ok(NodeKind::Num(s.to_string()));
    }
    Ok(NodeKind::Str(s.to_string()))
}

/// `(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?` (sign already stripped).
fn is_yaml_float(s: &str) -> bool {
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    };
    let mant_ok = match mant.split_once('.') {
        Some((i, f)) => {
            i.bytes().all(|b| b.is_ascii_digit())
                && f.bytes().all(|b| b.is_ascii_digit())
                && (!i.is_empty() || !f.is_empty())
        }
        None => !mant.is_empty() && mant.bytes().all(|b| b.is_ascii_digit()),
    };
    let exp_ok = exp.is_none_or(|e| {
        let e = e.strip_prefix(['-', '+']).unwrap_or(e);
        !e.is_empty() && e.bytes().all(|b| b.is_ascii_digit())
    });
    mant_ok && exp_ok
}

enum Frame {
    Map {
        start: usize,
        entries: Vec<Entry>,
        key: Option<(String, Range<usize>)>,
    },
    Seq {
        start: usize,
        items: Vec<Node>,
    },
}

fn parse_yaml(source: &SourceFile) -> Result<Node, InputError> {
    use saphyr_parser::{Event, Parser, ScalarStyle};
    let text: &str = &source.text;
    let mut parser = Parser::new_from_str(text);
    let mut stack: Vec<Frame> = Vec::new();
    let mut root: Option<Node> = None;
    let mut documents = 0usize;
    let structure = |span: Range<usize>, msg: &str, help: &str| {
        InputError::new(InputErrorKind::Structure, source.location(span), msg, help)
    };
    while let Some(ev) = parser.next_event() {
        let (event, span) = ev.map_err(|e| {
            let m = e.marker();
            let at = source.offset_of(m.line(), m.col());
            syntax_error(source, at..at, e.info(), "YAML")
        })?;
        let start = source.offset_of(span.start.line(), span.start.col());
        let end = source.offset_of(span.end.line(), span.end.col()).max(start);
        let node = match event {
            Event::StreamStart | Event::StreamEnd | Event::Nothing | Event::DocumentEnd => continue,
            Event::DocumentStart(_) => {
                documents += 1;
                if documents > 1 {
                    return Err(structure(
                        start..end,
                        "more than one YAML document in the file",
                        "keep one set per file",
                    ));
                }
                continue;
            }
            Event::Alias(_) => {
                return Err(structure(
                    start..end,
                    "YAML aliases are not supported",
                    "write the value out in full",
                ));
            }
            Event::Scalar(value, style, _anchor, tag) => {
                if tag.is_some() {
                    return Err(structure(
                        start..end,
                        "YAML tags are not supported",
                        "remove the `!tag`",
                    ));
                }
                let kind = match style {
                    ScalarStyle::Plain => resolve_plain(&value).map_err(|()| {
                        structure(
                            start..end,
                            &format!("`{value}` is not a finite number"),
                            "give a decimal number; NaN and infinity are not parameter values",
                        )
                    })?,
                    _ => NodeKind::Str(value.to_string()),
                };
                Node {
                    kind,
                    span: start..end,
                }
            }
            Event::SequenceStart(_, tag) | Event::MappingStart(_, tag) if tag.is_some() => {
                return Err(structure(
                    start..end,
                    "YAML tags are not supported",
                    "remove the `!tag`",
                ));
            }
            Event::SequenceStart(..) | Event::MappingStart(..) => {
                if stack.len() >= MAX_DEPTH {
                    return Err(structure(
                        start..end,
                        &format!("nesting deeper than {MAX_DEPTH} levels"),
                        "driveset files are flat; remove the nesting",
                    ));
                }
                if let Some(Frame::Map { key: None, .. }) = stack.last() {
                    return Err(structure(
                        start..end,
                        "a mapping key must be a plain value",
                        "use a simple key such as `C0011`",
                    ));
                }
                stack.push(if matches!(event, Event::SequenceStart(..)) {
                    Frame::Seq {
                        start,
                        items: Vec::new(),
                    }
                } else {
                    Frame::Map {
                        start,
                        entries: Vec::new(),
                        key: None,
                    }
                });
                continue;
            }
            Event::SequenceEnd | Event::MappingEnd => match stack.pop() {
                Some(Frame::Seq { start, items }) => Node {
                    kind: NodeKind::Array(items),
                    span: start..end.max(start),
                },
                Some(Frame::Map { start, entries, .. }) => Node {
                    kind: NodeKind::Table(entries),
                    span: start..end.max(start),
                },
                None => {
                    return Err(structure(
                        start..end,
                        "unbalanced YAML structure",
                        "check the indentation",
                    ));
                }
            },
        };
        // attach the finished node to its parent
        match stack.last_mut() {
            None => root = Some(node),
            Some(Frame::Seq { items, .. }) => items.push(node),
            Some(Frame::Map { entries, key, .. }) => match key.take() {
                None => {
                    let k = match node.kind {
                        NodeKind::Str(s) | NodeKind::Num(s) => s,
                        NodeKind::Bool(b) => b.to_string(),
                        NodeKind::Null => String::new(),
                        _ => {
                            return Err(structure(
                                node.span,
                                "a mapping key must be a plain value",
                                "use a simple key such as `C0011`",
                            ));
                        }
                    };
                    *key = Some((k, node.span));
                }
                Some((k, key_span)) => entries.push(Entry {
                    key: k,
                    key_span,
                    value: node,
                }),
            },
        }
    }
    root.ok_or_else(|| structure(0..0, "the YAML file holds no document", "add `schema: ...`"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toml(s: &str) -> Document {
        parse(SourceFile::new("t.toml", s), Syntax::Toml).unwrap()
    }
    fn yaml(s: &str) -> Document {
        parse(SourceFile::new("t.yaml", s), Syntax::Yaml).unwrap()
    }

    #[test]
    fn toml_keeps_literal_numbers_and_positions() {
        let d = toml("schema = \"x\"\n[values]\nC0011 = 0.1\nC0012 = 1_000\nC0068 = 0x0900\n");
        let values = &d.root.get("values").unwrap().value;
        let e = &values.entries()[0];
        assert_eq!(e.key, "C0011");
        assert_eq!(e.value.kind, NodeKind::Num("0.1".into()));
        let loc = d.loc(&e.value.span);
        assert_eq!((loc.line, loc.column), (3, 9));
        assert_eq!(
            values.entries()[1].value.kind,
            NodeKind::Num("1_000".into())
        );
        assert_eq!(
            values.entries()[2].value.kind,
            NodeKind::Num("0x0900".into())
        );
        let kl = d.loc(&values.entries()[2].key_span);
        assert_eq!((kl.line, kl.column), (5, 1));
    }

    #[test]
    fn toml_rejects_nan_and_syntax() {
        let e = parse(SourceFile::new("t.toml", "a = nan\n"), Syntax::Toml).unwrap_err();
        assert_eq!(e.message, "`nan` is not a finite number");
        assert_eq!((e.location.line, e.location.column), (1, 5));
        let e = parse(SourceFile::new("t.toml", "a = \n"), Syntax::Toml).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::Syntax);
        assert_eq!(e.location.line, 1);
    }

    #[test]
    fn yaml_core_schema_and_positions() {
        let d = yaml(
            "schema: x\nvalues:\n  C0011: 0.1\n  C0012: \"0.1\"\n  C0013: true\n  C0014: 0x10\n  C0015: abc\n",
        );
        let v = &d.root.get("values").unwrap().value;
        let kinds: Vec<_> = v.entries().iter().map(|e| e.value.kind.clone()).collect();
        assert_eq!(
            kinds,
            vec![
                NodeKind::Num("0.1".into()),
                NodeKind::Str("0.1".into()),
                NodeKind::Bool(true),
                NodeKind::Num("0x10".into()),
                NodeKind::Str("abc".into()),
            ]
        );
        let e = &v.entries()[0];
        let (kl, vl) = (d.loc(&e.key_span), d.loc(&e.value.span));
        assert_eq!((kl.line, kl.column, vl.line, vl.column), (3, 3, 3, 10));
        assert_eq!(vl.line_text, "  C0011: 0.1");
    }

    #[test]
    fn yaml_refuses_alias_nan_and_multi_docs() {
        for (src, msg) in [
            ("a: &x 1\nb: *x\n", "YAML aliases are not supported"),
            ("a: .nan\n", "`.nan` is not a finite number"),
            (
                "a: 1\n---\nb: 2\n",
                "more than one YAML document in the file",
            ),
        ] {
            let e = parse(SourceFile::new("t.yaml", src), Syntax::Yaml).unwrap_err();
            assert_eq!(e.message, msg);
        }
        let e = parse(SourceFile::new("t.yaml", "a: [1\n"), Syntax::Yaml).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::Syntax);
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let deep = format!("a = {}{}\n", "[".repeat(5000), "]".repeat(5000));
        assert!(parse(SourceFile::new("t.toml", deep), Syntax::Toml).is_err());
        let deep = format!("a: {}{}\n", "[".repeat(5000), "]".repeat(5000));
        assert!(parse(SourceFile::new("t.yaml", deep), Syntax::Yaml).is_err());
    }
}
