//! `--transfer-baud` end to end over a real pseudo terminal (issue 17):
//! `driveset sim --pty` follows the rate the host sets on its end of the
//! pty (termios), so a drive switched by 4-PROG = 111 answers only a host
//! that followed, as on a real line. An upload switched to 57600 and back,
//! and one cut by a pulled cable at the transfer rate, then `driveset
//! recover`; the drive's state is read from the simulator's dump.

use std::path::Path;

use crate::e2e_pty::{Sim, load, one_at_a_time, run};

const SET: &str = "parameter-sets/mc6000/axis-1.toml";

/// The simulator's dump of drive 1: its values and its rate.
fn dump(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("mc6000.dump.json")).expect("dump written");
    serde_json::from_str(&text).expect("dump JSON")
}

/// 81-SBAUD as the dump's canonical form spells it.
fn sbaud(dump: &serde_json::Value) -> String {
    let canonical = dump["drives"][0]["canonical"].as_str().expect("canonical");
    canonical
        .lines()
        .find_map(|l| l.strip_prefix("81 "))
        .unwrap_or_else(|| panic!("no 81 in\n{canonical}"))
        .to_string()
}

/// `driveset sim --pty` with one MC6000 at address 1 at 9600 baud,
/// logging into `DIR/bus.jsonl`: the simulator, the log and the port
/// (`PTY?baud=9600`).
fn logged_sim(dir: &Path) -> (Sim, std::path::PathBuf, String) {
    let log = dir.join("bus.jsonl");
    let log_arg = log.to_string_lossy().into_owned();
    let sim = Sim::start(dir, "mc6000", 1, &["--baud", "9600", "--log", &log_arg]);
    let port = format!("{}?baud=9600", sim.path);
    (sim, log, port)
}

#[test]
fn upload_at_57600_over_a_pty_switches_and_comes_back_to_9600() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut sim, log, port) = logged_sim(dir.path());
    let jd = dir.path().join("journal").to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "upload",
        SET,
        "--port",
        &port,
        "--address",
        "1",
        "--transfer-baud",
        "57600",
        "--journal-dir",
        &jd,
    ]);
    let context = || {
        format!(
            "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- sim\n{}",
            sim.stderr()
        )
    };
    assert_eq!(code, Some(0), "{}", context());
    assert!(
        stdout.contains("line rate: the drive runs at 9600 baud again; 81-SBAUD holds 19200 (not active: in effect after the drive's next restart)"),
        "{}",
        context()
    );
    // the host's pty went to 57600 and back, and the drive with it
    let events = std::fs::read_to_string(&log).expect("log");
    let notes: Vec<&str> = events
        .lines()
        .filter(|l| l.contains("host-baud") || l.contains("baud-change"))
        .collect();
    assert_eq!(notes.len(), 4, "{notes:#?}");
    assert!(
        notes[0].contains("drive 1 runs at 57600 baud from here"),
        "{notes:#?}"
    );
    assert!(
        notes[1].contains("the host's port runs at 57600 baud from here"),
        "{notes:#?}"
    );
    assert!(
        notes[2].contains("drive 1 runs at 9600 baud from here"),
        "{notes:#?}"
    );
    assert!(
        notes[3].contains("the host's port runs at 9600 baud from here"),
        "{notes:#?}"
    );
    // at 9600 the drive holds the set
    let (code, out, err) = run(&["diff", SET, "--port", &port, "--address", "1"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.contains("no differences"), "{out}");
    // a host at 57600 now gets no answer from a drive at 9600
    let (code, out, err) = run(&[
        "diff",
        SET,
        "--port",
        &format!("{}?baud=57600", sim.path),
        "--address",
        "1",
        "--no-learn",
    ]);
    assert_ne!(code, Some(0), "{out}{err}");
    assert!(sim.terminate().success(), "{}", sim.stderr());
    let d = dump(dir.path());
    assert_eq!(sbaud(&d), "19200", "{d}");
    let set = load(SET);
    assert_eq!(crate::e2e_pty::dump_subset(&d, 1, &set), set.canonical());
}

/// The simulator's state file of the `sim://` runs below: drive 1's rate
/// (absent: the line's) and its canonical values.
fn state(dir: &Path) -> (serde_json::Value, String) {
    let path = std::fs::read_dir(dir)
        .expect("state dir")
        .next()
        .expect("a state file")
        .expect("entry")
        .path();
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("state")).expect("JSON");
    let drive = &d["drives"][0];
    (
        drive["rate"].clone(),
        drive["canonical"].as_str().expect("canonical").to_string(),
    )
}

fn code_line<'a>(canonical: &'a str, code: &str) -> &'a str {
    canonical
        .lines()
        .find(|l| l.split_once(' ').is_some_and(|(c, _)| c == code))
        .unwrap_or_else(|| panic!("no {code} in\n{canonical}"))
}

/// One of issue 17's reproductions through the binary: upload with
/// `faults`, then `recover` through the same simulated bus (cable back, no
/// faults), then `diff`. Returns (upload stderr, recover stdout, diff exit
/// code, 81 and 428 as the drive holds them, its rate).
fn cut_then_recover(
    faults: &str,
) -> (
    String,
    String,
    Option<i32>,
    String,
    String,
    serde_json::Value,
) {
    let dir = tempfile::tempdir().expect("tempdir");
    let state_dir = dir.path().join("sim");
    std::fs::create_dir_all(&state_dir).expect("state dir");
    let set = driveset_test_support::workspace_root().join(SET);
    let journal = dir.path().join("j.json");
    let up = driveset_test_support::driveset()
        .env("DRIVESET_SIM_STATE_DIR", &state_dir)
        .arg("upload")
        .arg(&set)
        .args([
            "--port",
            &format!("sim://mc6000?addresses=1&faults={faults}"),
            "--address",
            "1",
        ])
        .args(["--transfer-baud", "57600", "--journal"])
        .arg(&journal)
        .output()
        .expect("upload");
    let up_err = String::from_utf8_lossy(&up.stderr).into_owned();
    assert_eq!(
        up.status.code(),
        Some(3),
        "{faults}: upload\n{}{up_err}",
        String::from_utf8_lossy(&up.stdout)
    );
    assert!(
        up_err.contains(&format!("driveset recover {}", journal.display())),
        "{up_err}"
    );
    let rec = driveset_test_support::driveset()
        .env("DRIVESET_SIM_STATE_DIR", &state_dir)
        .arg("recover")
        .arg(&journal)
        .args(["--port", "sim://mc6000?addresses=1"])
        .output()
        .expect("recover");
    let rec_out = String::from_utf8_lossy(&rec.stdout).into_owned();
    assert_eq!(
        rec.status.code(),
        Some(0),
        "{faults}: recover\n{rec_out}{}",
        String::from_utf8_lossy(&rec.stderr)
    );
    let diff = driveset_test_support::driveset()
        .env("DRIVESET_SIM_STATE_DIR", &state_dir)
        .arg("diff")
        .arg(&set)
        .args(["--port", "sim://mc6000?addresses=1", "--address", "1"])
        .output()
        .expect("diff");
    let (rate, canonical) = state(&state_dir);
    (
        up_err,
        rec_out,
        diff.status.code(),
        code_line(&canonical, "81").to_string(),
        code_line(&canonical, "428").to_string(),
        rate,
    )
}

/// Issue 17: the cable goes right after 81-SBAUD = 57600 reached the
/// drive. Recover writes the drive's own 9600 back into 81 and reads it
/// back before it says "rolled back"; nothing of the set was written.
#[test]
fn cable_right_after_sbaud_57600_then_recover_leaves_81_at_the_own_rate() {
    let (_, rec, diff, sbaud, _, rate) = cut_then_recover("cable@5+600s");
    assert!(
        rec.contains(
            "journal was planned; rolled back: the drive holds its old values again (verified)"
        ),
        "{rec}"
    );
    assert!(
        rec.contains(
            "line rate: found at 9600 baud; the drive runs at 9600 baud again; 81-SBAUD = 9600\n"
        ),
        "{rec}"
    );
    assert_eq!(sbaud, "81 9600");
    assert_eq!(
        rate,
        serde_json::Value::Null,
        "the drive runs at the line's 9600"
    );
    assert_eq!(diff, Some(1), "the set was not written");
}

/// Issue 17: the cable goes during the switch back (81 = 9600 written on
/// the way): the upload does not exit 0; recover finds the drive, judges
/// 81 by the value the journal says it keeps, completes, and writes the
/// set's 19200 into 81 (read back); `diff` then finds nothing.
#[test]
fn cable_during_the_switch_back_then_recover_completes_with_the_sets_81() {
    for at in ["432", "433"] {
        let (_, rec, diff, sbaud, _, rate) = cut_then_recover(&format!("cable@{at}+600s"));
        assert!(
            rec.contains("journal was complete; completed: the drive holds the new set (verified)"),
            "{at}: {rec}"
        );
        assert!(rec.contains("the drive runs at 9600 baud again; 81-SBAUD holds 19200 (not active: in effect after the drive's next restart)\n"), "{at}: {rec}");
        assert_eq!(sbaud, "81 19200", "{at}");
        assert_eq!(rate, 9600, "{at}");
        assert_eq!(diff, Some(0), "{at}");
    }
}

/// Issue 17: a power cycle during the switch back loses 428-RSIO (RAM):
/// the upload does not exit 0 (it used to say "complete"); recover rolls
/// back to the old set and leaves 81 at the drive's own 9600.
#[test]
fn power_cycle_during_the_switch_back_never_exits_0_and_recover_settles() {
    let (up, rec, diff, sbaud, rsio, _) = cut_then_recover("power-cycle@432:off=200ms");
    assert!(!up.contains("complete"), "{up}");
    assert!(
        rec.contains(
            "journal was complete; rolled back: the drive holds its old values again (verified)"
        ),
        "{rec}"
    );
    assert!(
        rec.contains(
            "line rate: found at 9600 baud; the drive runs at 9600 baud again; 81-SBAUD = 9600\n"
        ),
        "{rec}"
    );
    assert_eq!((sbaud.as_str(), rsio.as_str()), ("81 9600", "428 0"));
    assert_eq!(diff, Some(1));
}

/// kill -9 of a `--transfer-baud 57600` upload over a real pty once the
/// host's port went to 57600 (the simulator's log says so): the drive is
/// left at 57600. `driveset recover` through the port at 9600 finds it
/// there (the simulated drive hears garbage at 9600, as a real one would),
/// settles the transaction and switches it back; the simulator's dump
/// then shows the drive at 9600 with 81 = its own or the set's rate.
#[test]
fn upload_killed_at_57600_over_a_pty_then_recover_switches_the_drive_back() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut sim, log, port) = logged_sim(dir.path());
    let journal = dir.path().join("j.json");
    let mut up = std::process::Command::new(driveset_test_support::driveset_bin())
        .current_dir(driveset_test_support::workspace_root())
        .args([
            "upload",
            SET,
            "--port",
            &port,
            "--address",
            "1",
            "--transfer-baud",
            "57600",
            "--journal",
        ])
        .arg(&journal)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start the upload");
    let give_up = std::time::Instant::now() + std::time::Duration::from_secs(120);
    loop {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        // a few telegrams into the transaction at 57600
        let at_rate = text
            .lines()
            .position(|l| l.contains("the host's port runs at 57600 baud"));
        if at_rate.is_some_and(|i| text.lines().count() > i + 40) {
            break;
        }
        assert!(
            up.try_wait().expect("wait").is_none(),
            "the upload ended before it was killed: {}",
            sim.stderr()
        );
        assert!(
            std::time::Instant::now() < give_up,
            "the upload never reached 57600: {}",
            sim.stderr()
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    up.kill().expect("kill -9");
    up.wait().expect("reap");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).expect("journal")).expect("JSON");
    assert_eq!(j["transfer"]["state"], "at-transfer-rate", "{j}");
    // a host at 9600 gets no answer from the drive at 57600
    let (code, out, err) = run(&[
        "identify",
        "--port",
        &port,
        "--address",
        "1",
        "--family",
        "mc6000",
    ]);
    assert!(
        code != Some(0) || out.contains("57600"),
        "identify at 9600 must not find the drive at 9600: {out}{err}"
    );
    // the set names its schema by path; the journal records only its id
    // (recording the path is another part of issue 17)
    let schema = driveset_test_support::workspace_root()
        .join("parameter-sets/fixtures/fictional-mc6000-demo.toml");
    let (code, out, err) = run(&[
        "recover",
        &journal.to_string_lossy(),
        "--port",
        &port,
        "--schema",
        &schema.to_string_lossy(),
    ]);
    assert_eq!(code, Some(0), "{out}{err}\n--- sim\n{}", sim.stderr());
    assert!(
        out.contains("line rate: found at 57600 baud; the drive runs at 9600 baud again; 81-SBAUD"),
        "{out}"
    );
    let (code, out, err) = run(&["diff", SET, "--port", &port, "--address", "1"]);
    assert!(
        matches!(code, Some(0 | 1)),
        "the drive answers at 9600: {out}{err}"
    );
    assert!(sim.terminate().success(), "{}", sim.stderr());
    let d = dump(dir.path());
    let sbaud = sbaud(&d);
    assert!(sbaud == "9600" || sbaud == "19200", "{sbaud}");
    let rate = &d["drives"][0]["rate"];
    assert!(rate.is_null() || *rate == 9600, "{d}");
}
