//! `driveset schema check`: the built-in schemas pass, a broken fixture
//! schema reports each problem with its location, bad input exits 2.

use driveset_test_support::driveset;

fn check(args: &[&str]) -> (String, i32) {
    let out = driveset()
        .args(["schema", "check"])
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .expect("runs");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        out.status.code().expect("exit code"),
    )
}

const BROKEN: &str = "tests/data/sets/schemas/fictional-broken.toml";

#[test]
fn builtins_pass() {
    let (out, code) = check(&[]);
    assert_eq!(out, "0 findings in 0 of 4 schema files\n");
    assert_eq!(code, 0);
    // the same files given by path
    let (out, code) = check(&["schemas/"]);
    assert_eq!(out, "0 findings in 0 of 4 schema files\n");
    assert_eq!(code, 0);
}

#[test]
fn example_fixtures_pass() {
    let (out, code) = check(&["parameter-sets/fixtures/"]);
    assert_eq!(out, "0 findings in 0 of 3 schema files\n");
    assert_eq!(code, 0);
}

#[test]
fn broken_fixture_reports_every_problem() {
    let (out, code) = check(&[BROKEN]);
    assert_eq!(code, 1);
    assert_eq!(
        out,
        "error[schema-error]: code 9001: default is outside [min, max]
  --> tests/data/sets/schemas/fictional-broken.toml:16:11
   |
16 | default = \"150\"
   |           ^^^^^ here
   |
   = help: fix the default or the range

error[schema-error]: code 9001 is defined twice
  --> tests/data/sets/schemas/fictional-broken.toml:19:10
   |
19 | number = 9001
   |          ^^^^ here
   |
  ::: tests/data/sets/schemas/fictional-broken.toml:9:10
   |
 9 | number = 9001
   |          ^^^^ first defined here
   |
   = help: merge the two [[code]] entries

error[schema-error]: code 9002: value 300 (\"Too big\") is outside the raw range 0 ..= 255
  --> tests/data/sets/schemas/fictional-broken.toml:33:1
   |
33 | 300 = \"Too big\"
   | ^^^ here
   |
   = help: fix the value

error[schema-error]: code 9003: `default` is invalid: C9003 = 0.07 is not representable in steps of 0.05; nearest are 0.05 and 0.1
  --> tests/data/sets/schemas/fictional-broken.toml:41:11
   |
41 | default = \"0.07\"
   |           ^^^^^^ here
   |
   = help: give a value the type can hold exactly

4 findings in 1 of 1 schema file
"
    );
}

#[test]
fn github_and_json() {
    let (out, code) = check(&["--format", "github", BROKEN]);
    assert_eq!(code, 1);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines.first().copied(),
        Some(
            "::error file=tests/data/sets/schemas/fictional-broken.toml,line=16,col=11,title=schema-error::code 9001: default is outside [min, max]%0Ahelp: fix the default or the range"
        )
    );
    assert_eq!(lines.len(), 5);
    let (out, code) = check(&["--format", "json", BROKEN, "parameter-sets/fixtures/"]);
    assert_eq!(code, 1);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["summary"]["text"], "4 findings in 1 of 4 schema files");
    assert_eq!(
        v["files"][0]["findings"][1]["message"],
        "code 9001 is defined twice"
    );
    assert_eq!(v["files"][0]["findings"][1]["line"], 19);
}

#[test]
fn a_fact_on_an_untyped_code_is_not_an_error_but_a_real_problem_is() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.toml");
    std::fs::write(
        &p,
        "[schema]\nid = \"fictional-u\"\ntitle = \"FICTIONAL: u\"\nextends = \"lust-vf1000\"\nfictional = true\n\
         [[code]]\nnumber = 9000\nname = \"UNTYPED\"\ntitle = \"Untyped\"\nspec = \"fictional\"\nmin = 0\nmax = 10\ndefault = 99\n\
         [[code.bits]]\nname = \"b\"\nbits = [0, 0]\n\
         [[code]]\nnumber = 9001\nname = \"TYPED\"\ntitle = \"Typed\"\nspec = \"fictional\"\ntype = \"PT_USIGN8\"\nmin = 0\nmax = 10\ndefault = 99\n",
    )
    .unwrap();
    let (out, code) = check(&[p.to_str().unwrap()]);
    assert_eq!(code, 1);
    let out = out.replace(dir.path().to_str().unwrap(), "D");
    assert!(
        out.starts_with(
            "error[schema-error]: code 9001: default is outside [min, max]\n  --> D/s.toml:25:11\n"
        ),
        "{out}"
    );
    assert!(out.ends_with("1 finding in 1 of 1 schema file\n"));
}

#[test]
fn input_errors_exit_2() {
    // a set is not a schema
    let (out, code) = check(&["parameter-sets/tmd/base.toml"]);
    assert_eq!(code, 2);
    assert!(
        out.starts_with(
            "error: [schema] must be a table, found a string\n --> parameter-sets/tmd/base.toml:3:10\n"
        ),
        "{out}"
    );
    let (out, code) = check(&["no/such.toml"]);
    assert_eq!(code, 2);
    assert!(out.starts_with("error: cannot read no/such.toml: "));
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.toml");
    std::fs::write(&p, "[schema]\nid = \"x\"\ntitle = \"X\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\n[[code]]\nnumber = 1\nnmae = \"x\"\n").unwrap();
    let (out, code) = check(&[p.to_str().unwrap()]);
    assert_eq!(code, 2);
    let out = out.replace(dir.path().to_str().unwrap(), "D");
    assert!(
        out.starts_with("error: unknown key `nmae` in code 1\n --> D/s.toml:8:1\n"),
        "{out}"
    );
}
