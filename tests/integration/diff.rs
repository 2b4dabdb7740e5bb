//! `driveset diff`: added / removed / changed lines, --defaults, --unified,
//! json, exit codes 0 / 1 / 2.

use driveset_test_support::driveset;

const OLD: &str = "tests/data/sets/diff/old.toml";
const NEW: &str = "tests/data/sets/diff/new.yaml";
const SAME: &str = "tests/data/sets/diff/same-as-old.toml";
const ECS: &str = "tests/data/sets/diff/ecs.toml";

fn diff(args: &[&str]) -> (String, String, i32) {
    let out = driveset()
        .arg("diff")
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .expect("runs");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        String::from_utf8(out.stderr).expect("utf-8"),
        out.status.code().expect("exit code"),
    )
}

#[test]
fn added_removed_changed() {
    let (out, _, code) = diff(&[OLD, NEW]);
    assert_eq!(
        out,
        "--- tests/data/sets/diff/old.toml
+++ tests/data/sets/diff/new.yaml
+ C0010 minimum_output_frequency: (unset) -> 5 Hz
~ C0011 maximum_output_frequency: 50 Hz -> 60 Hz
- C0012 acceleration_time_1: 5 s -> (unset)
~ C0034 configuration_analog_input: \"0...10 V\" -> \"4...20 mA\"
4 differences (2 changed, 1 added, 1 removed)
"
    );
    assert_eq!(code, 1);
}

#[test]
fn same_values_in_other_spellings_are_equal() {
    let (out, _, code) = diff(&[OLD, SAME]);
    assert_eq!(
        out,
        "--- tests/data/sets/diff/old.toml\n+++ tests/data/sets/diff/same-as-old.toml\nno differences\n"
    );
    assert_eq!(code, 0);
    let (out, _, code) = diff(&["--unified", OLD, SAME]);
    assert_eq!((out.as_str(), code), ("", 0));
}

#[test]
fn against_factory_defaults() {
    let (out, _, code) = diff(&["--defaults", NEW]);
    assert_eq!(
        out,
        "--- factory defaults (lenze-tmd)
+++ tests/data/sets/diff/new.yaml
~ C0007 configuration_digital_inputs: { E1 = \"Activate fixed setpoint 1 (JOG1)\", E2 = \"Activate fixed setpoint 2 (JOG2)\", E3 = \"DC Braking (DCB)\", E4 = \"Direction of rotation\" } -> { E1 = \"Quick stop\", E2 = \"TRIP reset\", E3 = 0, E4 = 0 }
~ C0010 minimum_output_frequency: 0 Hz -> 5 Hz
~ C0011 maximum_output_frequency: 50 Hz -> 60 Hz
~ C0034 configuration_analog_input: \"0...10 V\" -> \"4...20 mA\"
4 differences (4 changed, 0 added, 0 removed)
"
    );
    assert_eq!(code, 1);
    // a code without a known factory default
    let (out, _, code) = diff(&["--defaults", "parameter-sets/tmd/conveyor-3.toml"]);
    assert_eq!(code, 1);
    assert!(out.contains("\n+ C0086 motor_rated_power: (no factory default known) -> 4 kW\n"));
}

#[test]
fn unified_diff_of_canonical_forms() {
    let (out, _, code) = diff(&["--unified", OLD, NEW]);
    assert_eq!(
        out,
        "--- tests/data/sets/diff/old.toml
+++ tests/data/sets/diff/new.yaml
@@ -1,6 +1,6 @@
 driveset-canonical 1
 schema lenze-tmd
 C0007 181
-C0011 500000
-C0012 50000
-C0034 0
+C0010 50000
+C0011 600000
+C0034 40000
"
    );
    assert_eq!(code, 1);
}

#[test]
fn json_format() {
    let (out, _, code) = diff(&["--format", "json", OLD, NEW]);
    assert_eq!(code, 1);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["schema"], "lenze-tmd");
    assert_eq!(v["equal"], false);
    assert_eq!(
        (
            v["changed"].as_u64(),
            v["added"].as_u64(),
            v["removed"].as_u64()
        ),
        (Some(2), Some(1), Some(1))
    );
    let e = &v["entries"][1];
    assert_eq!(e["code"], "C0011");
    assert_eq!(e["name"], "maximum_output_frequency");
    assert_eq!(e["kind"], "changed");
    assert_eq!(
        (e["old"].as_str(), e["new"].as_str()),
        (Some("50 Hz"), Some("60 Hz"))
    );
    assert_eq!(
        (e["old_raw"].as_i64(), e["new_raw"].as_i64()),
        (Some(500000), Some(600000))
    );
    assert_eq!(v["entries"][0]["kind"], "added");
    assert_eq!(v["entries"][0]["old"], serde_json::Value::Null);
    assert_eq!(v["entries"][2]["kind"], "removed");
    let (out, _, code) = diff(&["--format", "json", OLD, SAME]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["equal"], true);
    assert_eq!(v["entries"], serde_json::json!([]));
}

#[test]
fn errors_exit_2() {
    let (out, err, code) = diff(&[OLD, ECS]);
    assert_eq!((out.as_str(), code), ("", 2));
    assert_eq!(
        err,
        "error: cannot diff sets of different schemas: tests/data/sets/diff/old.toml is `lenze-tmd`, tests/data/sets/diff/ecs.toml is `lenze-ecs`\n  = help: compare sets of one drive family\n"
    );
    let (_, err, code) = diff(&[OLD, "no/such.toml"]);
    assert_eq!(code, 2);
    assert!(
        err.starts_with("error: cannot read no/such.toml: "),
        "{err}"
    );
    // a set with findings is not diffed
    let (out, err, code) = diff(&[OLD, "tests/data/sets/findings/out-of-range.toml"]);
    assert_eq!((out.as_str(), code), ("", 2));
    assert!(err.starts_with("error[out-of-range]: C0011 = 300 Hz is above the maximum 240 Hz\n"));
    assert!(err.ends_with("tests/data/sets/findings/out-of-range.toml: 2 findings; fix the set first (`driveset validate tests/data/sets/findings/out-of-range.toml`)\n"), "{err}");
    // usage: B is required without --defaults, and conflicts with it
    let (_, _, code) = diff(&[OLD]);
    assert_eq!(code, 2);
    let (_, _, code) = diff(&["--defaults", OLD, NEW]);
    assert_eq!(code, 2);
}
