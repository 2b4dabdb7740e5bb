//! Tidy tests (rust-analyzer's `tidy.rs` style): tests that read the
//! repository's own sources and docs and hold the rules
//! `docs/architecture.md` states ("Invariants and the tests that check
//! them"): nothing points up, the engine does no file or network IO but its
//! journal's store, no source file over 900 lines but the listed ones, the
//! docs cite only files the repository holds, no reference to design
//! notes outside it, and the upload runner names nothing of the
//! transfer-rate switch. Each failure names the file and line and says what to
//! do. They read files only: no build, no git, no network.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use driveset_test_support::workspace_root;

/// Which of our crates each crate's `[dependencies]` may name: the arrows
/// of `docs/architecture.md`, "Crates and their arrows" (dev-dependencies
/// are free: the engine's tests use the simulator).
const ARROWS: &[(&str, &[&str])] = &[
    ("driveset-proto", &[]),
    ("driveset-schema", &["driveset-proto"]),
    ("driveset-link", &["driveset-proto"]),
    (
        "driveset-engine",
        &["driveset-link", "driveset-proto", "driveset-schema"],
    ),
    (
        "driveset-sim",
        &["driveset-link", "driveset-proto", "driveset-schema"],
    ),
    // the plant history's store: implements the engine's seam, below the CLI
    ("driveset-history", &["driveset-engine"]),
    // the bridge between engine and simulator: twins, rehearsal buses
    (
        "driveset-twin",
        &[
            "driveset-engine",
            "driveset-sim",
            "driveset-link",
            "driveset-schema",
        ],
    ),
    // the reports (JSON, HTML, JUnit, textconv, the history's): the
    // engine's line report, the history's queries, schema
    (
        "driveset-report",
        &["driveset-engine", "driveset-history", "driveset-schema"],
    ),
    (
        "driveset-cli",
        &[
            "driveset-report",
            "driveset-engine",
            "driveset-history",
            "driveset-twin",
            "driveset-sim",
            "driveset-link",
            "driveset-proto",
            "driveset-schema",
        ],
    ),
    // dev-only: only ever a dev-dependency (nobody lists it above)
    ("driveset-test-support", &["driveset-link", "driveset-sim"]),
];

/// The longest a source file under `crates/*/src/` may be.
const MAX_LINES: usize = 900;

/// The source files over [`MAX_LINES`] when this test was written, each
/// with why it may stay for now. Issue 19 splits them into modules of one
/// job each; whoever brings one under the limit removes its entry (the test
/// says so). A table of data may stay here for good, saying so.
const LARGE_FILES: &[(&str, &str)] = &[];

/// The sources the session rules hold for (clients built only by the
/// session, ports opened only through it): the engine, the twin bridge
/// and the CLI.
pub(crate) const SCANNED: &[&str] = &[
    "crates/driveset-engine/src",
    "crates/driveset-twin/src",
    "crates/driveset-cli/src",
];

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

/// The crate manifests `crates/*/Cargo.toml`.
fn crate_manifests(root: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .expect("crates/")
        .flatten()
        .map(|e| e.path().join("Cargo.toml"))
        .filter(|p| p.is_file())
        .collect();
    v.sort();
    v
}

/// The line (1-based) of `text` where the dependency `name` is listed, for
/// the message.
fn line_of_dep(text: &str, name: &str) -> usize {
    text.lines()
        .position(|l| {
            let l = l.trim_start();
            l.starts_with(name) && l[name.len()..].trim_start().starts_with(['=', '.'])
        })
        .map_or(1, |i| i + 1)
}

/// What breaks the arrows in the manifest `text` of `path`.
fn arrow_problems(path: &str, text: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let doc: toml::Table = text
        .parse()
        .unwrap_or_else(|e| panic!("{path}: not TOML: {e}"));
    let name = doc["package"]["name"].as_str().expect("package.name");
    let Some((_, allowed)) = ARROWS.iter().find(|(c, _)| *c == name) else {
        return vec![format!(
            "{path}:1: crate `{name}` is not among docs/architecture.md's arrows: draw it there (\"Crates and their arrows\") and add it to ARROWS in tests/integration/tidy.rs"
        )];
    };
    // [dependencies], [build-dependencies] and their
    // [target.'cfg(..)'.*] forms; not [dev-dependencies]
    let mut tables = Vec::new();
    for key in ["dependencies", "build-dependencies"] {
        tables.extend(doc.get(key).and_then(|t| t.as_table()));
    }
    if let Some(targets) = doc.get("target").and_then(|t| t.as_table()) {
        for t in targets.values().filter_map(|t| t.as_table()) {
            for key in ["dependencies", "build-dependencies"] {
                tables.extend(t.get(key).and_then(|t| t.as_table()));
            }
        }
    }
    for table in tables {
        for (dep, spec) in table {
            let real = spec.get("package").and_then(|p| p.as_str()).unwrap_or(dep);
            if real.starts_with("driveset-") && !allowed.contains(&real) {
                problems.push(format!(
                    "{path}:{}: `{name}` depends on `{real}`, which docs/architecture.md's arrows do not allow (it may use only {allowed:?}): move what it needs down, or make it a [dev-dependencies] entry if only tests use it",
                    line_of_dep(text, dep)
                ));
            }
        }
    }
    let publish = doc["package"].get("publish").and_then(|p| p.as_bool());
    if name == "driveset-test-support" && publish != Some(false) {
        problems.push(format!(
            "{path}:1: driveset-test-support must say `publish = false`: it is dev-only"
        ));
    }
    problems
}

#[test]
fn tidy_nothing_points_up() {
    let root = workspace_root();
    let mut problems = Vec::new();
    for manifest in crate_manifests(&root) {
        problems.extend(arrow_problems(&rel(&root, &manifest), &read(&manifest)));
    }
    report("crate arrows (docs/architecture.md)", &problems);
}

/// The check itself: an arrow up (the simulator on the engine, also as a
/// target dependency), a renamed one, and a dev-dependency, which is free.
#[test]
fn tidy_the_arrow_check_sees_an_arrow_up() {
    let text = "[package]\nname = \"driveset-sim\"\n\n[dependencies]\ndriveset-link.workspace = true\nengine = { package = \"driveset-engine\", path = \"../driveset-engine\" }\n\n[target.'cfg(unix)'.dependencies]\ndriveset-cli.workspace = true\n\n[dev-dependencies]\ndriveset-engine.workspace = true\n";
    let problems = arrow_problems("crates/driveset-sim/Cargo.toml", text);
    assert_eq!(problems.len(), 2, "{problems:#?}");
    assert!(
        problems[0].starts_with("crates/driveset-sim/Cargo.toml:6: `driveset-sim` depends on `driveset-engine`, which docs/architecture.md's arrows do not allow"),
        "{}",
        problems[0]
    );
    assert!(
        problems[1].starts_with(
            "crates/driveset-sim/Cargo.toml:9: `driveset-sim` depends on `driveset-cli`"
        ),
        "{}",
        problems[1]
    );
    let stray = arrow_problems("crates/x/Cargo.toml", "[package]\nname = \"driveset-x\"\n");
    assert_eq!(
        stray,
        [
            "crates/x/Cargo.toml:1: crate `driveset-x` is not among docs/architecture.md's arrows: draw it there (\"Crates and their arrows\") and add it to ARROWS in tests/integration/tidy.rs"
        ]
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

#[test]
fn tidy_the_engine_does_no_io_but_its_journal() {
    let root = workspace_root();
    let src = root.join("crates/driveset-engine/src");
    let mut problems = Vec::new();
    let mut used_exceptions = BTreeSet::new();
    for file in files(&src, &[".rs"]) {
        let path = rel(&root, &file);
        if path == JOURNAL_STORE || is_test_module_file(&file) {
            continue;
        }
        let text = read(&file);
        let lines: Vec<&str> = text.lines().collect();
        let skip = skipped_blocks(&lines, None);
        for (i, line) in lines.iter().enumerate() {
            let code = line.trim_start();
            if code.starts_with("//") || skip.iter().any(|&(a, b)| (a..=b).contains(&i)) {
                continue;
            }
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
                .find(|(f, l, _)| *f == path && *l == code.trim_end())
            {
                used_exceptions.insert(ex.1);
                continue;
            }
            problems.push(format!(
                "{path}:{}: `{what}` in the engine: the engine does no IO of its own but its journal (docs/architecture.md, \"The engine's seams\"); take it through a seam (`Environment`, the link, the schema crate's `input` reader) or, if it is the journal's, put it in its store (crates/driveset-engine/src/journal/store.rs)",
                i + 1
            ));
        }
    }
    for (f, l, _) in ENGINE_IO_EXCEPTIONS {
        if !used_exceptions.contains(l) {
            problems.push(format!(
                "{f}:1: the exception `{l}` in ENGINE_IO_EXCEPTIONS (tests/integration/tidy.rs) matches no line any more: remove it"
            ));
        }
    }
    report("engine IO (docs/architecture.md)", &problems);
}

/// The client constructors: only `connect.rs` (which `engine::session`
/// calls) and the clients themselves use them.
const CLIENT_CONSTRUCTORS: &[&str] = &[
    "LustbusClient::new(",
    "LustbusClient::with_options(",
    "LecomClient::new(",
    "LecomClient::with_options(",
    "CanClient::new(",
];

/// Source files that still build a client themselves, with how many
/// constructions each holds (a count may only go down).
const CLIENTS_STILL_BUILT_ELSEWHERE: &[(&str, usize)] = &[];

/// `connect`'s clients on a link the caller keeps: a drive's work gets its
/// client from the session (`engine::session::BusSession`, whose `reach`
/// calls `connect_on`); only the bus-level work below asks `connect` for
/// one itself.
const BORROWED_CLIENTS: &[&str] = &["connect_on(", "lustbus_on(", "lecom_on("];

/// Source files that ask `connect` for a client on a link they keep, with
/// how many calls each holds (a count may only go down): a line's work on its bus rather than on one drive: the LUSTBUS
/// SELECT to address 31 and the transactions parked around it, the LECOM
/// MULTICAST and the running check of its members (docs/architecture.md,
/// "One path from a port to a drive").
const BORROWED_CLIENTS_OUTSIDE_THE_SESSION: &[(&str, usize)] = &[
    ("crates/driveset-engine/src/line/commission/broadcast.rs", 1),
    ("crates/driveset-engine/src/line/commission/multicast.rs", 2),
    ("crates/driveset-engine/src/line/commission/parked.rs", 2),
];

/// How often `patterns` occur in `lines` outside comments and test
/// modules, and the 1-based line of the first.
fn occurrences(lines: &[&str], patterns: &[&str]) -> (usize, usize) {
    let skip = skipped_blocks(lines, None);
    let mut n = 0;
    let mut first = 0;
    for (i, line) in lines.iter().enumerate() {
        if line.trim_start().starts_with("//") || skip.iter().any(|&(a, b)| (a..=b).contains(&i)) {
            continue;
        }
        let here = patterns.iter().filter(|c| line.contains(*c)).count();
        if here > 0 && n == 0 {
            first = i + 1;
        }
        n += here;
    }
    (n, first)
}

#[test]
fn tidy_clients_are_built_only_by_connect_and_the_session() {
    let root = workspace_root();
    let mut problems = Vec::new();
    for dir in SCANNED {
        for file in files(&root.join(dir), &[".rs"]) {
            let path = rel(&root, &file);
            if path == "crates/driveset-engine/src/connect.rs"
                || path.starts_with("crates/driveset-engine/src/client/")
            {
                continue;
            }
            let text = read(&file);
            let lines: Vec<&str> = text.lines().collect();
            let (n, first) = occurrences(&lines, CLIENT_CONSTRUCTORS);
            let allowed = CLIENTS_STILL_BUILT_ELSEWHERE
                .iter()
                .find(|(f, _)| *f == path)
                .map_or(0, |(_, a)| *a);
            if n > allowed {
                problems.push(format!(
                    "{path}:{first}: {n} client construction(s): reach a drive through `engine::session::Session` or `engine::connect` (docs/architecture.md, \"One path from a port to a drive\")"
                ));
            } else if n < allowed {
                problems.push(format!(
                    "{path}:1: {n} client construction(s), the allowlist says {allowed}: lower or remove its entry in CLIENTS_STILL_BUILT_ELSEWHERE (tests/integration/tidy.rs)"
                ));
            }
            if path.starts_with("crates/driveset-engine/src/session/") {
                continue;
            }
            let (n, first) = occurrences(&lines, BORROWED_CLIENTS);
            let allowed = BORROWED_CLIENTS_OUTSIDE_THE_SESSION
                .iter()
                .find(|(f, _)| *f == path)
                .map_or(0, |(_, a)| *a);
            if n > allowed {
                problems.push(format!(
                    "{path}:{first}: {n} client(s) asked of `connect` on a kept link: reach the drive through `engine::session::BusSession` (docs/architecture.md, \"One path from a port to a drive\")"
                ));
            } else if n < allowed {
                problems.push(format!(
                    "{path}:1: {n} client(s) asked of `connect` on a kept link, the allowlist says {allowed}: lower or remove its entry in BORROWED_CLIENTS_OUTSIDE_THE_SESSION (tests/integration/tidy.rs)"
                ));
            }
        }
    }
    for (f, _) in BORROWED_CLIENTS_OUTSIDE_THE_SESSION {
        if !root.join(f).is_file() {
            problems.push(format!(
                "{f}: listed in BORROWED_CLIENTS_OUTSIDE_THE_SESSION (tests/integration/tidy.rs) but no such file: remove its entry"
            ));
        }
    }
    report("client construction (docs/architecture.md)", &problems);
}

/// What opens a port or takes a bus lock; only the session's sequence
/// (`session::open_port`, through the CLI's `Ports` in `cli/src/port.rs`)
/// may, so every bus is locked before a command drives it.
const PORT_OPENINGS: &[&str] = &[
    "driveset_link::open(",
    "port::reopen(",
    "open_with(",
    "open_sim_with(",
    "BusLock::acquire",
];

/// Files that open ports outside the session's sequence, and why (each
/// must still hold such a call).
const PORTS_OPENED_ELSEWHERE: &[(&str, &str)] = &[
    (
        "crates/driveset-cli/src/cmd/doctor.rs",
        "reopens, at each line rate it tries, the port the session opened and locked",
    ),
    (
        "crates/driveset-twin/src/rehearse.rs",
        "a rehearsal's buses of twins live in this process only: nothing to lock",
    ),
];

#[test]
fn tidy_ports_are_opened_only_through_the_session() {
    let root = workspace_root();
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for dir in SCANNED {
        for file in files(&root.join(dir), &[".rs"]) {
            let path = rel(&root, &file);
            if path == "crates/driveset-cli/src/port.rs" || is_test_module_file(&file) {
                continue;
            }
            let text = read(&file);
            let lines: Vec<&str> = text.lines().collect();
            let skip = skipped_blocks(&lines, None);
            for (i, line) in lines.iter().enumerate() {
                if line.trim_start().starts_with("//")
                    || skip.iter().any(|&(a, b)| (a..=b).contains(&i))
                {
                    continue;
                }
                let Some(what) = PORT_OPENINGS.iter().find(|p| line.contains(*p)) else {
                    continue;
                };
                if PORTS_OPENED_ELSEWHERE.iter().any(|(f, _)| *f == path) {
                    used.insert(path.clone());
                    continue;
                }
                problems.push(format!(
                    "{path}:{}: `{what}` opens a port (or takes a bus lock) outside the session: open it with `engine::session::open_port` (the CLI's `port::open_port_at`), which locks its bus (docs/architecture.md, \"One path from a port to a drive\")",
                    i + 1
                ));
            }
        }
    }
    for (f, _) in PORTS_OPENED_ELSEWHERE {
        if !used.contains(*f) {
            problems.push(format!(
                "{f}:1: listed in PORTS_OPENED_ELSEWHERE (tests/integration/tidy.rs) but opens no port any more: remove its entry"
            ));
        }
    }
    report("port opening (docs/architecture.md)", &problems);
}

#[test]
fn tidy_no_source_file_over_900_lines() {
    let root = workspace_root();
    let mut problems = Vec::new();
    let mut seen = BTreeSet::new();
    for manifest in crate_manifests(&root) {
        let src = manifest.parent().expect("crate dir").join("src");
        for file in files(&src, &[".rs"]) {
            let path = rel(&root, &file);
            let n = read(&file).lines().count();
            let listed = LARGE_FILES.iter().any(|(f, _)| *f == path);
            if listed {
                seen.insert(path.clone());
            }
            if n > MAX_LINES && !listed {
                problems.push(format!(
                    "{path}:{}: {n} lines, over the {MAX_LINES}-line limit: split it into modules of one job each (a table of data may instead get an entry with its reason in LARGE_FILES, tests/integration/tidy.rs)",
                    MAX_LINES + 1
                ));
            } else if n <= MAX_LINES && listed {
                problems.push(format!(
                    "{path}:1: {n} lines, within the limit now: remove its entry from LARGE_FILES in tests/integration/tidy.rs"
                ));
            }
        }
    }
    for (f, _) in LARGE_FILES {
        if !seen.contains(*f) {
            problems.push(format!(
                "{f}: listed in LARGE_FILES (tests/integration/tidy.rs) but no such file: remove its entry"
            ));
        }
    }
    report("file size", &problems);
}

/// GitHub's anchor of a heading's text: lower case, spaces to `-`,
/// punctuation other than `-` and `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a markdown file's headings (outside code fences); a
/// repeated heading's anchor gets `-1`, `-2`, ...
fn anchors(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut fence = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fence = !fence;
            continue;
        }
        if fence {
            continue;
        }
        if let Some(h) = line.strip_prefix('#') {
            let h = h.trim_start_matches('#');
            if !h.starts_with(' ') {
                continue;
            }
            let s = slug(h);
            let mut a = s.clone();
            let mut k = 1;
            while out.contains(&a) {
                a = format!("{s}-{k}");
                k += 1;
            }
            out.insert(a);
        }
    }
    out
}

/// The markdown link targets of a line: `[text](target)`.
fn link_targets(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let Some(end) = after.find(')') else { break };
        let target = after[..end].split_whitespace().next().unwrap_or("");
        out.push(target);
        rest = &after[end..];
    }
    out
}

/// The paths under `docs/` ending `.md` that a line mentions (from the
/// repository root: not the tail of a longer path).
fn docs_mentions(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    for (at, _) in line.match_indices("docs/") {
        let before = line[..at].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || "_-./".contains(c)) {
            continue;
        }
        let tail = &line[at..];
        let end = tail
            .find(|c: char| !(c.is_alphanumeric() || "_-./".contains(c)))
            .unwrap_or(tail.len());
        let path = tail[..end].trim_end_matches('.');
        if path.ends_with(".md") {
            out.push(path);
        }
    }
    out
}

#[test]
fn tidy_the_docs_cite_only_files_that_exist() {
    let root = workspace_root();
    let mut problems = Vec::new();
    let md = files(&root, &[".md"]);
    for file in &md {
        let path = rel(&root, file);
        let text = read(file);
        let dir = file.parent().expect("a folder");
        let mut fence = false;
        for (i, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("```") {
                fence = !fence;
            }
            if fence {
                continue;
            }
            for target in link_targets(line) {
                if target.contains("://") || target.starts_with("mailto:") || target.is_empty() {
                    continue;
                }
                let (file_part, anchor) = target.split_once('#').unwrap_or((target, ""));
                let linked = if file_part.is_empty() {
                    file.clone()
                } else {
                    dir.join(file_part)
                };
                if !linked.exists() {
                    problems.push(format!(
                        "{path}:{}: the link `{target}` points to {}, which the repository does not hold: point it to a file that exists (docs/architecture.md, docs/file-formats.md, ...) or cite a vendor spec by file name and section",
                        i + 1,
                        rel(&root, &linked)
                    ));
                    continue;
                }
                if !anchor.is_empty()
                    && linked.extension().is_some_and(|e| e == "md")
                    && !anchors(&read(&linked)).contains(anchor)
                {
                    problems.push(format!(
                        "{path}:{}: the link `{target}`: {} has no heading with the anchor `#{anchor}`: link a heading it has",
                        i + 1,
                        rel(&root, &linked)
                    ));
                }
            }
        }
    }
    let rs = files(&root.join("crates"), &[".rs"])
        .into_iter()
        .chain(files(&root.join("tests"), &[".rs"]));
    for file in md.iter().cloned().chain(rs) {
        let path = rel(&root, &file);
        for (i, line) in read(&file).lines().enumerate() {
            for mention in docs_mentions(line) {
                if !root.join(mention).is_file() {
                    problems.push(format!(
                        "{path}:{}: `{mention}` names a file the repository does not hold: name one under docs/ that exists",
                        i + 1
                    ));
                }
            }
        }
    }
    report("citations in the docs", &problems);
}

#[test]
fn tidy_no_reference_to_design_notes_outside_the_repository() {
    let root = workspace_root();
    // spelled in pieces so that this file does not hold them itself
    let design = concat!("DESIGN", ".md");
    let outside = [concat!("shared", "/specs/"), concat!("/work", "/")];
    let mut problems = Vec::new();
    let text_files = files(
        &root,
        &[
            ".rs", ".md", ".toml", ".txt", ".sh", ".py", ".js", ".json", ".yml", ".yaml",
        ],
    );
    for file in text_files {
        let path = rel(&root, &file);
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue; // not UTF-8: no prose to check
        };
        // the schema files' comments are hashed into their fingerprints
        // (journals record them), so their spec paths stay as written
        let check_outside = path.ends_with(".md") || path.ends_with(".rs");
        for (i, line) in text.lines().enumerate() {
            if line.contains(design) {
                problems.push(format!(
                    "{path}:{}: names {design}, which the repository does not hold: cite the repository's own docs (docs/architecture.md, docs/journals.md, ...) instead",
                    i + 1
                ));
            }
            if let Some(o) = outside.iter().find(|o| check_outside && line.contains(**o)) {
                problems.push(format!(
                    "{path}:{}: names a path outside the repository (`{o}`): cite a vendor spec by its file name and section, and the repository's files by their path in it",
                    i + 1
                ));
            }
        }
    }
    report("references outside the repository", &problems);
}

/// The helpers the checks stand on: test modules (and a module named by the
/// caller) skipped to their closing brace, GitHub's anchors, link targets and
/// `docs/` mentions.
#[test]
fn tidy_the_source_and_link_readers() {
    let src = [
        "use a;",
        "mod store {",
        "    fn f() {",
        "    }",
        "}",
        "fn g() {}",
        "#[cfg(test)]",
        "#[allow(dead_code)]",
        "mod tests {",
        "    use std::fs;",
        "}",
        "fn h() {}",
    ];
    assert_eq!(skipped_blocks(&src, None), [(6, 10)]);
    assert_eq!(skipped_blocks(&src, Some("store")), [(1, 4), (6, 10)]);
    assert_eq!(
        slug(" Changing the rate on an open port (`--transfer-baud`)"),
        "changing-the-rate-on-an-open-port---transfer-baud"
    );
    let a = anchors("# A\n## The bus\n```\n# not a heading\n```\n## The bus\n#hashtag\n");
    assert_eq!(
        a.into_iter().collect::<Vec<_>>(),
        ["a", "the-bus", "the-bus-1"]
    );
    assert_eq!(
        link_targets("see [x](ports.md#a \"t\") and [y](../TESTING.md), (z)"),
        ["ports.md#a", "../TESTING.md"]
    );
    // built with format! so that this file names no missing docs itself
    let line = format!(
        "{d}a.md, ({d}errata/b.md). ../{d}c.md x{d}d.md {d}e.txt",
        d = "docs/"
    );
    assert_eq!(
        docs_mentions(&line),
        [concat!("docs", "/a.md"), concat!("docs", "/errata/b.md")]
    );
}

/// The upload runner's folder, which names nothing of the transfer-rate
/// switch (docs/architecture.md, "Crates and their arrows": the switch
/// wraps an upload, never the other way round; what both carry, the
/// transfer report, is `driveset_engine::rate_report`'s).
const UPLOAD_DIR: &str = "crates/driveset-engine/src/upload";

/// The lines of `text` (the file `path`) that name the `transfer` module:
/// a path through it (`transfer::`) or to it (`::transfer`), comments
/// included, since a doc link to it is a reference as well.
fn transfer_mentions(path: &str, text: &str) -> Vec<String> {
    fn ident(c: char) -> bool {
        c.is_alphanumeric() || c == '_'
    }
    let names_it = |line: &str| {
        line.match_indices("transfer").any(|(i, w)| {
            let before = &line[..i];
            let after = &line[i + w.len()..];
            let whole = !before.ends_with(ident) && !after.starts_with(ident);
            whole && (before.ends_with("::") || after.starts_with("::"))
        })
    };
    text.lines()
        .enumerate()
        .filter(|(_, l)| names_it(l))
        .map(|(i, l)| {
            format!(
                "{path}:{}: names the transfer-rate switch (`{}`): upload/ knows nothing of it; put what both need beside them (`rate_report.rs`)",
                i + 1,
                l.trim()
            )
        })
        .collect()
}

#[test]
fn tidy_upload_does_not_name_the_transfer_switch() {
    let root = workspace_root();
    let dir = root.join(UPLOAD_DIR);
    let sources = files(&dir, &[".rs"]);
    assert!(!sources.is_empty(), "{UPLOAD_DIR}: no sources");
    let mut problems = Vec::new();
    for f in sources {
        problems.extend(transfer_mentions(&rel(&root, &f), &read(&f)));
    }
    report("upload/ names crate::transfer", &problems);
}

/// The check itself: a `use` of the module, a path through it and a doc
/// link to it are found; a field, a report type and a word are not.
#[test]
fn tidy_the_transfer_check_sees_a_use_of_transfer() {
    let text = "use crate::transfer::TransferReport;\nuse crate::transfer;\n/// see [`crate::transfer`]\nlet t = driveset_engine::transfer::decide(c, r, &[], &[]);\nself.opts.transfer.clone();\nuse crate::rate_report::TransferReport;\n// the transfer rate: transfer_rate, retransfer::x\n";
    let found = transfer_mentions("u.rs", text);
    let lines: Vec<&str> = found
        .iter()
        .map(|p| p.split(": names").next().expect("line"))
        .collect();
    assert_eq!(
        lines,
        ["u.rs:1", "u.rs:2", "u.rs:3", "u.rs:4"],
        "{found:#?}"
    );
}
