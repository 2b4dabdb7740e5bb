//! A rehearsal rehearses (issue 28): `commission MANIFEST --rehearse DIR`
//! with a missing or empty directory, or with no twin of any selected
//! drive, is an input error (exit 2, nothing run, the message says what to
//! capture); a selected drive without a twin makes the run exit 1 unless
//! `--allow-missing-twins` (the drives with a twin are rehearsed either
//! way). Through the built binary, from the demo line's manifest.

use std::path::Path;

use driveset_test_support::{driveset, outcome, sim_dir, workspace_root};

/// `commission DEMO --rehearse DIR [extra]` run in `d`: exit code, stdout,
/// stderr.
fn rehearse(d: &Path, dir: &str, extra: &[&str]) -> (Option<i32>, String, String) {
    let demo = workspace_root().join("parameter-sets/demo-line/line.toml");
    let mut c = driveset();
    c.current_dir(d)
        .args(["commission"])
        .arg(&demo)
        .args(["--rehearse", dir, "--report-dir", "rehearsal"])
        .args(extra);
    outcome(&mut c)
}

fn capture_hint(dir: &str) -> String {
    let demo = workspace_root().join("parameter-sets/demo-line/line.toml");
    format!(
        "capture the line's twins into it with `driveset twin capture-line {} -o {dir}`\n",
        demo.display()
    )
}

#[test]
fn a_rehearsal_against_a_missing_or_empty_directory_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (code, out, err) = rehearse(d, "no-such-dir/", &[]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert_eq!(
        err,
        format!(
            "error: --rehearse no-such-dir/: no such directory; {}",
            capture_hint("no-such-dir/")
        )
    );
    assert_eq!(out, "");
    assert!(!d.join("rehearsal").exists(), "nothing ran");

    std::fs::create_dir(d.join("empty")).unwrap();
    // a file that is not a twin does not count
    std::fs::write(d.join("empty/notes.txt"), "twins go here\n").unwrap();
    let (code, out, err) = rehearse(d, "empty", &[]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert_eq!(
        err,
        format!(
            "error: --rehearse empty: the directory holds no twin (*.twin.toml); {}",
            capture_hint("empty")
        )
    );

    std::fs::write(d.join("a-file"), "").unwrap();
    let (code, _, err) = rehearse(d, "a-file", &[]);
    assert_eq!(code, Some(2));
    assert!(
        err.starts_with("error: --rehearse a-file: is not a directory; "),
        "{err}"
    );
}

#[test]
fn a_rehearsal_without_a_twin_of_any_selected_drive_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::create_dir(d.join("twins")).unwrap();
    // a twin, but of no drive of the line
    std::fs::write(
        d.join("twins/stray.twin.toml"),
        "format = \"driveset-twin 2\"\n",
    )
    .unwrap();
    let (code, out, err) = rehearse(d, "twins", &["--only", "transfer"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert_eq!(
        err,
        format!(
            "error: --rehearse twins: no twin of any selected drive (looked for transfer-11.twin.toml, transfer-12.twin.toml, transfer-13.twin.toml); {}",
            capture_hint("twins")
        )
    );
    assert!(!d.join("rehearsal").exists(), "nothing ran");
}

/// The Tmd bus of the demo line captured (`--only transfer` keeps the
/// test short): one drive's twin removed, the rehearsal rehearses the
/// others and exits 1, or 0 with `--allow-missing-twins`.
#[test]
fn a_selected_drive_without_a_twin_fails_the_rehearsal_unless_allowed() {
    let tmp = sim_dir();
    let d = tmp.path();
    std::fs::create_dir_all(d.join("twins")).unwrap();
    for (name, address) in [("transfer-12", "12"), ("transfer-13", "13")] {
        let mut c = driveset();
        c.current_dir(d)
            .env("DRIVESET_SIM_STATE_DIR", d.join("sim"))
            .args([
                "twin",
                "capture",
                "--port",
                "sim://tmd?c0001=3",
                "--address",
            ])
            .arg(address)
            .arg("-o")
            .arg(format!("twins/{name}.twin.toml"));
        let (code, out, err) = outcome(&mut c);
        assert_eq!(code, Some(0), "{out}{err}");
    }
    // stderr without the progress lines (`[bus] i/n drive: result`)
    let said = |err: &str| -> String {
        err.lines()
            .filter(|l| !l.starts_with('['))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    let (code, out, err) = rehearse(d, "twins", &["--only", "transfer"]);
    assert_eq!(code, Some(1), "{out}{err}");
    assert_eq!(
        said(&err),
        "transfer-11: not rehearsed: no twin twins/transfer-11.twin.toml\n\
         error: not rehearsed (no twin): transfer-11; capture them (driveset twin capture-line), leave them out with --skip, or give --allow-missing-twins\n"
    );
    assert!(
        out.contains("; not rehearsed (no twin): transfer-11\n"),
        "{out}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("rehearsal/report.json")).unwrap())
            .unwrap();
    let results: Vec<(String, String)> = report["drives"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|x| x["bus"] == "transfer")
        .map(|x| {
            (
                x["name"].as_str().unwrap().to_string(),
                x["result"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(
        results,
        [
            ("transfer-11".to_string(), "not-selected".to_string()),
            ("transfer-12".to_string(), "verified".to_string()),
            ("transfer-13".to_string(), "verified".to_string()),
        ]
    );
    let (code, out, err) = rehearse(d, "twins", &["--only", "transfer", "--allow-missing-twins"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert_eq!(
        said(&err),
        "transfer-11: not rehearsed: no twin twins/transfer-11.twin.toml\n"
    );
    // skipping the drive is no missing twin
    let (code, out, err) = rehearse(d, "twins", &["--only", "transfer", "--skip", "transfer-11"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert_eq!(said(&err), "");
    // drives of the other buses are not selected: their missing twins do
    // not count (the label names no drive not rehearsed)
    let label = out.lines().next().unwrap();
    assert!(
        label.starts_with("REHEARSAL against the twins in twins (captured ")
            && label.ends_with(": transfer-12, transfer-13)"),
        "{out}"
    );
}
