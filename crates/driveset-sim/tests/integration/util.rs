//! Helpers shared by the simulator's integration-test modules: the one
//! pty lock of this process and the interop test's Python interpreter and
//! skip rule.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Tests run in parallel threads of this one binary: ptys are created one
/// at a time, under this lock, by every module.
static PTY_LOCK: Mutex<()> = Mutex::new(());

/// Hold while creating a pty (`serve::open_pty`, `SlcanServer::spawn`).
pub fn pty_lock() -> MutexGuard<'static, ()> {
    PTY_LOCK.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The Python interpreter of the interop tests: `DRIVESET_PYTHON`, else the
/// venv `scripts/setup-python` makes at `target/py`.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("DRIVESET_PYTHON") {
        return PathBuf::from(p);
    }
    root().join("target/py/bin/python")
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

/// [`python`], or `None` after [`interop_or_skip`] said why the test is
/// skipped.
pub fn python_or_skip(what: &str) -> Option<PathBuf> {
    let python = python();
    let missing = format!(
        "{} is missing (scripts/setup-python installs the pinned packages into target/py; or set DRIVESET_PYTHON)",
        python.display()
    );
    interop_or_skip(what, python.exists(), &missing).then_some(python)
}
