//! `driveset replace LINE --drive NAME --port SERVICE_PORT` (issue 20): a
//! factory-fresh spare alone on a simulated service port (its own state
//! file) becomes drive press-axis-3 of the demo line: its manifest address,
//! the bus's rate, then its whole set; refusals write nothing.

use std::path::Path;

use predicates::prelude::*;

use driveset_test_support::{copy_dir, driveset_in, workspace_root};

fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("sim")).unwrap();
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

const LINE: &str = "ps/demo-line/line.toml";

fn spare(dir: &Path, family: &str) -> String {
    format!(
        "sim://{family}?factory=1&state={}",
        dir.join("spare.json").display()
    )
}

/// The spare's state: (address, canonical values).
fn spare_state(dir: &Path) -> (u8, String) {
    let dump = driveset_sim::open::StateDump::read(&dir.join("spare.json")).expect("spare state");
    let d = &dump.drives[0];
    (d.address, d.canonical.clone())
}

#[test]
fn a_factory_fresh_spare_gets_the_address_the_rate_and_the_whole_set() {
    let dir = setup();
    let d = dir.path();
    let port = spare(d, "mc6000");
    let out = driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port, "--yes"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(format!(
            "spare on {port}: mc6000 at address 0, 9600 baud (91-TYPE = 0)\nwrote 82-SADDR = 3 at address 0\npress-axis-3: address 3, 9600 baud, 21 codes written and verified (46 codes in the set); the spare was at factory settings ("
        )))
        .stdout(predicate::str::contains(
            "report: target/driveset-report/replace-press-axis-3/report.json target/driveset-report/replace-press-axis-3/report.html\nnext: plug it into the line (bus `lustbus`, sim://lustbus?mc6000=1,2,3,4&vf1000=5,6,7&baud=9600) and run `driveset status ps/demo-line/line.toml --only press-axis-3`\n",
        ))
        .get_output()
        .clone();
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // the spare holds the manifest's address, the rate and every value of the set
    let (address, canonical) = spare_state(d);
    assert_eq!(address, 3);
    assert!(canonical.lines().any(|l| l == "82 3"), "{canonical}");
    assert!(canonical.lines().any(|l| l == "81 9600"), "{canonical}");
    let fp = driveset_in(d)
        .args(["fingerprint", "ps/demo-line/sets/press-axis-3.toml"])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let set_fp = String::from_utf8(fp).unwrap();
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(d.join("target/driveset-report/replace-press-axis-3/report.json"))
            .unwrap(),
    )
    .unwrap();
    assert_eq!(r["command"], "replace");
    assert_eq!(r["result"], "ok");
    assert_eq!(r["drives"].as_array().unwrap().len(), 1);
    let dr = &r["drives"][0];
    assert_eq!(dr["name"], "press-axis-3");
    assert_eq!(dr["result"], "verified");
    assert_eq!(dr["codes_written"], 21);
    assert_eq!(dr["fingerprint_after"], dr["set_fingerprint"]);
    assert!(
        set_fp.contains(dr["set_fingerprint"].as_str().unwrap()),
        "{set_fp}"
    );
    assert_eq!(dr["factory_settings"], true);
    let rep = &dr["replacement"];
    assert_eq!(rep["service_port"], port.as_str());
    assert_eq!(rep["found_address"], 0);
    assert_eq!(rep["found_rate"], 9600);
    assert_eq!(rep["old_address"], 1);
    assert_eq!(rep["address"], 3);
    assert_eq!(rep["rate"], 9600);
    assert_eq!(rep["assigned"][0], "82-SADDR = 3 at address 0");
    let html =
        std::fs::read_to_string(d.join("target/driveset-report/replace-press-axis-3/report.html"))
            .unwrap();
    assert!(
        html.contains("Replacement unit"),
        "the HTML says it is a replacement"
    );
}

#[test]
fn replace_json_reports_the_virtual_time() {
    let dir = setup();
    let d = dir.path();
    let port = spare(d, "mc6000");
    let out = driveset_in(d)
        .args([
            "replace",
            LINE,
            "--drive",
            "press-axis-3",
            "--port",
            &port,
            "--yes",
            "--format",
            "json",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["result"], "replaced");
    assert_eq!(v["address"], 3);
    assert_eq!(v["rate"], 9600);
    assert_eq!(v["codes"], 46);
    assert_eq!(v["codes_written"], 21);
    let total = v["virtual_ms"]["total"].as_f64().unwrap();
    let sum =
        v["virtual_ms"]["assign"].as_f64().unwrap() + v["virtual_ms"]["upload"].as_f64().unwrap();
    assert!((total - sum).abs() < 1e-6, "{v}");
    assert!(total > 0.0, "{v}");
    eprintln!("replace press-axis-3 (MC6000, demo set) at 9600 baud: {total:.3} ms virtual");
}

#[test]
fn a_spare_of_another_family_is_refused_with_nothing_written() {
    let dir = setup();
    let d = dir.path();
    let port = spare(d, "vf1000");
    driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port, "--yes"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            "error: the unit on the port is vf1000 with 91-TYPE 0, but drive `press-axis-3`'s set `sets/press-axis-3.toml` (schema `fictional-mc6000-demo`) is for mc6000; nothing was written. Connect a spare of the drive's family and type\n",
        );
    // the spare still at its factory address, nothing assigned
    let dump = driveset_sim::open::StateDump::read(&d.join("spare.json")).expect("spare state");
    assert_eq!(dump.drives[0].address, 1);
    assert!(
        !d.join("target/driveset-report/replace-press-axis-3")
            .exists()
    );
}

#[test]
fn without_yes_a_non_interactive_stdin_is_refused_and_no_is_no() {
    let dir = setup();
    let d = dir.path();
    let port = spare(d, "mc6000");
    driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port])
        .write_stdin("y\n")
        .assert()
        .code(2)
        .stderr(
            "error: replace asks before writing, and stdin is not a terminal; give --yes to run without asking (nothing was written)\n",
        );
    assert!(
        !d.join("spare.json").exists(),
        "the port was not even opened"
    );
    // answered (the test hook reads stdin as a terminal would be read): no
    driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port, "--prompt-stdin"])
        .write_stdin("n\n")
        .assert()
        .code(1)
        .stderr(format!(
            "replace press-axis-3: write address 3, 9600 baud and 46 codes to the unit on {port}? [y/N] not replaced: nothing was written\n"
        ));
    assert_eq!(spare_state(d).0, 1);
    // yes
    driveset_in(d)
        .args([
            "replace",
            LINE,
            "--drive",
            "press-axis-3",
            "--port",
            &port,
            "--prompt-stdin",
        ])
        .write_stdin("y\n")
        .assert()
        .code(0);
    assert_eq!(spare_state(d).0, 3);
}
