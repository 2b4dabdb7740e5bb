//! The upload benchmarks' lower bound (shared by `upload.rs` and
//! `latency.rs`; see `upload.rs`'s docs, "The lower bound"): the cheapest
//! required exchanges of a run as its event log shows them, plus the store
//! time that cannot overlap.

use std::time::Duration;

use driveset_engine::plan::Phase;
use driveset_engine::upload::Prepared;
use driveset_link::mem::{bits_time, wire_time};
use driveset_schema::ResolvedSet;
use driveset_sim::catalog::Family;
use driveset_sim::log::{Dir, Event};

use super::rig;

/// The drives' fixed reaction time in the benchmarks (the spec minimum).
pub const REACTION: Duration = Duration::from_millis(1);

fn hex_len(e: &Event) -> usize {
    e.hex.split_whitespace().count()
}

/// Exchange costs from the log (request start to reply end), split into
/// writes (the reply is an acknowledgement: LUSTBUS `ADR ACK`/`ADR NAK`,
/// LECOM ACK/NAK, SDO download response 0x60) and reads (a value reply).
fn exchanges(events: &[Event], can: bool) -> (Vec<Duration>, Vec<Duration>) {
    let mut reads = Vec::new();
    let mut writes = Vec::new();
    let mut pending: Option<&Event> = None;
    for e in events {
        match e.dir {
            Dir::Host => pending = Some(e),
            Dir::Drive => {
                if let Some(h) = pending.take() {
                    let start = Duration::from_nanos(h.t_ns);
                    let reply_start = Duration::from_nanos(e.t_ns);
                    let len = hex_len(e);
                    let (reply, is_write) = if can {
                        (bits_time(111, rig::BITRATE), e.hex.starts_with("60"))
                    } else {
                        (wire_time(len, rig::BAUD), len <= 2)
                    };
                    let cost = reply_start.saturating_sub(start) + reply;
                    if is_write {
                        writes.push(cost);
                    } else {
                        reads.push(cost);
                    }
                }
            }
            Dir::Event => {}
        }
    }
    reads.sort();
    writes.sort();
    (reads, writes)
}

/// A run's lower bound and the count of required exchanges in it.
#[allow(dead_code)] // `exchanges` is for latency.rs
pub struct Bound {
    /// The bound.
    pub bound: Duration,
    /// Required exchanges (reads + writes).
    pub exchanges: usize,
}

/// The lower bound of the upload of `set` whose plan is `prepared`, from
/// the run's `events` (those of the upload only).
pub fn lower_bound(
    family: Family,
    set: &ResolvedSet,
    prepared: &Prepared,
    events: &[Event],
) -> Bound {
    let (reads, writes) = exchanges(events, family == Family::Ecs);
    let w = prepared.plan.writes.len();
    let identify = rig::schema(family)
        .identify
        .as_ref()
        .map_or(0, |i| i.codes.len());
    let lustbus = matches!(family, Family::Mc6000 | Family::Vf1000);
    // LUSTBUS reads 91-TYPE when the schema names no identify codes
    let identify = if lustbus { identify.max(1) } else { identify };
    let staged: Vec<_> = prepared
        .plan
        .writes
        .iter()
        .filter(|w| w.phase == Phase::Dataset)
        .collect();
    // required reads: identify, read-back, SIOF, verification, the last SLOAD poll
    let mut n_reads = identify + set.values.len();
    // required writes: one per code that differs, SLOAD -1 and -2
    let mut n_writes = 0;
    if w > 0 {
        n_reads += w + usize::from(lustbus);
        n_writes += w;
        if !staged.is_empty() {
            n_reads += 1;
            n_writes += 2;
        }
    }
    assert!(
        reads.len() >= n_reads && writes.len() >= n_writes,
        "{}: {}/{} read/write exchanges in the log, {n_reads}/{n_writes} required",
        family.name(),
        reads.len(),
        writes.len()
    );
    let mut bound: Duration = reads.iter().take(n_reads).sum::<Duration>()
        + writes.iter().take(n_writes).sum::<Duration>();
    if !staged.is_empty() {
        let store: Duration = staged
            .iter()
            .map(|w| Duration::from_millis(15 * u64::from(w.width.unwrap_or(4))))
            .sum();
        let overlap = REACTION + wire_time(2, rig::BAUD) + wire_time(8, rig::BAUD);
        bound += store.saturating_sub(overlap);
    }
    // MC EEPROM chain after the commit (diagnostic: a second lower bound)
    let paced: Vec<_> = prepared
        .plan
        .writes
        .iter()
        .filter(|w| w.phase != Phase::Dataset && !w.store_time.is_zero())
        .collect();
    if paced.len() > 1 {
        let chain: Duration = paced[..paced.len() - 1].iter().map(|w| w.store_time).sum();
        let work: Duration = writes.iter().take(paced.len()).sum::<Duration>()
            + reads.iter().take(w).sum::<Duration>();
        if chain > work {
            eprintln!(
                "{}: EEPROM chain {chain:?} exceeds the phase's cheapest work {work:?}",
                family.name()
            );
            bound += chain - work;
        }
    }
    Bound {
        bound,
        exchanges: n_reads + n_writes,
    }
}
