//! Shared helpers for the integration tests.

#![allow(dead_code)]

use std::path::PathBuf;

/// The workspace root (where `schemas/` and `parameter-sets/` live).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("workspace root")
}

/// A `driveset` command, run from the workspace root.
pub fn driveset() -> assert_cmd::Command {
    let mut cmd = assert_cmd::Command::cargo_bin("driveset").expect("driveset binary");
    cmd.current_dir(workspace_root());
    cmd
}
