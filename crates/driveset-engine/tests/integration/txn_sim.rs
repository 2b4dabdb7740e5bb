//! The transaction runner over the real LUSTBUS client and the simulated
//! MC6000 / VF1000 (driveset-sim) in virtual time.

use std::path::Path;
use std::time::Duration;

use driveset_engine::client::{DriveClient, LustbusClient};
use driveset_engine::journal::{JournalFile, TxnState};
use driveset_engine::live::live_diff;
use driveset_engine::overrides::Overrides;
use driveset_engine::recover::{RecoverAction, RecoverOptions, recover};
use driveset_engine::upload::{UploadOptions, prepare, upload};
use driveset_link::VirtualClock;
use driveset_schema::{CodeKey, RawValue, Registry, ResolvedSet, load_set};
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

fn set(rel: &str) -> ResolvedSet {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel);
    let mut reg = Registry::builtin().expect("builtin");
    let loaded = load_set(&path, &mut reg).expect("set loads");
    assert!(loaded.findings.is_empty(), "{:?}", loaded.findings);
    loaded.resolved.expect("resolved")
}

fn bus(drive: Box<dyn ByteDrive>, faults: Option<&str>) -> SimByteBus {
    let clock = VirtualClock::new();
    let mut bus = SimByteBus::new(&clock, 19200, vec![drive]).expect("bus");
    if let Some(f) = faults {
        bus = bus.with_faults(FaultPlan::parse(f).expect("faults"), 1);
    }
    bus
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
    let mut probe = LustbusClient::new(
        bus(Box::new(Vf1000::new(opts(4)).expect("vf")), None),
        schema.clone(),
        4,
    )
    .expect("client");
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
    let mut probe = LustbusClient::new(
        bus(Box::new(Mc6000::new(opts(1)).expect("mc")), None),
        schema.clone(),
        1,
    )
    .expect("client");
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
    let mut c = LustbusClient::new(
        bus(Box::new(Mc6000::new(opts(1)).expect("mc")), None),
        schema.clone(),
        1,
    )
    .expect("client");
    let prepared = prepare(&mut c, &set, Overrides::none()).expect("prepare");
    let mut c = LustbusClient::new(
        bus(Box::new(Mc6000::new(opts(1)).expect("mc")), None),
        schema,
        1,
    )
    .expect("client");
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

#[test]
fn a_pulled_cable_is_observed_as_rollback_and_recover_as_read_rollback_verify() {
    use driveset_engine::observe::{Hook, Phase as P, Spans};
    use std::sync::Arc;
    let set = set("parameter-sets/vf1000/conveyor-1.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    let journal = dir.path().join("vf.journal.json");
    let schema = catalog::schema(Family::Vf1000).expect("schema");
    let mut probe = LustbusClient::new(
        bus(Box::new(Vf1000::new(opts(4)).expect("vf")), None),
        schema.clone(),
        4,
    )
    .expect("client");
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
