//! `driveset commission` / `driveset status` on the demo line (three
//! simulated buses, one of them a LUSTBUS with MC6000 and VF1000 drives,
//! thirteen drives) and line manifests in `validate`. Consecutive runs see
//! the same simulated drives through the simulator's state directory
//! (`DRIVESET_SIM_STATE_DIR`, one file per bus: `sim-lustbus.json` for the
//! mixed LUSTBUS, `sim-FAMILY.json` for the others).

use std::path::Path;

use predicates::prelude::*;

use driveset_schema::CodeStyle;
use driveset_test_support::{driveset_in, sim_dir, workspace_root};

fn demo() -> String {
    workspace_root()
        .join("parameter-sets/demo-line/line.toml")
        .display()
        .to_string()
}

fn report(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("target/driveset-report/report.json"))
        .expect("report.json written");
    serde_json::from_str(&text).expect("report.json parses")
}

fn results(r: &serde_json::Value) -> Vec<(String, String)> {
    r["drives"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            (
                d["name"].as_str().unwrap().to_string(),
                d["result"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// Change C0011 of the simulated Tmd at `address` in the state file.
fn drift_tmd(dir: &Path, address: u8, raw: i64) {
    let path = dir.join("sim/sim-tmd.json");
    driveset_test_support::poke_state(&path, Some(address), 11, raw, CodeStyle::Lenze);
}

#[test]
fn commission_the_demo_line_then_status_finds_a_drifted_drive_then_recommission() {
    let dir = sim_dir();
    driveset_in(dir.path())
        .args(["commission", &demo(), "--label", "it test"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "DRIVE         BUS/ADDRESS  RESULT    WRITTEN  FINGERPRINT\n",
        ))
        .stdout(predicate::str::contains(
            "13 of 13 drives commissioned: 13 verified, 0 unchanged, 0 already verified, 0 drift, 0 rolled back, 0 failed; line demo-line: ok\n",
        ))
        .stdout(predicate::str::contains(
            "report: target/driveset-report/report.json target/driveset-report/report.html\n",
        ))
        .stderr(predicate::str::contains(
            "[transfer] 2/3 transfer-12: verified, 10 codes written",
        ));
    let r = report(dir.path());
    assert_eq!(r["command"], "commission");
    assert_eq!(r["line"], "demo-line");
    assert_eq!(r["label"], "it test");
    assert_eq!(r["result"], "ok");
    assert_eq!(r["buses"].as_array().unwrap().len(), 3);
    for d in r["drives"].as_array().unwrap() {
        assert_eq!(d["result"], "verified", "{d}");
        assert_eq!(d["fingerprint_after"], d["set_fingerprint"], "{d}");
        // each drive is said kept over a power cycle: LUSTBUS and the Tmd
        // store every write, the demo ECS axes on their store command
        let kept = if d["schema"] == "fictional-ecs-demo" {
            "stored"
        } else {
            "stored (the drive stores every write)"
        };
        assert_eq!(d["stored"], kept, "{d}");
    }
    let html =
        std::fs::read_to_string(dir.path().join("target/driveset-report/report.html")).unwrap();
    assert!(
        html.contains("<dt>Kept at power off</dt><dd>stored (the drive stores every write)</dd>")
    );
    assert!(
        dir.path()
            .join("target/driveset-report/.commission-state.json")
            .exists()
    );

    // nothing drifted yet
    driveset_in(dir.path())
        .args(["status", &demo()])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "13 of 13 drives checked: 0 verified, 13 unchanged, 0 already verified, 0 drift",
        ));
    assert_eq!(report(dir.path())["command"], "status");

    // someone turns transfer-12 down to 55 Hz on the keypad
    drift_tmd(dir.path(), 12, 550_000);
    driveset_in(dir.path())
        .args(["status", &demo()])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "transfer-12   transfer/12  DRIFT",
        ))
        .stdout(predicate::str::contains(
            "transfer-12 (transfer/12) differs from sets/transfer-12.toml:\n  C0011 maximum_output_frequency: 55 Hz -> 60 Hz\n",
        ))
        .stdout(predicate::str::contains("line demo-line: DRIFT"));
    let r = report(dir.path());
    assert_eq!(r["result"], "drift");
    let t12 = &r["drives"][8];
    assert_eq!(t12["name"], "transfer-12");
    assert_eq!(t12["result"], "drift");
    assert_eq!(t12["diff"][0]["code"], "C0011");

    // commission again: only the drifted drive is written
    driveset_in(dir.path())
        .args(["commission", &demo()])
        .assert()
        .code(0)
        .stderr(predicate::str::contains(
            "warning: transfer-12: recorded as verified at ",
        ))
        .stdout(predicate::str::contains(
            "13 of 13 drives commissioned: 1 verified, 0 unchanged, 12 already verified",
        ));
    let r = report(dir.path());
    for (name, result) in results(&r) {
        let want = if name == "transfer-12" {
            "verified"
        } else {
            "already-verified"
        };
        assert_eq!(result, want, "{name}");
    }
    assert_eq!(r["drives"][8]["codes_written"], 1);
}

#[test]
fn a_killed_run_resumes_and_skips_the_verified_drives() {
    let dir = sim_dir();
    driveset_in(dir.path())
        .args(["commission", &demo(), "--stop-after", "1"])
        .assert()
        .code(3)
        .stdout(predicate::str::contains(
            "13 of 13 drives commissioned: 3 verified, 0 unchanged, 0 already verified, 0 drift, 0 rolled back, 10 failed; line demo-line: FAILED\n",
        ))
        .stdout(predicate::str::contains(
            "press-axis-2: not reached: the run stopped after 1 drive(s) on bus `lustbus` (--stop-after); run the command again to resume\n",
        ));
    driveset_in(dir.path())
        .args(["commission", &demo()])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "13 of 13 drives commissioned: 10 verified, 0 unchanged, 3 already verified",
        ));
    let r = report(dir.path());
    let already: Vec<String> = results(&r)
        .into_iter()
        .filter(|(_, res)| res == "already-verified")
        .map(|(n, _)| n)
        .collect();
    assert_eq!(already, ["press-axis-1", "transfer-11", "handling-1"]);
    // --fresh commissions everything again (the drives hold their sets: unchanged)
    driveset_in(dir.path())
        .args(["commission", &demo(), "--fresh", "--only", "transfer"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "3 of 13 drives commissioned: 0 verified, 3 unchanged",
        ));
}

#[test]
fn only_names_an_unknown_drive_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    driveset_in(dir.path())
        .args(["commission", &demo(), "--only", "press-axis-9"])
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: no drive or bus is named `press-axis-9` in ",
        ));
}

const BAD: &str = r#"[line]
name = "bad"

[[bus]]
name = "a"
port = "sim://tmd"
protocol = "lecom"

[[drive]]
bus = "a"
address = 20
set = "tmd.toml"

[[drive]]
bus = "a"
address = 11
set = "tmd.toml"

[[drive]]
name = "second"
bus = "a"
address = 11
set = "nope.toml"
"#;

#[test]
fn a_bad_manifest_fails_validation_with_locations() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("tmd.toml"),
        "schema = \"lenze-tmd\"\n[values]\nC0011 = \"50 Hz\"\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("line.toml"), BAD).unwrap();
    let out = driveset_in(dir.path())
        .args(["validate", "line.toml"])
        .assert()
        .code(1)
        .get_output()
        .stdout
        .clone();
    let out = String::from_utf8(out).unwrap();
    for want in [
        "address 20 on lecom bus `a`: LECOM 00 is the broadcast address and 10, 20, ... 90 are group addresses; a drive needs its own address 1..99 not ending in 0\n",
        "  --> line.toml:11:11\n",
        "address 11 is used twice on bus `a`\n",
        "  --> line.toml:22:11\n",
        "  ::: line.toml:16:11\n",
        "set file `nope.toml` does not exist (nope.toml)\n",
        "  --> line.toml:23:7\n",
        "3 findings in 1 of 1 file\n",
    ] {
        assert!(out.contains(want), "missing {want:?} in:\n{out}");
    }
    // commission refuses it before opening any bus: exit 2, own kinds
    driveset_in(dir.path())
        .args(["commission", "line.toml"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "error[duplicate-address]: address 11 is used twice on bus `a`\n  --> line.toml:22:11\n",
        ))
        .stderr(predicate::str::contains(
            "error: line.toml: 3 finding(s) in the line manifest; nothing was sent (see `driveset validate line.toml`)\n",
        ));
    assert!(!dir.path().join("target").exists());
}

/// A line whose sets name the built-in `lust-mc6000` / `lust-vf1000` with
/// codes those schemas have no type for: `validate` finds them (naming the
/// remedy), `commission --no-learn` refuses at load (exit 2), `commission`
/// learns each drive's schema, writes it into `--schema-dir`, names it in
/// report.json and verifies; `status` then finds both drives unchanged,
/// and a pull with the learned schema reads exactly the set's values.
#[test]
fn commission_learns_the_schema_of_sets_naming_the_built_in_lust_schemas() {
    let dir = sim_dir();
    let d = dir.path();
    std::fs::create_dir_all(d.join("sets")).unwrap();
    std::fs::write(
        d.join("line.toml"),
        "[line]\nname = \"learn-line\"\n\n[[bus]]\nname = \"lustbus\"\nport = \"sim://lustbus?mc6000=1&vf1000=5\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n[[drive]]\nbus = \"lustbus\"\naddress = 1\nset = \"sets/press.toml\"\nname = \"press\"\n\n[[drive]]\nbus = \"lustbus\"\naddress = 5\nset = \"sets/fan.toml\"\nname = \"fan\"\n",
    )
    .unwrap();
    std::fs::write(
        d.join("sets/press.toml"),
        "schema = \"lust-mc6000\"\n\n[values]\n100 = \"16 kHz\"\n132 = \"5 A\"\n134 = \"3500 1/min\"\n",
    )
    .unwrap();
    std::fs::write(
        d.join("sets/fan.toml"),
        "schema = \"lust-vf1000\"\n\n[values]\n7 = \"60 Hz\"\n20 = \"15 Hz\"\n",
    )
    .unwrap();
    driveset_in(d)
        .args(["validate", "line.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains("error[unknown-code]: 132 is not a code of lust-mc6000\n"))
        .stdout(predicate::str::contains(
            "the set names `lust-mc6000`, which lacks facts (types, kinds, ranges) the drive's own descriptions give: `driveset commission` and `driveset status` learn the schema from the drive first",
        ))
        .stdout(predicate::str::contains("5 findings in 1 of 1 file"));
    driveset_in(d)
        .args(["commission", "line.toml", "--no-learn"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "line.toml: 5 finding(s) in the line manifest; nothing was sent",
        ));
    let out = driveset_in(d)
        .args(["commission", "line.toml", "--schema-dir", "schemas"])
        .assert()
        .code(0)
        .get_output()
        .clone();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let r = report(d);
    assert_eq!(
        results(&r),
        [
            ("press".to_string(), "verified".to_string()),
            ("fan".to_string(), "verified".to_string())
        ]
    );
    let mut files = Vec::new();
    for (i, (base, family, codes, written)) in [
        ("lust-mc6000", "mc6000", 250, 3),
        ("lust-vf1000", "vf1000", 58, 2),
    ]
    .into_iter()
    .enumerate()
    {
        let dr = &r["drives"][i];
        let ls = &dr["learned_schema"];
        let id = ls["id"].as_str().unwrap().to_string();
        let ty = if family == "mc6000" { 6000 } else { 1000 };
        assert!(
            id.starts_with(&format!("learned-{family}-type{ty}-d")),
            "{id}"
        );
        assert_eq!(dr["schema"], id.as_str());
        assert_eq!(ls["base"], base);
        assert_eq!(ls["codes"], codes);
        assert_eq!(ls["texts"], true);
        assert_eq!(dr["codes_written"], written);
        let file = format!("schemas/{id}.toml");
        assert_eq!(ls["file"], file.as_str());
        assert!(d.join(&file).is_file(), "{file}");
        assert!(
            stderr.contains(&format!(
                " {}: verified, schema {id} learned, {written} codes written (",
                dr["name"].as_str().unwrap()
            )),
            "{stderr}"
        );
        files.push(file);
    }
    // the learned files pass `schema check`
    for f in &files {
        driveset_in(d).args(["schema", "check", f]).assert().code(0);
    }
    driveset_in(d)
        .args(["status", "line.toml", "--schema-dir", "schemas"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "2 unchanged, 0 already verified, 0 drift",
        ));
    let r = report(d);
    assert_eq!(r["command"], "status");
    assert_eq!(r["drives"][0]["learned_schema"]["file"], files[0].as_str());
    assert_eq!(r["drives"][0]["learned_schema"]["texts"], false);
    // exact values on the drives, read with the learned schemas
    for (file, address, lines) in [
        (
            &files[0],
            "1",
            &["100 = \"16 kHz\"", "132 = \"5 A\"", "134 = \"3500 1/min\""][..],
        ),
        (&files[1], "5", &["7 = \"60 Hz\"", "20 = \"15 Hz\""][..]),
    ] {
        let out = d.join(format!("pulled-{address}.toml"));
        driveset_in(d)
            .args([
                "pull",
                "--port",
                "sim://lustbus?mc6000=1&vf1000=5",
                "--address",
                address,
                "--schema",
                file,
                "-o",
            ])
            .arg(&out)
            .assert()
            .code(0);
        let text = std::fs::read_to_string(&out).unwrap();
        for l in lines {
            assert!(text.contains(&format!("\n{l}\n")), "{l} in {text}");
        }
    }
}

/// Three MC6000 axes on one simulated LUSTBUS sharing the demo line's base
/// set (each its own SADDR and KPSC1).
fn mc_axes_line(dir: &Path) -> String {
    let sets = workspace_root()
        .join("parameter-sets/demo-line/sets")
        .canonicalize()
        .unwrap();
    let mut m = String::from(
        "[line]\nname = \"axes\"\n\n[[bus]]\nname = \"axes\"\nport = \"sim://mc6000\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n",
    );
    for a in 1..=3u8 {
        std::fs::write(
            dir.join(format!("axis-{a}.toml")),
            format!(
                "schema = \"{s}/../../fixtures/fictional-mc6000-demo.toml\"\nextends = \"{s}/mc6000-base.toml\"\n\n[values]\nSADDR = {a}\nKPSC1 = \"0.0{k}25 Nm/(rad/s)\"\n",
                s = sets.display(),
                k = a + 1
            ),
        )
        .unwrap();
        m.push_str(&format!(
            "[[drive]]\nname = \"axis-{a}\"\nbus = \"axes\"\naddress = {a}\nset = \"axis-{a}.toml\"\n\n"
        ));
    }
    std::fs::write(dir.join("line.toml"), m).unwrap();
    "line.toml".into()
}

#[test]
fn commission_broadcast_common_on_lustbus_sends_to_address_31_and_verifies_every_drive() {
    let dir = sim_dir();
    let line = mc_axes_line(dir.path());
    driveset_in(dir.path())
        .args(["commission", &line, "--broadcast-common"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "3 of 3 drives commissioned: 3 verified, 0 unchanged, 0 already verified, 0 drift, 0 rolled back, 0 failed; line axes: ok\n",
        ))
        .stderr(predicate::str::is_match(
            "warning: bus `axes`: [0-9]+ value\\(s\\) common to its 3 drives sent once to address 31 \\(broadcast, no receipt\\) inside each drive's dataset download; every value verified drive by drive\n",
        ).unwrap());
    let r = report(dir.path());
    let timeline = r["buses"][0]["timeline"].as_array().unwrap();
    let bc: Vec<&serde_json::Value> = timeline
        .iter()
        .filter(|t| t["phase"] == "broadcast")
        .collect();
    assert_eq!(bc.len(), 1);
    assert_eq!(bc[0]["drive"], "address 31");
    for d in r["drives"].as_array().unwrap() {
        assert_eq!(d["result"], "verified", "{d}");
        assert_eq!(d["fingerprint_after"], d["set_fingerprint"], "{d}");
    }
    // every journal lists the broadcast codes: never 81..85 or 91
    let jdir = dir.path().join(".driveset/journal");
    let mut lists = Vec::new();
    for e in std::fs::read_dir(&jdir).unwrap() {
        let p = e.unwrap().path();
        if p.to_string_lossy().ends_with(".journal.json") {
            let j: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
            assert_eq!(j["state"], "complete");
            lists.push(j["broadcast"].clone());
        }
    }
    assert_eq!(lists.len(), 3);
    assert!(lists.iter().all(|l| *l == lists[0]));
    let codes: Vec<&str> = lists[0]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(codes.contains(&"171"), "{codes:?}");
    for c in ["81", "82", "83", "84", "85", "91", "80", "416"] {
        assert!(!codes.contains(&c), "{codes:?}");
    }
    // the drives hold their sets
    driveset_in(dir.path())
        .args(["status", &line])
        .assert()
        .code(0);
    // a rerun with broadcast trusts the state file as a drive-by-drive
    // run does: one read of each set, no broadcast, nothing written
    driveset_in(dir.path())
        .args(["commission", &line, "--broadcast-common"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(
            "3 of 3 drives commissioned: 0 verified, 0 unchanged, 3 already verified, 0 drift, 0 rolled back, 0 failed; line axes: ok\n",
        ));
}

#[test]
fn commission_broadcast_common_refuses_a_lustbus_with_vf1000_drives() {
    let dir = sim_dir();
    driveset_in(dir.path())
        .args(["commission", &demo(), "--only", "lustbus", "--broadcast-common"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains(
            "warning: bus `lustbus`: no broadcast (address 31): refused: the bus also has VF1000 drives (conveyor-5, conveyor-6, conveyor-7), which would execute every SELECT to address 31 as a write of their own parameter of that number (LUSTBUS 4.2); values were written drive by drive\n",
        ));
    let r = report(dir.path());
    assert!(
        !r["buses"][0]["timeline"]
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t["phase"] == "broadcast")
    );
}

#[test]
fn transfer_baud_on_a_bus_shared_with_vf1000s_needs_its_override() {
    let dir = sim_dir();
    let d = dir.path();
    // axis-1 as its sample file has it, but at the bus's 9600 baud (its
    // 81-SBAUD = 19200 disagrees with the manifest: `set-rate`)
    let sample = workspace_root().join("parameter-sets/mc6000/axis-1.toml");
    let fixture = workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml");
    let axis = d.join("axis-1.toml");
    std::fs::write(
        &axis,
        std::fs::read_to_string(&sample)
            .unwrap()
            .replace(
                "schema = \"../fixtures/fictional-mc6000-demo.toml\"",
                &format!("schema = {:?}", fixture.display().to_string()),
            )
            .replace("SBAUD = \"19200 Baud\"", "SBAUD = \"9600 Baud\""),
    )
    .unwrap();
    let fan = workspace_root().join("parameter-sets/vf1000/conveyor-1.toml");
    std::fs::write(
        d.join("line.toml"),
        format!(
            "[line]\nname = \"fast\"\n\n[[bus]]\nname = \"lustbus\"\nport = \"sim://lustbus?mc6000=1&vf1000=4\"\nprotocol = \"lustbus\"\nbaud = 9600\ntransfer_baud = 57600\n\n[[drive]]\nbus = \"lustbus\"\naddress = 1\nset = \"{}\"\nname = \"press\"\n\n[[drive]]\nbus = \"lustbus\"\naddress = 4\nset = \"{}\"\nname = \"fan\"\n",
            axis.display(),
            fan.display()
        ),
    )
    .unwrap();
    // without the override the MC is refused before anything is sent to
    // it; the VF1000 is uploaded at the bus's rate
    driveset_in(d)
        .args(["commission", "line.toml"])
        .assert()
        .code(1)
        .stdout(predicate::str::contains(
            "press: sim://lustbus?mc6000=1&vf1000=4&baud=9600 address 1: refused: --transfer-baud 57600: the bus is shared with 1 drive(s) (Lust SMARTDRIVE VF1000) that cannot follow: while this drive talks at 57600 baud they hear garbage, and their watchdog (84-SIOT / SWDGT, lustbus-protocol.txt §5.2) may fire; give --allow-shared-transfer-baud to switch anyway, or leave out --transfer-baud\n",
        ));
    assert_eq!(
        results(&report(d)),
        [
            ("press".to_string(), "failed".to_string()),
            ("fan".to_string(), "verified".to_string())
        ]
    );
    driveset_in(d)
        .args(["commission", "line.toml", "--allow-shared-transfer-baud"])
        .assert()
        .code(0)
        .stderr(predicate::str::contains(
            "warning: press: transfer rate 57600: saves 3.7 s of 4.8 s (195 exchanges: 4.8 s at 9600 baud, 962 ms at 57600 baud plus 112 ms to switch over and back)\n",
        ));
    assert_eq!(
        results(&report(d)),
        [
            ("press".to_string(), "verified".to_string()),
            ("fan".to_string(), "already-verified".to_string())
        ]
    );
}

/// Issue 17: a password set by commission and then changed in the set:
/// neither commission's nor status's output and reports show its value.
#[test]
fn commission_and_status_reports_never_show_a_password() {
    let dir = sim_dir();
    let d = dir.path();
    std::fs::write(
        d.join("line.toml"),
        "[line]\nname = \"pw-line\"\n\n[[bus]]\nname = \"a\"\nport = \"sim://tmd?c0001=3\"\nprotocol = \"lecom\"\n\n[[drive]]\nbus = \"a\"\naddress = 1\nset = \"tmd.toml\"\nname = \"axis\"\n",
    )
    .unwrap();
    let set = |pw: u32| {
        std::fs::write(
            d.join("tmd.toml"),
            format!("schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\nC0094 = {pw}\n"),
        )
        .unwrap();
    };
    let no_secret = |out: &std::process::Output, what: &str| {
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        for v in ["742", "743", "7420000", "7430000"] {
            assert!(
                !driveset_test_support::shows_value(&text, v),
                "{what}: {text}"
            );
        }
    };
    set(742);
    let out = driveset_in(d)
        .args(["commission", "line.toml", "--report-dir", "out"])
        .assert()
        .code(0)
        .get_output()
        .clone();
    no_secret(&out, "commission");
    set(743);
    let out = driveset_in(d)
        .args(["status", "line.toml", "--report-dir", "out2"])
        .assert()
        .code(1)
        .get_output()
        .clone();
    no_secret(&out, "status");
    assert!(
        String::from_utf8_lossy(&out.stdout)
            .contains("  C0094 user_password: <secret> -> <secret>\n")
    );
    for f in [
        "out/report.json",
        "out/report.html",
        "out2/report.json",
        "out2/report.html",
    ] {
        let text = std::fs::read_to_string(d.join(f)).unwrap();
        for v in ["742", "743", "7420000", "7430000"] {
            assert!(!driveset_test_support::shows_value(&text, v), "{f}");
        }
    }
}
