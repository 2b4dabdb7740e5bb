//! Owns what the editor offers at a place of a set file: hover (a code's
//! facts), go to a code's entry in its schema file (a built-in schema's
//! as a read-only copy in a cache directory), and completion of
//! `[values]` keys, a code's selection texts or default, and schema ids
//! (docs/editors.md). Places are byte offsets into the text; the language
//! server turns them into its positions.

use std::ops::Range;
use std::path::{Path, PathBuf};

use driveset_schema::doc::{Document, Entry, Node, NodeKind, Syntax};
use driveset_schema::error::SourceFile;
use driveset_schema::schema::{BUILTIN_FILES, Code};
use driveset_schema::{Location, Registry, Schema};

use crate::analysis::{quoted, values_entry};
use crate::facts;

/// A code's facts at the key it is written with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Hover {
    /// The facts as markdown (a subcode's say so).
    pub markdown: String,
    /// The key's byte span.
    pub span: Range<usize>,
}

/// The facts of the code whose `[values]` entry holds byte `offset`.
pub fn hover(schema: &Schema, parsed: &Document, offset: usize) -> Option<Hover> {
    let e = values_entry(parsed, offset)?;
    let (code, k) = driveset_schema::set::code_of_key(schema, parsed, e)?;
    let mut markdown = facts::markdown(schema, code);
    if let Some(s) = k.subcode {
        markdown = format!("subcode {s} of {markdown}");
    }
    Some(Hover {
        markdown,
        span: e.key_span.clone(),
    })
}

/// Where the schema defines the code whose `[values]` entry holds byte
/// `offset` (its schema file, line and column; a built-in schema's file
/// is named as the binary holds it).
pub fn definition<'s>(
    schema: &'s Schema,
    parsed: &Document,
    offset: usize,
) -> Option<&'s Location> {
    let e = values_entry(parsed, offset)?;
    let (code, _) = driveset_schema::set::code_of_key(schema, parsed, e)?;
    Some(&code.loc)
}

/// The file a schema's locations name ([`definition`]), to open: a loaded
/// schema file as it is (made absolute), a built-in one as a read-only copy
/// under `cache_dir` (the binary holds its text, not its path), written
/// through the one writer when it is missing or differs (docs/editors.md).
pub fn schema_file(file: &str, cache_dir: &Path) -> Option<PathBuf> {
    if let Some((path, text)) = BUILTIN_FILES.iter().find(|(p, _)| *p == file) {
        let copy = cache_dir.join(path);
        let held =
            driveset_schema::input::read_input(&copy, driveset_schema::input::InputKind::SET);
        if held.ok().as_deref() != Some(text.as_bytes()) {
            std::fs::create_dir_all(copy.parent()?).ok()?;
            if let Ok(m) = std::fs::metadata(&copy) {
                let mut p = m.permissions();
                #[allow(clippy::permissions_set_readonly_false)]
                p.set_readonly(false);
                let _ = std::fs::set_permissions(&copy, p);
            }
            driveset_schema::output::write_output(&copy, text.as_bytes()).ok()?;
            let mut p = std::fs::metadata(&copy).ok()?.permissions();
            p.set_readonly(true);
            std::fs::set_permissions(&copy, p).ok()?;
        }
        return Some(copy);
    }
    std::path::absolute(file).ok()
}

/// What a completion offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompletionKind {
    /// A `[values]` key.
    Field,
    /// A selection text.
    EnumMember,
    /// A code's default.
    Value,
    /// A schema id.
    Module,
}

/// How a completion goes into the text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Insert {
    /// This text at the cursor.
    Text(String),
    /// This text in place of the bytes from `start` to the cursor.
    Replace {
        /// The first byte replaced.
        start: usize,
        /// The new text.
        text: String,
    },
}

/// One completion.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Completion {
    /// What the list shows.
    pub label: String,
    /// What it is.
    pub kind: CompletionKind,
    /// The line beside it.
    pub detail: Option<String>,
    /// What the typed text is matched with, when not the label.
    pub filter_text: Option<String>,
    /// The code a key completes (its facts are filled in on request).
    pub code: Option<u32>,
    /// What goes into the text.
    pub insert: Insert,
}

/// Where the cursor is: its line (0-based), the byte offset where that
/// line starts and the cursor's byte offset (the server's positions,
/// clamped to the text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cursor {
    /// The line.
    pub line: usize,
    /// Its first byte.
    pub line_start: usize,
    /// The cursor's byte.
    pub offset: usize,
}

/// Completion at `at` in `text` (a set file of `syntax`): `[values]` keys
/// and values with the set's `schema`, the schema ids of `registry` after
/// `schema =`.
pub fn complete(
    text: &str,
    at: Cursor,
    syntax: Syntax,
    schema: Option<&Schema>,
    registry: &Registry,
) -> Option<Vec<Completion>> {
    let lines: Vec<&str> = text.split('\n').collect();
    let line = lines.get(at.line).copied().unwrap_or("");
    let line_start = at.line_start;
    let cursor = at.offset.saturating_sub(line_start).min(line.len());
    let prefix = &line[..cursor];
    let section = section_of(&lines, at.line, syntax);
    let sep = match syntax {
        Syntax::Toml => prefix.find('='),
        Syntax::Yaml => prefix
            .find(": ")
            .or_else(|| prefix.strip_suffix(':').map(str::len)),
    };
    match (section.as_deref(), sep) {
        (Some("values"), Some(i)) => {
            let schema = schema?;
            let key_text = prefix[..i].trim().trim_matches(['"', '\'']);
            let value_start = i
                + 1
                + prefix[i + 1..]
                    .find(|c: char| !c.is_whitespace())
                    .unwrap_or(prefix.len() - i - 1);
            Some(value_items(
                schema,
                key_text,
                line_start + value_start.min(cursor),
            ))
        }
        (Some("values"), None) => {
            let schema = schema?;
            let word_start = prefix
                .rfind(|c: char| c.is_whitespace() || c == '"')
                .map_or(0, |i| i + 1);
            Some(key_items(schema, syntax, line_start + word_start))
        }
        (None, Some(i)) if prefix[..i].trim() == "schema" => {
            let mut ids: Vec<&str> = registry.schemas().map(|s| s.id.as_str()).collect();
            ids.sort_unstable();
            Some(
                ids.into_iter()
                    .map(|id| Completion {
                        label: id.to_string(),
                        kind: CompletionKind::Module,
                        detail: None,
                        filter_text: None,
                        code: None,
                        insert: Insert::Text(match syntax {
                            Syntax::Toml => quoted(id),
                            Syntax::Yaml => id.to_string(),
                        }),
                    })
                    .collect(),
            )
        }
        _ => None,
    }
}

/// The top-level table line `line` is in: TOML `[values]` -> `values`,
/// YAML an indented line under `values:`; `None` at the top level.
fn section_of(lines: &[&str], line: usize, syntax: Syntax) -> Option<String> {
    let text_line = |i: usize| lines.get(i).copied().unwrap_or("");
    match syntax {
        Syntax::Toml => (0..=line).rev().find_map(|i| {
            let l = text_line(i).trim();
            let h = l.strip_prefix('[')?.trim_start_matches('[');
            Some(h.split(']').next().unwrap_or("").trim().to_string())
        }),
        Syntax::Yaml => {
            let here = text_line(line);
            if !here.starts_with([' ', '\t']) {
                return None;
            }
            (0..line).rev().find_map(|i| {
                let l = text_line(i);
                let t = l.trim();
                if t.is_empty() || t.starts_with('#') || l.starts_with([' ', '\t']) {
                    return None;
                }
                Some(t.split(':').next().unwrap_or("").trim().to_string())
            })
        }
    }
}

/// Completion of `[values]` keys: every code a set may write, by its
/// canonical key and its name (subcodes as `KEY/N`), from byte `start`.
fn key_items(schema: &Schema, syntax: Syntax, start: usize) -> Vec<Completion> {
    let mut out = Vec::new();
    for code in &schema.codes {
        if facts::refused(schema, code).is_some() {
            continue;
        }
        let named = facts::named_keys(schema, code);
        let keys: Vec<String> = match code.subcodes {
            None => named.into_iter().take(2).collect(),
            Some(n) => (1..=n).map(|s| format!("{}/{s}", named[0])).collect(),
        };
        let detail = code.title.clone();
        for k in keys {
            let quoted_key = k.contains('/') && syntax == Syntax::Toml;
            let insert = match syntax {
                Syntax::Toml if quoted_key => format!("{} = ", quoted(&k)),
                Syntax::Toml => format!("{k} = "),
                Syntax::Yaml => format!("{k}: "),
            };
            out.push(Completion {
                label: k.clone(),
                kind: CompletionKind::Field,
                detail: detail.clone(),
                filter_text: None,
                code: Some(code.number),
                insert: Insert::Replace {
                    start,
                    text: insert,
                },
            });
        }
    }
    out
}

/// Completion of a value from byte `start`: the code's selection texts
/// (quoted), or its default.
fn value_items(schema: &Schema, key: &str, start: usize) -> Vec<Completion> {
    let Some(code) = code_of_key_text(schema, key) else {
        return Vec::new();
    };
    let mut out: Vec<Completion> = facts::labels(schema, code)
        .into_iter()
        .map(|(v, label)| Completion {
            label: label.to_string(),
            kind: CompletionKind::EnumMember,
            detail: Some(format!("{} = {v}", schema.display_code(code.number, None))),
            filter_text: Some(quoted(label)),
            code: None,
            insert: Insert::Replace {
                start,
                text: quoted(label),
            },
        })
        .collect();
    if out.is_empty()
        && let Some(d) = facts::default_text(schema, code)
        && !schema.is_password(code)
        && code.bits.is_empty()
    {
        let text = if d.starts_with('"') || driveset_schema::Decimal::parse(&d).is_ok() {
            d.clone()
        } else {
            quoted(&d)
        };
        out.push(Completion {
            label: d,
            kind: CompletionKind::Value,
            detail: Some("default".into()),
            filter_text: None,
            code: None,
            insert: Insert::Replace { start, text },
        });
    }
    out
}

/// The code a key written on a line names (the set reader's resolution).
fn code_of_key_text<'s>(schema: &'s Schema, key: &str) -> Option<&'s Code> {
    let doc = Document {
        source: SourceFile::new("<key>", key.to_string()),
        root: Node {
            kind: NodeKind::Table(Vec::new()),
            span: 0..0,
        },
    };
    let entry = Entry {
        key: key.to_string(),
        key_span: 0..key.len(),
        value: Node {
            kind: NodeKind::Null,
            span: 0..0,
        },
    };
    driveset_schema::set::code_of_key(schema, &doc, &entry).map(|(c, _)| c)
}
