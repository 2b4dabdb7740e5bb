//! Twins (issue 21): `driveset twin capture` from simulated drives of all
//! four families in several states (Tmd C0001 = 0 and 3, running drives,
//! every MC6000 description layout), then upload, dry run, diff and pull
//! (and `schema pull` on the MC) through the built binary against the
//! drive and against its twin side by side: the same exit codes, the same
//! plan, values and refusals (outputs equal once the port's name and the
//! measured times are masked). A recapture of an unchanged drive is
//! byte-identical; no twin holds a secret; the capture sends no write
//! telegram (the simulator's event log over TCP); a twin served by
//! `driveset sim --twin --tcp` answers a pull as in process; the demo line
//! rehearsed from captured twins; `commission --rehearse` reports drives
//! without a twin as not rehearsed.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use driveset_test_support::{
    Spawned, copy_dir, driveset, driveset_sim, send_signal, workspace_root,
};

/// One side of a comparison: a directory with its own copy of the sets,
/// its own simulator state and journals.
struct Side {
    dir: PathBuf,
    port: String,
}

impl Side {
    fn new(root: &Path, name: &str, port: &str) -> Side {
        let dir = root.join(name);
        copy_dir(
            &workspace_root().join("parameter-sets"),
            &dir.join("parameter-sets"),
        );
        std::fs::create_dir_all(dir.join("sim")).unwrap();
        Side {
            dir,
            port: port.to_string(),
        }
    }

    fn cmd(&self) -> assert_cmd::Command {
        let mut c = driveset();
        c.current_dir(&self.dir)
            .env("DRIVESET_SIM_STATE_DIR", self.dir.join("sim"));
        c
    }

    /// Run `args` (`PORT` replaced by the side's port): exit code, stdout
    /// and stderr with the port's names and the measured times masked.
    fn run(&self, args: &[&str]) -> (i32, String, String) {
        let args: Vec<String> = args
            .iter()
            .map(|a| {
                if *a == "PORT" {
                    self.port.clone()
                } else {
                    a.to_string()
                }
            })
            .collect();
        let out = self.cmd().args(&args).output().unwrap();
        (
            out.status.code().unwrap_or(-1),
            mask(&String::from_utf8_lossy(&out.stdout)),
            mask(&String::from_utf8_lossy(&out.stderr)),
        )
    }
}

/// The port's name (`sim://FAMILY?...` or `sim://twin?...`) as `PORT`, a
/// journal's file (named by the bus id and its state file) as `JOURNAL`, and
/// every measured time (`1.234 s`, `12.5 ms`) as `T`: a twin draws its
/// reaction times from the range the drive showed, so wall and bus times
/// differ, nothing else may.
fn mask(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let mut words: Vec<String> = Vec::new();
        let parts: Vec<&str> = line.split(' ').collect();
        for (i, w) in parts.iter().enumerate() {
            let next = parts.get(i + 1).copied().unwrap_or("");
            let next_unit = next.starts_with('s') || next.starts_with("ms");
            let core = w.trim_start_matches('(');
            let numeric = !core.is_empty()
                && core.chars().all(|c| c.is_ascii_digit() || c == '.')
                && core.contains('.');
            if w.contains(".journal.json") {
                // the journal is named by the bus id, which names the state file
                words.push("JOURNAL".into());
            } else if let Some(p) = w.find("sim://") {
                let end = w[p..].find([',', ')', ';']).map_or(w.len(), |e| p + e);
                words.push(format!("{}PORT{}", &w[..p], &w[end..]));
            } else if numeric && next_unit {
                words.push(format!("{}T", &w[..w.len() - core.len()]));
            } else {
                words.push(w.to_string());
            }
        }
        out.push_str(&words.join(" "));
        out.push('\n');
    }
    out
}

/// Capture the drive at `address` of `side` into `file` (exit 0).
fn capture(side: &Side, address: u8, file: &Path) -> String {
    let out = side
        .cmd()
        .args(["twin", "capture", "--port", &side.port, "--address"])
        .arg(address.to_string())
        .arg("-o")
        .arg(file)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read_to_string(file).unwrap()
}

/// The `[codes] secrets` of a twin's text, and its `[values]` keys.
fn secrets_and_values(text: &str) -> (Vec<String>, Vec<String>) {
    let t: toml::Table = toml::from_str(text).unwrap();
    let secrets = t["codes"]["secrets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    let values = t["values"].as_table().unwrap().keys().cloned().collect();
    (secrets, values)
}

struct Case {
    name: &'static str,
    port: &'static str,
    address: u8,
    set: &'static str,
    /// A code to poke into the drive's state before the capture (the
    /// running bit), as (family of the state file, code, raw).
    poke: Option<(&'static str, u32, i64)>,
    /// The exit code of the upload (the same on drive and twin).
    upload_exit: i32,
    /// The password codes the family's schema has (listed, never stored).
    secrets: &'static [&'static str],
    /// Also compare `schema pull` (MC description layouts).
    schema_pull: bool,
}

fn side_by_side(case: &Case) {
    let root = tempfile::tempdir().unwrap();
    let drive = Side::new(root.path(), "drive", case.port);
    let a = case.address.to_string();
    if let Some((family, code, raw)) = case.poke {
        // a first read-only run creates the drive's state; then start it
        drive.run(&["diff", case.set, "--port", "PORT", "--address", &a]);
        crate::safety::poke_state(&drive.dir, family, case.address, code, raw);
    }
    let file = root.path().join(format!("{}.twin.toml", case.name));
    let first = capture(&drive, case.address, &file);
    // a second capture of the unchanged drive: byte-identical
    assert_eq!(capture(&drive, case.address, &file), first, "{}", case.name);
    let (secrets, values) = secrets_and_values(&first);
    assert_eq!(secrets, case.secrets, "{}", case.name);
    for s in &secrets {
        assert!(!values.contains(s), "{}: secret {s} stored", case.name);
    }
    let twin = Side::new(
        root.path(),
        "twin",
        &format!("sim://twin?file={}", file.display()),
    );
    let mut steps: Vec<Vec<&str>> = vec![
        vec![
            "upload",
            case.set,
            "--port",
            "PORT",
            "--address",
            &a,
            "--dry-run",
        ],
        vec!["diff", case.set, "--port", "PORT", "--address", &a],
        vec![
            "pull",
            "--port",
            "PORT",
            "--address",
            &a,
            "-o",
            "pulled.toml",
        ],
    ];
    if case.schema_pull {
        steps.push(vec![
            "schema",
            "pull",
            "--port",
            "PORT",
            "--address",
            &a,
            "--params",
            "1-120",
            "-o",
            "learned.toml",
        ]);
    }
    let upload = steps.len();
    steps.push(vec!["upload", case.set, "--port", "PORT", "--address", &a]);
    if case.upload_exit == 0 {
        // the twin keeps what the upload wrote, as the drive does
        steps.push(vec!["diff", case.set, "--port", "PORT", "--address", &a]);
    }
    for (i, step) in steps.iter().enumerate() {
        let d = drive.run(step);
        let t = twin.run(step);
        assert_eq!(
            d,
            t,
            "{}: `{}` differs between drive and twin",
            case.name,
            step.join(" ")
        );
        if i == upload {
            assert_eq!(
                d.0, case.upload_exit,
                "{}: upload: {}{}",
                case.name, d.1, d.2
            );
        }
        if i == upload + 1 {
            assert_eq!(
                d.0, 0,
                "{}: the set holds after the upload: {}",
                case.name, d.1
            );
        }
    }
    for out in ["pulled.toml", "learned.toml"] {
        let read = |s: &Side| {
            std::fs::read_to_string(s.dir.join(out))
                .ok()
                .map(|t| mask(&t))
        };
        assert_eq!(read(&drive), read(&twin), "{}: {out}", case.name);
    }
    assert!(drive.dir.join("pulled.toml").is_file(), "{}", case.name);
}

#[test]
fn tmd_c0001_0_refuses_the_upload_on_twin_and_drive_alike() {
    side_by_side(&Case {
        name: "tmd-c0001-0",
        port: "sim://tmd",
        address: 4,
        set: "parameter-sets/tmd/conveyor-3.toml",
        poke: None,
        upload_exit: 3,
        secrets: &["94"],
        schema_pull: false,
    });
}

#[test]
fn tmd_c0001_3_uploads_on_twin_and_drive_alike() {
    side_by_side(&Case {
        name: "tmd-c0001-3",
        port: "sim://tmd?c0001=3",
        address: 4,
        set: "parameter-sets/tmd/conveyor-3.toml",
        poke: None,
        upload_exit: 0,
        secrets: &["94"],
        schema_pull: false,
    });
}

#[test]
fn a_running_vf1000_twin_refuses_as_the_drive() {
    side_by_side(&Case {
        name: "vf1000-running",
        port: "sim://vf1000",
        address: 1,
        set: "parameter-sets/vf1000/conveyor-1.toml",
        poke: Some(("vf1000", 3, 128)),
        upload_exit: 2,
        secrets: &["70"],
        schema_pull: false,
    });
}

#[test]
fn a_stopped_vf1000_twin_uploads_as_the_drive() {
    side_by_side(&Case {
        name: "vf1000",
        port: "sim://vf1000",
        // the set's 82-SIOA: no address change
        address: 4,
        set: "parameter-sets/vf1000/conveyor-1.toml",
        poke: None,
        upload_exit: 0,
        secrets: &["70"],
        schema_pull: false,
    });
}

#[test]
fn a_running_ecs_twin_refuses_as_the_drive() {
    side_by_side(&Case {
        name: "ecs-running",
        port: "sim://ecs",
        address: 1,
        set: "parameter-sets/ecs/axis-1.toml",
        poke: Some(("ecs", 150, 2)),
        upload_exit: 2,
        secrets: &[],
        schema_pull: false,
    });
}

#[test]
fn an_ecs_twin_uploads_as_the_drive() {
    side_by_side(&Case {
        name: "ecs",
        port: "sim://ecs",
        address: 1,
        set: "parameter-sets/ecs/axis-1.toml",
        poke: None,
        upload_exit: 0,
        secrets: &[],
        schema_pull: false,
    });
}

#[test]
fn mc6000_twins_describe_their_parameters_in_the_captured_layout() {
    for (name, port) in [
        ("mc-52", "sim://mc6000"),
        ("mc-43", "sim://mc6000?layout=43&types=table"),
        ("mc-42", "sim://mc6000?layout=42"),
        ("mc-34", "sim://mc6000?layout=34"),
    ] {
        side_by_side(&Case {
            name,
            port,
            address: 1,
            set: "parameter-sets/mc6000/axis-1.toml",
            poke: None,
            upload_exit: 0,
            secrets: &[],
            schema_pull: true,
        });
    }
}

fn report_at(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json written");
    serde_json::from_str(&text).expect("report.json parses")
}

/// Per drive: name, result, codes written, fingerprint after, error.
fn outcomes(r: &serde_json::Value) -> Vec<(String, String, u64, String, String)> {
    r["drives"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            (
                d["name"].as_str().unwrap().to_string(),
                d["result"].as_str().unwrap().to_string(),
                d["codes_written"].as_u64().unwrap(),
                d["fingerprint_after"].as_str().unwrap_or("-").to_string(),
                mask(d["error"].as_str().unwrap_or("")),
            )
        })
        .collect()
}

/// Capture every drive of `manifest` into `dir/twins`, rehearse the line
/// from them, then commission the (simulated) plant itself: the same
/// per-drive results, codes written, fingerprints, errors and exit code.
fn rehearse_then_commission(dir: &Path, manifest: &str, exit: i32) -> serde_json::Value {
    let side = Side {
        dir: dir.to_path_buf(),
        port: String::new(),
    };
    std::fs::create_dir_all(dir.join("sim")).unwrap();
    let out = side
        .cmd()
        .args(["twin", "capture-line", manifest, "-o", "twins"])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rehearsal = side
        .cmd()
        .args([
            "commission",
            manifest,
            "--rehearse",
            "twins",
            "--report-dir",
            "rehearsal",
        ])
        .output()
        .unwrap();
    let plant = side
        .cmd()
        .args(["commission", manifest, "--report-dir", "plant", "--fresh"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&rehearsal.stdout).to_string();
    assert_eq!(rehearsal.status.code(), Some(exit), "{stdout}");
    assert_eq!(
        plant.status.code(),
        Some(exit),
        "{}",
        String::from_utf8_lossy(&plant.stdout)
    );
    let r = report_at(&dir.join("rehearsal"));
    let p = report_at(&dir.join("plant"));
    assert_eq!(outcomes(&r), outcomes(&p));
    assert_eq!(r["command"], "rehearse");
    assert_eq!(p["command"], "commission");
    let date = std::fs::read_to_string(dir.join("twins/transfer-11.twin.toml"))
        .unwrap()
        .lines()
        .find_map(|l| {
            l.strip_prefix("captured = \"")
                .map(|d| d.trim_end_matches('"').to_string())
        })
        .unwrap();
    let label = r["label"].as_str().unwrap();
    assert!(
        label.starts_with(&format!(
            "REHEARSAL against the twins in twins (captured {date}: conveyor-5, conveyor-6,"
        )),
        "{label}"
    );
    assert!(stdout.contains(label), "{stdout}");
    let html = std::fs::read_to_string(dir.join("rehearsal/report.html")).unwrap();
    assert!(
        html.contains(": rehearsal report (against twins) of demo-line</title>"),
        "{html}"
    );
    r
}

#[test]
fn the_demo_line_rehearsed_from_its_twins_ends_as_its_commissioning() {
    let dir = tempfile::tempdir().unwrap();
    let demo = workspace_root().join("parameter-sets/demo-line/line.toml");
    rehearse_then_commission(dir.path(), demo.to_str().unwrap(), 0);
    let junit = std::fs::read_to_string(dir.path().join("rehearsal/report.junit.xml")).unwrap();
    let doc = roxmltree::Document::parse(&junit).unwrap();
    let root = doc.root_element();
    assert_eq!(root.attribute("tests"), Some("13"));
    assert_eq!(root.attribute("failures"), Some("0"));
    let cases: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("testcase"))
        .collect();
    assert_eq!(cases.len(), 13);
    assert_eq!(cases[0].attribute("name"), Some("press-axis-1"));
    assert_eq!(cases[0].attribute("classname"), Some("lustbus"));

    // a drive without a twin is not rehearsed; the others are
    std::fs::remove_file(dir.path().join("twins/conveyor-5.twin.toml")).unwrap();
    let out = driveset()
        .current_dir(dir.path())
        .args([
            "commission",
            demo.to_str().unwrap(),
            "--rehearse",
            "twins",
            "--report-dir",
            "again",
        ])
        .output()
        .unwrap();
    // a selected drive without a twin fails the run (issue 28)
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.starts_with("conveyor-5: not rehearsed: no twin twins/conveyor-5.twin.toml\n"),
        "{stderr}"
    );
    let r = report_at(&dir.path().join("again"));
    assert!(
        r["label"]
            .as_str()
            .unwrap()
            .ends_with("; not rehearsed (no twin): conveyor-5")
    );
    let results: Vec<_> = outcomes(&r).into_iter().map(|o| (o.0, o.1)).collect();
    assert_eq!(
        results[4],
        ("conveyor-5".to_string(), "not-selected".to_string())
    );
    assert_eq!(results.iter().filter(|r| r.1 == "verified").count(), 12);
    let junit = std::fs::read_to_string(dir.path().join("again/report.junit.xml")).unwrap();
    assert!(junit.contains(
        "<testcase classname=\"lustbus\" name=\"conveyor-5\" file=\"sets/conveyor-5.toml\">\n      <skipped message=\"not rehearsed: no twin\"/>"
    ), "{junit}");
}

#[test]
fn a_line_whose_tmds_were_left_at_c0001_0_fails_the_rehearsal_as_it_fails_on_site() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(
        &workspace_root().join("parameter-sets"),
        &dir.path().join("ps"),
    );
    let manifest = dir.path().join("ps/demo-line/line.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    assert!(text.contains("port = \"sim://tmd?c0001=3\""));
    // the keypad left C0001 at its factory 0: LECOM may only read (§4e)
    std::fs::write(&manifest, text.replace("sim://tmd?c0001=3", "sim://tmd")).unwrap();
    let r = rehearse_then_commission(dir.path(), manifest.to_str().unwrap(), 1);
    for d in r["drives"].as_array().unwrap() {
        let want = if d["bus"] == "transfer" {
            "rolled-back"
        } else {
            "verified"
        };
        assert_eq!(d["result"], want, "{d}");
    }
    let junit = std::fs::read_to_string(dir.path().join("rehearsal/report.junit.xml")).unwrap();
    assert!(junit.contains("failures=\"3\""), "{junit}");
    assert!(
        junit.contains("set C0001 to 2 or 3 at the keypad"),
        "{junit}"
    );
}

/// Host telegrams that carry a value (LUSTBUS SELECT, LECOM SEND: STX
/// after the address), as the simulator's event log shows them.
fn writes_in(log: &Path) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|l| l["dir"] == "host")
        .filter_map(|l| l["hex"].as_str().map(String::from))
        .filter(|hex| hex.split(' ').any(|b| b == "02"))
        .collect()
}

/// A `driveset sim` serving on TCP; killed when dropped.
struct Served(Spawned, String);

impl Served {
    fn start(args: &[&str]) -> Served {
        let mut child = driveset_sim(
            &[args, &["--tcp", "127.0.0.1:0"]].concat(),
            std::process::Stdio::null(),
        );
        let (line, _) = child.first_line();
        let addr = line
            .trim()
            .strip_prefix("tcp ")
            .unwrap_or_else(|| panic!("{line}"));
        Served(child, format!("tcp://{addr}"))
    }

    fn stop(mut self) {
        send_signal(self.0.id(), "-TERM");
        let _ = self.0.wait();
    }
}

#[test]
fn a_capture_over_tcp_sends_no_write_and_the_twin_serves_in_real_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = d.join("bus.jsonl");
    let sim = Served::start(&[
        "--family",
        "tmd",
        "--address",
        "4",
        "--c0001",
        "3",
        "--log",
        log.to_str().unwrap(),
    ]);
    let port = sim.1.clone();
    let twin = d.join("t.twin.toml");
    driveset()
        .args([
            "twin",
            "capture",
            "--port",
            &port,
            "--address",
            "4",
            "--schema",
            "lenze-tmd",
            "-o",
        ])
        .arg(&twin)
        .assert()
        .code(0);
    sim.stop();
    let host = std::fs::read_to_string(&log).unwrap();
    assert!(
        host.lines()
            .filter(|l| l.contains("\"dir\":\"host\""))
            .count()
            > 80,
        "{host}"
    );
    assert_eq!(writes_in(&log), Vec::<String>::new());
    let text = std::fs::read_to_string(&twin).unwrap();
    assert!(text.contains("\nc0001 = 3\n"), "{text}");
    assert!(
        text.contains("\nfamily = \"tmd\"\naddress = 4\nschema = \"lenze-tmd\"\n"),
        "{text}"
    );

    // the twin served in real time answers a pull as the twin in process
    let served = Served::start(&["--twin", twin.to_str().unwrap()]);
    let pull = |port: &str, out: &str| {
        driveset()
            .current_dir(d)
            .args([
                "pull",
                "--port",
                port,
                "--address",
                "4",
                "--schema",
                "lenze-tmd",
                "-o",
                out,
            ])
            .assert()
            .code(0);
        // the values (the header names the port)
        let t = std::fs::read_to_string(d.join(out)).unwrap();
        t.split_once("\n[values]\n").unwrap().1.to_string()
    };
    let real_time = pull(&served.1, "rt.toml");
    served.stop();
    let in_process = pull(&format!("sim://twin?file={}", twin.display()), "ip.toml");
    assert_eq!(real_time, in_process);
    assert!(real_time.contains("C0011 = \"50 Hz\""), "{real_time}");
}

#[test]
fn bad_twin_ports_and_files_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("bad.twin.toml"),
        "format = \"driveset-twin 1\"\nfamily = \"tmd\"\naddress = 20\n",
    )
    .unwrap();
    driveset()
        .current_dir(d)
        .args(["identify", "--port", "sim://twin?file=bad.twin.toml", "--address", "20"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "bad.twin.toml: address: tmd: address 20 is not allowed: LECOM station addresses are 1..=99 except the group addresses 10, 20, ... 90 (§4c)",
        ));
    driveset()
        .current_dir(d)
        .args(["identify", "--port", "sim://twin", "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "exactly one of file= (a twin) or dir= (a directory of twins)",
        ));
    driveset()
        .current_dir(d)
        .args(["identify", "--port", "sim://twin?dir=.", "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            "bad.twin.toml: address: tmd: address 20 is not allowed",
        ));
    std::fs::remove_file(d.join("bad.twin.toml")).unwrap();
    driveset()
        .current_dir(d)
        .args(["identify", "--port", "sim://twin?dir=.", "--address", "1"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains(
            ".: no *.twin.toml file in the directory; capture one with `driveset twin capture`",
        ));
}

/// The twins `examples/ci/` rehearses against are the demo line's drives
/// as captured: a recapture of the (factory) demo line keeps every file
/// byte-identical, whatever day it runs.
#[test]
fn the_committed_demo_line_twins_are_what_a_recapture_gives() {
    let dir = tempfile::tempdir().unwrap();
    let twins = dir.path().join("twins");
    copy_dir(&workspace_root().join("examples/ci/twins"), &twins);
    std::fs::create_dir_all(dir.path().join("sim")).unwrap();
    let demo = workspace_root().join("parameter-sets/demo-line/line.toml");
    let out = driveset()
        .current_dir(dir.path())
        .env("DRIVESET_SIM_STATE_DIR", dir.path().join("sim"))
        .args([
            "twin",
            "capture-line",
            demo.to_str().unwrap(),
            "-o",
            "twins",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        stdout
            .matches(", unchanged since the last capture (file kept); ")
            .count(),
        13,
        "{stdout}"
    );
    for e in std::fs::read_dir(workspace_root().join("examples/ci/twins")).unwrap() {
        let e = e.unwrap();
        assert_eq!(
            std::fs::read(e.path()).unwrap(),
            std::fs::read(twins.join(e.file_name())).unwrap(),
            "{}",
            e.path().display()
        );
    }
}

/// The bytes of a served session in the order they crossed the line,
/// from the simulator's event log (what a line sniffer would record).
fn session_bytes(log: &Path) -> Vec<u8> {
    let mut out = Vec::new();
    for l in std::fs::read_to_string(log).unwrap().lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        if v["dir"] == "host" || v["dir"] == "drive" {
            for b in v["hex"]
                .as_str()
                .unwrap()
                .split(' ')
                .filter(|b| !b.is_empty())
            {
                out.push(u8::from_str_radix(b, 16).unwrap());
            }
        }
    }
    out
}

/// The twin `twin from-capture` wrote (its output `out`: exit 0, the line
/// starting `heading`) at address 4 from `d/session.bin`.
fn session_twin(out: &std::process::Output, d: &Path, heading: &str) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.starts_with(heading), "{stdout}");
    let text = std::fs::read_to_string(d.join("twins/twin-4.twin.toml")).unwrap();
    assert!(
        text.contains("\nsource = \"capture session.bin\"\n"),
        "{text}"
    );
    text
}

/// A recorded session in `d/session.bin`: the sets copied to `d`, a drive
/// served with `sim_args` over TCP with an event log, the "vendor tool" (an
/// upload of `set`, exit 0, then `then` with the port) over the line.
fn record_session<T>(d: &Path, sim_args: &[&str], set: &str, then: impl FnOnce(&str) -> T) -> T {
    copy_dir(
        &workspace_root().join("parameter-sets"),
        &d.join("parameter-sets"),
    );
    let log = d.join("bus.jsonl");
    let mut args = sim_args.to_vec();
    args.extend(["--log", log.to_str().unwrap()]);
    let sim = Served::start(&args);
    driveset()
        .current_dir(d)
        .args(["upload", set, "--port", &sim.1, "--address", "4"])
        .assert()
        .code(0);
    let out = then(&sim.1);
    sim.stop();
    std::fs::write(d.join("session.bin"), session_bytes(&log)).unwrap();
    out
}

#[test]
fn a_twin_from_a_recorded_lecom_session_holds_what_the_session_showed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let set = "parameter-sets/tmd/conveyor-3.toml";
    record_session(
        d,
        &["--family", "tmd", "--address", "4", "--c0001", "3"],
        set,
        |_| (),
    );
    let out = driveset()
        .current_dir(d)
        .args([
            "twin",
            "from-capture",
            "--protocol",
            "lecom",
            "session.bin",
            "-o",
            "twins",
        ])
        .output()
        .unwrap();
    let text = session_twin(&out, d, "tmd lenze-tmd at address 4: ");
    // written by the session's SENDs (C0011 = 60 Hz, C0012 = 8 s)
    assert!(
        text.contains("\n\"11\" = 600000  # C0011 maximum_output_frequency = 60 Hz\n"),
        "{text}"
    );
    assert!(
        text.contains("\n\"12\" = 80000  # C0012 acceleration_time_1 = 8 s\n"),
        "{text}"
    );
    let t: toml::Table = toml::from_str(&text).unwrap();
    let unknown = t["codes"]["unknown"].as_array().unwrap();
    // the codes the upload neither read nor wrote
    assert!(unknown.iter().any(|u| u.as_str() == Some("37")), "{text}");
    assert!(!unknown.iter().any(|u| u.as_str() == Some("11")), "{text}");
    let (secrets, values) = secrets_and_values(&text);
    assert_eq!(secrets, ["94"]);
    assert!(!values.contains(&"94".to_string()));
    // the twin holds the set the session downloaded
    driveset()
        .current_dir(d)
        .args([
            "diff",
            set,
            "--port",
            "sim://twin?file=twins/twin-4.twin.toml",
            "--address",
            "4",
        ])
        .assert()
        .code(0);
}

/// An slcan session (a vendor tool's expedited SDO transfers with an ECS
/// at node 4: a read of C5001, a download of C5002, a read of C5003 the
/// drive aborts) becomes a twin holding what it showed: the values, the
/// refusal with its abort code, every other code unknown; the twin serves
/// them (`diff` exit 0, the refused code refused alike).
#[test]
fn a_twin_from_a_recorded_slcan_session_holds_what_the_session_showed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fixture = workspace_root().join("parameter-sets/fixtures/fictional-ecs-demo.toml");
    // C5001 = index 0x4C76, C5002 = 0x4C75, C5003 = 0x4C74 (24575 - code)
    let session = concat!(
        "t604840764C0000000000\r",
        "t584843764C0040A5AE02\r", // 4500 rpm = FIX32 45000000
        "t604823754C0040420F00\r", // 100 rpm = FIX32 1000000
        "t584860754C0000000000\r",
        "t604840744C0000000000\r",
        "t584880744C0000000206\r", // abort 0x06020000
    );
    std::fs::write(d.join("session.bin"), session).unwrap();
    let from = |schema: &str| {
        driveset()
            .current_dir(d)
            .args([
                "twin",
                "from-capture",
                "--protocol",
                "slcan",
                "--schema",
                schema,
            ])
            .args(["session.bin", "-o", "twins"])
            .output()
            .unwrap()
    };
    let wrong = from("lenze-tmd");
    assert_eq!(wrong.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&wrong.stderr),
        "error: --schema lenze-tmd: a tmd schema; a can session needs a schema of ecs\n"
    );
    let text = session_twin(
        &from(fixture.to_str().unwrap()),
        d,
        "ecs fictional-ecs-demo at address 4: 2 codes, 1 refused, ",
    );
    let t: toml::Table = toml::from_str(&text).unwrap();
    let values = t["values"].as_table().unwrap();
    assert_eq!(values["5001"].as_integer(), Some(45_000_000), "{text}");
    assert_eq!(values["5002"].as_integer(), Some(1_000_000), "{text}");
    assert_eq!(values.len(), 2, "{text}");
    assert!(
        text.contains("\n\"5003\" = { answer = \"SDO abort 0x06020000\", "),
        "{text}"
    );
    let unknown = t["codes"]["unknown"].as_array().unwrap();
    assert!(unknown.iter().any(|u| u.as_str() == Some("5004")), "{text}");
    std::fs::write(
        d.join("set.toml"),
        format!(
            "schema = \"{}\"\n[values]\nC5001 = \"4500 rpm\"\nC5002 = \"100 rpm\"\n",
            fixture.display()
        ),
    )
    .unwrap();
    let port = "sim://twin?file=twins/twin-4.twin.toml";
    driveset()
        .current_dir(d)
        .args(["diff", "set.toml", "--port", port, "--address", "4"])
        .assert()
        .code(0);
    std::fs::write(
        d.join("refused.toml"),
        format!(
            "schema = \"{}\"\n[values]\nC5003 = \"0.250 s\"\n",
            fixture.display()
        ),
    )
    .unwrap();
    driveset()
        .current_dir(d)
        .args(["diff", "refused.toml", "--port", port, "--address", "4"])
        .assert()
        .code(3)
        .stderr(predicate::str::contains("read C5003 refused: "));
}

/// A drive that refuses to read a code it holds (`refuse=`, the
/// simulator's way to hide a code) and its twin refuse it alike: the twin
/// records the wire answer in `[refused]`, and `diff` and `pull` against
/// drive and twin give the same output and exit code. A twin file of the
/// first version (the refusal as a reason string only) is served alike.
#[test]
fn a_twin_refuses_the_reads_its_drive_refused() {
    struct Refusing {
        name: &'static str,
        port: &'static str,
        address: u8,
        set: &'static str,
        line: &'static str,
        error: &'static str,
    }
    let cases = [
        Refusing {
            name: "tmd",
            port: "sim://tmd?c0001=3&refuse=12",
            address: 4,
            set: "parameter-sets/tmd/conveyor-3.toml",
            line: "\"12\" = { answer = \"EOT\", reason = \"no such code in this controller (STX C0012 EOT)\" }",
            error: "read C0012 refused: no such code in this controller (STX C0012 EOT)",
        },
        Refusing {
            name: "vf1000",
            port: "sim://vf1000?refuse=5",
            address: 4,
            set: "parameter-sets/vf1000/conveyor-1.toml",
            line: "\"5\" = { answer = \"NAK\", reason = \"no such parameter, or read-protected in the current operating state (NAK to ENQUIRY 00105)\" }",
            error: "read 5-FSSIO refused: no such parameter, or read-protected in the current operating state (NAK to ENQUIRY 00105)",
        },
        Refusing {
            name: "ecs",
            port: "sim://ecs?refuse=5001",
            address: 1,
            set: "parameter-sets/ecs/axis-1.toml",
            line: "\"5001\" = { answer = \"SDO abort 0x06010001\", reason = \"Attempt to read a write only object (SDO abort 0x06010001 at index 0x4C76 subindex 0)\" }",
            error: "read C5001 refused: Attempt to read a write only object (SDO abort 0x06010001 at index 0x4C76 subindex 0)",
        },
    ];
    for case in &cases {
        let root = tempfile::tempdir().unwrap();
        let drive = Side::new(root.path(), "drive", case.port);
        let a = case.address.to_string();
        let file = root.path().join(format!("{}.twin.toml", case.name));
        let text = capture(&drive, case.address, &file);
        assert!(
            text.contains(&format!("\n[refused]\n{}\n\n", case.line)),
            "{}: {text}",
            case.name
        );
        // the same twin as the first version of the format wrote it
        let old_file = root.path().join(format!("{}-v1.twin.toml", case.name));
        let reason = case.line.split("reason = ").nth(1).unwrap();
        let old_line = format!(
            "{} = {}",
            case.line.split(" = ").next().unwrap(),
            reason.strip_suffix(" }").unwrap()
        );
        std::fs::write(&old_file, text.replace(case.line, &old_line)).unwrap();
        let twins = [
            Side::new(
                root.path(),
                "twin",
                &format!("sim://twin?file={}", file.display()),
            ),
            Side::new(
                root.path(),
                "twin-v1",
                &format!("sim://twin?file={}", old_file.display()),
            ),
        ];
        let steps: [Vec<&str>; 2] = [
            vec!["diff", case.set, "--port", "PORT", "--address", &a],
            vec![
                "pull",
                "--port",
                "PORT",
                "--address",
                &a,
                "-o",
                "pulled.toml",
            ],
        ];
        for step in &steps {
            let d = drive.run(step);
            for twin in &twins {
                assert_eq!(
                    d,
                    twin.run(step),
                    "{}: `{}` differs between drive and twin",
                    case.name,
                    step.join(" ")
                );
            }
        }
        let (code, _, err) = drive.run(&steps[0]);
        assert_eq!(code, 3, "{}: {err}", case.name);
        assert_eq!(
            err.lines().filter(|l| l.contains(case.error)).count(),
            1,
            "{}: {err}",
            case.name
        );
    }
}

#[test]
fn a_twin_from_a_recorded_lustbus_session_holds_what_the_session_showed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let set = "parameter-sets/vf1000/conveyor-1.toml";
    let pull = ["pull", "--address", "4", "-o", "pulled.toml", "--port"];
    // a drive that refuses to read 12 (rotary_field_frequency); after the
    // upload the "vendor tool" reads every code
    let on_drive = record_session(
        d,
        &["--family", "vf1000", "--address", "4", "--refuse", "12"],
        set,
        |port| {
            driveset()
                .current_dir(d)
                .args(pull)
                .arg(port)
                .output()
                .unwrap()
        },
    );
    let from_capture = |schema: Option<&str>| {
        let mut c = driveset();
        c.current_dir(d)
            .args(["twin", "from-capture", "--protocol", "lustbus"]);
        if let Some(s) = schema {
            c.args(["--schema", s]);
        }
        c.args(["session.bin", "-o", "twins"]).output().unwrap()
    };
    // a LUSTBUS session does not name its family
    let out = from_capture(None);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        "error: twin from-capture --protocol lustbus: give the drives' schema with --schema (an MC6000/7000 or VF1000 schema id or file, e.g. lust-vf1000): a LUSTBUS session does not say which family it talks to\n"
    );
    let out = from_capture(Some("lenze-tmd"));
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        "error: --schema lenze-tmd: a tmd schema; a lustbus session needs a schema of mc6000 or vf1000\n"
    );
    let out = from_capture(Some("parameter-sets/fixtures/fictional-vf1000-demo.toml"));
    let text = session_twin(&out, d, "vf1000 fictional-vf1000-demo at address 4: ");
    // written by the session's SELECTs (5-FSSIO = 23.15 Hz, 0.05 Hz steps)
    assert!(text.contains("\n\"5\" = 463  # 5-FSSIO"), "{text}");
    // the ENQUIRY the drive answered with NAK
    assert!(
        text.contains("\n[refused]\n\"12\" = { answer = \"NAK\", reason = \"no such parameter, or read-protected in the current operating state (NAK to ENQUIRY 00112)\" }\n"),
        "{text}"
    );
    let t: toml::Table = toml::from_str(&text).unwrap();
    let unknown = t["codes"]["unknown"].as_array().unwrap();
    assert!(!unknown.iter().any(|u| u.as_str() == Some("5")), "{text}");
    assert!(!unknown.is_empty(), "{text}");
    let (secrets, values) = secrets_and_values(&text);
    assert_eq!(secrets, ["70"]);
    assert!(!values.contains(&"70".to_string()));
    // the twin holds the set the session downloaded
    std::fs::create_dir_all(d.join("state")).unwrap();
    driveset()
        .current_dir(d)
        .env("DRIVESET_SIM_STATE_DIR", d.join("state"))
        .args([
            "diff",
            set,
            "--port",
            "sim://twin?file=twins/twin-4.twin.toml",
            "--address",
            "4",
        ])
        .assert()
        .code(0);
    // and refuses the read the drive refused, as the drive did
    let on_twin = driveset()
        .current_dir(d)
        .env("DRIVESET_SIM_STATE_DIR", d.join("state"))
        .args(pull)
        .arg("sim://twin?file=twins/twin-4.twin.toml")
        .output()
        .unwrap();
    let refusal = "12-rotary_field_frequency could not be read: the drive refused to read it: no such parameter, or read-protected in the current operating state (NAK to ENQUIRY 00112)";
    for out in [&on_drive, &on_twin] {
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(refusal), "{err}");
    }
}

/// No value of the simulator's model fills a gap (issue 28): a twin
/// captured with a schema of two codes has those two codes only; a pull
/// from it with the schema the model is built from reads them and is
/// refused every other code as a node refuses an object it does not have
/// (SDO abort 0x06020000), exit 1, where the first version served the
/// model's factory values.
#[test]
fn a_twin_has_only_the_codes_its_capture_saw() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let side = Side::new(d, "side", "sim://ecs");
    let file = d.join("node.twin.toml");
    let out = side
        .cmd()
        .args(["twin", "capture", "--port", "sim://ecs", "--address", "1"])
        .args(["--schema", "lenze-ecs", "-o"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        format!(
            "ecs lenze-ecs at address 1: 2 codes, 0 refused, 0 secret(s) not stored; {} ({} bytes)\n",
            file.display(),
            std::fs::metadata(&file).unwrap().len()
        )
    );
    let fixture = workspace_root().join("parameter-sets/fixtures/fictional-ecs-demo.toml");
    let (code, out, err) = side.run(&[
        "pull",
        "--port",
        &format!("sim://twin?file={}", file.display()),
        "--address",
        "1",
        "--schema",
        fixture.to_str().unwrap(),
        "-o",
        "pulled.toml",
    ]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        err.contains("C5001 max_speed could not be read: the drive refused to read it: Object does not exist in the object dictionary (SDO abort 0x06020000 at index 0x4C76 subindex 0)"),
        "{err}"
    );
    let pulled = std::fs::read_to_string(side.dir.join("pulled.toml")).unwrap();
    let values = pulled.split_once("\n[values]\n").unwrap().1;
    assert_eq!(values, "C0150 = {}\n", "{pulled}");
}

/// A drive describes a parameter the simulator's table does not have
/// (a real MC6000's 96, say): its twin holds it as the drive described it,
/// and a pull that learns from the twin reads it, where the first version
/// refused the twin at open ("fictional-mc6000-demo has no parameter 96").
#[test]
fn a_twin_holds_a_parameter_only_its_drive_described() {
    let dir = tempfile::tempdir().unwrap();
    let side = Side::new(dir.path(), "side", "sim://mc6000");
    let file = dir.path().join("axis.twin.toml");
    let text = capture(&side, 1, &file);
    // the drive's own description of 96: its 1-MODE's, renamed
    let mode = text
        .lines()
        .find(|l| l.starts_with("\"1\" = \"MODE\\u0000\\u0000"))
        .unwrap()
        .to_string();
    let extra = mode.replace("\"1\" = \"MODE\\u0000\\u0000", "\"96\" = \"XTRA9\\u0000");
    let text = text.replace(&mode, &format!("{mode}\n{extra}")).replacen(
        "\n\n[refused]\n",
        "\n\"96\" = 2\n\n[refused]\n",
        1,
    );
    std::fs::write(&file, text).unwrap();
    // a side of its own: simulator state of the twin's bus apart from the
    // drive's
    let side = Side::new(dir.path(), "twin", "sim://twin");
    let (code, out, err) = side.run(&[
        "pull",
        "--port",
        &format!("sim://twin?file={}", file.display()),
        "--address",
        "1",
        "--schema",
        "lust-mc6000",
        "-o",
        "pulled.toml",
    ]);
    assert_eq!(code, 0, "{out}{err}");
    let pulled = std::fs::read_to_string(side.dir.join("pulled.toml")).unwrap();
    assert!(pulled.contains("\n96 = 2\n"), "{pulled}");
    let learned = driveset_test_support::toml_files_starting(&side.dir, "learned-mc6000-");
    let learned = std::fs::read_to_string(&learned[0]).unwrap();
    assert!(
        learned.contains("number = 96\nname = \"XTRA9\"\n"),
        "{learned}"
    );
}
