//! Owns reading TOML into the spanned [`Node`] tree straight from the
//! `toml_parser` event stream (lexer + parser of the `toml` crate), without
//! building `toml`'s sorted key maps first: keys stay in file order, numbers
//! keep their literal text, and the tree is built once (the hot path of
//! validating many sets).
//!
//! TOML semantics applied: `[table]` and `[[array.of.tables]]` headers,
//! dotted keys, inline tables and arrays; a key defined twice, a table
//! defined twice and appending to a value that is not a table are
//! "duplicate key" errors, as in the `toml` crate.

use std::borrow::Cow;
use std::ops::Range;

use toml_parser::decoder::ScalarKind;
use toml_parser::parser::{Event, EventKind, RecursionGuard, ValidateWhitespace};
use toml_parser::{ParseError, Raw, Source};

use crate::doc::{Entry, MAX_DEPTH, Node, NodeKind};
use crate::error::{InputError, InputErrorKind, SourceFile};
use crate::fnv::{FnvMap, hash_str};

/// Tables with more entries than this get a hash index for duplicate checks.
const INDEX_FROM: usize = 12;

#[derive(Clone, Copy, PartialEq, Eq)]
enum TKind {
    /// The document root.
    Root,
    /// Defined by a `[header]`.
    Header,
    /// Created on the way to a deeper header (`[a.b]` creates `a`).
    Implicit,
    /// Created by a dotted key (`a.b = 1` creates `a`).
    Dotted,
    /// `{ ... }`: closed.
    Inline,
}

struct Tbl {
    entries: Vec<BEntry>,
    /// hash of a key -> index of the first entry with that hash
    index: Option<FnvMap<u64, usize>>,
    span: Range<usize>,
    kind: TKind,
}

struct BEntry {
    key: String,
    key_span: Range<usize>,
    val: BVal,
}

enum BVal {
    Leaf(NodeKind, Range<usize>),
    Table(Tbl),
    /// Items, span, whether it is an array of tables (`[[x]]`).
    Array(Vec<BVal>, Range<usize>, bool),
}

impl Tbl {
    fn new(kind: TKind, span: Range<usize>) -> Self {
        Tbl {
            entries: Vec::new(),
            index: None,
            span,
            kind,
        }
    }

    fn find(&self, key: &str) -> Option<usize> {
        match &self.index {
            Some(ix) => {
                let i = *ix.get(&hash_str(key))?;
                if self.entries.get(i).is_some_and(|e| e.key == key) {
                    Some(i)
                } else {
                    // a hash collision: look at every entry
                    self.entries.iter().position(|e| e.key == key)
                }
            }
            None => self.entries.iter().position(|e| e.key == key),
        }
    }

    fn push(&mut self, key: String, key_span: Range<usize>, val: BVal) -> usize {
        let i = self.entries.len();
        if let Some(ix) = &mut self.index {
            ix.entry(hash_str(&key)).or_insert(i);
        } else if i + 1 > INDEX_FROM {
            let mut ix: FnvMap<u64, usize> = FnvMap::default();
            ix.reserve(256);
            for (j, e) in self.entries.iter().enumerate() {
                ix.entry(hash_str(&e.key)).or_insert(j);
            }
            ix.entry(hash_str(&key)).or_insert(i);
            self.index = Some(ix);
        }
        self.entries.push(BEntry { key, key_span, val });
        i
    }
}

impl BVal {
    fn into_node(self) -> Node {
        match self {
            BVal::Leaf(kind, span) => Node { kind, span },
            BVal::Table(t) => t.into_node(),
            BVal::Array(items, span, _) => Node {
                kind: NodeKind::Array(items.into_iter().map(BVal::into_node).collect()),
                span,
            },
        }
    }
}

impl Tbl {
    fn into_node(self) -> Node {
        Node {
            kind: NodeKind::Table(
                self.entries
                    .into_iter()
                    .map(|e| Entry {
                        key: e.key,
                        key_span: e.key_span,
                        value: e.val.into_node(),
                    })
                    .collect(),
            ),
            span: self.span,
        }
    }
}

fn range(ev: &Event) -> Range<usize> {
    ev.span().start()..ev.span().end()
}

/// A TOML parse error as toml renders it: description, `expected ...`.
fn render_parse_error(e: &ParseError) -> (String, Range<usize>) {
    let mut m = e.description().to_string();
    if let Some(expected) = e.expected() {
        m.push_str(", expected ");
        if expected.is_empty() {
            m.push_str("nothing");
        }
        for (i, x) in expected.iter().enumerate() {
            if i != 0 {
                m.push_str(", ");
            }
            match x {
                toml_parser::Expected::Literal(d) => match *d {
                    "\n" => m.push_str("newline"),
                    "`" => m.push_str("'`'"),
                    s if s.chars().all(|c| c.is_ascii_control()) => {
                        m.push_str(&format!("`{}`", s.escape_debug()));
                    }
                    s => m.push_str(&format!("`{s}`")),
                },
                toml_parser::Expected::Description(d) => m.push_str(d),
                _ => m.push_str("etc"),
            }
        }
    }
    let span = e
        .unexpected()
        .or(e.context())
        .map(|s| s.start()..s.end())
        .unwrap_or(0..0);
    (m, span)
}

/// One key part and its span.
type Part = (String, Range<usize>);

/// `a.b.c`: `a`, then `[b, c]`.
struct KeyPath {
    head: Part,
    rest: Vec<Part>,
}

impl KeyPath {
    /// (the parts before the last, the last part)
    fn split(self) -> (Vec<Part>, Part) {
        let KeyPath { head, mut rest } = self;
        match rest.pop() {
            None => (Vec::new(), head),
            Some(last) => {
                rest.insert(0, head);
                (rest, last)
            }
        }
    }
}

struct Builder<'a> {
    text: &'a str,
    source: &'a SourceFile,
    events: &'a [Event],
    pos: usize,
    err: Option<ParseError>,
    buf: Cow<'a, str>,
}

type R<T> = Result<T, InputError>;

impl<'a> Builder<'a> {
    fn syntax(&self, span: Range<usize>, msg: &str) -> InputError {
        InputError::new(
            InputErrorKind::Syntax,
            self.source.location(span),
            format!("malformed TOML: {msg}"),
            "fix the TOML syntax at this position",
        )
    }

    fn structure(&self, span: Range<usize>, msg: String, help: &str) -> InputError {
        InputError::new(
            InputErrorKind::Structure,
            self.source.location(span),
            msg,
            help,
        )
    }

    fn check_decode(&mut self) -> R<()> {
        match self.err.take() {
            None => Ok(()),
            Some(e) => {
                let (m, span) = render_parse_error(&e);
                Err(self.syntax(span, &m))
            }
        }
    }

    fn next(&mut self) -> Option<&'a Event> {
        let e = self.events.get(self.pos)?;
        self.pos += 1;
        Some(e)
    }

    fn peek_kind(&self) -> Option<EventKind> {
        self.events.get(self.pos).map(Event::kind)
    }

    fn skip_trivia(&mut self) {
        while matches!(
            self.peek_kind(),
            Some(EventKind::Whitespace | EventKind::Comment | EventKind::Newline)
        ) {
            self.pos += 1;
        }
    }

    fn raw(&self, ev: &Event) -> Raw<'a> {
        let s = ev.span();
        Raw::new_unchecked(
            self.text.get(s.start()..s.end()).unwrap_or(""),
            ev.encoding(),
            s,
        )
    }

    fn decode_key(&mut self, ev: &Event) -> R<String> {
        let raw = self.raw(ev);
        self.buf = Cow::Borrowed("");
        raw.decode_key(&mut self.buf, &mut self.err);
        self.check_decode()?;
        Ok(std::mem::take(&mut self.buf).into_owned())
    }

    /// A key path starting at the SimpleKey `first`: the first part, then any
    /// dotted parts (no allocation for the common plain key).
    fn key_path(&mut self, first: &'a Event) -> R<KeyPath> {
        let head = (self.decode_key(first)?, range(first));
        let mut rest = Vec::new();
        loop {
            let save = self.pos;
            while self.peek_kind() == Some(EventKind::Whitespace) {
                self.pos += 1;
            }
            if self.peek_kind() != Some(EventKind::KeySep) {
                self.pos = save;
                return Ok(KeyPath { head, rest });
            }
            self.pos += 1;
            while self.peek_kind() == Some(EventKind::Whitespace) {
                self.pos += 1;
            }
            match self.next() {
                Some(ev) if ev.kind() == EventKind::SimpleKey => {
                    rest.push((self.decode_key(ev)?, range(ev)));
                }
                Some(ev) => return Err(self.syntax(range(ev), "expected a key")),
                None => return Err(self.syntax(self.text.len()..self.text.len(), "expected a key")),
            }
        }
    }

    fn scalar(&mut self, ev: &Event) -> R<BVal> {
        let raw = self.raw(ev);
        let span = range(ev);
        self.buf = Cow::Borrowed("");
        let kind = raw.decode_scalar(&mut self.buf, &mut self.err);
        self.check_decode()?;
        let literal = || raw.as_str().to_string();
        let node = match kind {
            ScalarKind::String => NodeKind::Str(std::mem::take(&mut self.buf).into_owned()),
            ScalarKind::Boolean(b) => NodeKind::Bool(b),
            ScalarKind::DateTime => NodeKind::Datetime,
            ScalarKind::Integer(_) => NodeKind::Num(literal()),
            ScalarKind::Float => {
                let lit = literal();
                if lit.contains("inf") || lit.contains("nan") {
                    return Err(self.structure(
                        span,
                        format!("`{lit}` is not a finite number"),
                        "give a decimal number; NaN and infinity are not parameter values",
                    ));
                }
                NodeKind::Num(lit)
            }
        };
        Ok(BVal::Leaf(node, span))
    }

    fn depth_error(&self, span: Range<usize>) -> InputError {
        self.structure(
            span,
            format!("nesting deeper than {MAX_DEPTH} levels"),
            "driveset files are flat; remove the nesting",
        )
    }

    /// A value after `=` (or in an array).
    fn value(&mut self, depth: usize) -> R<BVal> {
        self.skip_trivia();
        let Some(ev) = self.next() else {
            let end = self.text.len();
            return Err(self.syntax(end..end, "expected a value"));
        };
        match ev.kind() {
            EventKind::Scalar => self.scalar(ev),
            EventKind::ArrayOpen => {
                if depth >= MAX_DEPTH {
                    return Err(self.depth_error(range(ev)));
                }
                let start = ev.span().start();
                let mut items = Vec::new();
                loop {
                    self.skip_trivia();
                    match self.peek_kind() {
                        Some(EventKind::ArrayClose) => {
                            let close = self.next().map(range).unwrap_or(start..start);
                            return Ok(BVal::Array(items, start..close.end, false));
                        }
                        Some(EventKind::ValueSep) => {
                            self.pos += 1;
                        }
                        None => {
                            return Err(self.syntax(start..start + 1, "unclosed array"));
                        }
                        Some(_) => items.push(self.value(depth + 1)?),
                    }
                }
            }
            EventKind::InlineTableOpen => {
                if depth >= MAX_DEPTH {
                    return Err(self.depth_error(range(ev)));
                }
                let start = ev.span().start();
                let mut t = Tbl::new(TKind::Inline, start..start);
                loop {
                    self.skip_trivia();
                    let Some(k) = self.next() else {
                        return Err(self.syntax(start..start + 1, "unclosed inline table"));
                    };
                    match k.kind() {
                        EventKind::InlineTableClose => {
                            t.span = start..k.span().end();
                            return Ok(BVal::Table(t));
                        }
                        EventKind::ValueSep => {}
                        EventKind::SimpleKey => {
                            let path = self.key_path(k)?;
                            self.expect_key_val_sep()?;
                            let v = self.value(depth + 1)?;
                            self.insert_dotted(&mut t, path, v)?;
                        }
                        _ => return Err(self.syntax(range(k), "expected a key")),
                    }
                }
            }
            _ => Err(self.syntax(range(ev), "expected a value")),
        }
    }

    fn expect_key_val_sep(&mut self) -> R<()> {
        while self.peek_kind() == Some(EventKind::Whitespace) {
            self.pos += 1;
        }
        match self.next() {
            Some(ev) if ev.kind() == EventKind::KeyValSep => Ok(()),
            Some(ev) => Err(self.syntax(range(ev), "expected `=`")),
            None => Err(self.syntax(self.text.len()..self.text.len(), "expected `=`")),
        }
    }

    fn duplicate(&self, span: Range<usize>) -> InputError {
        self.syntax(span, "duplicate key")
    }

    /// Insert `a.b.c = v` into `t`: `a`, `b` become dotted tables.
    fn insert_dotted(&self, t: &mut Tbl, path: KeyPath, v: BVal) -> R<()> {
        let (path, (last, last_span)) = path.split();
        let mut cur = t;
        for (k, span) in path {
            let i = match cur.find(&k) {
                Some(i) => i,
                None => cur.push(
                    k,
                    span.clone(),
                    BVal::Table(Tbl::new(TKind::Dotted, span.clone())),
                ),
            };
            cur = match cur.entries.get_mut(i).map(|e| &mut e.val) {
                Some(BVal::Table(sub)) if sub.kind == TKind::Dotted => sub,
                _ => return Err(self.duplicate(span)),
            };
        }
        // a big table: one hash for the lookup and the index entry
        if let Some(ix) = &mut cur.index {
            let i = cur.entries.len();
            let existing = *ix.entry(hash_str(&last)).or_insert(i);
            if existing != i
                && (cur.entries.get(existing).is_some_and(|e| e.key == last)
                    || cur.entries.iter().any(|e| e.key == last))
            {
                return Err(self.duplicate(last_span));
            }
            cur.entries.push(BEntry {
                key: last,
                key_span: last_span,
                val: v,
            });
            return Ok(());
        }
        if cur.find(&last).is_some() {
            return Err(self.duplicate(last_span));
        }
        cur.push(last, last_span, v);
        Ok(())
    }

    /// Walk a header path from the root, creating implicit tables; returns
    /// the table that holds the last key.
    fn descend<'t>(&self, root: &'t mut Tbl, path: &[(String, Range<usize>)]) -> R<&'t mut Tbl> {
        let mut cur = root;
        for (k, span) in path {
            let i = match cur.find(k) {
                Some(i) => i,
                None => cur.push(
                    k.clone(),
                    span.clone(),
                    BVal::Table(Tbl::new(TKind::Implicit, span.clone())),
                ),
            };
            cur = match cur.entries.get_mut(i).map(|e| &mut e.val) {
                Some(BVal::Table(sub)) if sub.kind != TKind::Inline => sub,
                Some(BVal::Array(items, _, true)) => match items.last_mut() {
                    Some(BVal::Table(sub)) => sub,
                    _ => return Err(self.duplicate(span.clone())),
                },
                _ => return Err(self.duplicate(span.clone())),
            };
        }
        Ok(cur)
    }

    fn document(&mut self) -> R<Tbl> {
        let mut root = Tbl::new(TKind::Root, 0..0);
        // path of the current table's header (empty: the root)
        let mut current: Vec<(String, Range<usize>)> = Vec::new();
        while let Some(ev) = self.next() {
            match ev.kind() {
                EventKind::Whitespace | EventKind::Comment | EventKind::Newline => {}
                EventKind::StdTableOpen | EventKind::ArrayTableOpen => {
                    let is_array = ev.kind() == EventKind::ArrayTableOpen;
                    let start = ev.span().start();
                    while self.peek_kind() == Some(EventKind::Whitespace) {
                        self.pos += 1;
                    }
                    let Some(k) = self.next().filter(|k| k.kind() == EventKind::SimpleKey) else {
                        return Err(self.syntax(start..start + 1, "expected a table name"));
                    };
                    let (mut path, (last, last_span)) = self.key_path(k)?.split();
                    while self.peek_kind() == Some(EventKind::Whitespace) {
                        self.pos += 1;
                    }
                    let end = match self.next() {
                        Some(c)
                            if matches!(
                                c.kind(),
                                EventKind::StdTableClose | EventKind::ArrayTableClose
                            ) =>
                        {
                            c.span().end()
                        }
                        _ => return Err(self.syntax(start..start + 1, "unclosed table header")),
                    };
                    let header = start..end;
                    let parent = self.descend(&mut root, &path)?;
                    match (parent.find(&last), is_array) {
                        (None, false) => {
                            parent.push(
                                last.clone(),
                                last_span.clone(),
                                BVal::Table(Tbl::new(TKind::Header, header)),
                            );
                        }
                        (None, true) => {
                            parent.push(
                                last.clone(),
                                last_span.clone(),
                                BVal::Array(
                                    vec![BVal::Table(Tbl::new(TKind::Header, header.clone()))],
                                    header,
                                    true,
                                ),
                            );
                        }
                        (Some(i), false) => match parent.entries.get_mut(i) {
                            Some(BEntry {
                                key_span,
                                val: BVal::Table(t),
                                ..
                            }) if t.kind == TKind::Implicit => {
                                // now defined here: point at this header, as toml does
                                *key_span = last_span.clone();
                                t.kind = TKind::Header;
                                t.span = header;
                            }
                            _ => return Err(self.duplicate(last_span)),
                        },
                        (Some(i), true) => match parent.entries.get_mut(i).map(|e| &mut e.val) {
                            Some(BVal::Array(items, _, true)) => {
                                items.push(BVal::Table(Tbl::new(TKind::Header, header)));
                            }
                            _ => return Err(self.duplicate(last_span)),
                        },
                    }
                    path.push((last, last_span));
                    current = path;
                }
                EventKind::SimpleKey => {
                    let path = self.key_path(ev)?;
                    self.expect_key_val_sep()?;
                    let v = self.value(1)?;
                    let table = self.descend(&mut root, &current)?;
                    self.insert_dotted(table, path, v)?;
                }
                _ => return Err(self.syntax(range(ev), "unexpected token")),
            }
        }
        Ok(root)
    }
}

/// Parse TOML text into a root table node (span 0..0, as before).
pub(crate) fn parse(source: &SourceFile) -> Result<Node, InputError> {
    let text: &str = &source.text;
    let src = Source::new(text);
    let mut tokens = Vec::with_capacity(text.len() / 3 + 16);
    tokens.extend(src.lex());
    let mut events: Vec<Event> = Vec::with_capacity(tokens.len());
    let mut err: Option<ParseError> = None;
    {
        let mut ws = ValidateWhitespace::new(&mut events, src);
        let mut guard = RecursionGuard::new(&mut ws, MAX_DEPTH as u32);
        toml_parser::parser::parse_document(&tokens, &mut guard, &mut err);
    }
    drop(tokens);
    let mut b = Builder {
        text,
        source,
        events: &events,
        pos: 0,
        err,
        buf: Cow::Borrowed(""),
    };
    b.check_decode()?;
    let root = b.document()?;
    Ok(root.into_node())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tree the `toml` crate's own parser gives (entries sorted by key position).
    fn via_toml(text: &str) -> Result<Node, String> {
        use toml::de::{DeTable, DeValue};
        fn conv(v: &DeValue<'_>, span: Range<usize>, text: &str) -> Node {
            let kind = match v {
                DeValue::String(s) => NodeKind::Str(s.to_string()),
                DeValue::Integer(_) | DeValue::Float(_) => {
                    NodeKind::Num(text.get(span.clone()).unwrap_or("").to_string())
                }
                DeValue::Boolean(b) => NodeKind::Bool(*b),
                DeValue::Datetime(_) => NodeKind::Datetime,
                DeValue::Array(a) => NodeKind::Array(
                    a.iter()
                        .map(|i| conv(i.get_ref(), i.span(), text))
                        .collect(),
                ),
                DeValue::Table(t) => NodeKind::Table(table(t, text)),
            };
            Node { kind, span }
        }
        fn table(t: &DeTable<'_>, text: &str) -> Vec<Entry> {
            let mut v: Vec<Entry> = t
                .iter()
                .map(|(k, v)| Entry {
                    key: k.get_ref().to_string(),
                    key_span: k.span(),
                    value: conv(v.get_ref(), v.span(), text),
                })
                .collect();
            v.sort_by_key(|e| (e.key_span.start, e.key_span.end));
            v
        }
        let root = DeTable::parse(text).map_err(|e| e.message().to_string())?;
        Ok(Node {
            kind: NodeKind::Table(table(root.get_ref(), text)),
            span: root.span(),
        })
    }

    fn mine(text: &str) -> Result<Node, String> {
        parse(&SourceFile::new("t.toml", text)).map_err(|e| e.message)
    }

    /// Entries sorted by key, spans of implicit tables ignored.
    fn norm(n: &Node) -> String {
        match &n.kind {
            NodeKind::Table(es) => {
                let mut parts: Vec<String> = es
                    .iter()
                    .map(|e| format!("{}@{:?}={}", e.key, e.key_span, norm(&e.value)))
                    .collect();
                parts.sort();
                format!("{{{}}}", parts.join(","))
            }
            NodeKind::Array(items) => {
                format!("[{}]", items.iter().map(norm).collect::<Vec<_>>().join(","))
            }
            other => format!("{other:?}@{:?}", n.span),
        }
    }

    #[test]
    fn same_tree_as_the_toml_crate() {
        let mut docs: Vec<String> = crate::schema::BUILTIN_FILES
            .iter()
            .map(|(_, t)| t.to_string())
            .collect();
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../parameter-sets");
        for dir in ["fixtures", "tmd", "mc6000", "vf1000", "ecs"] {
            for e in std::fs::read_dir(format!("{root}/{dir}")).unwrap() {
                let p = e.unwrap().path();
                if p.extension().is_some_and(|x| x == "toml") {
                    docs.push(std::fs::read_to_string(p).unwrap());
                }
            }
        }
        docs.extend(
            [
                "a = 1\nb.c = \"x\"\nb.d = [1, 2, {e = 3}]\n[t]\nx = 0x10\ny = 1e3\n[t.u]\nz = true\n",
                "[[a]]\nx = 1\n[[a]]\nx = 2\n[a.b]\ny = 3\n[[a.c]]\nz = 4\n",
                "[x.y.z]\na = 1\n[x]\nb = 2\n",
                "a = { b.c = 1, d = 'lit' }\ns = \"\"\"\nml\\tstring\"\"\"\n",
                "d = 1979-05-27T07:32:00Z\nf = -0.5\ni = +17\n\"quoted key\" = 1\n'lit key'.x = 2\n",
            ]
            .map(String::from),
        );
        assert!(docs.len() > 15);
        for d in &docs {
            let a = mine(d).unwrap();
            let b = via_toml(d).unwrap();
            assert_eq!(norm(&a), norm(&b), "{d}");
        }
    }

    #[test]
    fn errors_like_the_toml_crate() {
        for d in [
            "a = 1\na = 2\n",
            "[t]\na = 1\n[t]\nb = 2\n",
            "a = 1\n[a]\n",
            "a = {x = 1}\na.y = 2\n",
            "[[a]]\n[a]\n",
            "a.b = 1\n[a]\n",
            "x = [1\n",
            "x = \"\\q\"\n",
            "x = 1__0\n",
            "[values\n",
            "= 1\n",
            "a = 1 b = 2\n",
        ] {
            let b = via_toml(d);
            let a = mine(d);
            assert!(b.is_err(), "toml accepts {d:?}");
            assert!(a.is_err(), "accepted {d:?}: {a:?}");
        }
        assert_eq!(
            mine("a = 1\na = 2\n").unwrap_err(),
            "malformed TOML: duplicate key"
        );
        assert_eq!(
            mine("[values\n").unwrap_err(),
            via_toml("[values\n")
                .map(|_| ())
                .map_err(|e| format!("malformed TOML: {e}"))
                .unwrap_err()
        );
    }

    #[test]
    fn keeps_file_order() {
        let n = mine("b = 1\na = 2\n[z]\n[c]\n").unwrap();
        let keys: Vec<&str> = n.entries().iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["b", "a", "z", "c"]);
        // a big table (hash index) still finds duplicates
        let mut big = String::from("[values]\n");
        for i in 0..100 {
            big.push_str(&format!("C{i:04} = {i}\n"));
        }
        assert!(mine(&big).is_ok());
        big.push_str("C0042 = 1\n");
        assert_eq!(mine(&big).unwrap_err(), "malformed TOML: duplicate key");
    }
}
