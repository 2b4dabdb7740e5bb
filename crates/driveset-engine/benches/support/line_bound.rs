//! The line benchmark's lower bounds (see `line.rs`'s docs, "Bounds"): no
//! correct run can go under them. Every figure is an exchange the run
//! cannot do without, priced at its least wire time: the exact telegram
//! lengths at 10 bits a character at the bus rate (CAN: 111 bits a frame,
//! an 8-byte SDO frame without stuff bits, plus the 3-bit interframe
//! space), plus the family's minimum reaction time (the descriptor's; the
//! LUSTBUS spec's 1 ms, section 10), plus, for an MC6000/7000 dataset, the
//! time the drive checks and stores it after SLOAD = -2, which that drive's
//! poll and verification cannot overlap. A bus is serial: its bound is the
//! larger of (a) the sum of all its required exchanges and (b) the longest
//! single drive's chain (its exchanges before SLOAD = -2, the check and
//! store, the poll, its exchanges after). Buses run in parallel: the
//! line's bound is the largest bus bound.

use std::collections::BTreeSet;
use std::time::Duration;

use driveset_engine::plan::Phase;
use driveset_engine::upload::Prepared;
use driveset_link::mem::{bits_time, wire_time};
use driveset_schema::{CodeKey, RawValue, Schema};
use driveset_sim::log::{Dir, Event};

/// Bits of one CAN SDO frame at the least: 8 data bytes, no stuff bits,
/// with the interframe space.
const CAN_FRAME_BITS: u128 = 111;

/// MC VALUE characters of `raw` (section 2.3.2: hex without leading zeros;
/// negative values in two's complement of the code's width).
fn mc_value_len(schema: &Schema, key: CodeKey, raw: &RawValue) -> usize {
    let RawValue::Int(n) = raw else { return 1 };
    let width = schema.code(key.number).and_then(|c| c.width).unwrap_or(4);
    let wire: u64 = if *n >= 0 {
        *n as u64
    } else if width <= 2 {
        u64::from(*n as i16 as u16)
    } else {
        u64::from(*n as i32 as u32)
    };
    format!("{wire:X}").len()
}

/// Least time of an MC ENQUIRY of a value `len` characters long: `EOT ADR
/// CODE(5) ENQ`, the reaction, `ADR STX CODE(5) = VALUE ETX BCC`.
fn mc_read(len: usize, baud: u32, reaction: Duration) -> Duration {
    wire_time(8 + 10 + len, baud) + reaction
}

/// Least time of an MC SELECT: `EOT ADR STX CODE(5) = VALUE ETX BCC`, the
/// reaction, `ADR ACK`.
fn mc_write(len: usize, baud: u32, reaction: Duration) -> Duration {
    wire_time(11 + len + 2, baud) + reaction
}

/// One MC6000/7000 drive's commission as the bound counts it.
#[derive(Debug, Clone, Copy, Default)]
pub struct DriveBound {
    /// All its required exchanges.
    pub exchanges: Duration,
    /// Exchanges before its SLOAD = -2, the check and store, the poll, the
    /// exchanges after.
    pub chain: Duration,
}

/// The least commission of an MC6000/7000 drive whose live plan is
/// `prepared`, at `baud`: identify (91-TYPE), read back every code of the
/// set, the running check, SERR before the first SELECT, SLOAD = -1, one
/// SELECT per planned write except those in `broadcast` (a broadcast
/// brings them), SLOAD = -2, the check and store
/// ([`driveset_sim::mc6000::dataset_busy_time`]: the spec's 15 ms a byte
/// plus the simulator's FICTIONAL check time), one SLOAD poll, the writes
/// after the dataset, one verification read per planned code.
pub fn mc_drive(
    schema: &Schema,
    prepared: &Prepared,
    baud: u32,
    broadcast: &BTreeSet<CodeKey>,
) -> DriveBound {
    let reaction = driveset_schema::Family::Mc6000.descriptor().reaction.min;
    let read = |k: CodeKey, v: &RawValue| mc_read(mc_value_len(schema, k, v), baud, reaction);
    let write = |k: CodeKey, v: &RawValue| mc_write(mc_value_len(schema, k, v), baud, reaction);
    let type_len = prepared
        .identity
        .codes
        .iter()
        .find_map(|c| c.value.to_string().parse::<u64>().ok())
        .map_or(1, |t| format!("{t:X}").len());
    let mut before = mc_read(type_len, baud, reaction);
    for (k, v) in &prepared.current.values {
        before += read(*k, v);
    }
    let writes = &prepared.plan.writes;
    if writes.is_empty() {
        return DriveBound {
            exchanges: before,
            chain: before,
        };
    }
    // running (416-SCTL1 = 0) and SERR (0) reads, one character each
    before += 2 * mc_read(1, baud, reaction);
    let staged: Vec<_> = writes
        .iter()
        .filter(|w| w.phase == Phase::Dataset)
        .collect();
    let mut busy = Duration::ZERO;
    let mut poll = Duration::ZERO;
    if !staged.is_empty() {
        // SLOAD = -1 and -2 (FFFF, FFFE), then one poll reading 0
        before += 2 * mc_write(4, baud, reaction);
        for w in &staged {
            if !broadcast.contains(&w.key) {
                before += write(w.key, &w.new);
            }
        }
        let widths: Vec<u32> = staged
            .iter()
            .map(|w| u32::from(w.width.unwrap_or(4)))
            .collect();
        busy = driveset_sim::mc6000::dataset_busy_time(&widths);
        poll = mc_read(1, baud, reaction);
    }
    let mut after = Duration::ZERO;
    for w in writes.iter().filter(|w| w.phase != Phase::Dataset) {
        after += write(w.key, &w.new);
    }
    for w in writes {
        after += read(w.key, &w.new);
    }
    DriveBound {
        exchanges: before + poll + after,
        chain: before + busy + poll + after,
    }
}

/// Least time of the broadcast SELECTs of `values` (no reply, so no
/// reaction counted: the wire time alone).
pub fn mc_broadcast(schema: &Schema, values: &[(CodeKey, RawValue)], baud: u32) -> Duration {
    values
        .iter()
        .map(|(k, v)| wire_time(11 + mc_value_len(schema, *k, v), baud))
        .sum()
}

/// One bus's bound from its drives, and the broadcast time all of them
/// share (inside every drive's chain, before its SLOAD = -2).
pub fn bus(drives: &[DriveBound], broadcast: Duration) -> Duration {
    let sum: Duration = drives.iter().map(|d| d.exchanges).sum::<Duration>() + broadcast;
    let chain = drives
        .iter()
        .map(|d| d.chain + broadcast)
        .max()
        .unwrap_or_default();
    sum.max(chain)
}

/// The least time of a bus's read-only run (a rerun that finds every drive
/// holding its set, or `status`) from its event log: the `required`
/// cheapest read exchanges the log shows (identify and one read per code
/// per drive), each priced at its request's and reply's exact length at
/// `baud` (CAN: [`CAN_FRAME_BITS`] a frame at `bitrate`) plus `reaction`.
pub fn read_only_from_log(
    events: &[Event],
    required: usize,
    rate: u32,
    can: bool,
    reaction: Duration,
) -> Duration {
    let mut costs = Vec::new();
    let mut host: Option<usize> = None;
    for e in events {
        let len = e.hex.split_whitespace().count();
        match e.dir {
            Dir::Host => host = Some(len),
            Dir::Drive => {
                if let Some(h) = host.take() {
                    costs.push(if can {
                        bits_time(2 * CAN_FRAME_BITS, rate) + reaction
                    } else {
                        wire_time(h + len, rate) + reaction
                    });
                }
            }
            Dir::Event => {}
        }
    }
    costs.sort();
    assert!(
        costs.len() >= required,
        "{} exchanges in the log, {required} required",
        costs.len()
    );
    costs.iter().take(required).sum()
}
