//! Tidy test of the one writer (issue 29): no source outside
//! `driveset_schema::output` creates, writes or renames a file itself, but
//! the justified exceptions listed here. Test code (`#[cfg(test)]` modules,
//! `tests/`, benches) is free.

use super::{report, sources};

/// The one writer.
const WRITER: &str = "crates/driveset-schema/src/output.rs";

/// Files that may write files themselves, and why.
const WRITES_ELSEWHERE: &[(&str, &str)] = &[
    (
        "crates/driveset-engine/src/journal/store.rs",
        "the journal's own store: 0600 temp file, fsync, rename, directory fsync at each transition, before a drive is written (docs/architecture.md)",
    ),
    (
        "crates/driveset-link/src/lock.rs",
        "the bus lock file: opened for flock and never replaced (a rename would split the lock)",
    ),
];

/// What creating, writing or renaming a file looks like.
const WRITES: &[&str] = &[
    "File::create",
    "fs::write(",
    ".write(true)",
    ".append(true)",
    "fs::rename(",
];

#[test]
fn tidy_files_are_written_only_through_the_one_writer() {
    let mut problems = Vec::new();
    let mut used = std::collections::BTreeSet::new();
    for source in sources() {
        let path = &source.path;
        if path == WRITER {
            continue;
        }
        for (n, line) in source.code() {
            let Some(what) = WRITES.iter().find(|w| {
                line.match_indices(**w).any(|(at, _)| {
                    // `File::create` as its own path segment, not
                    // `JournalFile::create`
                    !line[..at]
                        .chars()
                        .next_back()
                        .is_some_and(|c| c.is_alphanumeric() || c == '_')
                })
            }) else {
                continue;
            };
            if WRITES_ELSEWHERE.iter().any(|(f, _)| f == path) {
                used.insert(path.clone());
                continue;
            }
            problems.push(format!(
                "{path}:{n}: `{what}` outside the one writer: write files through `driveset_schema::output` ({WRITER}: regular files only, temp + fsync + rename, symlinks followed, mode kept), or list the file in WRITES_ELSEWHERE (tests/integration/tidy/writes.rs) with its reason"
            ));
        }
    }
    for (f, _) in WRITES_ELSEWHERE {
        if !used.contains(*f) {
            problems.push(format!(
                "{f}:1: listed in WRITES_ELSEWHERE (tests/integration/tidy/writes.rs) but writes no file any more: remove it"
            ));
        }
    }
    report("files written outside the one writer", &problems);
}
