//! CanClient against the simulated Lenze ECS (driveset-sim SimCanBus) in
//! virtual time: expedited FIX32 / bit-coded values, segmented VS values,
//! DS301 aborts, lost answers.

use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{CanClient, CanOptions, DriveClient};
use driveset_engine::error::{DeviceFailure, ErrorKind, LinkFailure, Refused};
use driveset_link::Clock;
use driveset_proto::can::NodeId;
use driveset_schema::error::SourceFile;
use driveset_schema::{CodeKey, RawValue, Schema};
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::{FrameDrive, ReactionTime};
use driveset_sim::ecs::EcsDrive;
use driveset_sim::log::Dir;
use driveset_sim::table::ParamTable;
use driveset_test_support::sim_can_bus;

fn ecs(node: u8) -> Box<dyn FrameDrive> {
    Box::new(
        EcsDrive::new(NodeId::new(node).unwrap(), 1)
            .expect("ecs")
            .with_reaction(ReactionTime::fixed(Duration::from_millis(1))),
    )
}

fn schema() -> Arc<Schema> {
    catalog::schema(Family::Ecs).expect("schema")
}

#[test]
fn fix32_read_and_write() {
    let (_clock, log, bus) = sim_can_bus(vec![ecs(3)], None);
    let mut c = CanClient::new(bus, schema(), 3).unwrap();
    // C5001 max_speed, default 3000 rpm = raw 30 000 000.
    assert_eq!(
        c.read(CodeKey::new(5001)).unwrap(),
        RawValue::Int(30_000_000)
    );
    c.write(CodeKey::new(5001), &RawValue::Int(12_345_678))
        .unwrap();
    assert_eq!(
        c.read(CodeKey::new(5001)).unwrap(),
        RawValue::Int(12_345_678)
    );
    // the FICTIONAL fixture's running bit, C0150 bit 1 (read over SDO)
    assert_eq!(c.running().unwrap(), Some(false));
    let host: Vec<String> = log
        .events()
        .into_iter()
        .filter(|e| e.dir == Dir::Host)
        .map(|e| e.hex)
        .collect();
    // Index 24575 - 5001 = 19574 = 0x4C76; request COB-ID 0x603.
    assert!(host[0].contains("40 76 4C 00 00 00 00 00"), "{host:?}");
    // 12 345 678 = 0x00BC614E little-endian, expedited 4 bytes (0x23).
    assert!(host[1].contains("23 76 4C 00 4E 61 BC 00"), "{host:?}");
}

#[test]
fn abort_is_a_device_error_with_ds301_text() {
    let (_clock, _log, bus) = sim_can_bus(vec![ecs(3)], None);
    let mut c = CanClient::new(bus, schema(), 3).unwrap();
    // max 16000 rpm.
    let err = c
        .write(CodeKey::new(5001), &RawValue::Int(160_010_000))
        .unwrap_err();
    let ErrorKind::Device(DeviceFailure::Refused { cause, what, .. }) = &*err.kind else {
        panic!("{err}")
    };
    assert!(what.contains("C5001"), "{what}");
    assert_eq!(cause.cause(), "Value of parameter written too high");
    assert!(cause.raw().contains("0x06090031"), "{}", cause.raw());
    assert!(cause.remedy().contains("lower"), "{}", cause.remedy());
    assert_eq!(c.stats().retries, 0, "an abort is not repeated");
}

#[test]
fn lost_answers_are_repeated_then_no_answer() {
    let (_clock, _log, bus) = sim_can_bus(vec![ecs(3)], Some("lose=0.3,seed=5"));
    let mut c = CanClient::new(bus, schema(), 3).unwrap();
    for _ in 0..10 {
        assert_eq!(
            c.read(CodeKey::new(5001)).unwrap(),
            RawValue::Int(30_000_000)
        );
    }
    assert!(c.stats().retries > 0);

    let (clock, _log, bus) = sim_can_bus(vec![ecs(3)], None);
    let opts = CanOptions {
        tries: 2,
        answer_timeout: Duration::from_millis(10),
    };
    let mut c = CanClient::with_options(bus, schema(), 9, opts).unwrap();
    let t0 = clock.now();
    let err = c.read(CodeKey::new(5001)).unwrap_err();
    assert!(
        matches!(
            *err.kind,
            ErrorKind::Link(LinkFailure::NoAnswer { tries: 2, .. })
        ),
        "{err}"
    );
    assert!(clock.now() - t0 >= Duration::from_millis(20));
}

#[test]
fn segmented_text_value() {
    let text = r#"
[schema]
id = "test-ecs-text"
title = "test: lenze-ecs plus a text code"
extends = "lenze-ecs"
fictional = true

[[code]]
number = 5100
name = "axis_name"
title = "Axis name (test)"
spec = "test"
type = "VS"
note = "test"
"#;
    let mut reg = catalog::registry().unwrap();
    let s = reg
        .add_source(SourceFile::new("test-ecs-text.toml", text))
        .expect("schema");
    let table = ParamTable::from_schema(Arc::clone(&s)).expect("table");
    let drive: Box<dyn FrameDrive> = Box::new(
        EcsDrive::with_table(NodeId::new(4).unwrap(), table, 1)
            .with_reaction(ReactionTime::fixed(Duration::from_millis(1))),
    );
    let (_clock, _log, bus) = sim_can_bus(vec![drive], None);
    let mut c = CanClient::new(bus, s, 4).unwrap();
    let name = RawValue::Text("X-axis gantry left".into());
    c.write(CodeKey::new(5100), &name).unwrap();
    assert_eq!(c.read(CodeKey::new(5100)).unwrap(), name);
}

#[test]
fn node_zero_and_unknown_codes_are_refused() {
    let (_clock, _log, bus) = sim_can_bus(vec![ecs(3)], None);
    assert!(matches!(
        *CanClient::new(bus, schema(), 0).unwrap_err().kind,
        ErrorKind::Refusal(Refused::Rule(_))
    ));
    let (_clock, _log, bus) = sim_can_bus(vec![ecs(3)], None);
    let mut c = CanClient::new(bus, schema(), 3).unwrap();
    assert!(matches!(
        *c.read(CodeKey::new(4242)).unwrap_err().kind,
        ErrorKind::Refusal(Refused::Rule(_))
    ));
}

/// A one-value set of `schema`: C5001 (max_speed of the fixtures) = raw.
fn speed_set(schema: &Schema, raw: i64) -> driveset_schema::ResolvedSet {
    let mut s = driveset_schema::ResolvedSet::new(schema);
    s.insert(CodeKey::new(5001), RawValue::Int(raw));
    s
}

#[test]
fn upload_reads_the_running_state_from_c0150_and_refuses_a_running_axis() {
    use driveset_engine::journal::TxnState;
    use driveset_engine::overrides::{Override, Overrides};
    use driveset_engine::upload::{UploadOptions, upload};
    let dir = tempfile::tempdir().expect("tempdir");
    let schema = schema();
    let set = speed_set(&schema, 12_345_678);

    // stopped (C0150 bit 1 clear): the upload goes through, no warning
    let (_clock, _log, bus) = sim_can_bus(vec![ecs(3)], None);
    let mut c = CanClient::new(bus, schema.clone(), 3).unwrap();
    let report =
        upload(&mut c, &set, &UploadOptions::new(dir.path().join("a.json"))).expect("stopped axis");
    assert_eq!(report.state, TxnState::Complete);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);

    // running: refused before anything is written
    let (_clock, log, mut bus) = sim_can_bus(vec![ecs(3)], None);
    bus.drive_mut(3).unwrap().set_running(true).unwrap();
    assert!(bus.drives()[0].running());
    let mut c = CanClient::new(bus, schema.clone(), 3).unwrap();
    assert_eq!(c.running().unwrap(), Some(true));
    let journal = dir.path().join("b.json");
    let err = upload(&mut c, &set, &UploadOptions::new(&journal)).expect_err("running");
    assert!(
        err.to_string().ends_with(
            "refused: the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running"
        ),
        "{err}"
    );
    assert!(!journal.exists());
    // no SDO download request (command byte 0x2x) reached the axis
    let downloads = log
        .events()
        .into_iter()
        .filter(|e| e.dir == Dir::Host)
        .filter(|e| {
            e.hex
                .split_whitespace()
                .nth(2)
                .is_some_and(|b| b.starts_with('2'))
        })
        .count();
    assert_eq!(downloads, 0, "{:?}", log.events());
    assert_eq!(
        c.read(CodeKey::new(5001)).unwrap(),
        RawValue::Int(30_000_000)
    );

    // --allow-running lifts exactly that refusal
    let mut opts = UploadOptions::new(dir.path().join("c.json"));
    opts.overrides = Overrides::only(Override::AllowRunning);
    let report = upload(&mut c, &set, &opts).expect("allowed");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(
        report.warnings,
        vec!["--allow-running: the drive reports a running motor".to_string()]
    );
}

#[test]
fn upload_to_an_axis_whose_schema_names_no_running_bit_needs_allow_running_unknown() {
    use driveset_engine::journal::TxnState;
    use driveset_engine::overrides::{Override, Overrides};
    use driveset_engine::upload::{UploadOptions, prepare, upload};
    // lenze-ecs itself (its excerpt names no bit of C0150) plus one FIX32 code
    let text = r#"
[schema]
id = "test-ecs-unknown"
title = "test: lenze-ecs plus one FIX32 code, no running bit"
extends = "lenze-ecs"
fictional = true

[[code]]
number = 5001
name = "max_speed"
title = "Maximum speed (test)"
spec = "test"
type = "FIX32"
note = "test"
"#;
    let mut reg = catalog::registry().unwrap();
    let s = reg
        .add_source(SourceFile::new("test-ecs-unknown.toml", text))
        .expect("schema");
    assert_eq!(s.running_indicator(), None);
    let drive = || -> Box<dyn FrameDrive> {
        let table = ParamTable::from_schema(Arc::clone(&s)).expect("table");
        Box::new(
            EcsDrive::with_table(NodeId::new(4).unwrap(), table, 1)
                .with_reaction(ReactionTime::fixed(Duration::from_millis(1))),
        )
    };
    let set = speed_set(&s, 12_345_678);
    let dir = tempfile::tempdir().expect("tempdir");
    let why = "running state unknown: schema `test-ecs-unknown` names no status bit (role `running`) or control word start bit that says whether the motor runs";

    let (_clock, _log, mut bus) = sim_can_bus(vec![drive()], None);
    assert!(bus.drive_mut(4).unwrap().set_running(true).is_err());
    let mut c = CanClient::new(bus, Arc::clone(&s), 4).unwrap();
    assert_eq!(c.running().unwrap(), None);
    // the dry run says so too
    let err = prepare(&mut c, &set, Overrides::none()).expect_err("unknown");
    assert!(
        err.to_string().ends_with(&format!(
            "refused: {why}; make sure the drive is at standstill, then pass --allow-running-unknown"
        )),
        "{err}"
    );
    let journal = dir.path().join("a.json");
    let err = upload(&mut c, &set, &UploadOptions::new(&journal)).expect_err("unknown");
    assert!(err.to_string().contains(why), "{err}");
    assert!(!journal.exists());
    // --allow-running does not lift it
    let mut opts = UploadOptions::new(&journal);
    opts.overrides = Overrides::only(Override::AllowRunning);
    assert!(upload(&mut c, &set, &opts).is_err());

    let mut opts = UploadOptions::new(dir.path().join("b.json"));
    opts.overrides = Overrides::only(Override::AllowRunningUnknown);
    let report = upload(&mut c, &set, &opts).expect("allowed");
    assert_eq!(report.state, TxnState::Complete);
    assert_eq!(
        report.warnings,
        vec![
            "running state unknown (--allow-running-unknown): schema `test-ecs-unknown` names no status bit (role `running`) or control word start bit that says whether the motor runs"
                .to_string()
        ]
    );
    let p = prepare(&mut c, &speed_set(&s, 1), opts.overrides).expect("plan");
    assert!(
        p.plan
            .render(None)
            .contains("warning: running state unknown (--allow-running-unknown)"),
        "{}",
        p.plan.render(None)
    );
}

/// The write guard on the SDO download (issue 17): a C0135 value of the
/// fixture without its inhibit bit, and a CiA 402 controlword 0x6040 that
/// enables operation in a schema without roles (the ECS floor), are
/// refused and no frame goes out; a stopped value is downloaded.
#[test]
fn the_write_guard_refuses_sdo_downloads_that_would_enable_the_axis() {
    let (_clock, log, bus) = sim_can_bus(vec![ecs(3)], None);
    let mut c = CanClient::new(bus, schema(), 3).unwrap();
    let e = c.write(CodeKey::new(135), &RawValue::Int(0)).unwrap_err();
    assert!(
        matches!(*e.kind, ErrorKind::Refusal(Refused::Rule(_))),
        "{e}"
    );
    assert!(e.to_string().contains("C0135 = "), "{e}");
    assert!(
        e.to_string().contains("sets none of the inhibit bits"),
        "{e}"
    );
    assert!(log.events().is_empty(), "nothing sent");

    let mut r = driveset_schema::Registry::new();
    let bare = r
        .add_source(SourceFile::new(
            "bare.toml",
            "[schema]\nid = \"bare-402\"\ntitle = \"CiA 402 objects, no roles\"\nprotocol = \"lenze-can-sdo\"\ncode_style = \"lenze\"\n[schema.can]\nindex_base = 24575\n\n[[code]]\nindex = 0x6040\nname = \"controlword\"\ntype = \"UNSIGNED16\"\n",
        ))
        .expect("schema");
    let (_clock, log, bus) = sim_can_bus(vec![ecs(3)], None);
    let mut c = CanClient::new(bus, bare, 3).unwrap();
    let cw = CodeKey::new(driveset_schema::schema::CIA_NUMBER_BASE + 0x6040);
    let e = c.write(cw, &RawValue::Int(0x0F)).unwrap_err();
    assert!(
        e.to_string()
            .contains("would start or enable the drive (switch_on, enable_operation set)"),
        "{e}"
    );
    assert!(log.events().is_empty(), "nothing sent");
}

/// A schema whose store step is a device command with a readable status
/// (`[schema.store] done`, as Lenze's 8400 / 9400 C00002 "save start
/// parameters"): C5990 = 1 (raw 10000, FIX32) stores, C5990 reads 0 once done. FICTIONAL code.
fn device_command_schema(timeout_ms: u64) -> Arc<Schema> {
    let text = format!(
        r#"
[schema]
id = "test-ecs-device-command"
title = "test: the ECS demo storing by a device command"
extends = "fictional-ecs-demo"
fictional = true

[schema.store]
keeps = "on-command"
code = "save_parameters"
value = 10000
done = 0
poll_ms = 50
timeout_ms = {timeout_ms}
spec = "test"

[[code]]
number = 5990
name = "save_parameters"
title = "Save parameters (test device command)"
spec = "test"
type = "FIX32"
role = "command"
"#
    );
    catalog::registry()
        .unwrap()
        .add_source(SourceFile::new("test-ecs-device-command.toml", text))
        .expect("schema")
}

fn device_command_drive(s: &Arc<Schema>) -> Box<dyn FrameDrive> {
    let table = ParamTable::from_schema(Arc::clone(s)).expect("table");
    Box::new(
        EcsDrive::with_table(NodeId::new(4).unwrap(), table, 1)
            .with_reaction(ReactionTime::fixed(Duration::from_millis(1))),
    )
}

/// The store step waits as its schema says: the acknowledgement, then the
/// device command's status read every `poll_ms` until it reads `done`
/// (the simulated store runs `STORE_RUNS`, 300 ms, after it is
/// acknowledged); the values are stored only then.
#[test]
fn a_device_command_store_is_polled_until_done() {
    let s = device_command_schema(2000);
    let (clock, log, bus) = sim_can_bus(vec![device_command_drive(&s)], None);
    let mut c = CanClient::new(bus, Arc::clone(&s), 4).unwrap();
    c.write(CodeKey::new(5001), &RawValue::Int(25_000_000))
        .unwrap();
    let command = s.store.command().expect("on-command").clone();
    let t0 = clock.now();
    c.store(&command).unwrap();
    let waited = clock.now() - t0;
    assert!(
        waited >= driveset_sim::ecs::STORE_RUNS
            && waited < driveset_sim::ecs::STORE_RUNS + Duration::from_millis(60),
        "{waited:?}"
    );
    // the write of C5990 (index 24575 - 5990 = 18585 = 0x4899), then its reads: one
    // per 50 ms poll while the store runs, the last one 0
    let reads = log
        .events()
        .iter()
        .filter(|e| e.dir == Dir::Host && e.hex.contains("40 99 48 00"))
        .count();
    assert_eq!(reads, 7, "a read at 0, 50, ..., 300 ms");
    assert_eq!(
        c.read(CodeKey::new(5990)).unwrap(),
        RawValue::Int(0),
        "done"
    );
}

/// A store that does not finish within `timeout_ms` fails naming what the
/// status read last.
#[test]
fn a_device_command_store_that_does_not_finish_in_time_fails() {
    let s = device_command_schema(200);
    let (_clock, _log, bus) = sim_can_bus(vec![device_command_drive(&s)], None);
    let mut c = CanClient::new(bus, Arc::clone(&s), 4).unwrap();
    let command = s.store.command().expect("on-command").clone();
    let err = c.store(&command).unwrap_err();
    assert!(
        err.to_string().ends_with(
            "unexpected answer to store (C5990 save_parameters = 1): C5990 save_parameters still reads 1, not 0 (done), 200 ms after the store command: the drive did not finish storing within [schema.store] timeout_ms; do not power it off before it has"
        ),
        "{err}"
    );
}
