//! Size ratchets: no source file over [`MAX_LINES`] lines and no function
//! over [`MAX_FN_LINES`] lines, but the listed ones, each of which may only
//! shrink (docs/architecture.md, "Invariants and the tests that check
//! them").

use std::collections::BTreeSet;

use super::{Source, report, sources};

/// The longest a source file under `crates/*/src/` may be.
const MAX_LINES: usize = 900;

/// The source files over [`MAX_LINES`], each with why it may stay for now;
/// whoever brings one under the limit removes its entry (the test says so).
/// A table of data may stay here for good, saying so.
const LARGE_FILES: &[(&str, &str)] = &[];

/// The longest a function of `crates/*/src/` may be, from its `fn` line to
/// its closing brace (test code apart): what a reader can hold in mind.
const MAX_FN_LINES: usize = 150;

/// The functions over [`MAX_FN_LINES`] when the ratchet was set: `(file,
/// function, its lines then)`. A listed function may only shrink: lower
/// its count as it does, remove it once it is within the limit; never add
/// one.
const LONG_FUNCTIONS: &[(&str, &str, usize)] = &[
    ("crates/driveset-cli/src/cmd/replace.rs", "run", 165),
    ("crates/driveset-cli/src/cmd/scan.rs", "scan", 227),
    (
        "crates/driveset-engine/src/assign/plan.rs",
        "plan_lecom",
        177,
    ),
    (
        "crates/driveset-engine/src/assign/plan.rs",
        "plan_lustbus",
        216,
    ),
    (
        "crates/driveset-engine/src/assign/recover.rs",
        "recover",
        223,
    ),
    ("crates/driveset-engine/src/assign/run.rs", "finish", 175),
    ("crates/driveset-engine/src/decode/lecom.rs", "decode", 189),
    (
        "crates/driveset-engine/src/decode/lustbus.rs",
        "decode",
        172,
    ),
    (
        "crates/driveset-engine/src/learn/render.rs",
        "render_code",
        175,
    ),
    ("crates/driveset-engine/src/recover.rs", "settle", 331),
    ("crates/driveset-proto/src/lustbus/stream.rs", "step", 171),
    ("crates/driveset-schema/src/check.rs", "check_code", 156),
    (
        "crates/driveset-schema/src/eds/import/facts.rs",
        "var_facts",
        170,
    ),
    (
        "crates/driveset-schema/src/eds/import/mod.rs",
        "import",
        380,
    ),
    (
        "crates/driveset-schema/src/schema/load.rs",
        "parse_schema",
        287,
    ),
    (
        "crates/driveset-schema/src/schema/parse.rs",
        "parse_code",
        233,
    ),
    ("crates/driveset-schema/src/set.rs", "load_source", 221),
    (
        "crates/driveset-schema/src/validate.rs",
        "convert_value",
        184,
    ),
    ("crates/driveset-sim/src/port/mod.rs", "from_opaque", 188),
    ("crates/driveset-sim/src/twin/reader.rs", "twin", 195),
];

#[test]
fn tidy_no_source_file_over_900_lines() {
    let mut problems = Vec::new();
    let mut seen = BTreeSet::new();
    for source in sources() {
        let path = &source.path;
        let n = source.text.lines().count();
        let listed = LARGE_FILES.iter().any(|(f, _)| f == path);
        if listed {
            seen.insert(path.clone());
        }
        if n > MAX_LINES && !listed {
            problems.push(format!(
                "{path}:{}: {n} lines, over the {MAX_LINES}-line limit: split it into modules of one job each (a table of data may instead get an entry with its reason in LARGE_FILES, tests/integration/tidy/size.rs)",
                MAX_LINES + 1
            ));
        } else if n <= MAX_LINES && listed {
            problems.push(format!(
                "{path}:1: {n} lines, within the limit now: remove its entry from LARGE_FILES in tests/integration/tidy/size.rs"
            ));
        }
    }
    for (f, _) in LARGE_FILES {
        if !seen.contains(*f) {
            problems.push(format!(
                "{f}: listed in LARGE_FILES (tests/integration/tidy/size.rs) but no such file: remove its entry"
            ));
        }
    }
    report("file size", &problems);
}

#[test]
fn tidy_no_function_over_150_lines() {
    let mut problems = Vec::new();
    let mut seen = BTreeSet::new();
    for source in sources() {
        let path = &source.path;
        for f in functions(source) {
            if f.lines <= MAX_FN_LINES {
                continue;
            }
            let listed = LONG_FUNCTIONS
                .iter()
                .find(|(p, name, _)| p == path && *name == f.name);
            match listed {
                None => problems.push(format!(
                    "{path}:{}: fn `{}` is {} lines, over the {MAX_FN_LINES}-line limit: split it into functions a reader can hold in mind",
                    f.line, f.name, f.lines
                )),
                Some(&(_, _, was)) if f.lines > was => problems.push(format!(
                    "{path}:{}: fn `{}` is {} lines, it was {was} when listed in LONG_FUNCTIONS (tests/integration/tidy/size.rs): it may only shrink",
                    f.line, f.name, f.lines
                )),
                Some(&(_, _, was)) => {
                    seen.insert((path.clone(), f.name.clone()));
                    if f.lines < was {
                        problems.push(format!(
                            "{path}:{}: fn `{}` is {} lines now: lower its entry in LONG_FUNCTIONS (tests/integration/tidy/size.rs) from {was} to {}",
                            f.line, f.name, f.lines, f.lines
                        ));
                    }
                }
            }
        }
    }
    for (p, name, _) in LONG_FUNCTIONS {
        if !seen.contains(&(p.to_string(), name.to_string())) {
            problems.push(format!(
                "{p}: fn `{name}` is listed in LONG_FUNCTIONS (tests/integration/tidy/size.rs) but is no longer over {MAX_FN_LINES} lines (or no longer there): remove its entry"
            ));
        }
    }
    report("function size", &problems);
}

/// A function with a body, found by [`functions`].
pub(crate) struct Function {
    pub(crate) name: String,
    /// The 1-based line of its `fn`.
    pub(crate) line: usize,
    /// Its lines, from the `fn` line to the closing brace.
    pub(crate) lines: usize,
}

/// The functions with a body in the code of `source` (test modules
/// apart), by their braces: string, character and comment contents are
/// blanked out first so that a `"{path}"` or a `'}'` counts nothing.
pub(crate) fn functions(source: &Source) -> Vec<Function> {
    let code: BTreeSet<usize> = source.code().map(|(n, _)| n).collect();
    let blank = blanked(&source.text);
    let lines: Vec<&str> = blank.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if !code.contains(&(i + 1)) {
            continue;
        }
        let Some(name) = fn_name(line) else {
            continue;
        };
        let mut depth = 0usize;
        let mut opened = false;
        'body: for (j, l) in lines.iter().enumerate().skip(i) {
            for c in l.chars() {
                match c {
                    ';' if !opened => break 'body, // a declaration: no body
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' if opened => {
                        depth -= 1;
                        if depth == 0 {
                            out.push(Function {
                                name: name.to_string(),
                                line: i + 1,
                                lines: j - i + 1,
                            });
                            break 'body;
                        }
                    }
                    _ => {}
                }
            }
        }
    }
    out
}

/// The name of the function a (blanked) line starts, if it does: `fn`
/// after the qualifiers a function item may have.
fn fn_name(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    loop {
        let before = rest;
        for q in [
            "pub(crate) ",
            "pub(super) ",
            "pub ",
            "const ",
            "async ",
            "unsafe ",
            "extern \" \" ",
        ] {
            if let Some(r) = rest.strip_prefix(q) {
                rest = r.trim_start();
            }
        }
        if let Some(r) = rest.strip_prefix("pub(in ") {
            rest = r.split_once(')').map_or("", |(_, r)| r.trim_start());
        }
        if rest == before {
            break;
        }
    }
    let rest = rest.strip_prefix("fn ")?;
    let end = rest
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    (end > 0).then(|| &rest[..end])
}

/// `text` with the contents of its string and character literals and its
/// comments replaced by blanks (line breaks kept), so that braces and
/// semicolons left are the code's own.
pub(crate) fn blanked(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let keep = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let mut i = 0;
    while i < c.len() {
        match c[i] {
            '/' if c.get(i + 1) == Some(&'/') => {
                while i < c.len() && c[i] != '\n' {
                    keep(&mut out, c[i]);
                    i += 1;
                }
            }
            '/' if c.get(i + 1) == Some(&'*') => {
                let mut depth = 0;
                while i < c.len() {
                    if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                        depth += 1;
                        out.push_str("  ");
                        i += 2;
                    } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                        depth -= 1;
                        out.push_str("  ");
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        keep(&mut out, c[i]);
                        i += 1;
                    }
                }
            }
            'r' if (c.get(i + 1) == Some(&'"') || c.get(i + 1) == Some(&'#'))
                && !c[..i]
                    .last()
                    .is_some_and(|p| p.is_alphanumeric() || *p == '_') =>
            {
                // a raw string: r"..", r#".."#
                let mut j = i + 1;
                while c.get(j) == Some(&'#') {
                    j += 1;
                }
                if c.get(j) != Some(&'"') {
                    out.push(c[i]);
                    i += 1;
                    continue;
                }
                let hashes = j - i - 1;
                out.push_str("r\"");
                for _ in 0..j - i - 1 {
                    out.push(' ');
                }
                i = j + 1;
                while i < c.len() {
                    if c[i] == '"' && (0..hashes).all(|k| c.get(i + 1 + k) == Some(&'#')) {
                        out.push('"');
                        for _ in 0..hashes {
                            out.push(' ');
                        }
                        i += 1 + hashes;
                        break;
                    }
                    keep(&mut out, c[i]);
                    i += 1;
                }
            }
            '"' => {
                out.push('"');
                i += 1;
                while i < c.len() && c[i] != '"' {
                    if c[i] == '\\' && i + 1 < c.len() {
                        keep(&mut out, c[i]);
                        i += 1;
                    }
                    keep(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    out.push('"');
                    i += 1;
                }
            }
            '\'' => {
                // a character literal ('x', '\n', '\u{7f}'), or a lifetime
                let end = if c.get(i + 1) == Some(&'\\') {
                    (i + 2..c.len().min(i + 12)).find(|&k| c[k] == '\'')
                } else if c.get(i + 2) == Some(&'\'') {
                    Some(i + 2)
                } else {
                    None
                };
                if let Some(end) = end {
                    out.push('\'');
                    for _ in i + 1..end {
                        out.push(' ');
                    }
                    out.push('\'');
                    i = end + 1;
                } else {
                    out.push('\'');
                    i += 1;
                }
            }
            ch => {
                out.push(ch);
                i += 1;
            }
        }
    }
    out
}

/// The readers themselves: braces in strings, characters and comments
/// count nothing; a declaration has no body; qualifiers are passed over.
#[test]
fn tidy_the_function_reader_counts_code_braces() {
    let text = "pub(crate) fn a(x: u8) -> String {\n    let s = \"}{\";\n    let c = '}';\n    // }\n    /* { */\n    let r = r#\"}\"#;\n    format!(\"{s}{c}{r}\")\n}\nfn decl(&self);\nconst fn b<'a>(x: &'a str) -> &'a str {\n    x\n}\n#[cfg(test)]\nmod tests {\n    fn hidden() {\n    }\n}\n";
    let source = Source::new("crates/x/src/lib.rs", text.to_string(), false);
    let found: Vec<(String, usize, usize)> = functions(&source)
        .into_iter()
        .map(|f| (f.name, f.line, f.lines))
        .collect();
    assert_eq!(
        found,
        [("a".to_string(), 1, 8), ("b".to_string(), 10, 3)],
        "{}",
        blanked(text)
    );
}
