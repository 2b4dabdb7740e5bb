//! Rendering for reviewers, browsers and CI: the commissioning report of a
//! line run (`report.json` + a self-contained `report.html`), the git
//! commit of the sets ([`git_info`]), JUnit XML of validation findings
//! ([`junit`]) and the line-oriented semantic view of a set file that
//! `git diff` shows through the `driveset` textconv driver ([`textconv`]).

pub mod html;
pub mod junit;
pub mod textconv;

use std::io;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

pub use driveset_engine::line::report::{GitInfo, LineReport};

/// Arguments of the hidden `driveset report` (render a saved report again).
#[derive(clap::Args)]
pub struct Args {
    /// A report.json written by `driveset commission` / `status`.
    #[arg(value_name = "REPORT_JSON")]
    pub input: PathBuf,
    /// Folder to write report.json and report.html into [default: the input's folder].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Run `driveset report`: read a report.json, write report.json + report.html.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let text = match driveset_schema::input::read_input(
        &args.input,
        driveset_schema::input::InputKind::REPORT,
    )
    .map(|b| String::from_utf8_lossy(&b).into_owned())
    {
        Ok(t) => t,
        Err(e) => {
            return Err(crate::fail::Fail::input(format!(
                "{}\n  = help: {}",
                e.message, e.help
            )));
        }
    };
    let report: LineReport = match serde_json::from_str(&text) {
        Ok(r) => r,
        Err(e) => {
            return Err(crate::fail::Fail::input(format!(
                "{}: not a line report: {e}\n  = help: give the report.json that `driveset commission` wrote",
                args.input.display()
            )));
        }
    };
    let dir = args.out.clone().unwrap_or_else(|| {
        args.input
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    });
    let (json, html) = write_reports(&report, &dir)?;
    outln!("{}\n{}", json.display(), html.display());
    Ok(crate::EXIT_OK)
}

/// File name of the machine-readable report.
pub const JSON_NAME: &str = "report.json";
/// File name of the HTML report.
pub const HTML_NAME: &str = "report.html";

/// Write `report.json` (the serde form of `report`) and `report.html` (a
/// self-contained page: inline CSS and SVG, no scripts, no external assets)
/// into `dir`, creating it if needed. Each file is written to a temporary
/// name and renamed into place, so a reader never sees half a report.
/// Returns the paths of the JSON and the HTML file.
pub fn write_reports(report: &LineReport, dir: &Path) -> io::Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir)?;
    let mut json = serde_json::to_string_pretty(report).map_err(io::Error::other)?;
    json.push('\n');
    let json_path = dir.join(JSON_NAME);
    write_atomic(&json_path, json.as_bytes())?;
    let html_path = dir.join(HTML_NAME);
    write_atomic(&html_path, html::render(report).as_bytes())?;
    Ok((json_path, html_path))
}

/// Write `bytes` to `path` through the one writer
/// (`driveset_schema::output`: temporary name, fsync, rename).
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    driveset_schema::output::write_output(path, bytes)
        .map_err(|e| io::Error::other(format!("{}; {}", e.message, e.help)))
}

/// The git commit of the sets: `git rev-parse HEAD` and `git status
/// --porcelain` (tracked files only) run in `manifest_dir` (the directory of
/// the line manifest; an empty path means the current directory). `None`
/// outside a git work tree, in a repository without commits, or when git is
/// not installed.
pub fn git_info(manifest_dir: &Path) -> Option<GitInfo> {
    let dir = if manifest_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        manifest_dir
    };
    let commit = git_output(dir, &["rev-parse", "--verify", "-q", "HEAD"])?;
    let commit = commit.trim().to_string();
    if commit.is_empty() || !commit.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let status = git_output(dir, &["status", "--porcelain", "--untracked-files=no"])?;
    Some(GitInfo {
        commit,
        dirty: !status.trim().is_empty(),
    })
}

/// stdout of `git ARGS` in `dir`, or `None` when git fails or is missing.
pub(crate) fn git_output(dir: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        // a report must not take index locks in someone's work tree
        .env("GIT_OPTIONAL_LOCKS", "0")
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    String::from_utf8(out.stdout).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn git(dir: &Path, args: &[&str]) {
        let ok = Command::new("git")
            .arg("-C")
            .arg(dir)
            .args(args)
            .env("GIT_CONFIG_GLOBAL", "/dev/null")
            .env("GIT_CONFIG_NOSYSTEM", "1")
            .output()
            .unwrap()
            .status
            .success();
        assert!(ok, "git {args:?}");
    }

    #[test]
    fn git_info_reads_head_and_dirty_state() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        assert!(git_info(&d.join("does-not-exist")).is_none());
        git(d, &["init", "-q"]);
        // a repository without commits has no HEAD commit
        assert!(git_info(d).is_none());
        std::fs::write(d.join("line.toml"), "name = \"l\"\n").unwrap();
        git(d, &["add", "line.toml"]);
        git(
            d,
            &[
                "-c",
                "user.name=t",
                "-c",
                "user.email=t@example.invalid",
                "commit",
                "-q",
                "-m",
                "m",
            ],
        );
        let clean = git_info(d).unwrap();
        assert_eq!(clean.commit.len(), 40);
        assert!(!clean.dirty);
        // untracked files do not make it dirty; a changed tracked file does
        std::fs::write(d.join("other.toml"), "x").unwrap();
        assert!(!git_info(d).unwrap().dirty);
        std::fs::write(d.join("line.toml"), "name = \"m\"\n").unwrap();
        let dirty = git_info(d).unwrap();
        assert!(dirty.dirty);
        assert_eq!(dirty.commit, clean.commit);
    }
}
