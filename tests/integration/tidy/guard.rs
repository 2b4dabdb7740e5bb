//! The write guard over every crate (docs/architecture.md, "The write
//! guard and the role floor"): the codecs' constructors of telegrams that
//! change a drive are named, outside the codecs that define them, only by
//! the engine's guard (`guard.rs`), so every write to a drive leaves
//! through its `check` and the `Cleared` proof it hands out.

use std::collections::BTreeSet;

use super::{report, sources};

/// What building a telegram that changes a drive looks like.
const WRITING_TELEGRAMS: &[&str] = &[
    "Select::new(",
    "Send::new(",
    "Broadcast::new(",
    "start_write(",
    "Telegram::Send)",
    "Telegram::Broadcast)",
    "SdoRequest::Write {",
    "SdoRequest::InitiateWrite {",
];

/// Where they may be named, and why (each must still name one).
const MAY_BUILD_WRITES: &[(&str, &str)] = &[
    (
        "crates/driveset-proto/src/",
        "the codecs: where the telegrams are defined, encoded and parsed (no IO: they send nothing)",
    ),
    (
        "crates/driveset-engine/src/guard.rs",
        "the write guard: every write to a drive is built here, after its check",
    ),
    (
        "crates/driveset-engine/src/decode/",
        "decoding recorded captures (it matches the telegrams it reads) and `driveset encode`'s description language (`decode/encode.rs`: telegram bytes printed for a reader): neither sends anything",
    ),
];

#[test]
fn tidy_only_the_guard_builds_writing_telegrams() {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for source in sources() {
        let path = &source.path;
        let allowed = MAY_BUILD_WRITES.iter().find(|(p, _)| source.under(p));
        // test modules too: a test that builds a write builds it through
        // the guard, or lives where the telegram is defined
        for (n, line) in source.lines() {
            if line.trim_start().starts_with("//") {
                continue;
            }
            let Some(what) = WRITING_TELEGRAMS.iter().find(|t| line.contains(*t)) else {
                continue;
            };
            if let Some((p, _)) = allowed {
                used.insert(*p);
                continue;
            }
            problems.push(format!(
                "{path}:{n}: `{what}` builds a telegram that changes a drive outside the write guard: write through the engine's `guard::check` and the `Cleared` proof it hands out (crates/driveset-engine/src/guard.rs), or list the place in MAY_BUILD_WRITES (tests/integration/tidy/guard.rs) with why it sends nothing"
            ));
        }
    }
    for (p, _) in MAY_BUILD_WRITES {
        if !used.contains(p) {
            problems.push(format!(
                "{p}: listed in MAY_BUILD_WRITES (tests/integration/tidy/guard.rs) but builds no writing telegram any more: remove its entry"
            ));
        }
    }
    report("writing telegrams outside the guard", &problems);
}
