//! Issue 18 through the built binary: drives whose own descriptions
//! contradict the spec (the simulator's `describe=` key: another kind,
//! type, range or unit, a code the spec calls a command) for VF1000 and
//! MC6000, one-step (`pull`) and two-step (`schema pull`, then `pull
//! --schema`): the spec's fact stands, the report names code, both facts
//! and the spec section, the learned file records the drive's guess and
//! the pulled files validate offline. README's two flows in every MC
//! description layout and for the VF1000; a learned file is used as it is
//! and learned on top of only for the parameters it did not ask for.

use std::path::Path;

use predicates::prelude::*;

use driveset_test_support::{driveset, driveset_in, sim_dir};

/// The learned files (`*.toml` other than the sets) in `dir`.
fn learned_files(dir: &Path) -> Vec<std::path::PathBuf> {
    driveset_test_support::toml_files_starting(dir, "learned-")
}

/// (family, describe=, the report's line, the learned file's comment).
const CASES: [(&str, &str, &str, &str); 10] = [
    (
        "vf1000",
        "11:actual:binary8",
        "11-STAT: the drive describes an actual value (kind 1, BINARY8); lustbus-protocol.txt section 8.1.1 makes it a command: kept as a command, left out of the set",
        "# drive says: kind = \"ram-actual\" (a guess; the spec's role = \"command\" stands, lustbus-protocol.txt section 8.1.1)\n[[code]]\nnumber = 11\n",
    ),
    (
        "vf1000",
        "5:usign16",
        "5-FSSIO: the drive describes type PT_USIGN16; lustbus-protocol.txt section 6.2.2, section 7.1, section 7.1.1 gives type PT_FIXPOINT16: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: type = \"PT_USIGN16\" (a guess; the spec's type = \"PT_FIXPOINT16\" stands, lustbus-protocol.txt section 6.2.2, section 7.1, section 7.1.1)\n[[code]]\nnumber = 5\n",
    ),
    (
        "vf1000",
        "5:unit=rpm",
        "5-FSSIO: the drive describes unit rpm; lustbus-protocol.txt section 6.2.2, section 7.1, section 7.1.1 gives unit Hz: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: unit = \"rpm\" (a guess; the spec's unit = \"Hz\" stands, lustbus-protocol.txt section 6.2.2, section 7.1, section 7.1.1)\n",
    ),
    (
        "vf1000",
        "84:default=5",
        "84-SIOT: the drive describes default 5; lustbus-protocol.txt section 1, section 5.2 gives default 0: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: default = \"5\" (a guess; the spec's default = \"0\" stands, lustbus-protocol.txt section 1, section 5.2)\n",
    ),
    (
        "vf1000",
        "83:eeprom",
        "83-SIOW: the drive describes kind eeprom; lustbus-protocol.txt section 5.2 gives kind ram-control: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: kind = \"eeprom\" (a guess; the spec's kind = \"ram-control\" stands, lustbus-protocol.txt section 5.2)\n",
    ),
    (
        "mc6000",
        "4:actual",
        "4-PROG: the drive describes an actual value (kind 0, USIGN8); lustbus-protocol.txt section 10 (exception 1), section 11.5 makes it a command: kept as a command, left out of the set",
        "# drive says: kind = \"ram-actual\" (a guess; the spec's role = \"command\" stands, lustbus-protocol.txt section 10 (exception 1), section 11.5)\n[[code]]\nnumber = 4\n",
    ),
    (
        "mc6000",
        "77:integer16:min=-100:max=100:default=0",
        "77-SPEED: the drive describes type PT_INTEGER16; lustbus-protocol.txt section 6.1.1.2 gives type PT_INT32Q16: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: type = \"PT_INTEGER16\" (a guess; the spec's type = \"PT_INT32Q16\" stands, lustbus-protocol.txt section 6.1.1.2)\n",
    ),
    (
        "mc6000",
        "77:unit=rpm",
        "77-SPEED: the drive describes unit rpm; lustbus-protocol.txt section 6.1.1.2 gives unit 1/min: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: unit = \"rpm\" (a guess; the spec's unit = \"1/min\" stands, lustbus-protocol.txt section 6.1.1.2)\n",
    ),
    (
        "mc6000",
        "84:default=5",
        "84-SWDGT: the drive describes default 5; lustbus-protocol.txt section 1, section 5.2 gives default 0: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: default = \"5\" (a guess; the spec's default = \"0\" stands, lustbus-protocol.txt section 1, section 5.2)\n",
    ),
    (
        "mc6000",
        "83:eeprom",
        "83-SDMMY: the drive describes kind eeprom; lustbus-protocol.txt section 5.2 gives kind ram-control: the spec's stands (the drive's recorded in the learned file)",
        "# drive says: kind = \"eeprom\" (a guess; the spec's kind = \"ram-control\" stands, lustbus-protocol.txt section 5.2)\n",
    ),
];

/// The pulled set and the learned file validate offline (no port, no
/// simulator state), the learned file with 0 findings.
fn offline_ok(set: &Path, schema: &Path) {
    driveset().arg("validate").arg(set).assert().code(0);
    driveset()
        .args(["schema", "check"])
        .arg(schema)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("0 findings"));
}

#[test]
fn one_step_pull_keeps_the_spec_where_the_drive_contradicts_it() {
    for (family, describe, line, comment) in CASES {
        let dir = tempfile::tempdir().unwrap();
        let port = format!("sim://{family}?addresses=1&describe={describe}");
        let out = driveset_in(dir.path())
            .args(["pull", "--port", &port, "--address", "1", "--schema"])
            .arg(format!("lust-{family}"))
            .args(["-o", "set.toml"])
            .assert()
            .code(0)
            .get_output()
            .clone();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(
            stderr.contains(&format!("\n{line}\n")),
            "{describe}: {stderr}"
        );
        let files = learned_files(dir.path());
        assert_eq!(files.len(), 1, "{files:?}");
        let text = std::fs::read_to_string(&files[0]).unwrap();
        assert!(text.contains(comment), "{describe}: {text}");
        assert!(text.contains("\n[schema.learned]\nasked = \"1-"), "{text}");
        let set = dir.path().join("set.toml");
        offline_ok(&set, &files[0]);
        // The command stays out of the set.
        let set_text = std::fs::read_to_string(&set).unwrap();
        if describe == "11:actual:binary8" {
            assert!(!set_text.contains("\n11 = "), "{set_text}");
        }
        if describe == "4:actual" {
            assert!(!set_text.contains("\n4 = "), "{set_text}");
        }
    }
}

#[test]
fn two_step_schema_pull_then_pull_with_the_learned_file() {
    for (family, describe, line, comment) in CASES {
        let dir = tempfile::tempdir().unwrap();
        let port = format!("sim://{family}?addresses=1&describe={describe}");
        driveset_in(dir.path())
            .args(["schema", "pull", "--port", &port, "--address", "1"])
            .args(["--family", family, "-o", "drive.toml"])
            .assert()
            .code(0)
            .stdout(predicate::str::contains(format!("\n{line}\n")));
        let schema = dir.path().join("drive.toml");
        let text = std::fs::read_to_string(&schema).unwrap();
        assert!(text.contains(comment), "{describe}: {text}");
        // The learned file is used as it is: nothing learned again.
        driveset_in(dir.path())
            .args(["pull", "--port", &port, "--address", "1"])
            .args(["--schema", "drive.toml", "-o", "set.toml"])
            .assert()
            .code(0)
            .stderr(predicate::str::contains("learned schema").not())
            .stdout(predicate::str::contains(format!(
                "schema: pulled-{family}-1 (drive.toml)\n"
            )));
        assert!(learned_files(dir.path()).is_empty());
        let set = dir.path().join("set.toml");
        assert!(
            std::fs::read_to_string(&set)
                .unwrap()
                .contains("\nschema = \"drive.toml\"\n")
        );
        offline_ok(&set, &schema);
    }
}

#[test]
fn schema_pull_of_a_command_alone_writes_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("stat.toml");
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://vf1000?addresses=1&describe=11:actual:binary8",
            "--address",
            "1",
            "--family",
            "vf1000",
            "--params",
            "11",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0)
        .stdout(predicate::str::diff(format!(
            "pulled 1 parameter descriptions (0 substitution texts) from sim://vf1000?addresses=1&describe=11:actual:binary8 address 1 into {} (schema id pulled-vf1000-1)\n0 of 1 parameters asked for are not on the drive (NAK)\n11-STAT: the drive describes an actual value (kind 1, BINARY8); lustbus-protocol.txt section 8.1.1 makes it a command: kept as a command, left out of the set\n",
            out.display()
        )));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("\n[schema.learned]\nasked = \"11\"\n"),
        "{text}"
    );
    // No read-only access nor actual-value kind on a command.
    assert!(!text.contains("access = \"ro\""), "{text}");
    assert!(!text.contains("kind = \"ram-actual\"\n"), "{text}");
    driveset()
        .args(["schema", "check"])
        .arg(&out)
        .assert()
        .code(0);
}

#[test]
fn where_the_spec_is_silent_the_drive_s_range_is_taken() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mode.toml");
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://vf1000?addresses=1&describe=1:max=2",
            "--address",
            "1",
            "--family",
            "vf1000",
            "--params",
            "1",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("\nnumber = 1\nname = \"MODE\"\ntype = \"PT_USIGN8\"\nmin = \"0\"\nmax = \"2\"\ndefault = \"0\"\n"),
        "{text}"
    );
    let set = dir.path().join("set.toml");
    std::fs::write(&set, "schema = \"mode.toml\"\n\n[values]\n1 = 3\n").unwrap();
    driveset()
        .arg("validate")
        .arg(&set)
        .assert()
        .code(1)
        .stdout(predicate::str::contains("1-MODE"));
}

#[test]
fn a_bad_describe_key_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    driveset()
        .args([
            "pull",
            "--port",
            "sim://vf1000?addresses=1&describe=11:running",
            "--address",
            "1",
            "-o",
        ])
        .arg(dir.path().join("x.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "`11:running`: `running` is neither a kind (actual, control, eeprom, fsel) nor a type (binary8, fixpoint16, usign16, usign8, vf_error, password, integer16, int32q16, float_ieee, mc_error)",
        ));
}

/// README's two flows for the VF1000 and for the MC6000 in each
/// description layout: one-step `pull` learns and writes the learned file
/// beside the set; `schema pull` then `pull --schema` uses the file as it
/// is; both sets validate offline, and a live diff of the two-step set
/// against the drive finds nothing.
#[test]
fn readme_flows_in_every_layout() {
    for (family, query) in [
        ("vf1000", ""),
        ("mc6000", ""),
        ("mc6000", "&layout=43&types=table"),
        ("mc6000", "&layout=42&types=table"),
        ("mc6000", "&layout=34"),
        ("mc6000", "&layout=34&types=table"),
    ] {
        let dir = sim_dir();
        let port = format!("sim://{family}?addresses=1{query}");
        driveset_in(dir.path())
            .args(["pull", "--port", &port, "--address", "1", "-o", "one.toml"])
            .args(["--schema", &format!("lust-{family}")])
            .assert()
            .code(0)
            .stderr(predicate::str::contains("learned schema learned-"));
        let files = learned_files(dir.path());
        assert_eq!(files.len(), 1, "{query}: {files:?}");
        offline_ok(&dir.path().join("one.toml"), &files[0]);
        // Pulling again with the learned file learns nothing.
        driveset_in(dir.path())
            .args([
                "pull",
                "--port",
                &port,
                "--address",
                "1",
                "-o",
                "again.toml",
            ])
            .arg("--schema")
            .arg(&files[0])
            .assert()
            .code(0)
            .stderr(predicate::str::contains("learned schema").not());

        driveset_in(dir.path())
            .args(["schema", "pull", "--port", &port, "--address", "1"])
            .args(["--family", family, "-o", "drive.toml"])
            .assert()
            .code(0);
        driveset_in(dir.path())
            .args(["pull", "--port", &port, "--address", "1"])
            .args(["--schema", "drive.toml", "-o", "two.toml"])
            .assert()
            .code(0)
            .stderr(predicate::str::contains("learned schema").not());
        assert_eq!(learned_files(dir.path()).len(), 1, "{query}");
        let two = dir.path().join("two.toml");
        offline_ok(&two, &dir.path().join("drive.toml"));
        driveset_in(dir.path())
            .arg("diff")
            .arg(&two)
            .args(["--port", &port, "--address", "1"])
            .assert()
            .code(0)
            .stderr(predicate::str::contains("learned schema").not());
    }
}

/// A learned file that asked for only some parameters: `pull --schema`
/// learns the rest only, the result carries the file's entries, extends
/// the file's own base (`lust-mc6000`) and validates offline; pulling with
/// the result learns nothing.
#[test]
fn learning_on_top_of_a_partial_learned_file_extends_its_base() {
    let dir = tempfile::tempdir().unwrap();
    let port = "sim://mc6000?addresses=1&layout=43&types=table";
    driveset_in(dir.path())
        .args(["schema", "pull", "--port", port, "--address", "1"])
        .args(["--family", "mc6000", "--params", "1-150", "-o", "part.toml"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "pulled 44 parameter descriptions (18 substitution texts)",
        ));
    let out = driveset_in(dir.path())
        .args(["pull", "--port", port, "--address", "1"])
        .args(["--schema", "part.toml", "-o", "set.toml"])
        .assert()
        .code(0)
        .get_output()
        .clone();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let files = learned_files(dir.path());
    assert_eq!(files.len(), 1, "{files:?}");
    let id = files[0].file_stem().unwrap().to_str().unwrap();
    assert!(
        stderr.contains(&format!(
            "learned schema {id} from the drive's descriptions: 206 codes, written to ./{id}.toml, description layout 43, type characters table (guessed)\n"
        )),
        "{stderr}"
    );
    let text = std::fs::read_to_string(&files[0]).unwrap();
    assert!(text.contains(&format!("\nid = \"{id}\"\n")), "{text}");
    assert!(text.contains("\nextends = \"lust-mc6000\"\n"), "{text}");
    assert!(text.contains("\nasked = \"1-999\"\n"), "{text}");
    assert!(
        text.contains("\n# Learned on top of `pulled-mc6000-1` from sim://mc6000?addresses=1&layout=43&types=table address 1: parameters 151-999.\n"),
        "{text}"
    );
    // The earlier file's entries are carried (1-MODE) and the new ones added.
    assert!(text.contains("\nnumber = 1\nname = \"MODE\"\n"), "{text}");
    assert!(text.contains("\nnumber = 416\n"), "{text}");
    let set = dir.path().join("set.toml");
    assert!(
        std::fs::read_to_string(&set)
            .unwrap()
            .contains(&format!("\nschema = \"{id}.toml\"\n"))
    );
    offline_ok(&set, &files[0]);
    driveset_in(dir.path())
        .args(["pull", "--port", port, "--address", "1", "--schema"])
        .arg(&files[0])
        .args(["-o", "again.toml"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains("learned schema").not());
}

/// `commission` and `status` with sets naming files `schema pull` wrote
/// (README's second flow on a line): the line validates offline, the
/// learned files are used as they are (nothing learned, no learned schema
/// in the report), each drive verifies and `status` finds them unchanged;
/// `upload` of a pulled set naming such a file lands its edit.
#[test]
fn commission_status_and_upload_use_a_learned_file_as_it_is() {
    let dir = sim_dir();
    let d = dir.path();
    std::fs::create_dir_all(d.join("sets")).unwrap();
    let port = "sim://lustbus?mc6000=1&vf1000=5";
    for (family, address) in [("mc6000", "1"), ("vf1000", "5")] {
        driveset_in(d)
            .args(["schema", "pull", "--port", port, "--address", address])
            .args(["--family", family, "-o"])
            .arg(format!("schemas/{family}.toml"))
            .assert()
            .code(0);
    }
    std::fs::write(
        d.join("line.toml"),
        format!("[line]\nname = \"learned-line\"\n\n[[bus]]\nname = \"lustbus\"\nport = \"{port}\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n[[drive]]\nbus = \"lustbus\"\naddress = 1\nset = \"sets/press.toml\"\nname = \"press\"\n\n[[drive]]\nbus = \"lustbus\"\naddress = 5\nset = \"sets/fan.toml\"\nname = \"fan\"\n"),
    )
    .unwrap();
    std::fs::write(
        d.join("sets/press.toml"),
        "schema = \"../schemas/mc6000.toml\"\n\n[values]\n100 = \"16 kHz\"\n132 = \"5 A\"\n",
    )
    .unwrap();
    std::fs::write(
        d.join("sets/fan.toml"),
        "schema = \"../schemas/vf1000.toml\"\n\n[values]\n7 = \"60 Hz\"\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["validate", "line.toml"])
        .assert()
        .code(0);
    driveset_in(d)
        .args(["identify", "--port", port, "--address", "5"])
        .args(["--schema", "schemas/vf1000.toml"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "\nuses:     pulled-vf1000-5 (learned, schemas/vf1000.toml)\n",
        ));
    driveset_in(d)
        .args(["commission", "line.toml"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains("learned").not());
    let text = std::fs::read_to_string(d.join("target/driveset-report/report.json")).unwrap();
    let r: serde_json::Value = serde_json::from_str(&text).unwrap();
    for (i, (name, schema)) in [("press", "pulled-mc6000-1"), ("fan", "pulled-vf1000-5")]
        .into_iter()
        .enumerate()
    {
        let dr = &r["drives"][i];
        assert_eq!(dr["name"], name);
        assert_eq!(dr["result"], "verified");
        assert_eq!(dr["schema"], schema);
        assert!(dr["learned_schema"].is_null(), "{dr}");
    }
    driveset_in(d)
        .args(["status", "line.toml"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "2 unchanged, 0 already verified, 0 drift",
        ));
    // upload: a pulled set naming the learned file, edited.
    driveset_in(d)
        .args(["pull", "--port", port, "--address", "5"])
        .args(["--schema", "schemas/vf1000.toml", "-o", "fan-pulled.toml"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains("learned schema").not());
    let pulled = d.join("fan-pulled.toml");
    let text = std::fs::read_to_string(&pulled).unwrap();
    assert!(
        text.contains("\nschema = \"schemas/vf1000.toml\"\n"),
        "{text}"
    );
    assert!(text.contains("\n7 = \"60 Hz\"\n"), "{text}");
    std::fs::write(
        &pulled,
        text.replace("\n7 = \"60 Hz\"\n", "\n7 = \"55 Hz\"\n"),
    )
    .unwrap();
    driveset_in(d)
        .arg("upload")
        .arg(&pulled)
        .args(["--port", port, "--address", "5", "--journal-dir", "journal"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "\n  7-FMAX: 60 Hz -> 55 Hz  verified\n",
        ))
        .stderr(predicate::str::contains("learned schema").not());
}

/// A described type the bounds do not fit, where the spec gives the type:
/// the spec's type stands (the code is read with it), and the report says
/// so instead of "not read".
#[test]
fn a_described_type_the_bounds_do_not_fit_keeps_the_spec_s_type() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("speed.toml");
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://mc6000?addresses=1&describe=77:integer16",
            "--address",
            "1",
            "--family",
            "mc6000",
            "--params",
            "77",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0)
        .stdout(predicate::str::ends_with(
            "\n77-SPEED: downgraded: its min/max/default (0x80000000, 0x7FFFFFFF, 0x0) do not fit its type PT_INTEGER16; the spec's type PT_INT32Q16 stands\n",
        ));
    let set = dir.path().join("speed-set.toml");
    driveset()
        .args([
            "pull",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
        ])
        .arg("--schema")
        .arg(&out)
        .arg("-o")
        .arg(&set)
        .assert()
        .code(0);
    let text = std::fs::read_to_string(&set).unwrap();
    assert!(text.contains(": 77-SPEED = 0 1/min, "), "{text}");
}
