//! `driveset validate`: every finding kind (exact message, file:line:col, exit
//! code), bad input (exit 2 with a location), json and github formats, and
//! the example tree.

use std::path::Path;

use driveset_test_support::driveset;

const DATA: &str = "tests/data/sets/findings";

/// Run `driveset validate ARGS`, return (stdout, exit code).
fn validate(args: &[&str]) -> (String, i32) {
    let out = driveset()
        .arg("validate")
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .expect("runs");
    (
        String::from_utf8(out.stdout).expect("utf-8"),
        out.status.code().expect("exit code"),
    )
}

/// Validate one data file; assert the exit code, the summary and that each
/// `(kind, message, line, col)` is rendered as `error[kind]: message` followed
/// by `--> file:line:col`.
fn expect(file: &str, want: &[(&str, &str, usize, usize)]) -> String {
    let path = format!("{DATA}/{file}");
    let (out, code) = validate(&[&path]);
    assert_eq!(code, 1, "{out}");
    for (kind, message, line, col) in want {
        let head = format!("error[{kind}]: {message}\n");
        let at = format!("--> {path}:{line}:{col}\n");
        let i = out
            .find(&head)
            .unwrap_or_else(|| panic!("missing {head:?} in\n{out}"));
        let next = out[i + head.len()..].lines().next().unwrap_or("");
        assert_eq!(format!("{}\n", next.trim_start()), at, "{out}");
    }
    let n = want.len();
    let summary = format!(
        "{n} finding{} in 1 of 1 file\n",
        if n == 1 { "" } else { "s" }
    );
    assert!(out.ends_with(&summary), "{out}");
    assert_eq!(out.matches("error[").count(), n, "{out}");
    out
}

#[test]
fn example_tree_validates_clean() {
    // every example set, the fixture schemas (checked as schemas) and whatever
    // else lives in the tree (others add files: count only the known ones)
    let (out, code) = validate(&["parameter-sets/"]);
    assert!(out.starts_with("0 findings in 0 of "), "{out}");
    assert_eq!(out.lines().count(), 1, "{out}");
    assert_eq!(code, 0);
    let (out, code) = validate(&[
        "parameter-sets/tmd",
        "parameter-sets/mc6000",
        "parameter-sets/vf1000",
        "parameter-sets/ecs",
        "parameter-sets/fixtures",
    ]);
    assert_eq!(out, "0 findings in 0 of 15 files\n");
    assert_eq!(code, 0);
}

#[test]
fn unknown_code_by_number_and_by_name() {
    expect(
        "unknown-code.toml",
        &[
            ("unknown-code", "C0999 is not a code of lenze-tmd", 3, 1),
            (
                "unknown-code",
                "`max_output_freqency` is not a code name of lenze-tmd",
                4,
                1,
            ),
        ],
    );
    let (out, _) = validate(&[&format!("{DATA}/unknown-code.toml")]);
    assert!(out.contains("  = help: did you mean `maximum_output_frequency`?\n"));
}

#[test]
fn duplicate_code_by_number_and_by_name() {
    let out = expect(
        "duplicate-code.toml",
        &[
            (
                "duplicate-code",
                "C0011 is given twice in this file: as `C0011` (line 3) and as `11`",
                4,
                1,
            ),
            (
                "duplicate-code",
                "C0011 is given twice in this file: as `C0011` (line 3) and as `maximum_output_frequency`",
                5,
                1,
            ),
        ],
    );
    // the full rustc-style rendering of one finding, snippet and related place included
    assert!(
        out.starts_with(
            "error[duplicate-code]: C0011 is given twice in this file: as `C0011` (line 3) and as `11`
 --> tests/data/sets/findings/duplicate-code.toml:4:1
  |
4 | 11 = \"50 Hz\"
  | ^^ here
  |
 ::: tests/data/sets/findings/duplicate-code.toml:3:1
  |
3 | C0011 = \"50 Hz\"
  | ^^^^^ first given here
  |
  = help: keep one of them

"
        ),
        "{out}"
    );
}

#[test]
fn wrong_type() {
    expect(
        "wrong-type.toml",
        &[(
            "wrong-type",
            "C0011 (VD) needs a number, found a boolean",
            3,
            9,
        )],
    );
}

#[test]
fn out_of_range_and_negative_for_unsigned() {
    let out = expect(
        "out-of-range.toml",
        &[
            (
                "out-of-range",
                "C0011 = 300 Hz is above the maximum 240 Hz",
                3,
                9,
            ),
            (
                "out-of-range",
                "C0007 = -1 is negative, but VH is unsigned",
                4,
                9,
            ),
        ],
    );
    assert!(out.contains("  = help: give a value from 7.5 Hz to 240 Hz\n"));
    assert!(out.contains("^^^^^ maximum in the schema\n"), "{out}");
    assert!(out.contains("  = help: give a value from 0 to 65535\n"));
}

#[test]
fn unrepresentable_with_nearest_values() {
    let out = expect(
        "unrepresentable.toml",
        &[(
            "unrepresentable",
            "C0011 = 50.00005 is not representable in steps of 0.0001; nearest are 50 and 50.0001",
            3,
            9,
        )],
    );
    assert!(out.contains("  = help: write 50 or 50.0001\n"));
}

#[test]
fn not_an_enum_value() {
    let out = expect(
        "not-an-enum-value.toml",
        &[(
            "not-an-enum-value",
            "C0001 = 2.5 is not one of its values",
            4,
            9,
        )],
    );
    assert!(
        out.contains("  = help: use a label or one of: 0 = \"Analog / Terminal / Keypad\", 1 = \"Code c40 / Terminal / Keypad\", "),
        "{out}"
    );
}

#[test]
fn partial_enumeration_accepts_values_it_does_not_list() {
    let (out, code) = validate(&["tests/data/sets/findings/partial-enum.toml"]);
    assert_eq!((out.as_str(), code), ("0 findings in 0 of 1 file\n", 0));
}

#[test]
fn unknown_enum_label() {
    let out = expect(
        "unknown-enum-label.toml",
        &[(
            "unknown-enum-label",
            "C0034 has no label \"4...20 A\"",
            3,
            9,
        )],
    );
    assert!(
        out.contains("  = help: use one of: \"0...10 V\", "),
        "{out}"
    );
}

#[test]
fn unknown_bit_field() {
    let out = expect(
        "unknown-bit-field.toml",
        &[("unknown-bit-field", "C0007 has no bit field `E5`", 3, 30)],
    );
    assert!(out.contains("  = help: use one of: E1, E2, E3, E4\n"));
}

#[test]
fn read_only_write() {
    expect(
        "read-only.toml",
        &[(
            "read-only",
            "C0050 (output_frequency) is read-only; a set cannot write it",
            3,
            1,
        )],
    );
}

#[test]
fn rule_c0007_inputs_must_differ() {
    let out = expect(
        "rule-distinct.toml",
        &[(
            "rule-violation",
            "E1, E2, E3, E4 cannot have the same settings, otherwise \"CFG\" fault will be triggered: E1 and E3 are both 5 (\"Quick stop\")",
            3,
            54,
        )],
    );
    // the gutter is as wide as the longest line number of all places
    // (the schema's rule at line 1346)
    assert!(out.contains(
        "    ::: tests/data/sets/findings/rule-distinct.toml:3:16
     |
   3 | C0007 = { E1 = \"Quick stop\", E2 = \"TRIP reset\", E3 = \"Quick stop\" }
     |                ^^^^^^^^^^^^ E1 set here
"
    ));
    assert!(out.contains(" rule stated here\n"));
}

#[test]
fn rule_c0010_le_c0011_across_extends() {
    let out = expect(
        "rule-overlay.toml",
        &[(
            "rule-violation",
            "minimum output frequency C0010 must not exceed maximum output frequency C0011: C0010 = 60 Hz is greater than C0011 = 50 Hz",
            4,
            9,
        )],
    );
    // the other side of the rule is in the base file
    assert!(out.contains(
        "    ::: tests/data/sets/findings/rule-base.toml:3:9
     |
   3 | C0011 = \"50 Hz\"
     |         ^^^^^^^ C0011 set here
"
    ));
    assert!(out.contains("  = help: lower C0010 or raise C0011\n"));
}

#[test]
fn unknown_schema_with_suggestion() {
    let out = expect(
        "unknown-schema.toml",
        &[("unknown-schema", "unknown schema `lenze-tdm`", 1, 10)],
    );
    assert!(out.contains("  = help: did you mean `lenze-tmd`? known schemas: lenze-ecs, lenze-tmd, lust-mc6000, lust-vf1000\n"), "{out}");
}

#[test]
fn bad_extends_cycle_and_missing_base() {
    // the finding is in the base that leads back
    let (out, code) = validate(&[&format!("{DATA}/cycle-a.toml")]);
    assert_eq!(code, 1);
    assert!(out.starts_with(
        "error[bad-extends]: `extends = \"cycle-a.toml\"` forms a cycle: tests/data/sets/findings/cycle-a.toml is already being loaded
 --> tests/data/sets/findings/cycle-b.toml:2:11
  |
2 | extends = \"cycle-a.toml\"
  |           ^^^^^^^^^^^^^^ here
  |
  = help: remove the extends that leads back to this file
"
    ), "{out}");
    assert!(out.ends_with("1 finding in 1 of 1 file\n"));
    let out = expect(
        "missing-base.toml",
        &[(
            "bad-extends",
            "base set tests/data/sets/findings/no-such-base.toml cannot be read: cannot read tests/data/sets/findings/no-such-base.toml: No such file or directory (os error 2)",
            2,
            11,
        )],
    );
    assert!(out.contains("  = help: check the path; it is relative to the file that names it\n"));
}

#[test]
fn unknown_type() {
    expect(
        "unknown-type.toml",
        &[(
            "unknown-type",
            "the type of 81-SBAUD (SBAUD) is unknown, so it cannot be given a value",
            3,
            9,
        )],
    );
}

#[test]
fn unit_mismatch() {
    let out = expect(
        "unit-mismatch.toml",
        &[("unit-mismatch", "C0011 is in Hz, not rpm", 3, 9)],
    );
    assert!(out.contains("  = help: write the value in Hz, e.g. \"50 Hz\"\n"));
}

#[test]
fn lust_keys_in_spec_notation() {
    let out = expect(
        "lust-key.toml",
        &[(
            "unknown-code",
            "`82-FOO`: parameter 82 is 82-SADDR, not FOO",
            4,
            1,
        )],
    );
    assert!(out.contains("  = help: write `82-SADDR`, `82` or `SADDR`\n"));
}

#[test]
fn directory_summary_counts_files_and_findings() {
    let (out, code) = validate(&[DATA]);
    assert_eq!(code, 1);
    // 20 files; rule-base.toml and partial-enum.toml are the clean ones
    assert!(out.ends_with("21 findings in 18 of 20 files\n"), "{out}");
}

// ---------------------------------------------------------------------------
// bad input: exit 2 with a location, never a panic

fn bad_input(name: &str, content: &[u8]) -> (String, String) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, content).unwrap();
    let (out, code) = validate(&[p.to_str().unwrap()]);
    assert_eq!(code, 2, "{out}");
    assert!(
        out.ends_with("0 findings in 0 of 1 file; 1 file could not be read\n"),
        "{out}"
    );
    (out.replace(p.to_str().unwrap(), name), name.to_string())
}

#[test]
fn malformed_toml() {
    let (out, _) = bad_input("m.toml", b"schema = \"lenze-tmd\"\n[values\nC0011 = 1\n");
    assert!(out.starts_with(
        "error: malformed TOML: unclosed table, expected `]`
 --> m.toml:2:8
  |
2 | [values
  |        ^ here
  |
  = help: fix the TOML syntax at this position
"
    ));
}

#[test]
fn malformed_yaml() {
    let (out, _) = bad_input("m.yaml", b"schema: lenze-tmd\nvalues:\n  C0011: [1\n");
    assert!(
        out.starts_with(
            "error: malformed YAML: while parsing a flow sequence, expected ',' or ']'\n = note: at m.yaml:4:1\n"
        ),
        "{out}"
    );
    let (out, _) = bad_input("t.yaml", b"schema: lenze-tmd\n  values: x\n");
    assert!(out.starts_with("error: malformed YAML: "), "{out}");
    assert!(out.contains(" --> t.yaml:2:"), "{out}");
}

#[test]
fn binary_and_non_utf8() {
    let (out, _) = bad_input("b.toml", b"schema = \"lenze-tmd\"\x00\x01\x02");
    assert!(
        out.starts_with(
            "error: b.toml is a binary file (contains NUL bytes)\n = note: in b.toml\n"
        )
    );
    let (out, _) = bad_input("l.toml", b"schema = \"lenze-tmd\"\n# \xe9t\xe9\n");
    assert!(
        out.starts_with("error: l.toml is not UTF-8 text (invalid byte at offset 23)\n"),
        "{out}"
    );
}

#[test]
fn empty_files() {
    for content in [&b""[..], b"\n\n# only a comment\n", b"---\n"] {
        let (out, _) = bad_input("e.yaml", content);
        assert!(
            out.starts_with("error: e.yaml is empty\n = note: in e.yaml\n = help: a set needs at least `schema = \"...\"`\n"),
            "{out}"
        );
    }
}

#[test]
fn huge_file_and_10_mb_string() {
    let mut huge = b"schema = \"lenze-tmd\"\n[values]\n".to_vec();
    huge.extend(std::iter::repeat_n(&b"# padding\n"[..], 450_000).flatten());
    let (out, _) = bad_input("h.toml", &huge);
    assert!(out.starts_with("error: h.toml is larger than 4194304 bytes\n = note: in h.toml\n"));
    let mut s = b"schema = \"lenze-tmd\"\n[values]\nC0200 = \"".to_vec();
    s.extend(std::iter::repeat_n(b'x', 10 * 1024 * 1024));
    s.extend(b"\"\n");
    let (out, _) = bad_input("s.toml", &s);
    assert!(out.starts_with("error: s.toml is larger than 4194304 bytes\n"));
}

#[test]
fn long_values_within_the_limit_give_short_messages() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("long.toml");
    let mut s = String::from("schema = \"lenze-tmd\"\n[values]\nC0011 = \"");
    s.push_str(&"x".repeat(2 * 1024 * 1024));
    s.push_str("\"\nC0010 = ");
    s.push_str(&"1".repeat(1024 * 1024));
    s.push('\n');
    std::fs::write(&p, s).unwrap();
    let (out, code) = validate(&[p.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(out.len() < 4000, "{} bytes of output", out.len());
    assert!(out.contains(&format!(
        "error[wrong-type]: C0011 (VD) needs a number, found the text \"{}\"... (2097152 characters)\n",
        "x".repeat(60)
    )));
    assert!(out.contains("2 findings in 1 of 1 file"));
}

#[test]
fn unknown_top_level_key() {
    let (out, _) = bad_input(
        "k.toml",
        b"schema = \"lenze-tmd\"\ncolour = \"red\"\n[values]\n",
    );
    assert!(out.starts_with(
        "error: unknown top-level key `colour`
 --> k.toml:2:1
  |
2 | colour = \"red\"
  | ^^^^^^ here
  |
  = help: a set has schema, extends, title, [drive] and [values]; code values go under [values]
"
    ));
}

#[test]
fn nan_and_inf() {
    let (out, _) = bad_input("n.toml", b"schema = \"lenze-tmd\"\n[values]\nC0011 = nan\n");
    assert!(out.starts_with("error: `nan` is not a finite number\n --> n.toml:3:9\n"));
    let (out, _) = bad_input(
        "i.toml",
        b"schema = \"lenze-tmd\"\n[values]\nC0011 = -inf\n",
    );
    assert!(out.starts_with("error: `-inf` is not a finite number\n --> i.toml:3:9\n"));
    let (out, _) = bad_input(
        "i.yaml",
        b"schema: lenze-tmd\nvalues:\n  C0011: .inf\n  C0010: .nan\n",
    );
    assert!(out.starts_with("error: `.inf` is not a finite number\n --> i.yaml:3:10\n"));
}

#[test]
fn missing_path_and_input_errors_beside_findings() {
    let (out, code) = validate(&["no/such/file.toml"]);
    assert_eq!(code, 2);
    assert!(out.starts_with(
        "error: cannot read no/such/file.toml: No such file or directory (os error 2)\n = note: in no/such/file.toml\n"
    ));
    // an unreadable file wins over findings elsewhere: exit 2, both reported
    let (out, code) = validate(&[&format!("{DATA}/wrong-type.toml"), "no/such/file.toml"]);
    assert_eq!(code, 2);
    assert!(out.ends_with("1 finding in 1 of 2 files; 1 file could not be read\n"));
}

#[test]
fn usage_errors_exit_2() {
    let out = driveset().arg("validate").output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = driveset()
        .args(["validate", "--format", "xml", "parameter-sets/"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

// ---------------------------------------------------------------------------
// machine formats

#[test]
fn json_format() {
    let (out, code) = validate(&[
        "--format",
        "json",
        &format!("{DATA}/out-of-range.toml"),
        &format!("{DATA}/rule-base.toml"),
    ]);
    assert_eq!(code, 1);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["exit_code"], 1);
    assert_eq!(v["summary"]["findings"], 2);
    assert_eq!(v["summary"]["files"], 2);
    assert_eq!(v["summary"]["files_with_findings"], 1);
    assert_eq!(v["summary"]["text"], "2 findings in 1 of 2 files");
    let f = &v["files"][0]["findings"][0];
    assert_eq!(f["kind"], "out-of-range");
    assert_eq!(f["message"], "C0011 = 300 Hz is above the maximum 240 Hz");
    assert_eq!(f["help"], "give a value from 7.5 Hz to 240 Hz");
    assert_eq!(f["file"], "tests/data/sets/findings/out-of-range.toml");
    assert_eq!(
        (f["line"].as_u64(), f["column"].as_u64()),
        (Some(3), Some(9))
    );
    assert_eq!(f["related"][0]["label"], "maximum in the schema");
    assert_eq!(f["related"][0]["file"], "schemas/lenze-tmd.toml");
    assert_eq!(v["files"][0]["findings"][1]["kind"], "out-of-range");
    assert_eq!(v["files"][1]["ok"], true);
    assert_eq!(v["files"][1]["findings"], serde_json::json!([]));

    // input errors appear in the same document
    let (out, code) = validate(&["--format", "json", "no/such.toml"]);
    assert_eq!(code, 2);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["files"][0]["error"]["kind"], "input-error");
    assert_eq!(v["files"][0]["error"]["line"], serde_json::Value::Null);
    assert_eq!(v["summary"]["unreadable"], 1);
}

#[test]
fn github_format() {
    let (out, code) = validate(&[
        "--format",
        "github",
        &format!("{DATA}/out-of-range.toml"),
        &format!("{DATA}/unknown-bit-field.toml"),
    ]);
    assert_eq!(code, 1);
    assert_eq!(
        out,
        "::error file=tests/data/sets/findings/out-of-range.toml,line=3,col=9,title=out-of-range::C0011 = 300 Hz is above the maximum 240 Hz%0Ahelp: give a value from 7.5 Hz to 240 Hz
::error file=tests/data/sets/findings/out-of-range.toml,line=4,col=9,title=out-of-range::C0007 = -1 is negative, but VH is unsigned%0Ahelp: give a value from 0 to 65535
::error file=tests/data/sets/findings/unknown-bit-field.toml,line=3,col=30,title=unknown-bit-field::C0007 has no bit field `E5`%0Ahelp: use one of: E1, E2, E3, E4
3 findings in 2 of 2 files
"
    );
    let (out, code) = validate(&["--format", "github", "no/such.toml"]);
    assert_eq!(code, 2);
    assert!(out.starts_with(
        "::error file=no/such.toml,title=input-error::cannot read no/such.toml: No such file or directory (os error 2)%0Ahelp: check the path\n"
    ));
}

#[test]
fn no_colour_when_not_a_terminal() {
    // assert_cmd pipes stdout: plain text even without NO_COLOR
    let out = driveset()
        .args(["validate", &format!("{DATA}/wrong-type.toml")])
        .env_remove("NO_COLOR")
        .output()
        .unwrap();
    assert!(!String::from_utf8_lossy(&out.stdout).contains('\x1b'));
}

#[test]
fn fixture_schemas_in_the_tree_are_checked_as_schemas() {
    let dir = tempfile::tempdir().unwrap();
    let good = Path::new("parameter-sets/fixtures/fictional-ecs-demo.toml");
    std::fs::copy(
        driveset_test_support::workspace_root().join(good),
        dir.path().join("good.toml"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("broken.toml"),
        "[schema]\nid = \"fictional-broken\"\ntitle = \"FICTIONAL: broken\"\nextends = \"lenze-tmd\"\nfictional = true\n[[code]]\nnumber = 9001\nname = \"x\"\ntitle = \"X\"\nspec = \"fictional\"\ntype = \"PT_USIGN8\"\ndefault = \"300\"\n",
    )
    .unwrap();
    let (out, code) = validate(&[dir.path().to_str().unwrap()]);
    assert_eq!(code, 1, "{out}");
    let out = out.replace(dir.path().to_str().unwrap(), "D");
    assert!(out.starts_with(
        "error[schema-error]: code 9001: `default` is invalid: C9001 = 300 is outside the range of PT_USIGN8 (0 ..= 255)\n  --> D/broken.toml:12:11\n"
    ), "{out}");
    assert!(out.ends_with("1 finding in 1 of 2 files\n"));
}

#[test]
fn schemas_dir_adds_schemas_by_id() {
    let dir = tempfile::tempdir().unwrap();
    let schemas = dir.path().join("schemas");
    std::fs::create_dir(&schemas).unwrap();
    std::fs::write(
        schemas.join("fictional-extra.toml"),
        "[schema]\nid = \"fictional-extra\"\ntitle = \"FICTIONAL: extra\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\nfictional = true\n\n[[code]]\nnumber = 5001\nname = \"gain\"\ntitle = \"Gain\"\nspec = \"fictional\"\ntype = \"VD\"\n",
    )
    .unwrap();
    let p = dir.path().join("axis.toml");
    std::fs::write(&p, "schema = \"fictional-extra\"\n[values]\ngain = 1.5\n").unwrap();
    let p = p.to_str().unwrap();
    let (out, code) = validate(&["--schemas", schemas.to_str().unwrap(), p]);
    assert_eq!((out.as_str(), code), ("0 findings in 0 of 1 file\n", 0));
    let (out, code) = validate(&[p]);
    assert_eq!(code, 1);
    assert!(
        out.starts_with("error[unknown-schema]: unknown schema `fictional-extra`\n"),
        "{out}"
    );
    let (out, code) = validate(&["--schemas", "no/such/dir", p]);
    assert_eq!(code, 2);
    assert!(out.is_empty(), "{out}");
}

#[test]
fn simulator_fixture_schemas_are_known_by_path_or_with_schemas() {
    // The simulator's fictional fixtures are not built in (issue 9): a set
    // names one by path, or the fixtures' directory is given explicitly.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("axis.toml");
    std::fs::write(
        &p,
        "schema = \"fictional-ecs-demo\"\n[values]\nmax_speed = \"3000 rpm\"\n",
    )
    .unwrap();
    let (out, code) = validate(&["--schemas", "parameter-sets/fixtures", p.to_str().unwrap()]);
    assert_eq!((out.as_str(), code), ("0 findings in 0 of 1 file\n", 0));
    let (out, code) = validate(&[p.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}");
    assert!(out.starts_with("error[unknown-schema]: schema `fictional-ecs-demo` is a fictional fixture of the simulator; a set cannot name it by id\n"), "{out}");
    let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../parameter-sets/fixtures/fictional-ecs-demo.toml");
    std::fs::write(
        &p,
        format!(
            "schema = {:?}\n[values]\nmax_speed = \"3000 rpm\"\n",
            fixture.display().to_string()
        ),
    )
    .unwrap();
    let (out, code) = validate(&[p.to_str().unwrap()]);
    assert_eq!((out.as_str(), code), ("0 findings in 0 of 1 file\n", 0));
}

/// The simulator's fictional fixture schemas are not built in: a user's set
/// naming one by id gets a finding that says to name its file (issue 9); a
/// bus command refuses the set (exit 2) before opening the port.
#[test]
fn fictional_fixture_schema_by_id_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("f.toml");
    std::fs::write(
        &set,
        "schema = \"fictional-mc6000-demo\"\n[values]\nSWDGT = 100\n",
    )
    .unwrap();
    let set = set.display().to_string();
    let (out, code) = validate(&[&set]);
    let help = "name its file instead (schema = \"PATH\", relative to this set; in driveset's sources it is parameter-sets/fixtures/fictional-mc6000-demo.toml), or a schema of a real drive: lenze-ecs, lenze-tmd, lust-mc6000, lust-vf1000";
    assert_eq!(
        (out.as_str(), code),
        (
            format!(
                "error[unknown-schema]: schema `fictional-mc6000-demo` is a fictional fixture of the simulator; a set cannot name it by id
 --> {set}:1:10
  |
1 | schema = \"fictional-mc6000-demo\"
  |          ^^^^^^^^^^^^^^^^^^^^^^^ here
  |
  = help: {help}

1 finding in 1 of 1 file
"
            )
            .as_str(),
            1
        )
    );
    let out = driveset()
        .args(["upload", &set, "--port", "/dev/null", "--address", "1"])
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&out.stdout), "");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error[unknown-schema]: schema `fictional-mc6000-demo` is a fictional fixture of the simulator; a set cannot name it by id\n"),
        "{err}"
    );
    assert!(
        err.ends_with(&format!("error: {set}: not uploaded\n")),
        "{err}"
    );
}

#[test]
fn a_password_under_a_wrong_key_is_masked_in_every_format() {
    // issue 17: `"C0094/1"` is not a code, but its value is the password's
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("w.toml"),
        "schema = \"lenze-tmd\"\n[values]\n\"C0094/1\" = 7771\n",
    )
    .unwrap();
    let run = |format: &str| {
        let out = driveset()
            .current_dir(dir.path())
            .args(["validate", "--format", format, "w.toml"])
            .assert()
            .code(1)
            .get_output()
            .clone();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(!text.contains("7771"), "{format}: {text}");
        text
    };
    assert_eq!(
        run("human"),
        "error[unknown-code]: C0094 has no subcodes\n --> w.toml:3:1\n  |\n3 | \"C0094/1\" = <secret>\n  | ^^^^^^^^^ here\n  |\n  = help: write `C0094` without `/N`\n\n1 finding in 1 of 1 file\n"
    );
    assert!(
        run("junit").contains("  | &quot;C0094/1&quot; = &lt;secret&gt;\n"),
        "junit snippet"
    );
    run("json");
    run("github");
}

#[test]
fn a_syntax_error_on_a_password_line_masks_the_value() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text, line) in [
        (
            "dup.toml",
            "schema = \"lenze-tmd\"\n[values]\nC0094 = 7771\nC0094 = 8812\n",
            "4 | C0094 = <secret>",
        ),
        (
            "bare.toml",
            "schema = \"lenze-tmd\"\n[values]\nuser_password = 8812 x\n",
            "3 | user_password = <secret>",
        ),
    ] {
        std::fs::write(dir.path().join(name), text).unwrap();
        for format in ["human", "json", "github", "junit"] {
            let out = driveset()
                .current_dir(dir.path())
                .args(["validate", "--format", format, name])
                .assert()
                .code(2)
                .get_output()
                .clone();
            let shown = String::from_utf8_lossy(&out.stdout);
            assert!(
                !shown.contains("8812") && !shown.contains("7771"),
                "{name} {format}: {shown}"
            );
            if format == "human" {
                assert!(shown.contains(line), "{name}: {shown}");
            }
        }
    }
}
