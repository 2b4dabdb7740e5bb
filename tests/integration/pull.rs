//! `driveset pull` against simulated drives: the file re-loads (validate,
//! fingerprint) to the fingerprint the pull printed.

use predicates::prelude::*;

use crate::util::{driveset, workspace_root};

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
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&got).unwrap();
    assert_eq!(v["schema"], "fictional-vf1000-demo");
    assert!(v["fingerprint"].as_str().unwrap().starts_with("sha256:"));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("\nvalues:\n"));
}

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
        .code(2)
        .stderr(predicate::str::contains("simulates vf1000 drives"));
    assert!(!dir.path().join("x.toml").exists());
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
    let j = std::fs::read_to_string(
        dir.path()
            .join(".driveset/journal/sim_mc6000-1.journal.json"),
    )
    .unwrap();
    let j: serde_json::Value = serde_json::from_str(&j).unwrap();
    assert_eq!(
        (j["state"].as_str(), j["transfer"]["state"].as_str()),
        (Some("complete"), Some("back"))
    );
}
