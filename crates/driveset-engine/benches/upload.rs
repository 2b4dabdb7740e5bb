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
//! What any correct client of the transaction in docs/architecture.md ("The data path of an upload")
//! must spend, and nothing else:
//!
//! 1. **Required exchanges.** identify (the schema's identify codes), one
//!    read-back of every code of the set, and when anything differs: the
//!    SIOF/SERR read LUSTBUS forces before the first SELECT (power-on bit),
//!    one SELECT per code that differs, one verification read per code
//!    written, and on the MC6000 the SLOAD handshake (SLOAD = -1, SLOAD =
//!    -2, one poll that reads 0); for a drive whose schema keeps writes only
//!    on command (the ECS demo fixture), on every run, the store command and
//!    one read of every code of the set after it (`bound::store_exchanges`,
//!    docs/file-formats.md "The store step"). That is `N` exchanges. Not counted: the
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
//!
//! That bound is kept for these targets, but it is not a bound in the
//! strict sense: it is taken from the run's own log, so a run that spends
//! less on an exchange than another correct client could still come out
//! below it (issue 12: "a lower bound that a run can beat is not one").
//!
//! # The first-principles bound
//!
//! Printed beside it for every family but Tmd (and the only bound of the
//! transfer-rate rows). Nothing in it comes from the run:
//!
//! 1. **Required exchanges**, counted by what any correct client of
//!    the transaction (docs/architecture.md) must do: identify (91-TYPE), one read-back
//!    per code of the set; when any SELECT goes out (a write, or the rate
//!    switch): the SIOF/SERR read before the first SELECT (§6: a set
//!    power-on bit blocks every change), at the rate of that SELECT; one
//!    SELECT per code that differs and one verification read of it; on the
//!    MC6000 SLOAD = -1, SLOAD = -2 and one poll; on the ECS (demo fixture)
//!    the store step's command and its read of every code. With a transfer rate:
//!    81-SBAUD = RATE and 4-PROG = 111 at the old rate, 81-SBAUD = old and
//!    4-PROG = 111 at RATE (confirmation reads and the EEPROM restore of
//!    81 are this client's choice, not required). Not counted: the running
//!    check, retries, extra polls, lone EOTs.
//! 2. **Each at its minimum wire time at the rate in use** (the old rate
//!    before the switch and after it, RATE in between): the minimal
//!    telegrams' exact characters at 10 bits each. LUSTBUS ENQUIRY `EOT
//!    ADR CODE(5) ENQ` = 8 and its reply `ADR STX CODE(5) = VALUE ETX BCC`
//!    = 10 + the drive's digits (MC two per byte of the width, VF1000 4);
//!    SELECT `EOT ADR STX CODE(5) = VALUE ETX BCC` = 11 + the fewest
//!    digits that carry the value (MC: 1..8 hex digits, §2.3.2, all of the
//!    width for a negative value; VF1000 4) and `ADR ACK` = 2; one EOT per
//!    exchange (the trailing EOT of one is the leading EOT of the next).
//!    CAN (ECS): request and reply are 8-byte frames at their stuff-bit-free
//!    minimum, 111 bit times each. Plus the spec's **minimum reaction** (1
//!    ms, §10; the benchmark drives react in exactly that) and the VF1000's
//!    forced ACK delay of a changed EEPROM value (60 / 120 ms, §10
//!    exception 4).
//! 3. **Store and check time that cannot overlap**: the MC dataset's store
//!    time after SLOAD = -2 (width x 3 x 5 ms per staged value, §10.2.2)
//!    minus the -2 ACK and the final poll's ENQUIRY at the rate in use (the
//!    drive's check time, FICTIONAL in the simulator, is left out: the spec
//!    gives none); and the MC EEPROM chain after the commit (stores of
//!    consecutive paced writes cannot overlap), where it exceeds that
//!    phase's minimal exchanges.
//!
//! The benchmark fails (prints TARGETS MISSED, exit code 1) if any target
//! is missed or any run comes out under its first-principles bound. Tmd (LECOM) has none yet: its reply length
//! depends on the value's format, which the bound would have to derive
//! from the drive's answers.
//!
//! # Transfer rate (issue 12)
//!
//! The MC6000 full set uploaded and re-run with `--transfer-baud 57600`
//! (`driveset_engine::transfer`), timed on the bus clock from before the
//! switch to after the switch back, and an MC6000 pull of every readable
//! code at 9600 and at 57600. Targets (issue 33; issue 12's were 0.70,
//! 0.30, 0.30): the full upload <= 0.50 x the same upload at 9600 (the
//! store time after SLOAD = -2 does not shrink with the rate), the re-run
//! <= 0.30 x and the pull <= 0.25 x theirs at 9600, and each within 1.10 x
//! its first-principles bound, whose derivation (term by term) the
//! benchmark prints below its tables.

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

use bound::{
    Derivation, REACTION, ecs_upload_bound, lower_bound, lustbus_pull_derivation,
    lustbus_upload_bound, lustbus_upload_derivation,
};

/// One measured run.
struct Run {
    time: Duration,
    /// The log-based bound (cheapest exchanges of the run's own log).
    bound: Duration,
    /// The first-principles bound, where defined (not for Tmd).
    principled: Option<Duration>,
    report: UploadReport,
}

/// The first-principles bound of an upload (module docs).
fn principled(
    family: Family,
    set: &ResolvedSet,
    prepared: &driveset_engine::upload::Prepared,
    transfer: Option<u32>,
) -> Option<Duration> {
    match family {
        Family::Mc6000 | Family::Vf1000 => Some(lustbus_upload_bound(
            family,
            set,
            prepared,
            rig::BAUD,
            transfer,
        )),
        Family::Ecs => Some(ecs_upload_bound(set, prepared)),
        Family::Tmd => None,
    }
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
        principled: principled(family, set, &prepared, None),
        report,
    }
}

/// An MC6000 upload (`rerun`: the second one) with `--transfer-baud rate`:
/// the time on the bus clock from before the switch to after the switch
/// back, and its first-principles bound (the plan is that of the upload:
/// a `prepare` at 9600 before it, left out of the time).
fn transfer_run(set: &ResolvedSet, rerun: bool, rate: u32) -> (Duration, Derivation, UploadReport) {
    use driveset_engine::transfer::{self, TransferRequest};
    let family = Family::Mc6000;
    let b = rig::bus(
        family,
        Some(ReactionTime::fixed(REACTION)),
        7,
        None,
        EventLog::memory(),
    );
    let mut c = rig::client(family, b, LustbusOptions::default());
    let dir = tempfile::tempdir().expect("tempdir");
    let mut opts = UploadOptions::new(dir.path().join("first.json"));
    if rerun {
        upload(&mut *c, set, &opts).unwrap_or_else(|f| panic!("mc6000: {f}"));
        opts.journal = dir.path().join("second.json");
    }
    let prepared = prepare(&mut *c, set, Overrides::none()).expect("prepare");
    let t0 = c.clock().now();
    let report = transfer::upload(&mut *c, set, &opts, &TransferRequest::new(rate))
        .unwrap_or_else(|f| panic!("mc6000 at {rate}: {f}"));
    let time = c.clock().now() - t0;
    assert!(
        report.transfer.as_ref().is_some_and(|t| t.switched),
        "not switched: {}",
        report.render()
    );
    let switched = (rate != rig::BAUD).then_some(rate);
    let bound = lustbus_upload_derivation(family, set, &prepared, rig::BAUD, switched);
    (time, bound, report)
}

/// An MC6000 pull of every readable code, at 9600 (`rate` = None) or with
/// `--transfer-baud rate`: time and first-principles bound.
fn pull_run(rate: Option<u32>) -> (Duration, Derivation, usize) {
    use driveset_engine::pull::{PullOptions, pull};
    use driveset_engine::transfer::{self, TransferRequest};
    let family = Family::Mc6000;
    let b = rig::bus(
        family,
        Some(ReactionTime::fixed(REACTION)),
        7,
        None,
        EventLog::memory(),
    );
    let mut c = rig::client(family, b, LustbusOptions::default());
    let dir = tempfile::tempdir().expect("tempdir");
    let popts = PullOptions::default();
    let keys = transfer::pull_exchanges(&rig::schema(family), &popts);
    let t0 = c.clock().now();
    let pulled = match rate {
        None => pull(&mut *c, &popts).expect("pull"),
        Some(r) => {
            let (p, t) = transfer::pull(
                &mut *c,
                &popts,
                &TransferRequest::new(r),
                &dir.path().join("pull.json"),
                &driveset_engine::observe::Hook::none(),
            )
            .expect("pull");
            assert!(t.switched, "{}", t.render());
            p
        }
    };
    let time = c.clock().now() - t0;
    assert!(pulled.skipped.iter().all(|s| !s.failed), "a code failed");
    (
        time,
        lustbus_pull_derivation(family, &keys, rig::BAUD, rate),
        pulled.read,
    )
}

fn secs(d: Duration) -> String {
    format!("{:.3} s", d.as_secs_f64())
}

fn ratio(r: &Run) -> f64 {
    r.time.as_secs_f64() / r.bound.as_secs_f64()
}

fn of(a: Duration, b: Duration) -> f64 {
    a.as_secs_f64() / b.as_secs_f64()
}

fn opt_secs(d: Option<Duration>) -> String {
    d.map_or_else(|| "-".into(), secs)
}

fn main() {
    let mut rows = Vec::new();
    let mut misses = Vec::new();
    let mut mc_times: Vec<Duration> = Vec::new();
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
            if let Some(p) = fast.principled
                && fast.time < p
            {
                misses.push(format!(
                    "{} {label}: the run ({}) beat its first-principles bound ({}): the bound is wrong",
                    family.name(),
                    secs(fast.time),
                    secs(p)
                ));
            }
            if family == Family::Mc6000 {
                mc_times.push(fast.time);
            }
            rows.push(format!(
                "| {} | {label} | {} | {} codes ({eeprom} EEPROM, {} written) | {} | {} | {:.4} | {} | {} | {} | {:.4} |",
                family.name(),
                if family == Family::Ecs { "500 kbit/s" } else { "9600" },
                set.values.len(),
                fast.report.codes_written,
                secs(fast.time),
                secs(fast.bound),
                ratio(&fast),
                opt_secs(fast.principled),
                fast.principled.map_or_else(|| "-".into(), |p| format!("{:.4}", of(fast.time, p))),
                secs(naive.time),
                naive.time.as_secs_f64() / fast.bound.as_secs_f64(),
            ));
        }
    }
    // MC6000 with the transfer rate 57600 (issue 12), and pull
    let set = rig::full_set(Family::Mc6000, 1);
    let rate = 57600;
    let mut xrows = Vec::new();
    let mut derivations = Vec::new();
    for (i, (label, rerun, target)) in [
        ("full upload", false, FULL_AT_RATE),
        ("re-run", true, RERUN_AT_RATE),
    ]
    .into_iter()
    .enumerate()
    {
        let (time, d, report) = transfer_run(&set, rerun, rate);
        let bound = d.total();
        let base = mc_times[i];
        check_transfer(&mut misses, label, time, bound, base, target);
        derivations.push((format!("mc6000 {label} at {rate}"), d));
        xrows.push(format!(
            "| mc6000 | {label} | 9600, transfer {rate} | {} codes ({} written) | {} | {} | {:.4} (<= {WITHIN_BOUND}) | {:.4}x (<= {target}) |",
            set.values.len(),
            report.codes_written,
            secs(time),
            secs(bound),
            of(time, bound),
            of(time, base)
        ));
    }
    let (p9600, b9600, n) = pull_run(None);
    let (pfast, bfast, _) = pull_run(Some(rate));
    let (b9600, bfast_t) = (b9600.total(), bfast.total());
    if p9600 < b9600 {
        misses.push("mc6000 pull at 9600 beat its bound: the bound is wrong".into());
    }
    check_transfer(&mut misses, "pull", pfast, bfast_t, p9600, PULL_AT_RATE);
    derivations.push((format!("mc6000 pull at {rate}"), bfast));
    xrows.push(format!(
        "| mc6000 | pull | 9600 | {n} codes read | {} | {} | {:.4} | - |",
        secs(p9600),
        secs(b9600),
        of(p9600, b9600)
    ));
    xrows.push(format!(
        "| mc6000 | pull | 9600, transfer {rate} | {n} codes read | {} | {} | {:.4} (<= {WITHIN_BOUND}) | {:.4}x (<= {PULL_AT_RATE}) |",
        secs(pfast),
        secs(bfast_t),
        of(pfast, bfast_t),
        of(pfast, p9600)
    ));
    println!();
    println!(
        "| family | run | rate | set size | time | log bound | log ratio | first-principles bound | ratio | naive time | naive ratio |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
    println!();
    println!(
        "| family | run | rate | set size | time | first-principles bound | ratio | vs 9600 |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in xrows {
        println!("{r}");
    }
    println!("\nThe first-principles bounds of the transfer-rate rows, term by term:");
    for (what, d) in &derivations {
        println!("\n{what}:\n{}", d.render("  "));
    }
    if misses.is_empty() {
        println!(
            "upload: all targets met (full upload <= 1.05, re-run <= 1.02 of the log bound; at 57600 full upload <= {FULL_AT_RATE}x, re-run <= {RERUN_AT_RATE}x, pull <= {PULL_AT_RATE}x the 9600 run, each within {WITHIN_BOUND}x its first-principles bound; no run under its first-principles bound)"
        );
    } else {
        println!("upload: TARGETS MISSED:\n{}", misses.join("\n"));
        std::process::exit(1);
    }
}

/// Targets of the transfer-rate rows against the same run at 9600 and
/// against their first-principles bound. Issue 12 set 0.70 / 0.30 / 0.30;
/// issue 33 tightened them to what the switch reaches when nothing but the
/// work runs at the transfer rate (0.478x / 0.235x / 0.231x measured
/// before the regression it found): the full upload keeps the store time
/// after SLOAD = -2, which no rate shortens, so it cannot go as low as the
/// reads.
const FULL_AT_RATE: f64 = 0.50;
/// See [`FULL_AT_RATE`].
const RERUN_AT_RATE: f64 = 0.30;
/// See [`FULL_AT_RATE`].
const PULL_AT_RATE: f64 = 0.25;
/// How far over its first-principles bound a transfer-rate row may be
/// (issue 33): the bound leaves out only the client's own choices (the
/// switch's confirmation reads, the check for a restart after the switch
/// back, the running check) and the host's gaps.
const WITHIN_BOUND: f64 = 1.10;

/// The checks of one transfer-rate row.
fn check_transfer(
    misses: &mut Vec<String>,
    label: &str,
    time: Duration,
    bound: Duration,
    base: Duration,
    target: f64,
) {
    if of(time, base) > target {
        misses.push(format!(
            "mc6000 {label} at the transfer rate: {:.4}x the 9600 run > {target}",
            of(time, base)
        ));
    }
    if time < bound {
        misses.push(format!(
            "mc6000 {label} at the transfer rate beat its first-principles bound: the bound is wrong"
        ));
    } else if of(time, bound) > WITHIN_BOUND {
        misses.push(format!(
            "mc6000 {label} at the transfer rate: {:.4}x its first-principles bound > {WITHIN_BOUND}",
            of(time, bound)
        ));
    }
}
