//! Sets that cannot start a motor, named overrides, secrets no output gives
//! away (issue 10): `validate` findings for commands and control words,
//! `upload` refusals before anything is sent (exit 2), each `--allow-*`
//! lifting exactly its refusal, the running state of simulated drives
//! (VF1000 3-CNTL, ECS C0150 bit 1 of the FICTIONAL fixture, unknown with
//! the real lenze-ecs schema), `pull` leaving commands, control words and
//! passwords out, and `diff` / `fingerprint` / `show` on sets that differ
//! only in a password.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use crate::util::{driveset, workspace_root};

const VF: &str = "sim://vf1000?addresses=1";

fn fixture(name: &str) -> String {
    workspace_root()
        .join("parameter-sets/fixtures")
        .join(name)
        .display()
        .to_string()
}

fn in_dir(dir: &Path) -> assert_cmd::Command {
    let mut c = driveset();
    c.current_dir(dir)
        .env("DRIVESET_SIM_STATE_DIR", dir.join("sim"));
    c
}

/// A set file `name` in `dir` for the fixture schema `schema` with `values`.
fn set_file(dir: &Path, name: &str, schema: &str, values: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!("schema = \"{}\"\n[values]\n{values}", fixture(schema)),
    )
    .unwrap();
    p
}

fn tmp() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(d.path().join("sim")).unwrap();
    d
}

/// Put `raw` into code `number` of the simulated drive at `address` in the
/// state file `sim/sim-FAMILY.json` (written by an earlier run).
pub(crate) fn poke_state(dir: &Path, family: &str, address: u8, number: u32, raw: i64) {
    use driveset_schema::{CodeKey, CodeStyle, RawValue, ResolvedSet};
    use driveset_sim::open::{DriveDump, StateDump, parse_canonical};
    let path = dir.join(format!("sim/sim-{family}.json"));
    let mut dump = StateDump::read(&path).expect("state saved");
    let d = dump
        .drives
        .iter_mut()
        .find(|d| d.address == address)
        .expect("drive in the dump");
    let (schema, mut values) = parse_canonical(&d.canonical).expect("canonical");
    values.insert(CodeKey::new(number), RawValue::Int(raw));
    let style = if family == "ecs" {
        CodeStyle::Lenze
    } else {
        CodeStyle::Lust
    };
    let set = ResolvedSet {
        schema,
        code_style: style,
        values,
        secrets: Default::default(),
    };
    *d = DriveDump::new(&d.family.clone(), address, &set);
    dump.write(&path).expect("state written");
}

#[test]
fn validate_reports_commands_and_control_words_that_could_start_a_motor() {
    let dir = tmp();
    let d = dir.path();
    set_file(
        d,
        "vf.toml",
        "fictional-vf1000-demo.toml",
        "CNTL = 128\nPROG = 1\nFSSEL = 8\n",
    );
    set_file(
        d,
        "mc.toml",
        "fictional-mc6000-demo.toml",
        "SCTL1 = { start = true }\nRJOG = 0\n",
    );
    set_file(
        d,
        "mc-ok.toml",
        "fictional-mc6000-demo.toml",
        "SCTL1 = { start = false, error_reset = false }\n",
    );
    in_dir(d)
        .args(["validate", "vf.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "error[control-word-not-stopped]: 3-CNTL = { start_clockwise = 1 } would start or enable the drive (start_clockwise set)\n --> vf.toml:3:8\n  |\n3 | CNTL = 128\n  |        ^^^ here\n  |\n  = help: clear start_clockwise or remove this line; a set may hold a control word only in a stopped or inhibited state\n",
        ))
        .stdout(predicate::str::contains(
            "error[command]: 71-PROG = \"Load factory settings\" is a command (PROG), not a setting; a set cannot hold it\n --> vf.toml:4:8\n",
        ))
        .stdout(predicate::str::contains("2 findings in 1 of 1 file"));
    in_dir(d)
        .args(["validate", "mc.toml", "--format", "github"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "file=mc.toml,line=3,col=9,title=control-word-not-stopped::416-SCTL1 = { start = 1, error_reset = 0 } would start or enable the drive (start set)",
        ))
        .stdout(predicate::str::contains("line=4,col=8,title=command::704-RJOG = \"Off\" is a command (Jog command), not a setting"));
    in_dir(d).args(["validate", "mc-ok.toml"]).assert().code(0);
}

#[test]
fn upload_refuses_a_command_before_anything_is_sent_whatever_override_is_given() {
    // the scenario: PROG = 1 under the old --force was sent three
    // times and reset the drive; now it never reaches the bus
    let dir = tmp();
    let d = dir.path();
    set_file(d, "prog.toml", "fictional-vf1000-demo.toml", "PROG = 1\n");
    for dry in [false, true] {
        let mut c = in_dir(d);
        c.args(["upload", "prog.toml", "--port", VF, "--address", "1"])
            .args([
                "--allow-family",
                "--allow-running",
                "--allow-running-unknown",
                "--allow-address-change",
            ]);
        if dry {
            c.arg("--dry-run");
        }
        c.assert()
            .code(2)
            .stderr(predicate::str::contains(
                "error[command]: 71-PROG = \"Load factory settings\" is a command (PROG), not a setting; a set cannot hold it\n --> prog.toml:3:8\n",
            ))
            .stderr(predicate::str::ends_with("error: prog.toml: not uploaded\n"));
    }
    // the simulated bus was never opened: no state file, no telegram
    assert!(!d.join("sim/sim-vf1000.json").exists());
    assert!(!d.join(".driveset").exists());
    // the removed catch-all says what replaced it
    set_file(d, "ok.toml", "fictional-vf1000-demo.toml", "SIOT = 5\n");
    in_dir(d)
        .args(["upload", "ok.toml", "--port", VF, "--address", "1", "--force"])
        .assert()
        .code(2)
        .stderr("error: --force was replaced by named overrides, each lifting one refusal: --allow-family, --allow-running, --allow-running-unknown, --allow-address-change, --allow-shared-transfer-baud (commands and control words that could start a motor have none)\n");
    assert!(!d.join("sim/sim-vf1000.json").exists());
}

#[test]
fn a_running_vf1000_needs_allow_running_and_no_other_override_lifts_it() {
    let dir = tmp();
    let d = dir.path();
    // 83-SIOW: a RAM value (the running VF1000 refuses EEPROM writes)
    set_file(d, "ok.toml", "fictional-vf1000-demo.toml", "SIOW = 7\n");
    // a first run creates the simulated drive's state; then start its motor
    in_dir(d)
        .args([
            "upload",
            "ok.toml",
            "--port",
            VF,
            "--address",
            "1",
            "--dry-run",
        ])
        .assert()
        .code(0);
    poke_state(d, "vf1000", 1, 3, 128);
    let refusal = "error: sim://vf1000?addresses=1 address 1: refused: the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running\n";
    for extra in [
        &[][..],
        &[
            "--allow-family",
            "--allow-running-unknown",
            "--allow-address-change",
        ][..],
    ] {
        in_dir(d)
            .args(["upload", "ok.toml", "--port", VF, "--address", "1"])
            .args(extra)
            .assert()
            .code(2)
            .stderr(predicate::str::ends_with(refusal));
    }
    in_dir(d)
        .args([
            "upload",
            "ok.toml",
            "--port",
            VF,
            "--address",
            "1",
            "--dry-run",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with(refusal));
    in_dir(d)
        .args([
            "upload",
            "ok.toml",
            "--port",
            VF,
            "--address",
            "1",
            "--allow-running",
        ])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "warning: --allow-running: the drive reports a running motor\n",
        ))
        .stdout(predicate::str::contains("  83-SIOW: 0 -> 7  verified\n"));
}

#[test]
fn ecs_running_state_comes_from_c0150_and_is_unknown_with_the_real_schema() {
    let dir = tmp();
    let d = dir.path();
    let port = "sim://ecs?addresses=1";
    set_file(
        d,
        "axis.toml",
        "fictional-ecs-demo.toml",
        "C5001 = \"4000 rpm\"\n",
    );
    // stopped (the simulated axis starts so): uploads
    in_dir(d)
        .args(["upload", "axis.toml", "--port", port, "--address", "1"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "C5001 max_speed: 3000 rpm -> 4000 rpm  verified",
        ));
    // running: C0150 bit 1 set (FICTIONAL fixture meaning)
    poke_state(d, "ecs", 1, 150, 2);
    set_file(
        d,
        "axis2.toml",
        "fictional-ecs-demo.toml",
        "C5001 = \"4100 rpm\"\n",
    );
    in_dir(d)
        .args(["upload", "axis2.toml", "--port", port, "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with("error: sim://ecs?addresses=1 address 1: refused: the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running\n"));
    in_dir(d)
        .args(["diff", "axis2.toml", "--port", port, "--address", "1"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "C5001 max_speed: 4000 rpm -> 4100 rpm",
        ));

    // a schema without a running bit (lenze-ecs itself names none)
    let schemas = d.join("schemas");
    std::fs::create_dir_all(&schemas).unwrap();
    std::fs::write(
        schemas.join("test-ecs-unknown.toml"),
        "[schema]\nid = \"fictional-ecs-unknown\"\ntitle = \"FICTIONAL: lenze-ecs plus one FIX32 code, no running bit\"\nextends = \"lenze-ecs\"\nfictional = true\n\n[[code]]\nnumber = 5001\nname = \"max_speed\"\ntitle = \"Maximum speed (test)\"\nspec = \"test\"\ntype = \"FIX32\"\nunit = \"rpm\"\n",
    )
    .unwrap();
    std::fs::write(
        d.join("unknown.toml"),
        "schema = \"fictional-ecs-unknown\"\n[values]\nmax_speed = \"4200 rpm\"\n",
    )
    .unwrap();
    let schemas = schemas.display().to_string();
    let why = "running state unknown: schema `fictional-ecs-unknown` names no status bit (role `running`) or control word start bit that says whether the motor runs";
    in_dir(d)
        .args(["upload", "unknown.toml", "--port", port, "--address", "1", "--schemas", &schemas])
        .args(["--allow-running"])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with(format!("error: sim://ecs?addresses=1 address 1: refused: {why}; make sure the drive is at standstill, then pass --allow-running-unknown\n")));
    in_dir(d)
        .args(["upload", "unknown.toml", "--port", port, "--address", "1", "--schemas", &schemas])
        .args(["--allow-running-unknown", "--dry-run"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "warning: running state unknown (--allow-running-unknown): schema `fictional-ecs-unknown` names no status bit (role `running`) or control word start bit that says whether the motor runs\n",
        ));
    in_dir(d)
        .args([
            "upload",
            "unknown.toml",
            "--port",
            port,
            "--address",
            "1",
            "--schemas",
            &schemas,
        ])
        .args(["--allow-running-unknown"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "warning: running state unknown (--allow-running-unknown)",
        ))
        .stdout(predicate::str::contains(
            "C5001 max_speed: 4000 rpm -> 4200 rpm  verified",
        ));
}

#[test]
fn an_address_change_needs_allow_address_change() {
    let dir = tmp();
    let d = dir.path();
    std::fs::write(
        d.join("addr.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0009 = 12\n",
    )
    .unwrap();
    in_dir(d)
        .args(["upload", "addr.toml", "--port", "sim://tmd?addresses=1", "--address", "1", "--allow-running", "--allow-family"])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with("error: sim://tmd?addresses=1 address 1: refused: C0009 network_address: 1 -> 12 changes the bus address of the drive being talked to; it would stop answering mid-transaction. Upload the set to the drive at its new address after changing the address on its own (or pass --allow-address-change)\n"));
    // read back only: no journal, nothing written
    let journals = d.join(".driveset/journal");
    assert!(!journals.exists() || std::fs::read_dir(&journals).unwrap().next().is_none());
    in_dir(d)
        .args([
            "diff",
            "addr.toml",
            "--port",
            "sim://tmd?addresses=1",
            "--address",
            "1",
        ])
        .assert()
        .code(1)
        .stdout(predicate::str::contains("C0009 network_address: 1 -> 12"));
}

#[test]
fn pull_leaves_commands_control_words_and_passwords_out() {
    let dir = tmp();
    let d = dir.path();
    in_dir(d)
        .args(["pull", "--port", VF, "--address", "1", "-o", "vf.toml"])
        .assert()
        .code(0);
    let text = std::fs::read_to_string(d.join("vf.toml")).unwrap();
    for line in [
        "#   3-CNTL: role `control-word`: left out, a set cannot hold it\n",
        "#   11-STAT: role `command`: left out, a set cannot hold it\n",
        "#   71-PROG: role `command`: left out, a set cannot hold it\n",
        "#   70-PASS: password (never read: its value stays on the drive)\n",
    ] {
        assert!(text.contains(line), "{line}\n{text}");
    }
    for code in ["\nCNTL", "\nPROG", "\nSTAT", "\nPASS", "\n3 =", "\n70 ="] {
        assert!(!text.contains(code), "{code}\n{text}");
    }
    // what was pulled validates (against the simulator's fixture schema,
    // which only `--schemas` or a sim:// port know by id) and uploads back
    // unchanged
    in_dir(d)
        .args(["validate", "--schemas"])
        .arg(crate::util::workspace_root().join("parameter-sets/fixtures"))
        .arg("vf.toml")
        .assert()
        .code(0);
    in_dir(d)
        .args(["upload", "vf.toml", "--port", VF, "--address", "1"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "nothing to write: the drive already holds the set",
        ));
}

#[test]
fn sets_differing_only_in_a_password_share_the_fingerprint_and_diff_says_it_differs() {
    let dir = tmp();
    let d = dir.path();
    std::fs::write(
        d.join("a.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = 60\nC0094 = 123\n",
    )
    .unwrap();
    std::fs::write(
        d.join("b.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = 60\nuser_password = 456\n",
    )
    .unwrap();
    let fp = |f: &str| {
        let out = in_dir(d)
            .args(["fingerprint", f])
            .assert()
            .code(0)
            .get_output()
            .stdout
            .clone();
        String::from_utf8(out)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(fp("a.toml"), fp("b.toml"));
    in_dir(d)
        .args(["diff", "a.toml", "b.toml"])
        .assert()
        .code(1)
        .stdout("--- a.toml\n+++ b.toml\n~ C0094 user_password: differs (secret)\n1 difference (1 changed, 0 added, 0 removed)\n");
    in_dir(d)
        .args(["diff", "--unified", "a.toml", "b.toml"])
        .assert()
        .code(1)
        .stdout("--- a.toml\n+++ b.toml\n@@ -1,4 +1,4 @@\n driveset-canonical 1\n schema lenze-tmd\n C0011 600000\n-C0094 <secret: old value>\n+C0094 <secret: new value>\n");
    for to in ["toml", "yaml", "json"] {
        let out = in_dir(d)
            .args(["show", "--to", to, "a.toml"])
            .assert()
            .code(0)
            .get_output()
            .stdout
            .clone();
        let out = String::from_utf8(out).unwrap();
        assert!(out.contains("<secret>") && !out.contains("123"), "{out}");
    }
    in_dir(d).args(["show", "a.toml"]).assert().code(0).stdout(
        predicate::str::contains("C0094 <secret>\n").and(predicate::str::contains("123").not()),
    );
    // validate masks the value in the snippet
    std::fs::write(
        d.join("bad.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0094 = 4711\n",
    )
    .unwrap();
    in_dir(d)
        .args(["validate", "bad.toml"])
        .assert()
        .code(1)
        .stdout("error[out-of-range]: C0094 (user_password) = <secret>: the value is not valid for this code (out-of-range)\n --> bad.toml:3:9\n  |\n3 | C0094 = <secret>\n  |         ^^^^^^^^ here\n  |\n  = help: give a valid password (the value is not shown: it is a secret)\n\n1 finding in 1 of 1 file\n");
}

#[test]
fn commission_refuses_a_line_whose_set_could_start_a_motor_before_anything_is_sent() {
    let dir = tmp();
    let d = dir.path();
    set_file(
        d,
        "vf.toml",
        "fictional-vf1000-demo.toml",
        "CNTL = 128\nSIOT = 5\n",
    );
    std::fs::write(
        d.join("line.toml"),
        "[line]\nname = \"t\"\n\n[[bus]]\nname = \"b\"\nport = \"sim://vf1000?addresses=1\"\nprotocol = \"lustbus\"\n\n[[drive]]\nname = \"conveyor\"\nbus = \"b\"\naddress = 1\nset = \"vf.toml\"\n",
    )
    .unwrap();
    for extra in [&[][..], &["--allow-running", "--allow-family"][..]] {
        in_dir(d)
            .args(["commission", "line.toml"])
            .args(extra)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(
                "error[control-word-not-stopped]: 3-CNTL = { start_clockwise = 1 } would start or enable the drive (start_clockwise set)\n --> vf.toml:3:8\n",
            ))
            .stderr(predicate::str::ends_with(
                "error: line.toml: 1 finding(s) in the line manifest; nothing was sent (see `driveset validate line.toml`)\n",
            ));
    }
    assert!(!d.join("sim/sim-vf1000.json").exists());
    in_dir(d)
        .args(["commission", "line.toml", "--force"])
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --force was replaced by named overrides",
        ));
}
