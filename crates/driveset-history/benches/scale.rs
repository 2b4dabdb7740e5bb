//! The plant history at scale (docs/history.md): a generated history of a
//! 200-drive line (`driveset_history::generate`), then the queries a plant
//! asks, timed: `blame` of one code, one drive's `log`, the `as-built` of
//! the 200 drives (latest and at a label). SQLite always; PostgreSQL when
//! `DRIVESET_HISTORY_BENCH_PG` names a server (a URL; its database is
//! used as it is: give an empty one).
//!
//! `DRIVESET_HISTORY_BENCH_SQLITE=0` leaves SQLite out (a PostgreSQL run
//! alone).
//!
//! Size: `DRIVESET_HISTORY_BENCH_SESSIONS` sessions (default 20000), 200
//! drives, `DRIVESET_HISTORY_BENCH_CODES` codes each (default 50): the
//! issue's ten years are 1000000 sessions and 50 codes (50M code records).
//! Targets: blame and one drive's log < 50 ms, as-built < 500 ms. This is
//! a measurement, not a test: its CI variant is the generator's unit test,
//! which checks the answers on a small plant without timing anything.
//!
//! `cargo bench -p driveset-history --bench scale`

use std::time::Instant;

use driveset_history::generate::{Plant, code_name, drive_name, generate};
use driveset_history::query::{At, LogFilter};
use driveset_history::{Store, Target};

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn time<T>(what: &str, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let r = f();
    println!("  {what}: {:.1} ms", t.elapsed().as_secs_f64() * 1000.0);
    r
}

fn run(name: &str, mut store: Store, p: &Plant) {
    println!(
        "{name}: {} sessions, {} drives x {} codes ({} code records)",
        p.sessions,
        p.drives,
        p.codes,
        p.sessions * p.codes
    );
    let t = Instant::now();
    generate(&mut store, p, 2000, |n| {
        if n % 100_000 == 0 {
            eprintln!("  {n} sessions ({:.0} s)", t.elapsed().as_secs_f64());
        }
    })
    .expect("generate");
    println!("  generated in {:.1} s", t.elapsed().as_secs_f64());
    let names: Vec<String> = (0..p.drives).map(drive_name).collect();
    for round in 0..2 {
        println!(" round {round}");
        let b = time("blame d100 C0007", || {
            store.blame(None, "d100", &code_name(7)).expect("blame")
        });
        assert!(b.is_some());
        let l = time("log --drive d100 (newest 1000)", || {
            store
                .log(&LogFilter {
                    drive: Some("d100".into()),
                    limit: 1000,
                    ..LogFilter::default()
                })
                .expect("log")
        });
        assert!(!l.is_empty());
        let a = time("as-built, 200 drives, latest", || {
            store
                .as_built("plant", &names, &At::Latest)
                .expect("as-built")
        });
        assert_eq!(a.drives.len(), p.drives);
        let sweep = p.sessions / p.drives / 2;
        let a = time("as-built, 200 drives, at a label", || {
            store
                .as_built("plant", &names, &At::Label(format!("sweep-{sweep}")))
                .expect("as-built")
        });
        assert_eq!(a.drives.len(), p.drives);
    }
}

fn main() {
    let p = Plant {
        drives: 200,
        codes: env("DRIVESET_HISTORY_BENCH_CODES", 50),
        sessions: env("DRIVESET_HISTORY_BENCH_SESSIONS", 20_000),
    };
    let dir = tempfile::tempdir().expect("temp dir");
    if std::env::var("DRIVESET_HISTORY_BENCH_SQLITE").as_deref() != Ok("0") {
        let store =
            driveset_history::open_sqlite(&dir.path().join("bench.sqlite")).expect("sqlite");
        run("sqlite", store, &p);
    }
    if let Ok(url) = std::env::var("DRIVESET_HISTORY_BENCH_PG") {
        let store = Target::parse(&url)
            .expect("url")
            .open()
            .expect("postgres")
            .expect("a store");
        run("postgresql", store, &p);
    }
}
