//! `driveset identify` and `driveset scan` against simulated buses
//! (`sim://` ports, virtual time), and the port / protocol checks.

use predicates::prelude::*;

use driveset_test_support::driveset;

#[test]
fn identify_mc6000() {
    driveset()
        .args([
            "identify",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("family:   lustbus-mc\n"))
        .stdout(predicate::str::contains("91-TYPE: "))
        .stdout(predicate::str::contains("schema:   lust-mc6000 (fits)\n"));
}

#[test]
fn identify_vf1000() {
    driveset()
        .args([
            "identify",
            "--port",
            "sim://vf1000?addresses=2",
            "--address",
            "2",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("family:   lustbus-vf1000\n"))
        .stdout(predicate::str::contains("schema:   lust-vf1000 (fits)\n"));
}

#[test]
fn identify_tmd_reports_type_codes_and_software() {
    driveset()
        .args([
            "identify",
            "--port",
            "sim://tmd?addresses=3",
            "--address",
            "3",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("family:   lecom\n"))
        .stdout(predicate::str::contains("C0200: 33STMD-M_12000\n"))
        .stdout(predicate::str::contains("software: 1.20\n"))
        .stdout(predicate::str::contains("schema:   lenze-tmd (fits)\n"));
}

#[test]
fn identify_ecs_json() {
    let out = driveset()
        .args([
            "identify",
            "--port",
            "sim://ecs?addresses=5",
            "--address",
            "5",
            "--format",
            "json",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["protocol"], "lenze-can-sdo");
    assert_eq!(v["schema"], "lenze-ecs");
    assert_eq!(v["fits"], true);
    assert_eq!(v["address"], 5);
}

#[test]
fn identify_lustbus_protocol_tells_mc_from_vf1000() {
    driveset()
        .args([
            "identify",
            "--port",
            "sim://vf1000?addresses=2",
            "--address",
            "2",
            "--protocol",
            "lustbus",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("schema:   lust-vf1000 (fits)\n"))
        .stdout(predicate::str::contains(
            "the MC6000/7000 CODE 20091 not: a VF1000",
        ));
    driveset()
        .args([
            "identify",
            "--port",
            "sim://mc6000?addresses=2",
            "--address",
            "2",
            "--protocol",
            "lustbus",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("schema:   lust-mc6000 (fits)\n"));
}

/// A schema of another protocol on a character line: the drive does not
/// understand its telegrams, as on a serial line (a simulated port is only
/// a transport; the port's kind of link is what is refused up front).
#[test]
fn identify_refuses_a_schema_of_another_protocol() {
    driveset()
        .args([
            "identify", "--port", "sim://mc6000?addresses=1", "--address", "1", "--schema",
            "lenze-tmd",
        ])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "error: sim://mc6000?addresses=1 address 1: no answer to identify: read C0093 after 3 tries; check wiring, address and baud rate",
        ));
    driveset()
        .args([
            "identify",
            "--port",
            "sim://ecs?addresses=1",
            "--address",
            "1",
            "--schema",
            "lust-mc6000",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("is a CAN port"));
}

#[test]
fn identify_probes_real_ports_and_needs_a_valid_port() {
    // No family given: the port is opened for the read-only probes.
    driveset()
        .args(["identify", "--port", "/dev/ttyUSB0", "--address", "1"])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "error: cannot open /dev/ttyUSB0: /dev/ttyUSB0: no such serial device",
        ));
    driveset()
        .args([
            "identify",
            "--port",
            "bogus://x",
            "--address",
            "1",
            "--protocol",
            "lecom",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("invalid port `bogus://x`"));
}

#[test]
fn identify_no_drive_at_the_address_is_a_bus_failure() {
    driveset()
        .args([
            "identify",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "4",
        ])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "address 4: no drive answered the read-only probes",
        ));
}

#[test]
fn scan_mc6000_finds_exactly_3_and_7() {
    driveset()
        .args([
            "scan",
            "--port",
            "sim://mc6000?addresses=3,7",
            "--protocol",
            "lustbus",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::starts_with(
            "scanned sim://mc6000?addresses=3,7 (LUSTBUS addresses 1..30)\naddress 3: 91-TYPE = ",
        ))
        .stdout(predicate::str::contains("\naddress 7: 91-TYPE = "))
        .stdout(predicate::str::ends_with("2 drives found\n"));
    let out = driveset()
        .args([
            "scan",
            "--port",
            "sim://mc6000?addresses=3,7",
            "--protocol",
            "lustbus",
            "--format",
            "json",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let found: Vec<u64> = v["found"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["address"].as_u64().unwrap())
        .collect();
    assert_eq!(found, vec![3, 7]);
    assert_eq!(v["protocol"], "lustbus");
}

#[test]
fn scan_lecom_and_can() {
    driveset()
        .args([
            "scan",
            "--port",
            "sim://tmd?addresses=3,17",
            "--protocol",
            "lecom",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("address 3: C0093 = "))
        .stdout(predicate::str::contains("address 17: C0093 = "))
        .stdout(predicate::str::ends_with("2 drives found\n"));
    driveset()
        .args(["scan", "--port", "sim://ecs?addresses=4,100"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("(CAN node ids 1..127)"))
        .stdout(predicate::str::contains("address 4: "))
        .stdout(predicate::str::contains("address 100: "))
        .stdout(predicate::str::ends_with("2 drives found\n"));
}

#[test]
fn scan_detect_baud_reports_a_rate() {
    driveset()
        .args([
            "scan",
            "--port",
            "sim://vf1000?addresses=5",
            "--protocol",
            "lustbus",
            "--detect-baud",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("baud rate: "))
        .stdout(predicate::str::contains("address 5: 91-TYPE = "));
}

/// Scanning a LUSTBUS line for LECOM stations finds none, as on a serial
/// line; without --protocol the line's protocol is found, whatever transport.
#[test]
fn scan_protocol_must_fit_the_simulated_family() {
    driveset()
        .args([
            "scan",
            "--port",
            "sim://mc6000?addresses=3",
            "--protocol",
            "lecom",
        ])
        .assert()
        .code(3)
        .stdout(predicate::str::ends_with("0 drives found\n"))
        .stderr(predicate::str::contains(
            "error: no drive answered on sim://mc6000?addresses=3",
        ));
    // no --protocol: the line's protocol is found by the probes, as on
    // a serial line (issue 28)
    driveset()
        .args(["scan", "--port", "sim://mc6000?addresses=3"])
        .assert()
        .code(0)
        .stdout("scanned sim://mc6000?addresses=3 (LUSTBUS addresses 1..30)\naddress 3: 91-TYPE = 6000\n1 drive found\n");
}

#[test]
fn schema_pull_mc6000_passes_schema_check() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pulled-mc.toml");
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
            "--family",
            "mc6000",
            "--params",
            "1-200",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0)
        .stdout(predicate::str::starts_with("pulled "))
        .stdout(predicate::str::contains("(schema id pulled-mc6000-1)"));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("protocol = \"lustbus-mc\"\n"));
    assert!(text.contains("\nextends = \"lust-mc6000\"\n"));
    assert!(text.contains("spec = \"learned from the drive's descriptions (sim://mc6000?addresses=1 address 1); spec facts from lust-mc6000\"\n"));
    // the spec's name stands
    assert!(text.contains("\nnumber = 4\nname = \"PROG\"\n"));
    // substitution texts became enumeration labels (100-PWMF: the spec
    // gives it no values)
    assert!(text.contains("\n[code.values]\n0 = \"4 kHz\"\n"));
    // units come from the 107-UNIT texts
    assert!(text.contains("unit = \"Baud\"\n"));
    driveset()
        .args(["schema", "check"])
        .arg(&out)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("0 findings"));
}

#[test]
fn schema_pull_vf1000_passes_schema_check() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pulled-vf.toml");
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://vf1000?addresses=2",
            "--address",
            "2",
            "--family",
            "vf1000",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("protocol = \"lustbus-vf1000\"\n"));
    assert!(text.contains("basis = "));
    driveset()
        .args(["schema", "check"])
        .arg(&out)
        .assert()
        .code(0);
}

#[test]
fn schema_pull_refuses_the_wrong_family_and_bad_ranges() {
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
            "--family",
            "vf1000",
            "-o",
            "/nonexistent/x.toml",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "error: sim://mc6000?addresses=1 address 1: the drive answers as Lust MASTERCONTROL MC6000/7000 (LUSTBUS ENQUIRY of 91-TYPE answered (6000) and the MC6000/7000 CODE 20091 too), not Lust SMARTDRIVE VF1000; nothing written",
        ));
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
            "--family",
            "mc6000",
            "--params",
            "5-1",
            "-o",
            "/nonexistent/x.toml",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--params: `5-1`: a range goes up"));
}

/// Issue 12: a drive left at the transfer rate by an interrupted
/// `--transfer-baud` upload (the cable pulled after the switch; the
/// simulator's state file keeps the drive's rate, as a powered drive keeps
/// it) is found by `identify` and `scan` through the rate search
/// (LUSTBUS 5.1), and they say at which rate and what to do.
#[test]
fn identify_and_scan_find_a_drive_left_at_the_transfer_rate() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("sim");
    std::fs::create_dir_all(&state).unwrap();
    let set = driveset_test_support::workspace_root().join("parameter-sets/mc6000/axis-1.toml");
    driveset()
        .env("DRIVESET_SIM_STATE_DIR", &state)
        .current_dir(dir.path())
        .args(["upload"])
        .arg(&set)
        .args([
            "--port",
            "sim://mc6000?addresses=1&faults=cable@60+600s",
            "--address",
            "1",
            "--transfer-baud",
            "57600",
            "--journal",
            "j.json",
        ])
        .assert()
        .code(3)
        .stderr(predicate::str::contains(
            "the drive answers at no rate (it may still run at the transfer rate 57600 baud; its 81-SBAUD holds 9600 in EEPROM, so a restart brings it to that rate)",
        ));
    let note = "the drive answers at 57600 baud, not at the port's 9600 (left at a transfer rate by an interrupted --transfer-baud? `driveset recover JOURNAL` switches it back; or add ?baud=57600 to the port)\n";
    driveset()
        .env("DRIVESET_SIM_STATE_DIR", &state)
        .args([
            "identify",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains("family:   lustbus-mc\n"))
        .stdout(predicate::str::contains(format!("note:     {note}")));
    driveset()
        .env("DRIVESET_SIM_STATE_DIR", &state)
        .args(["scan", "--port", "sim://mc6000?addresses=1", "--protocol", "lustbus"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "baud rate: 57600, not the port's 9600 (a drive left at a transfer rate by an interrupted --transfer-baud? `driveset recover JOURNAL` switches it back; or add ?baud=57600 to the port)\naddress 1: 91-TYPE = 6000\n1 drive found\n",
        ));
    // without the state file's rate the drive would answer at 9600: the
    // search is what found it
    let dump = std::fs::read_to_string(
        std::fs::read_dir(&state)
            .unwrap()
            .next()
            .unwrap()
            .unwrap()
            .path(),
    )
    .unwrap();
    let dump: serde_json::Value = serde_json::from_str(&dump).unwrap();
    assert_eq!(dump["drives"][0]["rate"], 57600, "{dump}");
}
