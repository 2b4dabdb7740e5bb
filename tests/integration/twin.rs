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

use crate::util::{driveset, workspace_root};

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

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
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
