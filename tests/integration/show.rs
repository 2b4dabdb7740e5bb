//! `driveset show`: canonical form, and conversions TOML -> YAML -> TOML ->
//! JSON that never change the fingerprint (a Tmd, an MC6000 and an ECS set).

use std::path::Path;

use driveset_test_support::driveset;

fn run(args: &[&str]) -> (String, String, i32) {
    let out = driveset().args(args).output().expect("runs");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        String::from_utf8(out.stderr).expect("utf-8"),
        out.status.code().expect("exit code"),
    )
}

fn fingerprint_of(path: &str) -> String {
    let (out, err, code) = run(&["fingerprint", "--schemas", "parameter-sets/fixtures", path]);
    assert_eq!(code, 0, "{err}");
    out.split_once("  ")
        .expect("fingerprint line")
        .0
        .to_string()
}

#[test]
fn canonical_form() {
    let (out, _, code) = run(&["show", "tests/data/sets/diff/new.yaml"]);
    assert_eq!(code, 0);
    assert_eq!(
        out,
        "driveset-canonical 1\nschema lenze-tmd\nC0007 181\nC0010 50000\nC0011 600000\nC0034 40000\n"
    );
}

#[test]
fn conversion_output() {
    let (out, _, code) = run(&["show", "--to", "toml", "tests/data/sets/diff/new.yaml"]);
    assert_eq!(code, 0);
    assert_eq!(
        out,
        "schema = \"lenze-tmd\"
title = \"diff test, new\"

[values]
C0007 = { E1 = \"Quick stop\", E2 = \"TRIP reset\" }
C0010 = \"5 Hz\"
C0011 = \"60 Hz\"
C0034 = \"4...20 mA\"
"
    );
    let (out, _, _) = run(&["show", "--to", "json", "tests/data/sets/diff/new.yaml"]);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["values"]["C0011"], "60 Hz");
    assert_eq!(v["values"]["C0007"]["E2"], "TRIP reset");
}

/// TOML -> `show --to yaml` -> file -> `show --to toml` -> file -> `show --to json` -> file.
fn round_trip(set: &str) {
    let dir = tempfile::tempdir().unwrap();
    let original = fingerprint_of(set);
    let mut from = set.to_string();
    for (to, name) in [("yaml", "a.yaml"), ("toml", "b.toml"), ("json", "c.json")] {
        let (out, err, code) = run(&[
            "show",
            "--schemas",
            "parameter-sets/fixtures",
            "--to",
            to,
            &from,
        ]);
        assert_eq!(code, 0, "{from} --to {to}: {err}");
        let p = dir.path().join(name);
        std::fs::write(&p, &out).unwrap();
        from = p.to_str().unwrap().to_string();
        assert_eq!(fingerprint_of(&from), original, "{set} -> {name}:\n{out}");
    }
    // the canonical forms agree too
    let canon = |p: &str| run(&["show", "--schemas", "parameter-sets/fixtures", p]).0;
    assert_eq!(canon(set), canon(&from));
    assert!(Path::new(&from).exists());
}

#[test]
fn round_trip_tmd() {
    round_trip("parameter-sets/tmd/conveyor-3.toml");
}

#[test]
fn round_trip_mc6000() {
    round_trip("parameter-sets/mc6000/axis-1.toml");
}

#[test]
fn round_trip_ecs() {
    round_trip("parameter-sets/ecs/axis-1.toml");
}

#[test]
fn round_trip_yaml_and_extends_sets() {
    round_trip("parameter-sets/mc6000/axis-3.yaml");
    round_trip("parameter-sets/vf1000/conveyor-1.toml");
}

#[test]
fn errors_exit_2() {
    let (out, err, code) = run(&["show", "tests/data/sets/findings/wrong-type.toml"]);
    assert_eq!((out.as_str(), code), ("", 2));
    assert!(err.starts_with("error[wrong-type]: "));
    let (_, _, code) = run(&["show", "--to", "xml", "tests/data/sets/diff/new.yaml"]);
    assert_eq!(code, 2);
    let (_, err, code) = run(&["show", "tests/data/sets/input-missing.toml"]);
    assert_eq!(code, 2);
    assert!(err.starts_with("error: cannot read tests/data/sets/input-missing.toml: "));
}
