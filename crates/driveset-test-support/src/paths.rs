//! The workspace root and the files tests read or copy from it.

use std::path::{Path, PathBuf};

/// The workspace root (where `schemas/` and `parameter-sets/` live),
/// canonical.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the workspace root (two folders above driveset-test-support) exists")
}

/// Copy the directory tree `from` to `to` (created).
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("create {}: {e}", to.display()));
    let entries =
        std::fs::read_dir(from).unwrap_or_else(|e| panic!("read {}: {e}", from.display()));
    for e in entries {
        let e = e.unwrap_or_else(|e| panic!("read {}: {e}", from.display()));
        let target = to.join(e.file_name());
        let is_dir = e
            .file_type()
            .unwrap_or_else(|err| panic!("{}: {err}", e.path().display()))
            .is_dir();
        if is_dir {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap_or_else(|err| {
                panic!("copy {} to {}: {err}", e.path().display(), target.display())
            });
        }
    }
}

/// The files of `dir` whose name starts with `prefix` and ends `.toml`
/// (learned schemas), sorted.
pub fn toml_files_starting(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("read {}: {e}", dir.display()))
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix) && n.ends_with(".toml"))
        })
        .collect();
    v.sort();
    v
}

/// The regular files directly in `dir` (a fuzz target's seed corpus), as
/// (file name, contents), sorted by name.
pub fn files_in(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| {
            entry
                .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
                .path()
        })
        .filter(|p| p.is_file())
        .map(|path| {
            let name = path
                .file_name()
                .expect("a file name")
                .to_string_lossy()
                .into_owned();
            let data = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            (name, data)
        })
        .collect();
    files.sort();
    files
}

/// A FIFO at `path` (`mkfifo`): an input that would block a reader that
/// opened it.
pub fn mkfifo(path: &Path) {
    let st = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(st.success(), "mkfifo {}", path.display());
}

/// A fresh temporary directory holding an empty `sim/`: the state folder
/// of the simulated drives of a `driveset_in(dir)` run.
pub fn sim_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("a temporary directory");
    std::fs::create_dir_all(dir.path().join("sim")).expect("create sim/");
    dir
}

/// [`sim_dir`] with the demo line's sets and the fixture schemas copied
/// under `ps/` (`ps/demo-line/`, `ps/fixtures/`), for a test that edits
/// them.
pub fn demo_line_dir() -> tempfile::TempDir {
    let dir = sim_dir();
    let d = dir.path();
    copy_dir(
        &workspace_root().join("parameter-sets/demo-line"),
        &d.join("ps/demo-line"),
    );
    copy_dir(
        &workspace_root().join("parameter-sets/fixtures"),
        &d.join("ps/fixtures"),
    );
    dir
}
