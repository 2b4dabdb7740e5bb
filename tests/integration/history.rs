//! The plant history (docs/history.md) through the built binary: two
//! commissions of the demo line by two operators with a value changed
//! between them, then `history log / blame / as-built / diff / verify`; a
//! row altered by hand caught by `verify`; no password in the store in
//! any form; a shared PostgreSQL store (a real server: a cluster of our
//! own in a temp dir on a unix socket, stopped after) refusing UPDATE and
//! DELETE, down (recorded locally, `history sync` forwards once), and eight
//! lines commissioning into it at once.

use std::path::{Path, PathBuf};
use std::process::Command;

use driveset_history::db::{Db, Postgres, Sqlite};
use driveset_test_support::{copy_dir, driveset_in, sim_dir, workspace_root};

/// The demo line copied into `dir/line` (its sets are edited by the tests).
fn demo_copy(dir: &Path) -> PathBuf {
    for sub in ["demo-line", "fixtures"] {
        copy_dir(
            &workspace_root().join("parameter-sets").join(sub),
            &dir.join("sets").join(sub),
        );
    }
    std::fs::create_dir_all(dir.join("sim")).unwrap();
    dir.join("sets/demo-line/line.toml")
}

fn run(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = driveset_in(dir)
        .env_remove("DRIVESET_HISTORY")
        .env_remove("DRIVESET_OPERATOR")
        .args(args)
        .output()
        .expect("driveset runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// Commission the demo line as `operator` with `label`; exit 0.
fn commission(dir: &Path, line: &str, operator: &str, label: &str, extra: &[&str]) {
    let mut args = vec![
        "commission",
        line,
        "--operator",
        operator,
        "--reason",
        "acceptance test",
        "--label",
        label,
    ];
    args.extend_from_slice(extra);
    let (code, out, err) = run(dir, &args);
    assert_eq!(code, 0, "{out}{err}");
}

#[test]
fn two_commissions_by_two_operators_then_log_blame_as_built_diff_and_verify() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let line = demo_copy(d);
    let line = line.to_str().unwrap();
    commission(d, line, "alice", "FAT", &[]);
    // between FAT and SAT the transfer conveyor 12 is slowed to 55 Hz
    let set = d.join("sets/demo-line/sets/transfer-12.toml");
    let text = std::fs::read_to_string(&set).unwrap();
    std::fs::write(
        &set,
        text.replace("C0011 = \"60.0 Hz\"", "C0011 = \"55.0 Hz\""),
    )
    .unwrap();
    commission(d, line, "bob", "SAT", &[]);

    // the log of the drive: both runs, who and why
    let (code, out, err) = run(
        d,
        &[
            "history",
            "log",
            "--drive",
            "transfer-12",
            "--format",
            "json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let rows = json(&out);
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2, "{out}");
    let who: Vec<(&str, &str, &str, i64)> = rows
        .iter()
        .map(|r| {
            (
                r["operator"].as_str().unwrap(),
                r["label"].as_str().unwrap(),
                r["result"].as_str().unwrap(),
                r["codes_written"].as_i64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        who,
        [
            ("alice", "FAT", "verified", 10),
            ("bob", "SAT", "verified", 1)
        ]
    );
    assert_eq!(rows[0]["line"], "demo-line");
    assert_eq!(rows[0]["bus"], "transfer");
    assert_eq!(rows[0]["address"], 12);
    assert_eq!(rows[0]["family"], "lecom");
    assert_eq!(rows[0]["command"], "commission");
    assert_eq!(rows[0]["reason"], "acceptance test");
    // the other drives were confirmed, not written, at SAT
    let (_, out, _) = run(d, &["history", "log", "--label", "SAT", "--format", "json"]);
    let sat = json(&out);
    let results: Vec<&str> = sat
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["result"].as_str().unwrap())
        .collect();
    assert_eq!(results.len(), 13);
    assert_eq!(
        results.iter().filter(|r| **r == "already-verified").count(),
        12
    );
    // --code: only the records that wrote it, with the change
    let (code, out, err) = run(
        d,
        &[
            "history",
            "log",
            "--line",
            "demo-line",
            "--code",
            "C0011",
            "--format",
            "csv",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    // header, transfer-12 at FAT (11 and 13 held 50 Hz already) and at SAT
    assert_eq!(lines.len(), 3, "{out}");
    assert!(lines[0].ends_with(",old,new"), "{out}");
    assert!(lines[1].contains(",alice,acceptance test,FAT,"), "{out}");
    assert!(lines[1].ends_with(",50 Hz,60 Hz"), "{out}");
    assert!(lines[2].contains(",bob,acceptance test,SAT,"), "{out}");
    assert!(lines[2].ends_with(",60 Hz,55 Hz"), "{out}");

    // blame: bob, from 60 to 55 Hz, why
    let (code, out, err) = run(d, &["history", "blame", "--drive", "transfer-12", "C0011"]);
    assert_eq!(code, 0, "{err}");
    let mut l = out.lines();
    assert_eq!(
        l.next(),
        Some("transfer-12 C0011: 60 Hz -> 55 Hz (read back 55 Hz)")
    );
    assert!(l.next().unwrap().starts_with("when:    20"), "{out}");
    assert!(
        l.next().unwrap().starts_with("by:      bob (OS user "),
        "{out}"
    );
    assert_eq!(l.next(), Some("reason:  acceptance test"));
    assert_eq!(l.next(), Some("label:   SAT"));
    let (code, _, err) = run(d, &["history", "blame", "--drive", "transfer-12", "C9999"]);
    assert_eq!(code, 2);
    assert_eq!(
        err,
        "error: history: no record of C9999 written on drive transfer-12\n"
    );

    // as built at FAT and at SAT
    let (code, out, err) = run(
        d,
        &[
            "history", "as-built", line, "--at", "FAT", "--format", "json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let fat = json(&out);
    assert_eq!(fat["drives"].as_array().unwrap().len(), 13);
    assert_eq!(fat["unknown"].as_array().unwrap().len(), 0);
    let t12 = &fat["drives"][8];
    assert_eq!(t12["drive"], "transfer-12");
    assert_eq!(t12["values"]["C0011"], "60 Hz");
    assert_eq!(t12["put_by"]["operator"], "alice");
    let (_, out, _) = run(
        d,
        &[
            "history", "as-built", line, "--at", "SAT", "--format", "json",
        ],
    );
    let sat = json(&out);
    assert_eq!(sat["drives"][8]["values"]["C0011"], "55 Hz");
    assert_eq!(sat["drives"][8]["put_by"]["operator"], "bob");
    // a drive SAT only confirmed was put there by alice at FAT
    assert_eq!(sat["drives"][0]["put_by"]["operator"], "alice");
    assert_eq!(
        sat["drives"][0]["fingerprint"],
        fat["drives"][0]["fingerprint"]
    );
    let (code, out, _) = run(
        d,
        &[
            "history", "as-built", line, "--at", "SAT", "--format", "html",
        ],
    );
    assert_eq!(code, 0);
    assert!(
        out.contains("<tr><td>C0011</td><td>55 Hz</td></tr>"),
        "{out}"
    );

    // FAT vs SAT: the one change
    let (code, out, err) = run(d, &["history", "diff", "--at", "FAT", "--at", "SAT", line]);
    assert_eq!(code, 1, "{err}");
    assert_eq!(
        out,
        "--- FAT\n+++ SAT\ntransfer-12 C0011: 60 Hz -> 55 Hz\n1 difference(s)\n"
    );

    // the chain: 2 sessions x (open + 13 drives + close)
    let (code, out, err) = run(d, &["history", "verify"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.starts_with("sqlite:.driveset/history.sqlite: 30 records, chain intact; head "),
        "{out}"
    );
    // the export: one line per record, each naming its predecessor's hash
    let (code, out, _) = run(d, &["history", "export"]);
    assert_eq!(code, 0);
    let recs: Vec<serde_json::Value> = out.lines().map(json).collect();
    assert_eq!(recs.len(), 30);
    for w in recs.windows(2) {
        assert_eq!(w[1]["prev_hash"], w[0]["hash"]);
    }
    // an archive re-verifies with any sha256: hash = sha256(prev "\n" content)
    for r in &recs {
        use sha2::Digest;
        let text = format!("{}\n{}", r["prev_hash"].as_str().unwrap(), r["content"]);
        let h: String = sha2::Sha256::digest(text.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(r["hash"], h.as_str());
    }
    assert_eq!(recs[0]["kind"], "session");
    assert_eq!(recs[0]["content"][2], "commission");
    assert_eq!(recs[14]["kind"], "end");
    assert_eq!(recs[14]["content"][3], "ok");

    // the SAT report links the run and each drive to the history
    let report =
        json(&std::fs::read_to_string(d.join("target/driveset-report/report.json")).unwrap());
    let link = &report["history"];
    assert_eq!(link["store"], "sqlite:.driveset/history.sqlite");
    assert_eq!(link["session"], recs[15]["session"]);
    assert_eq!(
        link["as_built"],
        format!("driveset history as-built {line} --at SAT").as_str()
    );
    let drives = report["drives"].as_array().unwrap();
    assert_eq!(drives.len(), 13);
    for (i, dr) in drives.iter().enumerate() {
        let name = dr["name"].as_str().unwrap();
        let h = &dr["history"];
        assert_eq!(
            h["log"],
            format!("driveset history log --line demo-line --drive {name}").as_str()
        );
        // the record is the drive's in the SAT session
        let rec = recs
            .iter()
            .find(|r| r["seq"] == h["record"])
            .unwrap_or_else(|| panic!("{name}: no record {}", h["record"]));
        assert_eq!(rec["kind"], "drive", "{name}");
        assert_eq!(rec["session"], link["session"], "{name}");
        assert_eq!(rec["content"][4], name, "{name} ({i})");
    }
    // the commands as written run and answer with that record
    let t12 = &drives[8];
    let words: Vec<&str> = t12["history"]["log"].as_str().unwrap().split(' ').collect();
    assert_eq!(words[0], "driveset");
    let mut args = words[1..].to_vec();
    args.extend(["--format", "json"]);
    let (code, out, err) = run(d, &args);
    assert_eq!(code, 0, "{err}");
    let rows = json(&out);
    assert_eq!(rows.as_array().unwrap().len(), 2);
    assert_eq!(rows[1]["seq"], t12["history"]["record"]);
    assert_eq!(rows[1]["session"], link["session"]);
    let words: Vec<&str> = link["as_built"].as_str().unwrap().split(' ').collect();
    let mut args = words[1..].to_vec();
    args.extend(["--format", "json"]);
    let (code, out, err) = run(d, &args);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json(&out)["drives"][8]["values"]["C0011"], "55 Hz");
    // report.html shows them
    let html = std::fs::read_to_string(d.join("target/driveset-report/report.html")).unwrap();
    let session = link["session"].as_str().unwrap();
    assert!(
        html.contains(&format!(
            "<dt>History</dt><dd>session <code id=\"history-session\">{session}</code> in \
             <code id=\"history-store\">sqlite:.driveset/history.sqlite</code>; the line as built: \
             <code id=\"history-as-built\">driveset history as-built {line} --at SAT</code></dd>"
        )),
        "{html}"
    );
    assert!(
        html.contains(&format!(
            "<dt>History</dt><dd class=\"history\">record {} \u{b7} <code>driveset history log --line demo-line --drive transfer-12</code></dd>",
            t12["history"]["record"]
        )),
        "{html}"
    );
}

/// The records of `history export` (JSON Lines) of one kind.
fn exported(dir: &Path, kind: &str) -> Vec<serde_json::Value> {
    let (code, out, err) = run(dir, &["history", "export"]);
    assert_eq!(code, 0, "{err}");
    out.lines()
        .map(json)
        .filter(|r| r["kind"] == kind)
        .collect()
}

/// A code row as the store holds it: (old, new, verified, outcome).
type CodeRow = (Option<String>, Option<String>, Option<String>, String);

/// A drive record's code rows as the store holds them, by code.
fn code_rows(drive: &serde_json::Value) -> std::collections::BTreeMap<String, CodeRow> {
    let c = drive["content"].as_array().unwrap();
    let s = |v: &serde_json::Value| v.as_str().map(str::to_string);
    c.last()
        .unwrap()
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r[1].as_str().unwrap().to_string(),
                (
                    s(&r[2]),
                    s(&r[3]),
                    s(&r[4]),
                    r[5].as_str().unwrap().to_string(),
                ),
            )
        })
        .collect()
}

#[test]
fn pull_live_diff_and_twin_capture_are_recorded_with_the_values_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let port = "sim://tmd?c0001=3";
    // pull: every value read, the fingerprint the file carries
    let (code, out, err) = run(
        d,
        &[
            "pull",
            "--port",
            port,
            "--address",
            "4",
            "-o",
            "axis.toml",
            "--format",
            "json",
            "--operator",
            "carol",
            "--reason",
            "before SAT",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let pulled = json(&out);
    let fp = pulled["fingerprint"].as_str().unwrap().to_string();
    // the live diff of the pulled set: nothing differs, the same fingerprint
    let (code, out, err) = run(d, &["diff", "axis.toml", "--port", port, "--address", "4"]);
    assert_eq!(code, 0, "{out}{err}");
    // a set asking 55 Hz of C0011: drift, exit 1
    let text = std::fs::read_to_string(d.join("axis.toml")).unwrap();
    assert!(text.contains("C0011 = \"50 Hz\""), "{text}");
    std::fs::write(
        d.join("slow.toml"),
        text.replace("C0011 = \"50 Hz\"", "C0011 = \"55.0 Hz\""),
    )
    .unwrap();
    let (code, out, err) = run(d, &["diff", "slow.toml", "--port", port, "--address", "4"]);
    assert_eq!(code, 1, "{out}{err}");
    // a twin capture: every value of the schema read
    let (code, out, err) = run(
        d,
        &[
            "twin",
            "capture",
            "--port",
            port,
            "--address",
            "4",
            "-o",
            "t.twin.toml",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains(": 86 codes, 0 refused, 1 secret(s) not stored;"),
        "{out}"
    );

    let (code, out, err) = run(d, &["history", "log", "--format", "json"]);
    assert_eq!(code, 0, "{err}");
    let rows = json(&out);
    let rows = rows.as_array().unwrap();
    let seen: Vec<(&str, &str, &str, i64, i64)> = rows
        .iter()
        .map(|r| {
            (
                r["command"].as_str().unwrap(),
                r["result"].as_str().unwrap(),
                r["bus"].as_str().unwrap(),
                r["address"].as_i64().unwrap(),
                r["codes_written"].as_i64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        seen,
        [
            ("pull", "read", port, 4, 0),
            ("diff", "unchanged", port, 4, 0),
            ("diff", "drift", port, 4, 0),
            ("twin capture", "read", port, 4, 0),
        ]
    );
    for r in rows {
        assert_eq!(r["family"], "lecom");
        assert_eq!(r["software"], "1.20");
        assert_eq!(r["line"], serde_json::Value::Null);
    }
    assert_eq!(rows[0]["operator"], "carol");
    assert_eq!(rows[0]["reason"], "before SAT");
    // the drive's fingerprint, read three times: the pulled file's (the
    // drifting set's codes are the file's, the drive unchanged)
    for r in &rows[..3] {
        assert_eq!(r["fingerprint_after"], fp.as_str());
    }
    let ends: Vec<String> = exported(d, "end")
        .iter()
        .map(|e| format!("{} {}", e["content"][3], e["content"][4]))
        .collect();
    assert_eq!(ends, ["\"ok\" 0", "\"ok\" 0", "\"differs\" 1", "\"ok\" 0"]);

    // the values read, per code
    let drives = exported(d, "drive");
    assert_eq!(drives.len(), 4);
    let pull = code_rows(&drives[0]);
    // every value read, actual values (C0093 TYPE) included, no password
    assert_eq!(
        pull["C0011"],
        (Some("50 Hz".into()), None, None, "read".into())
    );
    assert!(pull.contains_key("C0093"), "{pull:?}");
    assert!(!pull.contains_key("C0094"), "{pull:?}");
    assert_eq!(
        pull.len(),
        pulled["values"].as_u64().unwrap() as usize
            + pulled["actual_values"].as_array().unwrap().len()
    );
    let same = code_rows(&drives[1]);
    assert_eq!(
        same["C0011"],
        (
            Some("50 Hz".into()),
            Some("50 Hz".into()),
            Some("50 Hz".into()),
            "read".into()
        )
    );
    let drift = code_rows(&drives[2]);
    assert_eq!(
        drift["C0011"],
        (
            Some("50 Hz".into()),
            Some("55 Hz".into()),
            None,
            "drift".into()
        )
    );
    assert_eq!(drift.values().filter(|c| c.3 == "drift").count(), 1);
    let twin = code_rows(&drives[3]);
    assert_eq!(twin.len(), 86);
    assert_eq!(twin["C0011"].0.as_deref(), Some("50 Hz"));
    // the live diff's drive record names the set's fingerprint too
    let (_, out, _) = run(d, &["fingerprint", "slow.toml"]);
    assert!(
        out.contains(drives[2]["content"][12].as_str().unwrap()),
        "{out} {}",
        drives[2]["content"]
    );
    let (code, out, err) = run(d, &["history", "verify"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains(": 12 records, chain intact;"), "{out}");
}

#[test]
fn twin_capture_line_records_every_drive_of_the_line_as_status_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let line = demo_copy(d);
    let line = line.to_str().unwrap();
    let (code, out, err) = run(d, &["twin", "capture-line", line, "-o", "twins"]);
    assert_eq!(code, 0, "{out}{err}");
    // status reads the same (fresh, simulated) drives
    let (code, out, err) = run(d, &["status", line]);
    assert_eq!(code, 1, "{out}{err}");
    let (_, out, _) = run(d, &["history", "log", "--format", "json"]);
    let rows = json(&out);
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 26);
    // status runs its buses at once: its drives matched by name
    let (capture, status) = rows.split_at(13);
    for c in capture {
        let s = status
            .iter()
            .find(|s| s["drive"] == c["drive"])
            .unwrap_or_else(|| panic!("{} not read by status", c["drive"]));
        assert_eq!(c["command"], "twin capture-line");
        assert_eq!(s["command"], "status");
        assert_eq!(c["line"], "demo-line");
        assert_eq!(c["label"], "demo line, simulated");
        assert_eq!(c["drive"], s["drive"]);
        assert_eq!(c["bus"], s["bus"]);
        assert_eq!(c["address"], s["address"]);
        assert_eq!(c["result"], s["result"], "{}", c["drive"]);
        assert_eq!(
            c["fingerprint_after"], s["fingerprint_after"],
            "{}",
            c["drive"]
        );
    }
    // transfer-12: each code of its set read against it
    let drives = exported(d, "drive");
    let t12 = |i: usize| {
        drives
            .iter()
            .filter(|r| r["content"][4] == "transfer-12")
            .nth(i)
            .map(code_rows)
            .unwrap()
    };
    let (cap, st) = (t12(0), t12(1));
    assert_eq!(
        cap["C0011"],
        (
            Some("50 Hz".into()),
            Some("60 Hz".into()),
            None,
            "drift".into()
        )
    );
    assert_eq!(cap, st);
}

#[test]
fn rollbacks_are_on_record_with_the_values_restored() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let set = driveset_test_support::workspace_root().join("parameter-sets/tmd/conveyor-3.toml");
    let set = set.to_str().unwrap();
    let state = d.join("drive.json");
    let port = |faults: &str| {
        format!(
            "sim://tmd?addresses=11&c0001=3&state={}{faults}",
            state.display()
        )
    };
    // the cable out for 1 s at telegram 30: the upload rolls back itself
    let (code, out, err) = run(
        d,
        &[
            "upload",
            set,
            "--port",
            &port("&faults=cable@30+1s"),
            "--address",
            "11",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    assert!(
        err.contains("the upload did not land and was rolled back"),
        "{err}"
    );
    // out for good: the drive holds a mix, recover rolls it back
    let (code, out, err) = run(
        d,
        &[
            "upload",
            set,
            "--port",
            &port("&faults=cable@30+600s"),
            "--address",
            "11",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    let journal = std::fs::read_dir(d.join(".driveset/journal"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().contains("drive_json"))
        .unwrap();
    let (code, out, err) = run(
        d,
        &["recover", journal.to_str().unwrap(), "--port", &port("")],
    );
    assert_eq!(code, 0, "{out}{err}");

    let (_, out, _) = run(
        d,
        &["history", "log", "--code", "C0011", "--format", "json"],
    );
    let rows = json(&out);
    let seen: Vec<(&str, &str, &serde_json::Value)> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["command"].as_str().unwrap(),
                r["result"].as_str().unwrap(),
                &r["change"],
            )
        })
        .collect();
    assert_eq!(
        seen,
        [
            (
                "upload",
                "rolled-back",
                &serde_json::json!(["50 Hz", "60 Hz"])
            ),
            ("upload", "failed", &serde_json::json!(["50 Hz", "60 Hz"])),
            (
                "recover",
                "rolled-back",
                &serde_json::json!(["60 Hz", "50 Hz"])
            ),
        ]
    );
    let drives = exported(d, "drive");
    // the upload's own rollback: each code written, then restored and read back
    let own = code_rows(&drives[0]);
    assert_eq!(
        own["C0011"],
        (
            Some("50 Hz".into()),
            Some("60 Hz".into()),
            Some("50 Hz".into()),
            "restored".into()
        )
    );
    assert_eq!(own.values().filter(|c| c.3 == "restored").count(), 5);
    assert_eq!(own["C0018"].3, "failed");
    // recover's: what the drive held, what it was restored to, read back
    let rec = code_rows(&drives[2]);
    assert_eq!(rec.len(), 5 + 1, "{rec:?}");
    assert_eq!(
        rec["C0011"],
        (
            Some("60 Hz".into()),
            Some("50 Hz".into()),
            Some("50 Hz".into()),
            "restored".into()
        )
    );
    assert!(rec.values().all(|c| c.3 == "restored"));
    // both end where the drive began
    assert_eq!(drives[0]["content"][14], drives[2]["content"][14]);
    assert_eq!(drives[0]["content"][14], drives[0]["content"][13]);
}

#[test]
fn a_commission_that_recovers_a_drive_first_records_the_rollback_before_the_upload() {
    let dir = sim_dir();
    let d = dir.path();
    let set = driveset_test_support::workspace_root().join("parameter-sets/tmd/conveyor-3.toml");
    std::fs::write(
        d.join("line.toml"),
        format!(
            "[line]\nname = \"l\"\n\n[[bus]]\nname = \"transfer\"\nport = \"sim://tmd?c0001=3\"\nprotocol = \"lecom\"\nbaud = 9600\n\n[[drive]]\nname = \"transfer-11\"\nbus = \"transfer\"\naddress = 11\nset = \"{}\"\n",
            set.display()
        ),
    )
    .unwrap();
    // an upload cut by a pulled cable leaves its journal failed
    let (code, out, err) = run(
        d,
        &[
            "upload",
            set.to_str().unwrap(),
            "--port",
            "sim://tmd?addresses=11&c0001=3&faults=cable@30+600s",
            "--address",
            "11",
        ],
    );
    assert_eq!(code, 3, "{out}{err}");
    let (code, out, err) = run(d, &["commission", "line.toml"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(err.contains("rolled back (old values restored)"), "{err}");
    let (_, out, _) = run(
        d,
        &[
            "history",
            "log",
            "--drive",
            "transfer-11",
            "--format",
            "json",
        ],
    );
    let rows = json(&out);
    let seen: Vec<(&str, &str)> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["command"].as_str().unwrap(),
                r["result"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        seen,
        [("commission", "rolled-back"), ("commission", "verified")]
    );
    assert_eq!(rows[0]["session"], rows[1]["session"]);
    let drives = exported(d, "drive");
    assert_eq!(drives.len(), 3);
    let back = code_rows(&drives[1]);
    assert!(!back.is_empty());
    assert!(
        back.values().all(|c| c.3 == "restored" && c.1 == c.2),
        "{back:?}"
    );
    // what the rollback restored is what the upload then found
    let up = code_rows(&drives[2]);
    for (code, c) in &back {
        assert_eq!(up[code].0, c.1, "{code}");
    }
    // the report links the drive to its last record: the upload's
    let report =
        json(&std::fs::read_to_string(d.join("target/driveset-report/report.json")).unwrap());
    assert_eq!(report["drives"][0]["history"]["record"], rows[1]["seq"]);
}

#[test]
fn a_row_altered_by_hand_is_caught_by_verify() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let line = demo_copy(d);
    commission(
        d,
        line.to_str().unwrap(),
        "alice",
        "FAT",
        &["--only", "transfer"],
    );
    let (code, out, _) = run(d, &["history", "verify"]);
    assert_eq!(code, 0, "{out}");
    // somebody makes it look as if 12 had been set to 65 Hz
    let mut db = Sqlite::open(&d.join(".driveset/history.sqlite")).unwrap();
    let n = db
        .exec(
            "UPDATE codes SET new = '65 Hz', verified = '65 Hz' WHERE code = 'C0011' AND drive_seq = (SELECT seq FROM drives WHERE drive = 'transfer-12')",
            &[],
        )
        .unwrap();
    assert_eq!(n, 1);
    drop(db);
    let (code, out, err) = run(d, &["history", "verify"]);
    assert_eq!(code, 1, "{err}");
    let session = json(&run(d, &["history", "log", "--format", "json"]).1)[0]["session"]
        .as_str()
        .unwrap()
        .to_string();
    // record 1 opens the session, 2..4 are transfer-11, -12, -13
    assert!(
        out.starts_with(&format!(
            "sqlite:.driveset/history.sqlite: chain broken at record 3 (drive of session {session}): its content does not hash to its recorded hash (recorded "
        )),
        "{out}"
    );
}

#[test]
fn a_password_never_enters_the_store() {
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
    set(731);
    let (code, out, err) = run(d, &["commission", "line.toml", "--operator", "o"]);
    assert_eq!(code, 0, "{out}{err}");
    set(732);
    let (code, _, _) = run(d, &["status", "line.toml"]);
    assert_eq!(code, 1);
    let (code, _, _) = run(d, &["commission", "line.toml"]);
    assert_eq!(code, 0);
    // the password's code is on record, its value is not
    let (_, out, _) = run(d, &["history", "export"]);
    assert!(
        out.contains(r#""C0094","<secret>","<secret>","<secret>","verified""#),
        "{out}"
    );
    let mut bytes = Vec::new();
    for e in std::fs::read_dir(d.join(".driveset")).unwrap() {
        let p = e.unwrap().path();
        if p.file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("history.sqlite")
        {
            bytes.extend(std::fs::read(&p).unwrap());
        }
    }
    assert!(bytes.len() > 4096);
    // the value as text, and the raw LECOM forms (x10000), anywhere
    let text = String::from_utf8_lossy(&bytes);
    for v in ["731", "732", "7310000", "7320000"] {
        assert!(
            !driveset_test_support::shows_value(&text, v),
            "{v} in the store"
        );
    }
}

#[test]
fn a_bad_history_url_is_refused_and_history_required_refuses_to_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let line = demo_copy(d);
    let line = line.to_str().unwrap();
    let (code, out, err) = run(d, &["commission", line, "--history", "mysql://root:pw@x/y"]);
    assert_eq!((code, out.as_str()), (2, ""));
    assert_eq!(
        err,
        "error: history store `mysql://root:***@x/y` not understood: give sqlite:PATH, postgresql://USER@HOST/DB (or postgres://), or off\n"
    );
    // a store that cannot be created: refused before anything is sent
    std::fs::write(d.join("blocker"), "a file, not a directory").unwrap();
    let (code, out, err) = run(
        d,
        &[
            "commission",
            line,
            "--history",
            "sqlite:blocker/h.sqlite",
            "--history-required",
        ],
    );
    assert_eq!((code, out.as_str()), (2, ""), "{err}");
    assert!(
        err.starts_with("error: history: this run cannot be recorded (history store sqlite:blocker/h.sqlite cannot be opened: "),
        "{err}"
    );
    assert!(
        err.ends_with("); nothing was sent (--history-required)\n"),
        "{err}"
    );
    assert!(!d.join("target/driveset-report/report.json").exists());
    // without --history-required the run goes on and says it is not recorded
    let (code, _, err) = run(
        d,
        &[
            "commission",
            line,
            "--history",
            "sqlite:blocker/h.sqlite",
            "--only",
            "transfer",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("warning: history: this run is not recorded: history store sqlite:blocker/h.sqlite cannot be opened: "), "{err}");
    // off: nothing recorded, nothing created
    let (code, _, err) = run(
        d,
        &["commission", line, "--history", "off", "--only", "transfer"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(!d.join(".driveset/history.sqlite").exists());
}

/// A PostgreSQL cluster of our own: initdb in a temp dir, the server on a
/// unix socket there (no TCP), run as `nobody` when we are root; stopped
/// (immediately) when dropped.
struct Pg {
    dir: tempfile::TempDir,
    bin: PathBuf,
    as_nobody: bool,
}

impl Pg {
    fn bin() -> Option<PathBuf> {
        if let Ok(b) = std::env::var("DRIVESET_PG_BIN") {
            return Some(PathBuf::from(b));
        }
        let mut found: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
            .ok()?
            .filter_map(|e| e.ok().map(|e| e.path().join("bin")))
            .filter(|b| b.join("initdb").is_file())
            .collect();
        found.sort();
        found.pop()
    }

    fn cmd(&self, tool: &str) -> Command {
        let exe = self.bin.join(tool);
        if self.as_nobody {
            let mut c = Command::new("runuser");
            c.args(["-u", "nobody", "--"]).arg(exe);
            c
        } else {
            Command::new(exe)
        }
    }

    /// A running cluster, or `None` (skipped, or failed under
    /// `DRIVESET_REQUIRE_INTEROP=1`) when the server is not installed.
    fn start() -> Option<Pg> {
        let bin = driveset_test_support::interop_or_skip(
            "PostgreSQL",
            Pg::bin(),
            "no initdb under /usr/lib/postgresql/*/bin (scripts/setup-postgres; or set DRIVESET_PG_BIN)",
        )?;
        let dir = tempfile::tempdir().unwrap();
        let as_nobody = std::fs::read_to_string("/proc/self/status")
            .unwrap_or_default()
            .lines()
            .any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0"));
        if as_nobody {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
        }
        let pg = Pg {
            dir,
            bin,
            as_nobody,
        };
        let data = pg.dir.path().join("data");
        let st = pg
            .cmd("initdb")
            .args([
                "-A",
                "trust",
                "-U",
                "driveset",
                "--no-sync",
                "-E",
                "UTF8",
                "-D",
            ])
            .arg(&data)
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "initdb: {}",
            String::from_utf8_lossy(&st.stderr)
        );
        let st = pg
            .cmd("pg_ctl")
            .arg("-D")
            .arg(&data)
            .arg("-o")
            .arg(format!(
                "-k {} -c listen_addresses= -c fsync=off",
                pg.dir.path().display()
            ))
            .arg("-l")
            .arg(pg.dir.path().join("log"))
            .args(["-w", "start"])
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "pg_ctl start: {}{}",
            String::from_utf8_lossy(&st.stderr),
            std::fs::read_to_string(pg.dir.path().join("log")).unwrap_or_default()
        );
        Some(pg)
    }

    /// The URL of database `postgres` on the socket, with a password
    /// (trust ignores it; the history must mask it).
    fn url(&self) -> String {
        format!(
            "postgresql://driveset:hunter2@localhost/postgres?host={}",
            self.dir.path().display()
        )
    }
}

impl Pg {
    fn stop(&self) {
        let st = self
            .cmd("pg_ctl")
            .arg("-D")
            .arg(self.dir.path().join("data"))
            .args(["-m", "immediate", "-w", "stop"])
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "pg_ctl stop: {}",
            String::from_utf8_lossy(&st.stderr)
        );
    }

    fn start_again(&self) {
        let st = self
            .cmd("pg_ctl")
            .arg("-D")
            .arg(self.dir.path().join("data"))
            .arg("-o")
            .arg(format!(
                "-k {} -c listen_addresses= -c fsync=off",
                self.dir.path().display()
            ))
            .arg("-l")
            .arg(self.dir.path().join("log"))
            .args(["-w", "start"])
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "pg_ctl start: {}",
            String::from_utf8_lossy(&st.stderr)
        );
    }
}

impl Drop for Pg {
    fn drop(&mut self) {
        let _ = self
            .cmd("pg_ctl")
            .arg("-D")
            .arg(self.dir.path().join("data"))
            .args(["-m", "immediate", "stop"])
            .output();
    }
}

#[test]
fn postgres_records_refuses_update_and_delete_and_forwards_a_run_recorded_while_it_was_down() {
    let Some(pg) = Pg::start() else { return };
    let url = pg.url();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let line = demo_copy(d);
    let line = line.to_str().unwrap();
    commission(
        d,
        line,
        "alice",
        "FAT",
        &["--history", &url, "--only", "transfer"],
    );
    let (code, out, err) = run(d, &["history", "verify", "--history", &url]);
    assert_eq!(code, 0, "{err}");
    let shown = url.replace(":hunter2@", ":***@");
    assert!(
        out.starts_with(&format!("{shown}: 5 records, chain intact; head ")),
        "{out}"
    );
    // the URL's password is in no record
    let (_, export, _) = run(d, &["history", "export", "--history", &url]);
    assert!(!export.contains("hunter2"), "{export}");
    assert!(export.contains("--history"), "{export}");
    // the tables refuse UPDATE and DELETE to the role driveset uses
    let mut db = Postgres::connect(&url, "pg").unwrap();
    let e = db
        .exec("UPDATE codes SET new = '65 Hz' WHERE code = 'C0011'", &[])
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "history store: the driveset history is append-only: UPDATE on codes refused"
    );
    let e = db.exec("DELETE FROM chain", &[]).unwrap_err().to_string();
    assert_eq!(
        e,
        "history store: the driveset history is append-only: DELETE on chain refused"
    );
    let e = db.batch("TRUNCATE sessions").unwrap_err().to_string();
    assert_eq!(
        e,
        "history store: the driveset history is append-only: TRUNCATE on sessions refused"
    );

    // the store goes down: the run is recorded locally and says so
    pg.stop();
    let set = d.join("sets/demo-line/sets/transfer-12.toml");
    let text = std::fs::read_to_string(&set).unwrap();
    std::fs::write(
        &set,
        text.replace("C0011 = \"60.0 Hz\"", "C0011 = \"55.0 Hz\""),
    )
    .unwrap();
    let (code, out, err) = run(
        d,
        &[
            "commission",
            line,
            "--history",
            &url,
            "--operator",
            "bob",
            "--label",
            "SAT",
            "--only",
            "transfer",
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        err.contains(&format!(
            "warning: history store {shown} cannot be opened: "
        )),
        "{err}"
    );
    assert!(err.contains("; this run is recorded in .driveset/history.sqlite and forwarded by the next run that reaches the store, or by `driveset history sync`\n"), "{err}");
    let (_, out, _) = run(d, &["history", "log", "--label", "SAT", "--format", "json"]);
    assert_eq!(json(&out).as_array().unwrap().len(), 3);
    // back up: it has not got the run until it is forwarded, once
    pg.start_again();
    let (_, out, _) = run(
        d,
        &[
            "history",
            "log",
            "--history",
            &url,
            "--label",
            "SAT",
            "--format",
            "json",
        ],
    );
    assert_eq!(json(&out).as_array().unwrap().len(), 0);
    let (code, out, err) = run(d, &["history", "sync", "--history", &url]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out, format!("1 session(s) forwarded to {shown}\n"), "{err}");
    let (code, out, err) = run(d, &["history", "sync", "--history", &url]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out, format!("0 session(s) forwarded to {shown}\n"));
    // nor does the next run forward it again
    let (code, _, err) = run(
        d,
        &["status", line, "--history", &url, "--only", "transfer"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("forwarded"), "{err}");
    let (_, out, _) = run(
        d,
        &[
            "history",
            "log",
            "--history",
            &url,
            "--label",
            "SAT",
            "--format",
            "json",
        ],
    );
    let rows = json(&out);
    assert_eq!(rows.as_array().unwrap().len(), 3);
    assert_eq!(rows[1]["drive"], "transfer-12");
    assert_eq!(rows[1]["operator"], "bob");
    let (code, out, _) = run(
        d,
        &[
            "history",
            "blame",
            "--history",
            &url,
            "--drive",
            "transfer-12",
            "C0011",
        ],
    );
    assert_eq!(code, 0);
    assert!(
        out.starts_with("transfer-12 C0011: 60 Hz -> 55 Hz (read back 55 Hz)\n"),
        "{out}"
    );
    // FAT (5) + SAT (5, forwarded) + the status (5)
    let (code, out, err) = run(d, &["history", "verify", "--history", &url]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.starts_with(&format!("{shown}: 15 records, chain intact; head ")),
        "{out}"
    );
}

#[test]
fn eight_stations_commissioning_at_once_into_one_postgres_lose_nothing_and_keep_one_chain() {
    const STATIONS: usize = 8;
    let Some(pg) = Pg::start() else { return };
    let url = pg.url();
    let dirs: Vec<tempfile::TempDir> = (0..STATIONS)
        .map(|_| tempfile::tempdir().unwrap())
        .collect();
    let mut children = Vec::new();
    for (i, d) in dirs.iter().enumerate() {
        let line = demo_copy(d.path());
        let manifest = std::fs::read_to_string(&line).unwrap();
        std::fs::write(
            &line,
            manifest.replace("name = \"demo-line\"", &format!("name = \"line-{i}\"")),
        )
        .unwrap();
        children.push(
            Command::new(driveset_test_support::driveset_bin())
                .current_dir(d.path())
                .env("DRIVESET_SIM_STATE_DIR", d.path().join("sim"))
                .env_remove("DRIVESET_HISTORY")
                .args([
                    "commission",
                    line.to_str().unwrap(),
                    "--history",
                    &url,
                    "--history-required",
                    "--operator",
                    &format!("op{i}"),
                ])
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap(),
        );
    }
    // all eight started before any is waited for
    for c in children {
        let out = c.wait_with_output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // recorded in the shared store, not locally
        assert!(
            !String::from_utf8_lossy(&out.stderr).contains("warning"),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let d = dirs[0].path();
    let (code, out, err) = run(d, &["history", "verify", "--history", &url]);
    assert_eq!(code, 0, "{err}");
    // 8 x (open + 13 drives + close), one chain
    assert!(out.contains(": 120 records, chain intact; head "), "{out}");
    // nothing lost: every session opened and closed ok, each line's 13
    // drives in its own session, by its own operator
    let (_, out, _) = run(d, &["history", "export", "--history", &url]);
    let recs: Vec<serde_json::Value> = out.lines().map(json).collect();
    assert_eq!(recs.len(), 120);
    let sessions: std::collections::BTreeSet<&str> = recs
        .iter()
        .filter(|r| r["kind"] == "session")
        .map(|r| r["session"].as_str().unwrap())
        .collect();
    assert_eq!(sessions.len(), STATIONS);
    for s in &sessions {
        let of = |k: &str| {
            recs.iter()
                .filter(|r| r["session"] == *s && r["kind"] == k)
                .collect::<Vec<_>>()
        };
        assert_eq!(of("drive").len(), 13, "{s}");
        let end = of("end");
        assert_eq!(end.len(), 1, "{s}");
        assert_eq!(end[0]["content"][3], "ok", "{s}");
        // the session opens before its drives and closes after them
        let seq = |r: &serde_json::Value| r["seq"].as_i64().unwrap();
        let open = seq(of("session")[0]);
        assert!(
            of("drive")
                .iter()
                .all(|r| open < seq(r) && seq(r) < seq(end[0]))
        );
    }
    for i in 0..STATIONS {
        let (_, out, _) = run(
            d,
            &[
                "history",
                "log",
                "--history",
                &url,
                "--line",
                &format!("line-{i}"),
                "--format",
                "json",
            ],
        );
        let rows = json(&out);
        let rows = rows.as_array().unwrap();
        assert_eq!(rows.len(), 13);
        assert!(
            rows.iter()
                .all(|r| r["operator"] == format!("op{i}").as_str() && r["result"] == "verified")
        );
        let one: std::collections::BTreeSet<&str> = rows
            .iter()
            .map(|r| r["session"].as_str().unwrap())
            .collect();
        assert_eq!(one.len(), 1);
    }
}

/// A commission over a pty served by `driveset sim` killed with SIGKILL
/// while it writes leaves its session open; `recover` of its journal
/// closes it with what it found.
#[test]
fn a_commission_killed_mid_write_leaves_an_open_session_that_recover_closes() {
    use std::time::{Duration, Instant};
    let _serial = crate::e2e_pty::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = crate::e2e_pty::Sim::start(d, "tmd", 13, &["--c0001", "3"]);
    for f in ["conveyor-3.toml", "base.toml"] {
        std::fs::copy(
            workspace_root().join("parameter-sets/tmd").join(f),
            d.join(f),
        )
        .unwrap();
    }
    std::fs::write(
        d.join("line.toml"),
        format!(
            "[line]\nname = \"pty-line\"\n\n[[bus]]\nname = \"a\"\nport = \"{}\"\nprotocol = \"lecom\"\nbaud = 9600\n\n[[drive]]\nbus = \"a\"\naddress = 13\nset = \"conveyor-3.toml\"\nname = \"conveyor-3\"\n",
            sim.path
        ),
    )
    .unwrap();
    let mut child = Command::new(driveset_test_support::driveset_bin())
        .current_dir(d)
        .env("DRIVESET_LOCK_DIR", d.join("locks"))
        .env_remove("DRIVESET_HISTORY")
        .args([
            "commission",
            "line.toml",
            "--operator",
            "carol",
            "--reason",
            "cut",
        ])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // the journal says writing: kill -9
    let journal_dir = d.join(".driveset/journal");
    let give_up = Instant::now() + Duration::from_secs(300);
    let journal = loop {
        let found = std::fs::read_dir(&journal_dir).ok().and_then(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .find(|p| p.to_string_lossy().ends_with(".journal.json"))
        });
        if let Some(p) = found
            && let Ok(t) = std::fs::read_to_string(&p)
            && let Ok(j) = serde_json::from_str::<serde_json::Value>(&t)
            && j["state"] == "writing"
        {
            break p;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the commission ended before it wrote"
        );
        assert!(Instant::now() < give_up, "no journal");
        std::thread::sleep(Duration::from_millis(2));
    };
    assert!(driveset_test_support::send_signal(child.id(), "-KILL"));
    let pid = child.id();
    let _ = child.wait();
    // the session is open: opened, nothing closed it
    let (_, out, _) = run(d, &["history", "export"]);
    let recs: Vec<serde_json::Value> = out.lines().map(json).collect();
    assert_eq!(recs.len(), 1, "{out}");
    assert_eq!(recs[0]["kind"], "session");
    assert_eq!(recs[0]["content"][7], "carol");
    let session = recs[0]["session"].as_str().unwrap().to_string();

    let jarg = journal.display().to_string();
    let out = driveset_in(d)
        .env("DRIVESET_LOCK_DIR", d.join("locks"))
        .env_remove("DRIVESET_HISTORY")
        .args(["recover", &jarg, "--operator", "dave"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains(&format!(
            "history: closed session {session} of `driveset commission` (process {pid} gone)\n"
        )),
        "{err}"
    );
    let (_, out, _) = run(d, &["history", "export"]);
    let recs: Vec<serde_json::Value> = out.lines().map(json).collect();
    // the commission's open, recover's open, its drive, the commission's
    // end (written by recover), recover's end
    let kinds: Vec<(&str, bool)> = recs
        .iter()
        .map(|r| {
            (
                r["kind"].as_str().unwrap(),
                r["session"] == session.as_str(),
            )
        })
        .collect();
    assert_eq!(
        kinds,
        [
            ("session", true),
            ("session", false),
            ("drive", false),
            ("end", true),
            ("end", false)
        ]
    );
    let end = &recs[3]["content"];
    assert_eq!(end[3], "interrupted");
    assert_eq!(end[4], serde_json::Value::Null);
    assert_eq!(end[6], recs[1]["session"]);
    let detail = end[5].as_str().unwrap();
    assert!(
        detail.starts_with(&format!(
            "process {pid} ended without closing its session (`driveset commission` started "
        )),
        "{detail}"
    );
    assert!(
        detail.ends_with(&format!(
            "; `driveset recover {jarg}` found the journal writing and rolled-back it"
        )),
        "{detail}"
    );
    let (code, out, _) = run(d, &["history", "verify"]);
    assert_eq!(code, 0, "{out}");
}
