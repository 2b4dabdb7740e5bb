//! Benchmark: parse + validate + fingerprint 10,000 sets of 300 codes each
//! against a synthetic 300-code schema of mixed types; prints wall time and
//! max RSS (VmHWM). Run: `cargo bench -p driveset-schema --bench validate_many`.
//!
//! The set texts stand for the files a CI job reads: they are generated in
//! batches of 1,000 outside the clock, and the time reported is the sum of
//! the timed batches (what `driveset validate` + `fingerprint` do with
//! them, on both cores). The reported RSS includes one batch of texts.

// The same allocator as the `driveset` binary (crates/driveset-cli/src/main.rs).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

use driveset_schema::error::SourceFile;
use driveset_schema::{Registry, load_set_str};

const CODES: u32 = 300;
const SETS: usize = 10_000;

fn schema_text() -> String {
    let mut s = String::from(
        "[schema]\nid = \"fictional-bench\"\ntitle = \"FICTIONAL: bench\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\nfictional = true\n",
    );
    for n in 1..=CODES {
        let ty = [
            "VD",
            "VH",
            "PT_INT32Q16",
            "PT_FIXPOINT16",
            "PT_USIGN16",
            "PT_FLOAT_IEEE",
        ][(n % 6) as usize];
        let _ = write!(
            s,
            "[[code]]\nnumber = {n}\nname = \"code_{n}\"\ntitle = \"Code {n}\"\nspec = \"bench\"\ntype = \"{ty}\"\n"
        );
        if ty == "VD" {
            s.push_str("unit = \"Hz\"\nmin = \"0\"\nmax = \"1000\"\n");
        }
    }
    s
}

fn set_text(i: usize) -> String {
    let mut s = String::from("schema = \"fictional-bench\"\n[values]\n");
    for n in 1..=CODES {
        let v = (i as u32).wrapping_mul(31).wrapping_add(n) % 1000;
        let _ = match n % 6 {
            0 => writeln!(s, "C{n:04} = \"{v}.25 Hz\""),
            1 => writeln!(s, "C{n:04} = 0x{v:04x}"),
            2 => writeln!(s, "C{n:04} = {v}.5"),
            3 => writeln!(s, "C{n:04} = {v}.05"),
            4 => writeln!(s, "code_{n} = {v}"),
            _ => writeln!(s, "C{n:04} = {v}.1"),
        };
    }
    s
}

fn vm_hwm() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM"))
                .map(|l| l.split_whitespace().skip(1).collect::<Vec<_>>().join(" "))
        })
        .unwrap_or_else(|| "unknown".into())
}

/// User + system CPU seconds of this process (/proc/self/stat, 100 ticks/s).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // fields after the command name (which is in parentheses)
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn main() {
    let mut registry = Registry::new();
    registry
        .add_source(SourceFile::new("bench-schema.toml", schema_text()))
        .expect("bench schema");
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(2);
    const BATCH: usize = 1_000;
    let mut wall = std::time::Duration::ZERO;
    let mut results: Vec<(usize, usize, String)> = Vec::new();
    for batch in (0..SETS).step_by(BATCH) {
        let texts: Vec<String> = (batch..(batch + BATCH).min(SETS)).map(set_text).collect();
        let texts = &texts;
        let start = Instant::now();
        let batch_results: Vec<(usize, usize, String)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads)
                .map(|t| {
                    let mut reg = registry.clone();
                    scope.spawn(move || {
                        let (mut values, mut findings, mut last) = (0usize, 0usize, String::new());
                        for text in texts.iter().skip(t).step_by(threads) {
                            let l = load_set_str(Path::new("bench.toml"), text, &mut reg)
                                .expect("bench set parses");
                            findings += l.findings.len();
                            if let Some(r) = l.resolved {
                                values += r.values.len();
                                last = r.fingerprint();
                            }
                        }
                        (values, findings, last)
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("bench thread"))
                .collect()
        });
        wall += start.elapsed();
        results.extend(batch_results);
    }
    let values: usize = results.iter().map(|r| r.0).sum();
    let findings: usize = results.iter().map(|r| r.1).sum();
    println!(
        "validate_many: {SETS} sets x {CODES} codes ({values} values, {findings} findings) on {threads} thread(s): {:.3} s wall, {:.2} s CPU, max RSS {}",
        wall.as_secs_f64(),
        cpu_seconds(),
        vm_hwm()
    );
    println!(
        "last fingerprint: {}",
        results.last().map(|r| r.2.as_str()).unwrap_or("")
    );
}
