//! `driveset fingerprint`: `sha256:...  FILE` lines; the same values in
//! another spelling or syntax give the same fingerprint.

use driveset_test_support::driveset;

fn fingerprint(args: &[&str]) -> (String, String, i32) {
    let out = driveset()
        .arg("fingerprint")
        .args(args)
        .output()
        .expect("runs");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        String::from_utf8(out.stderr).expect("utf-8"),
        out.status.code().expect("exit code"),
    )
}

#[test]
fn prints_sha256_and_file() {
    let (out, _, code) = fingerprint(&[
        "tests/data/sets/diff/old.toml",
        "tests/data/sets/diff/same-as-old.toml",
        "tests/data/sets/diff/new.yaml",
    ]);
    assert_eq!(code, 0);
    let lines: Vec<(&str, &str)> = out
        .lines()
        .map(|l| l.split_once("  ").expect("two spaces"))
        .collect();
    assert_eq!(lines.len(), 3);
    for (fp, _) in &lines {
        assert!(fp.starts_with("sha256:") && fp.len() == 71, "{fp}");
        assert!(
            fp[7..]
                .bytes()
                .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase())
        );
    }
    assert_eq!(lines[0].1, "tests/data/sets/diff/old.toml");
    // same values, other spellings: same fingerprint; other values: another
    assert_eq!(lines[0].0, lines[1].0);
    assert_ne!(lines[0].0, lines[2].0);
}

#[test]
fn is_the_sha256_of_the_canonical_form() {
    // sha256 of "driveset-canonical 1\nschema lenze-ecs\n" (an empty ECS set)
    let (out, _, code) = fingerprint(&["tests/data/sets/diff/ecs.toml"]);
    assert_eq!(code, 0);
    let canonical = driveset()
        .args(["show", "tests/data/sets/diff/ecs.toml"])
        .output()
        .unwrap()
        .stdout;
    assert_eq!(canonical, b"driveset-canonical 1\nschema lenze-ecs\n");
    assert_eq!(
        out,
        "sha256:e62f715224d9d7fe19c1a38f97f4f15e0a3cb06bd5e4f17c20c20c453f347249  tests/data/sets/diff/ecs.toml\n"
    );
}

#[test]
fn errors_exit_2_and_other_files_still_print() {
    let (out, err, code) = fingerprint(&[
        "tests/data/sets/findings/wrong-type.toml",
        "tests/data/sets/diff/old.toml",
    ]);
    assert_eq!(code, 2);
    assert!(out.ends_with("  tests/data/sets/diff/old.toml\n"));
    assert!(err.starts_with("error[wrong-type]: C0011 (VD) needs a number, found a boolean\n"));
    let (_, err, code) = fingerprint(&["no/such.toml"]);
    assert_eq!(code, 2);
    assert!(err.starts_with("error: cannot read no/such.toml: "));
}
