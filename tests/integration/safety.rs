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

use driveset_schema::{CodeStyle, RawValue};
use driveset_test_support::{driveset_in, sim_dir, state_raw, workspace_root};

const VF: &str = "sim://vf1000?addresses=1";

fn fixture(name: &str) -> String {
    workspace_root()
        .join("parameter-sets/fixtures")
        .join(name)
        .display()
        .to_string()
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

/// Put `raw` into code `number` of the simulated drive at `address` in the
/// state file `sim/sim-FAMILY.json` (written by an earlier run).
pub(crate) fn poke_state(dir: &Path, family: &str, address: u8, number: u32, raw: i64) {
    let style = if family == "ecs" {
        CodeStyle::Lenze
    } else {
        CodeStyle::Lust
    };
    let path = dir.join(format!("sim/sim-{family}.json"));
    driveset_test_support::poke_state(&path, Some(address), number, raw, style);
}

#[test]
fn validate_reports_commands_and_control_words_that_could_start_a_motor() {
    let dir = sim_dir();
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
    driveset_in(d)
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
    driveset_in(d)
        .args(["validate", "mc.toml", "--format", "github"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "file=mc.toml,line=3,col=9,title=control-word-not-stopped::416-SCTL1 = { start = 1, error_reset = 0 } would start or enable the drive (start set)",
        ))
        .stdout(predicate::str::contains("line=4,col=8,title=command::704-RJOG = \"Off\" is a command (Jog command), not a setting"));
    driveset_in(d)
        .args(["validate", "mc-ok.toml"])
        .assert()
        .code(0);
}

#[test]
fn upload_refuses_a_command_before_anything_is_sent_whatever_override_is_given() {
    // the scenario: PROG = 1 under the old --force was sent three
    // times and reset the drive; now it never reaches the bus
    let dir = sim_dir();
    let d = dir.path();
    set_file(d, "prog.toml", "fictional-vf1000-demo.toml", "PROG = 1\n");
    for dry in [false, true] {
        let mut c = driveset_in(d);
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
    driveset_in(d)
        .args(["upload", "ok.toml", "--port", VF, "--address", "1", "--force"])
        .assert()
        .code(2)
        .stderr("error: --force was replaced by named overrides, each lifting one refusal: --allow-family, --allow-running, --allow-running-unknown, --allow-address-change, --allow-shared-transfer-baud (commands and control words that could start a motor have none)\n");
    assert!(!d.join("sim/sim-vf1000.json").exists());
}

#[test]
fn a_running_vf1000_needs_allow_running_and_no_other_override_lifts_it() {
    let dir = sim_dir();
    let d = dir.path();
    // 5-FSSIO: the setpoint, an FSEL/ISEL variable (the running VF1000
    // refuses EEPROM writes; a set cannot hold a RAM control value)
    set_file(d, "ok.toml", "fictional-vf1000-demo.toml", "FSSIO = 7\n");
    // a first run creates the simulated drive's state; then start its motor
    driveset_in(d)
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
        driveset_in(d)
            .args(["upload", "ok.toml", "--port", VF, "--address", "1"])
            .args(extra)
            .assert()
            .code(2)
            .stderr(predicate::str::ends_with(refusal));
    }
    driveset_in(d)
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
    driveset_in(d)
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
        .stdout(predicate::str::contains(
            "  5-FSSIO: 0 Hz -> 7 Hz  verified\n",
        ));
}

#[test]
fn ecs_running_state_comes_from_c0150_and_is_unknown_with_the_real_schema() {
    let dir = sim_dir();
    let d = dir.path();
    let port = "sim://ecs?addresses=1";
    set_file(
        d,
        "axis.toml",
        "fictional-ecs-demo.toml",
        "C5001 = \"4000 rpm\"\n",
    );
    // stopped (the simulated axis starts so): uploads
    driveset_in(d)
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
    driveset_in(d)
        .args(["upload", "axis2.toml", "--port", port, "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with("error: sim://ecs?addresses=1 address 1: refused: the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running\n"));
    driveset_in(d)
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
    driveset_in(d)
        .args(["upload", "unknown.toml", "--port", port, "--address", "1", "--schemas", &schemas])
        .args(["--allow-running"])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with(format!("error: sim://ecs?addresses=1 address 1: refused: {why}; make sure the drive is at standstill, then pass --allow-running-unknown\n")));
    driveset_in(d)
        .args(["upload", "unknown.toml", "--port", port, "--address", "1", "--schemas", &schemas])
        .args(["--allow-running-unknown", "--dry-run"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "warning: running state unknown (--allow-running-unknown): schema `fictional-ecs-unknown` names no status bit (role `running`) or control word start bit that says whether the motor runs\n",
        ));
    driveset_in(d)
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
    let dir = sim_dir();
    let d = dir.path();
    std::fs::write(
        d.join("addr.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0009 = 12\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["upload", "addr.toml", "--port", "sim://tmd?addresses=1", "--address", "1", "--allow-running", "--allow-family"])
        .assert()
        .code(2)
        .stderr(predicate::str::ends_with("error: sim://tmd?addresses=1 address 1: refused: C0009 network_address: 1 -> 12 changes the bus address of the drive being talked to; it would stop answering mid-transaction. Upload the set to the drive at its new address after changing the address on its own (or pass --allow-address-change)\n"));
    // read back only: no journal, nothing written
    let journals = d.join(".driveset/journal");
    assert!(!journals.exists() || std::fs::read_dir(&journals).unwrap().next().is_none());
    driveset_in(d)
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
    let dir = sim_dir();
    let d = dir.path();
    driveset_in(d)
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
    driveset_in(d)
        .args(["validate", "--schemas"])
        .arg(driveset_test_support::workspace_root().join("parameter-sets/fixtures"))
        .arg("vf.toml")
        .assert()
        .code(0);
    driveset_in(d)
        .args(["upload", "vf.toml", "--port", VF, "--address", "1"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "nothing to write: the drive already holds the set",
        ));
}

#[test]
fn sets_differing_only_in_a_password_share_the_fingerprint_and_diff_says_it_differs() {
    let dir = sim_dir();
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
        let out = driveset_in(d)
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
    driveset_in(d)
        .args(["diff", "a.toml", "b.toml"])
        .assert()
        .code(1)
        .stdout("--- a.toml\n+++ b.toml\n~ C0094 user_password: differs (secret)\n1 difference (1 changed, 0 added, 0 removed)\n");
    driveset_in(d)
        .args(["diff", "--unified", "a.toml", "b.toml"])
        .assert()
        .code(1)
        .stdout("--- a.toml\n+++ b.toml\n@@ -1,4 +1,4 @@\n driveset-canonical 1\n schema lenze-tmd\n C0011 600000\n-C0094 <secret: old value>\n+C0094 <secret: new value>\n");
    for to in ["toml", "yaml", "json"] {
        let out = driveset_in(d)
            .args(["show", "--to", to, "a.toml"])
            .assert()
            .code(0)
            .get_output()
            .stdout
            .clone();
        let out = String::from_utf8(out).unwrap();
        assert!(out.contains("<secret>") && !out.contains("123"), "{out}");
    }
    driveset_in(d)
        .args(["show", "a.toml"])
        .assert()
        .code(0)
        .stdout(
            predicate::str::contains("C0094 <secret>\n").and(predicate::str::contains("123").not()),
        );
    // validate masks the value in the snippet
    std::fs::write(
        d.join("bad.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0094 = 4711\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["validate", "bad.toml"])
        .assert()
        .code(1)
        .stdout("error[out-of-range]: C0094 (user_password) = <secret>: the value is not valid for this code (out-of-range)\n --> bad.toml:3:9\n  |\n3 | C0094 = <secret>\n  |         ^^^^^^^^ here\n  |\n  = help: give a valid password (the value is not shown: it is a secret)\n\n1 finding in 1 of 1 file\n");
}

#[test]
fn commission_refuses_a_line_whose_set_could_start_a_motor_before_anything_is_sent() {
    let dir = sim_dir();
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
        driveset_in(d)
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
    driveset_in(d)
        .args(["commission", "line.toml", "--force"])
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --force was replaced by named overrides",
        ));
}

// ---------------------------------------------------------------------------
// Issue 17: the role floor no schema file removes, the write guard, and
// rollbacks / recover that never restart a motor.
// ---------------------------------------------------------------------------

const MC: &str = "sim://mc6000?addresses=1";

/// What the simulated drive at `address` holds in code `number` (state file
/// `sim/sim-FAMILY.json`).
fn held(dir: &Path, family: &str, address: u8, number: u32) -> i64 {
    let path = dir.join(format!("sim/sim-{family}.json"));
    match state_raw(&path, address, number) {
        Some(RawValue::Int(v)) => v,
        other => panic!("code {number}: {other:?}"),
    }
}

/// `lenze-tmd.toml` with every `role` and `stopped` line removed, as `id`.
fn tmd_without_roles(dir: &Path, id: &str) -> PathBuf {
    let text = std::fs::read_to_string(workspace_root().join("schemas/lenze-tmd.toml")).unwrap();
    let stripped: String = text
        .lines()
        .filter(|l| !l.starts_with("role = ") && !l.starts_with("stopped = "))
        .map(|l| {
            if l == "id = \"lenze-tmd\"" {
                format!("id = \"{id}\"\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert!(!stripped.contains("role = "));
    let p = dir.join(format!("{id}.toml"));
    std::fs::write(&p, stripped).unwrap();
    p
}

#[test]
fn a_tmd_schema_copy_without_roles_named_by_path_refuses_c0040_enable_and_sends_nothing() {
    let dir = sim_dir();
    let d = dir.path();
    tmd_without_roles(d, "my-tmd");
    std::fs::write(
        d.join("tmd.toml"),
        "schema = \"my-tmd.toml\"\n[values]\nC0040 = 1\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["validate", "tmd.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::starts_with(
            "error[control-word-not-stopped]: C0040 = \"Controller enabled\" would enable the drive (the stopped values are 0 \"Controller inhibited\")\n --> tmd.toml:3:9\n",
        ));
    for extra in [&[][..], &["--allow-running", "--allow-family"][..]] {
        driveset_in(d)
            .args([
                "upload",
                "tmd.toml",
                "--port",
                "sim://tmd?addresses=1&c0001=3",
                "--address",
                "1",
            ])
            .args(extra)
            .assert()
            .code(2)
            .stderr(predicate::str::ends_with("error: tmd.toml: not uploaded\n"));
    }
    // the simulated bus was never opened: not a byte reached the drive
    assert!(!d.join("sim/sim-tmd.json").exists());
    // the same copy keeping the built-in id is refused as a schema
    tmd_without_roles(d, "lenze-tmd");
    std::fs::write(
        d.join("tmd2.toml"),
        "schema = \"lenze-tmd.toml\"\n[values]\nC0040 = 1\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["upload", "tmd2.toml", "--port", "sim://tmd?addresses=1&c0001=3", "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: schema id `lenze-tmd` is already defined by schemas/lenze-tmd.toml\n",
        ))
        .stderr(predicate::str::contains(
            "= help: give each schema file its own id (a schema file cannot reuse a built-in or fixture id)\n",
        ));
    assert!(!d.join("sim/sim-tmd.json").exists());
}

const MINIMAL_MC: &str = "[schema]\nid = \"my-mc\"\ntitle = \"A minimal MC6000 schema without roles\"\nprotocol = \"lustbus-mc\"\ncode_style = \"lust\"\n\n[[code]]\nnumber = 4\nname = \"PROG\"\ntype = \"PT_USIGN16\"\nwidth = 2\n\n[[code]]\nnumber = 91\nname = \"TYPE\"\ntype = \"PT_USIGN16\"\nwidth = 2\n\n[[code]]\nnumber = 416\nname = \"SCTL1\"\ntype = \"PT_USIGN16\"\nwidth = 2\nkind = \"ram-control\"\n";

#[test]
fn a_minimal_mc_schema_without_roles_refuses_sctl1_start_and_prog() {
    let dir = sim_dir();
    let d = dir.path();
    std::fs::write(d.join("my-mc.toml"), MINIMAL_MC).unwrap();
    std::fs::write(
        d.join("start.toml"),
        "schema = \"my-mc.toml\"\n[values]\nSCTL1 = 1\n",
    )
    .unwrap();
    std::fs::write(
        d.join("prog.toml"),
        "schema = \"my-mc.toml\"\n[values]\nPROG = 1\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["validate", "start.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::starts_with(
            "error[control-word-not-stopped]: 416-SCTL1 = { start = 1, error_reset = 0 } would start or enable the drive (start set)\n --> start.toml:3:9\n",
        ));
    driveset_in(d)
        .args(["validate", "prog.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::starts_with(
            "error[command]: 4-PROG = 1 is a command (PROG), not a setting; a set cannot hold it\n --> prog.toml:3:8\n",
        ));
    for set in ["start.toml", "prog.toml"] {
        driveset_in(d)
            .args(["upload", set, "--port", MC, "--address", "1", "--no-learn"])
            .args([
                "--allow-running",
                "--allow-running-unknown",
                "--allow-family",
            ])
            .assert()
            .code(2)
            .stderr(predicate::str::ends_with(format!(
                "error: {set}: not uploaded\n"
            )));
    }
    assert!(!d.join("sim/sim-mc6000.json").exists());
}

/// A schema of the user's own named by path is used as it is: no learning
/// on top of it (a learned file could not name `my-mc` as its base), the
/// stopped control word lands and is verified without `--no-learn`.
#[test]
fn a_user_schema_by_path_is_used_as_it_is_without_learning() {
    let dir = sim_dir();
    let d = dir.path();
    std::fs::write(d.join("my-mc.toml"), MINIMAL_MC).unwrap();
    std::fs::write(
        d.join("stop.toml"),
        "schema = \"my-mc.toml\"\n[values]\nSCTL1 = 0\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["upload", "stop.toml", "--port", MC, "--address", "1"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "address 1: complete (0 of 1 codes written, 1 attempt(s), 2 telegrams, 0 retries,",
        ))
        .stderr(predicate::str::contains("learn").not());
    assert_eq!(
        driveset_test_support::toml_files_starting(d, "learned-"),
        Vec::<PathBuf>::new()
    );
    assert_eq!(held(d, "mc6000", 1, 416), 0);
}

#[test]
fn a_schemas_dir_cannot_reuse_a_built_in_or_fixture_id() {
    let dir = sim_dir();
    let d = dir.path();
    let schemas = d.join("schemas");
    std::fs::create_dir_all(&schemas).unwrap();
    // the fixture's id with its codes and no roles
    std::fs::write(
        schemas.join("mine.toml"),
        MINIMAL_MC.replace("id = \"my-mc\"", "id = \"fictional-mc6000-demo\""),
    )
    .unwrap();
    std::fs::write(
        d.join("set.toml"),
        "schema = \"fictional-mc6000-demo\"\n[values]\nSCTL1 = 1\n",
    )
    .unwrap();
    // validate's registry withholds the fixture; a command on a sim://
    // port has it loaded (its drives hold it): refused either way
    for (cmd, first) in [
        (
            "validate",
            "error: schema id `fictional-mc6000-demo` is the id of the simulator's fixture schema parameter-sets/fixtures/fictional-mc6000-demo.toml\n",
        ),
        (
            // one catalog on every port: the upload's registry withholds the
            // fixture ids as validate's does
            "upload",
            "error: schema id `fictional-mc6000-demo` is the id of the simulator's fixture schema parameter-sets/fixtures/fictional-mc6000-demo.toml\n",
        ),
    ] {
        let mut c = driveset_in(d);
        c.args([cmd, "--schemas", "schemas", "set.toml"]);
        if cmd == "upload" {
            c.args(["--port", MC, "--address", "1"]);
        }
        c.assert()
            .code(2)
            .stderr(predicate::str::starts_with(first))
            .stderr(predicate::str::contains(
                " --> schemas/mine.toml:2:6\n",
            ))
            .stderr(predicate::str::contains(
                "= help: give each schema file its own id (a schema file cannot reuse a built-in or fixture id)\n",
            ));
    }
    assert!(!d.join("sim/sim-mc6000.json").exists());
    // a built-in id
    std::fs::write(
        schemas.join("mine.toml"),
        MINIMAL_MC.replace("id = \"my-mc\"", "id = \"lust-mc6000\""),
    )
    .unwrap();
    driveset_in(d)
        .args(["validate", "--schemas", "schemas", "set.toml"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "error: schema id `lust-mc6000` is already defined by schemas/lust-mc6000.toml\n",
        ));
}

/// A running simulated MC6000 (416-SCTL1 = 1, started by the machine's
/// control) and the set that stops it, with 81-SBAUD written after it.
fn running_mc_and_stop_set(d: &Path) {
    set_file(
        d,
        "stop.toml",
        "fictional-mc6000-demo.toml",
        "SCTL1 = { start = false }\nSBAUD = 19200\n",
    );
    driveset_in(d)
        .args([
            "upload",
            "stop.toml",
            "--port",
            MC,
            "--address",
            "1",
            "--dry-run",
        ])
        .assert()
        .code(0);
    poke_state(d, "mc6000", 1, 416, 1);
    assert_eq!(held(d, "mc6000", 1, 416), 1);
}

const LEFT_STOPPED: &str =
    "416-SCTL1 left stopped: the motor was running before; start it from the machine's control";

#[test]
fn stopping_a_running_mc6000_cut_at_telegram_6_rolls_back_leaving_416_stopped() {
    let dir = sim_dir();
    let d = dir.path();
    running_mc_and_stop_set(d);
    let port = "sim://mc6000?addresses=1&faults=cable@6+1s";
    driveset_in(d)
        .args(["upload", "stop.toml", "--port", port, "--address", "1", "--allow-running"])
        .args(["--journal", "j.json"])
        .assert()
        .code(3)
        .stdout(predicate::str::contains(format!("warning: {LEFT_STOPPED}\n")))
        .stderr(predicate::str::contains(format!(
            "the upload did not land and was rolled back: {port} address 1: no answer to write 416-SCTL1 (raw 0) after 3 tries; check wiring, address and baud rate; {LEFT_STOPPED}; "
        )));
    // the rollback wrote the stopped state, never 416 = 1
    assert_eq!(held(d, "mc6000", 1, 416), 0);
    assert_eq!(held(d, "mc6000", 1, 81), 9600);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("j.json")).unwrap()).unwrap();
    assert_eq!(j["state"], "rolled-back", "{j}");
}

#[test]
fn recover_of_a_cut_stop_and_of_an_edited_journal_leave_416_stopped() {
    let dir = sim_dir();
    let d = dir.path();
    running_mc_and_stop_set(d);
    // the cable stays out: the upload cannot roll back, recover does
    driveset_in(d)
        .args([
            "upload",
            "stop.toml",
            "--port",
            "sim://mc6000?addresses=1&faults=cable@6+600s",
        ])
        .args(["--address", "1", "--allow-running", "--journal", "j.json"])
        .assert()
        .code(3);
    assert_eq!(held(d, "mc6000", 1, 416), 0);
    let journal = d.join("j.json");
    let cut: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).unwrap()).unwrap();
    assert_eq!(cut["state"], "failed", "{cut}");
    driveset_in(d)
        .args(["recover", "j.json", "--port", MC])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "journal was failed; rolled back: the drive holds its old values again (verified); journal marked rolled-back\nrestored: 416-SCTL1\n",
        ))
        .stdout(predicate::str::contains(format!("\n{LEFT_STOPPED}\n")));
    assert_eq!(held(d, "mc6000", 1, 416), 0);
    assert_eq!(held(d, "mc6000", 1, 81), 9600);

    // the same journal edited by hand: unsettled again, and its old value
    // of 416 a start with an error reset (129)
    let mut edited = cut.clone();
    for b in edited["backup"].as_array_mut().unwrap() {
        if b["number"] == 416 {
            b["old"] = serde_json::json!({"int": 129});
        }
    }
    std::fs::write(&journal, serde_json::to_string_pretty(&edited).unwrap()).unwrap();
    driveset_in(d)
        .args(["recover", "j.json", "--port", MC, "--format", "json"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(format!(
            "\"notes\": [\n    \"{LEFT_STOPPED}\"\n  ]"
        )));
    assert_eq!(held(d, "mc6000", 1, 416), 0);
}

/// Issue 17: every output of the commands that see a set's password, with
/// the password uploaded to a simulated Tmd: none shows its value.
#[test]
fn a_password_never_shows_in_upload_pull_diff_show_or_fingerprint() {
    use std::os::unix::fs::PermissionsExt as _;
    let d = sim_dir();
    let dir = d.path();
    std::fs::write(
        dir.join("p.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\nC0094 = 742\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("q.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\nC0094 = 743\n",
    )
    .unwrap();
    let port = "sim://tmd?c0001=3";
    let runs: [(&[&str], i32); 10] = [
        (
            &[
                "upload",
                "p.toml",
                "--port",
                port,
                "--address",
                "1",
                "--dry-run",
            ],
            0,
        ),
        (
            &[
                "upload",
                "p.toml",
                "--port",
                port,
                "--address",
                "1",
                "--dry-run",
                "--format",
                "json",
            ],
            0,
        ),
        (
            &[
                "upload",
                "p.toml",
                "--port",
                port,
                "--address",
                "1",
                "--format",
                "json",
                "--journal",
                "j.json",
            ],
            0,
        ),
        (&["upload", "p.toml", "--port", port, "--address", "1"], 0),
        (
            &[
                "pull",
                "--port",
                port,
                "--address",
                "1",
                "-o",
                "pulled.toml",
            ],
            0,
        ),
        (&["diff", "q.toml", "--port", port, "--address", "1"], 1),
        (&["diff", "p.toml", "q.toml"], 1),
        (&["diff", "--unified", "p.toml", "q.toml"], 1),
        (&["show", "p.toml"], 0),
        (&["fingerprint", "p.toml"], 0),
    ];
    for (args, code) in runs {
        let out = driveset_in(dir)
            .args(args)
            .assert()
            .code(code)
            .get_output()
            .clone();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        for v in ["742", "743", "7420000", "7430000"] {
            assert!(
                !driveset_test_support::shows_value(&text, v),
                "{args:?}: {text}"
            );
        }
    }
    for t in ["toml", "yaml", "json"] {
        let out = driveset_in(dir)
            .args(["show", "--to", t, "p.toml"])
            .assert()
            .code(0)
            .get_output()
            .clone();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            !driveset_test_support::shows_value(&text, "742"),
            "--to {t}"
        );
    }
    let pulled = std::fs::read_to_string(dir.join("pulled.toml")).unwrap();
    assert!(
        !driveset_test_support::shows_value(&pulled, "742"),
        "{pulled}"
    );
    // the drive does hold it (the state file is the drive's memory, 0600)
    let state = dir.join("sim/sim-tmd.json");
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
    assert!(
        dump["drives"][0]["canonical"]
            .as_str()
            .unwrap()
            .contains("\nC0094 7420000\n")
    );
    assert_eq!(
        std::fs::metadata(&state).unwrap().permissions().mode() & 0o777,
        0o600
    );
    // the journal keeps the password for a rollback: 0600, marked secret
    let j = dir.join("j.json");
    assert_eq!(
        std::fs::metadata(&j).unwrap().permissions().mode() & 0o777,
        0o600
    );
    assert!(
        std::fs::read_to_string(&j)
            .unwrap()
            .contains("\"secret\": true")
    );
}
