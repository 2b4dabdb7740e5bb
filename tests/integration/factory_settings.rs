//! "At factory settings (a new or exchanged unit?)" (issue 20): `status`
//! and `commission` say it when a drive holds its schema's defaults
//! wherever it differs from its set (the rule: `driveset-engine`'s
//! `line::factory`), in the text, the JSON report (`factory_settings`) and
//! the HTML report; a drive that drifted away from its set is plain drift.

use std::path::Path;

use predicates::prelude::*;

use driveset_schema::CodeStyle;
use driveset_test_support::{driveset_in, sim_dir, workspace_root};

fn demo() -> String {
    workspace_root()
        .join("parameter-sets/demo-line/line.toml")
        .display()
        .to_string()
}

fn report(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("target/driveset-report/report.json"))
        .expect("report.json written");
    serde_json::from_str(&text).expect("report.json parses")
}

fn drive<'a>(r: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    r["drives"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["name"] == name)
        .expect("drive in the report")
}

/// Set C0011 of the simulated Tmd at 12 to `raw` in the state file.
fn set_c0011(dir: &Path, raw: i64) {
    let path = dir.join("sim/sim-tmd.json");
    driveset_test_support::poke_state(&path, Some(12), 11, raw, CodeStyle::Lenze);
}

const WORDS: &str = "at factory settings (a new or exchanged unit?)";

#[test]
fn status_of_a_factory_fresh_drive_says_factory_settings_then_commission_says_it_was() {
    let dir = sim_dir();
    // the simulated Tmd starts at its schema's defaults
    driveset_in(dir.path())
        .args(["status", &demo(), "--only", "transfer-12"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "\ntransfer-12 (transfer/12) is at factory settings (a new or exchanged unit?): it differs from sets/transfer-12.toml:\n",
        ))
        .stdout(predicate::str::contains(
            "  C0011 maximum_output_frequency: 50 Hz -> 60 Hz\n",
        ))
        .stderr(predicate::str::contains(
            "[transfer] 1/1 transfer-12: DRIFT, 10 code(s) differ (",
        ))
        .stderr(predicate::str::contains(
            " s), at factory settings (a new or exchanged unit?)\n",
        ));
    let r = report(dir.path());
    let t12 = drive(&r, "transfer-12");
    assert_eq!(t12["result"], "drift");
    assert_eq!(t12["factory_settings"], true);
    // not selected: no claim either way, the field is left out
    assert!(drive(&r, "transfer-11").get("factory_settings").is_none());
    let html =
        std::fs::read_to_string(dir.path().join("target/driveset-report/report.html")).unwrap();
    assert!(html.contains("<strong>At factory settings (a new or exchanged unit?):</strong>"));

    driveset_in(dir.path())
        .args(["commission", &demo(), "--only", "transfer-12"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains(
            "[transfer] 1/1 transfer-12: verified, 10 codes written (",
        ))
        .stderr(predicate::str::contains(
            " s), was at factory settings (a new or exchanged unit?)\n",
        ));
    let r = report(dir.path());
    assert_eq!(drive(&r, "transfer-12")["factory_settings"], true);
    let html =
        std::fs::read_to_string(dir.path().join("target/driveset-report/report.html")).unwrap();
    assert!(html.contains("<strong>Was at factory settings (a new or exchanged unit?):</strong>"));

    // holds its set: neither drift nor factory
    driveset_in(dir.path())
        .args(["status", &demo(), "--only", "transfer-12"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains(WORDS).not());
    assert!(
        drive(&report(dir.path()), "transfer-12")
            .get("factory_settings")
            .is_none()
    );

    // turned to 55 Hz on the keypad (the default is 50 Hz): plain drift
    set_c0011(dir.path(), 550_000);
    driveset_in(dir.path())
        .args(["status", &demo(), "--only", "transfer-12"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "\ntransfer-12 (transfer/12) differs from sets/transfer-12.toml:\n  C0011 maximum_output_frequency: 55 Hz -> 60 Hz\n",
        ))
        .stdout(predicate::str::contains(WORDS).not())
        .stderr(predicate::str::contains(WORDS).not());
    let r = report(dir.path());
    assert_eq!(drive(&r, "transfer-12")["result"], "drift");
    assert!(drive(&r, "transfer-12").get("factory_settings").is_none());
}
