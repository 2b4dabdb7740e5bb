//! Nothing points up: each crate's `[dependencies]` follow the arrows of
//! docs/architecture.md, "Crates and their arrows".

use std::path::{Path, PathBuf};

use driveset_test_support::workspace_root;

use super::{read, rel, report};

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
    // the reports (JSON, HTML, JUnit, textconv): engine's report, schema
    ("driveset-report", &["driveset-engine", "driveset-schema"]),
    // the editor's analysis (plain data); the language server is the CLI's
    (
        "driveset-ide",
        &["driveset-engine", "driveset-link", "driveset-schema"],
    ),
    // the LSP base protocol as a codec (frames in, frames out); the
    // language server is the CLI's
    ("driveset-lsp-base", &[]),
    (
        "driveset-cli",
        &[
            "driveset-report",
            "driveset-engine",
            "driveset-history",
            "driveset-twin",
            "driveset-ide",
            "driveset-lsp-base",
            "driveset-sim",
            "driveset-link",
            "driveset-proto",
            "driveset-schema",
        ],
    ),
    // dev-only: only ever a dev-dependency (nobody lists it above)
    (
        "driveset-test-support",
        &["driveset-link", "driveset-schema", "driveset-sim"],
    ),
];

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
            "{path}:1: crate `{name}` is not among docs/architecture.md's arrows: draw it there (\"Crates and their arrows\") and add it to ARROWS in tests/integration/tidy/arrows.rs"
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
            "crates/x/Cargo.toml:1: crate `driveset-x` is not among docs/architecture.md's arrows: draw it there (\"Crates and their arrows\") and add it to ARROWS in tests/integration/tidy/arrows.rs"
        ]
    );
}
