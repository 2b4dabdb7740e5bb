//! `driveset recover` from a journal an interrupted upload left: the cable
//! of the simulated bus is pulled mid-transaction (`faults=cable@N+D`), the
//! upload fails with exit 3 naming the journal and `driveset recover`, and
//! recover (on the port without the fault) settles the transaction.

use predicates::prelude::*;

use driveset_test_support::{driveset, driveset_in, sim_dir, workspace_root};

#[test]
fn interrupted_upload_then_recover() {
    let dir = sim_dir();
    let set = workspace_root().join("parameter-sets/mc6000/axis-1.toml");
    let journal = dir.path().join("axis-1.journal.json");
    let out = driveset_in(dir.path())
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
    // not a terminal: plain progress lines, the runner's own phases; the
    // restore attempts are `rolling back`, not writing and verifying
    assert!(
        stderr.starts_with(
            "upload: reading 195 codes from the drive\nupload: writing\nupload: rolling back\nerror: "
        ),
        "{stderr}"
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    assert_eq!(j["state"], "failed", "{j}");
    let backed_up = j["backup"].as_array().unwrap().len();

    // recover on the port without the fault
    let out = driveset_in(dir.path())
        .args(["recover"])
        .arg(&journal)
        .args(["--port", "sim://mc6000?addresses=1"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "sim://mc6000?addresses=1 address 1: journal was failed; ",
        ))
        .stdout(predicate::str::contains("drive holds: sha256:"))
        .get_output()
        .clone();
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let reading = format!("recover: reading {backed_up} codes from the drive\n");
    let want = if j["state"] == "rolled-back" {
        format!("{reading}recover: rolling back\nrecover: verifying\n")
    } else {
        format!("{reading}recover: verifying\n")
    };
    assert_eq!(stderr, want, "{j}");
    assert!(
        j["state"] == "rolled-back" || j["state"] == "complete",
        "{j}"
    );
    // settled: nothing more to do
    driveset_in(dir.path())
        .args(["recover"])
        .arg(&journal)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("nothing to do"));
}

#[test]
fn recover_of_a_missing_or_foreign_file_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    driveset_in(dir.path())
        .args(["recover", "nope.json"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "journal nope.json: cannot read it",
        ));
    std::fs::write(dir.path().join("x.json"), "{}").unwrap();
    driveset_in(dir.path())
        .args(["recover", "x.json"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("is not a driveset journal"));
}

/// A Tmd upload to address 11 of `sim://tmd?addresses=11,12&c0001=3`, cut by a
/// pulled cable mid-write (exit 3); returns the journal's path as the
/// upload names it (relative to `dir`) and the simulated bus's id.
fn cut_tmd_upload(dir: &std::path::Path) -> (String, String) {
    std::fs::create_dir_all(dir.join("sim")).unwrap();
    let set = workspace_root().join("parameter-sets/tmd/conveyor-3.toml");
    driveset_in(dir)
        .args(["upload"])
        .arg(&set)
        .args([
            "--port",
            "sim://tmd?addresses=11,12&c0001=3&faults=cable@30+600s",
            "--address",
            "11",
        ])
        .assert()
        .code(3);
    let state = std::fs::canonicalize(dir.join("sim"))
        .unwrap()
        .join("sim-tmd.json");
    let bus = format!("sim:tmd@{}", state.display());
    let name: String = bus
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let journal = format!(".driveset/journal/{name}-11.journal.json");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join(&journal)).unwrap()).unwrap();
    assert_eq!(j["state"], "failed", "{j}");
    assert_eq!(j["journal_version"], 2, "{j}");
    assert_eq!(j["target"]["bus"], bus.as_str(), "{j}");
    assert_eq!(j["target"]["address"], 11, "{j}");
    (journal, bus)
}

#[test]
fn recover_refuses_another_address_and_another_bus_with_exit_2_and_sends_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (journal, bus) = cut_tmd_upload(dir.path());
    let state = dir.path().join("sim/sim-tmd.json");
    let before = sim_state(&state);
    driveset_in(dir.path())
        .args(["recover", &journal, "--port", "sim://tmd?addresses=11,12&c0001=3", "--address", "12"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(format!(
            "error: sim://tmd?addresses=11,12&c0001=3 address 12: refused to recover journal {journal}: it belongs to the drive at address 11 on bus `{bus}`, not the one at address 12; nothing was sent. Recover at address 11 (leave out --address)\n"
        ));
    let other = dir.path().join("other.json");
    let other_port = format!(
        "sim://tmd?addresses=11,12&c0001=3&state={}",
        other.display()
    );
    let other_bus = format!(
        "sim:tmd@{}",
        std::fs::canonicalize(dir.path())
            .unwrap()
            .join("other.json")
            .display()
    );
    // the port's name carries its state file, absolute
    let other_name = format!(
        "sim://tmd?addresses=11,12&c0001=3&state={}",
        &other_bus["sim:tmd@".len()..]
    );
    driveset_in(dir.path())
        .args(["recover", &journal, "--port", &other_port])
        .assert()
        .code(2)
        .stdout("")
        .stderr(format!(
            "error: {other_name} address 11: refused to recover journal {journal}: it belongs to the drive at address 11 on bus `{bus}` (port sim://tmd?addresses=11,12&c0001=3&faults=cable@30+600s), but this port reaches bus `{other_bus}`; nothing was sent. Recover through a port to that bus\n"
        ));
    // not one telegram reached the bus; the drives hold what the cut upload left
    let after = sim_state(&state);
    assert_eq!(after["telegrams"], 0, "{after}");
    assert_eq!(after["drives"], before["drives"]);
    assert_eq!(sim_state(&other)["telegrams"], 0);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join(&journal)).unwrap()).unwrap();
    assert_eq!(j["state"], "failed", "{j}");
    // the same bus, spelled otherwise (another address order, a seed): the
    // guard sees the journal; recover through it settles the drive
    let set = workspace_root().join("parameter-sets/tmd/conveyor-3.toml");
    driveset_in(dir.path())
        .args(["upload"])
        .arg(&set)
        .args(["--port", "sim://tmd?addresses=12,11&c0001=3&seed=4", "--address", "11"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(format!(
            "error: journal {journal}: the drive at sim://tmd?addresses=12,11&c0001=3&seed=4 address 11 has an unfinished transaction ({journal} (state failed)); nothing was sent. Run `driveset recover {journal}` first\n"
        ));
    driveset_in(dir.path())
        .args(["recover", &journal, "--port", "sim://tmd?addresses=12,11&c0001=3&seed=4"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "sim://tmd?addresses=12,11&c0001=3&seed=4 address 11: journal was failed; rolled back: the drive holds its old values again (verified); journal marked rolled-back\n",
        ))
        .stdout(predicate::str::contains(format!(
            "note: the journal was written through sim://tmd?addresses=11,12&c0001=3&faults=cable@30+600s address 11; sim://tmd?addresses=12,11&c0001=3&seed=4 address 11 reaches the same drive (bus `{bus}`)\n"
        )));
}

#[test]
fn recover_of_a_journal_a_later_upload_made_stale_names_the_codes_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let (journal, _) = cut_tmd_upload(dir.path());
    let later = workspace_root().join("parameter-sets/tmd/conveyor-commissioning.toml");
    // the guard blocks the later upload ...
    driveset_in(dir.path())
        .args(["upload"])
        .arg(&later)
        .args([
            "--port",
            "sim://tmd?addresses=11,12&c0001=3",
            "--address",
            "11",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(format!(
            "has an unfinished transaction ({journal} (state failed)); nothing was sent."
        )));
    // ... forced past it with another journal directory (nothing deleted)
    driveset_in(dir.path())
        .args(["upload"])
        .arg(&later)
        .args([
            "--port",
            "sim://tmd?addresses=11,12&c0001=3",
            "--address",
            "11",
            "--journal-dir",
            "later",
        ])
        .assert()
        .code(0);
    let state = dir.path().join("sim/sim-tmd.json");
    let before = sim_state(&state);
    driveset_in(dir.path())
        .args(["recover", &journal, "--port", "sim://tmd?addresses=11,12&c0001=3"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(predicate::str::ends_with(format!(
            "error: sim://tmd?addresses=11,12&c0001=3 address 11: refused to recover journal {journal}: C0012 acceleration_time_1, C0013 deceleration_time_1, C0086 motor_rated_power, C0087 motor_rated_speed, C0088 motor_rated_current, C0091 motor_cosine_phi hold neither the old nor the new value the journal records (written since the transaction was cut); nothing was written. The journal is stale: compare the drive with its set (`driveset diff SET --port ...`), upload the set again if needed, then delete the journal\n"
        )));
    // only reads were sent: the drives hold the later set still
    assert_eq!(sim_state(&state)["drives"], before["drives"]);
}

/// The simulator's state dump (`DRIVESET_SIM_STATE_DIR`): `telegrams` is
/// what the last CLI run sent.
fn sim_state(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn an_upload_in_a_git_repository_leaves_git_status_clean() {
    let dir = tempfile::tempdir().unwrap();
    let sim = tempfile::tempdir().unwrap();
    let git = |args: &[&str]| {
        let out = std::process::Command::new("git")
            .args(args)
            .current_dir(dir.path())
            .output()
            .expect("git runs");
        assert!(out.status.success(), "git {args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    git(&["init", "-q"]);
    let set = workspace_root().join("parameter-sets/tmd/conveyor-3.toml");
    driveset()
        .current_dir(dir.path())
        .env("DRIVESET_SIM_STATE_DIR", sim.path())
        .args(["upload"])
        .arg(&set)
        .args([
            "--port",
            "sim://tmd?addresses=11&c0001=3",
            "--address",
            "11",
        ])
        .assert()
        .code(0);
    assert!(dir.path().join(".driveset/journal").is_dir());
    assert_eq!(
        std::fs::read_to_string(dir.path().join(".driveset/.gitignore")).unwrap(),
        "# written by driveset: journals hold old values, passwords included\n*\n"
    );
    assert_eq!(git(&["status", "--porcelain", "--untracked-files=all"]), "");
}

#[test]
fn a_commission_in_a_git_repository_leaves_git_status_clean() {
    let dir = tempfile::tempdir().unwrap();
    let sim = tempfile::tempdir().unwrap();
    let git = |args: &[&str]| {
        let out = std::process::Command::new("git")
            .args(args)
            .current_dir(dir.path())
            .output()
            .expect("git runs");
        assert!(out.status.success(), "git {args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    git(&["init", "-q"]);
    let set = workspace_root().join("parameter-sets/demo-line/sets/transfer-11.toml");
    std::fs::write(
        dir.path().join("line.toml"),
        format!(
            "[line]\nname = \"l\"\n\n[[bus]]\nname = \"transfer\"\nport = \"sim://tmd?c0001=3\"\nprotocol = \"lecom\"\nbaud = 9600\n\n[[drive]]\nname = \"transfer-11\"\nbus = \"transfer\"\naddress = 11\nset = {:?}\n",
            set.display().to_string()
        ),
    )
    .unwrap();
    git(&["add", "line.toml"]);
    driveset()
        .current_dir(dir.path())
        .env("DRIVESET_SIM_STATE_DIR", sim.path())
        .args(["commission", "line.toml", "--report-dir"])
        .arg(sim.path().join("report"))
        .assert()
        .code(0);
    assert_eq!(
        std::fs::read_to_string(dir.path().join(".driveset/.gitignore")).unwrap(),
        "# written by driveset: journals hold old values, passwords included\n*\n"
    );
    assert_eq!(
        git(&["status", "--porcelain", "--untracked-files=all"]),
        "A  line.toml\n"
    );
}

#[test]
fn status_fails_and_commission_recovers_a_drive_an_upload_left_unfinished() {
    let dir = sim_dir();
    let set = workspace_root().join("parameter-sets/demo-line/sets/transfer-11.toml");
    std::fs::write(
        dir.path().join("line.toml"),
        format!(
            "[line]\nname = \"l\"\n\n[[bus]]\nname = \"transfer\"\nport = \"sim://tmd?c0001=3\"\nprotocol = \"lecom\"\nbaud = 9600\n\n[[drive]]\nname = \"transfer-11\"\nbus = \"transfer\"\naddress = 11\nset = \"{}\"\n",
            set.display()
        ),
    )
    .unwrap();
    // an upload (not a commission) cut by a pulled cable
    driveset_in(dir.path())
        .args(["upload"])
        .arg(&set)
        .args([
            "--port",
            "sim://tmd?addresses=11&c0001=3&faults=cable@30+600s",
            "--address",
            "11",
        ])
        .assert()
        .code(3);
    let state = std::fs::canonicalize(dir.path().join("sim"))
        .unwrap()
        .join("sim-tmd.json");
    let name: String = format!("sim:tmd@{}", state.display())
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let journal = format!(".driveset/journal/{name}-11.journal.json");
    // status: not "unchanged", failed, exit 1, nothing written
    driveset_in(dir.path())
        .args(["status", "line.toml", "--report-dir", "rep"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "transfer-11  transfer/11  FAILED        0  -\n",
        ))
        .stdout(predicate::str::contains(format!(
            "transfer-11: journal {journal}: the drive at sim://tmd?addresses=11&baud=9600&c0001=3 address 11 has an unfinished transaction ({journal} (state failed)); its values are not trusted. Run `driveset commission` (it recovers the journal first) or `driveset recover {journal}`\n"
        )));
    // commission sees the upload's journal (same name, same directory), recovers it
    driveset_in(dir.path())
        .args(["commission", "line.toml", "--report-dir", "rep"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "transfer-11  transfer/11  verified ",
        ))
        .stderr(predicate::str::contains(format!(
            "warning: transfer-11: recovered the unfinished journal {journal} of an earlier run: "
        )));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join(&journal)).unwrap()).unwrap();
    assert!(
        j["state"] == "complete" || j["state"] == "rolled-back",
        "{j}"
    );
}

/// Issue 28: `driveset address --baud` made with a schema learned by
/// `schema pull` (given with `--schema`), over a pty behind 25 ms each
/// way, killed with SIGKILL once its journal says the rate change is under
/// way. `recover JOURNAL` (no `--schema`) takes the schema the journal
/// records and finishes the change; before, it took the built-in
/// `lust-mc6000`, which types no 81-SBAUD, and exited 2.
#[cfg(unix)]
#[test]
fn recover_of_an_address_change_cut_by_kill_9_uses_the_journal_s_schema() {
    use crate::e2e_pty::{Sim, one_at_a_time};
    use driveset_test_support::{Spawned, driveset_at, driveset_bin, outcome};
    use std::time::{Duration, Instant};

    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut sim = Sim::start(d, "mc6000", 1, &[]);
    let (code, out, err) = outcome(driveset_at(d).args([
        "schema",
        "pull",
        "--port",
        &sim.path,
        "--address",
        "1",
        "-o",
        "learned.toml",
    ]));
    assert_eq!(code, Some(0), "{out}{err}");
    let port = sim.path.clone();
    let journal = d.join("j.journal.json");
    let mut address = Spawned::new(
        std::process::Command::new(driveset_bin())
            .current_dir(d)
            .args([
                "address",
                "--port",
                &port,
                "--protocol",
                "lustbus",
                "--to",
                "5",
            ])
            .args(["--baud", "57600", "--schema", "learned.toml", "--journal"])
            .arg(&journal)
            .stdout(std::process::Stdio::null())
            .stderr(std::fs::File::create(d.join("address.err")).unwrap())
            .spawn()
            .expect("start driveset address"),
        "driveset address",
    );
    // SIGKILL once the journal says the address write is under way
    let give_up = Instant::now() + Duration::from_secs(120);
    loop {
        let step = std::fs::read_to_string(&journal)
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|v| v["assign"]["step"].as_str().map(str::to_string));
        if step.as_deref() == Some("address") {
            break;
        }
        assert!(
            Instant::now() < give_up,
            "the address step never came: {step:?}"
        );
        assert!(
            address.try_wait().unwrap().is_none(),
            "address ended first: {}",
            std::fs::read_to_string(d.join("address.err")).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    address.signal("-KILL", Duration::from_secs(10));
    let before: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    assert_eq!(before["state"], "planned", "{before}");
    assert_eq!(
        before["schema_path"],
        d.join("learned.toml")
            .canonicalize()
            .unwrap()
            .display()
            .to_string(),
        "{before}"
    );
    let j = journal.display().to_string();
    let (code, out, err) = outcome(driveset_at(d).args(["recover", &j]));
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(
        out.contains("completed: the drive answers at address 5 at 57600 baud"),
        "{out}"
    );
    let after: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    assert_eq!(after["state"], "complete");
    assert!(sim.terminate().success());
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("mc6000.dump.json")).unwrap())
            .unwrap();
    assert_eq!(dump["drives"][0]["address"], 5);
    let canonical = dump["drives"][0]["canonical"].as_str().unwrap();
    for want in ["81 57600", "82 5"] {
        assert!(canonical.lines().any(|l| l == want), "{want}: {canonical}");
    }
}
