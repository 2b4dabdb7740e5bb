//! Upload benchmark, in virtual time (`cargo bench -p driveset-engine --bench upload`).
//!
//! For each simulated family (MC6000, VF1000 and Tmd at 9600 baud 7E1; ECS
//! on CAN at 500 kbit/s) a generated set that changes every writable
//! integer code of the family's schema the factory-fresh drive takes
//! (`tests/integration/support/campaign_rig.rs`, `full_set`; on the MC6000 also the
//! enumerated and bit-field codes: a full set of 200+ EEPROM codes of mixed
//! width; never address, baud, command or control codes) is uploaded with
//! verification ("full upload"), then uploaded again to the same drive
//! ("re-run": nothing differs). Each run is timed on the bus's virtual clock
//! (the report's `elapsed`) and compared with a lower bound; the same is done
//! for a naive strategy (a fixed 60 ms after every EEPROM write, nothing
//! interleaved, a lone EOT after every reply as well as before every
//! telegram). Output: a Markdown table (set size: codes, of them EEPROM
//! codes, and codes written).
//!
//! # Reaction time
//!
//! The drives run with a **fixed reaction of 1 ms**, the spec's minimum
//! (LUSTBUS section 10; the Lenze models' fictional minimum), and the bound
//! uses the same figure. Random reactions would make the ratio measure the
//! drive's slowness rather than the client's overhead, and two runs would
//! not compare; a bound taken from a fixed minimum is also what a client
//! could at best hope for. Forced extra reactions the drive adds (the
//! VF1000 delays the ACK of a changed EEPROM value by 60 / 120 ms, section
//! 10 exception 4) are taken as they occur: the bound measures each
//! exchange in the event log.
//!
//! # The lower bound
//!
//! What any correct client of the transaction in DESIGN.md ("Transactions")
//! must spend, and nothing else:
//!
//! 1. **Required exchanges.** identify (the schema's identify codes), one
//!    read-back of every code of the set, and when anything differs: the
//!    SIOF/SERR read LUSTBUS forces before the first SELECT (power-on bit),
//!    one SELECT per code that differs, one verification read per code
//!    written, and on the MC6000 the SLOAD handshake (SLOAD = -1, SLOAD =
//!    -2, one poll that reads 0). That is `N` exchanges. Not counted: the
//!    engine's running-motor check, retries, extra SLOAD polls, NAKed
//!    SELECTs, lone EOTs, journal I/O (no virtual time).
//! 2. **Cost of an exchange** = from the first character (frame) of the
//!    request to the last of the reply, as the event log of the run shows:
//!    request wire time at 10 bits a character + the drive's reaction + reply
//!    wire time. The host's own gap before the next request is not counted.
//!    (CAN: request frame + reaction + the reply frame counted at its
//!    stuff-bit-free minimum of 111 bit times.) The bound sums the `N`
//!    cheapest exchanges of the run: every required exchange is among the
//!    run's exchanges, so that sum cannot exceed theirs. Reads and writes
//!    are counted apart (a write is an exchange whose reply is an
//!    acknowledgement), so an extra read never pushes out a write.
//! 3. **Check and store time that cannot overlap.** MC6000 dataset: after
//!    SLOAD = -2 the drive checks the set (the simulator's FICTIONAL check
//!    time, 20 ms + 1 ms per staged parameter; the spec gives none) and
//!    stores the staged values for width x 3 x 5 ms each (section 10.2.2),
//!    `driveset_sim::mc6000::dataset_busy_time`, reading SLOAD = -1 and
//!    NAKing every SELECT meanwhile; the staged
//!    values read back old until it is done and the DESIGN puts every other
//!    write after the commit, so nothing useful overlaps it but the -2 ACK
//!    and the final poll's request: `max(0, store - (1 ms + ACK + ENQUIRY))`.
//!    MC6000 EEPROM writes after the commit: the chain `sum(store of every
//!    paced write but the last) + last write + its verification read` is a
//!    second lower bound of that phase; it is printed when it exceeds the
//!    phase's work (it does not for these sets).
//!
//! The targets (issue): ratio <= 1.05 for the full upload, <= 1.02 for the
//! re-run.

#[path = "../tests/integration/support/campaign_rig.rs"]
mod rig;

#[path = "support/bound.rs"]
mod bound;

use std::time::Duration;

use driveset_engine::client::LustbusOptions;
use driveset_engine::overrides::Overrides;
use driveset_engine::upload::{Strategy, UploadOptions, UploadReport, prepare, upload};
use driveset_schema::ResolvedSet;
use driveset_schema::schema::StorageKind;
use driveset_sim::catalog::Family;
use driveset_sim::drive::ReactionTime;
use driveset_sim::log::EventLog;

use bound::{REACTION, lower_bound};

/// One measured run.
struct Run {
    time: Duration,
    bound: Duration,
    report: UploadReport,
}

fn run(family: Family, set: &ResolvedSet, naive: bool, rerun: bool) -> Run {
    let log = EventLog::memory();
    let b = rig::bus(
        family,
        Some(ReactionTime::fixed(REACTION)),
        7,
        None,
        log.clone(),
    );
    let lust = LustbusOptions {
        eot_after_reply: naive,
        ..LustbusOptions::default()
    };
    let mut c = rig::client(family, b, lust);
    let dir = tempfile::tempdir().expect("tempdir");
    let mut opts = UploadOptions::new(dir.path().join("first.json"));
    if naive {
        opts.strategy = Strategy::Naive {
            eeprom_wait: Duration::from_millis(60),
        };
    }
    if rerun {
        upload(&mut *c, set, &opts).unwrap_or_else(|f| panic!("{}: {f}", family.name()));
        opts.journal = dir.path().join("second.json");
    }
    // the plan of this run (reads only; its exchanges are left out of the log)
    let prepared = prepare(&mut *c, set, Overrides::none()).expect("prepare");
    let skip = log.events().len();
    let report = upload(&mut *c, set, &opts).unwrap_or_else(|f| {
        panic!(
            "{}: {f}\n{}",
            family.name(),
            f.report.as_ref().map(|r| r.render()).unwrap_or_default()
        )
    });
    let events = log.events();
    let bound = lower_bound(family, set, &prepared, &events[skip..]).bound;
    Run {
        time: report.elapsed,
        bound,
        report,
    }
}

fn secs(d: Duration) -> String {
    format!("{:.3} s", d.as_secs_f64())
}

fn ratio(r: &Run) -> f64 {
    r.time.as_secs_f64() / r.bound.as_secs_f64()
}

fn main() {
    let mut rows = Vec::new();
    let mut misses = Vec::new();
    for family in Family::ALL {
        let set = rig::full_set(family, 1);
        let schema = rig::schema(family);
        let eeprom = set
            .values
            .keys()
            .filter(|k| {
                schema
                    .code(k.number)
                    .is_some_and(|c| c.kind == Some(StorageKind::Eeprom))
            })
            .count();
        for (label, rerun, target) in [("full upload", false, 1.05), ("re-run", true, 1.02)] {
            let fast = run(family, &set, false, rerun);
            let naive = run(family, &set, true, rerun);
            eprintln!(
                "{} {label}: {} telegrams, {} retries, {} interleaved reads, {} written",
                family.name(),
                fast.report.telegrams,
                fast.report.retries,
                fast.report.interleaved_reads,
                fast.report.codes_written
            );
            if ratio(&fast) > target {
                misses.push(format!(
                    "{} {label}: ratio {:.4} > {target}",
                    family.name(),
                    ratio(&fast)
                ));
            }
            rows.push(format!(
                "| {} | {label} | {} codes ({eeprom} EEPROM, {} written) | {} | {} | {:.4} | {} | {:.4} |",
                family.name(),
                set.values.len(),
                fast.report.codes_written,
                secs(fast.time),
                secs(fast.bound),
                ratio(&fast),
                secs(naive.time),
                naive.time.as_secs_f64() / fast.bound.as_secs_f64(),
            ));
        }
    }
    println!();
    println!("| family | run | set size | time | bound | ratio | naive time | naive ratio |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
    if misses.is_empty() {
        println!("\nall targets met (full upload <= 1.05, re-run <= 1.02)");
    } else {
        println!("\nTARGETS MISSED:\n{}", misses.join("\n"));
    }
}
