//! `driveset git-setup` + the textconv driver: in a temporary git
//! repository, `git diff` of a changed set file shows the semantic line
//! (code, name, engineering value); .gitattributes keeps existing lines and
//! is not duplicated on a second run; `git show`/`git log -p` of a set that
//! `extends` a base resolve it.

use std::path::Path;
use std::process::Command;

use driveset_test_support::{driveset, workspace_root};

fn git(dir: &Path, args: &[&str]) -> String {
    let out = Command::new("git")
        .current_dir(dir)
        .args(args)
        .env("GIT_CONFIG_GLOBAL", "/dev/null")
        .env("GIT_CONFIG_NOSYSTEM", "1")
        .env("GIT_AUTHOR_NAME", "t")
        .env("GIT_AUTHOR_EMAIL", "t@example.invalid")
        .env("GIT_COMMITTER_NAME", "t")
        .env("GIT_COMMITTER_EMAIL", "t@example.invalid")
        .env("GIT_PAGER", "cat")
        .output()
        .expect("git");
    assert!(
        out.status.success(),
        "git {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn setup_repo() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    git(d, &["init", "-q"]);
    std::fs::write(d.join(".gitattributes"), "*.png binary\n").unwrap();
    let sets = d.join("parameter-sets/tmd");
    std::fs::create_dir_all(&sets).unwrap();
    for f in ["base.toml", "conveyor-3.toml"] {
        std::fs::copy(
            workspace_root().join("parameter-sets/tmd").join(f),
            sets.join(f),
        )
        .unwrap();
    }
    std::fs::write(
        sets.join("pump.yaml"),
        "schema: lenze-tmd\nvalues:\n  C0011: 50 Hz\n  C0034: \"0...10 V\"\n",
    )
    .unwrap();
    driveset()
        .current_dir(d)
        .env("GIT_CONFIG_GLOBAL", "/dev/null")
        .arg("git-setup")
        .assert()
        .success();
    git(d, &["add", "."]);
    git(d, &["commit", "-q", "-m", "sets"]);
    tmp
}

#[test]
fn git_setup_writes_attributes_once_and_local_config() {
    let tmp = setup_repo();
    let d = tmp.path();
    let attrs = std::fs::read_to_string(d.join(".gitattributes")).unwrap();
    assert!(attrs.starts_with("*.png binary\n"), "{attrs}");
    for ext in ["toml", "yaml", "yml"] {
        let line = format!("parameter-sets/**/*.{ext} diff=driveset");
        assert_eq!(attrs.lines().filter(|l| *l == line).count(), 1, "{attrs}");
    }
    driveset()
        .current_dir(d)
        .env("GIT_CONFIG_GLOBAL", "/dev/null")
        .arg("git-setup")
        .assert()
        .success()
        .stdout(predicates::str::contains("up to date"));
    assert_eq!(
        std::fs::read_to_string(d.join(".gitattributes")).unwrap(),
        attrs
    );
    let driver = git(d, &["config", "--local", "--get", "diff.driveset.textconv"]);
    assert!(driver.trim_end().ends_with(" textconv"), "{driver}");
    let attr = git(
        d,
        &["check-attr", "diff", "parameter-sets/tmd/conveyor-3.toml"],
    );
    assert!(attr.contains("diff: driveset"), "{attr}");
}

#[test]
fn git_diff_shows_semantic_lines() {
    let tmp = setup_repo();
    let d = tmp.path();
    let p = d.join("parameter-sets/tmd/conveyor-3.toml");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(
        &p,
        text.replace("C0011 = \"60.0 Hz\"", "C0011 = \"65.5 Hz\""),
    )
    .unwrap();
    let y = d.join("parameter-sets/tmd/pump.yaml");
    let text = std::fs::read_to_string(&y).unwrap();
    std::fs::write(&y, text.replace("\"0...10 V\"", "\"4...20 mA\"")).unwrap();

    let diff = git(d, &["diff"]);
    assert!(
        diff.contains(
            "\n-C0011 maximum_output_frequency = 60 Hz\n+C0011 maximum_output_frequency = 65.5 Hz\n"
        ),
        "{diff}"
    );
    assert!(
        diff.contains("\n-C0034 configuration_analog_input = \"0...10 V\"\n+C0034 configuration_analog_input = \"4...20 mA\"\n"),
        "{diff}"
    );
    // the raw TOML text is not what is shown, and nothing else changed
    assert!(!diff.contains("C0011 = \"65.5 Hz\""), "{diff}");
    assert_eq!(
        diff.lines()
            .filter(|l| l.starts_with("-C") || l.starts_with("+C"))
            .count(),
        4,
        "{diff}"
    );

    // committed history too: `git log -p` runs the driver on temporary copies,
    // and values from the base (`extends = "base.toml"`) are resolved
    git(d, &["commit", "-q", "-am", "faster belt"]);
    let log = git(
        d,
        &[
            "log",
            "-p",
            "-1",
            "--",
            "parameter-sets/tmd/conveyor-3.toml",
        ],
    );
    assert!(
        log.contains("+C0011 maximum_output_frequency = 65.5 Hz\n"),
        "{log}"
    );
    let show = git(d, &["show", "HEAD:parameter-sets/tmd/conveyor-3.toml"]);
    assert!(
        show.contains("C0011 = \"65.5 Hz\""),
        "plain show is the file: {show}"
    );
    let conv = git(
        d,
        &[
            "show",
            "--textconv",
            "HEAD:parameter-sets/tmd/conveyor-3.toml",
        ],
    );
    assert!(conv.contains("extends base.toml\n"), "{conv}");
    // C0034 comes from base.toml only
    assert!(
        conv.contains("C0034 configuration_analog_input = "),
        "{conv}"
    );
}

#[test]
fn textconv_prints_files_that_are_not_sets_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("notes.toml");
    std::fs::write(&p, "[schema]\nid = \"x\"\n").unwrap();
    driveset()
        .arg("textconv")
        .arg(&p)
        .assert()
        .success()
        .stdout("[schema]\nid = \"x\"\n");
}

#[test]
fn git_setup_outside_a_work_tree_needs_global() {
    let tmp = tempfile::tempdir().unwrap();
    driveset()
        .current_dir(tmp.path())
        .env("GIT_CEILING_DIRECTORIES", tmp.path().parent().unwrap())
        .env("GIT_CONFIG_GLOBAL", "/dev/null")
        .arg("git-setup")
        .assert()
        .code(2)
        .stderr(predicates::str::contains("not inside a git work tree"));
}

#[test]
fn pre_commit_example_checks_the_staged_sets() {
    let tmp = setup_repo();
    let d = tmp.path();
    let hook = d.join(".git/hooks/pre-commit");
    std::fs::copy(workspace_root().join("examples/pre-commit"), &hook).unwrap();
    let bin = driveset_test_support::driveset_bin();
    let commit = |msg: &str| {
        Command::new("git")
            .current_dir(d)
            .args(["commit", "-q", "-m", msg])
            .env("GIT_CONFIG_GLOBAL", "/dev/null")
            .env("GIT_CONFIG_NOSYSTEM", "1")
            .env("GIT_AUTHOR_NAME", "t")
            .env("GIT_AUTHOR_EMAIL", "t@example.invalid")
            .env("GIT_COMMITTER_NAME", "t")
            .env("GIT_COMMITTER_EMAIL", "t@example.invalid")
            .env("DRIVESET", &bin)
            .output()
            .unwrap()
    };
    let p = d.join("parameter-sets/tmd/conveyor-3.toml");
    let good = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, good.replace("\"60.0 Hz\"", "\"999 Hz\"")).unwrap();
    git(d, &["add", "-A"]);
    // fixed in the work tree but not staged: the staged copy is checked
    std::fs::write(&p, good.replace("\"60.0 Hz\"", "\"61 Hz\"")).unwrap();
    let out = commit("bad");
    // git sends a hook's stdout to stderr
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{said}");
    assert!(
        said.contains("parameter-sets/tmd/conveyor-3.toml:12:9"),
        "{said}"
    );
    git(d, &["add", "-A"]);
    let out = commit("good");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
