//! `driveset pull` against simulated drives: the file re-loads (validate,
//! fingerprint) to the fingerprint the pull printed.

use predicates::prelude::*;

use driveset_test_support::{driveset, workspace_root};

fn fingerprint_line(stdout: &[u8]) -> String {
    let text = String::from_utf8_lossy(stdout);
    text.lines()
        .find_map(|l| l.strip_prefix("fingerprint: "))
        .expect("a fingerprint line")
        .to_string()
}

fn round_trip(port: &str, schema: Option<&str>, file: &str, extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join(file);
    let mut cmd = driveset();
    cmd.args(["pull", "--port", port, "--address", "1", "-o"])
        .arg(&out)
        .args(extra);
    if let Some(s) = schema {
        cmd.args(["--schema", s]);
    }
    let got = cmd.assert().code(0).get_output().stdout.clone();
    let fp = fingerprint_line(&got);
    assert!(fp.starts_with("sha256:"), "{fp}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains(&format!("# Fingerprint: {fp}")), "{text}");
    driveset()
        .args(["validate", "--schemas", "parameter-sets/fixtures"])
        .arg(&out)
        .assert()
        .code(0);
    driveset()
        .args(["fingerprint", "--schemas", "parameter-sets/fixtures"])
        .arg(&out)
        .assert()
        .code(0)
        .stdout(predicate::str::starts_with(format!("{fp}  ")));
    text
}

#[test]
fn pull_mc6000_toml_round_trip_with_schema_path() {
    let schema = workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml");
    let text = round_trip(
        "sim://mc6000?addresses=1",
        Some(schema.to_str().unwrap()),
        "axis.toml",
        &[],
    );
    assert!(text.starts_with("# Pulled by driveset from sim://mc6000?addresses=1 address 1.\n# Drive: lustbus-mc, 91-TYPE = "));
    assert!(text.contains(
        "\n[drive]\nport = \"sim://mc6000?addresses=1\"\naddress = 1\nprotocol = \"lustbus-mc\"\n"
    ));
    assert!(text.contains("#   85-SERR: reading clears it (status code)"));
    assert!(text.contains("# Read-only actual values (not part of the set): 77-SPEED = "));
    // the handshake and the overwrite command are no settings
    assert!(!text.contains("\n80 = "));
    assert!(!text.contains("\n4 = "));
    assert!(text.contains("\n[values]\n"));
}

#[test]
fn pull_tmd_yaml_changed_only_round_trip() {
    let text = round_trip("sim://tmd?addresses=1", None, "t.yaml", &["--changed-only"]);
    assert!(text.contains("schema: \"lenze-tmd\"\n"));
    assert!(text.contains("\ndrive:\n  port: \"sim://tmd?addresses=1\"\n  address: 1\n"));
    assert!(text.contains("equal to the factory default left out"));
    // a password is never read into the file
    assert!(text.contains("C0094 user_password: password"));
    // nor the bus address and line rate (the manifest gives them)
    assert!(
        text.contains("\n#   C0009 network_address: role `bus-address`: left out, the line manifest gives the drive's address and the bus's rate\n"),
        "{text}"
    );
    assert!(
        text.contains("\n#   C0125 lecom_baud_rate: role `baud-rate`: left out, the line manifest gives the drive's address and the bus's rate\n"),
        "{text}"
    );
    assert!(!text.contains("\n  \"C0009\": "), "{text}");
    assert!(!text.contains("\n  \"C0125\": "), "{text}");
}

#[test]
fn pull_vf1000_and_ecs_round_trip() {
    round_trip("sim://vf1000?addresses=1", None, "v.toml", &[]);
    round_trip("sim://ecs?addresses=1", None, "e.yml", &[]);
}

#[test]
fn pull_json_report_and_to_yaml() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.set");
    let got = driveset()
        .args([
            "pull",
            "--port",
            "sim://vf1000?addresses=1",
            "--address",
            "1",
            "--to",
            "yaml",
            "--format",
            "json",
            "--schema",
        ])
        .arg(workspace_root().join("parameter-sets/fixtures/fictional-vf1000-demo.toml"))
        .arg("-o")
        .arg(&out)
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&got).unwrap();
    assert_eq!(v["schema"], "fictional-vf1000-demo");
    assert!(v["fingerprint"].as_str().unwrap().starts_with("sha256:"));
    assert_eq!(
        v["left_out_bus_codes"],
        serde_json::json!(["81-SIOC", "82-SIOA"])
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("\nvalues:\n"));
}

/// An MC6000 schema against a VF1000: as on a serial line (a simulated
/// port is only a transport), the drive refuses the MC codes and the pull
/// says so (exit 1). LUSTBUS gives no TYPE values to tell the families
/// apart by identify (the schemas' `[schema.identify]` notes).
#[test]
fn pull_refuses_another_family() {
    let dir = tempfile::tempdir().unwrap();
    driveset()
        .args([
            "pull",
            "--port",
            "sim://vf1000?addresses=1",
            "--address",
            "1",
            "--schema",
            "lust-mc6000",
            "-o",
        ])
        .arg(dir.path().join("x.toml"))
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "error: sim://vf1000?addresses=1 address 1: 77-SPEED could not be read: the drive refused to read it",
        ));
}

#[test]
fn pull_with_transfer_baud_gives_the_same_file_as_at_9600() {
    let dir = tempfile::tempdir().unwrap();
    let pull = |file: &str, extra: &[&str]| {
        let out = dir.path().join(file);
        let got = driveset()
            .current_dir(dir.path())
            .args([
                "pull",
                "--port",
                "sim://mc6000?addresses=1",
                "--address",
                "1",
                "-o",
            ])
            .arg(&out)
            .args(extra)
            .assert()
            .code(0)
            .get_output()
            .clone();
        (
            fingerprint_line(&got.stdout),
            String::from_utf8_lossy(&got.stderr).to_string(),
        )
    };
    let (plain, _) = pull("plain.toml", &[]);
    let (fast, stderr) = pull("fast.toml", &["--transfer-baud", "57600"]);
    assert_eq!(plain, fast);
    assert!(
        stderr.contains("transfer rate 57600: saves ")
            && stderr.contains("line rate: the drive runs at 9600 baud again; 81-SBAUD = 9600\n"),
        "{stderr}"
    );
    // the in-process bus's journal, named by its bus (which names this
    // process: `sim:mc6000~PID`)
    let journal = std::fs::read_dir(dir.path().join(".driveset/journal"))
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("sim_mc6000_") && n.ends_with("-1.journal.json"))
        })
        .expect("the journal");
    let j = std::fs::read_to_string(journal).unwrap();
    let j: serde_json::Value = serde_json::from_str(&j).unwrap();
    assert_eq!(
        (j["state"].as_str(), j["transfer"]["state"].as_str()),
        (Some("complete"), Some("back"))
    );
}

/// Pull `address` of `port` with the fixture MC6000 schema into `out`
/// (`extra` arguments appended); stdout.
fn pull_demo_mc6000(port: &str, address: &str, out: &std::path::Path, extra: &[&str]) -> String {
    let schema = workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml");
    let got = driveset()
        .args(["pull", "--port", port, "--address", address, "--schema"])
        .arg(&schema)
        .arg("-o")
        .arg(out)
        .args(extra)
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    String::from_utf8(got).unwrap()
}

#[test]
fn pull_leaves_the_bus_address_and_rate_out_unless_kept() {
    let dir = tempfile::tempdir().unwrap();
    let port = "sim://mc6000?addresses=1";
    let plain = dir.path().join("plain.toml");
    let stdout = pull_demo_mc6000(port, "1", &plain, &[]);
    assert!(
        stdout.contains("\nleft out 81-SBAUD, 82-SADDR: the line manifest gives the drive's address and the bus's rate (--keep-bus-codes keeps them)\n"),
        "{stdout}"
    );
    assert!(!stdout.contains("not read: 81-SBAUD"), "{stdout}");
    let text = std::fs::read_to_string(&plain).unwrap();
    assert!(!text.contains("\n81 = "), "{text}");
    assert!(!text.contains("\n82 = "), "{text}");
    assert!(
        text.contains("\n#   82-SADDR: role `bus-address`: left out, the line manifest gives the drive's address and the bus's rate\n"),
        "{text}"
    );
    assert!(
        text.contains("\n#   81-SBAUD: role `baud-rate`: left out, the line manifest gives the drive's address and the bus's rate\n"),
        "{text}"
    );

    let kept = dir.path().join("kept.toml");
    let stdout = pull_demo_mc6000(port, "1", &kept, &["--keep-bus-codes"]);
    assert!(!stdout.contains("left out 8"), "{stdout}");
    let text = std::fs::read_to_string(&kept).unwrap();
    assert!(text.contains("\n81 = \"9600 Baud\"\n"), "{text}");
    assert!(text.contains("\n82 = 1\n"), "{text}");
}

/// `driveset validate LINE`, which must exit 1 (findings): its stdout.
fn validate_findings(line: &std::path::Path) -> String {
    let out = driveset()
        .arg("validate")
        .arg(line)
        .assert()
        .code(1)
        .get_output()
        .stdout
        .clone();
    String::from_utf8(out).unwrap()
}

/// Issue 20, "the manifest's address is the truth": axis-1's set pulled
/// with its bus codes and copied for axis-2 is caught by `validate LINE`,
/// naming the set's line and the manifest's address; the plain pull's copy
/// passes.
#[test]
fn validate_line_catches_a_set_copied_with_its_address() {
    let dir = tempfile::tempdir().unwrap();
    let sets = dir.path().join("sets");
    let axis1 = sets.join("axis-1.toml");
    pull_demo_mc6000(
        "sim://mc6000?addresses=1",
        "1",
        &axis1,
        &["--keep-bus-codes"],
    );
    let text = std::fs::read_to_string(&axis1).unwrap();
    std::fs::write(sets.join("axis-2.toml"), &text).unwrap();
    let line = dir.path().join("line.toml");
    std::fs::write(
        &line,
        "[[bus]]\nname = \"press\"\nport = \"sim://mc6000\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n\
         [[drive]]\nname = \"axis-1\"\nbus = \"press\"\naddress = 1\nset = \"sets/axis-1.toml\"\n\n\
         [[drive]]\nname = \"axis-2\"\nbus = \"press\"\naddress = 2\nset = \"sets/axis-2.toml\"\n",
    )
    .unwrap();
    let addr_line = text
        .lines()
        .position(|l| l == "82 = 1")
        .expect("82 in the kept set")
        + 1;
    let set2 = sets.join("axis-2.toml");
    let stdout = validate_findings(&line);
    let expected = format!(
        "error[rule-violation]: set `sets/axis-2.toml` gives 82-SADDR = 1, but the manifest puts drive `axis-2` at address 2 on bus `press`\n  --> {}:{addr_line}:1\n",
        set2.display()
    );
    assert!(stdout.starts_with(&expected), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "  ::: {}:16:11\n   |\n16 | address = 2\n   |           ^ the drive's address in the manifest\n",
            line.display()
        )),
        "{stdout}"
    );
    assert!(
        stdout.contains("   = help: the manifest's address is the truth: remove 82-SADDR from the set, or give drive `axis-2` address 1 in the manifest\n"),
        "{stdout}"
    );
    assert!(stdout.ends_with("1 finding in 1 of 1 file\n"), "{stdout}");

    // a bus rate other than the sets' 81-SBAUD: both sets are reported
    std::fs::write(
        &line,
        std::fs::read_to_string(&line)
            .unwrap()
            .replace("baud = 9600", "baud = 19200"),
    )
    .unwrap();
    let stdout = validate_findings(&line);
    for axis in ["axis-1", "axis-2"] {
        assert!(
            stdout.contains(&format!(
                "error[rule-violation]: set `sets/{axis}.toml` gives 81-SBAUD = 9600 Baud, but bus `press` of drive `{axis}` runs at 19200 baud\n"
            )),
            "{stdout}"
        );
    }
    assert!(
        stdout.contains("   = help: the manifest's rate is the truth: remove 81-SBAUD from the set, or give bus `press` the set's rate in the manifest\n"),
        "{stdout}"
    );
    assert!(stdout.ends_with("3 findings in 1 of 1 file\n"), "{stdout}");

    // the plain pull (no bus codes) copied for axis-2: 0 findings
    pull_demo_mc6000("sim://mc6000?addresses=1", "1", &axis1, &[]);
    std::fs::copy(&axis1, &set2).unwrap();
    driveset()
        .arg("validate")
        .arg(&line)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("0 findings"));
}
