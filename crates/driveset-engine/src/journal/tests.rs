//! The journal's unit tests: older forms still read (a version 2
//! journal before typed causes and recorded schema files), the typed
//! failure cause's JSON form, the file names, the directory's
//! `.gitignore`. The JSON forms of whole journals are pinned by the
//! fixtures of the engine's integration tests (`journal_forms`).

use std::fs;

use super::*;
use crate::client::Target;
use crate::client::lustbus::LustbusRefusal;
use crate::error::{DeviceCause, EngineError};

/// A `failed` journal as the release before typed causes wrote it
/// (version 2, `failure` text only, `holding` names as strings).
const V2_FAILED: &str = r#"{
  "journal_version": 2,
  "state": "failed",
  "target": { "port": "sim://demo", "address": 1, "bus": "sim:demo" },
  "identity": { "protocol": "lustbus-mc", "codes": [["91-TYPE", "1234"]], "software": null },
  "schema": "fictional-mc6000-demo",
  "set_fingerprint": "sha256:5c1e",
  "fingerprint_before": "sha256:09ab",
  "dataset": false,
  "attempt": 1,
  "backup": [
    { "number": 100, "subcode": null, "code": "100-KPSC1", "secret": false, "old": { "int": 1310 } },
    { "number": 101, "subcode": null, "code": "101-TNSC1", "secret": false, "old": { "int": 200 } },
    { "number": 102, "subcode": null, "code": "102-X", "secret": false, "old": { "int": 1 } },
    { "number": 103, "subcode": null, "code": "103-Y", "secret": false, "old": { "int": 2 } }
  ],
  "plan": [],
  "written": ["100"],
  "transitions": [{ "state": "planned", "at_ns": 1, "note": null }],
  "failure": "sim://demo address 1: no answer to write 101-TNSC1 after 3 tries",
  "holding": [
    { "code": "100-KPSC1", "holds": "new" },
    { "code": "101-TNSC1", "holds": "unknown" },
    { "code": "102-X", "holds": "other" },
    { "code": "103-Y", "holds": "old" }
  ]
}"#;

#[test]
fn a_version_2_journal_without_typed_causes_is_read() {
    let j: Journal = serde_json::from_str(V2_FAILED).expect("v2 journal");
    assert_eq!(j.journal_version, 2);
    assert_eq!(j.state, TxnState::Failed);
    assert_eq!(j.failure_cause, None);
    assert_eq!(
        j.failure.as_deref(),
        Some("sim://demo address 1: no answer to write 101-TNSC1 after 3 tries")
    );
    let holds: Vec<(&str, Holding)> = j
        .holding
        .iter()
        .map(|h| (h.code.as_str(), h.holds))
        .collect();
    assert_eq!(
        holds,
        [
            ("100-KPSC1", Holding::New),
            ("101-TNSC1", Holding::Unknown),
            ("102-X", Holding::Other),
            ("103-Y", Holding::Old)
        ]
    );
    // written back, the holding names are the same strings
    let back = serde_json::to_value(&j).expect("json");
    assert_eq!(back["holding"][2]["holds"], "other");
    assert!(back.get("failure_cause").is_none(), "{back}");
    // a journal of a release before the schema's file and fingerprint
    // were recorded: read, and written back without them
    assert_eq!(j.schema_source, SchemaSource::default());
    assert!(back.get("schema_path").is_none(), "{back}");
    assert!(back.get("schema_fingerprint").is_none(), "{back}");
    assert_eq!(back["schema"], "fictional-mc6000-demo");
    let mut with = j.clone();
    with.schema_source = SchemaSource {
        schema_path: Some("/plant/schemas/demo.toml".into()),
        schema_fingerprint: Some("sha256:00".into()),
    };
    let v = serde_json::to_value(&with).expect("json");
    assert_eq!(v["schema_path"], "/plant/schemas/demo.toml");
    assert_eq!(v["schema_fingerprint"], "sha256:00");
    let again: Journal = serde_json::from_value(v).expect("read back");
    assert_eq!(again.schema_source, with.schema_source);
    // and through the file reader
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("sim_demo-1.journal.json");
    fs::write(&path, V2_FAILED).expect("write");
    let jf = JournalFile::open(&path).expect("open v2");
    assert_eq!(jf.journal, j);
}

#[test]
fn the_failure_cause_is_stored_typed() {
    let mut j: Journal = serde_json::from_str(V2_FAILED).expect("v2 journal");
    let target = Target {
        port: "sim://demo".into(),
        address: 1,
    };
    let e = EngineError::device(
        target.clone(),
        "write 101-TNSC1 (raw 9)",
        DeviceCause::Siof {
            register: crate::error::SiofRegister::Serr,
            bits: driveset_proto::lustbus::Siof(0x80),
            verdict: crate::error::SiofVerdict::Failed,
        },
    );
    let rolled = EngineError::rolled_back(target.clone(), "j", "it failed", e);
    j.failure_cause = Some(FailureCause::of(&rolled));
    let v = serde_json::to_value(&j).expect("json");
    assert_eq!(
        v["failure_cause"].to_string(),
        r#"{"cause":{"cause":{"bits":128,"kind":"siof","register":"serr","verdict":{"kind":"failed"}},"kind":"device","what":"write 101-TNSC1 (raw 9)"},"detail":"it failed","kind":"rolled_back"}"#
    );
    let back: Journal = serde_json::from_value(v).expect("back");
    assert_eq!(back, j);
    let refused = EngineError::refused(target, LustbusRefusal::NoDatasetOpen);
    assert_eq!(
        serde_json::to_string(&FailureCause::of(&refused)).expect("json"),
        r#"{"kind":"refused","refusal":{"kind":"no_dataset_open"}}"#
    );
}

#[test]
fn file_names_come_from_bus_id_and_address() {
    assert_eq!(
        journal_file_name("tcp:127.0.0.1:4001", 3),
        "tcp_127_0_0_1_4001-3.journal.json"
    );
    assert_eq!(
        journal_file_name("serial:/dev/ttyUSB0", 12),
        "serial__dev_ttyUSB0-12.journal.json"
    );
    let long = format!("sim:mc6000@/{}", "d/".repeat(80));
    let name = journal_file_name(&long, 1);
    assert_eq!(name.len(), 96 + 1 + 16 + "-1.journal.json".len());
    assert!(name.ends_with("-1.journal.json"), "{name}");
    assert_ne!(name, journal_file_name(&format!("{long}x"), 1));
}

#[test]
fn ensure_dir_writes_a_gitignore_into_the_topmost_directory_it_creates() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join(".driveset/journal");
    ensure_dir(&dir).unwrap();
    assert!(dir.is_dir());
    assert_eq!(
        fs::read_to_string(d.path().join(".driveset/.gitignore")).unwrap(),
        "# written by driveset: journals hold old values, passwords included\n*\n"
    );
    assert!(!dir.join(".gitignore").exists());
    // an existing directory is left alone
    let other = d.path().join("mine");
    fs::create_dir(&other).unwrap();
    ensure_dir(&other).unwrap();
    assert!(!other.join(".gitignore").exists());
}

#[test]
fn a_journal_goes_to_the_file_named_else_into_its_directory() {
    use std::path::{Path, PathBuf};
    let bus = "serial:/dev/ttyUSB0";
    let (file, dir) = (Path::new("axis.journal.json"), Path::new("journals"));
    assert_eq!(JournalAt::new(Some(file), Some(dir)).path(bus, 3), file);
    assert_eq!(
        JournalAt::new(None, Some(dir)).path(bus, 3),
        journal_path(dir, bus, 3)
    );
    assert_eq!(
        JournalAt::new(None, None).path(bus, 3),
        journal_path(Path::new(DEFAULT_JOURNAL_DIR), bus, 3)
    );
    assert_eq!(
        journal_dir_or_default(None),
        PathBuf::from(DEFAULT_JOURNAL_DIR)
    );
    assert_eq!(journal_dir_or_default(Some(dir)), dir);
}

#[test]
fn recover_routes_an_unfinished_upload_to_the_upload_and_a_settled_one_to_nothing() {
    use crate::recover::{JournalRoute, RecoverAction, route};
    let j: Journal = serde_json::from_str(V2_FAILED).expect("v2 journal");
    assert_eq!(route(&j), JournalRoute::Upload);
    let done = V2_FAILED.replace(r#""state": "failed""#, r#""state": "complete""#);
    let j: Journal = serde_json::from_str(&done).expect("v2 journal");
    assert_eq!(route(&j), JournalRoute::Finished(TxnState::Complete));
    // the plant history's words; the JSON report's are serde's
    for (a, word, json) in [
        (RecoverAction::Nothing, "nothing-to-do", "\"nothing\""),
        (RecoverAction::Completed, "completed", "\"completed\""),
        (RecoverAction::RolledBack, "rolled-back", "\"rolled-back\""),
    ] {
        assert_eq!(a.as_str(), word);
        assert_eq!(serde_json::to_string(&a).unwrap(), json);
    }
}
