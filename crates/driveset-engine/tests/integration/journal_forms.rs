//! The journal's JSON forms, pinned by files (`tests/data/journals/`,
//! docs/journals.md, "The file"): journals the engine wrote on simulated
//! buses (an MC6000 dataset upload, a failed Tmd upload cut by a pulled
//! cable, a transfer-rate switch finished and one cut while switching
//! back, an address change), each read with [`JournalFile::open`] and
//! written back with the journal's own durable write, byte for byte; and a
//! version 1 journal (no bus id), which is still read and is written back
//! in today's form; an unknown name in a typed field is a journal error
//! naming the file and the field. The state files' paths in the bus ids are spelled
//! `/plant/sim/...` instead of the temporary directories they were written
//! in.

use std::path::{Path, PathBuf};

use driveset_engine::journal::{Journal, JournalFile, TxnState};
use driveset_engine::plan::{Phase, Storage};

/// The fixtures' folder.
fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/journals")
}

/// The fixture `name`, read as a journal file.
fn open(name: &str) -> JournalFile {
    let path = dir().join(name);
    JournalFile::open(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// What the journal's own write (`JournalFile::persist`, through
/// `replace`) puts on disk for `journal`.
fn written(journal: Journal) -> String {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = tmp.path().join("j.journal.json");
    JournalFile::replace(&path, journal).expect("write");
    std::fs::read_to_string(&path).expect("read back")
}

/// `name` read and written back is `name` again, byte for byte.
fn round_trip(name: &str) -> Journal {
    let jf = open(name);
    let text = std::fs::read_to_string(dir().join(name)).expect("fixture");
    let back = written(jf.journal.clone());
    assert!(
        back == text,
        "{name}: written back differs:\n--- fixture\n{text}\n--- written\n{back}"
    );
    jf.journal
}

#[test]
fn an_mc6000_dataset_upload_journal_is_written_back_byte_for_byte() {
    let j = round_trip("mc6000-dataset-upload.journal.json");
    assert_eq!(j.state, TxnState::Complete);
    assert!(j.dataset);
    assert!(
        j.plan
            .iter()
            .any(|p| p.storage == Storage::CardWriteable && p.phase == Phase::Dataset)
    );
}

#[test]
fn a_failed_tmd_upload_journal_is_written_back_byte_for_byte() {
    let j = round_trip("tmd-failed-upload.journal.json");
    assert_eq!(j.state, TxnState::Failed);
    assert!(j.failure_cause.is_some());
    assert!(!j.holding.is_empty());
}

#[test]
fn transfer_rate_switch_journals_are_written_back_byte_for_byte() {
    let j = round_trip("transfer-rate-switch.journal.json");
    let t = j.transfer.expect("transfer record");
    assert!(t.is_back());
    assert!(t.keep.is_some());
    let cut = round_trip("transfer-rate-switch-cut.journal.json");
    assert!(!cut.is_finished());
    assert_eq!(cut.transfer.expect("transfer record").keep, None);
}

#[test]
fn an_address_change_journal_is_written_back_byte_for_byte() {
    let j = round_trip("address-change.journal.json");
    assert!(j.assign.is_some());
    assert_eq!(j.written, ["82-SADDR = 5 at address 0"]);
}

#[test]
fn a_version_1_journal_is_read_and_written_back_in_todays_form() {
    let j = open("v1-upload.journal.json").journal;
    assert_eq!(j.journal_version, 1);
    assert_eq!(j.target.bus, None);
    assert!(j.unchanged.is_empty());
    let expected =
        std::fs::read_to_string(dir().join("v1-upload.written-back.json")).expect("fixture");
    assert_eq!(written(j), expected);
}

/// A plan entry's `storage` or `phase` that names nothing the engine knows
/// is refused as a journal error naming the file and the field, not read
/// as some other kind.
#[test]
fn an_unknown_storage_or_phase_is_a_journal_error_naming_file_and_field() {
    let text =
        std::fs::read_to_string(dir().join("mc6000-dataset-upload.journal.json")).expect("fixture");
    let tmp = tempfile::tempdir().expect("tmp");
    for (field, from, to) in [
        ("storage", r#""storage": "ram""#, r#""storage": "flash""#),
        ("phase", r#""phase": "link""#, r#""phase": "later""#),
    ] {
        assert!(text.contains(from), "{from}");
        let path = tmp.path().join(format!("{field}.journal.json"));
        std::fs::write(&path, text.replacen(from, to, 1)).expect("write");
        let e = JournalFile::open(&path)
            .expect_err("an unknown name")
            .to_string();
        let name = to.rsplit('"').nth(1).expect("name");
        assert!(
            e.starts_with(&format!("journal {}: is not a driveset journal (plan entry `{field}`: unknown name `{name}`, expected one of ", path.display())),
            "{e}"
        );
    }
}

/// The identity's `protocol` is read typed: a name the engine writes is
/// its protocol (a family's, or a bus's for a drive only probed); any other
/// is a journal error naming the file and the field.
#[test]
fn an_unknown_identity_protocol_is_a_journal_error_naming_file_and_field() {
    use driveset_engine::client::IdentProtocol;
    use driveset_schema::{BusProtocol, Family};

    assert_eq!(
        open("mc6000-dataset-upload.journal.json")
            .journal
            .identity
            .protocol,
        IdentProtocol::Family(Family::Mc6000)
    );
    assert_eq!(
        open("tmd-failed-upload.journal.json")
            .journal
            .identity
            .protocol,
        IdentProtocol::Family(Family::Tmd)
    );
    // the address change's own record keeps the bus it ran on
    let a = open("address-change.journal.json").journal;
    assert_eq!(a.identity.protocol, IdentProtocol::Family(Family::Mc6000));
    assert_eq!(
        a.assign.expect("assign record").protocol,
        BusProtocol::Lustbus
    );
    let text =
        std::fs::read_to_string(dir().join("mc6000-dataset-upload.journal.json")).expect("fixture");
    let from = r#""protocol": "lustbus-mc""#;
    assert!(text.contains(from), "{from}");
    let tmp = tempfile::tempdir().expect("tmp");
    let path = tmp.path().join("protocol.journal.json");
    std::fs::write(&path, text.replacen(from, r#""protocol": "profibus""#, 1)).expect("write");
    let e = JournalFile::open(&path)
        .expect_err("an unknown name")
        .to_string();
    assert!(
        e.starts_with(&format!(
            "journal {}: is not a driveset journal (identity `protocol`: unknown name `profibus`, expected one of lustbus-mc, lustbus-vf1000, lecom, lenze-can-sdo, lustbus, can",
            path.display()
        )),
        "{e}"
    );
}
