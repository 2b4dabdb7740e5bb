//! Inputs of a line manifest and its buses (issue 29), through the built
//! binary: a `set =` that is a FIFO, a directory, a device or a symlink
//! loop is named as such by `validate`, `commission` and the language
//! server alike (not "does not exist"); two buses of one manifest whose
//! ports reach one device (a device server by name and by its IPv4-mapped
//! address, a tty by a symlink and by a `..` path) are a `validate`
//! finding. Timeouts are hang guards only.
#![cfg(unix)]

use std::path::Path;
use std::time::Duration;

use driveset_test_support::{driveset, mkfifo};

const GUARD: Duration = Duration::from_secs(60);

const SPECIAL_SETS: &str = r#"[[bus]]
name = "a"
port = "sim://tmd?c0001=3"
protocol = "lecom"

[[drive]]
name = "one"
bus = "a"
address = 1
set = "fifo.toml"

[[drive]]
name = "two"
bus = "a"
address = 2
set = "dir.toml"

[[drive]]
name = "three"
bus = "a"
address = 3
set = "zero.toml"

[[drive]]
name = "four"
bus = "a"
address = 4
set = "loop.toml"
"#;

/// What each set path is, as every reader of the manifest names it.
const NAMED: [&str; 4] = [
    "set file `fifo.toml` cannot be read: fifo.toml is a FIFO (named pipe), not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only",
    "set file `dir.toml` cannot be read: dir.toml is a directory, not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only",
    "set file `zero.toml` cannot be read: zero.toml is a character device, not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only",
    "set file `loop.toml` cannot be read: loop.toml is a symlink loop, not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only",
];

fn special_sets(dir: &Path) {
    mkfifo(&dir.join("fifo.toml"));
    std::fs::create_dir(dir.join("dir.toml")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.toml")).unwrap();
    std::os::unix::fs::symlink("loop.toml", dir.join("loop.toml")).unwrap();
    std::fs::write(dir.join("line.toml"), SPECIAL_SETS).unwrap();
}

#[test]
fn manifest_sets_that_are_no_regular_files_are_named_in_validate_commission_and_lsp() {
    let dir = tempfile::tempdir().unwrap();
    special_sets(dir.path());
    for args in [
        &["validate", "line.toml"][..],
        &["commission", "line.toml"][..],
    ] {
        let out = driveset()
            .current_dir(dir.path())
            .env("DRIVESET_LOCK_DIR", dir.path().join("locks"))
            .args(args)
            .timeout(GUARD)
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        let want = if args[0] == "validate" { 1 } else { 2 };
        assert_eq!(out.status.code(), Some(want), "{args:?}: {text}");
        for n in NAMED {
            assert!(text.contains(n), "{args:?}: {n}\n{text}");
        }
        assert!(!text.contains("does not exist"), "{text}");
    }
    // the language server, on the manifest
    let cache = tempfile::tempdir().unwrap();
    let mut c = crate::lsp::Client::start(cache.path());
    let diags = c.open(&dir.path().join("line.toml"), SPECIAL_SETS);
    let messages: Vec<String> = diags
        .iter()
        .map(|d| {
            // the server names files by their absolute path
            d["message"]
                .as_str()
                .unwrap_or_default()
                .replace(&format!("{}/", dir.path().display()), "")
        })
        .collect();
    for n in NAMED {
        assert!(
            messages.iter().any(|m| m.starts_with(n)),
            "{n}\n{messages:#?}"
        );
    }
    c.shutdown();
}

#[test]
fn validate_reports_two_buses_of_one_manifest_that_reach_one_device() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("ttyX"), "").unwrap();
    std::os::unix::fs::symlink("ttyX", d.join("link")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    std::fs::copy(
        driveset_test_support::workspace_root().join("parameter-sets/tmd/conveyor-3.toml"),
        d.join("set.toml"),
    )
    .unwrap();
    let link = d.join("link").display().to_string();
    let dotdot = d.join("sub/../ttyX").display().to_string();
    let mut m = String::new();
    for (name, port) in [
        ("a", "tcp://localhost:4901"),
        ("b", "tcp://[::ffff:127.0.0.1]:4901"),
        ("c", link.as_str()),
        ("e", dotdot.as_str()),
    ] {
        m.push_str(&format!(
            "[[bus]]\nname = \"{name}\"\nport = \"{port}\"\nprotocol = \"lecom\"\n\n[[drive]]\nname = \"{name}1\"\nbus = \"{name}\"\naddress = 11\nset = \"set.toml\"\n\n"
        ));
    }
    std::fs::write(d.join("line.toml"), m).unwrap();
    let out = driveset()
        .current_dir(d)
        .args(["validate", "line.toml"])
        .timeout(GUARD)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    let real = std::fs::canonicalize(d.join("ttyX")).unwrap();
    for want in [
        "buses `a` (tcp://localhost:4901) and `b` (tcp://[::ffff:127.0.0.1]:4901) reach one device (tcp:127.0.0.1:4901)".to_string(),
        format!("buses `c` ({link}) and `e` ({dotdot}) reach one device (device:{})", real.display()),
    ] {
        assert!(text.contains(&want), "{want}\n{text}");
    }
    assert_eq!(
        text.matches("= help: one device is one bus: put the drives of both on one [[bus]]")
            .count(),
        2,
        "{text}"
    );
}
