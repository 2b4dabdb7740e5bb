//! Learning the schema from the drive (driveset-engine's `learn`) through
//! the CLI: `pull` with a schema that lacks facts learns them from the
//! simulated drive's own descriptions in every layout the errata discuss,
//! writes the learned schema beside the set, the set validates offline and
//! uploads back exactly; `pull` without a schema; a code that cannot be
//! read; `identify` naming the schema it would use; `schema pull` with a
//! forced layout.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use driveset_test_support::{driveset, driveset_with_sim_state, sim_dir, workspace_root};

fn learned_file(dir: &Path) -> PathBuf {
    let mut files = driveset_test_support::toml_files_starting(dir, "learned-mc6000-type6000-d");
    assert_eq!(files.len(), 1, "{files:?}");
    files.pop().unwrap()
}

/// (code line as pulled, as edited) for the round trip.
const EDITS: [(&str, &str); 4] = [
    ("100 = \"8 kHz\"", "100 = \"16 kHz\""),
    ("132 = \"4.25 A\"", "132 = \"5 A\""),
    ("134 = \"3000 1/min\"", "134 = \"3500 1/min\""),
    ("171 = 1024", "171 = 2048"),
];

/// Pull with the built-in schema (which lacks types and ranges) from a
/// simulated MC6000 whose descriptions come in `query`'s layout, edit four
/// values, validate offline, upload, pull again: the drive holds exactly
/// the edited values.
fn round_trip(query: &str, layout: &str, types: &str) {
    let dir = sim_dir();
    let port = format!("sim://mc6000?addresses=1{query}");
    let set = dir.path().join("set").join("axis.toml");
    let out = driveset_with_sim_state(dir.path())
        .args([
            "pull",
            "--port",
            &port,
            "--address",
            "1",
            "--schema",
            "lust-mc6000",
            "-o",
        ])
        .arg(&set)
        .assert()
        .code(0)
        .get_output()
        .clone();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let schema = learned_file(set.parent().unwrap());
    let id = schema.file_stem().unwrap().to_str().unwrap().to_string();
    assert!(
        stderr.starts_with(&format!(
            "learned schema {id} from the drive's descriptions: 250 codes, written to {}, description layout {layout}, type characters {types} (guessed)\n",
            schema.display()
        )),
        "{stderr}"
    );
    let mut text = std::fs::read_to_string(&set).unwrap();
    assert!(
        text.contains(&format!("\nschema = \"{id}.toml\"\n")),
        "{text}"
    );
    for (from, to) in EDITS {
        assert!(text.contains(&format!("\n{from}\n")), "{from} in {text}");
        text = text.replace(&format!("\n{from}\n"), &format!("\n{to}\n"));
    }
    std::fs::write(&set, &text).unwrap();
    // Offline: no port, no simulator state; the set names the learned file.
    driveset().arg("validate").arg(&set).assert().code(0);
    driveset()
        .args(["schema", "check"])
        .arg(&schema)
        .assert()
        .code(0)
        .stdout(predicate::str::contains("0 findings"));
    driveset_with_sim_state(dir.path())
        .arg("upload")
        .arg(&set)
        .args(["--port", &port, "--address", "1", "--journal-dir"])
        .arg(dir.path().join("journal"))
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "100-PWMF: \"8 kHz\" -> \"16 kHz\"  verified",
        ));
    let again = dir.path().join("again.toml");
    driveset_with_sim_state(dir.path())
        .args(["pull", "--port", &port, "--address", "1", "--schema"])
        .arg(&schema)
        .arg("-o")
        .arg(&again)
        .assert()
        .code(0);
    let back = std::fs::read_to_string(&again).unwrap();
    for (_, to) in EDITS {
        assert!(back.contains(&format!("\n{to}\n")), "{to} in {back}");
    }
    // And the live diff of the edited set against the drive: nothing differs.
    driveset_with_sim_state(dir.path())
        .arg("diff")
        .arg(&set)
        .args(["--port", &port, "--address", "1"])
        .assert()
        .code(0);
}

#[test]
fn pull_learn_upload_round_trip_52_characters() {
    round_trip("", "52", "driveset");
}

#[test]
fn pull_learn_upload_round_trip_43_characters_table_order_types() {
    round_trip("&layout=43&types=table", "43", "table");
}

#[test]
fn pull_learn_upload_round_trip_42_characters() {
    round_trip("&layout=42&types=table", "42", "table");
}

#[test]
fn pull_learn_upload_round_trip_34_characters() {
    round_trip("&layout=34", "34", "driveset");
}

#[test]
fn pull_without_a_schema_on_sim_ports_without_addresses() {
    // the vendor's built-in schema, learned from the simulated drive's own
    // descriptions where the family learns, as on a serial line
    for (port, schema) in [
        ("sim://vf1000", "learned-vf1000-type1000-"),
        ("sim://mc6000", "learned-mc6000-type6000-"),
        ("sim://tmd", "lenze-tmd\""),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let set = dir.path().join("drive.toml");
        driveset()
            .args(["pull", "--port", port, "--address", "3", "-o"])
            .arg(&set)
            .assert()
            .code(0)
            .stdout(predicate::str::contains(format!(
                "from {port}?addresses=3 address 3 into"
            )));
        let text = std::fs::read_to_string(&set).unwrap();
        assert!(text.contains(&format!("\nschema = \"{schema}")), "{text}");
    }
}

#[test]
fn a_code_that_cannot_be_read_is_reported_and_the_pull_carries_on() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("vf.toml");
    driveset()
        .args([
            "pull",
            "--port",
            "sim://vf1000?addresses=1&faults=cable@9+2s",
            "--address",
            "1",
            "--schema",
        ])
        .arg(workspace_root().join("parameter-sets/fixtures/fictional-vf1000-demo.toml"))
        .arg("-o")
        .arg(&set)
        .assert()
        .code(1)
        // 81-SIOC / 82-SIOA are left out (the manifest owns them), and the
        // RAM control values 26-FJOG, 27-OVRD (lost at power off): the cut
        // meets 84-SIOT
        .stdout(predicate::str::contains("pulled 33 values from"))
        .stderr(predicate::str::contains(
            "error: sim://vf1000?addresses=1&faults=cable@9+2s address 1: 84-SIOT could not be read: the drive did not answer (3 tries)\n",
        ));
    let text = std::fs::read_to_string(&set).unwrap();
    assert!(
        text.contains("#   84-SIOT: the drive did not answer (3 tries)\n"),
        "{text}"
    );
}

#[test]
fn identify_names_the_schema_it_would_use_and_whether_learned() {
    let dir = tempfile::tempdir().unwrap();
    let port = "sim://mc6000?addresses=1&layout=43&types=table";
    driveset()
        .args(["identify", "--port", port, "--address", "1", "--schema", "lust-mc6000", "--schema-dir"])
        .arg(dir.path())
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "\nschema:   lust-mc6000 (fits)\nuses:     learned-mc6000-type6000-* (learned from the drive's descriptions on pull / diff / upload; lust-mc6000 lacks types and ranges)\n",
        ));
    driveset()
        .args([
            "pull",
            "--port",
            port,
            "--address",
            "1",
            "--schema",
            "lust-mc6000",
            "-o",
        ])
        .arg(dir.path().join("axis.toml"))
        .assert()
        .code(0);
    let file = learned_file(dir.path());
    let id = file.file_stem().unwrap().to_str().unwrap().to_string();
    driveset()
        .args([
            "identify",
            "--port",
            port,
            "--address",
            "1",
            "--schema",
            "lust-mc6000",
            "--schema-dir",
        ])
        .arg(dir.path())
        .assert()
        .code(0)
        .stdout(predicate::str::contains(format!(
            "\nuses:     {id} (learned, {})\n",
            file.display()
        )));
    driveset()
        .args(["identify", "--port", port, "--address", "1", "--schema"])
        .arg(&file)
        .args(["--format", "json"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(format!("\"would_use\": \"{id}\"")))
        .stdout(predicate::str::contains("\"learned\": true"));
    // The simulator's (fictional) fixture schema, named by its file, gives
    // every fact.
    driveset()
        .args(["identify", "--port", port, "--address", "1", "--schema"])
        .arg(workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml"))
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "\nuses:     fictional-mc6000-demo (not learned: the schema gives every fact)\n",
        ));
}

#[test]
fn schema_pull_with_a_forced_layout_reports_what_does_not_decode() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("forced.toml");
    // The drive sends 52 characters; read as 43 every description is left out.
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
            "--params",
            "1-2",
            "--description-layout",
            "43",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(0)
        .stdout(predicate::str::diff(format!(
            "pulled 0 parameter descriptions (0 substitution texts) from sim://mc6000?addresses=1 address 1 into {} (schema id pulled-mc6000-1)\n1 of 2 parameters asked for are not on the drive (NAK)\n1-MODE: left out: its description does not decode: MC6000/7000 parameter description has 52 characters; expected 52, 43, 42 or 34 (the layout's length)\n",
            out.display()
        )));
    driveset()
        .args(["schema", "check"])
        .arg(&out)
        .assert()
        .code(0);
    driveset()
        .args([
            "schema",
            "pull",
            "--port",
            "sim://mc6000?addresses=1",
            "--address",
            "1",
            "--type-chars",
            "1=PT_BINARY8",
            "-o",
        ])
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "--type-chars: `1=PT_BINARY8`: PT_BINARY8 is not an MC6000/7000 type",
        ));
}

#[test]
fn upload_and_live_diff_of_a_set_naming_the_built_in_schema_learn_first() {
    let dir = sim_dir();
    let set = dir.path().join("mode.toml");
    // 1-MODE has no type in lust-mc6000 (the spec gives none): `validate`
    // alone refuses the value; against the drive its description gives it.
    std::fs::write(&set, "schema = \"lust-mc6000\"\n\n[values]\n1 = 3\n").unwrap();
    driveset().arg("validate").arg(&set).assert().code(1);
    let port = "sim://mc6000?addresses=1&layout=42&types=table";
    driveset_with_sim_state(dir.path())
        .arg("diff")
        .arg(&set)
        .args(["--port", port, "--address", "1"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains("~ 1-MODE: 0 -> 3\n"))
        .stderr(predicate::str::contains(
            " from the drive's descriptions: 250 codes, description layout 42, type characters table (guessed)\n",
        ));
    driveset_with_sim_state(dir.path())
        .arg("upload")
        .arg(&set)
        .args(["--port", port, "--address", "1", "--journal-dir"])
        .arg(dir.path().join("journal"))
        .assert()
        .code(0)
        .stdout(predicate::str::contains("  1-MODE: 0 -> 3  verified"));
    driveset_with_sim_state(dir.path())
        .arg("diff")
        .arg(&set)
        .args(["--port", port, "--address", "1", "--no-learn"])
        .assert()
        .code(2);
    driveset_with_sim_state(dir.path())
        .arg("diff")
        .arg(&set)
        .args(["--port", port, "--address", "1"])
        .assert()
        .code(0);
}
