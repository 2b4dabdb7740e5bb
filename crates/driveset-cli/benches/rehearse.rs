//! The 100-drive rehearsal from twins, through the built `driveset` binary
//! (`cargo bench -p driveset-cli --bench rehearse`): the line of the line
//! benchmark (`crates/driveset-engine/benches/support/line_sets.rs`: 25
//! MC6000 on LUSTBUS 19200, 25 VF1000 on LUSTBUS 9600, 25 Tmd on LECOM
//! 9600, 25 ECS on CAN 500 kbit/s) written out, its simulated drives
//! captured with `driveset twin capture-line`, then `driveset commission
//! --rehearse` against the twins (docs/twins.md), each timed in wall time.
//!
//! Every rehearsal must exit 0 with every drive verified (report.json) and
//! take the same bus time (virtual) each run; the benchmark exits 1
//! otherwise. Wall time is this benchmark's figure, and it depends on the
//! build and on the machine's load: only an optimized build is held to a
//! target, <= 5 s a rehearsal (the target docs/twins.md has given since
//! the rehearsal landed; issue 33's goal, < 2 s, is printed met or not
//! beside it: on a shared 2-core machine a release run measured 2.1-2.3 s,
//! so a 2 s gate would fail on load alone). A debug build (CI) runs one
//! rehearsal and checks everything but the wall time.
//!
//! The plant history's overhead (docs/history.md; target < 5 % added wall
//! time). A rehearsal is not recorded (it writes twins, not drives), so
//! recording is measured on the same 100 drives commissioned on their
//! simulated buses (`sim://`, in process, virtual time: the same work as a
//! rehearsal but for the twins): `driveset commission` recording into the
//! default SQLite store against `--history off`, the two interleaved
//! (optimized build: 5 pairs; debug: 1) so a load on the machine falls on
//! both alike, each the fastest of its runs (a run's wall time is mostly
//! the journals' fsyncs, which a busy disk stretches: the fastest is the
//! least disturbed). Every recorded run must leave
//! its 102 records (session, 100 drives, end) on an intact chain (after
//! the capture's 102: `twin capture-line` is recorded too). The
//! target is gated in an optimized build only, as every wall time here.

#[path = "../../driveset-engine/benches/support/line_sets.rs"]
mod line_sets;

use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// Wall-time target of one rehearsal, optimized build (module docs).
const TARGET_S: f64 = 5.0;
/// Issue 33's goal for one rehearsal, optimized build.
const GOAL_S: f64 = 2.0;
/// Recording's added wall time, at most (the history issue).
const HISTORY_TARGET_PCT: f64 = 5.0;

/// Run the built `driveset` in `dir`; its wall time (it must exit 0).
fn driveset(args: &[&str], dir: &Path) -> f64 {
    driveset_out(args, dir).0
}

/// Run the built `driveset` in `dir`: its wall time and stdout (it must
/// exit 0).
fn driveset_out(args: &[&str], dir: &Path) -> (f64, String) {
    let t = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_driveset"))
        .args(args)
        .current_dir(dir)
        .env_remove("DRIVESET_HISTORY")
        .output()
        .expect("driveset runs");
    let wall = t.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "driveset {}: {}\n{}\n{}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (wall, String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Recording's overhead (module docs): the fastest recorded and the
/// fastest unrecorded commission of the line, and what went wrong.
fn history_overhead(dir: &Path, manifest: &str, pairs: usize) -> (Vec<f64>, Vec<f64>, Vec<String>) {
    let (mut on, mut off, mut misses) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..pairs {
        for recorded in [false, true] {
            // each run starts without the journals of the runs before
            // (all complete): an in-process simulated bus's name carries
            // the process id, so every run leaves 100 journals of its own,
            // and a commission reads every journal of the directory for
            // each drive; kept, they would slow each run after the first
            let _ = std::fs::remove_dir_all(dir.join(".driveset/journal"));
            let out = format!("commission-{i}-{recorded}");
            let mut args = vec!["commission", manifest, "--report-dir", &out];
            if !recorded {
                args.extend(["--history", "off"]);
            }
            let wall = driveset(&args, dir);
            let (drives, verified, _) = report(&dir.join(&out));
            if drives != 100 || verified != 100 {
                misses.push(format!(
                    "commission {i}: {verified} of {drives} drives verified (100 expected)"
                ));
            }
            if recorded { &mut on } else { &mut off }.push(wall);
        }
    }
    // every recorded run on record (and the capture before them):
    // session, 100 drives, end; one chain
    let (_, verify) = driveset_out(&["history", "verify"], dir);
    let want = format!(
        "sqlite:.driveset/history.sqlite: {} records, chain intact;",
        (pairs + 1) * 102
    );
    if !verify.starts_with(&want) {
        misses.push(format!("history verify: {verify} (expected {want} ...)"));
    }
    (on, off, misses)
}

/// Drives, drives verified, and the line's bus time from a report.json.
fn report(dir: &Path) -> (usize, usize, String) {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("report.json parses");
    let drives = v["drives"].as_array().expect("drives");
    let verified = drives
        .iter()
        .filter(|d| d["result"].as_str() == Some("verified"))
        .count();
    let ms = v["buses"]
        .as_array()
        .expect("buses")
        .iter()
        .filter_map(|b| b["elapsed_ms"].as_f64())
        .fold(0.0, f64::max);
    (drives.len(), verified, format!("{:.1} s", ms / 1000.0))
}

fn main() {
    let optimized = !cfg!(debug_assertions);
    let runs = if optimized { 3 } else { 1 };
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path();
    let manifest = line_sets::write_line(dir, 25);
    let manifest = manifest.to_str().expect("utf-8 path");
    let capture = driveset(&["twin", "capture-line", manifest, "-o", "twins"], dir);
    let mut walls = Vec::new();
    let mut bus_times = Vec::new();
    let mut misses = Vec::new();
    for i in 0..runs {
        let out = format!("rehearsal-{i}");
        let wall = driveset(
            &[
                "commission",
                manifest,
                "--rehearse",
                "twins",
                "--report-dir",
                &out,
            ],
            dir,
        );
        let (drives, verified, bus) = report(&dir.join(&out));
        if drives != 100 || verified != 100 {
            misses.push(format!(
                "rehearsal {i}: {verified} of {drives} drives verified (100 expected)"
            ));
        }
        walls.push(wall);
        bus_times.push(bus);
    }
    bus_times.dedup();
    if bus_times.len() != 1 {
        misses.push(format!("the bus time differs between runs: {bus_times:?}"));
    }
    let build = if optimized { "release" } else { "debug" };
    let list = walls
        .iter()
        .map(|s| format!("{s:.2}"))
        .collect::<Vec<_>>()
        .join(" / ");
    let worst = walls.iter().copied().fold(0.0, f64::max);
    println!("| build | run | wall time | bus time (virtual) | target |");
    println!("| --- | --- | --- | --- | --- |");
    println!(
        "| {build} | `commission --rehearse` ({runs} run{}) | {list} s | {} | {} |",
        if runs == 1 { "" } else { "s" },
        bus_times.first().map_or("-", String::as_str),
        if optimized {
            format!(
                "<= {TARGET_S} s; goal < {GOAL_S} s {}",
                if worst < GOAL_S { "met" } else { "not met" }
            )
        } else {
            "not gated in a debug build".to_string()
        }
    );
    println!("| {build} | `twin capture-line` (100 drives) | {capture:.1} s | - | - |");
    if optimized && worst > TARGET_S {
        misses.push(format!("a rehearsal took {worst:.2} s > {TARGET_S} s"));
    }
    let pairs = if optimized { 5 } else { 1 };
    let (on, off, history_misses) = history_overhead(dir, manifest, pairs);
    misses.extend(history_misses);
    let fastest = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let (t_on, t_off) = (fastest(&on), fastest(&off));
    let pct = (t_on / t_off - 1.0) * 100.0;
    let list = |v: &[f64]| {
        v.iter()
            .map(|s| format!("{s:.2}"))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    println!();
    println!(
        "| build | run (100 drives, sim://, virtual time) | wall time | fastest | added by recording | target |"
    );
    println!("| --- | --- | --- | --- | --- | --- |");
    println!(
        "| {build} | `commission --history off` | {} s | {t_off:.2} s | - | - |",
        list(&off)
    );
    println!(
        "| {build} | `commission`, recorded (SQLite, 102 records a run) | {} s | {t_on:.2} s | {pct:+.1} % | {} |",
        list(&on),
        if optimized {
            format!("< {HISTORY_TARGET_PCT} %")
        } else {
            "not gated in a debug build".to_string()
        }
    );
    if optimized && pct >= HISTORY_TARGET_PCT {
        misses.push(format!(
            "recording added {pct:.1} % to the commission's wall time (>= {HISTORY_TARGET_PCT} %)"
        ));
    }
    if misses.is_empty() {
        println!("rehearse: all targets met");
    } else {
        println!("rehearse: TARGETS MISSED:\n{}", misses.join("\n"));
        std::process::exit(1);
    }
}
