//! `driveset upload` and `driveset diff SET --port` against simulated drives.
//! Consecutive runs see the same simulated drive through the simulator's
//! state directory (`DRIVESET_SIM_STATE_DIR`); the journal goes to the
//! default `.driveset/journal/` under the (temporary) working directory.

use predicates::prelude::*;

use driveset_test_support::{driveset, driveset_in, sim_dir, workspace_root};

const AXIS1: &str = "parameter-sets/mc6000/axis-1.toml";
const PORT: &str = "sim://mc6000?addresses=1";

fn set(p: &str) -> String {
    workspace_root().join(p).display().to_string()
}

#[test]
fn dry_run_prints_the_plan_and_writes_nothing() {
    let dir = sim_dir();
    driveset_in(dir.path())
        .args(["upload", &set(AXIS1), "--port", PORT, "--address", "1", "--dry-run"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("; nothing is written\nplan: 78 of 195 codes differ (schema fictional-mc6000-demo, set sha256:"))
        .stdout(predicate::str::contains("  dataset download (SLOAD = -1, CardWriteable values, SLOAD = -2, drive checks the set):\n"))
        .stdout(predicate::str::contains("    100-PWMF: \"8 kHz\" -> \"16 kHz\"  [CardWriteable, EEPROM 1 B]\n"))
        .stdout(predicate::str::contains("expected time: "));
    assert!(!dir.path().join(".driveset").exists());
    // still the factory state: the live diff shows the same 78 codes
    driveset_in(dir.path())
        .args(["diff", &set(AXIS1), "--port", PORT, "--address", "1"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "78 differences (78 changed, 0 added, 0 removed)\n",
        ));
}

#[test]
fn upload_then_live_diff_shows_no_differences() {
    let dir = sim_dir();
    let out = driveset_in(dir.path())
        .args(["upload", &set(AXIS1), "--port", PORT, "--address", "1"])
        .assert()
        .code(0)
        .get_output()
        .clone();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with(
            "sim://mc6000?addresses=1 address 1: complete (78 of 195 codes written, 1 attempt(s), "
        ),
        "{stdout}"
    );
    assert!(stdout.contains("dataset: accepted (SLOAD = 0)\n"));
    // named after the bus id `sim:mc6000@<canonical state file>` and the address
    let bus = format!(
        "sim:mc6000@{}",
        std::fs::canonicalize(dir.path().join("sim"))
            .unwrap()
            .join("sim-mc6000.json")
            .display()
    );
    let name: String = bus
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let journal = format!(".driveset/journal/{name}-1.journal.json");
    assert!(stdout.contains(&format!("journal: {journal} ")), "{stdout}");
    // not a terminal: plain progress lines on stderr
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("upload: reading 195 codes from the drive\nupload: writing\n"),
        "{stderr}"
    );
    let after = stdout
        .lines()
        .find_map(|l| l.strip_prefix("after:  "))
        .unwrap()
        .to_string();
    driveset()
        .arg("fingerprint")
        .arg(set(AXIS1))
        .assert()
        .stdout(predicate::str::starts_with(after));
    assert!(dir.path().join(&journal).exists());
    assert!(dir.path().join(".driveset/.gitignore").exists());
    driveset_in(dir.path())
        .args(["diff", &set(AXIS1), "--port", PORT, "--address", "1"])
        .assert()
        .code(0)
        .stdout(format!(
            "--- sim://mc6000?addresses=1 address 1\n+++ {}\nno differences\n",
            set(AXIS1)
        ));
    // a second upload has nothing to write
    driveset_in(dir.path())
        .args([
            "upload",
            &set(AXIS1),
            "--port",
            PORT,
            "--address",
            "1",
            "--format",
            "json",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("\"codes_written\": 0"))
        .stdout(predicate::str::contains("\"state\": \"complete\""));
    // another set of the family differs; JSON diff
    driveset_in(dir.path())
        .args([
            "diff",
            &set("parameter-sets/mc6000/axis-2.toml"),
            "--port",
            PORT,
            "--address",
            "1",
            "--format",
            "json",
        ])
        .assert()
        .code(1)
        .stdout(predicate::str::contains("\"equal\": false"));
}

/// An MC6000 set onto a VF1000: the read-back is refused by the drive
/// before anything is written, as on a serial line (a simulated port is
/// only a transport; LUSTBUS gives no TYPE values that identify could tell
/// the families apart by).
#[test]
fn upload_to_another_family_is_refused_without_allow_family() {
    let dir = sim_dir();
    driveset_in(dir.path())
        .args(["upload", &set(AXIS1), "--port", "sim://vf1000?addresses=1", "--address", "1"])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "error: sim://vf1000?addresses=1 address 1: read 100-PWMF refused: no such parameter, or read-protected in the current operating state (NAK to ENQUIRY 20100); check the drive is the family the schema names",
        ));
    // the read-back refused before anything was written: no journal (the
    // refused attempt is on record: docs/history.md)
    assert!(!dir.path().join(".driveset/journal").exists());
    // another protocol on the line: no drive understands it, as on a
    // serial line (nothing written)
    driveset_in(dir.path())
        .args([
            "upload",
            &set("parameter-sets/tmd/conveyor-3.toml"),
            "--port",
            PORT,
            "--address",
            "1",
            "--allow-family",
        ])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "error: sim://mc6000?addresses=1 address 1: no answer to identify: read C0093 after 3 tries",
        ));
    // --allow-family onto a VF1000: the MC codes do not exist there, so the drive
    // refuses them; nothing was written
    driveset_in(dir.path())
        .args([
            "upload",
            &set(AXIS1),
            "--port",
            "sim://vf1000?addresses=1",
            "--address",
            "1",
            "--allow-family",
            "--dry-run",
        ])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "error: sim://vf1000?addresses=1 address 1: ",
        ));
    assert!(!dir.path().join(".driveset/journal").exists());
}

#[test]
fn upload_of_an_invalid_set_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"999 Hz\"\n",
    )
    .unwrap();
    driveset_in(dir.path())
        .args(["upload"])
        .arg(&bad)
        .args(["--port", "sim://tmd?addresses=1", "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("not uploaded"));
}

#[test]
fn upload_tmd_json_report() {
    let dir = sim_dir();
    let out = driveset_in(dir.path())
        .args([
            "upload",
            &set("parameter-sets/tmd/conveyor-3.toml"),
            "--port",
            "sim://tmd?addresses=3&c0001=3",
            "--address",
            "3",
            "--journal",
            "j.json",
            "--format",
            "json",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["state"], "complete");
    assert_eq!(v["journal"], "j.json");
    assert!(
        v["fingerprint_after"]
            .as_str()
            .unwrap()
            .starts_with("sha256:")
    );
    assert!(dir.path().join("j.json").exists());
}

// --transfer-baud (issue 12): the switch itself is tested telegram by
// telegram in driveset-engine's txn_sim; here the command line.

#[test]
fn upload_with_transfer_baud_switches_back_and_keeps_the_sets_sbaud() {
    let dir = sim_dir();
    // the dry run says it would pay, and writes nothing
    driveset_in(dir.path())
        .args(["upload", &set(AXIS1), "--port", PORT, "--address", "1", "--dry-run", "--transfer-baud", "57600"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "transfer rate 57600: saves 3.7 s of 4.8 s (195 exchanges: 4.8 s at 9600 baud, 962 ms at 57600 baud plus 112 ms to switch over and back)\n",
        ));
    assert!(!dir.path().join(".driveset").exists());
    driveset_in(dir.path())
        .args(["upload", &set(AXIS1), "--port", PORT, "--address", "1", "--transfer-baud", "57600"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "transfer rate 57600: saves 3.7 s of 4.8 s",
        ))
        .stdout(predicate::str::contains(
            "\nline rate: the drive runs at 9600 baud again; 81-SBAUD holds 19200 (not active: in effect after the drive's next restart)\n",
        ));
    let journals: Vec<_> = std::fs::read_dir(dir.path().join(".driveset/journal"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().ends_with(".journal.json"))
        .collect();
    assert_eq!(journals.len(), 1, "{journals:?}");
    let journal = &journals[0];
    let text = std::fs::read_to_string(journal).unwrap();
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(j["state"], "complete");
    assert_eq!(j["transfer"]["state"], "back");
    assert_eq!(j["transfer"]["old_rate"], 9600);
    assert_eq!(j["transfer"]["transfer_rate"], 57600);
    assert_eq!(j["transfer"]["stored"], serde_json::json!({"int": 19200}));
    // the next command talks at 9600 and finds the set
    driveset_in(dir.path())
        .args([
            "diff",
            &set(AXIS1),
            "--port",
            PORT,
            "--address",
            "1",
            "--transfer-baud",
            "57600",
        ])
        .assert()
        .code(0)
        .stderr(predicate::str::contains("transfer rate 57600: saves "));
}

#[test]
fn transfer_baud_refusals_name_what_and_send_nothing() {
    let dir = sim_dir();
    driveset_in(dir.path())
        .args([
            "upload",
            &set("parameter-sets/vf1000/conveyor-1.toml"),
            "--port",
            "sim://vf1000?addresses=4",
            "--address",
            "4",
            "--transfer-baud",
            "19200",
        ])
        .assert()
        .code(2)
        .stderr(
            "error: sim://vf1000?addresses=4 address 4: refused: --transfer-baud 19200: a Lust SMARTDRIVE VF1000 runs at 9600 baud at most (lustbus-protocol.txt §4) and activates a new rate only at a restart (§11.5); leave out --transfer-baud\n",
        );
    driveset_in(dir.path())
        .args(["upload", &set(AXIS1), "--port", PORT, "--address", "1", "--transfer-baud", "1200"])
        .assert()
        .code(2)
        .stderr(
            "error: sim://mc6000?addresses=1 address 1: refused: --transfer-baud 1200: a Lust MASTERCONTROL MC6000/7000 runs at 2400, 4800, 9600, 19200, 38400, 57600 baud (lustbus-protocol.txt §4); pick one of these\n",
        );
    // no journal; the refused attempts are on record (docs/history.md)
    assert!(!dir.path().join(".driveset/journal").exists());
}
