//! The engine does no file or network IO of its own but its journal's
//! store (docs/architecture.md, "The engine's seams").

use std::collections::BTreeSet;

use super::{report, sources_under};

/// The journal's store, the engine's one file of file IO (skipped whole).
const JOURNAL_STORE: &str = "crates/driveset-engine/src/journal/store.rs";

/// Where the engine may touch files itself, beyond the journal's store
/// ([`JOURNAL_STORE`]): `(file, the line's text, why)`.
const ENGINE_IO_EXCEPTIONS: &[(&str, &str, &str)] = &[(
    "crates/driveset-engine/src/journal/records.rs",
    ".then(|| std::fs::canonicalize(file).ok())",
    "SchemaSource::of records the schema file's absolute path in the journal for recover",
)];

/// What file, network or process IO in the engine's sources looks like.
const ENGINE_IO: &[&str] = &[
    "std::fs",
    "std::net",
    "std::process",
    "std::os::unix::fs",
    "File::",
    "OpenOptions::new",
];

#[test]
fn tidy_the_engine_does_no_io_but_its_journal() {
    let mut problems = Vec::new();
    let mut used_exceptions = BTreeSet::new();
    for source in sources_under("crates/driveset-engine/src/") {
        let path = &source.path;
        if path == JOURNAL_STORE {
            continue;
        }
        for (n, line) in source.code() {
            let code = line.trim_start();
            let Some(what) = ENGINE_IO.iter().find(|pat| {
                line.match_indices(*pat).any(|(at, _)| {
                    // `File::` only as its own path segment, not
                    // `JournalFile::` or `SourceFile::`
                    !line[..at]
                        .chars()
                        .next_back()
                        .is_some_and(|c| c.is_alphanumeric() || c == '_')
                })
            }) else {
                continue;
            };
            if let Some(ex) = ENGINE_IO_EXCEPTIONS
                .iter()
                .find(|(f, l, _)| f == path && *l == code.trim_end())
            {
                used_exceptions.insert(ex.1);
                continue;
            }
            problems.push(format!(
                "{path}:{n}: `{what}` in the engine: the engine does no IO of its own but its journal (docs/architecture.md, \"The engine's seams\"); take it through a seam (`Environment`, the link, the schema crate's `input` reader) or, if it is the journal's, put it in its store (crates/driveset-engine/src/journal/store.rs)"
            ));
        }
    }
    for (f, l, _) in ENGINE_IO_EXCEPTIONS {
        if !used_exceptions.contains(l) {
            problems.push(format!(
                "{f}:1: the exception `{l}` in ENGINE_IO_EXCEPTIONS (tests/integration/tidy/engine_io.rs) matches no line any more: remove it"
            ));
        }
    }
    report("engine IO (docs/architecture.md)", &problems);
}
