//! The smaller cases of issue 29 and the one writer's promises, through
//! the built binary: outputs follow a symlink and keep the file's mode;
//! a twin that is a FIFO (`sim --twin`, `sim://twin?file=`, a rehearsal's
//! twin directory) is an error naming it, not a hang or "no twin"; after
//! a refused SLOAD = -1 where every code holds its old value the upload
//! says rolled back, not "a mix"; `address --protocol can` names `can`;
//! a twin captured again through `?latency=` is kept byte for byte.
//! Timeouts are hang guards only.
#![cfg(unix)]

use std::os::unix::fs::PermissionsExt as _;
use std::path::Path;
use std::time::Duration;

use driveset_test_support::{driveset, mkfifo, outcome, workspace_root};

use crate::e2e_pty::Sim;

const GUARD: Duration = Duration::from_secs(60);

fn run(dir: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let mut c = driveset();
    c.current_dir(dir)
        .env("DRIVESET_LOCK_DIR", dir.join("locks"))
        .env("DRIVESET_SIM_STATE_DIR", dir.join("sim"))
        .args(args)
        .timeout(GUARD);
    outcome(&mut c)
}

#[test]
fn pull_and_twin_capture_write_through_a_symlink_and_keep_the_mode() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, file) in [
        (
            &[
                "pull",
                "--port",
                "sim://tmd?addresses=1",
                "--address",
                "1",
                "-o",
                "link.toml",
            ][..],
            "real.toml",
        ),
        (
            &[
                "twin",
                "capture",
                "--port",
                "sim://tmd?addresses=1",
                "--address",
                "1",
                "-o",
                "link.twin.toml",
            ][..],
            "real.twin.toml",
        ),
    ] {
        let link = args.last().unwrap();
        std::fs::write(d.join(file), "old\n").unwrap();
        std::fs::set_permissions(d.join(file), std::fs::Permissions::from_mode(0o640)).unwrap();
        std::os::unix::fs::symlink(file, d.join(link)).unwrap();
        let (code, stdout, stderr) = run(d, args);
        assert_eq!(code, Some(0), "{args:?}: {stdout}{stderr}");
        let meta = std::fs::symlink_metadata(d.join(link)).unwrap();
        assert!(meta.file_type().is_symlink(), "{link} replaced by a file");
        let text = std::fs::read_to_string(d.join(file)).unwrap();
        assert!(text.len() > 100 && !text.starts_with("old"), "{text}");
        let mode = std::fs::metadata(d.join(file))
            .unwrap()
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(mode, 0o640, "{file}");
    }
    // no temporary file left beside them (`.driveset` holds the plant
    // history both runs are recorded in: docs/history.md)
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && n != ".driveset")
        .collect();
    names.sort();
    assert_eq!(names, Vec::<String>::new());
}

#[test]
fn a_twin_that_is_a_fifo_is_named_in_sim_sim_ports_and_a_rehearsal() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    mkfifo(&d.join("t.twin.toml"));
    let named = |text: &str| {
        text.contains("t.twin.toml is a FIFO (named pipe), not a regular file; driveset reads twin files from regular files only")
    };
    let (code, out, err) = run(d, &["sim", "--twin", "t.twin.toml"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(named(&err), "{err}");
    let (code, out, err) = run(
        d,
        &[
            "pull",
            "--port",
            "sim://twin?file=t.twin.toml",
            "--address",
            "1",
            "-o",
            "x.toml",
        ],
    );
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(named(&err), "{err}");
    assert!(!d.join("x.toml").exists());
    // a rehearsal: the twin of drive `conveyor-5` is a FIFO in the twin
    // directory: an error naming it, not "no twin"
    let twins = d.join("twins");
    std::fs::create_dir(&twins).unwrap();
    for e in std::fs::read_dir(workspace_root().join("examples/ci/twins")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), twins.join(e.file_name())).unwrap();
    }
    std::fs::remove_file(twins.join("conveyor-5.twin.toml")).unwrap();
    mkfifo(&twins.join("conveyor-5.twin.toml"));
    let manifest = workspace_root().join("parameter-sets/demo-line/line.toml");
    let (code, out, err) = run(
        d,
        &[
            "commission",
            manifest.to_str().unwrap(),
            "--rehearse",
            twins.to_str().unwrap(),
        ],
    );
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(
        err.contains("conveyor-5.twin.toml is a FIFO (named pipe), not a regular file"),
        "{out}{err}"
    );
}

#[test]
fn address_protocol_can_is_refused_by_its_own_name() {
    let dir = tempfile::tempdir().unwrap();
    let (code, out, err) = run(
        dir.path(),
        &[
            "address",
            "--port",
            "sim://ecs",
            "--protocol",
            "can",
            "--to",
            "5",
        ],
    );
    assert_eq!(code, Some(2), "{out}");
    assert_eq!(
        err,
        "error: --protocol can: driveset address sets LUSTBUS and LECOM addresses; a CAN node id is set on the drive\n"
    );
}

#[test]
fn a_refused_sload_with_every_code_old_is_a_rollback_not_a_mix() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let port = "sim://mc6000?addresses=1&state=st.json";
    let (code, out, err) = run(d, &["identify", "--port", port, "--address", "1"]);
    assert_eq!(code, Some(0), "{out}{err}");
    // the drive runs (416-SCTL1 bit 0): SLOAD = -1 is refused (NAK 40H)
    let mut state: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("st.json")).unwrap()).unwrap();
    let canonical = state["drives"][0]["canonical"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(canonical.contains("\n416 0\n"), "{canonical}");
    state["drives"][0]["canonical"] = canonical.replace("\n416 0\n", "\n416 1\n").into();
    std::fs::write(d.join("st.json"), serde_json::to_vec(&state).unwrap()).unwrap();
    // the simulator's fixture, named by its file (a set cannot name a
    // fixture by id, on any port)
    let fixture = workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml");
    std::fs::write(
        d.join("s.toml"),
        format!(
            "schema = {:?}\n[values]\nMAINV = 420\n",
            fixture.display().to_string()
        ),
    )
    .unwrap();
    let (code, out, err) = run(
        d,
        &[
            "upload",
            "s.toml",
            "--port",
            port,
            "--address",
            "1",
            "--allow-running",
        ],
    );
    assert_eq!(code, Some(3), "{out}{err}");
    assert!(!err.contains("mix of old and new"), "{err}");
    assert!(
        err.contains(": the upload did not land and was rolled back: "),
        "{err}"
    );
    assert!(
        err.contains("; every code reads back its old value); the drive holds its old values again (verified); journal "),
        "{err}"
    );
    assert!(
        out.contains(" address 1: rolled-back (0 of 1 codes written"),
        "{out}"
    );
    let after: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("st.json")).unwrap()).unwrap();
    assert!(
        after["drives"][0]["canonical"]
            .as_str()
            .unwrap()
            .contains("\n101 400\n"),
        "MAINV keeps its old value"
    );
}

#[test]
fn a_twin_captured_again_through_latency_is_kept_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut sim = Sim::start_tcp(d, "tmd", 1, &["--c0001", "3"]);
    let port = format!("tcp://{}", sim.path);
    let (code, out, err) = run(
        d,
        &[
            "twin",
            "capture",
            "--port",
            &port,
            "--address",
            "1",
            "-o",
            "t.twin.toml",
        ],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    let first = std::fs::read(d.join("t.twin.toml")).unwrap();
    let slow = format!("{port}?latency=240ms");
    let (code, out, err) = run(
        d,
        &[
            "twin",
            "capture",
            "--port",
            &slow,
            "--address",
            "1",
            "-o",
            "t.twin.toml",
        ],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("unchanged since the last capture (file kept)"),
        "{out}"
    );
    assert_eq!(std::fs::read(d.join("t.twin.toml")).unwrap(), first);
    let status = sim.terminate();
    assert!(status.success(), "{}", sim.stderr());
}
