//! The one place the CLI runs `git` for facts: the commit of the sets a
//! line run records ([`info`], through the engine's environment) and the
//! tracked files the textconv view anchors a set at ([`tracked_files`]).
//! `git-setup` runs git to configure it (`cmd/git_setup.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use driveset_report::GitInfo;

/// The git commit of the sets: `git rev-parse HEAD` and `git status
/// --porcelain` (tracked files only) run in `manifest_dir` (the directory of
/// the line manifest; an empty path means the current directory). `None`
/// outside a git work tree, in a repository without commits, or when git is
/// not installed.
pub fn info(manifest_dir: &Path) -> Option<GitInfo> {
    let dir = if manifest_dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        manifest_dir
    };
    let commit = output(dir, &["rev-parse", "--verify", "-q", "HEAD"])?;
    let commit = commit.trim().to_string();
    if commit.is_empty() || !commit.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let status = output(dir, &["status", "--porcelain", "--untracked-files=no"])?;
    Some(GitInfo {
        commit,
        dirty: !status.trim().is_empty(),
    })
}

/// stdout of `git ARGS` in `dir`, or `None` when git fails or is missing.
pub fn output(dir: &Path, args: &[&str]) -> Option<String> {
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

/// The tracked files of the repository git runs in here (`git ls-files`
/// joined to `git rev-parse --show-toplevel`); none outside one or
/// without git.
pub fn tracked_files() -> Vec<PathBuf> {
    let Some(listed) = output(Path::new("."), &["ls-files", "-z", "--full-name"]) else {
        return Vec::new();
    };
    let Some(top) = output(Path::new("."), &["rev-parse", "--show-toplevel"]) else {
        return Vec::new();
    };
    let top = PathBuf::from(top.trim_end_matches('\n'));
    listed
        .split('\0')
        .filter(|f| !f.is_empty())
        .map(|f| top.join(f))
        .collect()
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
        assert!(info(&d.join("does-not-exist")).is_none());
        git(d, &["init", "-q"]);
        // a repository without commits has no HEAD commit
        assert!(info(d).is_none());
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
        let clean = info(d).unwrap();
        assert_eq!(clean.commit.len(), 40);
        assert!(!clean.dirty);
        // untracked files do not make it dirty; a changed tracked file does
        std::fs::write(d.join("other.toml"), "x").unwrap();
        assert!(!info(d).unwrap().dirty);
        std::fs::write(d.join("line.toml"), "name = \"m\"\n").unwrap();
        let dirty = info(d).unwrap();
        assert!(dirty.dirty);
        assert_eq!(dirty.commit, clean.commit);
    }
}
