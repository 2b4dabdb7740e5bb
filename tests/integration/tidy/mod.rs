//! Tidy tests (rust-analyzer's `tidy.rs` style): tests that read the
//! repository's own sources and docs and hold the rules
//! `docs/architecture.md` states ("Invariants and the tests that check
//! them"). One walker reads the workspace once: [`files`] lists a folder's
//! files, [`sources`] holds every crate's Rust sources (`crates/*/src`)
//! with their code told apart from comments and test modules
//! ([`Source::code`]), and every rule asks it:
//!
//! - `arrows`: nothing points up (each crate's `[dependencies]`);
//! - `engine_io`: the engine does no file or network IO but its journal's
//!   store;
//! - `session`: clients are built only by `connect` and the session, ports
//!   opened only through the session;
//! - `transport`: a simulated port is only a transport; one set of port
//!   arguments;
//! - `family`: family facts only in the descriptor;
//! - `guard`: every telegram that changes a drive is built by the engine's
//!   write guard, in every crate;
//! - `writes`: files are written only through the one writer;
//! - `commands`: the CLI's commands never import each other;
//! - `size`: no source file over 900 lines, no function over 150 lines
//!   (each ratchet with its listed exceptions);
//! - `signatures`: no `pub fn` takes a bare `bool`;
//! - `transfer`: the upload runner names nothing of the transfer-rate
//!   switch;
//! - `docs`: the docs cite only files the repository holds, and nothing
//!   outside it.
//!
//! Each failure names the file and line and says what to do. They read
//! files only: no build, no git, no network.

mod arrows;
mod commands;
mod docs;
mod engine_io;
mod family;
mod guard;
mod session;
mod signatures;
mod size;
mod transfer;
mod transport;
mod writes;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use driveset_test_support::workspace_root;

/// One Rust source file of a crate (`crates/<crate>/src/**.rs`), read once
/// by [`sources`].
pub(crate) struct Source {
    /// From the workspace root, with `/`.
    pub(crate) path: String,
    /// The whole file.
    pub(crate) text: String,
    /// A test module in a file of its own ([`is_test_module_file`]).
    pub(crate) test_file: bool,
    /// The 0-based line ranges of its inline `#[cfg(test)]` items
    /// ([`skipped_blocks`]).
    test_blocks: Vec<(usize, usize)>,
}

impl Source {
    /// The source `text` at `path` (a file of the workspace, or a test's
    /// own text).
    pub(crate) fn new(path: &str, text: String, test_file: bool) -> Source {
        let lines: Vec<&str> = text.lines().collect();
        let test_blocks = skipped_blocks(&lines, None);
        Source {
            path: path.to_string(),
            test_file,
            test_blocks,
            text,
        }
    }

    /// Whether its path starts with `prefix` (a folder ending `/`, or a
    /// file's whole path).
    pub(crate) fn under(&self, prefix: &str) -> bool {
        self.path.starts_with(prefix)
    }

    /// Every line, numbered from 1: comments and tests included.
    pub(crate) fn lines(&self) -> impl Iterator<Item = (usize, &str)> {
        self.text.lines().enumerate().map(|(i, l)| (i + 1, l))
    }

    /// Its lines of code, numbered from 1: whole-line comments, inline
    /// `#[cfg(test)]` items and the whole of a test module file left out.
    pub(crate) fn code(&self) -> impl Iterator<Item = (usize, &str)> {
        let test_file = self.test_file;
        self.text
            .lines()
            .enumerate()
            .filter(move |&(i, l)| {
                !test_file
                    && !l.trim_start().starts_with("//")
                    && !self.test_blocks.iter().any(|&(a, b)| (a..=b).contains(&i))
            })
            .map(|(i, l)| (i + 1, l))
    }
}

/// Every Rust source file under `crates/*/src`, sorted by path, read once
/// for all the rules.
pub(crate) fn sources() -> &'static [Source] {
    static SOURCES: OnceLock<Vec<Source>> = OnceLock::new();
    SOURCES.get_or_init(|| {
        let root = workspace_root();
        let all: Vec<Source> = files(&root.join("crates"), &[".rs"])
            .into_iter()
            .filter_map(|file| {
                let path = rel(&root, &file);
                let in_src = path.split('/').nth(2) == Some("src");
                in_src.then(|| Source::new(&path, read(&file), is_test_module_file(&file)))
            })
            .collect();
        assert!(
            all.len() > 200,
            "{} source files under crates/*/src",
            all.len()
        );
        all
    })
}

/// The sources whose path starts with `prefix` (`crates/driveset-engine/src/`).
pub(crate) fn sources_under(prefix: &str) -> impl Iterator<Item = &'static Source> {
    let found: Vec<&Source> = sources().iter().filter(|s| s.under(prefix)).collect();
    assert!(!found.is_empty(), "no source file under {prefix}");
    found.into_iter()
}

/// The path of `p` from the workspace root, with `/`.
pub(crate) fn rel(root: &Path, p: &Path) -> String {
    p.strip_prefix(root)
        .unwrap_or(p)
        .components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// The files below `dir` (recursively, sorted) whose name ends with one of
/// `exts`; build output, VCS data, hidden and cache folders skipped.
pub(crate) fn files(dir: &Path, exts: &[&str]) -> Vec<PathBuf> {
    fn walk(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let path = e.path();
            if path.is_dir() {
                let skip = name.starts_with('.')
                    || matches!(name.as_str(), "target" | "node_modules" | "__pycache__");
                if !skip {
                    walk(&path, exts, out);
                }
            } else if exts.iter().any(|x| name.ends_with(x)) {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, exts, &mut out);
    out.sort();
    out
}

pub(crate) fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Fails the test with every problem found, one a line.
pub(crate) fn report(what: &str, problems: &[String]) {
    assert!(
        problems.is_empty(),
        "{what}: {} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// Whether `file` is a test module in a file of its own: a `tests.rs`
/// whose parent module (`mod.rs` beside it, or the file named as its
/// folder) declares it `#[cfg(test)] mod tests;`. Skipped whole, as an
/// inline `#[cfg(test)]` module is ([`skipped_blocks`]).
pub(crate) fn is_test_module_file(file: &Path) -> bool {
    let Some(dir) = file.parent().filter(|_| file.ends_with("tests.rs")) else {
        return false;
    };
    let parents = [dir.join("mod.rs"), dir.with_extension("rs")];
    parents.iter().any(|p| {
        std::fs::read_to_string(p).is_ok_and(|t| {
            let lines: Vec<&str> = t.lines().map(str::trim).collect();
            lines
                .windows(2)
                .any(|w| w[0] == "#[cfg(test)]" && w[1] == "mod tests;")
        })
    })
}

/// The 0-based line ranges of `lines` to skip: each `#[cfg(test)]` module
/// (`mod x { .. }`) and, when `skip_mod` names one, that module too. A
/// block ends at the first later line that is its opening line's
/// indentation and `}` (rustfmt's layout, which CI holds).
pub(crate) fn skipped_blocks(lines: &[&str], skip_mod: Option<&str>) -> Vec<(usize, usize)> {
    let mut blocks = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i].trim_start();
        let indent = &lines[i][..lines[i].len() - l.len()];
        let starts_skipped_mod =
            skip_mod.is_some_and(|m| l == format!("mod {m} {{") || l == format!("pub mod {m} {{"));
        let mut open = None;
        if l.starts_with("#[cfg(test)]") {
            // the item the attribute is on: the next line that is not an
            // attribute
            let mut j = i + 1;
            while j < lines.len() && lines[j].trim_start().starts_with("#[") {
                j += 1;
            }
            if j < lines.len() && lines[j].trim_end().ends_with('{') {
                open = Some(j);
            }
        } else if starts_skipped_mod {
            open = Some(i);
        }
        if let Some(j) = open {
            let close = format!("{indent}}}");
            let end = (j + 1..lines.len())
                .find(|&k| lines[k].trim_end() == close)
                .unwrap_or(lines.len() - 1);
            blocks.push((i, end));
            i = end + 1;
        } else {
            i += 1;
        }
    }
    blocks
}
