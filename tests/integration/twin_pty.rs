//! Twins that are the drive (issue 28), over real ptys in real time: a
//! drive served by `driveset sim --pty` (MC6000 in the 43-character
//! description layout with the table's type characters and descriptions
//! that contradict its behaviour, VF1000, Tmd, ECS over slcan; LUSTBUS
//! drives answering 91-TYPE 6000 / 1000) is captured with `twin capture`
//! as a user would (no schema: found and learned as `pull` finds it), the
//! twin served by `driveset sim --twin --pty`, and the same commands run
//! against both: identify, pull, a dry run and a diff of the pulled set, an
//! upload of an edited set and the diff after it. Exit codes, stdout and
//! stderr are equal once the port's name and measured times are masked,
//! and so are the pulled files. For the MC6000 the line too: `twin
//! capture-line` of a manifest whose set names the learned file `pull`
//! wrote, then `commission --rehearse` against the twin and `commission`
//! of the drive, both exit 0.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::time::Duration;

use driveset_test_support::{Spawned, driveset, driveset_sim, outcome, workspace_root};

/// A `driveset sim ... --pty` (killed when dropped) and its pty.
struct Served {
    child: Spawned,
    path: String,
}

impl Served {
    fn start(dir: &Path, name: &str, args: &[&str]) -> Served {
        let stderr = dir.join(format!("{name}.sim.stderr"));
        let mut all: Vec<&str> = args.to_vec();
        all.push("--pty");
        let mut child = driveset_sim(&all, std::fs::File::create(&stderr).unwrap().into());
        let (first, _) = child.first_line();
        let path = first
            .trim_end()
            .strip_prefix("pty ")
            .unwrap_or_else(|| {
                panic!(
                    "`{first}`: {}",
                    std::fs::read_to_string(&stderr).unwrap_or_default()
                )
            })
            .to_string();
        Served { child, path }
    }

    fn stop(mut self) {
        self.child.signal("-TERM", Duration::from_secs(30));
    }
}

/// `driveset ARGS` in `dir`, `PORT` replaced by `port`: exit code, stdout
/// and stderr with `port` as `PORT`, a journal's file (named by the bus id)
/// as `JOURNAL` and every measured time (`1.234 s`) as `T` (a twin draws
/// its reaction times from the range the drive showed).
fn run(dir: &Path, port: &str, args: &[&str]) -> (Option<i32>, String, String) {
    let args: Vec<&str> = args
        .iter()
        .map(|a| if *a == "PORT" { port } else { a })
        .collect();
    let mut c = driveset();
    c.current_dir(dir)
        .env_remove("DRIVESET_SIM_STATE_DIR")
        .args(&args);
    let (code, out, err) = outcome(&mut c);
    (code, mask(&out, port), mask(&err, port))
}

fn mask(text: &str, port: &str) -> String {
    // the port as given, and as reports name it (without its options)
    let text = text
        .replace(port, "PORT")
        .replace(port.split('?').next().unwrap_or(port), "PORT");
    let mut out = String::new();
    for line in text.lines() {
        // a reply the host's scheduler delayed past its answer timeout is
        // retried: real time, not the drive (counted in the summary)
        if line.starts_with("late replies: ") {
            continue;
        }
        let parts: Vec<&str> = line.split(' ').collect();
        let words: Vec<String> = parts
            .iter()
            .enumerate()
            .map(|(i, w)| {
                let next = parts.get(i + 1).copied().unwrap_or("");
                let core = w.trim_start_matches('(');
                let timed = (next.starts_with('s') || next.starts_with("ms"))
                    && core.contains('.')
                    && core.chars().all(|c| c.is_ascii_digit() || c == '.');
                let counted = matches!(next, "telegrams," | "retries," | "retries)")
                    && w.chars().all(|c| c.is_ascii_digit());
                if counted {
                    "N".to_string()
                } else if w.contains(".journal.json") {
                    // named by the bus id, the pty's path
                    "JOURNAL".to_string()
                } else if timed {
                    format!("{}T", &w[..w.len() - core.len()])
                } else {
                    (*w).to_string()
                }
            })
            .collect();
        out.push_str(&words.join(" "));
        out.push('\n');
    }
    out
}

/// A directory per side (`drive`, `twin`) where the commands run.
fn sides(root: &Path) -> (PathBuf, PathBuf) {
    let (a, b) = (root.join("drive"), root.join("twin"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    (a, b)
}

/// Run `steps` against the drive (in `dirs.0`) and the twin (in
/// `dirs.1`): every result equal; the drive's results.
fn same(
    dirs: &(PathBuf, PathBuf),
    drive: &str,
    twin: &str,
    steps: &[Vec<&str>],
) -> Vec<(Option<i32>, String, String)> {
    let mut all = Vec::new();
    for step in steps {
        let d = run(&dirs.0, drive, step);
        let t = run(&dirs.1, twin, step);
        assert_eq!(d, t, "`{}` differs between drive and twin", step.join(" "));
        all.push(d);
    }
    all
}

/// Capture the drive on `port` at `address` (no schema unless
/// `extra` gives one) into `file`; the twin's text.
fn capture(dir: &Path, port: &str, address: &str, extra: &[&str], file: &Path) -> String {
    let mut args = vec!["twin", "capture", "--port", "PORT", "--address", address];
    args.extend(extra);
    args.extend(["-o", file.to_str().unwrap()]);
    let (code, out, err) = run(dir, port, &args);
    assert_eq!(code, Some(0), "{out}{err}");
    std::fs::read_to_string(file).unwrap()
}

/// `text` with the value line of `code` in `[values]` (`CODE = ...`)
/// replaced by `line`.
fn edit(text: &str, code: &str, line: &str) -> String {
    let mut seen = false;
    let out: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with(&format!("{code} = ")) {
                seen = true;
                line.to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(seen, "no `{code} = ` in {text}");
    out.join("\n") + "\n"
}

/// A drive that answers 91-TYPE `type_value` (its simulator state poked
/// before it is served), served on a pty with `args`.
fn lustbus_drive(root: &Path, family: &str, args: &[&str], type_value: i64) -> Served {
    let state = root.join("sim").join(format!("sim-{family}.json"));
    std::fs::create_dir_all(root.join("sim")).unwrap();
    let mut all = args.to_vec();
    all.extend(["--state", state.to_str().unwrap()]);
    // a first start writes the drive's state on exit
    Served::start(root, family, &all).stop();
    crate::safety::poke_state(root, family, 1, 91, type_value);
    Served::start(root, family, &all)
}

#[test]
fn an_mc6000_twin_in_the_43_layout_is_the_drive_and_rehearses_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let drive = lustbus_drive(
        root,
        "mc6000",
        &[
            "--family",
            "mc6000",
            "--address",
            "1",
            "--layout",
            "43",
            "--types",
            "table",
            // descriptions that contradict the drive's behaviour
            "--describe",
            "100:min=1:max=3;134:unit=rpm",
            "--refuse",
            "102",
            "--baud",
            "57600",
        ],
        6000,
    );
    // at 57600 baud (fewer milliseconds per telegram: learning asks 999
    // descriptions)
    let drive = Served {
        path: format!("{}?baud=57600", drive.path),
        ..drive
    };
    let file = root.join("axis.twin.toml");
    let text = capture(root, &drive.path, "1", &[], &file);
    assert!(
        text.contains("\n\"91\" = 6000  # 91-TYPE = 6000\n"),
        "{text}"
    );
    assert!(
        text.contains("\n[identity]\n\"91-TYPE\" = \"6000\"\n"),
        "{text}"
    );
    assert!(
        text.contains("\nlayout = \"43\"\ntypes = \"table\"\n"),
        "{text}"
    );
    assert!(text.contains("\n[descriptions]\n"), "{text}");
    assert!(text.contains("\n\"102\" = { answer = \"NAK\", "), "{text}");
    assert!(text.contains("\n[timing]\nrate = 57600\n"), "{text}");
    let twin = Served::start(root, "twin", &["--twin", file.to_str().unwrap()]);
    let twin = Served {
        path: format!("{}?baud=57600", twin.path),
        ..twin
    };
    let dirs = sides(root);
    let a = "1";
    let results = same(
        &dirs,
        &drive.path,
        &twin.path,
        &[
            vec!["identify", "--port", "PORT", "--address", a],
            vec!["pull", "--port", "PORT", "--address", a, "-o", "axis.toml"],
        ],
    );
    assert!(
        results[0].1.contains("\n91-TYPE: 6000\n"),
        "{}",
        results[0].1
    );
    // pull reports the code the drive refused and exits 1, as on the drive
    assert_eq!(results[1].0, Some(1), "{}", results[1].2);
    let pulled = |d: &Path| {
        let text = std::fs::read_to_string(d.join("axis.toml")).unwrap();
        mask(
            &text,
            if d == dirs.0.as_path() {
                &drive.path
            } else {
                &twin.path
            },
        )
    };
    assert_eq!(pulled(&dirs.0), pulled(&dirs.1));
    let learned: Vec<String> = [&dirs.0, &dirs.1]
        .iter()
        .map(|d| {
            let f = driveset_test_support::toml_files_starting(d, "learned-mc6000-type6000-");
            assert_eq!(f.len(), 1, "{f:?}");
            std::fs::read_to_string(&f[0]).unwrap()
        })
        .collect();
    assert_eq!(
        mask(&learned[0], &drive.path),
        mask(&learned[1], &twin.path)
    );
    // an edited set: a dry run, a diff, the upload and a diff after it
    for d in [&dirs.0, &dirs.1] {
        let text = std::fs::read_to_string(d.join("axis.toml")).unwrap();
        std::fs::write(d.join("edited.toml"), edit(&text, "101", "101 = \"380 V\"")).unwrap();
    }
    let results = same(
        &dirs,
        &drive.path,
        &twin.path,
        &[
            vec!["diff", "axis.toml", "--port", "PORT", "--address", a],
            vec![
                "upload",
                "edited.toml",
                "--port",
                "PORT",
                "--address",
                a,
                "--dry-run",
            ],
            vec!["diff", "edited.toml", "--port", "PORT", "--address", a],
            vec!["upload", "edited.toml", "--port", "PORT", "--address", a],
            vec!["diff", "edited.toml", "--port", "PORT", "--address", a],
        ],
    );
    let codes: Vec<Option<i32>> = results.iter().map(|r| r.0).collect();
    assert_eq!(
        codes,
        [Some(0), Some(0), Some(1), Some(0), Some(0)],
        "{results:?}"
    );

    // the line: a manifest whose set names the learned file pull wrote
    for (d, port) in [(&dirs.0, &drive.path), (&dirs.1, &twin.path)] {
        let port = port.split('?').next().unwrap();
        std::fs::write(
            d.join("line.toml"),
            format!(
                "[line]\nname = \"press\"\n\n[[bus]]\nname = \"servo\"\nport = \"{port}\"\nprotocol = \"lustbus\"\nbaud = 57600\n\n[[drive]]\nname = \"axis\"\nbus = \"servo\"\naddress = 1\nset = \"edited.toml\"\n"
            ),
        )
        .unwrap();
    }
    let (code, out, err) = run(
        &dirs.0,
        &drive.path,
        &["twin", "capture-line", "line.toml", "-o", "twins"],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.starts_with("axis: mc6000 learned-mc6000-type6000-"),
        "{out}"
    );
    let (code, out, err) = run(
        &dirs.0,
        &drive.path,
        &[
            "commission",
            "line.toml",
            "--rehearse",
            "twins",
            "--report-dir",
            "rehearsal",
        ],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    let (code, out, err) = run(
        &dirs.0,
        &drive.path,
        &[
            "commission",
            "line.toml",
            "--report-dir",
            "plant",
            "--fresh",
        ],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    twin.stop();
    drive.stop();
}

/// The parity steps of a family whose set `set_of` makes from the pulled
/// file (`edited.toml`): pull, diff, dry run, upload, diff.
fn parity(
    root: &Path,
    drive: &Served,
    twin: &Served,
    a: &str,
    schema: &[&str],
    pull_exit: i32,
    edit_line: (&str, &str),
) {
    let dirs = sides(root);
    let mut pull = vec!["pull", "--port", "PORT", "--address", a, "-o", "set.toml"];
    pull.extend(schema);
    let results = same(&dirs, &drive.path, &twin.path, &[pull]);
    assert_eq!(results[0].0, Some(pull_exit), "{}", results[0].2);
    let read =
        |d: &Path, port: &str| mask(&std::fs::read_to_string(d.join("set.toml")).unwrap(), port);
    assert_eq!(read(&dirs.0, &drive.path), read(&dirs.1, &twin.path));
    for d in [&dirs.0, &dirs.1] {
        let text = std::fs::read_to_string(d.join("set.toml")).unwrap();
        std::fs::write(d.join("edited.toml"), edit(&text, edit_line.0, edit_line.1)).unwrap();
    }
    let results = same(
        &dirs,
        &drive.path,
        &twin.path,
        &[
            vec!["diff", "set.toml", "--port", "PORT", "--address", a],
            vec![
                "upload",
                "edited.toml",
                "--port",
                "PORT",
                "--address",
                a,
                "--dry-run",
            ],
            vec!["upload", "edited.toml", "--port", "PORT", "--address", a],
            vec!["diff", "edited.toml", "--port", "PORT", "--address", a],
        ],
    );
    let codes: Vec<Option<i32>> = results.iter().map(|r| r.0).collect();
    assert_eq!(codes, [Some(0), Some(0), Some(0), Some(0)], "{results:?}");
}

#[test]
fn a_vf1000_twin_is_the_drive_over_a_pty() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let drive = lustbus_drive(
        root,
        "vf1000",
        &[
            "--family",
            "vf1000",
            "--address",
            "1",
            "--describe",
            "11:actual:binary8",
        ],
        1000,
    );
    let file = root.join("conveyor.twin.toml");
    let text = capture(root, &drive.path, "1", &[], &file);
    assert!(
        text.contains("\n[identity]\n\"91-TYPE\" = \"1000\"\n"),
        "{text}"
    );
    let twin = Served::start(root, "twin", &["--twin", file.to_str().unwrap()]);
    let (code, out, _) = run(
        root,
        &twin.path,
        &["identify", "--port", "PORT", "--address", "1"],
    );
    assert_eq!(code, Some(0));
    assert!(out.contains("\n91-TYPE: 1000\n"), "{out}");
    parity(root, &drive, &twin, "1", &[], 0, ("5", "5 = \"12.5 Hz\""));
    twin.stop();
    drive.stop();
}

#[test]
fn a_tmd_twin_is_the_drive_over_a_pty() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let drive = Served::start(
        root,
        "tmd",
        &[
            "--family",
            "tmd",
            "--address",
            "4",
            "--c0001",
            "3",
            "--refuse",
            "37",
        ],
    );
    let file = root.join("conveyor.twin.toml");
    capture(root, &drive.path, "4", &[], &file);
    let twin = Served::start(root, "twin", &["--twin", file.to_str().unwrap()]);
    // the code the drive refused: pull exits 1 on both
    parity(
        root,
        &drive,
        &twin,
        "4",
        &[],
        1,
        ("C0011", "C0011 = \"60 Hz\""),
    );
    twin.stop();
    drive.stop();
}

#[test]
fn an_ecs_twin_is_the_drive_over_slcan() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let drive = Served::start(root, "ecs", &["--family", "ecs", "--address", "1"]);
    let drive = Served {
        path: format!("slcan://{}?bitrate=500000", drive.path),
        ..drive
    };
    // a node's protocol is not probed on CAN: the schema is given, as an
    // imported one would be
    let fixture = workspace_root().join("parameter-sets/fixtures/fictional-ecs-demo.toml");
    let schema = ["--schema", fixture.to_str().unwrap()];
    let file = root.join("handling.twin.toml");
    capture(root, &drive.path, "1", &schema, &file);
    let twin = Served::start(root, "twin", &["--twin", file.to_str().unwrap()]);
    let twin = Served {
        path: format!("slcan://{}?bitrate=500000", twin.path),
        ..twin
    };
    parity(
        root,
        &drive,
        &twin,
        "1",
        &schema,
        0,
        ("C5001", "C5001 = \"2500 rpm\""),
    );
    twin.stop();
    drive.stop();
}

/// `twin capture-line` captures every drive it reaches when one does not
/// answer: the failure is reported naming the drive, the others' twins are
/// written, and the run exits 3 (bus).
#[test]
fn capture_line_captures_the_other_drives_when_one_fails() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let drive = Served::start(
        root,
        "tmd",
        &["--family", "tmd", "--address", "4", "--c0001", "3"],
    );
    for f in ["conveyor-3.toml", "base.toml"] {
        std::fs::copy(
            workspace_root().join("parameter-sets/tmd").join(f),
            root.join(f),
        )
        .unwrap();
    }
    std::fs::write(
        root.join("line.toml"),
        format!(
            "[line]\nname = \"l\"\n\n[[bus]]\nname = \"b\"\nport = \"{}\"\nprotocol = \"lecom\"\nbaud = 9600\n\n[[drive]]\nname = \"gone\"\nbus = \"b\"\naddress = 5\nset = \"conveyor-3.toml\"\n\n[[drive]]\nname = \"here\"\nbus = \"b\"\naddress = 4\nset = \"conveyor-3.toml\"\n",
            drive.path
        ),
    )
    .unwrap();
    let (code, out, err) = run(
        root,
        &drive.path,
        &["twin", "capture-line", "line.toml", "-o", "twins"],
    );
    assert_eq!(code, Some(3), "{out}{err}");
    assert!(
        out.starts_with("here: tmd lenze-tmd at address 4: "),
        "{out}"
    );
    assert!(root.join("twins/here.twin.toml").is_file());
    assert!(!root.join("twins/gone.twin.toml").exists());
    let lines: Vec<&str> = err.lines().collect();
    assert!(lines[0].starts_with("error: gone (b address 5): "), "{err}");
    assert_eq!(
        lines.last(),
        Some(&"error: 1 of 2 drive(s) not captured: gone"),
        "{err}"
    );
    drive.stop();
}
