//! Sets that survive a power cycle (docs/file-formats.md, "How a drive
//! keeps what is written"): the demo ECS axes keep SDO writes in RAM until
//! the store command (the FICTIONAL fixture's `[schema.store]`, CiA 301
//! 0x1010 sub 1 = "save"), so an upload stores after verifying, the journal
//! says `storing`, `recover` stores again, and `driveset sim --state FILE
//! --power-cycle` shows what a drive keeps. Every step runs the built
//! binary on a `sim://` state file.

use std::path::{Path, PathBuf};

use driveset_test_support::{driveset_in_with_locks, outcome, sim_dir, workspace_root};

fn set() -> PathBuf {
    workspace_root().join("parameter-sets/ecs/axis-1.toml")
}

fn port(state: &Path, faults: &str) -> String {
    let mut p = format!("sim://ecs?addresses=1&state={}", state.display());
    if !faults.is_empty() {
        p.push_str(&format!("&faults={faults}"));
    }
    p
}

fn upload(dir: &Path, state: &Path, faults: &str, journal: &Path) -> (Option<i32>, String, String) {
    outcome(
        driveset_in_with_locks(dir)
            .arg("upload")
            .arg(set())
            .args([
                "--port",
                &port(state, faults),
                "--address",
                "1",
                "--journal",
            ])
            .arg(journal),
    )
}

fn power_cycle(dir: &Path, state: &Path) {
    let (code, _, err) = outcome(
        driveset_in_with_locks(dir)
            .args(["sim", "--power-cycle", "--state"])
            .arg(state),
    );
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        err,
        format!(
            "power-cycled 1 simulated ecs drive of {}\n",
            state.display()
        )
    );
}

fn diff(dir: &Path, state: &Path) -> (Option<i32>, String) {
    let (code, out, err) = outcome(driveset_in_with_locks(dir).arg("diff").arg(set()).args([
        "--port",
        &port(state, ""),
        "--address",
        "1",
    ]));
    (code, format!("{out}{err}"))
}

fn transitions(journal: &Path) -> Vec<String> {
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(journal).unwrap()).unwrap();
    j["transitions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["state"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn an_uploaded_demo_ecs_set_is_stored_and_held_over_a_power_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let (state, journal) = (dir.path().join("ecs.json"), dir.path().join("j.json"));
    let (code, out, err) = upload(dir.path(), &state, "", &journal);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.contains("\nstore: stored\n"), "{out}");
    assert!(err.contains("upload: storing\n"), "{err}");
    assert_eq!(
        transitions(&journal),
        ["planned", "writing", "verifying", "storing", "complete"]
    );
    power_cycle(dir.path(), &state);
    let (code, text) = diff(dir.path(), &state);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("no differences"), "{text}");
}

#[test]
fn a_cut_before_the_store_loses_the_set_at_power_off_and_recover_stores_it() {
    let dir = tempfile::tempdir().unwrap();
    let (state, journal) = (dir.path().join("ecs.json"), dir.path().join("j.json"));
    // telegram 37 is the last read-back: the cable is pulled before the
    // store command (telegram 38) is sent
    let (code, out, err) = upload(dir.path(), &state, "cable@37+600s", &journal);
    assert_eq!(code, Some(3), "{out}{err}");
    assert!(!out.contains("store: stored"), "{out}");
    assert_eq!(
        transitions(&journal),
        ["planned", "writing", "verifying", "rolling-back", "failed"]
    );
    // the drive holds the new values in RAM only: a power cycle loses them
    let lost = dir.path().join("lost.json");
    std::fs::copy(&state, &lost).unwrap();
    power_cycle(dir.path(), &lost);
    let (code, text) = diff(dir.path(), &lost);
    assert_eq!(code, Some(1), "{text}");
    assert!(text.contains("C5001"), "{text}");

    // recover finds the new values and stores them
    let (code, out, err) = outcome(
        driveset_in_with_locks(dir.path())
            .arg("recover")
            .arg(&journal)
            .args(["--port", &port(&state, ""), "--address", "1"]),
    );
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("\nstore: stored (the store command was written again)\n"),
        "{out}"
    );
    assert!(
        out.contains("completed: the drive holds the new set"),
        "{out}"
    );
    assert_eq!(
        transitions(&journal)[5..],
        ["storing", "complete"],
        "{:?}",
        transitions(&journal)
    );
    power_cycle(dir.path(), &state);
    let (code, text) = diff(dir.path(), &state);
    assert_eq!(code, Some(0), "{text}");
}

#[test]
fn a_cut_during_the_store_is_journaled_as_storing_and_recovered() {
    let dir = tempfile::tempdir().unwrap();
    let (state, journal) = (dir.path().join("ecs.json"), dir.path().join("j.json"));
    let (code, out, err) = upload(dir.path(), &state, "cable@38+600s", &journal);
    assert_eq!(code, Some(3), "{out}{err}");
    assert_eq!(
        transitions(&journal),
        [
            "planned",
            "writing",
            "verifying",
            "storing",
            "rolling-back",
            "failed"
        ]
    );
    let (code, out, err) = outcome(
        driveset_in_with_locks(dir.path())
            .arg("recover")
            .arg(&journal)
            .args(["--port", &port(&state, ""), "--address", "1"]),
    );
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.contains("store: stored"), "{out}");
    power_cycle(dir.path(), &state);
    assert_eq!(diff(dir.path(), &state).0, Some(0));
}

#[test]
fn a_set_holding_a_ram_code_is_a_validate_finding_naming_its_source() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("fan.toml");
    let schema = workspace_root().join("parameter-sets/fixtures/fictional-vf1000-demo.toml");
    std::fs::write(
        &f,
        format!(
            "schema = \"{}\"\n\n[values]\nSIOW = 5\nOVRD = \"100 %\"\n",
            schema.display()
        ),
    )
    .unwrap();
    let (code, out, err) = outcome(driveset_in_with_locks(dir.path()).arg("validate").arg(&f));
    let text = format!("{out}{err}");
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains(
            "error[ram-code]: 83-SIOW is a RAM control value (kind ram-control, lustbus-protocol.txt §5.2): the drive loses it at power off (lustbus-protocol.txt §11.1: RAM control sizes (kinds '0', '4') \"lose their values on power down\"), so the set would not survive a power cycle\n"
        ),
        "{text}"
    );
    assert!(
        text.contains(
            "error[ram-code]: 27-OVRD is a RAM control value (kind ram-control, fictional): the drive loses it at power off (lustbus-protocol.txt §11.1: RAM control sizes (kinds '0', '4') \"lose their values on power down\"), so the set would not survive a power cycle\n"
        ),
        "{text}"
    );
    assert!(text.contains("2 findings in 1 of 1 file"), "{text}");

    // an MC6000's RAM control value: the section is §11.2.1's
    let mc = dir.path().join("axis.toml");
    let schema = workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml");
    std::fs::write(
        &mc,
        format!("schema = \"{}\"\n\n[values]\nSCOPE = 1\n", schema.display()),
    )
    .unwrap();
    let (code, out, err) = outcome(driveset_in_with_locks(dir.path()).arg("validate").arg(&mc));
    let text = format!("{out}{err}");
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains(
            "error[ram-code]: 705-SCOPE is a RAM control value (kind ram-control, fictional): the drive loses it at power off (lustbus-protocol.txt §11.2.1: RAM control values \"lose their values on power down\"), so the set would not survive a power cycle\n"
        ),
        "{text}"
    );
}

#[test]
fn pull_leaves_ram_control_values_out_so_a_pulled_set_validates() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("vf.json");
    let pulled = dir.path().join("pulled.toml");
    let (code, out, err) = outcome(
        driveset_in_with_locks(dir.path())
            .arg("pull")
            .args([
                "--port",
                &format!("sim://vf1000?addresses=1&state={}", state.display()),
                "--address",
                "1",
                "--schema",
            ])
            .arg(workspace_root().join("parameter-sets/fixtures/fictional-vf1000-demo.toml"))
            .arg("-o")
            .arg(&pulled),
    );
    assert_eq!(code, Some(0), "{out}{err}");
    let text = std::fs::read_to_string(&pulled).unwrap();
    assert!(!text.contains("\nOVRD ="), "{text}");
    assert!(!text.contains("\nFJOG ="), "{text}");
    let (code, out, err) = outcome(
        driveset_in_with_locks(dir.path())
            .arg("validate")
            .arg(&pulled),
    );
    assert_eq!(code, Some(0), "{out}{err}");
}

#[test]
fn the_demo_lines_ecs_drives_are_stored_and_still_hold_their_sets_after_a_power_cycle() {
    let dir = sim_dir();
    let d = dir.path();
    let line = workspace_root().join("parameter-sets/demo-line/line.toml");
    let only = "handling-1,handling-2,handling-3";
    let (code, out, err) = outcome(
        driveset_test_support::driveset_in(d)
            .arg("commission")
            .arg(&line)
            .args(["--only", only, "--report-dir", "rep"]),
    );
    assert_eq!(code, Some(0), "{out}{err}");
    for name in ["handling-1", "handling-2", "handling-3"] {
        assert!(
            err.lines()
                .any(|l| l.contains(&format!(" {name}: verified, "))
                    && l.contains(" codes written, stored (")),
            "{name}: {err}"
        );
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("rep/report.json")).unwrap()).unwrap();
    // every verified drive is said kept or not
    let stored: Vec<(&str, &str)> = report["drives"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|r| Some((r["name"].as_str()?, r["stored"].as_str()?)))
        .collect();
    assert_eq!(
        stored,
        [
            ("handling-1", "stored"),
            ("handling-2", "stored"),
            ("handling-3", "stored")
        ]
    );
    let verified: Vec<_> = report["drives"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["result"] == "verified")
        .collect();
    assert_eq!(verified.len(), 3, "{verified:?}");
    assert!(
        verified.iter().all(|r| r["stored"].is_string()),
        "{verified:?}"
    );
    let html = std::fs::read_to_string(d.join("rep/report.html")).unwrap();
    assert!(html.contains("<dt>Kept at power off</dt><dd>stored</dd>"));
    let state = d.join("sim/sim-ecs.json");
    let (code, _, err) = outcome(
        driveset_test_support::driveset_in(d)
            .args(["sim", "--power-cycle", "--state"])
            .arg(&state),
    );
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        err,
        format!(
            "power-cycled 3 simulated ecs drives of {}\n",
            state.display()
        )
    );
    let (code, out, err) = outcome(
        driveset_test_support::driveset_in(d)
            .arg("status")
            .arg(&line)
            .args(["--only", only]),
    );
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains(
            "3 of 13 drives checked: 0 verified, 3 unchanged, 0 already verified, 0 drift"
        ),
        "{out}"
    );
}
