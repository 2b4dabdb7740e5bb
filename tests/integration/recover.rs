//! `driveset recover` from a journal an interrupted upload left: the cable
//! of the simulated bus is pulled mid-transaction (`faults=cable@N+D`), the
//! upload fails with exit 3 naming the journal and `driveset recover`, and
//! recover (on the port without the fault) settles the transaction.

use predicates::prelude::*;

use crate::util::{driveset, workspace_root};

fn in_dir(dir: &std::path::Path) -> assert_cmd::Command {
    let mut c = driveset();
    c.current_dir(dir)
        .env("DRIVESET_SIM_STATE_DIR", dir.join("sim"));
    c
}

#[test]
fn interrupted_upload_then_recover() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("sim")).unwrap();
    let set = workspace_root().join("parameter-sets/mc6000/axis-1.toml");
    let journal = dir.path().join("axis-1.journal.json");
    let out = in_dir(dir.path())
        .args(["upload"])
        .arg(&set)
        .args([
            "--port",
            "sim://mc6000?addresses=1&faults=cable@260+600s",
            "--address",
            "1",
            "--journal",
        ])
        .arg(&journal)
        .assert()
        .code(3)
        .get_output()
        .clone();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("error: "), "{stderr}");
    assert!(stderr.contains("driveset recover"), "{stderr}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    assert_eq!(j["state"], "failed", "{j}");

    // recover on the port without the fault
    in_dir(dir.path())
        .args(["recover"])
        .arg(&journal)
        .args(["--port", "sim://mc6000?addresses=1"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "sim://mc6000?addresses=1 address 1: journal was failed; ",
        ))
        .stdout(predicate::str::contains("drive holds: sha256:"));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    assert!(
        j["state"] == "rolled-back" || j["state"] == "complete",
        "{j}"
    );
    // settled: nothing more to do
    in_dir(dir.path())
        .args(["recover"])
        .arg(&journal)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("nothing to do"));
}

#[test]
fn recover_of_a_missing_or_foreign_file_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    in_dir(dir.path())
        .args(["recover", "nope.json"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "journal nope.json: cannot read it",
        ));
    std::fs::write(dir.path().join("x.json"), "{}").unwrap();
    in_dir(dir.path())
        .args(["recover", "x.json"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("is not a driveset journal"));
}
