//! Machine lines: manifest findings, commissioning the demo line against
//! simulated buses (virtual time), resume, status drift, broadcast.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use driveset_engine::env::Environment;
use driveset_engine::line::commission::{
    CommissionState, LineObserver, LineOptions, STATE_FILE, StopAfter, Verdict, commission,
};
use driveset_engine::line::manifest::{Manifest, load_manifest, validate_manifest};
use driveset_engine::line::report::{DriveResult, LineResult};
use driveset_engine::line::status::status;
use driveset_link::{Link, PortSpec, VirtualClock};
use driveset_schema::{CodeKey, RawValue, Registry};
use driveset_sim::open::{SimLink, open_sim};

use driveset_test_support::{sim_openers, workspace_root};

/// The wall-clock instant every report and state entry of these tests
/// carries.
const FIXED_NOW: &str = "2026-12-01T08:30:00.250Z";

/// A fixed wall-clock time, no git, real files (the tests read the state
/// and learned schema files back from disk).
struct DiskEnv;

impl Environment for DiskEnv {
    fn now_utc(&self) -> jiff::Timestamp {
        FIXED_NOW.parse().unwrap()
    }
    fn git_info(&self, _dir: &Path) -> Option<driveset_engine::line::report::GitInfo> {
        None
    }
    fn read_file(&self, path: &Path) -> std::io::Result<Option<String>> {
        match std::fs::read_to_string(path) {
            Ok(t) => Ok(Some(t)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e),
        }
    }
    fn write_file(&self, path: &Path, text: &str) -> std::io::Result<()> {
        if let Some(d) = path.parent() {
            std::fs::create_dir_all(d)?;
        }
        let tmp = path.with_extension("tmp");
        std::fs::write(&tmp, text)?;
        std::fs::rename(&tmp, path)
    }
    fn create_dir(&self, dir: &Path) -> std::io::Result<()> {
        std::fs::create_dir_all(dir)
    }
}

fn disk_env() -> std::sync::Arc<dyn Environment> {
    std::sync::Arc::new(DiskEnv)
}

fn demo() -> Manifest {
    let path = workspace_root().join("parameter-sets/demo-line/line.toml");
    let mut reg = Registry::builtin().expect("builtin");
    let l = load_manifest(&path, &mut reg, &sim_openers()).expect("manifest reads");
    assert!(
        l.findings.is_empty(),
        "{}",
        l.findings
            .iter()
            .map(|f| f.render_human())
            .collect::<String>()
    );
    l.manifest.expect("manifest")
}

/// Simulated buses that live across runs (one virtual clock each).
#[derive(Default)]
struct Sims(Mutex<BTreeMap<String, SimLink>>);

impl Sims {
    fn open(&self, bus: &driveset_engine::line::manifest::Bus) -> Result<Link, String> {
        let mut m = self.0.lock().unwrap();
        if let Some(s) = m.get(&bus.name) {
            return Ok(s.link());
        }
        let PortSpec::Sim(spec) = &bus.port else {
            return Err("not a sim port".into());
        };
        let spec = driveset_sim::port::SimSpec::from_opaque(spec).map_err(|e| e.to_string())?;
        let s = open_sim(&spec, &VirtualClock::new()).map_err(|e| e.to_string())?;
        let l = s.link();
        m.insert(bus.name.clone(), s);
        Ok(l)
    }

    fn get(&self, bus: &str) -> SimLink {
        self.0.lock().unwrap()[bus].clone()
    }
}

#[test]
fn demo_manifest_loads_with_three_buses_and_thirteen_drives() {
    let m = demo();
    assert_eq!(m.name, "demo-line");
    assert_eq!(m.buses.len(), 3);
    assert_eq!(m.drives.len(), 13);
    // One LUSTBUS with servocontrollers and inverters on it.
    assert_eq!(
        m.buses[0].port_name,
        "sim://lustbus?mc6000=1,2,3,4&vf1000=5,6,7&baud=9600"
    );
    let on_lustbus: Vec<&str> = m
        .drives
        .iter()
        .filter(|d| d.bus == "lustbus")
        .map(|d| d.schema.id.as_str())
        .collect();
    assert_eq!(on_lustbus.len(), 7);
    assert!(
        on_lustbus.iter().any(|s| s.contains("mc6000")),
        "{on_lustbus:?}"
    );
    assert!(
        on_lustbus.iter().any(|s| s.contains("vf1000")),
        "{on_lustbus:?}"
    );
    assert_eq!(
        validate_manifest(
            &workspace_root().join("parameter-sets/demo-line/line.toml"),
            &sim_openers()
        )
        .expect("reads")
        .len(),
        0
    );
}

#[test]
fn commission_demo_line_then_rerun_costs_only_reads_then_status_finds_drift() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let opts = LineOptions::new(dir.path(), disk_env());
    let first = commission(&m, &opts, &opener).expect("runs");
    for d in &first.report.drives {
        assert_eq!(d.result, DriveResult::Verified, "{d:?}");
        assert_eq!(
            d.fingerprint_after.as_deref(),
            Some(d.set_fingerprint.as_str())
        );
        assert!(d.codes_written > 0);
        assert!(!d.diff.is_empty());
    }
    assert_eq!(first.verdict(), Verdict::Holds);
    assert_eq!(first.report.result, LineResult::Ok);
    assert_eq!(first.report.buses.len(), 3);
    for b in &first.report.buses {
        assert!(b.elapsed_ms > 0.0);
        assert!(
            b.timeline.iter().any(|t| t.phase.as_str() == "write"),
            "{b:?}"
        );
        assert!(
            b.timeline.iter().any(|t| t.phase.as_str() == "verify"),
            "{b:?}"
        );
    }
    // wall-clock times come from the environment, RFC 3339 with ms
    assert_eq!(first.report.started, FIXED_NOW);
    assert_eq!(first.report.finished, FIXED_NOW);
    assert_eq!(first.report.git, None);
    // state file: every drive at its set fingerprint
    let state = CommissionState::load(&DiskEnv, dir.path()).expect("state");
    assert_eq!(state.drives.len(), 13);
    assert!(state.drives.values().all(|e| e.verified_at == FIXED_NOW));
    assert_eq!(
        state.drives["lustbus/2"].fingerprint,
        m.drives[1].set.fingerprint()
    );

    // rerun: every drive already verified, confirmed by reads only
    let second = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(second.verdict(), Verdict::Holds);
    for d in &second.report.drives {
        assert_eq!(d.result, DriveResult::AlreadyVerified, "{d:?}");
        assert_eq!(d.codes_written, 0);
    }
    for b in &second.report.buses {
        assert!(
            b.timeline
                .iter()
                .all(|t| t.phase.as_str() == "identify" || t.phase.as_str() == "read"),
            "{b:?}"
        );
    }
    // the read-only check costs the same bus time
    let st = status(&m, &opts, &opener).expect("runs");
    assert_eq!(st.verdict(), Verdict::Holds);
    assert_eq!(st.report.command, "status");
    // (within 3%: the drives' seeded reaction times differ from run to run;
    // the slowest bus is the 7-drive mixed LUSTBUS at 9600 baud)
    assert!(
        second.line_ms() <= st.line_ms() * 1.03,
        "{} vs {}",
        second.line_ms(),
        st.line_ms()
    );

    // a drive drifts: status names it and the code, exit 1
    let tmd = sims.get("transfer");
    tmd.poke(12, CodeKey::new(11), RawValue::Int(550_000))
        .expect("poke");
    let st = status(&m, &opts, &opener).expect("runs");
    assert_eq!(st.verdict(), Verdict::Differs);
    assert_eq!(st.report.result, LineResult::Drift);
    let drifted: Vec<_> = st
        .report
        .drives
        .iter()
        .filter(|d| d.result == DriveResult::Drift)
        .collect();
    assert_eq!(drifted.len(), 1, "{drifted:?}");
    assert_eq!(drifted[0].name, "transfer-12");
    assert_eq!(drifted[0].diff.len(), 1);
    assert_eq!(drifted[0].diff[0].code, "C0011");
    assert_eq!(drifted[0].diff[0].old.as_deref(), Some("55 Hz"));
    assert_eq!(drifted[0].diff[0].new.as_deref(), Some("60 Hz"));

    // commission again: the drifted drive is rewritten, the rest confirmed
    let third = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(third.verdict(), Verdict::Holds);
    for d in &third.report.drives {
        let want = if d.name == "transfer-12" {
            DriveResult::Verified
        } else {
            DriveResult::AlreadyVerified
        };
        assert_eq!(d.result, want, "{d:?}");
    }
    assert_eq!(third.report.drives[8].codes_written, 1);
}

/// Told nothing: the inner observer of the engine's `StopAfter`.
struct Quiet;

impl LineObserver for Quiet {}

/// Stops every bus after `n` drives, as if the run had been killed there.
fn stop_after(n: usize) -> StopAfter {
    StopAfter {
        n,
        who: "--stop-after".into(),
        inner: Arc::new(Quiet),
    }
}

#[test]
fn a_stopped_run_resumes_where_it_stopped() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path(), disk_env());
    opts.observer = Some(Arc::new(stop_after(2)));
    let first = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(first.verdict(), Verdict::BusFailed);
    let verified: Vec<&str> = first
        .report
        .drives
        .iter()
        .filter(|d| d.result == DriveResult::Verified)
        .map(|d| d.name.as_str())
        .collect();
    // two per bus, three buses
    assert_eq!(verified.len(), 6, "{verified:?}");
    let stopped = &first.report.drives[2];
    assert_eq!(stopped.result, DriveResult::Failed);
    assert!(stopped.error.as_deref().unwrap().contains("--stop-after"));

    opts.observer = None;
    let second = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(second.verdict(), Verdict::Holds);
    for d in &second.report.drives {
        let want = if verified.contains(&d.name.as_str()) {
            DriveResult::AlreadyVerified
        } else {
            DriveResult::Verified
        };
        assert_eq!(d.result, want, "{}", d.name);
    }
}

#[test]
fn only_and_skip_select_by_drive_or_bus_name() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path(), disk_env());
    opts.only = vec!["transfer".into(), "press-axis-1".into()];
    opts.skip = vec!["transfer-13".into()];
    let r = commission(&m, &opts, &opener).expect("runs");
    let done: Vec<&str> = r
        .report
        .drives
        .iter()
        .filter(|d| d.result != DriveResult::NotSelected)
        .map(|d| d.name.as_str())
        .collect();
    assert_eq!(done, ["press-axis-1", "transfer-11", "transfer-12"]);
    assert_eq!(r.verdict(), Verdict::Holds);
    opts.only = vec!["nope".into()];
    let e = commission(&m, &opts, &opener).unwrap_err();
    assert!(
        e.to_string().contains("no drive or bus is named `nope`"),
        "{e}"
    );
}

#[test]
fn broadcast_common_multicasts_to_the_lecom_group_then_verifies_each_drive() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path(), disk_env());
    opts.only = vec!["transfer".into()];
    opts.broadcast_common = true;
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Holds, "{:?}", r.report.drives);
    let bus = &r.report.buses[1];
    assert!(
        bus.timeline
            .iter()
            .any(|t| t.phase.as_str() == "broadcast" && t.drive == "group 10"),
        "{bus:?}"
    );
    // the common values landed by MULTICAST: each drive wrote only its own
    let written: Vec<u32> = r.report.drives[7..10]
        .iter()
        .map(|d| d.codes_written)
        .collect();
    assert!(written[0] < written[2], "{written:?}");
    for d in &r.report.drives[7..10] {
        assert!(
            matches!(d.result, DriveResult::Verified | DriveResult::Unchanged),
            "{d:?}"
        );
        assert_eq!(
            d.fingerprint_after.as_deref(),
            Some(d.set_fingerprint.as_str())
        );
    }
}

#[test]
fn a_bus_that_cannot_be_opened_fails_its_drives_with_exit_3() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| {
        if b.name == "handling" {
            Err("port gone".to_string())
        } else {
            sims.open(b)
        }
    };
    let r = commission(&m, &LineOptions::new(dir.path(), disk_env()), &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::BusFailed);
    assert_eq!(r.report.result, LineResult::Failed);
    let h = &r.report.drives[10];
    assert_eq!(h.result, DriveResult::Failed);
    assert_eq!(
        h.error.as_deref(),
        Some(
            "bus `handling` (sim://ecs?addresses=1,2,3&bitrate=500000) could not be opened: port gone"
        )
    );
    assert!(dir.path().join(STATE_FILE).exists());
}

fn findings(text: &str, sets: &[(&str, &str)]) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    for (name, body) in sets {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    let p = dir.path().join("line.toml");
    std::fs::write(&p, text).unwrap();
    let d = dir.path().display().to_string();
    validate_manifest(&p, &sim_openers())
        .expect("reads")
        .iter()
        .map(|f| {
            format!(
                "{}:{} [{}] {}",
                f.location.line, f.location.column, f.kind, f.message
            )
            .replace(&d, "DIR")
        })
        .collect()
}

const TMD_SET: &str = "schema = \"lenze-tmd\"\n[values]\nC0011 = \"50.0 Hz\"\n";
const VF_SET: &str = "schema = \"lust-vf1000\"\n[values]\n";

#[test]
fn manifest_findings_have_exact_messages_and_locations() {
    let text = r#"[line]
name = "bad"
colour = "red"

[[bus]]
name = "a"
port = "sim://tmd"
protocol = "lecom"

[[bus]]
name = "b"
port = "/dev/ttyUSB0"
protocol = "lustbus"
baud = 19200

[[drive]]
bus = "a"
address = 20
set = "tmd.toml"

[[drive]]
bus = "a"
address = 11
set = "tmd.toml"

[[drive]]
name = "a/11"
bus = "a"
address = 11
set = "tmd.toml"

[[drive]]
bus = "b"
address = 31
set = "tmd.toml"

[[drive]]
bus = "b"
address = 40
set = "vf.toml"

[[drive]]
bus = "c"
address = 1
set = "missing.toml"
"#;
    let got = findings(text, &[("tmd.toml", TMD_SET), ("vf.toml", VF_SET)]);
    let want = [
        "3:1 [unknown-key] unknown key `colour` in [line]",
        "18:11 [group-address] address 20 on lecom bus `a`: LECOM 00 is the broadcast address and 10, 20, ... 90 are group addresses; a drive needs its own address 1..99 not ending in 0",
        "29:11 [duplicate-address] address 11 is used twice on bus `a`",
        "27:8 [duplicate-name] drive name `a/11` is used twice",
        "34:11 [group-address] address 31 on lustbus bus `b`: LUSTBUS address 0 is the group address and 31 the broadcast address; a drive needs its own address 1..30",
        "35:7 [set-family] set `tmd.toml` is for schema `lenze-tmd` (tmd drives, protocol lecom), which does not run on lustbus bus `b`",
        "39:11 [address-out-of-range] address 40 on lustbus bus `b`: LUSTBUS drive addresses are 1..30",
        "43:7 [unknown-bus] no bus is named `c`",
        "45:7 [missing-set] set file `missing.toml` does not exist (DIR/missing.toml)",
    ];
    assert_eq!(got, want);
}

#[test]
fn manifest_set_findings_and_sim_family_are_reported() {
    let text = "[[bus]]\nname = \"a\"\nport = \"sim://vf1000\"\nprotocol = \"lustbus\"\nspeed = 1\n\n[[drive]]\nbus = \"a\"\naddress = 1\nset = \"mc.toml\"\n\n[[drive]]\nbus = \"a\"\naddress = 2\nset = \"bad.toml\"\n";
    let mc = "schema = \"lust-mc6000\"\n[values]\n";
    let bad = "schema = \"lust-vf1000\"\n[values]\nNOPE = 1\n";
    let got = findings(text, &[("mc.toml", mc), ("bad.toml", bad)]);
    assert_eq!(got.len(), 3, "{got:#?}");
    assert_eq!(got[0], "5:1 [unknown-key] unknown key `speed` in a bus");
    assert_eq!(
        got[1],
        "7:1 [set-family] drive `a/1` has a `lust-mc6000` set, but simulated bus `a` holds `vf1000` drives"
    );
    assert_eq!(
        got[2],
        "3:1 [unknown-code] `NOPE` is not a code name of lust-vf1000"
    );
}

#[test]
fn a_mixed_sim_lustbus_checks_the_family_per_address() {
    let mc = "schema = \"lust-mc6000\"\n[values]\n";
    let vf = "schema = \"lust-vf1000\"\n[values]\n";
    let drives = "[[drive]]\nbus = \"l\"\naddress = 1\nset = \"mc.toml\"\n\n[[drive]]\nbus = \"l\"\naddress = 5\nset = \"vf.toml\"\n";
    let bus = |port: &str| {
        format!("[[bus]]\nname = \"l\"\nport = \"{port}\"\nprotocol = \"lustbus\"\n\n{drives}")
    };
    let sets = [("mc.toml", mc), ("vf.toml", vf)];
    assert!(findings(&bus("sim://lustbus?mc6000=1&vf1000=5"), &sets).is_empty());
    // Without per-family keys the manifest's drives are simulated.
    assert!(findings(&bus("sim://lustbus"), &sets).is_empty());
    let got = findings(&bus("sim://lustbus?vf1000=1,5"), &sets);
    assert_eq!(
        got,
        [
            "6:1 [set-family] drive `l/1` has a `lust-mc6000` set, but simulated bus `l` has a `vf1000` drive at address 1"
        ]
    );
    let got = findings(&bus("sim://lustbus?mc6000=1"), &sets);
    assert_eq!(got.len(), 1, "{got:?}");
    assert!(
        got[0].contains("drive `l/5` is at address 5, which simulated bus `l` does not have"),
        "{got:?}"
    );
}

#[test]
fn yaml_manifest_with_buses_and_drives_lists_reads_like_toml() {
    let text = "line:\n  name: yaml-line\nbuses:\n  - name: t\n    port: sim://tmd\n    protocol: lecom\n    baud: 19200\ndrives:\n  - bus: t\n    address: 11\n    set: tmd.toml\n  - bus: t\n    address: 12\n    set: tmd.toml\n    name: second\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tmd.toml"), TMD_SET).unwrap();
    let p = dir.path().join("line.yaml");
    std::fs::write(&p, text).unwrap();
    let mut reg = Registry::builtin().unwrap();
    let l = load_manifest(&p, &mut reg, &sim_openers()).expect("reads");
    assert!(l.findings.is_empty(), "{:?}", l.findings);
    let m = l.manifest.unwrap();
    assert_eq!(m.name, "yaml-line");
    assert_eq!(m.buses[0].port_name, "sim://tmd?addresses=11,12&baud=19200");
    let names: Vec<&str> = m.drives.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["t/11", "second"]);
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let out = dir.path().join("out");
    let r = commission(&m, &LineOptions::new(&out, disk_env()), &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Holds, "{:?}", r.report.drives);
}

/// A LECOM group holding a drive with an unfinished journal gets no
/// MULTICAST; that drive is recovered first (here: the journal does not fit
/// it, so it fails), the others are commissioned drive by drive.
#[test]
fn broadcast_common_skips_a_group_with_an_unfinished_journal() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path(), disk_env());
    opts.only = vec!["transfer".into()];
    opts.broadcast_common = true;
    std::fs::create_dir_all(&opts.journal_dir).unwrap();
    let journal = opts.journal_dir.join("by-hand.journal.json");
    std::fs::write(
        &journal,
        r#"{"journal_version":2,"state":"writing",
            "target":{"port":"sim://tmd","address":12,"bus":"sim:tmd~PID"},
            "identity":{"protocol":"lecom","codes":[["C0200","\"another drive\""]],"software":null},
            "schema":"lenze-tmd","set_fingerprint":"x","fingerprint_before":"y","dataset":false,
            "attempt":1,"backup":[],"plan":[],"written":[],"transitions":[],"failure":null}"#
            // the in-process bus's id names this process (sim:NAME~PID)
            .replace("PID", &std::process::id().to_string()),
    )
    .unwrap();
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Differs, "{:?}", r.report.drives);
    assert!(
        r.warnings.contains(&format!(
            "bus `transfer` group 10: no MULTICAST while the group has unfinished journals ({}); values were written drive by drive after recovery",
            journal.display()
        )),
        "{:?}",
        r.warnings
    );
    assert!(
        !r.report.buses[1]
            .timeline
            .iter()
            .any(|t| t.phase.as_str() == "broadcast")
    );
    let by_name = |n: &str| r.report.drives.iter().find(|d| d.name == n).unwrap();
    let t12 = by_name("transfer-12");
    assert_eq!(t12.result, DriveResult::Failed);
    let err = t12.error.as_deref().unwrap();
    assert!(
        err.starts_with(&format!(
            "journal {}: the drive has an unfinished transaction from an earlier run, and recovering it failed: ",
            journal.display()
        )) && err.contains("refused to recover journal")
            && err.contains("but the journal was written for lecom: C0200 = \"another drive\""),
        "{err}"
    );
    for n in ["transfer-11", "transfer-13"] {
        assert_eq!(by_name(n).result, DriveResult::Verified, "{:?}", by_name(n));
    }
}

/// A line whose sets name the built-in LUSTBUS schemas (which lack the
/// codes' types and ranges): the manifest loads with the sets' findings
/// kept apart (`learnable`), commission learns each drive's schema from its
/// descriptions over the bus's link, writes it, resolves the set against it
/// and verifies; the drive then holds the exact values; status learns
/// read-only and finds no drift; without learning the drives fail.
#[test]
fn commission_learns_the_schema_of_sets_naming_the_built_in_lust_schemas() {
    use driveset_engine::line::commission::LineLearn;
    use driveset_engine::plan::value_text;

    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("line.toml");
    std::fs::write(
        &p,
        "[line]\nname = \"learn\"\n\n[[bus]]\nname = \"lb\"\nport = \"sim://lustbus?mc6000=1&vf1000=5\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n[[drive]]\nbus = \"lb\"\naddress = 1\nset = \"press.toml\"\nname = \"press\"\n\n[[drive]]\nbus = \"lb\"\naddress = 5\nset = \"fan.toml\"\nname = \"fan\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("press.toml"),
        "schema = \"lust-mc6000\"\n\n[values]\n100 = \"16 kHz\"\n132 = \"5 A\"\n134 = \"3500 1/min\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("fan.toml"),
        "schema = \"lust-vf1000\"\n\n[values]\n7 = \"60 Hz\"\n20 = \"15 Hz\"\n",
    )
    .unwrap();
    let mut reg = Registry::builtin().unwrap();
    let l = load_manifest(&p, &mut reg, &sim_openers()).unwrap();
    assert!(l.findings.is_empty(), "{:?}", l.findings);
    let learnable: Vec<String> = l
        .learnable
        .iter()
        .map(|f| format!("{}:{} {}", f.location.line, f.location.column, f.message))
        .collect();
    assert_eq!(
        learnable,
        [
            "4:1 100 is not a code of lust-mc6000",
            "5:1 132 is not a code of lust-mc6000",
            "6:1 134 is not a code of lust-mc6000",
            "4:1 7 is not a code of lust-vf1000",
            "5:1 20 is not a code of lust-vf1000",
        ]
    );
    assert!(
        l.learnable[0].help.contains(
            "`driveset commission` and `driveset status` learn the schema from the drive first"
        ),
        "{}",
        l.learnable[0].help
    );
    // offline, validate keeps them as findings
    assert_eq!(validate_manifest(&p, &sim_openers()).unwrap().len(), 5);
    let m = l.manifest.expect("loads");
    assert_eq!(
        m.drives
            .iter()
            .map(|d| d.learn_from.as_ref().map(|s| s.id.as_str()))
            .collect::<Vec<_>>(),
        [Some("lust-mc6000"), Some("lust-vf1000")]
    );

    // without learning: the drives fail, nothing is written
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let out = commission(
        &m,
        &LineOptions::new(dir.path().join("off"), disk_env()),
        &opener,
    )
    .unwrap();
    assert_eq!(out.verdict(), Verdict::Differs);
    assert!(
        out.report.drives[0]
            .error
            .as_deref()
            .unwrap()
            .ends_with("set `press.toml` names `lust-mc6000`, which lacks facts (types, kinds, ranges) the drive's descriptions give, and learning is off (--no-learn); name a learned schema in the set (`driveset schema pull`)"),
        "{:?}",
        out.report.drives[0].error
    );

    let schemas = dir.path().join("schemas");
    let mut opts = LineOptions::new(dir.path().join("report"), disk_env());
    opts.learn = Some(LineLearn {
        registry: Registry::builtin().unwrap(),
        schema_dir: schemas.clone(),
        options: Default::default(),
    });
    let out = commission(&m, &opts, &opener).unwrap();
    assert_eq!(out.verdict(), Verdict::Holds, "{:?}", out.report.drives);
    let mut ids = Vec::new();
    for (d, base, codes_written) in [
        (&out.report.drives[0], "lust-mc6000", 3),
        (&out.report.drives[1], "lust-vf1000", 2),
    ] {
        assert_eq!(d.result, DriveResult::Verified, "{:?}", d.error);
        assert_eq!(d.codes_written, codes_written);
        let ls = d.learned_schema.as_ref().expect("learned");
        assert_eq!(ls.base, base);
        assert_eq!(d.schema, ls.id);
        assert!(ls.texts);
        let file = schemas.join(format!("{}.toml", ls.id));
        assert_eq!(
            ls.file.as_deref(),
            Some(file.display().to_string().as_str())
        );
        assert!(file.is_file());
        ids.push(ls.id.clone());
    }
    assert!(ids[0].starts_with("learned-mc6000-type6000-d"), "{ids:?}");
    assert!(ids[1].starts_with("learned-vf1000-type1000-d"), "{ids:?}");
    let phases: Vec<(&str, &str)> = out.report.buses[0]
        .timeline
        .iter()
        .map(|t| (t.drive.as_str(), t.phase.as_str()))
        .filter(|(_, p)| *p == "learn")
        .collect();
    assert_eq!(phases, [("press", "learn"), ("fan", "learn")]);

    // the drives hold exactly the set's values (read with the learned schemas)
    let mut learned = Registry::builtin().unwrap();
    learned.load_dir(&schemas).unwrap();
    let mut link = sims.get("lb").link();
    for (id, address, want) in [
        (
            &ids[0],
            1,
            &[(100, "\"16 kHz\""), (132, "5 A"), (134, "3500 1/min")][..],
        ),
        (&ids[1], 5, &[(7, "60 Hz"), (20, "15 Hz")][..]),
    ] {
        let schema = learned.get(id).unwrap();
        let mut c = driveset_engine::connect::connect_on(
            &mut link,
            schema.clone(),
            address,
            &Default::default(),
        )
        .unwrap();
        for (code, text) in want {
            let key = CodeKey::new(*code);
            let raw = c.read(key).unwrap();
            assert_eq!(value_text(&schema, key, &raw), *text, "{id} {code}");
        }
        c.finish().unwrap();
    }

    // status: read-only learning, the commission's file is used; no drift
    let mut sopts = opts.clone();
    sopts.report_dir = dir.path().join("status");
    let st = status(&m, &sopts, &opener).unwrap();
    assert_eq!(st.verdict(), Verdict::Holds, "{:?}", st.report.drives);
    for (d, id) in st.report.drives.iter().zip(&ids) {
        assert_eq!(d.result, DriveResult::Unchanged);
        let ls = d.learned_schema.as_ref().unwrap();
        assert_eq!(&ls.id, id);
        assert!(!ls.texts);
        assert_eq!(
            ls.file.as_deref(),
            Some(
                schemas
                    .join(format!("{id}.toml"))
                    .display()
                    .to_string()
                    .as_str()
            )
        );
    }
}

/// The line run's world is its Environment: the report's times and git
/// commit and the resume state come from it, nothing else is written but
/// the journals' directory.
#[test]
fn a_line_run_takes_time_git_and_its_state_file_from_the_environment() {
    use driveset_engine::env::Memory;
    use driveset_engine::line::report::GitInfo;
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = Sims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let git = GitInfo {
        commit: "0123456789abcdef0123456789abcdef01234567".into(),
        dirty: true,
    };
    let env = std::sync::Arc::new(
        Memory::at("2031-07-04T12:00:00Z".parse().unwrap()).with_git(git.clone()),
    );
    let report_dir = dir.path().join("report");
    let mut opts = LineOptions::new(&report_dir, env.clone());
    opts.journal_dir = dir.path().join("journal");
    opts.only = vec!["transfer-11".into()];
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Holds, "{:?}", r.report.drives);
    assert_eq!(r.report.started, "2031-07-04T12:00:00.000Z");
    assert_eq!(r.report.finished, "2031-07-04T12:00:00.000Z");
    assert_eq!(r.report.git, Some(git));
    // the state file went to the environment, not to the disk
    let state_path = report_dir.join(STATE_FILE);
    assert_eq!(env.paths(), std::slice::from_ref(&state_path));
    assert!(!report_dir.exists());
    let text = env.file(&state_path).expect("state written");
    assert!(
        text.contains("\"verified_at\": \"2031-07-04T12:00:00.000Z\""),
        "{text}"
    );
    let state = CommissionState::load(&*env, &report_dir).expect("state reads");
    assert_eq!(state.drives.len(), 1);
    // a rerun reads it back from there: already verified
    let again = commission(&m, &opts, &opener).expect("runs");
    let t11 = |r: &driveset_engine::line::commission::LineOutcome| {
        r.report
            .drives
            .iter()
            .find(|d| d.name == "transfer-11")
            .unwrap()
            .result
    };
    assert_eq!(t11(&again), DriveResult::AlreadyVerified);
    // the timelines: the runner's own phases (planning holds the running
    // check's status read; the journal writes take no time on the virtual
    // clock and are left out), then the resume check
    let phases = |r: &driveset_engine::line::commission::LineOutcome| -> Vec<String> {
        r.report
            .buses
            .iter()
            .flat_map(|b| b.timeline.iter().map(|t| t.phase.as_str().to_string()))
            .collect()
    };
    assert_eq!(phases(&r), ["identify", "read", "plan", "write", "verify"]);
    assert_eq!(phases(&again), ["identify", "read"]);
}

// ---------------------------------------------------------------------------
// LUSTBUS broadcast of common values (address 31, inside each dataset)
// ---------------------------------------------------------------------------

/// A line of `n` MC6000 axes on one LUSTBUS (`sim://mc6000`, 9600 Bd): the
/// demo line's common base set plus each axis' own SADDR and KPSC1.
fn mc_axes_line(dir: &Path, n: u8) -> Manifest {
    let sets = workspace_root()
        .join("parameter-sets/demo-line/sets")
        .canonicalize()
        .unwrap();
    let mut m = String::from(
        "[line]\nname = \"axes\"\n\n[[bus]]\nname = \"axes\"\nport = \"sim://mc6000\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n",
    );
    for a in 1..=n {
        std::fs::write(
            dir.join(format!("axis-{a}.toml")),
            format!(
                "schema = \"{}/../../fixtures/fictional-mc6000-demo.toml\"\nextends = \"{}/mc6000-base.toml\"\n\n[values]\nSADDR = {a}\nKPSC1 = \"0.0{}25 Nm/(rad/s)\"\n",
                sets.display(),
                sets.display(),
                a % 9 + 1
            ),
        )
        .unwrap();
        m.push_str(&format!(
            "[[drive]]\nname = \"axis-{a}\"\nbus = \"axes\"\naddress = {a}\nset = \"axis-{a}.toml\"\n\n"
        ));
    }
    let path = dir.join("line.toml");
    std::fs::write(&path, m).unwrap();
    let mut reg = Registry::builtin().expect("builtin");
    let l = load_manifest(&path, &mut reg, &sim_openers()).expect("manifest reads");
    assert!(l.findings.is_empty(), "{:?}", l.findings);
    l.manifest.expect("manifest")
}

/// Simulated buses with a memory event log each; `drop_broadcast`: the
/// link loses the first telegram to address 31 (a noise burst), so no
/// drive takes it.
#[derive(Default)]
struct LoggedSims {
    sims: Mutex<BTreeMap<String, (SimLink, driveset_sim::log::EventLog)>>,
    drop_broadcast: bool,
}

impl LoggedSims {
    fn open(&self, bus: &driveset_engine::line::manifest::Bus) -> Result<Link, String> {
        let mut m = self.sims.lock().unwrap();
        if !m.contains_key(&bus.name) {
            let PortSpec::Sim(spec) = &bus.port else {
                return Err("not a sim port".into());
            };
            let spec = driveset_sim::port::SimSpec::from_opaque(spec).map_err(|e| e.to_string())?;
            let config =
                driveset_sim::open::SimConfig::from_spec(&spec).map_err(|e| e.to_string())?;
            let log = driveset_sim::log::EventLog::memory();
            let port = spec.to_string();
            let s = driveset_sim::open::open_sim_with(
                &config,
                &VirtualClock::new(),
                &port,
                log.clone(),
            )
            .map_err(|e| e.to_string())?;
            m.insert(bus.name.clone(), (s, log));
        }
        let link = m[&bus.name].0.link();
        Ok(match link {
            Link::Bytes(b) if self.drop_broadcast => Link::Bytes(Box::new(DropBroadcast {
                inner: b,
                dropped: false,
            })),
            l => l,
        })
    }

    fn sim(&self, bus: &str) -> SimLink {
        self.sims.lock().unwrap()[bus].0.clone()
    }

    /// Host telegrams, as bytes, in order; and whether a drive replied
    /// between each and the next.
    fn host_telegrams(&self, bus: &str) -> Vec<(Vec<u8>, bool)> {
        let events = self.sims.lock().unwrap()[bus].1.events();
        let mut out: Vec<(Vec<u8>, bool)> = Vec::new();
        for e in events {
            match e.dir {
                driveset_sim::log::Dir::Host => out.push((unhex(&e.hex), false)),
                driveset_sim::log::Dir::Drive => {
                    if let Some(last) = out.last_mut() {
                        last.1 = true;
                    }
                }
                driveset_sim::log::Dir::Event => {}
            }
        }
        out
    }
}

fn unhex(h: &str) -> Vec<u8> {
    let h: String = h.chars().filter(|c| c.is_ascii_hexdigit()).collect();
    (0..h.len() / 2)
        .map(|i| u8::from_str_radix(&h[2 * i..2 * i + 2], 16).unwrap())
        .collect()
}

/// A link that loses the first telegram to LUSTBUS address 31.
#[derive(Debug)]
struct DropBroadcast {
    inner: Box<dyn driveset_link::ByteLink>,
    dropped: bool,
}

impl driveset_link::ByteLink for DropBroadcast {
    fn port(&self) -> &str {
        self.inner.port()
    }
    fn bus_id(&self) -> String {
        self.inner.bus_id()
    }
    fn baud(&self) -> u32 {
        self.inner.baud()
    }
    fn clock(&self) -> &dyn driveset_link::Clock {
        self.inner.clock()
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), driveset_link::LinkError> {
        if !self.dropped && bytes.starts_with(&[0x04, b'_']) {
            self.dropped = true;
            return Ok(());
        }
        self.inner.send(bytes)
    }
    fn recv(
        &mut self,
        buf: &mut [u8],
        deadline: driveset_link::Instant,
    ) -> Result<usize, driveset_link::LinkError> {
        self.inner.recv(buf, deadline)
    }
    fn discard_input(&mut self) -> Result<(), driveset_link::LinkError> {
        self.inner.discard_input()
    }
    fn flush(&mut self) -> Result<(), driveset_link::LinkError> {
        self.inner.flush()
    }
}

/// Telegrams to address 31 (`EOT _ ...`).
fn broadcasts(t: &[(Vec<u8>, bool)]) -> Vec<&(Vec<u8>, bool)> {
    t.iter()
        .filter(|(b, _)| b.starts_with(&[0x04, b'_']))
        .collect()
}

fn journals_of(dir: &Path) -> Vec<serde_json::Value> {
    let mut out: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".journal.json"))
        .map(|e| serde_json::from_str(&std::fs::read_to_string(e.path()).unwrap()).unwrap())
        .collect();
    out.sort_by_key(|j: &serde_json::Value| j["target"]["address"].as_u64());
    out
}

#[test]
fn lustbus_broadcast_sends_common_values_once_to_address_31_inside_each_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let m = mc_axes_line(dir.path(), 3);
    let sims = LoggedSims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path().join("out"), disk_env());
    opts.broadcast_common = true;
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(
        r.verdict(),
        Verdict::Holds,
        "{:?} {:?}",
        r.report.drives,
        r.warnings
    );
    for d in &r.report.drives {
        assert_eq!(d.result, DriveResult::Verified, "{d:?}");
        assert_eq!(
            d.fingerprint_after.as_deref(),
            Some(d.set_fingerprint.as_str())
        );
    }
    let bus = &r.report.buses[0];
    let phases: Vec<&str> = bus
        .timeline
        .iter()
        .filter(|t| t.phase.as_str() == "broadcast")
        .map(|t| t.drive.as_str())
        .collect();
    assert_eq!(phases, vec!["address 31"]);

    // every drive's journal names the broadcast codes; they are the same list
    let journals = journals_of(&opts.journal_dir);
    assert_eq!(journals.len(), 3);
    let listed: Vec<String> = journals[0]["broadcast"]
        .as_array()
        .expect("broadcast list")
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    for j in &journals {
        assert_eq!(j["state"], "complete");
        assert_eq!(j["broadcast"], journals[0]["broadcast"]);
    }
    assert!(listed.contains(&"171".to_string()), "{listed:?}");
    assert_eq!(
        r.warnings,
        vec![format!(
            "bus `axes`: {} value(s) common to its 3 drives sent once to address 31 (broadcast, no receipt) inside each drive's dataset download; every value verified drive by drive",
            listed.len()
        )]
    );

    let telegrams = sims.host_telegrams("axes");
    let sent = broadcasts(&telegrams);
    assert_eq!(sent.len(), listed.len());
    // 171-ECLIN = 2048 (PT_USIGN16, hex without leading zeros), BCC 0x33
    assert!(
        sent.iter()
            .any(|(b, _)| b.as_slice() == b"\x04_\x0220171=800\x033"),
        "{:?}",
        sent.iter()
            .map(|(b, _)| String::from_utf8_lossy(b))
            .collect::<Vec<_>>()
    );
    for (b, replied) in &sent {
        // no receipt was given, none awaited: the next telegram follows
        assert!(!replied, "{}", String::from_utf8_lossy(b));
        // never a numerically compatible code (CODE 000xx: 81..85, 91)
        assert!(
            !b.starts_with(b"\x04_\x02000"),
            "{}",
            String::from_utf8_lossy(b)
        );
    }
    // the broadcast sits inside every drive's dataset: SLOAD = -1 to each
    // before the first one, SLOAD = -2 to each after the last
    let pos = |pred: &dyn Fn(&[u8]) -> bool| telegrams.iter().position(|(b, _)| pred(b));
    let first_bc = pos(&|b| b.starts_with(&[0x04, b'_'])).unwrap();
    let last_bc = telegrams
        .iter()
        .rposition(|(b, _)| b.starts_with(&[0x04, b'_']))
        .unwrap();
    for a in [b'A', b'B', b'C'] {
        let open =
            pos(&|b| b.starts_with(&[0x04, a, 0x02]) && b[3..].starts_with(b"20080=FFFF\x03"))
                .unwrap();
        let commit =
            pos(&|b| b.starts_with(&[0x04, a, 0x02]) && b[3..].starts_with(b"20080=FFFE\x03"))
                .unwrap();
        assert!(open < first_bc && commit > last_bc, "{a}: {open} {commit}");
        // every code read back one by one after the commit, broadcast ones too
        let read_eclin = telegrams[commit..]
            .iter()
            .any(|(b, _)| b.as_slice() == [0x04, a, b'2', b'0', b'1', b'7', b'1', 0x05]);
        assert!(read_eclin, "{a}");
    }
    // and each drive holds it
    for a in 1..=3 {
        assert_eq!(
            sims.sim("axes").state(a).unwrap().values[&CodeKey::new(171)],
            RawValue::Int(2048)
        );
    }
    // the drives wrote fewer values themselves than without the broadcast
    let dir2 = tempfile::tempdir().unwrap();
    let m2 = mc_axes_line(dir2.path(), 3);
    let sims2 = LoggedSims::default();
    let opener2 = |b: &driveset_engine::line::manifest::Bus| sims2.open(b);
    let plain = commission(
        &m2,
        &LineOptions::new(dir2.path().join("out"), disk_env()),
        &opener2,
    )
    .expect("runs");
    for (b, p) in r.report.drives.iter().zip(&plain.report.drives) {
        assert_eq!(
            b.codes_written as usize + listed.len(),
            p.codes_written as usize
        );
    }
    assert!(r.line_ms() < plain.line_ms());
}

#[test]
fn a_lost_lustbus_broadcast_value_is_written_on_its_own_and_verified() {
    let dir = tempfile::tempdir().unwrap();
    let m = mc_axes_line(dir.path(), 2);
    let sims = LoggedSims {
        drop_broadcast: true,
        ..LoggedSims::default()
    };
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path().join("out"), disk_env());
    opts.broadcast_common = true;
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(
        r.verdict(),
        Verdict::Holds,
        "{:?} {:?}",
        r.report.drives,
        r.warnings
    );
    let journals = journals_of(&opts.journal_dir);
    let first = journals[0]["broadcast"][0].as_str().unwrap().to_string();
    let telegrams = sims.host_telegrams("axes");
    // the lost one never reached the bus; the rest did
    let n = journals[0]["broadcast"].as_array().unwrap().len();
    assert_eq!(broadcasts(&telegrams).len(), n - 1);
    for d in &r.report.drives {
        assert_eq!(d.result, DriveResult::Verified, "{d:?}");
        assert_eq!(
            d.fingerprint_after.as_deref(),
            Some(d.set_fingerprint.as_str())
        );
        let w = r
            .warnings
            .iter()
            .find(|w| w.starts_with(&format!("{}: ", d.name)) && w.contains("did not land"))
            .unwrap_or_else(|| panic!("{:?}", r.warnings));
        assert!(
            w.contains(&format!("{first}-")) && w.ends_with("; written on its own and verified"),
            "{w}"
        );
    }
    // the own write went to each drive after its commit
    for a in [b'A', b'B'] {
        let commit = telegrams
            .iter()
            .position(|(b, _)| {
                b.starts_with(&[0x04, a, 0x02]) && b[3..].starts_with(b"20080=FFFE\x03")
            })
            .unwrap();
        let code = format!("20{first:0>3}=");
        assert!(
            telegrams[commit..].iter().any(
                |(b, _)| b.starts_with(&[0x04, a, 0x02]) && b[3..].starts_with(code.as_bytes())
            ),
            "{first}"
        );
    }
}

#[test]
fn lustbus_broadcast_refuses_a_bus_with_vf1000_drives() {
    let m = demo();
    let dir = tempfile::tempdir().unwrap();
    let sims = LoggedSims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path(), disk_env());
    opts.only = vec!["lustbus".into()];
    opts.broadcast_common = true;
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Holds, "{:?}", r.report.drives);
    assert_eq!(
        r.warnings,
        vec!["bus `lustbus`: no broadcast (address 31): refused: the bus also has VF1000 drives (conveyor-5, conveyor-6, conveyor-7), which would execute every SELECT to address 31 as a write of their own parameter of that number (LUSTBUS 4.2); values were written drive by drive".to_string()]
    );
    assert!(broadcasts(&sims.host_telegrams("lustbus")).is_empty());
    assert!(
        !r.report.buses[0]
            .timeline
            .iter()
            .any(|t| t.phase.as_str() == "broadcast")
    );
}

#[test]
fn lustbus_broadcast_never_while_a_drive_runs() {
    let dir = tempfile::tempdir().unwrap();
    let m = mc_axes_line(dir.path(), 3);
    let sims = LoggedSims::default();
    sims.open(&m.buses[0]).unwrap();
    // axis 2 runs (416-SCTL1 bit 0, "start")
    sims.sim("axes")
        .poke(2, CodeKey::new(416), RawValue::Int(1))
        .unwrap();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path().join("out"), disk_env());
    opts.broadcast_common = true;
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Differs);
    assert!(broadcasts(&sims.host_telegrams("axes")).is_empty());
    assert_eq!(
        r.warnings,
        vec!["bus `axes`: no broadcast (address 31): `axis-2` did not reach its dataset download; values were written drive by drive".to_string()]
    );
    let results: Vec<DriveResult> = r.report.drives.iter().map(|d| d.result).collect();
    assert_eq!(
        results,
        vec![
            DriveResult::Verified,
            DriveResult::Failed,
            DriveResult::Verified
        ]
    );
    assert!(
        r.report.drives[1]
            .error
            .as_deref()
            .unwrap()
            .contains("running"),
        "{:?}",
        r.report.drives[1].error
    );
}

#[test]
fn lustbus_broadcast_never_while_the_bus_has_an_unfinished_journal() {
    let dir = tempfile::tempdir().unwrap();
    let m = mc_axes_line(dir.path(), 2);
    let sims = LoggedSims::default();
    let opener = |b: &driveset_engine::line::manifest::Bus| sims.open(b);
    let mut opts = LineOptions::new(dir.path().join("out"), disk_env());
    opts.broadcast_common = true;
    std::fs::create_dir_all(&opts.journal_dir).unwrap();
    // an unfinished journal of address 9, a drive the line does not list
    let journal = opts.journal_dir.join("by-hand.journal.json");
    std::fs::write(
        &journal,
        r#"{"journal_version":2,"state":"writing",
            "target":{"port":"sim://mc6000","address":9,"bus":"sim:mc6000~PID"},
            "identity":{"protocol":"lustbus-mc","codes":[["91-TYPE","6000"]],"software":null},
            "schema":"fictional-mc6000-demo","set_fingerprint":"x","fingerprint_before":"y","dataset":true,
            "attempt":1,"backup":[],"plan":[],"written":[],"transitions":[],"failure":null}"#
            // the in-process bus's id names this process (sim:NAME~PID)
            .replace("PID", &std::process::id().to_string()),
    )
    .unwrap();
    let r = commission(&m, &opts, &opener).expect("runs");
    assert_eq!(r.verdict(), Verdict::Holds, "{:?}", r.report.drives);
    assert_eq!(
        r.warnings,
        vec![format!(
            "bus `axes`: no broadcast (address 31): the bus has unfinished journals ({}); they are recovered drive by drive first; values were written drive by drive",
            journal.display()
        )]
    );
    assert!(broadcasts(&sims.host_telegrams("axes")).is_empty());
}

#[test]
fn a_first_contact_s_service_port_goes_on_the_line_s_one_serial_bus_at_its_rate() {
    use driveset_engine::line::commission_assign::{ServicePortError, on_service_port};
    let dir = tempfile::tempdir().unwrap();
    let on = on_service_port(mc_axes_line(dir.path(), 2), "/dev/ttyUSB9", &sim_openers())
        .expect("a line with one LUSTBUS bus");
    assert_eq!(on.buses[0].port_name, "/dev/ttyUSB9");
    assert_eq!(
        on.buses[0].port,
        driveset_link::PortSpec::parse("/dev/ttyUSB9?baud=9600").unwrap()
    );
    // the demo line: a LUSTBUS and a LECOM bus (and a CAN bus, not counted)
    let e = on_service_port(demo(), "/dev/ttyUSB9", &sim_openers()).unwrap_err();
    assert!(
        matches!(e, ServicePortError::NotOneBus { buses: 2, .. }),
        "{e}"
    );
    assert!(e.to_string().starts_with(
        "--port /dev/ttyUSB9: the line has 2 LUSTBUS / LECOM buses; --port names the one port"
    ));
    let e = on_service_port(mc_axes_line(dir.path(), 1), "nope://x", &sim_openers()).unwrap_err();
    assert!(matches!(e, ServicePortError::BadPort { .. }), "{e}");
    assert!(e.to_string().starts_with("--port nope://x: "), "{e}");
}

/// The front end's ports as `replace` asks them before opening anything:
/// an opener's port names the bus its front end says (here `said:PORT`),
/// every other port as the link says; nothing is opened.
struct SaidPorts;

impl driveset_engine::session::Ports for SaidPorts {
    fn open(
        &self,
        port: &str,
        _spec: PortSpec,
        _address: Option<u8>,
    ) -> Result<driveset_engine::session::OpenedPort, driveset_engine::session::PortError> {
        panic!("{port} opened: replace asks the line's ports before opening them")
    }

    fn bus_before_open(&self, port: &str, spec: &PortSpec) -> Option<String> {
        driveset_link::bus_id::before_open(spec).or_else(|| Some(format!("said:{port}")))
    }

    fn lock(&self, _bus: &str) -> Result<(), driveset_link::LockError> {
        Ok(())
    }
}

#[test]
fn replace_knows_the_buses_the_line_s_ports_reach_before_opening_them() {
    use driveset_engine::line::replace::{LineBusId, ReplaceOptions, line_bus_ids};
    let dir = tempfile::tempdir().unwrap();
    let mut m = mc_axes_line(dir.path(), 1);
    let ids = line_bus_ids(&m, &SaidPorts);
    assert_eq!(
        ids,
        vec![LineBusId {
            bus: "axes".into(),
            port: m.buses[0].port_name.clone(),
            id: format!("said:{}", m.buses[0].port),
        }]
    );
    // a TCP device server: the front end's answer, then every address its
    // host resolves to
    m.buses[0].port = PortSpec::parse("tcp://127.0.0.1:4001").unwrap();
    let ids: Vec<String> = line_bus_ids(&m, &SaidPorts)
        .into_iter()
        .map(|b| b.id)
        .collect();
    assert_eq!(ids, ["said:tcp://127.0.0.1:4001", "tcp:127.0.0.1:4001"]);
    // a serial device: its canonical path, as the link names it
    m.buses[0].port = PortSpec::parse("/dev/ttyS0").unwrap();
    let opts = ReplaceOptions::for_line(&m, Default::default(), &SaidPorts);
    assert_eq!(
        opts.line_buses
            .iter()
            .map(|b| b.id.as_str())
            .collect::<Vec<_>>(),
        [driveset_link::bus_id::serial("/dev/ttyS0")]
    );
    assert_eq!(
        opts.journal_dir,
        Path::new(driveset_engine::journal::DEFAULT_JOURNAL_DIR)
    );
}
