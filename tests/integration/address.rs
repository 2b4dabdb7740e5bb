//! `driveset address` end to end through the binary: one lone drive per
//! family on `sim://` ports with `state=` (the simulator's state asserted
//! afterwards: the drive answers at N and its 82 / C0009 holds N), over a
//! pty (`driveset sim --pty`, real time; timeouts are hang guards only),
//! the refusals (exit 2, nothing written: the state file or the
//! simulator's event log shows no SELECT / SEND), `--dry-run`, and a cut
//! `--baud` change finished by `driveset recover`.

use std::path::Path;

use serde_json::Value;

use crate::e2e_pty::{Sim, one_at_a_time, run};
use driveset_test_support::driveset;

/// The state file's drives as (address, canonical text).
fn drives(state: &Path) -> Vec<(u64, String)> {
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(state).expect("state file")).expect("json");
    v["drives"]
        .as_array()
        .expect("drives")
        .iter()
        .map(|d| {
            (
                d["address"].as_u64().expect("address"),
                d["canonical"].as_str().expect("canonical").to_string(),
            )
        })
        .collect()
}

/// The canonical line of `code` (`82 5`).
fn line<'a>(canonical: &'a str, code: &str) -> &'a str {
    canonical
        .lines()
        .find(|l| l.split(' ').next() == Some(code))
        .unwrap_or_else(|| panic!("no {code} in\n{canonical}"))
}

/// Run `driveset address ARGS` in `dir`: (exit code, stdout, stderr).
fn address(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = driveset()
        .current_dir(dir)
        .arg("address")
        .args(args)
        .output()
        .expect("run");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_lone_mc6000_gets_address_5() {
    let dir = tempfile::tempdir().expect("dir");
    let state = dir.path().join("s.json");
    let port = format!("sim://mc6000?addresses=1&state={}", state.display());
    let (code, out, err) = address(
        dir.path(),
        &["--port", &port, "--protocol", "lustbus", "--to", "5"],
    );
    assert_eq!(code, 0, "{err}");
    let name = format!("sim://mc6000?addresses=1&state={}", state.display());
    let journal = std::fs::read_dir(dir.path().join(".driveset/journal"))
        .expect("journal dir")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "json"))
        .expect("journal");
    let jname = journal
        .file_name()
        .expect("name")
        .to_string_lossy()
        .to_string();
    assert!(jname.ends_with("-5.journal.json"), "{jname}");
    assert_eq!(
        out,
        format!(
            "{name}: found a Lust MASTERCONTROL MC6000/7000 at address 0 at 9600 baud (91-TYPE = 6000), own address 1\n\
             network list 1..30 (2586 ms): address 1: 91-TYPE = 6000\n\
             wrote 82-SADDR = 5 at address 0\n\
             verified address 5: 82-SADDR = 5, 91-TYPE = 6000\n\
             verified nothing answers at the old address 1\n\
             done: Lust MASTERCONTROL MC6000/7000 (mc6000, 91-TYPE 6000) at address 5, 9600 baud (3220 ms)\n\
             journal: .driveset/journal/{jname}\n"
        )
    );
    let d = drives(&state);
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].0, 5);
    assert_eq!(line(&d[0].1, "82"), "82 5");
    // it answers at 5 (the state loads into a drive at 5)
    let scan = driveset()
        .args([
            "scan",
            "--port",
            &format!("sim://mc6000?addresses=5&state={}", state.display()),
            "--protocol",
            "lustbus",
        ])
        .output()
        .expect("scan");
    assert_eq!(scan.status.code(), Some(0));
    assert!(
        String::from_utf8_lossy(&scan.stdout)
            .contains("address 5: 91-TYPE = 6000\n1 drive found\n")
    );
    // the journal is complete
    let j: Value =
        serde_json::from_str(&std::fs::read_to_string(journal).expect("read")).expect("json");
    assert_eq!(j["state"], "complete");
    assert_eq!(j["assign"]["step"], "done");
    assert_eq!(j["assign"]["to"], 5);
    assert_eq!(j["target"]["address"], 5);
}

#[test]
fn vf1000_and_tmd_lone_drives_with_baud() {
    let dir = tempfile::tempdir().expect("dir");
    let state = dir.path().join("vf.json");
    let port = format!("sim://vf1000?addresses=1&state={}", state.display());
    let (code, out, err) = address(
        dir.path(),
        &[
            "--port",
            &port,
            "--protocol",
            "lustbus",
            "--to",
            "9",
            "--baud",
            "4800",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("found a Lust SMARTDRIVE VF1000 at address 0 at 9600 baud"),
        "{out}"
    );
    assert!(
        out.contains("wrote 82-SIOA = 9 at address 0\nwrote 81-SIOC = 4800 Baud at address 9\n"),
        "{out}"
    );
    assert!(out.contains("note: the Lust SMARTDRIVE VF1000 takes the new rate 4800 baud at its next restart (lustbus-protocol.txt §11.5: only a servocontroller activates a rate online); until then it answers at 9600 baud\n"), "{out}");
    let d = drives(&state);
    assert_eq!(
        (d[0].0, line(&d[0].1, "82"), line(&d[0].1, "81")),
        (9, "82 9", "81 4800")
    );

    let state = dir.path().join("tmd.json");
    let port = format!("sim://tmd?addresses=1&c0001=3&state={}", state.display());
    let (code, out, err) = address(
        dir.path(),
        &[
            "--port",
            &port,
            "--protocol",
            "lecom",
            "--to",
            "12",
            "--baud",
            "2400",
            "--format",
            "json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["family"], "tmd");
    assert_eq!(v["address"], 12);
    assert_eq!(v["found_at"]["address"], 1);
    assert_eq!(
        v["written"],
        serde_json::json!([
            "C0009 network_address = 12 at address 1",
            "C0125 lecom_baud_rate = \"2400 bps (9600,8,E,1 if C01 = 8...11)\" at address 12"
        ])
    );
    let d = drives(&state);
    assert_eq!(
        (d[0].0, line(&d[0].1, "C0009"), line(&d[0].1, "C0125")),
        (12, "C0009 120000", "C0125 20000")
    );
}

#[test]
fn dry_run_prints_the_telegrams_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("dir");
    let state = dir.path().join("s.json");
    let port = format!("sim://mc6000?addresses=1&state={}", state.display());
    // a first command creates the state file
    let (code, _, err) = address(
        dir.path(),
        &["--port", &port, "--protocol", "lustbus", "--to", "1"],
    );
    assert_eq!(code, 0, "{err}");
    let before = std::fs::read_to_string(&state).expect("state");
    let (code, out, err) = address(
        dir.path(),
        &[
            "--port",
            &port,
            "--protocol",
            "lustbus",
            "--to",
            "5",
            "--baud",
            "38400",
            "--dry-run",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.ends_with(
            "would write (dry run: nothing was written):\n  \
             LUSTBUS SELECT to address 0 (@), CODE 00082: 82-SADDR = 5 at 9600 baud\n  \
             LUSTBUS SELECT to address 5, CODE 00081: 81-SBAUD = 38400 at 9600 baud\n  \
             LUSTBUS SELECT to address 5, CODE 20004: 4-PROG = \"Activate new baud rate\" at 9600 baud\n"
        ),
        "{out}"
    );
    let after = std::fs::read_to_string(&state).expect("state");
    let canon = |s: &str| {
        let v: Value = serde_json::from_str(s).expect("json");
        v["drives"][0]["canonical"].as_str().expect("c").to_string()
    };
    assert_eq!(canon(&before), canon(&after));
    assert_eq!(line(&canon(&after), "82"), "82 1");
    let journals = std::fs::read_dir(dir.path().join(".driveset/journal"))
        .expect("journal dir")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "json"))
        })
        .count();
    assert_eq!(journals, 1, "the dry run made a journal");
}

/// The upload's advice when C0001 forbids LECOM writes (tests/integration/audit.rs).
const UPLOAD_ADVICE: &str = "the code cannot be written now: inhibit the controller (many codes are writable only at standstill), check the user password C0094, or set C0001 to 2 or 3 at the keypad so LECOM may program the drive (§4e)";

#[test]
fn refusals_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().expect("dir");
    let cases: [(&str, &[&str], String); 5] = [
        (
            "sim://mc6000?addresses=1,2",
            &["--protocol", "lustbus", "--to", "5"],
            "refused: the answers at address 0 at 9600 baud do not decode (device telegram BCC is 0x05 but CODE..ETX XOR to 0x41): more than one device answers (lustbus-protocol.txt §4.2: every device answers at address 0); the network list at 9600 baud finds address 1: 91-TYPE = 6000; address 2: 91-TYPE = 6000; nothing was written. Connect the drive alone and run again\n".into(),
        ),
        (
            "sim://tmd?addresses=1,12&c0001=3",
            &["--protocol", "lecom", "--to", "12"],
            "address 1: refused: address 12 is taken: another device answers there (address 12: C0093 = 0); nothing was written. No address may be assigned twice (lustbus-protocol.txt §4.2, lecom-ab-tmd-manual.txt §4c): pick a free address or disconnect that device\n".into(),
        ),
        (
            "sim://tmd?addresses=1",
            &["--protocol", "lecom", "--to", "12"],
            format!("address 1: refused: C0001 = \"Analog / Terminal / Keypad\": LECOM may read but not write (lecom-ab-tmd-manual.txt §4e, §4f); nothing was written; {UPLOAD_ADVICE}\n"),
        ),
        (
            "sim://mc6000?addresses=1",
            &["--protocol", "lustbus", "--to", "31"],
            "address 31: refused: --to 31: LUSTBUS address 0 is the group address and 31 the broadcast address; a drive needs its own address 1..30; nothing was sent. Give an address the rule allows\n".into(),
        ),
        (
            "sim://tmd?addresses=1&c0001=3",
            &["--protocol", "lecom", "--to", "20"],
            "address 20: refused: --to 20: LECOM 00 is the broadcast address and 10, 20, ... 90 are group addresses; a drive needs its own address 1..99 not ending in 0; nothing was sent. Give an address the rule allows\n".into(),
        ),
    ];
    for (i, (port, args, want)) in cases.iter().enumerate() {
        let state = dir.path().join(format!("s{i}.json"));
        let port = format!("{port}&state={}", state.display());
        // the drives' state before (a read-only scan creates the file)
        let (code, _, err) = address(
            dir.path(),
            &[&["--port", &port], *args, &["--dry-run"]].concat(),
        );
        assert_eq!(code, 2, "{port}: {err}");
        let before = std::fs::read_to_string(&state).unwrap_or_default();
        let (code, out, err) = address(dir.path(), &[&["--port", &port], *args].concat());
        assert_eq!(code, 2, "{port}: {out}{err}");
        assert!(out.is_empty(), "{out}");
        assert!(err.starts_with(&format!("error: {port}")), "{err}");
        assert!(
            err.ends_with(want.as_str()),
            "{port}:\n{err}\nwant ...{want}"
        );
        let after = std::fs::read_to_string(&state).unwrap_or_default();
        let v = |s: &str| -> Vec<String> {
            serde_json::from_str::<Value>(s).map_or_else(
                |_| Vec::new(),
                |v| {
                    v["drives"]
                        .as_array()
                        .into_iter()
                        .flatten()
                        .map(|d| d["canonical"].as_str().unwrap_or("").to_string())
                        .collect()
                },
            )
        };
        assert_eq!(v(&before), v(&after), "{port}: a drive changed");
        assert!(
            !dir.path().join(".driveset").exists(),
            "{port}: a journal was made"
        );
    }
}

/// Two MC6000s on one pty line (`driveset sim --address 1,2 --log`): the
/// collision at address 0 is refused and the log holds no host telegram
/// with an STX (every SELECT has one; the ENQUIRYs have none).
#[test]
fn two_drives_over_a_pty_refused_and_no_select_in_the_log() {
    let _guard = one_at_a_time();
    let dir = tempfile::tempdir().expect("dir");
    let log = dir.path().join("bus.jsonl");
    let log_arg = log.display().to_string();
    let mut sim = Sim::start(
        dir.path(),
        "mc6000",
        1,
        &["--address", "2", "--log", &log_arg],
    );
    let (code, out, err) = run(&[
        "address",
        "--port",
        &sim.path,
        "--protocol",
        "lustbus",
        "--to",
        "5",
    ]);
    assert_eq!(code, Some(2), "{out}{err}\n{}", sim.stderr());
    assert!(err.contains("more than one device answers"), "{err}");
    sim.terminate();
    let text = std::fs::read_to_string(&log).expect("log");
    let hosts: Vec<Value> = text
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|e| e["dir"] == "host")
        .collect();
    assert!(!hosts.is_empty());
    let selects: Vec<&Value> = hosts
        .iter()
        .filter(|e| e["text"].as_str().is_some_and(|t| t.contains("<STX>")))
        .collect();
    assert!(selects.is_empty(), "{selects:?}");
}

/// A lone Tmd over a pty (LECOM, real serial code), and a lone MC6000
/// with the schema given as a file (the built-in one does not type 82).
#[test]
fn lone_tmd_and_mc6000_over_a_pty() {
    let _guard = one_at_a_time();
    let dir = tempfile::tempdir().expect("dir");
    let mut sim = Sim::start(dir.path(), "tmd", 1, &["--c0001", "3"]);
    let (code, out, err) = run(&[
        "address",
        "--port",
        &sim.path,
        "--protocol",
        "lecom",
        "--to",
        "14",
        "--journal-dir",
        &dir.path().display().to_string(),
    ]);
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(
        out.contains("wrote C0009 network_address = 14 at address 1\n"),
        "{out}"
    );
    sim.terminate();
    let dump: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("tmd.dump.json")).expect("dump"),
    )
    .expect("json");
    assert_eq!(dump["drives"][0]["address"], 14);
    let c = dump["drives"][0]["canonical"].as_str().expect("canonical");
    assert_eq!(line(c, "C0009"), "C0009 140000");

    let mut sim = Sim::start(dir.path(), "mc6000", 1, &[]);
    let (code, out, err) = run(&[
        "address",
        "--port",
        &sim.path,
        "--protocol",
        "lustbus",
        "--to",
        "6",
        "--schema",
        "parameter-sets/fixtures/fictional-mc6000-demo.toml",
        "--journal-dir",
        &dir.path().display().to_string(),
    ]);
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(
        out.contains("verified address 6: 82-SADDR = 6, 91-TYPE = 6000\n"),
        "{out}"
    );
    sim.terminate();
    let dump: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("mc6000.dump.json")).expect("dump"),
    )
    .expect("json");
    assert_eq!(dump["drives"][0]["address"], 6);
    let c = dump["drives"][0]["canonical"].as_str().expect("canonical");
    assert_eq!(line(c, "82"), "82 6");
}

/// `--baud 38400` cut by a pulled cable after the address was written;
/// `driveset recover JOURNAL --port` (the drive's state now at address 5)
/// finds it and finishes: 82 = 5, 81 = 38400, answering at 38400.
#[test]
fn a_cut_baud_change_is_finished_by_recover() {
    let dir = tempfile::tempdir().expect("dir");
    let state = dir.path().join("s.json");
    let journal = dir.path().join("a.journal.json");
    let j = journal.display().to_string();
    let port = format!(
        "sim://mc6000?addresses=1&state={}&faults=cable@46+600s",
        state.display()
    );
    let (code, out, err) = address(
        dir.path(),
        &[
            "--port",
            &port,
            "--protocol",
            "lustbus",
            "--to",
            "5",
            "--baud",
            "38400",
            "--journal",
            &j,
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    assert!(
        err.contains(&format!("run `driveset recover {j}`")),
        "{err}"
    );
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).expect("journal")).expect("json");
    assert_eq!(v["state"], "failed");
    assert_eq!(v["assign"]["step"], "rate");
    assert_eq!(drives(&state)[0].0, 5);
    let out = driveset()
        .current_dir(dir.path())
        .args([
            "recover",
            &j,
            "--port",
            &format!("sim://mc6000?addresses=5&state={}", state.display()),
        ])
        .output()
        .expect("recover");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("completed: the drive answers at address 5 at 38400 baud"),
        "{stdout}"
    );
    let d = drives(&state);
    assert_eq!(
        (d[0].0, line(&d[0].1, "82"), line(&d[0].1, "81")),
        (5, "82 5", "81 38400")
    );
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(&journal).expect("journal")).expect("json");
    assert_eq!(v["state"], "complete");
    // a second recover: nothing to do
    let again = driveset()
        .current_dir(dir.path())
        .args(["recover", &j])
        .output()
        .expect("recover");
    assert_eq!(again.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&again.stdout).contains("already complete"));
}

/// A simulated MC6000 served on a pty by `driveset sim` whose motor runs
/// (416-SCTL1 = 1, as the machine's control started it): a first start
/// writes its `--state` file, the state is edited, the second start
/// serves it, its telegrams in `DIR/bus.jsonl`. `extra`: more `driveset
/// sim` arguments.
pub(crate) fn running_mc6000_on_a_pty(dir: &Path, extra: &[&str]) -> Sim {
    let state = dir.join("state.json");
    let state_arg = state.display().to_string();
    let mut args = vec!["--state", state_arg.as_str()];
    args.extend_from_slice(extra);
    let mut first = Sim::start(dir, "mc6000", 1, &args);
    assert!(first.terminate().success(), "{}", first.stderr());
    driveset_test_support::poke_state(&state, None, 416, 1, driveset_schema::CodeStyle::Lust);
    let log = dir.join("bus.jsonl");
    let log_arg = log.display().to_string();
    args.extend_from_slice(&["--log", log_arg.as_str()]);
    Sim::start(dir, "mc6000", 1, &args)
}

/// The host's SELECTs (what changes a drive, LUSTBUS §5.1) in the log.
pub(crate) fn selects_in_log(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("bus.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|e| e["dir"] == "host")
        .filter_map(|e| e["text"].as_str().map(str::to_string))
        .filter(|t| t.contains("<STX>"))
        .collect()
}

/// Issue 28: `address --baud 57600` on an MC6000 whose motor runs sent
/// 82-SADDR, 81-SBAUD and 4-PROG = 111. Refused before anything is sent
/// (exit 2), as upload refuses; `--allow-running` lifts exactly that.
#[test]
fn a_running_mc6000_over_a_pty_gets_no_address_rate_or_prog() {
    let _guard = one_at_a_time();
    let dir = tempfile::tempdir().expect("dir");
    let d = dir.path();
    let mut sim = running_mc6000_on_a_pty(d, &[]);
    let journal_dir = d.join("journal").display().to_string();
    let mut args = vec![
        "address",
        "--port",
        &sim.path,
        "--protocol",
        "lustbus",
        "--to",
        "5",
        "--baud",
        "57600",
        "--schema",
        "parameter-sets/fixtures/fictional-mc6000-demo.toml",
        "--journal-dir",
        &journal_dir,
    ];
    let (code, out, err) = run(&args);
    assert_eq!(code, Some(2), "{out}{err}\n{}", sim.stderr());
    assert_eq!(out, "");
    assert_eq!(
        err,
        format!(
            "error: {} address 0: refused: the drive reports a running motor; driveset changes a drive's bus address or line rate only at standstill: stop it (standstill), or pass --allow-running\n",
            sim.path
        )
    );
    // another override does not lift it
    args.push("--allow-running-unknown");
    let (code, _, err) = run(&args);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(selects_in_log(d), Vec::<String>::new());
    assert!(
        !d.join("journal").exists(),
        "no journal: nothing was to be written"
    );
    assert!(sim.terminate().success());
    let dump: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("mc6000.dump.json")).expect("dump"))
            .expect("json");
    assert_eq!(dump["drives"][0]["address"], 1);
    let c = dump["drives"][0]["canonical"].as_str().expect("canonical");
    assert_eq!(
        (line(c, "81"), line(c, "82"), line(c, "416")),
        ("81 9600", "82 1", "416 1")
    );
}
