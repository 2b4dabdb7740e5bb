//! Line commissioning speed in virtual time: 100 simulated drives on 4
//! buses (25 MC6000 on LUSTBUS 19200, 25 VF1000 on LUSTBUS 9600, 25 Tmd on
//! LECOM 9600, 25 ECS on CAN 500 kbit/s), sets = the demo line's bases plus
//! a per-drive overlay.
//!
//! Prints, each bus on its own virtual clock:
//! - every bus commissioned alone (fresh drives) and the slowest of them;
//! - the whole line (fresh drives, buses in parallel): its time is the
//!   slowest bus's; target <= 1.10 x the slowest bus alone;
//! - the read-only bound (`status` of the commissioned line) and a rerun of
//!   `commission` on the unchanged line; target rerun <= 1.02 x the bound;
//! - real wall time of each run.
//!
//! `cargo bench -p driveset-engine --bench line`

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

use driveset_engine::env::Memory;
use driveset_engine::line::commission::{LineOptions, LineOutcome, Mode, Verdict, run_line};
use driveset_engine::line::manifest::{Bus, Manifest, load_manifest};
use driveset_engine::line::report::DriveResult;
use driveset_link::{Link, PortSpec, VirtualClock};
use driveset_schema::Registry;
use driveset_sim::open::{SimLink, open_sim};

#[derive(Default)]
struct Sims(Mutex<BTreeMap<String, SimLink>>);

impl Sims {
    fn open(&self, bus: &Bus) -> Result<Link, String> {
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
}

const BUSES: [(&str, &str, &str, &str, &str); 4] = [
    // name, port, protocol, rate line, base set
    (
        "mc",
        "sim://mc6000",
        "lustbus",
        "baud = 19200",
        "mc6000-base.toml",
    ),
    (
        "vf",
        "sim://vf1000",
        "lustbus",
        "baud = 9600",
        "vf1000-base.toml",
    ),
    (
        "tmd",
        "sim://tmd?c0001=3",
        "lecom",
        "baud = 9600",
        "tmd-base.toml",
    ),
    (
        "ecs",
        "sim://ecs",
        "can",
        "bitrate = 500000",
        "ecs-base.toml",
    ),
];

fn write_line(dir: &Path, per_bus: usize) -> std::path::PathBuf {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../parameter-sets/demo-line/sets");
    let base = base.canonicalize().expect("demo-line sets");
    let mut m = String::from("[line]\nname = \"bench-line\"\n\n");
    for (name, port, proto, rate, _) in BUSES {
        m.push_str(&format!(
            "[[bus]]\nname = \"{name}\"\nport = \"{port}\"\nprotocol = \"{proto}\"\n{rate}\n\n"
        ));
    }
    for (bus, _, _, _, base_set) in BUSES {
        let schema = std::fs::read_to_string(base.join(base_set))
            .unwrap()
            .lines()
            .find(|l| l.starts_with("schema = "))
            .unwrap()
            .replace("../../", &format!("{}/../../", base.display()));
        let addrs: Vec<u8> = match bus {
            "tmd" => (1..=99).filter(|a| a % 10 != 0).take(per_bus).collect(),
            _ => (1..=per_bus as u8).collect(),
        };
        for a in addrs {
            let own = match bus {
                "mc" => format!("SADDR = {a}\nKPSC1 = \"0.0{}25 Nm/(rad/s)\"\n", a % 9 + 1),
                "vf" => format!("SIOA = {a}\n5 = \"{}.5 Hz\"\n", 10 + a),
                "tmd" => format!("C0012 = \"{}.0 s\"\n", 2 + a % 7),
                _ => format!("C5001 = \"{} rpm\"\n", 3000 + 10 * u32::from(a)),
            };
            let file = format!("{bus}-{a}.toml");
            std::fs::write(
                dir.join(&file),
                format!(
                    "{schema}\nextends = \"{}\"\n\n[values]\n{own}",
                    base.join(base_set).display()
                ),
            )
            .unwrap();
            m.push_str(&format!(
                "[[drive]]\nname = \"{bus}-{a}\"\nbus = \"{bus}\"\naddress = {a}\nset = \"{file}\"\n\n"
            ));
        }
    }
    let path = dir.join("line.toml");
    std::fs::write(&path, m).unwrap();
    path
}

fn run(m: &Manifest, sims: &Sims, dir: &Path, mode: Mode, only: &[&str]) -> (LineOutcome, f64) {
    let mut opts = LineOptions::new(
        dir,
        std::sync::Arc::new(Memory::at(jiff::Timestamp::UNIX_EPOCH)),
    );
    opts.only = only.iter().map(|s| s.to_string()).collect();
    let opener = |b: &Bus| sims.open(b);
    let t = Instant::now();
    let o = run_line(m, &opts, &opener, mode).expect("line runs");
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

    let mut alone = Vec::new();
    for (bus, ..) in BUSES {
        let sims = Sims::default();
        let d = tempfile::tempdir().unwrap();
        let (o, wall) = run(&m, &sims, d.path(), Mode::Commission, &[bus]);
        let ms = o.line_ms();
        println!(
            "  bus {bus:<4} alone: {:>9.1} ms virtual, {:>6.3} s wall",
            ms, wall
        );
        alone.push(ms);
    }
    let slowest = alone.iter().copied().fold(0.0, f64::max);
    let sum: f64 = alone.iter().sum();

    let sims = Sims::default();
    let d = tempfile::tempdir().unwrap();
    let (full, wall_full) = run(&m, &sims, d.path(), Mode::Commission, &[]);
    assert!(
        full.report
            .drives
            .iter()
            .all(|d| d.result == DriveResult::Verified)
    );
    let line = full.line_ms();
    println!(
        "whole line, parallel: {:>9.1} ms virtual ({:.4} x slowest bus alone {:.1} ms; target <= 1.10; buses one after another would take {:.1} ms), {:.3} s wall",
        line,
        line / slowest,
        slowest,
        sum,
        wall_full
    );
    let (st, wall_st) = run(&m, &sims, d.path(), Mode::Status, &[]);
    let bound = st.line_ms();
    println!("read-only bound (status): {bound:>9.1} ms virtual, {wall_st:.3} s wall");
    let (re, wall_re) = run(&m, &sims, d.path(), Mode::Commission, &[]);
    assert!(
        re.report
            .drives
            .iter()
            .all(|d| d.result == DriveResult::AlreadyVerified)
    );
    let rerun = re.line_ms();
    println!(
        "rerun, unchanged line: {:>9.1} ms virtual ({:.4} x read-only bound; target <= 1.02; {:.1} % of the first run), {:.3} s wall",
        rerun,
        rerun / bound,
        100.0 * rerun / line,
        wall_re
    );
    let ok = line <= 1.10 * slowest && rerun <= 1.02 * bound;
    println!("targets: {}", if ok { "met" } else { "MISSED" });
    if !ok {
        std::process::exit(1);
    }
}

/// The simulator's port opener, as the CLI registers it.
fn sim_openers() -> driveset_link::Openers {
    driveset_link::Openers::none()
        .with(std::sync::Arc::new(driveset_sim::port::SimOpener::default()))
}
