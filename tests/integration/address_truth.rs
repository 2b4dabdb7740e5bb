//! The manifest's address is the truth (issue 20), the story as a
//! new user would try it: pull axis-1's set from the drive (the bus
//! address and rate are left out), copy it for axis-2 with `82 = 1` added
//! back by hand; `validate` names both places, and `commission` refuses
//! axis-2 (nothing sent to it) while axis-1 is done.

use std::path::Path;

use predicates::prelude::*;

use driveset_test_support::{demo_line_dir, driveset_in};

const PRESS: &str = "[line]\nname = \"press\"\n\n[[bus]]\nname = \"press\"\nport = \"sim://mc6000\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n[[drive]]\nname = \"axis-1\"\nbus = \"press\"\naddress = 1\nset = \"sets/press-axis-1.toml\"\n\n[[drive]]\nname = \"axis-2\"\nbus = \"press\"\naddress = 2\nset = \"sets/AXIS2\"\n";

/// The canonical values the simulated MC6000 at `address` holds.
fn held(dir: &Path, address: u8) -> String {
    let dump = driveset_sim::open::StateDump::read(&dir.join("sim/sim-mc6000.json"))
        .expect("mc6000 state saved");
    dump.drives
        .iter()
        .find(|d| d.address == address)
        .expect("drive in the dump")
        .canonical
        .clone()
}

#[test]
fn a_set_copied_from_axis_1_is_caught_by_validate_and_refused_by_commission() {
    let dir = demo_line_dir();
    let d = dir.path();
    let line = d.join("ps/demo-line/press.toml");
    std::fs::write(&line, PRESS.replace("AXIS2", "press-axis-2.toml")).unwrap();
    // the demo sets give SADDR = the manifest's address: a no-op
    driveset_in(d)
        .args(["commission", "ps/demo-line/press.toml"])
        .assert()
        .code(0);

    driveset_in(d)
        .args([
            "pull",
            "--port",
            "sim://mc6000?addresses=1,2",
            "--address",
            "1",
            "--schema",
            "ps/fixtures/fictional-mc6000-demo.toml",
            "-o",
            "ps/demo-line/sets/pulled-axis-1.toml",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "left out 81-SBAUD, 82-SADDR: the line manifest gives the drive's address and the bus's rate (--keep-bus-codes keeps them)\n",
        ));
    // copied for axis-2, the address added back by hand
    let pulled = std::fs::read_to_string(d.join("ps/demo-line/sets/pulled-axis-1.toml")).unwrap();
    let copy = pulled.replacen("\n[values]\n", "\n[values]\n82 = 1\n", 1);
    assert_ne!(copy, pulled);
    let line_no = copy
        .lines()
        .position(|l| l == "82 = 1")
        .expect("the added line")
        + 1;
    std::fs::write(d.join("ps/demo-line/sets/axis-2.toml"), &copy).unwrap();
    std::fs::write(&line, PRESS.replace("AXIS2", "axis-2.toml")).unwrap();

    driveset_in(d)
        .args(["validate", "ps/demo-line/press.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "error[rule-violation]: set `sets/axis-2.toml` gives 82-SADDR = 1, but the manifest puts drive `axis-2` at address 2 on bus `press`\n",
        ))
        .stdout(predicate::str::contains(format!(
            "  --> ps/demo-line/sets/axis-2.toml:{line_no}:1\n"
        )))
        .stdout(predicate::str::contains(
            "  ::: ps/demo-line/press.toml:19:11\n",
        ))
        .stdout(predicate::str::contains(
            "= help: the manifest's address is the truth: remove 82-SADDR from the set, or give drive `axis-2` address 1 in the manifest\n",
        ));

    let before = held(d, 2);
    driveset_in(d)
        .args(["commission", "ps/demo-line/press.toml", "--fresh"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "axis-1  press/1      unchanged        0  ",
        ))
        .stdout(predicate::str::contains(
            "axis-2  press/2      FAILED           0  -\n",
        ))
        .stdout(predicate::str::contains(format!(
            "\naxis-2: refused before anything was sent to the drive: ps/demo-line/sets/axis-2.toml:{line_no}:1: set `sets/axis-2.toml` gives 82-SADDR = 1, but the manifest puts drive `axis-2` at address 2 on bus `press` (ps/demo-line/press.toml:19:11: the drive's address in the manifest); the manifest's address is the truth: remove 82-SADDR from the set, or give drive `axis-2` address 1 in the manifest. A line run never writes a drive's bus address or line rate: give a drive its address with `driveset address` (or `driveset replace` for an exchanged unit)\n"
        )));
    assert_eq!(held(d, 2), before, "nothing was written to axis-2");
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(d.join("target/driveset-report/report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(r["drives"][1]["result"], "failed");
    assert_eq!(r["drives"][1]["codes_written"], 0);
    assert_eq!(r["drives"][1]["telegrams"], 0);
    // axis-2 is not on the bus's timeline: nothing was sent to it
    assert!(
        !r["buses"][0]["timeline"]
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t["drive"] == "axis-2")
    );
}
