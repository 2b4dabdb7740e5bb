//! Line commissioning speed in virtual time: 100 simulated drives on 4
//! buses (25 MC6000 on LUSTBUS 19200, 25 VF1000 on LUSTBUS 9600, 25 Tmd on
//! LECOM 9600, 25 ECS on CAN 500 kbit/s), sets = the demo line's bases plus
//! a per-drive overlay.
//!
//! Prints, each bus on its own virtual clock:
//! - every bus commissioned alone (fresh drives) and the slowest of them;
//! - the whole line (fresh drives, buses in parallel): its time is the
//!   slowest bus's; target <= 1.10 x the slowest bus alone;
//! - `status` of the commissioned line and a rerun of `commission` on the
//!   unchanged line (target rerun <= 1.02 x status: the same reads), and
//!   both against the read-only bound (below; never under it);
//! - 25 MC6000 axes on one LUSTBUS (19200 Bd) whose sets share 80 % of
//!   their values (the demo base set, 46 values, 9 of them each axis'
//!   own), commissioned fresh drive by drive and with `--broadcast-common`
//!   (the shared CardWriteable values once to address 31 inside every
//!   drive's dataset download); target with <= 0.70 x without (goal
//!   0.60; issue 33); each against its bound;
//! - real wall time of each run.
//!
//! Each MC6000 set gives 81-SBAUD = the bus's 19200 (the demo base set
//! gives the demo line's 9600), or the manifest check refuses it. The
//! 100-drive rehearsal from twins is `crates/driveset-cli/benches/rehearse.rs`
//! (it runs the built binary). The history store (the history issue) does
//! not exist yet: no figure of its overhead here.
//!
//! Exit code 1 when a target is missed or a run goes under its bound.
//!
//! # Bounds
//!
//! A bound here is a time no correct run can go under
//! (`support/line_bound.rs`): every exchange the run cannot do without,
//! priced at its least wire time (the exact telegram lengths, 10 bits a
//! character at the bus rate, CAN 111 bits an 8-byte frame), plus the
//! family's minimum reaction time (LUSTBUS section 10: 1 ms), plus, per MC
//! dataset, the check and store time after SLOAD = -2 that the drive's own
//! poll and verification must wait for. A bus is serial: its bound is the
//! larger of the sum of its exchanges and the longest single drive's chain
//! (exchanges before SLOAD = -2, check and store, poll, exchanges after);
//! buses run in parallel, so the line's bound is the largest bus bound.
//! - Read-only bound (rerun, `status`): per drive the identify reads and
//!   one read per code of its set; the exchange lengths are the cheapest
//!   that many the run's event log shows (a value's reply length is fixed
//!   by the value), each at the minimum reaction.
//! - Commission bound of the axes (computed from each drive's live plan on
//!   an identical fresh bus, `prepare`): identify, read-back, the running
//!   check, SERR before the first SELECT, SLOAD = -1, one SELECT per
//!   planned write, SLOAD = -2, the check and store
//!   (`driveset_sim::mc6000::dataset_busy_time`: the spec's 15 ms a byte
//!   plus the simulator's FICTIONAL check time), one poll, one
//!   verification read per written code. With broadcast the shared values
//!   cost one SELECT each on the bus (wire time only: no reply) instead of
//!   one per drive.
//!
//! The simulated drives draw their reaction between the spec's minimum and
//! maximum (1..30 ms for the MC with KEYPAD), so a run sits well above its
//! bound; the figure that says how close a method comes is the ratio to
//! the bound, and a run under its bound would fail the benchmark.
//!
//! `cargo bench -p driveset-engine --bench line`

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use driveset_engine::env::Memory;
use driveset_engine::line::commission::{
    LineError, LineOptions, LineOutcome, Opener, Verdict, commission, lustbus_common_values,
};
use driveset_engine::line::manifest::{Bus, Drive, Manifest, load_manifest};
use driveset_engine::line::report::DriveResult;
use driveset_engine::line::status::status;
use driveset_engine::overrides::Overrides;
use driveset_engine::plan::Phase;
use driveset_engine::upload::prepare;
use driveset_link::{Link, PortSpec, VirtualClock};
use driveset_schema::{CodeKey, Registry};
use driveset_sim::log::{Event, EventLog};
use driveset_sim::open::{SimConfig, SimLink, open_sim_with};
use driveset_test_support::sim_openers;

#[path = "support/line_bound.rs"]
mod line_bound;

#[path = "support/line_sets.rs"]
mod line_sets;

use line_sets::{BUSES, write_line};

/// Simulated buses that live across runs, each with a memory event log,
/// and the one environment (state file, clock of the report) the runs on
/// them share, so a rerun sees the first run's resume state.
struct Sims(
    Mutex<BTreeMap<String, (SimLink, EventLog)>>,
    std::sync::Arc<dyn driveset_engine::env::Environment>,
);

impl Default for Sims {
    fn default() -> Self {
        Sims(
            Mutex::default(),
            std::sync::Arc::new(Memory::at(jiff::Timestamp::UNIX_EPOCH)),
        )
    }
}

impl Sims {
    fn open(&self, bus: &Bus) -> Result<Link, String> {
        let mut m = self.0.lock().unwrap();
        if let Some((s, _)) = m.get(&bus.name) {
            return Ok(s.link());
        }
        let PortSpec::Sim(spec) = &bus.port else {
            return Err("not a sim port".into());
        };
        let spec = driveset_sim::port::SimSpec::from_opaque(spec).map_err(|e| e.to_string())?;
        let config = SimConfig::from_spec(&spec).map_err(|e| e.to_string())?;
        let log = EventLog::memory();
        let port = spec.to_string();
        let s = open_sim_with(&config, &VirtualClock::new(), &port, log.clone())
            .map_err(|e| e.to_string())?;
        let l = s.link();
        m.insert(bus.name.clone(), (s, log));
        Ok(l)
    }

    /// The events of bus `name` so far.
    fn events(&self, name: &str) -> Vec<Event> {
        self.0
            .lock()
            .unwrap()
            .get(name)
            .map(|(_, l)| l.events())
            .unwrap_or_default()
    }
}

/// The read-only bound of `m` (module docs) from the events each bus
/// logged after `from` (events per bus before the run).
fn read_only_bound(m: &Manifest, sims: &Sims, from: &BTreeMap<String, usize>) -> f64 {
    let mut worst = 0.0f64;
    for (bi, bus) in m.buses.iter().enumerate() {
        let drives: Vec<&Drive> = m.drives.iter().filter(|d| d.bus_index == bi).collect();
        let Some(first) = drives.first() else {
            continue;
        };
        let family = first.schema.family;
        let lustbus = family.bus() == driveset_schema::BusProtocol::Lustbus;
        let required: usize = drives
            .iter()
            .map(|d| {
                let id = d.schema.identify.as_ref().map_or(0, |i| i.codes.len());
                (if lustbus { id.max(1) } else { id }) + d.set.values.len()
            })
            .sum();
        let events = sims.events(&bus.name);
        let events = &events[from.get(&bus.name).copied().unwrap_or(0)..];
        let b = line_bound::read_only_from_log(
            events,
            required,
            bus.rate,
            family.bus() == driveset_schema::BusProtocol::CanSdo,
            family.descriptor().reaction.min,
        );
        worst = worst.max(b.as_secs_f64() * 1000.0);
    }
    worst
}

fn event_counts(m: &Manifest, sims: &Sims) -> BTreeMap<String, usize> {
    m.buses
        .iter()
        .map(|b| (b.name.clone(), sims.events(&b.name).len()))
        .collect()
}

/// A line command: `commission` or `status`.
type Walk = fn(&Manifest, &LineOptions, &Opener<'_>) -> Result<LineOutcome, LineError>;

fn run(m: &Manifest, sims: &Sims, dir: &Path, walk: Walk, only: &[&str]) -> (LineOutcome, f64) {
    let mut opts = LineOptions::new(dir, sims.1.clone());
    opts.only = only.iter().map(|s| s.to_string()).collect();
    let opener = |b: &Bus| sims.open(b);
    let t = Instant::now();
    let o = walk(m, &opts, &opener).expect("line runs");
    let wall = t.elapsed().as_secs_f64();
    assert_eq!(
        o.verdict(),
        Verdict::Holds,
        "{:?}",
        o.report.drives.iter().find(|d| d.error.is_some())
    );
    (o, wall)
}

fn main() {
    let tmp = tempfile::tempdir().unwrap();
    let path = write_line(tmp.path(), 25);
    let mut reg = Registry::builtin().unwrap();
    let l = load_manifest(&path, &mut reg, &sim_openers()).expect("manifest reads");
    assert!(l.findings.is_empty(), "{:?}", l.findings);
    let m = l.manifest.unwrap();
    println!("line: {} drives on {} buses", m.drives.len(), m.buses.len());
    let mut rows: Vec<String> = Vec::new();
    let mut walls: Vec<(String, f64)> = Vec::new();

    let mut alone = Vec::new();
    for ((bus, ..), what) in BUSES.into_iter().zip([
        "25 MC6000, LUSTBUS 19200",
        "25 VF1000, LUSTBUS 9600",
        "25 Tmd, LECOM 9600",
        "25 ECS, CAN 500 kbit/s",
    ]) {
        let sims = Sims::default();
        let d = tempfile::tempdir().unwrap();
        let (o, wall) = run(&m, &sims, d.path(), commission, &[bus]);
        let ms = o.line_ms();
        rows.push(format!(
            "| commission, bus {bus} alone ({what}) | {ms:.1} | - | - | - |"
        ));
        walls.push((format!("bus {bus} alone"), wall));
        alone.push(ms);
    }
    let slowest = alone.iter().copied().fold(0.0, f64::max);
    let sum: f64 = alone.iter().sum();

    let sims = Sims::default();
    let d = tempfile::tempdir().unwrap();
    let (full, wall_full) = run(&m, &sims, d.path(), commission, &[]);
    assert!(
        full.report
            .drives
            .iter()
            .all(|d| d.result == DriveResult::Verified)
    );
    let line = full.line_ms();
    rows.push(format!(
        "| commission, whole line, buses in parallel (one after another: {sum:.1} ms) | {line:.1} | the slowest bus alone, {slowest:.1} ms | {:.4} | <= {LINE_TARGET} |",
        line / slowest
    ));
    walls.push(("whole line".into(), wall_full));
    let before = event_counts(&m, &sims);
    let (st, wall_st) = run(&m, &sims, d.path(), status, &[]);
    let status_ms = st.line_ms();
    let st_bound = read_only_bound(&m, &sims, &before);
    rows.push(format!(
        "| status (read-only) | {status_ms:.1} | read-only bound, {st_bound:.1} ms | {:.4} | >= 1 |",
        status_ms / st_bound
    ));
    walls.push(("status".into(), wall_st));
    let before = event_counts(&m, &sims);
    let (re, wall_re) = run(&m, &sims, d.path(), commission, &[]);
    assert!(
        re.report
            .drives
            .iter()
            .all(|d| d.result == DriveResult::AlreadyVerified)
    );
    let rerun = re.line_ms();
    let bound = read_only_bound(&m, &sims, &before);
    rows.push(format!(
        "| commission again, unchanged line ({:.1} % of the first run; {:.4} x its read-only bound {bound:.1} ms, >= 1) | {rerun:.1} | status | {:.4} | <= {RERUN_TARGET} |",
        100.0 * rerun / line,
        rerun / bound,
        rerun / status_ms
    ));
    walls.push(("rerun".into(), wall_re));
    let mut misses = Vec::new();
    if line > LINE_TARGET * slowest {
        misses.push(format!(
            "whole line {:.4} x the slowest bus > {LINE_TARGET}",
            line / slowest
        ));
    }
    if rerun > RERUN_TARGET * status_ms {
        misses.push(format!(
            "rerun {:.4} x status > {RERUN_TARGET}",
            rerun / status_ms
        ));
    }
    if rerun < bound || status_ms < st_bound {
        misses.push("a read-only run went under its bound: the bound is wrong".into());
    }
    println!("\n| run | virtual ms | against | ratio | target |");
    println!("| --- | ---: | --- | ---: | --- |");
    for r in rows {
        println!("{r}");
    }
    broadcast_line(&mut misses, &mut walls);
    let build = if cfg!(debug_assertions) {
        "debug"
    } else {
        "release"
    };
    println!("\n| run ({build} build) | wall s |");
    println!("| --- | ---: |");
    for (what, w) in walls {
        println!("| {what} | {w:.3} |");
    }
    println!(
        "\nthe history store (the history issue) does not exist yet: no overhead figure for it"
    );
    if misses.is_empty() {
        println!("line: all targets met");
    } else {
        println!("line: TARGETS MISSED:\n{}", misses.join("\n"));
        std::process::exit(1);
    }
}

/// The whole line against the slowest bus alone (buses run in parallel).
const LINE_TARGET: f64 = 1.10;
/// A rerun of the unchanged line against `status` (the same reads).
const RERUN_TARGET: f64 = 1.02;

/// The 25 MC6000 axes on one LUSTBUS (19200 Bd) sharing 80 % of their
/// values: the demo base set (46 values) with 9 of them each axis' own.
fn write_axes(dir: &Path, n: u8) -> std::path::PathBuf {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../parameter-sets/demo-line/sets");
    let base = base.canonicalize().expect("demo-line sets");
    let mut m = format!(
        "[line]\nname = \"axes\"\n\n[[bus]]\nname = \"{AXES}\"\nport = \"sim://mc6000\"\nprotocol = \"lustbus\"\nbaud = {AXES_BAUD}\n\n"
    );
    for a in 1..=n {
        let own = format!(
            "SADDR = {a}\nSBAUD = \"{AXES_BAUD} Baud\"\nKPSC1 = \"0.0{}25 Nm/(rad/s)\"\nTNSC1 = \"{} ms\"\nSCFLT = \"{}.5 ms\"\nBRKT1 = \"{} ms\"\nBRKT2 = \"{} ms\"\nRACC0 = \"{} 1/min/s\"\nRDEC0 = \"{} 1/min/s\"\nTLIMP = {}\n",
            a % 9 + 1,
            20 + u32::from(a),
            1 + a % 9,
            200 + u32::from(a),
            130 + u32::from(a),
            2000 + 10 * u32::from(a),
            2000 + 20 * u32::from(a),
            200 + u32::from(a),
        );
        let file = format!("axis-{a}.toml");
        std::fs::write(
            dir.join(&file),
            format!(
                "schema = \"{b}/../../fixtures/fictional-mc6000-demo.toml\"\nextends = \"{b}/mc6000-base.toml\"\n\n[values]\n{own}",
                b = base.display()
            ),
        )
        .unwrap();
        m.push_str(&format!(
            "[[drive]]\nname = \"axis-{a}\"\nbus = \"{AXES}\"\naddress = {a}\nset = \"{file}\"\n\n"
        ));
    }
    let path = dir.join("line.toml");
    std::fs::write(&path, m).unwrap();
    path
}

const AXES: &str = "axes";
/// The broadcast run against the drive-by-drive run: issue 33 tightened
/// the target from 0.80 to 0.70 (0.659x was measured before the bench
/// stopped running; a regression past 0.70 would go unseen under 0.80),
/// goal 0.60.
const BROADCAST_TARGET: f64 = 0.70;
/// See [`BROADCAST_TARGET`].
const BROADCAST_GOAL: f64 = 0.60;
const AXES_BAUD: u32 = 19200;

fn run_axes(m: &Manifest, broadcast: bool) -> (LineOutcome, f64) {
    let sims = Sims::default();
    let d = tempfile::tempdir().unwrap();
    let mut opts = LineOptions::new(d.path(), sims.1.clone());
    opts.broadcast_common = broadcast;
    let opener = |b: &Bus| sims.open(b);
    let t = Instant::now();
    let o = commission(m, &opts, &opener).expect("line runs");
    let wall = t.elapsed().as_secs_f64();
    assert_eq!(o.verdict(), Verdict::Holds, "{:?}", o.warnings);
    for d in &o.report.drives {
        assert_eq!(d.result, DriveResult::Verified, "{d:?}");
        assert_eq!(
            d.fingerprint_after.as_deref(),
            Some(d.set_fingerprint.as_str())
        );
    }
    if broadcast {
        assert!(
            o.report.buses[0]
                .timeline
                .iter()
                .any(|t| t.phase.as_str() == "broadcast"),
            "{:?}",
            o.warnings
        );
    }
    (o, wall)
}

/// The axes' commission bounds without and with broadcast (module docs),
/// in ms, and how many values the broadcast carries: each drive's plan
/// from `prepare` on an identical fresh bus.
fn axes_bounds(m: &Manifest) -> (f64, f64, usize) {
    let sims = Sims::default();
    let mut link = sims.open(&m.buses[0]).expect("bus opens");
    let drives: Vec<&Drive> = m.drives.iter().collect();
    let preps: Vec<_> = drives
        .iter()
        .map(|d| {
            let mut c = driveset_engine::connect::connect_on(
                &mut link,
                d.schema.clone(),
                d.address,
                &Default::default(),
            )
            .expect("client");
            let p = prepare(&mut *c, &d.set, Overrides::none()).expect("plan");
            c.finish().expect("finish");
            p
        })
        .collect();
    let shared: Vec<_> = lustbus_common_values(&drives)
        .into_iter()
        .filter(|(k, _)| {
            preps.iter().all(|p| {
                p.plan
                    .writes
                    .iter()
                    .any(|w| w.key == *k && w.phase == Phase::Dataset)
            })
        })
        .collect();
    let keys: BTreeSet<CodeKey> = shared.iter().map(|(k, _)| *k).collect();
    let per = |keys: &BTreeSet<CodeKey>| -> Vec<line_bound::DriveBound> {
        drives
            .iter()
            .zip(&preps)
            .map(|(d, p)| line_bound::mc_drive(&d.schema, p, AXES_BAUD, keys))
            .collect()
    };
    let plain = line_bound::bus(&per(&BTreeSet::new()), Duration::ZERO);
    let bc = line_bound::bus(
        &per(&keys),
        line_bound::mc_broadcast(&drives[0].schema, &shared, AXES_BAUD),
    );
    (
        plain.as_secs_f64() * 1000.0,
        bc.as_secs_f64() * 1000.0,
        shared.len(),
    )
}

/// The broadcast comparison (module docs): its table; a missed target
/// goes to `misses`, the runs' wall times to `walls`.
fn broadcast_line(misses: &mut Vec<String>, walls: &mut Vec<(String, f64)>) {
    let tmp = tempfile::tempdir().unwrap();
    let path = write_axes(tmp.path(), 25);
    let mut reg = Registry::builtin().unwrap();
    let l = load_manifest(&path, &mut reg, &sim_openers()).expect("manifest reads");
    assert!(l.findings.is_empty(), "{:?}", l.findings);
    let m = l.manifest.unwrap();
    let sets: Vec<_> = m.drives.iter().map(|d| &d.set).collect();
    let shared = sets[0]
        .values
        .iter()
        .filter(|(k, v)| sets[1..].iter().all(|s| s.values.get(k) == Some(*v)))
        .count();
    println!(
        "\n25 MC6000 axes on one LUSTBUS at {AXES_BAUD} Bd: {} values each, {shared} shared by all ({:.1} %)",
        sets[0].values.len(),
        100.0 * shared as f64 / sets[0].values.len() as f64
    );
    let (bound_plain, bound_bc, n_bc) = axes_bounds(&m);
    let (plain, wall_plain) = run_axes(&m, false);
    let (bc, wall_bc) = run_axes(&m, true);
    let (tp, tb) = (plain.line_ms(), bc.line_ms());
    let ratio = tb / tp;
    let telegrams = |o: &LineOutcome| o.report.drives.iter().map(|d| d.telegrams).sum::<u64>();
    println!(
        "\n| run (25 MC6000 axes, LUSTBUS {AXES_BAUD}) | virtual ms | x drive by drive | bound ms | x bound | telegrams | target |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | ---: | --- |");
    println!(
        "| commission, drive by drive | {tp:.1} | 1.0000 | {bound_plain:.1} | {:.4} | {} | - |",
        tp / bound_plain,
        telegrams(&plain)
    );
    println!(
        "| commission --broadcast-common ({n_bc} values to address 31) | {tb:.1} | {ratio:.4} | {bound_bc:.1} | {:.4} | {} + {n_bc} | <= {BROADCAST_TARGET} (goal {BROADCAST_GOAL}) |",
        tb / bound_bc,
        telegrams(&bc)
    );
    // one line per kind of note (the 25 axes give the same one each)
    let mut kinds: Vec<(String, usize)> = Vec::new();
    for w in &bc.warnings {
        let kind = w
            .split_once(": ")
            .map_or(w.as_str(), |(_, k)| k)
            .to_string();
        match kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => *n += 1,
            None => kinds.push((kind, 1)),
        }
    }
    for (k, n) in kinds {
        println!("note ({n} x): {k}");
    }
    walls.push(("axes drive by drive".into(), wall_plain));
    walls.push(("axes --broadcast-common".into(), wall_bc));
    if ratio > BROADCAST_TARGET {
        misses.push(format!(
            "broadcast {ratio:.4} x drive by drive > {BROADCAST_TARGET}"
        ));
    }
    if tp < bound_plain || tb < bound_bc {
        misses.push("an axes run went under its bound: the bound is wrong".into());
    }
}
