//! End to end over a real pseudo terminal, in real time: `driveset sim`
//! serves a simulated drive on a pty, `driveset upload` downloads a set to
//! it through the serial port code (`SerialLink`, 7E1), `driveset diff
//! SET --port` reads it back, and after SIGTERM the simulator's `--dump`
//! holds exactly the set's values (same canonical lines, so the same
//! fingerprint as `driveset fingerprint SET`). LUSTBUS (MC6000, with the
//! SLOAD dataset download) and LECOM (Tmd).
//!
//! Timeouts are hang guards only; nothing here asserts how long anything
//! took.
#![cfg(unix)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use driveset_schema::{Registry, ResolvedSet, load_set};

use crate::util::{driveset, workspace_root};

/// Hang guard of one `driveset upload` / `diff` run.
const RUN_GUARD: Duration = Duration::from_secs(300);

/// Hang guard for the simulator to stop after SIGTERM.
const STOP_GUARD: Duration = Duration::from_secs(30);

/// A running `driveset sim --pty`; killed if the test fails first.
struct Sim {
    child: Child,
    /// The pty's slave path from the first stdout line.
    path: String,
    stderr: PathBuf,
}

impl Sim {
    fn start(dir: &Path, family: &str, address: u8, extra: &[&str]) -> Sim {
        let stderr = dir.join(format!("sim-{family}.stderr"));
        let mut child = Command::new(assert_cmd::cargo::cargo_bin("driveset"))
            .args(["sim", "--family", family, "--address"])
            .arg(address.to_string())
            .arg("--pty")
            .arg("--dump")
            .arg(dir.join(format!("{family}.dump.json")))
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&stderr).expect("sim stderr file"))
            .spawn()
            .expect("start driveset sim");
        let mut first = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut first)
            .expect("read the first line");
        let path = first
            .trim_end()
            .strip_prefix("pty ")
            .unwrap_or_else(|| {
                panic!(
                    "first line `{first}` is not `pty PATH`; stderr: {}",
                    std::fs::read_to_string(&stderr).unwrap_or_default()
                )
            })
            .to_string();
        Sim {
            child,
            path,
            stderr,
        }
    }

    fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// SIGTERM, then wait (bounded) for the exit.
    fn terminate(&mut self) -> ExitStatus {
        let status = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .expect("run kill");
        assert!(status.success());
        let give_up = Instant::now() + STOP_GUARD;
        loop {
            if let Some(s) = self.child.try_wait().expect("wait") {
                return s;
            }
            assert!(
                Instant::now() < give_up,
                "driveset sim did not stop within {STOP_GUARD:?} after SIGTERM"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Run `driveset ARGS` from the workspace root; (exit code, stdout, stderr).
fn run(args: &[&str]) -> (Option<i32>, String, String) {
    let out = driveset()
        .args(args)
        .timeout(RUN_GUARD)
        .output()
        .expect("run driveset");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn load(rel: &str) -> ResolvedSet {
    let mut registry = Registry::builtin().expect("built-in schemas");
    let loaded = load_set(&workspace_root().join(rel), &mut registry).expect("set loads");
    assert!(loaded.findings.is_empty(), "{:?}", loaded.findings);
    loaded.resolved.expect("resolved")
}

/// `driveset fingerprint SET`'s fingerprint.
fn fingerprint_cli(rel: &str) -> String {
    let (code, stdout, stderr) = run(&["fingerprint", rel]);
    assert_eq!(code, Some(0), "{stderr}");
    stdout
        .split_whitespace()
        .next()
        .expect("a fingerprint")
        .to_string()
}

/// The dump's canonical lines of the set's codes, as a canonical text of
/// the set's schema: equal to the set's canonical form exactly when the
/// drive holds every value of the set.
fn dump_subset(dump: &serde_json::Value, address: u8, set: &ResolvedSet) -> String {
    let drive = dump["drives"]
        .as_array()
        .expect("drives")
        .iter()
        .find(|d| d["address"] == address)
        .unwrap_or_else(|| panic!("no drive {address} in the dump: {dump}"));
    assert_eq!(drive["schema"], set.schema.as_str(), "{dump}");
    let canonical = drive["canonical"].as_str().expect("canonical");
    let mut out = format!("driveset-canonical 1\nschema {}\n", set.schema);
    for key in set.values.keys() {
        let code = key.canonical(set.code_style);
        let line = canonical
            .lines()
            .find(|l| l.split_once(' ').is_some_and(|(c, _)| c == code))
            .unwrap_or_else(|| panic!("{code} is not in the dump:\n{canonical}"));
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Upload `set_rel` to a simulated `family` drive at `address` over a pty,
/// diff it live, stop the simulator and compare its dump with the set.
/// `port_query` is appended to the pty path (`?baud=...`), `sim_args` go
/// to `driveset sim`. Returns the upload's stdout.
fn upload_over_pty(
    family: &str,
    address: u8,
    set_rel: &str,
    sim_args: &[&str],
    port_query: &str,
) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let set = load(set_rel);
    let fingerprint = fingerprint_cli(set_rel);
    assert_eq!(fingerprint, set.fingerprint());
    let mut sim = Sim::start(dir.path(), family, address, sim_args);
    let port = format!("{}{port_query}", sim.path);
    let addr = address.to_string();
    let journal_dir = dir.path().join("journal");
    let journal_dir_arg = journal_dir.to_string_lossy().into_owned();

    // upload
    let (code, stdout, stderr) = run(&[
        "upload",
        set_rel,
        "--port",
        &port,
        "--address",
        &addr,
        "--journal-dir",
        &journal_dir_arg,
    ]);
    let context = || {
        format!(
            "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- sim stderr\n{}",
            sim.stderr()
        )
    };
    assert_eq!(code, Some(0), "upload failed\n{}", context());
    let n = set.values.len();
    let head = stdout.lines().next().unwrap_or_default();
    assert!(
        head.starts_with(&format!("{} address {address}: complete (", sim.path)),
        "{}",
        context()
    );
    assert!(
        head.contains(&format!(" of {n} codes written, 1 attempt(s), ")),
        "{}",
        context()
    );
    assert!(
        stdout
            .lines()
            .any(|l| l == format!("after:  {fingerprint}")),
        "the drive holds the set's fingerprint\n{}",
        context()
    );
    assert!(!stdout.contains("FAILED"), "{}", context());
    // every written code verified
    let written: usize = head
        .split_once("complete (")
        .and_then(|(_, r)| r.split_once(' '))
        .and_then(|(w, _)| w.parse().ok())
        .expect("codes written");
    let verified = stdout.lines().filter(|l| l.ends_with("  verified")).count();
    assert_eq!(verified, written, "{}", context());
    // the journal says complete
    let journals: Vec<PathBuf> = std::fs::read_dir(&journal_dir)
        .expect("journal dir")
        .map(|e| e.expect("entry").path())
        .collect();
    assert_eq!(journals.len(), 1, "{journals:?}");
    let journal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journals[0]).expect("journal"))
            .expect("journal JSON");
    assert_eq!(journal["state"], "complete", "{journal}");

    // live diff: nothing differs
    let (code, diff_out, diff_err) = run(&["diff", set_rel, "--port", &port, "--address", &addr]);
    assert_eq!(
        code,
        Some(0),
        "diff\n--- stdout\n{diff_out}\n--- stderr\n{diff_err}\n--- sim stderr\n{}",
        sim.stderr()
    );
    assert!(diff_out.contains("no differences"), "{diff_out}");

    // stop the simulator; its dump holds the set
    let status = sim.terminate();
    assert!(status.success(), "{status}\n{}", sim.stderr());
    let dump_path = dir.path().join(format!("{family}.dump.json"));
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&dump_path).expect("dump written"))
            .expect("dump JSON");
    assert_eq!(dump["family"], family);
    assert_eq!(
        dump_subset(&dump, address, &set),
        set.canonical(),
        "the drive's values of the set's codes (so the fingerprint {fingerprint})"
    );
    stdout
}

#[test]
fn mc6000_upload_over_a_pty_lands_through_the_dataset_download() {
    let stdout = upload_over_pty(
        "mc6000",
        1,
        "tests/data/sets/e2e/mc6000-small.toml",
        &[],
        "",
    );
    // 9 CardWriteable codes go through the SLOAD dataset, 428-RSIO to RAM.
    assert!(
        stdout.lines().any(|l| l == "dataset: accepted (SLOAD = 0)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("address 1: complete (10 of 10 codes written"),
        "{stdout}"
    );
    for line in [
        "  100-PWMF: \"8 kHz\" -> \"16 kHz\"  verified",
        "  561-USR2: 0 -> -42  verified",
        "  428-RSIO: 0 1/min -> 132.25 1/min  verified",
    ] {
        assert!(stdout.lines().any(|l| l == line), "{line}\n{stdout}");
    }
}

#[test]
fn mc6000_full_axis_set_over_a_pty_at_57600_baud() {
    let stdout = upload_over_pty(
        "mc6000",
        1,
        "parameter-sets/mc6000/axis-1.toml",
        &["--baud", "57600"],
        "?baud=57600",
    );
    assert!(
        stdout.lines().any(|l| l == "dataset: accepted (SLOAD = 0)"),
        "{stdout}"
    );
}

#[test]
fn tmd_upload_over_a_pty_with_lecom() {
    let stdout = upload_over_pty("tmd", 13, "tests/data/sets/e2e/tmd-small.toml", &[], "");
    // C0089 already holds 50 Hz: read back, not written.
    assert!(
        stdout.contains("address 13: complete (5 of 6 codes written"),
        "{stdout}"
    );
    for line in [
        "  C0010 minimum_output_frequency: 0 Hz -> 5 Hz  verified",
        "  C0088 motor_rated_current: 0 A -> 8.2 A  verified",
    ] {
        assert!(stdout.lines().any(|l| l == line), "{line}\n{stdout}");
    }
    assert!(!stdout.contains("C0089"), "{stdout}");
}
