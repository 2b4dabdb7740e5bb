//! The built `driveset` binary under assert_cmd, from the workspace root
//! or from a test's temporary directory.

use std::path::Path;

use assert_cmd::Command;

use crate::paths::workspace_root;

/// A `driveset` command, run from the workspace root.
pub fn driveset() -> Command {
    let mut cmd = Command::cargo_bin("driveset")
        .expect("the driveset binary (built by cargo for the CLI's integration tests)");
    cmd.current_dir(workspace_root());
    cmd
}

/// `driveset` from the workspace root, its simulated drives' state in
/// `DIR/sim` (`DRIVESET_SIM_STATE_DIR`).
pub fn driveset_with_sim_state(dir: &Path) -> Command {
    let mut c = driveset();
    c.env("DRIVESET_SIM_STATE_DIR", dir.join("sim"));
    c
}

/// `driveset` run in `dir`, nothing else changed (a test whose `sim://`
/// ports name their own `state=` files).
pub fn driveset_at(dir: &Path) -> Command {
    let mut c = driveset();
    c.current_dir(dir);
    c
}

/// `driveset` run in `dir` (journals, reports and learned files land
/// there), its simulated drives' state in `DIR/sim`.
pub fn driveset_in(dir: &Path) -> Command {
    let mut c = driveset_with_sim_state(dir);
    c.current_dir(dir);
    c
}

/// `driveset` run in `dir` with its bus locks in `DIR/locks`
/// (`DRIVESET_LOCK_DIR`) and no simulator state directory: a `sim://`
/// port's own `state=` file is the only state.
pub fn driveset_in_with_locks(dir: &Path) -> Command {
    let mut c = driveset();
    c.current_dir(dir)
        .env("DRIVESET_LOCK_DIR", dir.join("locks"))
        .env_remove("DRIVESET_SIM_STATE_DIR");
    c
}

/// The path of the built `driveset` binary, for a [`std::process::Command`]
/// a test spawns itself (a server it talks to while it runs).
pub fn driveset_bin() -> std::path::PathBuf {
    assert_cmd::cargo::cargo_bin("driveset")
}

/// Run `cmd` to its end: (exit code, stdout, stderr), the output as text.
pub fn outcome(cmd: &mut Command) -> (Option<i32>, String, String) {
    let o = cmd.output().expect("run driveset");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `driveset sim ARGS` started in the background (stdin closed, stdout
/// piped for its first line, stderr to `stderr`), killed when dropped.
pub fn driveset_sim<S: AsRef<std::ffi::OsStr>>(
    args: &[S],
    stderr: std::process::Stdio,
) -> crate::Spawned {
    use std::process::Stdio;
    let child = std::process::Command::new(driveset_bin())
        .arg("sim")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(stderr)
        .spawn()
        .expect("start driveset sim");
    crate::Spawned::new(child, "driveset sim")
}
