//! Whether an interop test's outside software is there, and the Python
//! interpreter of the interop tests.

use std::path::PathBuf;

use crate::paths::workspace_root;

/// Whether an interop test can run: `found` is its outside software
/// where it is installed (a path, or `()` for a check), `None` where it is
/// not. When it is not, a plain `cargo test` skips the test with a
/// message naming `scripts/setup` (`None` back); README's test command
/// (`./scripts/test` exports `DRIVESET_REQUIRE_INTEROP=1`) fails it
/// instead.
pub fn interop_or_skip<T>(what: &str, found: Option<T>, missing: &str) -> Option<T> {
    if found.is_some() {
        return found;
    }
    let msg = format!("{what}: {missing}: run scripts/setup");
    if std::env::var_os("DRIVESET_REQUIRE_INTEROP").is_some_and(|v| v == "1") {
        panic!("{msg} (DRIVESET_REQUIRE_INTEROP=1: not skipping)");
    }
    eprintln!("skipped: {msg}");
    None
}

/// The Python interpreter of the interop tests: `DRIVESET_PYTHON`, else the
/// venv `scripts/setup-python` makes at `target/py`.
pub fn python() -> PathBuf {
    std::env::var_os("DRIVESET_PYTHON").map_or_else(
        || workspace_root().join("target/py/bin/python"),
        PathBuf::from,
    )
}

/// [`python`], or `None` after [`interop_or_skip`] said why the test is
/// skipped.
pub fn python_or_skip(what: &str) -> Option<PathBuf> {
    let python = python();
    let missing = format!(
        "{} is missing (scripts/setup-python installs the pinned packages into target/py; or set DRIVESET_PYTHON)",
        python.display()
    );
    interop_or_skip(what, python.exists().then_some(python), &missing)
}
