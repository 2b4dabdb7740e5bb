//! Transaction runner tests over an in-memory fake drive (`support::fake`).

use std::time::Duration;

use crate::support::fake::*;
use driveset_engine::client::{IdentCode, IdentProtocol, IdentValue};
use driveset_engine::error::{EngineError, ErrorKind, InputFailure, Refused, TransactionOutcome};
use driveset_engine::journal::{JournalFile, Mismatch, NotJournalDrive, TxnState};
use driveset_engine::overrides::{Override, Overrides};
use driveset_engine::plan::{Phase, PlanOptions, Storage, plan};
use driveset_engine::recover::{RecoverAction, RecoverOptions, recover};
use driveset_engine::upload::{CodeOutcome, UploadOptions, prepare, upload};
use driveset_schema::{CodeKey, Family, RawValue};

fn ms(n: u64) -> u64 {
    n * 1_000_000
}

fn tmd_drive() -> Drive {
    Drive::new(
        Family::Tmd,
        [
            (k(1), RawValue::Int(0)),
            (k(2), RawValue::Int(0)),
            (k(11), RawValue::Int(500_000)),
            (k(12), RawValue::Int(50_000)),
            (k(13), RawValue::Int(50_000)),
            (k(14), RawValue::Int(20_000)),
            (CodeKey::sub(39, 1), RawValue::Int(0)),
            (CodeKey::sub(39, 2), RawValue::Int(0)),
            (k(40), RawValue::Int(10_000)), // enabled: the set inhibits it
            (k(46), RawValue::Int(0)),
            (k(50), RawValue::Int(123)),
            (k(94), RawValue::Int(0)),
            (k(135), RawValue::Int(0)),
        ],
    )
}

fn mc_drive() -> Drive {
    Drive::new(
        Family::Mc6000,
        [
            (k(4), RawValue::Int(0)),
            (k(81), RawValue::Int(9600)),
            (k(82), RawValue::Int(1)),
            (k(91), RawValue::Int(4711)),
            (k(100), RawValue::Int(0)),
            (k(101), RawValue::Int(10)),
            (k(102), RawValue::Int(0)),
            (k(110), RawValue::Int(0)),
            (k(111), RawValue::Int(0)),
            (k(112), RawValue::Int(0)),
            (k(120), RawValue::Int(0)),
            (k(130), RawValue::Int(1357)),
            (k(140), RawValue::Int(7)),
        ],
    )
}

fn tmd_set() -> driveset_schema::ResolvedSet {
    let s = tmd_schema();
    set_of(
        &s,
        &[
            (k(1), 30_000),
            (k(11), 600_000),
            (k(12), 25_000),
            (k(13), 50_000), // unchanged
            (k(14), 40_000),
            (k(40), 0),
            (k(135), 0x0008),
            (CodeKey::sub(39, 1), 200_000),
        ],
    )
}

fn journal_in(dir: &tempfile::TempDir) -> std::path::PathBuf {
    dir.path().join("drive.journal.json")
}

/// An MC set of two card-writeable values (100, 101: the dataset) and two
/// others (111 EEPROM, 120 RAM).
fn mc_dataset_set(schema: &driveset_schema::Schema) -> driveset_schema::ResolvedSet {
    set_of(
        schema,
        &[(k(100), 65536), (k(101), 20), (k(111), 5), (k(120), -3)],
    )
}

/// What an upload of [`mc_dataset_set`] sends, reads aside: the dataset
/// (100, 101) between begin and commit, then 111 and 120.
fn mc_dataset_ops() -> Vec<Op> {
    vec![
        Op::Begin,
        Op::Write(k(100), RawValue::Int(65536)),
        Op::Write(k(101), RawValue::Int(20)),
        Op::Commit,
        Op::Write(k(111), RawValue::Int(5)),
        Op::Write(k(120), RawValue::Int(-3)),
    ]
}

/// What most Tmd upload tests start from: the Tmd schema, a temporary
/// directory (keep it while the test runs) with the journal's path in it,
/// and [`tmd_set`].
fn tmd_upload() -> (
    std::sync::Arc<driveset_schema::Schema>,
    tempfile::TempDir,
    std::path::PathBuf,
    driveset_schema::ResolvedSet,
) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = journal_in(&dir);
    (tmd_schema(), dir, path, tmd_set())
}

/// `recover` of the journal at `path` through `c` is refused: the drive is
/// not the journal's, for `mismatch`. The client and the error, for the
/// caller's checks of the message and of what was sent.
fn recover_refused(
    mut c: FakeClient,
    path: &std::path::Path,
    mismatch: Mismatch,
) -> (FakeClient, EngineError) {
    let err = recover(&mut c, path, &RecoverOptions::default()).expect_err("refused");
    assert!(
        matches!(&*err.kind, ErrorKind::Refusal(Refused::NotJournalDrive(NotJournalDrive { mismatch: m, .. })) if *m == mismatch),
        "{err}"
    );
    (c, err)
}

#[test]
fn plan_orders_stored_then_control_then_mode_with_c0001_last() {
    let schema = tmd_schema();
    let set = tmd_set();
    let current =
        FakeClient::new(schema.clone(), tmd_drive()).values_of(set.values.keys().copied());
    let p = plan(&schema, &set, &current, &PlanOptions::default()).expect("plan");
    let order: Vec<(u32, Option<u32>, Phase)> = p
        .writes
        .iter()
        .map(|w| (w.key.number, w.key.subcode, w.phase))
        .collect();
    assert_eq!(
        order,
        vec![
            (11, None, Phase::Stored),
            (12, None, Phase::Stored),
            (39, Some(1), Phase::Stored),
            (40, None, Phase::Control),
            (135, None, Phase::Control),
            (14, None, Phase::Mode),
            (1, None, Phase::Mode),
        ]
    );
    assert_eq!(p.unchanged, vec![k(13)]);
    assert!(p.writes.iter().all(|w| w.storage == Storage::Unspecified));
    let text = p.render(None);
    assert!(
        text.contains("C0011 max_output_frequency: 50 Hz -> 60 Hz"),
        "{text}"
    );
    assert!(text.contains("operating mode / control source:"), "{text}");
}

#[test]
fn mc_plan_puts_card_writeable_values_in_the_dataset_and_classifies_storage() {
    let schema = mc_schema();
    let set = set_of(
        &schema,
        &[
            (k(100), 65536),
            (k(101), 20),
            (k(111), 5),
            (k(120), -3),
            (k(110), 1),
        ],
    );
    let current = FakeClient::new(schema.clone(), mc_drive()).values_of(set.values.keys().copied());
    let opts = PlanOptions {
        dataset: true,
        ..Default::default()
    };
    let p = plan(&schema, &set, &current, &opts).expect("plan");
    let got: Vec<(u32, Storage, Phase, u128)> = p
        .writes
        .iter()
        .map(|w| (w.key.number, w.storage, w.phase, w.store_time.as_millis()))
        .collect();
    assert_eq!(
        got,
        vec![
            (100, Storage::CardWriteable, Phase::Dataset, 0),
            (101, Storage::CardWriteable, Phase::Dataset, 0),
            (110, Storage::Eeprom, Phase::Stored, 60),
            (111, Storage::Eeprom, Phase::Stored, 30),
            (120, Storage::Ram, Phase::Control, 0),
        ]
    );
    assert!(p.dataset);
    let text = p.render(None);
    assert!(text.contains("100-KPA: 0 1/min -> 1 1/min"), "{text}");
    assert!(text.contains("EEPROM 4 B, store 60 ms"), "{text}");
}

#[test]
fn refuses_unknown_read_only_status_and_handshake_codes_before_sending_anything() {
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut set = set_of(
        &schema,
        &[
            (k(999), 1),
            (k(140), 1),
            (k(91), 1),
            (k(85), 0),
            (k(80), -1),
        ],
    );
    set.insert(k(101), RawValue::Int(11));
    let mut client = FakeClient::new(schema, mc_drive());
    let err =
        upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect_err("refused");
    let text = err.to_string();
    assert!(
        matches!(*err.error.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{text}"
    );
    for needle in [
        "999",
        "140-ACT: read-only",
        "91-TYPE: read-only",
        "85-SERR",
        "80-SLOAD",
    ] {
        assert!(text.contains(needle), "{needle} in {text}");
    }
    assert!(client.log.is_empty(), "nothing sent: {:?}", client.log);
    assert!(!journal_in(&dir).exists());
}

#[test]
fn refuses_a_running_drive_without_allow_running_and_another_schema_without_allow_family() {
    let schema = tmd_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut drive = tmd_drive();
    drive.running = Some(true);
    let set = set_of(&schema, &[(k(11), 600_000)]);
    let mut client = FakeClient::new(schema.clone(), drive.clone());
    let err =
        upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect_err("running");
    assert!(err.to_string().contains("running motor"), "{err}");
    assert!(client.writes_logged().is_empty());

    // another override does not lift it
    let mut opts = UploadOptions::new(journal_in(&dir));
    opts.overrides = Overrides::only(Override::AllowFamily);
    let mut client = FakeClient::new(schema.clone(), drive.clone());
    let err = upload(&mut client, &set, &opts).expect_err("running");
    assert_eq!(
        err.to_string(),
        "fake0 address 1: refused: the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running"
    );
    assert!(client.writes_logged().is_empty());

    let mut opts = UploadOptions::new(journal_in(&dir));
    opts.overrides = Overrides::only(Override::AllowRunning);
    let mut client = FakeClient::new(schema.clone(), drive);
    let report = upload(&mut client, &set, &opts).expect("allowed");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(
        report.warnings,
        vec!["--allow-running: the drive reports a running motor".to_string()]
    );

    let mut other = set_of(&schema, &[(k(11), 600_000)]);
    other.schema = "lenze-tmd".into();
    let mut client = FakeClient::new(schema.clone(), tmd_drive());
    let dir2 = tempfile::tempdir().expect("tempdir");
    let err =
        upload(&mut client, &other, &UploadOptions::new(journal_in(&dir2))).expect_err("schema");
    assert!(err.to_string().contains("schema `lenze-tmd`"), "{err}");

    // a drive identifying as another family
    let mut drive = tmd_drive();
    drive.identity.protocol = IdentProtocol::Family(Family::Mc6000);
    let mut client = FakeClient::new(schema, drive);
    let err =
        upload(&mut client, &set, &UploadOptions::new(journal_in(&dir2))).expect_err("family");
    assert!(err.to_string().contains("lustbus-mc"), "{err}");
    assert!(client.writes_logged().is_empty());
}

#[test]
fn refuses_commands_with_no_override_and_bad_subcodes() {
    let schema = tmd_schema();
    let set = set_of(
        &schema,
        &[
            (k(2), 10_000),
            (CodeKey::sub(39, 3), 1),
            (CodeKey::sub(11, 1), 1),
        ],
    );
    let current =
        FakeClient::new(schema.clone(), tmd_drive()).values_of(set.values.keys().copied());
    let problems = plan(&schema, &set, &current, &PlanOptions::default()).expect_err("refused");
    let all = problems
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        all.contains("C0002 = 1 is a command (Load Lenze setting), not a setting; a set cannot hold it; remove this line: run the command on the drive itself, never from a set"),
        "{all}"
    );
    // no override lifts it
    let every = PlanOptions {
        overrides: Override::ALL.into_iter().collect(),
        ..PlanOptions::default()
    };
    let again = plan(&schema, &set, &current, &every).expect_err("still refused");
    assert!(
        again
            .iter()
            .any(|p| p.to_string().contains("C0002 = 1 is a command")),
        "{again:?}"
    );
    assert!(
        all.contains("C0039/3: code 39 has subcodes 1..=2 only"),
        "{all}"
    );
    assert!(all.contains("C0011/1: code 11 has no subcodes"), "{all}");
}

#[test]
fn upload_writes_in_plan_order_verifies_and_completes_with_journal_before_first_write() {
    let (schema, _dir, path, set) = tmd_upload();
    let mut client = FakeClient::new(schema.clone(), tmd_drive()).with_journal(&path);
    let report = upload(&mut client, &set, &UploadOptions::new(&path)).expect("upload");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(report.codes_written, 7);
    assert_eq!(
        report.fingerprint_after.as_deref(),
        Some(set.fingerprint().as_str())
    );
    assert_eq!(
        client.values_of(set.values.keys().copied()).fingerprint(),
        set.fingerprint()
    );
    assert_eq!(
        client.writes_logged(),
        vec![
            k(11),
            k(12),
            CodeKey::sub(39, 1),
            k(40),
            k(135),
            k(14),
            k(1)
        ]
    );
    // the journal was on disk, complete, in state writing at the first write
    assert_eq!(
        client.journal_at_first_write,
        Some(("writing".into(), 7, 7))
    );
    let j = JournalFile::open(&path).expect("journal");
    assert_eq!(j.journal.state, TxnState::Complete);
    let states: Vec<TxnState> = j.journal.transitions.iter().map(|t| t.state).collect();
    assert_eq!(
        states,
        vec![
            TxnState::Planned,
            TxnState::Writing,
            TxnState::Verifying,
            TxnState::Complete
        ]
    );
    assert_eq!(j.journal.written.len(), 7);
    assert!(
        report
            .codes
            .iter()
            .filter(|c| c.outcome != CodeOutcome::Unchanged)
            .all(|c| c.outcome == CodeOutcome::Verified)
    );
    assert_eq!(report.telegrams, client.stats.telegrams);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).expect("meta").permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
    }
    // a second upload of the same set has nothing to do and writes no journal
    let dir2 = tempfile::tempdir().expect("tempdir");
    let report = upload(&mut client, &set, &UploadOptions::new(journal_in(&dir2))).expect("noop");
    assert_eq!(report.codes_written, 0);
    assert!(report.journal.is_none());
    assert!(!journal_in(&dir2).exists());
}

#[test]
fn a_failed_restore_does_not_stop_the_roll_back_of_the_other_codes() {
    let (schema, _dir, path, set) = tmd_upload();
    let before = tmd_drive();
    let mut client = FakeClient::new(schema.clone(), before.clone()).with_journal(&path);
    client.fail_write = Some(4); // C0040 refused
    client.also_fail_writes = vec![5]; // the restore of C0039/1 refused too
    let err = upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("fails");
    // C0012 and C0011 were still restored after C0039/1 failed.
    assert_eq!(
        client.writes_logged(),
        vec![
            k(11),
            k(12),
            CodeKey::sub(39, 1),
            k(40),
            CodeKey::sub(39, 1),
            k(12),
            k(11),
        ]
    );
    for key in [k(11), k(12), k(40)] {
        assert_eq!(
            client.drive.values.get(&key),
            before.values.get(&key),
            "{key:?}"
        );
    }
    assert_ne!(
        client.drive.values.get(&CodeKey::sub(39, 1)),
        before.values.get(&CodeKey::sub(39, 1))
    );
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::Inconsistent { .. })
        ),
        "{err}"
    );
    assert!(err.to_string().contains("driveset recover"), "{err}");
    let j = JournalFile::open(&path).expect("journal");
    assert_eq!(j.journal.state, TxnState::Failed);
}

#[test]
fn mid_transaction_write_failure_restores_exactly_the_old_values_in_reverse_order() {
    let (schema, _dir, path, set) = tmd_upload();
    let before = tmd_drive();
    let mut client = FakeClient::new(schema.clone(), before.clone()).with_journal(&path);
    client.fail_write = Some(4); // C0040
    let err = upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("fails");
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::RolledBack { .. })
        ),
        "{err}"
    );
    let text = err.to_string();
    assert!(
        text.contains("rolled back") && text.contains("invalid value"),
        "{text}"
    );
    assert_eq!(client.drive.values, before.values, "exactly the old values");
    assert_eq!(
        client.writes_logged(),
        vec![
            k(11),
            k(12),
            CodeKey::sub(39, 1),
            k(40), // refused by the drive ("invalid value"): not changed, not restored
            CodeKey::sub(39, 1), // restore, reverse order
            k(12),
            k(11),
        ]
    );
    let j = JournalFile::open(&path).expect("journal");
    assert_eq!(j.journal.state, TxnState::RolledBack);
    assert!(
        j.journal
            .failure
            .as_deref()
            .is_some_and(|f| f.contains("invalid value"))
    );
    let report = err.report.expect("report");
    assert_eq!(report.state, TxnState::RolledBack);
    let c40 = report.codes.iter().find(|c| c.number == 40).expect("c40");
    assert!(matches!(c40.outcome, CodeOutcome::Failed(_)));
    let c11 = report.codes.iter().find(|c| c.number == 11).expect("c11");
    assert_eq!(c11.outcome, CodeOutcome::Restored);
    let c1 = report.codes.iter().find(|c| c.number == 1).expect("c1");
    assert_eq!(c1.outcome, CodeOutcome::NotWritten);
}

#[test]
fn verify_mismatch_rolls_back() {
    let schema = tmd_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let set = tmd_set();
    let mut drive = tmd_drive();
    drive.ignore_writes_to = Some(k(12));
    let before = drive.values.clone();
    let mut client = FakeClient::new(schema, drive);
    let err =
        upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect_err("mismatch");
    let text = err.to_string();
    assert!(
        text.contains("verify C0012") && text.contains("reads back 5 s instead of 2.5 s"),
        "{text}"
    );
    // the drive was enabled (C0040 = 1, C0135 without an inhibit bit): the
    // rollback restores every other code and leaves both control words in
    // the stopped state the set gave them, saying so
    assert!(
        text.contains("C0040 controller_inhibit left stopped: the motor was running before; start it from the machine's control; C0135 control_word left stopped: the motor was running before; start it from the machine's control; the drive holds its old values again (verified)"),
        "{text}"
    );
    let mut stopped = before;
    stopped.insert(k(40), RawValue::Int(0));
    stopped.insert(k(135), RawValue::Int(8));
    assert_eq!(client.drive.values, stopped);
}

#[test]
fn failed_restore_marks_failed_names_codes_and_recover_finishes_the_roll_back() {
    let (schema, _dir, path, set) = tmd_upload();
    let before = tmd_drive();
    let mut client = FakeClient::new(schema.clone(), before.clone()).with_journal(&path);
    client.dead_after_writes = Some(3); // cable pulled after the third write
    let err = upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("fails");
    let text = err.to_string();
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::Inconsistent { .. })
        ),
        "{text}"
    );
    assert!(
        text.contains(&format!("driveset recover {}", path.display())),
        "{text}"
    );
    assert!(text.contains("could not be read"), "{text}");
    let j = JournalFile::open(&path).expect("journal");
    assert_eq!(j.journal.state, TxnState::Failed);
    assert_eq!(j.journal.holding.len(), 7);

    // the cable is back: recover from the journal alone
    let mut revived = FakeClient::new(schema.clone(), client.drive.clone());
    let r = recover(&mut revived, &path, &RecoverOptions::default()).expect("recover");
    assert_eq!(r.action, RecoverAction::RolledBack);
    assert_eq!(revived.drive.values, before.values);
    let old_fp = revived.values_of(set.values.keys().copied()).fingerprint();
    assert_eq!(r.fingerprint.as_deref(), Some(old_fp.as_str()));
    assert_eq!(
        JournalFile::open(&path).expect("j").journal.state,
        TxnState::RolledBack
    );
    // recover again: nothing to do
    let r = recover(&mut revived, &path, &RecoverOptions::default()).expect("recover");
    assert_eq!(r.action, RecoverAction::Nothing);
}

#[test]
fn an_unfinished_journal_blocks_a_new_upload() {
    let (schema, _dir, path, set) = tmd_upload();
    let mut client = FakeClient::new(schema.clone(), tmd_drive());
    client.dead_after_writes = Some(2);
    upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("fails");
    let mut client = FakeClient::new(schema, client.drive.clone());
    let err = upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("blocked");
    assert!(err.to_string().contains("unfinished transaction"), "{err}");
    assert!(client.writes_logged().is_empty());
}

#[test]
fn mc_dataset_accepted_then_non_card_values_then_verify() {
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = journal_in(&dir);
    let set = mc_dataset_set(&schema);
    let mut client = FakeClient::new(schema, mc_drive()).with_journal(&path);
    let report = upload(&mut client, &set, &UploadOptions::new(&path)).expect("upload");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(report.dataset.as_deref(), Some("accepted (SLOAD = 0)"));
    assert_eq!(client.changes_logged(), mc_dataset_ops());
    assert_eq!(
        client.values_of(set.values.keys().copied()).fingerprint(),
        set.fingerprint()
    );
    let j = JournalFile::open(&path).expect("journal");
    let states: Vec<TxnState> = j.journal.transitions.iter().map(|t| t.state).collect();
    assert_eq!(
        states,
        vec![
            TxnState::Planned,
            TxnState::Writing,
            TxnState::Committed,
            TxnState::Verifying,
            TxnState::Complete
        ]
    );
    assert!(j.journal.dataset);
}

#[test]
fn mc_dataset_rejected_names_the_parameter_and_leaves_the_drive_unchanged() {
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = journal_in(&dir);
    let set = set_of(&schema, &[(k(100), 65536), (k(101), 20), (k(111), 5)]);
    let mut drive = mc_drive();
    drive.reject_dataset_at = Some(101);
    let before = drive.values.clone();
    let mut client = FakeClient::new(schema, drive).with_journal(&path);
    let err = upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("rejected");
    let text = err.to_string();
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::RolledBack { .. })
        ),
        "{text}"
    );
    assert!(
        text.contains("rejected the dataset at parameter 101-KPB"),
        "{text}"
    );
    assert_eq!(client.drive.values, before);
    assert!(
        !client.writes_logged().contains(&k(111)),
        "non-card values not written"
    );
    let j = JournalFile::open(&path).expect("journal");
    assert_eq!(j.journal.state, TxnState::RolledBack);
    let report = err.report.expect("report");
    assert_eq!(
        report.dataset.as_deref(),
        Some("rejected at parameter 101-KPB")
    );
}

#[test]
fn mc_failure_after_commit_restores_card_values_through_a_new_dataset() {
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let set = mc_dataset_set(&schema);
    let before = mc_drive();
    let mut client = FakeClient::new(schema, before.clone());
    client.fail_write = Some(4); // 120, after 111: refused by the drive, so not restored
    let err = upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect_err("fails");
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::RolledBack { .. })
        ),
        "{err}"
    );
    assert_eq!(client.drive.values, before.values);
    let ops = client.changes_logged();
    assert_eq!(
        ops[6..],
        [
            Op::Write(k(111), RawValue::Int(0)),
            Op::Begin,
            Op::Write(k(100), RawValue::Int(0)),
            Op::Write(k(101), RawValue::Int(10)),
            Op::Commit,
        ]
    );
}

#[test]
fn eeprom_gaps_are_filled_with_verification_reads_and_time_matches_the_estimate() {
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    // three non-card EEPROM values (4, 2, 4 bytes) and one RAM value
    let set = set_of(
        &schema,
        &[(k(110), 1), (k(111), 2), (k(112), 3), (k(120), 4)],
    );
    let mut client = FakeClient::new(schema.clone(), mc_drive());
    let prepared = prepare(&mut client, &set, Overrides::none()).expect("prepare");
    let mut client = FakeClient::new(schema, mc_drive());
    let report = upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect("upload");
    let ops: Vec<(u64, Op)> = client.log.clone();
    let ops_no_id: Vec<(u64, Op)> = ops
        .into_iter()
        .filter(|(_, o)| !matches!(o, Op::Identify | Op::Running))
        .collect();
    // r = 10 ms, w = 20 ms, store 15 ms/byte
    let expected = vec![
        (ms(0), Op::Read(k(110))),
        (ms(10), Op::Read(k(111))),
        (ms(20), Op::Read(k(112))),
        (ms(30), Op::Read(k(120))),
        (ms(40), Op::Write(k(110), RawValue::Int(1))), // busy until 60 + 60 = 120
        (ms(60), Op::Read(k(110))),                    // verify in the gap
        (ms(120), Op::Write(k(111), RawValue::Int(2))), // busy until 140 + 30 = 170
        (ms(140), Op::Read(k(111))),                   // verify in the gap
        (ms(170), Op::Write(k(112), RawValue::Int(3))), // busy until 250
        (ms(190), Op::Write(k(120), RawValue::Int(4))), // RAM: no wait
        (ms(210), Op::Read(k(112))),
        (ms(220), Op::Read(k(120))),
    ];
    assert_eq!(ops_no_id, expected);
    // bound: read back 4r, (w + 60) + (w + 30) + w + w (RAM), 2 trailing
    // reads, then the last save (112: busy until 250) waited out before the
    // transaction settles (§3: the MC saves in the background)
    let bound = Duration::from_millis(4 * 10 + (20 + 60) + (20 + 30) + 20 + 20 + 2 * 10 + 20);
    assert_eq!(report.elapsed, bound);
    assert_eq!(report.interleaved_reads, 2);
    assert_eq!(prepared.estimate.total, bound);
    assert_eq!(prepared.estimate.waits, Duration::from_millis(50 + 20 + 20));
    let text = prepared.plan.render(Some(&prepared.estimate));
    assert!(text.contains("expected time: 0.250 s"), "{text}");
}

#[test]
fn a_restart_voids_the_attempt_which_is_redone_once_then_fails() {
    let (schema, _dir, path, set) = tmd_upload();
    let mut client = FakeClient::new(schema.clone(), tmd_drive()).with_journal(&path);
    client.restart_at_writes = vec![3];
    let report = upload(&mut client, &set, &UploadOptions::new(&path)).expect("redone");
    assert_eq!(report.attempts, 2);
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(
        client.values_of(set.values.keys().copied()).fingerprint(),
        set.fingerprint()
    );
    let j = JournalFile::open(&path).expect("journal");
    // the backup is the first attempt's: C0011 old value 50 Hz
    let b11 = j
        .journal
        .backup
        .iter()
        .find(|b| b.number == 11)
        .expect("11");
    assert_eq!(
        b11.old,
        driveset_engine::journal::JournalValue::Int(500_000)
    );
    assert_eq!(j.journal.attempt, 2);

    // restarted twice: the redo is bounded, the drive is rolled back
    let dir = tempfile::tempdir().expect("tempdir");
    let before = tmd_drive();
    let mut client = FakeClient::new(schema, before.clone());
    client.restart_at_writes = vec![2, 5];
    let err = upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect_err("fails");
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::RolledBack { .. })
        ),
        "{err}"
    );
    assert!(err.to_string().contains("restarted"), "{err}");
    // C0040 was written (and is left stopped), C0135 never was
    let mut stopped = before.values;
    stopped.insert(k(40), RawValue::Int(0));
    assert_eq!(client.drive.values, stopped);
    assert!(
        err.to_string()
            .contains("C0040 controller_inhibit left stopped: the motor was running before"),
        "{err}"
    );
}

#[test]
fn passwords_never_appear_in_plan_report_or_errors() {
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let set = set_of(&schema, &[(k(130), 2468), (k(111), 9)]);
    let mut client = FakeClient::new(schema.clone(), mc_drive());
    let prepared = prepare(&mut client, &set, Overrides::none()).expect("prepare");
    let text = prepared.plan.render(Some(&prepared.estimate));
    assert!(text.contains("130-PASS: <secret> -> <secret>"), "{text}");
    assert!(!text.contains("2468") && !text.contains("1357"), "{text}");
    let report = upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect("upload");
    let rendered = report.render();
    let json = serde_json::to_string(&report).expect("json");
    for t in [&rendered, &json] {
        assert!(!t.contains("2468") && !t.contains("1357"), "{t}");
    }
    // a password that does not verify: the error does not show it either
    let dir = tempfile::tempdir().expect("tempdir");
    let mut drive = mc_drive();
    drive.ignore_writes_to = Some(k(130));
    let mut client = FakeClient::new(schema, drive);
    let err =
        upload(&mut client, &set, &UploadOptions::new(journal_in(&dir))).expect_err("mismatch");
    let text = format!("{err} {:?}", err.report);
    assert!(!text.contains("2468") && !text.contains("1357"), "{text}");
    // the journal does hold it (so it can be restored), with secret = true
    let j = JournalFile::open(&journal_in(&dir)).expect("journal");
    let b = j
        .journal
        .backup
        .iter()
        .find(|b| b.number == 130)
        .expect("130");
    assert!(b.secret);
}

/// Replays a crash at every snapshot: the drive as it was before each
/// mutating operation and the journal file as it was on disk then; recover
/// must end with exactly the old or exactly the new set.
fn crash_everywhere(
    schema: std::sync::Arc<driveset_schema::Schema>,
    drive: Drive,
    set: &driveset_schema::ResolvedSet,
    setup: impl Fn(&mut FakeClient),
) -> (usize, usize) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = journal_in(&dir);
    let keys: Vec<CodeKey> = set.values.keys().copied().collect();
    let old_fp = FakeClient::new(schema.clone(), drive.clone())
        .values_of(keys.clone())
        .fingerprint();
    let new_fp = set.fingerprint();
    let drive_before = drive.clone();
    let mut client = FakeClient::new(schema.clone(), drive).with_journal(&path);
    setup(&mut client);
    let _ = upload(&mut client, set, &UploadOptions::new(&path));
    let mut snaps = client.snapshots.clone();
    snaps.push(Snapshot {
        drive: client.drive.clone(),
        journal: std::fs::read(&path).ok(),
        op: Op::Identify,
    });
    let (mut to_old, mut to_new) = (0, 0);
    for (i, s) in snaps.iter().enumerate() {
        let p = dir.path().join(format!("crash-{i}.json"));
        let Some(bytes) = &s.journal else { continue };
        std::fs::write(&p, bytes).expect("write journal copy");
        let mut c = FakeClient::new(schema.clone(), s.drive.clone());
        let r = recover(&mut c, &p, &RecoverOptions::default())
            .unwrap_or_else(|e| panic!("snapshot {i} ({:?}): {e}", s.op));
        let holds = c.values_of(keys.clone()).fingerprint();
        // old values, where a control word whose old value ran may instead
        // hold the set's stopped value (a rollback never restarts a motor)
        let old_or_stopped = keys.iter().all(|key| {
            let now = c.drive.values.get(key);
            let cw = schema
                .code(key.number)
                .is_some_and(|code| code.has_role(driveset_schema::Role::ControlWord));
            now == drive_before.values.get(key) || (cw && now == set.values.get(key))
        });
        assert!(
            holds == old_fp || holds == new_fp || old_or_stopped,
            "snapshot {i} ({:?}): drive holds a mix",
            s.op
        );
        assert!(c.drive.staged.is_none(), "snapshot {i}: dataset left open");
        if r.action != RecoverAction::Nothing {
            assert_eq!(r.fingerprint.as_deref(), Some(holds.as_str()));
        }
        let state = JournalFile::open(&p).expect("journal").journal.state;
        assert!(state.is_settled(), "snapshot {i}: {state:?}");
        if holds == new_fp {
            to_new += 1;
        } else {
            to_old += 1;
        }
    }
    (to_old, to_new)
}

#[test]
fn recover_after_a_crash_at_every_point_of_a_tmd_upload() {
    let (old, new) = crash_everywhere(tmd_schema(), tmd_drive(), &tmd_set(), |_| {});
    assert!(old >= 7 && new >= 1, "old {old} new {new}");
}

#[test]
fn recover_after_a_crash_at_every_point_of_an_mc_dataset_upload() {
    let schema = mc_schema();
    let set = mc_dataset_set(&schema);
    let (old, new) = crash_everywhere(schema, mc_drive(), &set, |_| {});
    assert!(old >= 4 && new >= 1, "old {old} new {new}");
}

#[test]
fn recover_after_a_crash_at_every_point_of_a_roll_back() {
    let (old, _new) = crash_everywhere(tmd_schema(), tmd_drive(), &tmd_set(), |c| {
        c.fail_write = Some(5)
    });
    assert!(old >= 9, "old {old}");
    let schema = mc_schema();
    let set = mc_dataset_set(&schema);
    let (old, _) = crash_everywhere(schema, mc_drive(), &set, |c| c.fail_write = Some(4));
    assert!(old >= 8, "old {old}");
}

#[test]
fn recover_completes_when_the_drive_holds_the_new_values() {
    let (schema, _dir, path, set) = tmd_upload();
    let mut client = FakeClient::new(schema.clone(), tmd_drive()).with_journal(&path);
    upload(&mut client, &set, &UploadOptions::new(&path)).expect("upload");
    // the snapshot before the last verification: all writes done, journal "writing"
    let s = client.snapshots.last().expect("snapshot").clone();
    let mut drive = s.drive.clone();
    drive.values.insert(k(1), RawValue::Int(30_000)); // the last write landed
    std::fs::write(&path, s.journal.expect("journal")).expect("write");
    let mut c = FakeClient::new(schema, drive);
    let r = recover(&mut c, &path, &RecoverOptions::default()).expect("recover");
    assert_eq!(r.found, TxnState::Writing);
    assert_eq!(r.action, RecoverAction::Completed);
    assert_eq!(r.fingerprint.as_deref(), Some(set.fingerprint().as_str()));
    assert!(c.writes_logged().is_empty());
}

#[test]
fn recover_refuses_another_drive() {
    let (schema, _dir, path, set) = tmd_upload();
    let mut client = FakeClient::new(schema.clone(), tmd_drive());
    client.dead_after_writes = Some(2);
    upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("fails");
    let mut drive = client.drive.clone();
    drive.identity.codes = vec![IdentCode::new(
        CodeKey::new(91),
        "91 TYPE",
        IdentValue::Int(9999),
    )];
    let (c, err) = recover_refused(FakeClient::new(schema, drive), &path, Mismatch::Identity);
    assert_eq!(
        err.to_string(),
        format!(
            "fake0 address 1: refused to recover journal {}: the drive identifies as lecom: 91 TYPE = 9999 but the journal was written for lecom: 91 TYPE = 4711; nothing was written. Connect the drive the journal belongs to",
            path.display()
        )
    );
    assert!(c.writes_logged().is_empty());
}

#[test]
fn pull_reads_every_readable_code_skips_and_reports_the_rest() {
    use driveset_engine::pull::{PullOptions, pull};
    let schema = tmd_schema();
    let mut drive = tmd_drive();
    drive.missing.insert(k(46));
    drive.values.insert(k(94), RawValue::Int(77));
    let mut client = FakeClient::new(schema.clone(), drive);
    let pulled = pull(&mut client, &PullOptions::default()).expect("pull");
    let skipped: Vec<(String, &str)> = pulled
        .skipped
        .iter()
        .map(|s| (s.code.clone(), s.reason.split(' ').next().unwrap_or("")))
        .collect();
    assert_eq!(
        skipped,
        vec![
            ("C0002 load_lenze_setting".to_string(), "role"),
            ("C0040 controller_inhibit".to_string(), "role"),
            ("C0046 frequency_setpoint".to_string(), "the"),
            ("C0094 user_password".to_string(), "password"),
            ("C0135 control_word".to_string(), "role"),
            ("C0200 unknown_type_code".to_string(), "the"),
        ]
    );
    assert_eq!(
        pulled.skipped[0].reason,
        "role `command`: left out, a set cannot hold it"
    );
    assert_eq!(
        pulled.skipped[4].reason,
        "role `control-word`: left out, a set cannot hold it"
    );
    assert!(pulled.skipped[2].reason.contains("no parameter"));
    assert_eq!(pulled.read, 8);
    assert!(pulled.set.values.contains_key(&CodeKey::sub(39, 2)));
    assert!(!pulled.set.values.contains_key(&k(94)));
    assert_eq!(pulled.fingerprint, pulled.set.fingerprint());
    assert_eq!(pulled.identity.protocol, IdentProtocol::Family(Family::Tmd));

    let mut client = FakeClient::new(schema, tmd_drive());
    let opts = PullOptions {
        changed_only: true,
        include_passwords: true,
        keep_bus_codes: false,
    };
    let changed = pull(&mut client, &opts).expect("pull");
    // defaults: C0001 0, C0011 50, C0012 5, C0013 5, C0014 2 (C0002 and C0040 are not pulled)
    assert_eq!(changed.dropped_defaults, 5);
    assert!(changed.set.values.contains_key(&k(94)));
    assert!(!changed.set.values.contains_key(&k(11)));
    assert_ne!(changed.fingerprint, changed.full_fingerprint);
}

#[test]
fn live_diff_shows_what_an_upload_would_change() {
    use driveset_engine::live::live_diff;
    let schema = tmd_schema();
    let mut client = FakeClient::new(schema.clone(), tmd_drive());
    let d = live_diff(&mut client, &tmd_set()).expect("diff");
    let lines: Vec<&str> = d.entries.iter().map(|e| e.text.as_str()).collect();
    assert_eq!(d.entries.len(), 7);
    assert!(
        lines.contains(&"C0011 max_output_frequency: 50 Hz -> 60 Hz"),
        "{lines:?}"
    );
    assert!(client.writes_logged().is_empty());
    let mut other = tmd_set();
    other.insert(k(999), RawValue::Int(1));
    let err = live_diff(&mut client, &other).expect_err("unknown");
    assert!(err.to_string().contains("C0999"), "{err}");
}

#[test]
fn a_bus_address_change_is_refused_and_the_baud_rate_goes_last() {
    let schema = mc_schema();
    let drive = FakeClient::new(schema.clone(), mc_drive());
    let set = set_of(
        &schema,
        &[(k(82), 4), (k(81), 19200), (k(111), 3), (k(120), 1)],
    );
    let current = drive.values_of(set.values.keys().copied());
    let problems = plan(&schema, &set, &current, &PlanOptions::default()).expect_err("refused");
    assert!(
        problems.iter().any(|p| p
            .to_string()
            .contains("82-SADDR: 1 -> 4 changes the bus address")),
        "{problems:?}"
    );
    let set = set_of(
        &schema,
        &[(k(82), 1), (k(81), 19200), (k(111), 3), (k(120), 1)],
    );
    let p = plan(&schema, &set, &current, &PlanOptions::default()).expect("plan");
    let order: Vec<(u32, Phase)> = p.writes.iter().map(|w| (w.key.number, w.phase)).collect();
    assert_eq!(
        order,
        vec![
            (111, Phase::Stored),
            (120, Phase::Control),
            (81, Phase::Link)
        ]
    );
    assert!(
        p.warnings
            .iter()
            .any(|w| w.contains("81-SBAUD changes the baud rate"))
    );
}

/// A version 1 journal (no bus id) is still read: the guard matches it by
/// port and address; `recover` refuses it, nothing sent.
#[test]
fn version_1_journals_block_their_drive_and_recover_refuses_them() {
    let (schema, dir, path, set) = tmd_upload();
    let mut client = FakeClient::new(schema.clone(), tmd_drive());
    client.dead_after_writes = Some(2);
    upload(&mut client, &set, &UploadOptions::new(&path)).expect_err("fails");
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("read")).expect("json");
    assert_eq!(j["journal_version"], 2);
    assert_eq!(j["target"]["bus"], "fake:fake0");
    j["journal_version"] = 1.into();
    j["target"].as_object_mut().expect("target").remove("bus");
    std::fs::write(&path, j.to_string()).expect("write");
    let drive = client.drive.clone();
    // the guard: another journal name, the same drive by port and address
    let mut c = FakeClient::new(schema.clone(), drive.clone());
    let other = dir.path().join("other.journal.json");
    let err = upload(&mut c, &set, &UploadOptions::new(&other)).expect_err("guarded");
    assert_eq!(
        err.to_string(),
        format!(
            "journal {p}: the drive at fake0 address 1 has an unfinished transaction ({p} (state failed)); nothing was sent. Run `driveset recover {p}` first",
            p = path.display()
        )
    );
    let (c, err) = recover_refused(FakeClient::new(schema, drive), &path, Mismatch::Version);
    assert_eq!(
        err.to_string(),
        format!(
            "fake0 address 1: refused to recover journal {}: it has journal version 1, which does not record the drive's bus, so driveset cannot check that it reaches the drive the journal was written for; nothing was sent. Finish it with the driveset release that wrote it, or restore the drive by hand from the journal's backup",
            path.display()
        )
    );
    assert!(c.log.is_empty(), "{:?}", c.log);
}

/// Every event an observer gets, in order.
#[derive(Default)]
struct EventLog(std::sync::Mutex<Vec<driveset_engine::observe::Event>>);

impl driveset_engine::observe::Observer for EventLog {
    fn event(&self, _at: driveset_link::Instant, event: driveset_engine::observe::Event) {
        self.0.lock().unwrap().push(event);
    }
}

/// Upload options journaling to `journal`, every event going to the
/// returned log.
fn observed(journal: std::path::PathBuf) -> (std::sync::Arc<EventLog>, UploadOptions) {
    let log = std::sync::Arc::new(EventLog::default());
    let mut opts = UploadOptions::new(journal);
    opts.observer = driveset_engine::observe::Hook::new(log.clone());
    (log, opts)
}

impl EventLog {
    fn phases(&self) -> Vec<driveset_engine::observe::Phase> {
        use driveset_engine::observe::Event;
        let mut out: Vec<_> = Vec::new();
        for e in self.0.lock().unwrap().iter() {
            if let Event::Enter { phase, .. } = e
                && out.last() != Some(phase)
            {
                out.push(*phase);
            }
        }
        out
    }

    fn steps(&self, of: driveset_engine::observe::Phase) -> Vec<(usize, usize)> {
        use driveset_engine::observe::Event;
        self.0
            .lock()
            .unwrap()
            .iter()
            .filter_map(|e| match e {
                Event::Step { phase, done, total } if *phase == of => Some((*done, *total)),
                _ => None,
            })
            .collect()
    }
}

#[test]
fn the_observer_sees_a_rollback_as_rollback_not_as_writes_and_reads() {
    use driveset_engine::observe::{Event, Phase as P};
    // the MC6000 failure after the dataset's commit: its restore writes and
    // the card values' new dataset are the rollback's, and say so
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let set = mc_dataset_set(&schema);
    let mut client = FakeClient::new(schema, mc_drive());
    client.fail_write = Some(4); // 120: refused by the drive
    let (log, opts) = observed(journal_in(&dir));
    let err = upload(&mut client, &set, &opts).expect_err("fails");
    assert!(
        matches!(
            *err.error.kind,
            ErrorKind::Transaction(TransactionOutcome::RolledBack { .. })
        ),
        "{err}"
    );
    assert_eq!(
        log.phases(),
        [
            P::Identify,
            P::Read,
            P::Plan,
            P::Journal,
            P::Dataset,
            P::Write,
            P::Commit,
            P::Write,
            P::Rollback,
        ]
    );
    // code i of n: the read-back of the 4 codes, then 3 writes acknowledged
    // (the fourth was refused)
    assert_eq!(log.steps(P::Read), [(1, 4), (2, 4), (3, 4), (4, 4)]);
    assert_eq!(log.steps(P::Write), [(1, 4), (2, 4), (3, 4)]);
    assert_eq!(
        log.0.lock().unwrap().iter().rev().nth(1),
        Some(&Event::Enter {
            phase: P::Rollback,
            // 100, 101 and 111 were touched; 120 was refused (not changed)
            total: Some(3)
        })
    );
    assert_eq!(log.0.lock().unwrap().last(), Some(&Event::End));
    // the writes the rollback sent are not counted as the upload's
    let after_rollback = log
        .0
        .lock()
        .unwrap()
        .iter()
        .skip_while(|e| {
            !matches!(
                e,
                Event::Enter {
                    phase: P::Rollback,
                    ..
                }
            )
        })
        .filter(|e| matches!(e, Event::Step { .. }))
        .count();
    assert_eq!(after_rollback, 0);
}

#[test]
fn the_observer_sees_a_rejected_dataset_confirmed_as_rollback_and_a_clean_upload_verified() {
    use driveset_engine::observe::Phase as P;
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let set = set_of(&schema, &[(k(100), 65536), (k(101), 20), (k(111), 5)]);
    let mut drive = mc_drive();
    drive.reject_dataset_at = Some(101);
    let mut client = FakeClient::new(schema.clone(), drive);
    let (log, opts) = observed(journal_in(&dir));
    upload(&mut client, &set, &opts).expect_err("rejected");
    assert_eq!(
        log.phases(),
        [
            P::Identify,
            P::Read,
            P::Plan,
            P::Journal,
            P::Dataset,
            P::Write,
            P::Commit,
            P::Rollback,
        ]
    );

    // a Tmd upload that goes through: no rollback, every write verified
    let dir = tempfile::tempdir().expect("tempdir");
    let mut client = FakeClient::new(tmd_schema(), tmd_drive());
    let (log, opts) = observed(journal_in(&dir));
    let report = upload(&mut client, &tmd_set(), &opts).expect("uploads");
    assert_eq!(
        log.phases(),
        [
            P::Identify,
            P::Read,
            P::Plan,
            P::Journal,
            P::Write,
            P::Verify,
        ]
    );
    let n = report.codes_written;
    let writes: Vec<(usize, usize)> = (1..=n).map(|i| (i, n)).collect();
    assert_eq!(log.steps(P::Write), writes);
    assert_eq!(log.steps(P::Verify), writes);
}

/// The upload's steps one by one (`Transaction`), as the line runner
/// drives them: the same writes in the same order as `upload`.
#[test]
fn transaction_steps_one_by_one_do_what_upload_does() {
    use driveset_engine::upload::{Replanned, Transaction};
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = journal_in(&dir);
    let set = mc_dataset_set(&schema);
    let mut client = FakeClient::new(schema, mc_drive());
    let opts = UploadOptions::new(&path);
    let mut tx = Transaction::begin(&mut client, &set, &opts).expect("begin");
    assert_eq!(
        tx.replan(&mut client, &set).expect("replan"),
        Replanned::Writes
    );
    assert_eq!(tx.staged(), &[k(100), k(101)]);
    tx.journal(&mut client).expect("journal");
    assert_eq!(
        JournalFile::open(&path).expect("journal").journal.state,
        TxnState::Writing
    );
    assert!(tx.open_dataset(&mut client).expect("open"));
    tx.write_dataset(&mut client).expect("dataset writes");
    tx.commit(&mut client).expect("commit");
    tx.write_rest(&mut client).expect("writes");
    tx.verify(&mut client, &set).expect("verify");
    let report = tx.finish(&mut client, &set, Ok(())).expect("report");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(report.codes_written, 4);
    assert_eq!(client.changes_logged(), mc_dataset_ops());
    // a step out of order is refused, never a panic
    let mut tx = Transaction::begin(&mut client, &set, &opts).expect("begin");
    let e = tx.write_rest(&mut client).expect_err("before replan");
    assert_eq!(
        e.error().to_string(),
        "fake0 address 1: refused: transaction step `write_rest` called before `journal`"
    );
}

/// A journal that cannot be persisted stops the transaction and is
/// reported: never dropped. Here the journal directory disappears after
/// the dataset writes; the commit's `committed` record fails, nothing more
/// is written and the error says what the journal on disk still holds.
#[test]
fn a_failed_journal_persist_stops_the_transaction_and_is_reported() {
    use driveset_engine::upload::{Next, Replanned, Transaction};
    let schema = mc_schema();
    let dir = tempfile::tempdir().expect("tempdir");
    let jdir = dir.path().join("journals");
    let path = jdir.join("drive.journal.json");
    let set = set_of(&schema, &[(k(100), 65536), (k(111), 5)]);
    let mut client = FakeClient::new(schema, mc_drive());
    let opts = UploadOptions::new(&path);
    let mut tx = Transaction::begin(&mut client, &set, &opts).expect("begin");
    assert_eq!(
        tx.replan(&mut client, &set).expect("replan"),
        Replanned::Writes
    );
    tx.journal(&mut client).expect("journal");
    tx.open_dataset(&mut client).expect("open");
    tx.write_dataset(&mut client).expect("dataset writes");
    std::fs::remove_dir_all(&jdir).expect("remove the journal directory");
    let stop = tx
        .commit(&mut client)
        .expect_err("the journal cannot record `committed`");
    assert!(
        matches!(&*stop.error().kind, ErrorKind::Input(InputFailure::Journal { path: p, .. }) if *p == path.display().to_string()),
        "{stop:?}"
    );
    let writes_before = client.writes_logged().len();
    let Next::Failed(e) = tx.stopped(&mut client, stop) else {
        panic!("a journal failure is not redone");
    };
    // nothing is sent while the journal cannot be updated
    assert_eq!(client.writes_logged().len(), writes_before);
    let text = e.to_string();
    let want = format!(
        "journal {p}: {p_err}; nothing was rolled back; but recording state `rolling-back` failed",
        p = path.display(),
        p_err = "journal ".to_string()
            + &path.display().to_string()
            + ": cannot create the temporary file: No such file or directory (os error 2); check the directory exists, is writable and has space"
    );
    assert!(text.starts_with(&want), "{text}");
    assert!(
        text.ends_with(&format!(
            "so the journal on disk still says `writing`: fix the journal directory, then run `driveset recover {}`",
            path.display()
        )),
        "{text}"
    );
    let f = tx
        .finish(&mut client, &set, Err(e))
        .expect_err("the upload failed");
    assert_eq!(
        f.report.expect("a journal was written").state,
        TxnState::RollingBack
    );
}
