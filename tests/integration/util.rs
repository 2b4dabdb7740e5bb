//! Shared helpers for the integration tests.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The workspace root (where `schemas/` and `parameter-sets/` live).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("workspace root")
}

/// A `driveset` command, run from the workspace root.
pub fn driveset() -> assert_cmd::Command {
    let mut cmd = assert_cmd::Command::cargo_bin("driveset").expect("driveset binary");
    cmd.current_dir(workspace_root());
    cmd
}

/// Whether an interop test can run: `present` says its outside software is
/// installed. When it is not, a plain `cargo test` skips the test with a
/// message naming `scripts/setup`; README's test command (`./scripts/test`
/// exports `DRIVESET_REQUIRE_INTEROP=1`) fails it instead.
pub fn interop_or_skip(what: &str, present: bool, missing: &str) -> bool {
    if present {
        return true;
    }
    let msg = format!("{what}: {missing}: run scripts/setup");
    if std::env::var_os("DRIVESET_REQUIRE_INTEROP").is_some_and(|v| v == "1") {
        panic!("{msg} (DRIVESET_REQUIRE_INTEROP=1: not skipping)");
    }
    eprintln!("skipped: {msg}");
    false
}

/// The Python interpreter of the interop tests (`DRIVESET_PYTHON`, else the
/// venv `scripts/setup-python` makes at `target/py`), or `None` after
/// [`interop_or_skip`] said why the test is skipped.
pub fn python_or_skip(what: &str) -> Option<PathBuf> {
    let python = std::env::var_os("DRIVESET_PYTHON").map_or_else(
        || workspace_root().join("target/py/bin/python"),
        PathBuf::from,
    );
    let missing = format!(
        "{} is missing (scripts/setup-python installs the pinned packages into target/py; or set DRIVESET_PYTHON)",
        python.display()
    );
    interop_or_skip(what, python.exists(), &missing).then_some(python)
}

/// Whether `text` shows `value` as a value of its own: not inside another
/// number, word, hash or decimal fraction (a timing `0.742 s` or a
/// fingerprint holding the digits does not count, so the check cannot
/// fail by chance).
pub fn shows_value(text: &str, value: &str) -> bool {
    let part = |c: Option<char>| c.is_some_and(|c| c.is_ascii_alphanumeric() || c == '.');
    text.match_indices(value).any(|(i, _)| {
        !part(text[..i].chars().next_back()) && !part(text[i + value.len()..].chars().next())
    })
}

/// Copy the directory tree `from` to `to` (created).
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// The files of `dir` whose name starts with `prefix` and ends `.toml`
/// (learned schemas), sorted.
pub fn toml_files_starting(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix) && n.ends_with(".toml"))
        })
        .collect();
    v.sort();
    v
}
