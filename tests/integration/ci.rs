//! `examples/ci/`: the GitHub Actions workflow and the GitLab CI job run
//! locally. Each file is parsed as YAML (the schema crate's reader), the
//! `driveset` commands of its steps (`run:`) or script lines are run with
//! `sh` against the built binary in a copy of the repository's sets and
//! twins, each must exit 0, and every JUnit report the job declares as its
//! test result must exist and parse, with no failure in it.

use std::path::{Path, PathBuf};

use driveset_schema::doc::{Node, NodeKind, Syntax, parse};
use driveset_schema::error::SourceFile;

use driveset_test_support::{copy_dir, workspace_root};

fn yaml(path: &Path) -> Node {
    let text = std::fs::read_to_string(path).unwrap();
    parse(
        SourceFile::new(path.display().to_string(), text),
        Syntax::Yaml,
    )
    .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()))
    .root
}

fn strings(n: &Node) -> Vec<String> {
    match &n.kind {
        NodeKind::Str(s) => s.lines().map(String::from).collect(),
        NodeKind::Array(items) => items.iter().flat_map(strings).collect(),
        _ => Vec::new(),
    }
}

/// Run the `driveset` lines of `commands` in a copy of the repository's
/// sets and twins; then check `reports`.
fn run_job(commands: &[String], reports: &[String]) {
    let driveset: Vec<&String> = commands
        .iter()
        .filter(|c| c.starts_with("driveset "))
        .collect();
    assert_eq!(driveset.len(), 2, "{commands:?}");
    let dir = tempfile::tempdir().unwrap();
    let root = workspace_root();
    copy_dir(
        &root.join("parameter-sets"),
        &dir.path().join("parameter-sets"),
    );
    copy_dir(
        &root.join("examples/ci/twins"),
        &dir.path().join("examples/ci/twins"),
    );
    let bin: PathBuf = driveset_test_support::driveset_bin();
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for c in driveset {
        let out = std::process::Command::new("sh")
            .args(["-c", c])
            .current_dir(dir.path())
            .env("PATH", &path)
            .env_remove("DRIVESET_SIM_STATE_DIR")
            .output()
            .unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "`{c}`: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(reports.len(), 2, "{reports:?}");
    for r in reports {
        let text =
            std::fs::read_to_string(dir.path().join(r)).unwrap_or_else(|e| panic!("{r}: {e}"));
        let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{r}: {e}"));
        let suites = doc.root_element();
        assert_eq!(suites.tag_name().name(), "testsuites", "{r}");
        assert_eq!(suites.attribute("failures"), Some("0"), "{r}: {text}");
        assert!(suites.attribute("tests").is_some_and(|t| t != "0"), "{r}");
    }
}

#[test]
fn the_github_actions_workflow_validates_and_rehearses() {
    let root = yaml(&workspace_root().join("examples/ci/github-actions.yml"));
    let job = &root
        .get("jobs")
        .unwrap()
        .value
        .get("rehearse")
        .unwrap()
        .value;
    let NodeKind::Array(steps) = &job.get("steps").unwrap().value.kind else {
        panic!("steps is a list")
    };
    let commands: Vec<String> = steps
        .iter()
        .filter_map(|s| s.get("run"))
        .flat_map(|e| strings(&e.value))
        .collect();
    let reports: Vec<String> = steps
        .iter()
        .filter_map(|s| s.get("with"))
        .filter_map(|w| w.value.get("report_paths"))
        .flat_map(|e| strings(&e.value))
        .collect();
    run_job(&commands, &reports);
}

#[test]
fn the_gitlab_ci_job_validates_and_rehearses() {
    let root = yaml(&workspace_root().join("examples/ci/gitlab-ci.yml"));
    let job = &root.get("rehearse").unwrap().value;
    let commands = strings(&job.get("script").unwrap().value);
    let reports = strings(
        &job.get("artifacts")
            .unwrap()
            .value
            .get("reports")
            .unwrap()
            .value
            .get("junit")
            .unwrap()
            .value,
    );
    run_job(&commands, &reports);
}
