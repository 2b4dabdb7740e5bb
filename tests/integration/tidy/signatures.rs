//! No `pub fn` takes a bare `bool` (rust-analyzer's style: separate
//! functions over mode or bool parameters, small config structs over long
//! parameter lists; docs/architecture.md, "Invariants and the tests that
//! check them"). A caller's `f(x, true)` says nothing of what `true` means.

use std::collections::BTreeSet;

use super::size::blanked;
use super::{report, sources};

/// The `pub fn`s that took a bare `bool` when the rule was set: `(file,
/// function)`. The list may only shrink: give a function two names, or an
/// enum or a small options struct, and remove its entry; never add one.
const BOOL_PARAMETERS_STILL: &[(&str, &str)] = &[];

/// `(1-based line, name)` of each `pub fn` of `text` (a blanked source,
/// see [`blanked`]) whose parameters hold a `: bool`.
fn pub_fns_taking_bool(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (at, head) in ["pub fn ", "pub const fn "]
        .iter()
        .flat_map(|h| text.match_indices(h))
    {
        if text[..at]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '(')
        {
            continue;
        }
        let rest = &text[at + head.len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let Some(open) = rest.find('(') else { continue };
        let mut depth = 0;
        let mut close = None;
        for (i, c) in rest[open..].char_indices() {
            match c {
                '(' => depth += 1,
                ')' => {
                    depth -= 1;
                    if depth == 0 {
                        close = Some(open + i);
                        break;
                    }
                }
                _ => {}
            }
        }
        let Some(close) = close else { continue };
        let params = &rest[open + 1..close];
        let bare_bool = params
            .split(',')
            .any(|p| p.split_once(':').is_some_and(|(_, ty)| ty.trim() == "bool"));
        if bare_bool {
            out.push((text[..at].matches('\n').count() + 1, name));
        }
    }
    out.sort();
    out
}

#[test]
fn tidy_no_pub_fn_takes_a_bare_bool() {
    let mut problems = Vec::new();
    let mut seen = BTreeSet::new();
    for source in sources() {
        let path = &source.path;
        let code: BTreeSet<usize> = source.code().map(|(n, _)| n).collect();
        for (line, name) in pub_fns_taking_bool(&blanked(&source.text)) {
            if !code.contains(&line) {
                continue; // test code
            }
            if BOOL_PARAMETERS_STILL
                .iter()
                .any(|(p, f)| p == path && *f == name)
            {
                seen.insert((path.clone(), name));
                continue;
            }
            problems.push(format!(
                "{path}:{line}: `pub fn {name}` takes a bare `bool`: give it two functions, or an enum or a small options struct that says what the value means"
            ));
        }
    }
    for (p, f) in BOOL_PARAMETERS_STILL {
        if !seen.contains(&(p.to_string(), f.to_string())) {
            problems.push(format!(
                "{p}: `pub fn {f}` is listed in BOOL_PARAMETERS_STILL (tests/integration/tidy/signatures.rs) but takes no bare `bool` any more (or is gone): remove its entry"
            ));
        }
    }
    report("pub fn with a bare bool", &problems);
}

/// The reader: a bare `bool` is found in a one-line and a multi-line
/// signature; a `pub(crate) fn`, a `&bool`, an `Option<bool>` and a
/// function returning `bool` are not.
#[test]
fn tidy_the_bool_reader_finds_bare_bools() {
    let text = "pub fn a(x: u8, on: bool) {}\npub const fn b(\n    x: u8,\n    dry: bool,\n) -> u8 {}\npub(crate) fn c(on: bool) {}\npub fn d(on: &bool, o: Option<bool>) -> bool {}\n";
    assert_eq!(
        pub_fns_taking_bool(text),
        [(1, "a".to_string()), (2, "b".to_string())]
    );
}
