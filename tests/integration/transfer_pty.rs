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

#[test]
fn upload_at_57600_over_a_pty_switches_and_comes_back_to_9600() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("bus.jsonl");
    let log_arg = log.to_string_lossy().into_owned();
    let mut sim = Sim::start(
        dir.path(),
        "mc6000",
        1,
        &["--baud", "9600", "--log", &log_arg],
    );
    let port = format!("{}?baud=9600", sim.path);
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
