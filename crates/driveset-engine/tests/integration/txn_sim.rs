//! The transaction runner over the real LUSTBUS client and the simulated
//! MC6000 / VF1000 (driveset-sim) in virtual time.

use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{DriveClient, LustbusClient};
use driveset_engine::journal::{JournalFile, TxnState};
use driveset_engine::live::live_diff;
use driveset_engine::overrides::Overrides;
use driveset_engine::recover::{RecoverAction, RecoverOptions, recover};
use driveset_engine::upload::{UploadOptions, prepare, upload};
use driveset_link::VirtualClock;
use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};
use driveset_sim::bus::SimByteBus;
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::{ByteDrive, ReactionTime};
use driveset_sim::faults::FaultPlan;
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::vf1000::Vf1000;

fn opts(address: u8) -> LustOptions {
    LustOptions::new(address).reaction(ReactionTime::fixed(Duration::from_millis(2)))
}

use crate::support::sets::example_set as set;

fn bus(drive: Box<dyn ByteDrive>, faults: Option<&str>) -> SimByteBus {
    let clock = VirtualClock::new();
    let mut bus = SimByteBus::new(&clock, 19200, vec![drive]).expect("bus");
    if let Some(f) = faults {
        bus = bus.with_faults(FaultPlan::parse(f).expect("faults"), 1);
    }
    bus
}

/// A client of a fresh simulated MC6000 at address 1, on a bus without
/// faults.
fn mc_client(schema: Arc<Schema>) -> LustbusClient<SimByteBus> {
    let mc = Mc6000::new(opts(1)).expect("mc");
    LustbusClient::new(bus(Box::new(mc), None), schema, 1).expect("client")
}

/// A client of a fresh simulated VF1000 at address 4, on a bus without
/// faults.
fn vf_client(schema: Arc<Schema>) -> LustbusClient<SimByteBus> {
    let vf = Vf1000::new(opts(4)).expect("vf");
    LustbusClient::new(bus(Box::new(vf), None), schema, 4).expect("client")
}

#[test]
fn mc6000_axis_set_lands_through_the_dataset_and_verifies() {
    let set = set("parameter-sets/mc6000/axis-1.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    let journal = dir.path().join("axis-1.journal.json");
    let mc = Box::new(Mc6000::new(opts(1)).expect("mc"));
    let mut c = LustbusClient::new(
        bus(mc, None),
        catalog::schema(Family::Mc6000).expect("schema"),
        1,
    )
    .expect("client");
    let prepared = prepare(&mut c, &set, Overrides::none()).expect("prepare");
    assert!(prepared.plan.dataset, "{}", prepared.plan.render(None));
    let report = upload(&mut c, &set, &UploadOptions::new(&journal))
        .unwrap_or_else(|f| panic!("{f}\n{:?}", f.report.as_ref().map(|r| r.render())));
    assert_eq!(report.state, TxnState::Complete, "{}", report.render());
    let d = live_diff(&mut c, &set).expect("diff");
    assert!(d.is_empty(), "{d}");
    assert_eq!(
        report.fingerprint_after.as_deref(),
        Some(set.fingerprint().as_str())
    );
    assert_eq!(report.dataset.as_deref(), Some("accepted (SLOAD = 0)"));
    // the elapsed time is within the planned estimate plus the drive's check
    assert!(
        report.elapsed <= prepared.estimate.total + Duration::from_secs(10),
        "{:?} vs {:?}",
        report.elapsed,
        prepared.estimate
    );
    // the drive now holds exactly the set
    assert!(live_diff(&mut c, &set).expect("diff").is_empty());
    assert_eq!(
        JournalFile::open(&journal).expect("journal").journal.state,
        TxnState::Complete
    );
}

#[test]
fn vf1000_power_cycle_mid_upload_voids_the_attempt_and_is_redone() {
    let set = set("parameter-sets/vf1000/conveyor-1.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    let journal = dir.path().join("vf.journal.json");
    let vf = Box::new(Vf1000::new(opts(4)).expect("vf"));
    let schema = catalog::schema(Family::Vf1000).expect("schema");
    // learn how many telegrams read-back takes, then cut the power a few writes in
    let mut probe = vf_client(schema.clone());
    let prepared = prepare(&mut probe, &set, Overrides::none()).expect("prepare");
    assert!(
        prepared.plan.writes.len() >= 3,
        "{}",
        prepared.plan.render(None)
    );
    let at = probe.stats().telegrams + 3;
    let mut c = LustbusClient::new(
        bus(vf, Some(&format!("power-cycle@{at}:off=100ms"))),
        schema,
        4,
    )
    .expect("client");
    let report = upload(&mut c, &set, &UploadOptions::new(&journal))
        .unwrap_or_else(|f| panic!("{f}\n{:?}", f.report.as_ref().map(|r| r.render())));
    assert_eq!(report.state, TxnState::Complete, "{}", report.render());
    assert_eq!(report.attempts, 2, "{}", report.render());
    assert!(live_diff(&mut c, &set).expect("diff").is_empty());
}

#[test]
fn mc6000_cable_pulled_mid_upload_then_recover_ends_on_one_whole_set() {
    let set = set("parameter-sets/mc6000/axis-1.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    let journal = dir.path().join("axis.journal.json");
    let schema = catalog::schema(Family::Mc6000).expect("schema");
    let mut probe = mc_client(schema.clone());
    let before = driveset_engine::live::live_values(&mut probe, &set).expect("values");
    let n0 = probe.stats().telegrams;
    let prepared = prepare(&mut probe, &set, Overrides::none()).expect("prepare");
    // the telegrams the upload sends before its first write
    let n = probe.stats().telegrams - n0;
    // pull the cable for 60 s some writes into the transaction
    let at = n + 2 * (prepared.plan.writes.len() as u64) / 3;
    let mc = Box::new(Mc6000::new(opts(1)).expect("mc"));
    let mut c =
        LustbusClient::new(bus(mc, Some(&format!("cable@{at}+60s"))), schema, 1).expect("client");
    let failure = upload(&mut c, &set, &UploadOptions::new(&journal)).expect_err("cable pulled");
    let text = failure.to_string();
    assert!(text.contains("driveset recover"), "{text}");
    // later, the cable is back
    c.clock().sleep(Duration::from_secs(120));
    let r = recover(&mut c, &journal, &RecoverOptions::default()).expect("recover");
    assert_ne!(r.action, RecoverAction::Nothing);
    let holds = r.fingerprint.expect("fingerprint");
    assert!(
        holds == before.fingerprint() || holds == set.fingerprint(),
        "drive holds a mix"
    );
}

#[test]
fn mc6000_eeprom_gaps_carry_verification_reads_on_the_real_client() {
    let schema = catalog::schema(Family::Mc6000).expect("schema");
    let mut set = ResolvedSet::new(&schema);
    // non-CardWriteable EEPROM values of the demo fixture (103-OVLIM 2 B,
    // 110-KPLVL 1 B, 111-KPBRG 2 B, 112-KPDSP 2 B, 320-HSTMX 1 B)
    for (n, v) in [(103, 800), (110, 3), (111, 50), (112, 60), (320, 90)] {
        set.insert(CodeKey::new(n), RawValue::Int(v));
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut c = mc_client(schema.clone());
    let prepared = prepare(&mut c, &set, Overrides::none()).expect("prepare");
    let mut c = mc_client(schema);
    let report = upload(&mut c, &set, &UploadOptions::new(dir.path().join("j.json")))
        .unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(report.codes_written, 5);
    assert_eq!(report.retries, 0, "no EEPROM busy NAK: the runner paced");
    assert!(report.interleaved_reads >= 3, "{}", report.render());
    let est = prepared.estimate.total;
    // the estimate leaves out identify / running exchanges and host EOTs
    assert!(
        report.elapsed >= est && report.elapsed <= est + est * 3 / 10,
        "elapsed {:?} vs estimate {:?}",
        report.elapsed,
        prepared.estimate
    );
}

// ---------------------------------------------------------------------------
// --transfer-baud (issue 12, driveset_engine::transfer)
// ---------------------------------------------------------------------------

mod transfer_rate {
    use std::time::Duration;

    use driveset_engine::client::{DriveClient, LustbusClient, set_line_rate};
    use driveset_engine::journal::{JournalFile, TransferState, TxnState};
    use driveset_engine::live::live_diff;
    use driveset_engine::recover::{RecoverAction, RecoverOptions, recover};
    use driveset_engine::transfer::{self, TransferRequest};
    use driveset_engine::upload::{UploadFailure, UploadOptions, UploadReport};
    use driveset_link::VirtualClock;
    use driveset_schema::{CodeKey, RawValue, ResolvedSet};
    use driveset_sim::bus::SimByteBus;
    use driveset_sim::catalog::{self, Family};
    use driveset_sim::faults::FaultPlan;
    use driveset_sim::log::{Dir, EventLog};
    use driveset_sim::mc6000::Mc6000;

    use super::{opts, set};

    /// `transfer::upload` of `set` with the 57600 baud transfer rate
    /// requested, journal at `journal`.
    fn upload_at_57600(
        c: &mut LustbusClient<SimByteBus>,
        set: &ResolvedSet,
        journal: impl Into<std::path::PathBuf>,
    ) -> Result<UploadReport, UploadFailure> {
        upload_with(c, set, journal, &TransferRequest::new(57600))
    }

    /// `transfer::upload` of `set` with `req`, journal at `journal`.
    fn upload_with(
        c: &mut LustbusClient<SimByteBus>,
        set: &ResolvedSet,
        journal: impl Into<std::path::PathBuf>,
        req: &TransferRequest,
    ) -> Result<UploadReport, UploadFailure> {
        transfer::upload(c, set, &UploadOptions::new(journal), req)
    }

    fn mc_bus(log: &EventLog, faults: Option<&str>) -> SimByteBus {
        let clock = VirtualClock::new();
        let mut bus = SimByteBus::new(
            &clock,
            9600,
            vec![Box::new(Mc6000::new(opts(1)).expect("mc"))],
        )
        .expect("bus")
        .with_log(log.clone());
        if let Some(f) = faults {
            bus = bus.with_faults(FaultPlan::parse(f).expect("faults"), 1);
        }
        bus
    }

    /// The log as `h:` host / `d:` drive texts and `e:` notes.
    fn seq(log: &EventLog) -> Vec<String> {
        log.events()
            .iter()
            .map(|e| match e.dir {
                Dir::Host => format!("h:{}", e.text),
                Dir::Drive => format!("d:{}", e.text),
                _ => format!("e:{}", e.detail.clone().unwrap_or_default()),
            })
            .collect()
    }

    fn window(all: &[String], from: &str, n: usize) -> Vec<String> {
        let i = all
            .iter()
            .position(|s| s == from)
            .unwrap_or_else(|| panic!("{from} not in the log: {all:#?}"));
        all[i..(i + n).min(all.len())].to_vec()
    }

    fn last_window(all: &[String], from: &str, n: usize) -> Vec<String> {
        let i = all
            .iter()
            .rposition(|s| s == from)
            .unwrap_or_else(|| panic!("{from} not in the log"));
        all[i..(i + n).min(all.len())].to_vec()
    }

    fn mc_client(log: &EventLog, faults: Option<&str>) -> LustbusClient<SimByteBus> {
        let schema = catalog::schema(Family::Mc6000).expect("schema");
        LustbusClient::new(mc_bus(log, faults), schema, 1).expect("client")
    }

    #[test]
    fn upload_switches_to_57600_and_back_with_exact_telegrams() {
        let set = set("parameter-sets/mc6000/axis-1.toml");
        let dir = tempfile::tempdir().expect("tempdir");
        let journal = dir.path().join("j.journal.json");
        let log = EventLog::memory();
        let mut c = mc_client(&log, None);
        let report = upload_at_57600(&mut c, &set, &journal).unwrap_or_else(|f| panic!("{f}"));
        assert_eq!(report.state, TxnState::Complete, "{}", report.render());
        let t = report.transfer.as_ref().expect("transfer report");
        assert!(t.switched);
        assert_eq!(
            t.state,
            "the drive runs at 9600 baud again; 81-SBAUD holds 19200 (not active: in effect after the drive's next restart)"
        );
        assert!(
            t.decision
                .summary()
                .starts_with("transfer rate 57600: saves 3.7 s of 4.8 s (195 exchanges: 4.8 s at 9600 baud, 962 ms at 57600 baud plus 112 ms to switch over and back)"),
            "{}",
            t.decision.summary()
        );
        let all = seq(&log);
        // before the switch, at 9600: the rate code is read (81 = 0x2580 = 9600)
        assert_eq!(
            window(&all, "h:<EOT>A00081<ENQ>", 2),
            ["h:<EOT>A00081<ENQ>", "d:A<STX>00081=2580<ETX><BS>"]
        );
        // 81-SBAUD = 57600 (0xE100), 4-PROG = 111 (0x6F): ACK at 9600, then
        // the first telegram at 57600 reads 81 back, and 81 gets the
        // drive's own 9600 again, not activated
        assert_eq!(
            window(&all, "h:<EOT>A<STX>00081=E100<ETX>s", 9),
            [
                "h:<EOT>A<STX>00081=E100<ETX>s",
                "d:A<ACK>",
                "h:<EOT>A<STX>20004=6F<ETX>x",
                "d:A<ACK>",
                "e:drive 1 runs at 57600 baud from here",
                "h:<EOT>A00081<ENQ>",
                "d:A<STX>00081=E100<ETX>s",
                "h:<EOT>A<STX>00081=2580<ETX><BS>",
                "d:A<ACK>",
            ]
        );
        // the first exchange at 57600: 8 characters out, 2 ms reaction
        let ev = log.events();
        let i = ev
            .iter()
            .position(|e| e.fault.as_deref() == Some("baud-change"))
            .expect("baud change");
        let (q, a) = (&ev[i + 1], &ev[i + 2]);
        assert_eq!(a.t_ns - q.t_ns, 1_388_888 + 2_000_000);
        // back: SBAUD read (the set's 19200 = 0x4B00), 81 = 9600, PROG = 111
        // (ACK at 57600), then at 9600: confirm, write the set's 19200 back
        // without activating it, verify
        assert_eq!(
            last_window(&all, "h:<EOT>A<STX>00081=2580<ETX><BS>", 11),
            [
                "h:<EOT>A<STX>00081=2580<ETX><BS>",
                "d:A<ACK>",
                "h:<EOT>A<STX>20004=6F<ETX>x",
                "d:A<ACK>",
                "e:drive 1 runs at 9600 baud from here",
                "h:<EOT>A00081<ENQ>",
                "d:A<STX>00081=2580<ETX><BS>",
                "h:<EOT>A<STX>00081=4B00<ETX>q",
                "d:A<ACK>",
                "h:<EOT>A00081<ENQ>",
                "d:A<STX>00081=4B00<ETX>q",
            ]
        );
        // exactly two rate changes, and the drive runs at 9600 at the end
        assert_eq!(
            ev.iter()
                .filter(|e| e.fault.as_deref() == Some("baud-change"))
                .count(),
            2
        );
        assert_eq!(c.link().line().drive_baud(1), Some(9600));
        assert_eq!(c.link().line().baud(), 9600);
        // the set's SBAUD is in EEPROM (not active), the set is on the drive
        assert_eq!(c.read(CodeKey::new(81)).expect("81"), RawValue::Int(19200));
        assert!(live_diff(&mut c, &set).expect("diff").is_empty());
        let j = JournalFile::open(&journal).expect("journal").journal;
        assert_eq!(j.state, TxnState::Complete);
        let rec = j.transfer.expect("record");
        assert_eq!(
            (rec.state, rec.old_rate, rec.transfer_rate),
            (TransferState::Back, 9600, 57600)
        );
        assert_eq!(
            rec.before,
            driveset_engine::journal::JournalValue::Int(9600)
        );
        assert_eq!(
            rec.stored,
            Some(driveset_engine::journal::JournalValue::Int(19200))
        );
        assert!(rec.switched_at_ns.expect("switched") < rec.back_at_ns.expect("back"));
    }

    #[test]
    fn rerun_and_pull_at_the_transfer_rate_settle_their_journal() {
        let set = set("parameter-sets/mc6000/axis-1.toml");
        let dir = tempfile::tempdir().expect("tempdir");
        let journal = dir.path().join("j.journal.json");
        let log = EventLog::memory();
        let mut c = mc_client(&log, None);
        driveset_engine::upload::upload(
            &mut c,
            &set,
            &UploadOptions::new(dir.path().join("first.json")),
        )
        .unwrap_or_else(|f| panic!("{f}"));
        let report = upload_at_57600(&mut c, &set, &journal).unwrap_or_else(|f| panic!("{f}"));
        assert_eq!(report.codes_written, 0);
        assert!(report.transfer.as_ref().is_some_and(|t| t.switched));
        let j = JournalFile::open(&journal).expect("journal").journal;
        assert_eq!(j.state, TxnState::Complete);
        assert!(j.plan.is_empty() && j.is_finished());
        // pull at 57600: the same values as at 9600
        let pj = dir.path().join("pull.journal.json");
        let (pulled, t) = transfer::pull(
            &mut c,
            &driveset_engine::pull::PullOptions::default(),
            &TransferRequest::new(57600),
            &pj,
            &driveset_engine::observe::Hook::none(),
        )
        .expect("pull");
        assert!(t.switched, "{}", t.render());
        let plain = driveset_engine::pull::pull(&mut c, &Default::default()).expect("pull");
        assert_eq!(pulled.full_fingerprint, plain.full_fingerprint);
        assert!(
            JournalFile::open(&pj)
                .expect("journal")
                .journal
                .is_finished()
        );
        assert_eq!(c.link().line().drive_baud(1), Some(9600));
    }

    /// Issue 33: after the switch back, a drive that did not restart is
    /// asked once (SERR: no power-on bit, LUSTBUS §6) instead of having
    /// every code of the set read again at 9600, which made a switched
    /// re-run slower than staying at 9600. The re-run at 57600 now takes
    /// less bus time than the same re-run at 9600.
    #[test]
    fn after_the_switch_back_one_serr_read_stands_for_the_read_back_and_a_rerun_gains() {
        let set = set("parameter-sets/mc6000/axis-1.toml");
        let dir = tempfile::tempdir().expect("tempdir");
        let log = EventLog::memory();
        let mut c = mc_client(&log, None);
        driveset_engine::upload::upload(
            &mut c,
            &set,
            &UploadOptions::new(dir.path().join("first.json")),
        )
        .unwrap_or_else(|f| panic!("{f}"));
        let t0 = c.clock().now();
        driveset_engine::upload::upload(
            &mut c,
            &set,
            &UploadOptions::new(dir.path().join("plain.json")),
        )
        .unwrap_or_else(|f| panic!("{f}"));
        let plain = c.clock().now() - t0;
        let before = log.events().len();
        let t0 = c.clock().now();
        let report = upload_at_57600(&mut c, &set, dir.path().join("switched.json"))
            .unwrap_or_else(|f| panic!("{f}"));
        let switched = c.clock().now() - t0;
        assert!(report.transfer.as_ref().is_some_and(|t| t.switched));
        assert_eq!(report.state, TxnState::Complete);
        let all: Vec<String> = seq(&log).split_off(before);
        let back = all
            .iter()
            .rposition(|s| s == "e:drive 1 runs at 9600 baud from here")
            .expect("switched back");
        assert_eq!(
            all[back + 1..],
            [
                // confirm at 9600, the set's 19200 back into 81 (not
                // activated), its read-back
                "h:<EOT>A00081<ENQ>",
                "d:A<STX>00081=2580<ETX><BS>",
                "h:<EOT>A<STX>00081=4B00<ETX>q",
                "d:A<ACK>",
                "h:<EOT>A00081<ENQ>",
                "d:A<STX>00081=4B00<ETX>q",
                // the restart check: SERR without the power-on bit, and
                // no code of the set read again
                "h:<EOT>A00085<ENQ>",
                "d:A<STX>00085=00<ETX><ETX>",
            ],
            "{:#?}",
            &all[back + 1..]
        );
        assert!(
            switched < plain,
            "switched re-run {switched:?} against {plain:?} at 9600"
        );
    }

    /// A power cycle right after the switch back: the SERR read after it
    /// finds the power-on bit, every code is read back, and the RAM code
    /// 428-RSIO the restart lost fails the upload.
    #[test]
    fn a_restart_after_the_switch_back_is_found_and_the_read_back_fails_the_upload() {
        // without 81-SBAUD, so the drive restarts at its own 9600 and
        // answers the SERR read with the power-on bit
        let mut set = set("parameter-sets/mc6000/axis-1.toml");
        set.values.remove(&CodeKey::new(81));
        let dir = tempfile::tempdir().expect("tempdir");
        let journal = dir.path().join("j.journal.json");
        // the last host telegram of a clean run is the SERR read
        let clean = EventLog::memory();
        let mut c = mc_client(&clean, None);
        upload_at_57600(&mut c, &set, dir.path().join("clean.json"))
            .unwrap_or_else(|f| panic!("{f}"));
        let n = clean.events().iter().filter(|e| e.dir == Dir::Host).count();
        assert_eq!(
            seq(&clean)
                .iter()
                .rfind(|s| s.starts_with("h:"))
                .map(String::as_str),
            Some("h:<EOT>A00085<ENQ>")
        );
        let log = EventLog::memory();
        let fault = format!("power-cycle@{n}:off=200ms");
        let mut c = mc_client(&log, Some(&fault));
        let f = upload_at_57600(&mut c, &set, &journal)
            .expect_err("a restart after the switch back fails the upload");
        let text = f.error.to_string();
        assert!(
            text.contains("after the switch back, the final read-back at 9600 baud finds")
                && text.contains("428"),
            "{text}"
        );
        let j = JournalFile::open(&journal).expect("journal").journal;
        assert_eq!(j.state, TxnState::Failed);
    }

    #[test]
    fn a_small_set_is_not_switched_it_does_not_pay() {
        let schema = catalog::schema(Family::Mc6000).expect("schema");
        let mut set = ResolvedSet::new(&schema);
        set.insert(CodeKey::new(103), RawValue::Int(800));
        let dir = tempfile::tempdir().expect("tempdir");
        let journal = dir.path().join("j.journal.json");
        let log = EventLog::memory();
        let mut c = mc_client(&log, None);
        let report = upload_at_57600(&mut c, &set, &journal).unwrap_or_else(|f| panic!("{f}"));
        let t = report.transfer.expect("transfer");
        assert!(!t.switched);
        assert_eq!(
            t.decision.summary(),
            "transfer rate 57600: not switched: it does not pay (1 exchange: 23 ms at 9600 baud against 4 ms at 57600 baud plus 112 ms to switch over and back)"
        );
        assert!(
            !seq(&log).iter().any(|s| s.contains("00081=")),
            "no SBAUD write"
        );
        assert!(
            !seq(&log)
                .iter()
                .any(|s| s.starts_with("h:<EOT>A<STX>20004"))
        );
    }

    #[test]
    fn a_running_drive_is_refused_before_the_switch() {
        let set = set("parameter-sets/mc6000/axis-1.toml");
        let dir = tempfile::tempdir().expect("tempdir");
        let log = EventLog::memory();
        let mut c = mc_client(&log, None);
        // the machine's control starts the motor (416-SCTL1 bit 0)
        c.link_mut().drive_mut(1).expect("drive").set_running(true);
        let n = log.events().len();
        let err = upload_at_57600(&mut c, &set, dir.path().join("j.json")).expect_err("running");
        assert_eq!(
            err.to_string(),
            "sim address 1: refused: --transfer-baud 57600: the drive reports a running motor (or its running state cannot be read); the line rate is switched only at standstill, and no override lifts that: stop the drive, or leave out --transfer-baud"
        );
        // read-only exchanges only: identify and the running check
        let after: Vec<String> = seq(&log)[n..].to_vec();
        assert_eq!(
            after
                .iter()
                .filter(|s| s.starts_with("h:"))
                .cloned()
                .collect::<Vec<_>>(),
            ["h:<EOT>A00091<ENQ>", "h:<EOT>A20416<ENQ>"]
        );
        assert!(!dir.path().join("j.json").exists());
    }

    #[test]
    fn vf1000_tcp_and_a_shared_bus_are_refused_before_anything_is_sent() {
        use driveset_sim::vf1000::Vf1000;
        let set = set("parameter-sets/vf1000/conveyor-1.toml");
        let dir = tempfile::tempdir().expect("tempdir");
        let log = EventLog::memory();
        let clock = VirtualClock::new();
        let bus = SimByteBus::new(
            &clock,
            9600,
            vec![Box::new(Vf1000::new(opts(4)).expect("vf"))],
        )
        .expect("bus")
        .with_log(log.clone());
        let mut c = LustbusClient::new(bus, catalog::schema(Family::Vf1000).expect("schema"), 4)
            .expect("client");
        let err = upload_with(
            &mut c,
            &set,
            dir.path().join("j.json"),
            &TransferRequest::new(19200),
        )
        .expect_err("vf1000");
        assert_eq!(
            err.to_string(),
            "sim address 4: refused: --transfer-baud 19200: a Lust SMARTDRIVE VF1000 runs at 9600 baud at most (lustbus-protocol.txt §4) and activates a new rate only at a restart (§11.5); leave out --transfer-baud"
        );
        assert!(log.events().is_empty(), "nothing sent");
        // an MC on a bus with VF1000s: refused unless overridden
        let set = super::set("parameter-sets/mc6000/axis-1.toml");
        let log = EventLog::memory();
        let mut c = mc_client(&log, None);
        let mut req = TransferRequest::new(57600);
        req.others = vec![
            driveset_schema::Family::Vf1000,
            driveset_schema::Family::Mc6000,
        ];
        let err = upload_with(&mut c, &set, dir.path().join("k.json"), &req).expect_err("shared");
        assert_eq!(
            err.to_string(),
            "sim address 1: refused: --transfer-baud 57600: the bus is shared with 1 drive(s) (Lust SMARTDRIVE VF1000) that cannot follow: while this drive talks at 57600 baud they hear garbage, and their watchdog (84-SIOT / SWDGT, lustbus-protocol.txt §5.2) may fire; give --allow-shared-transfer-baud to switch anyway, or leave out --transfer-baud"
        );
        assert!(log.events().is_empty(), "nothing sent");
        req.allow_shared = true;
        let r = upload_with(&mut c, &set, dir.path().join("k.json"), &req)
            .unwrap_or_else(|f| panic!("{f}"));
        assert!(r.transfer.is_some_and(|t| t.switched));
        // a rate the family does not run at
        let err = upload_with(
            &mut c,
            &set,
            dir.path().join("l.json"),
            &TransferRequest::new(1200),
        )
        .expect_err("1200");
        assert_eq!(
            err.to_string(),
            "sim address 1: refused: --transfer-baud 1200: a Lust MASTERCONTROL MC6000/7000 runs at 2400, 4800, 9600, 19200, 38400, 57600 baud (lustbus-protocol.txt §4); pick one of these"
        );
    }

    #[test]
    fn cable_pulled_at_the_transfer_rate_then_recover_finds_the_drive_and_switches_back() {
        let set = set("parameter-sets/mc6000/axis-1.toml");
        let dir = tempfile::tempdir().expect("tempdir");
        let journal = dir.path().join("j.journal.json");
        // telegram 40: well after the switch (the 9th telegram), in the read-back
        let log = EventLog::memory();
        let mut c = mc_client(&log, Some("cable@40+60s"));
        let f = upload_at_57600(&mut c, &set, &journal).expect_err("cable");
        let text = f.to_string();
        assert!(
            text.contains("switching back from the transfer rate failed")
                && text.contains("it may still run at the transfer rate 57600 baud; its 81-SBAUD holds 9600 in EEPROM, so a restart brings it to that rate"),
            "{text}"
        );
        let j = JournalFile::open(&journal).expect("journal").journal;
        assert!(!j.is_finished());
        assert_ne!(
            j.transfer.as_ref().map(|t| t.state),
            Some(TransferState::Back)
        );
        assert_eq!(c.link().line().drive_baud(1), Some(57600));
        // the cable is back; recover through a port at 9600
        c.clock().sleep(Duration::from_secs(120));
        set_line_rate(&mut c, 9600).expect("port at 9600");
        let r = recover(&mut c, &journal, &RecoverOptions::default()).expect("recover");
        assert_eq!(
            r.transfer.as_deref(),
            Some("found at 57600 baud; the drive runs at 9600 baud again; 81-SBAUD = 9600")
        );
        assert_eq!(r.action, RecoverAction::RolledBack);
        assert_eq!(c.link().line().drive_baud(1), Some(9600));
        let j = JournalFile::open(&journal).expect("journal").journal;
        assert!(j.is_finished(), "{:?}", j.state);
    }
}

#[test]
fn a_pulled_cable_is_observed_as_rollback_and_recover_as_read_rollback_verify() {
    use driveset_engine::observe::{Hook, Phase as P, Spans};
    let set = set("parameter-sets/vf1000/conveyor-1.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    let journal = dir.path().join("vf.journal.json");
    let schema = catalog::schema(Family::Vf1000).expect("schema");
    let mut probe = vf_client(schema.clone());
    let n0 = probe.stats().telegrams;
    let prepared = prepare(&mut probe, &set, Overrides::none()).expect("prepare");
    let writes = prepared.plan.writes.len() as u64;
    assert!(writes >= 3, "{}", prepared.plan.render(None));
    // the cable goes after the second write, for 60 s
    let at = probe.stats().telegrams - n0 + 2;
    let vf = Box::new(Vf1000::new(opts(4)).expect("vf"));
    let mut c =
        LustbusClient::new(bus(vf, Some(&format!("cable@{at}+60s"))), schema, 4).expect("client");
    let spans = Arc::new(Spans::new());
    let mut uo = UploadOptions::new(&journal);
    uo.observer = Hook::new(spans.clone());
    let failure = upload(&mut c, &set, &uo).expect_err("cable pulled");
    assert!(
        failure.to_string().contains("driveset recover"),
        "{failure}"
    );
    assert_eq!(
        spans.phases(),
        [
            P::Identify,
            P::Read,
            P::Plan,
            P::Journal,
            P::Write,
            P::Rollback
        ]
    );
    // the rollback span holds the restore attempts: it takes bus time
    let (_, s, e) = *spans.spans().last().unwrap();
    assert!(e > s, "{s:?} {e:?}");

    c.clock().sleep(Duration::from_secs(120));
    let spans = Arc::new(Spans::new());
    let ro = RecoverOptions {
        observer: Hook::new(spans.clone()),
        ..RecoverOptions::default()
    };
    let r = recover(&mut c, &journal, &ro).expect("recover");
    assert_eq!(r.action, RecoverAction::RolledBack);
    assert_eq!(
        spans.phases(),
        [P::Identify, P::Read, P::Rollback, P::Verify]
    );
}

/// An MC acknowledges an EEPROM value once it is in RAM and saves it to
/// its EEPROM in the background (`lustbus-protocol.txt` §3: 15 ms a byte;
/// §11.2.1: the EEPROM "only as a backup", copied into RAM at the start):
/// an upload says `complete` only once the last save is done, so a power
/// cycle right after it keeps the set (the simulated MC6000 comes back with
/// the EEPROM's old value when the power goes during a save).
#[test]
fn mc6000_upload_completes_only_after_the_last_background_eeprom_save() {
    let schema = catalog::schema(Family::Mc6000).expect("schema");
    // 103-OVLIM: EEPROM, not CardWriteable (no dataset download), width
    // 2: saved 30 ms after its ACK
    let ovlim = CodeKey::new(103);
    let want = RawValue::Int(800);
    let mut set = ResolvedSet::new(&schema);
    set.insert(ovlim, want.clone());
    let dir = tempfile::tempdir().expect("tempdir");
    let journal = dir.path().join("ovlim.journal.json");
    let mc = Box::new(Mc6000::new(opts(1)).expect("mc"));
    let mut c = LustbusClient::new(bus(mc, None), schema, 1).expect("client");
    let report = upload(&mut c, &set, &UploadOptions::new(&journal)).expect("upload");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(report.dataset, None);
    let now = c.clock().now();
    let drive = c.link_mut().drive_mut(1).expect("drive");
    drive.power_cycle(now, Duration::from_millis(1));
    assert_eq!(drive.state().values.get(&ovlim), Some(&want), "kept");
}
