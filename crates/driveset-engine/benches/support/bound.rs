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
    // the store step of a schema that keeps writes only on command, on
    // every run (docs/file-formats.md, "The store step"): the store
    // command and one read of every code of the set after it
    let (store_reads, store_writes) = store_exchanges(family, set);
    n_reads += store_reads;
    n_writes += store_writes;
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

// ---------------------------------------------------------------------------
// The first-principles bound (issue 12: "a lower bound that a run can beat
// is not one"): see `upload.rs`'s docs, "The first-principles bound".
// ---------------------------------------------------------------------------

/// One required exchange of a LUSTBUS transaction.
#[derive(Debug, Clone, Copy)]
pub enum Need {
    /// An ENQUIRY of a code.
    Read(driveset_schema::CodeKey),
    /// A SELECT of a code with a value (raw).
    Write(driveset_schema::CodeKey, i64),
}

/// Hex digits of the VALUE of a SELECT at its shortest (§2.3.2: the MC
/// takes 1..8 digits; a negative value needs every digit of its width;
/// VF1000 values are 4 digits, §2.3.1).
fn select_digits(family: Family, width: usize, v: i64) -> usize {
    match family {
        Family::Vf1000 => 4,
        _ if v < 0 => 2 * width,
        _ => {
            let mut n = 1;
            let mut x = v >> 4;
            while x > 0 {
                n += 1;
                x >>= 4;
            }
            n
        }
    }
}

/// The drive's VALUE digits in a reply (MC: two per byte of the width,
/// the simulator's and §6.1.1.2's `04FA4000`; VF1000: 4).
fn reply_digits(family: Family, width: usize) -> usize {
    match family {
        Family::Vf1000 => 4,
        _ => 2 * width,
    }
}

/// The minimum time of one LUSTBUS exchange at `baud`: the minimal
/// telegrams' characters at 10 bits each plus the §10 minimum reaction.
/// ENQUIRY `EOT ADR CODE(5) ENQ` (8) + `ADR STX CODE(5) = VALUE ETX BCC`
/// (10 + digits); SELECT `EOT ADR STX CODE(5) = VALUE ETX BCC` (11 +
/// digits) + `ADR ACK` (2). One EOT per exchange: the trailing EOT of one
/// is the leading EOT of the next (§3).
pub fn lustbus_exchange(
    schema: &driveset_schema::Schema,
    family: Family,
    need: Need,
    baud: u32,
) -> Duration {
    let width = |k: driveset_schema::CodeKey| {
        usize::from(
            schema
                .code(k.number)
                .and_then(|c| c.width)
                .unwrap_or(1)
                .clamp(1, 4),
        )
    };
    let chars = match need {
        Need::Read(k) => 8 + 10 + reply_digits(family, width(k)),
        Need::Write(k, v) => 11 + select_digits(family, width(k), v) + 2,
    };
    wire_time(chars, baud) + REACTION
}

/// A first-principles bound as the sum of its terms, each named with what
/// it stands for (the benchmarks print the derivation beside the figure).
#[derive(Debug, Default)]
pub struct Derivation {
    /// (what, how many exchanges or `1`, time) per term.
    pub terms: Vec<(String, Duration)>,
}

#[allow(dead_code)] // not every bench uses every method
impl Derivation {
    fn add(&mut self, what: impl Into<String>, t: Duration) {
        if !t.is_zero() {
            self.terms.push((what.into(), t));
        }
    }

    /// The bound.
    pub fn total(&self) -> Duration {
        self.terms.iter().map(|(_, t)| *t).sum()
    }

    /// One line per term and the sum, indented by `indent`.
    pub fn render(&self, indent: &str) -> String {
        let mut out = String::new();
        for (what, t) in &self.terms {
            out.push_str(&format!(
                "{indent}{:>9.3} ms  {what}\n",
                t.as_secs_f64() * 1e3
            ));
        }
        out.push_str(&format!(
            "{indent}{:>9.3} ms  = the bound\n",
            self.total().as_secs_f64() * 1e3
        ));
        out
    }
}

/// The first-principles lower bound of a LUSTBUS upload of `set` planned
/// as `prepared`, at `baud`, switched to `transfer` (if any) for the work:
/// see `upload.rs`'s docs.
#[allow(dead_code)] // not every bench uses every bound
pub fn lustbus_upload_bound(
    family: Family,
    set: &ResolvedSet,
    prepared: &Prepared,
    baud: u32,
    transfer: Option<u32>,
) -> Duration {
    lustbus_upload_derivation(family, set, prepared, baud, transfer).total()
}

/// [`lustbus_upload_bound`] term by term.
#[allow(dead_code)] // not every bench uses every bound
pub fn lustbus_upload_derivation(
    family: Family,
    set: &ResolvedSet,
    prepared: &Prepared,
    baud: u32,
    transfer: Option<u32>,
) -> Derivation {
    use driveset_schema::{CodeKey, RawValue};
    // the schema once (the simulator's catalog parses every schema it
    // holds for each one it gives: once per exchange, that was most of the
    // benchmark's own time)
    let schema = rig::schema(family);
    let at = |n: Need, b: u32| lustbus_exchange(&schema, family, n, b);
    let int = |v: &RawValue| match v {
        RawValue::Int(i) => *i,
        _ => 0,
    };
    let work = transfer.unwrap_or(baud);
    let writes = &prepared.plan.writes;
    let mut d = Derivation::default();
    d.add(
        format!("identify: ENQUIRY 91-TYPE at {baud}"),
        at(Need::Read(CodeKey::new(91)), baud),
    );
    let selects = !writes.is_empty() || transfer.is_some();
    if selects {
        // SIOF/SERR before the first SELECT (§6: a set power-on bit blocks
        // every change), at the rate of that SELECT
        let first = if transfer.is_some() { baud } else { work };
        d.add(
            format!("SIOF/SERR before the first SELECT (§6) at {first}"),
            at(Need::Read(CodeKey::new(85)), first),
        );
    }
    if let Some(rate) = transfer {
        d.add(
            format!("switch over at {baud} (§11.5): SELECT 81 = {rate}, 4 = 111"),
            at(Need::Write(CodeKey::new(81), i64::from(rate)), baud)
                + at(Need::Write(CodeKey::new(4), 111), baud),
        );
        d.add(
            format!("switch back at {rate}: SELECT 81 = {baud}, 4 = 111"),
            at(Need::Write(CodeKey::new(81), i64::from(baud)), rate)
                + at(Need::Write(CodeKey::new(4), 111), rate),
        );
    }
    d.add(
        format!(
            "read-back: {} ENQUIRYs (8 + 10 + the value's digits characters) at {work}",
            set.values.len()
        ),
        set.values.keys().map(|k| at(Need::Read(*k), work)).sum(),
    );
    let staged: Vec<_> = writes
        .iter()
        .filter(|w| w.phase == Phase::Dataset)
        .collect();
    if !staged.is_empty() {
        let sload = CodeKey::new(80);
        d.add(
            format!("dataset (§11.4): SLOAD = -1, SLOAD = -2, one poll at {work}"),
            at(Need::Write(sload, -1), work)
                + at(Need::Write(sload, -2), work)
                + at(Need::Read(sload), work),
        );
        let store: Duration = staged
            .iter()
            .map(|w| Duration::from_millis(15 * u64::from(w.width.unwrap_or(4))))
            .sum();
        // overlapping it: the -2 ACK and the final poll's ENQUIRY
        let overlap = REACTION + wire_time(2, work) + wire_time(8, work);
        d.add(
            format!(
                "store of the {} staged values after SLOAD = -2 (width x 3 x 5 ms, §10.2.2; rate-independent), less the -2 ACK and the poll's ENQUIRY",
                staged.len()
            ),
            store.saturating_sub(overlap),
        );
    }
    let mut vf_ack = Duration::ZERO;
    let mut selects_time = Duration::ZERO;
    for w in writes {
        // VF1000: a changed EEPROM value delays the ACK (§10 exception 4:
        // 60 ms one-byte, 120 ms two-byte parameters); every planned write
        // changes its value
        if family == Family::Vf1000 && w.storage == driveset_engine::plan::Storage::Eeprom {
            vf_ack += Duration::from_millis(if w.width == Some(1) { 60 } else { 120 });
        }
        selects_time += at(Need::Write(w.key, int(&w.new)), work) + at(Need::Read(w.key), work);
    }
    d.add(
        format!(
            "{} SELECTs (11 + the fewest digits + ADR ACK) and their verification ENQUIRYs at {work}",
            writes.len()
        ),
        selects_time,
    );
    d.add(
        "VF1000 forced ACK delays of changed EEPROM values (§10 exception 4)",
        vf_ack,
    );
    // the MC EEPROM chain after the commit: stores of consecutive paced
    // writes cannot overlap each other; the phase lasts at least the chain
    let paced: Vec<_> = writes
        .iter()
        .filter(|w| w.phase != Phase::Dataset && !w.store_time.is_zero())
        .collect();
    if paced.len() > 1 {
        let chain: Duration = paced[..paced.len() - 1].iter().map(|w| w.store_time).sum();
        let phase: Duration = writes
            .iter()
            .filter(|w| w.phase != Phase::Dataset)
            .map(|w| at(Need::Write(w.key, int(&w.new)), work) + at(Need::Read(w.key), work))
            .sum();
        d.add(
            "the EEPROM store chain after the commit beyond that phase's exchanges",
            chain.saturating_sub(phase),
        );
    }
    d
}

/// The first-principles lower bound of a LUSTBUS pull of `keys` at
/// `baud`, switched to `transfer` (if any), term by term.
#[allow(dead_code)] // not every bench uses every bound
pub fn lustbus_pull_derivation(
    family: Family,
    keys: &[driveset_schema::CodeKey],
    baud: u32,
    transfer: Option<u32>,
) -> Derivation {
    use driveset_schema::CodeKey;
    let schema = rig::schema(family);
    let at = |n: Need, b: u32| lustbus_exchange(&schema, family, n, b);
    let work = transfer.unwrap_or(baud);
    let mut d = Derivation::default();
    d.add(
        format!("identify: ENQUIRY 91-TYPE at {baud}"),
        at(Need::Read(CodeKey::new(91)), baud),
    );
    if let Some(rate) = transfer {
        d.add(
            format!("SIOF/SERR before the first SELECT (§6) at {baud}"),
            at(Need::Read(CodeKey::new(85)), baud),
        );
        d.add(
            format!("switch over at {baud} (§11.5): SELECT 81 = {rate}, 4 = 111"),
            at(Need::Write(CodeKey::new(81), i64::from(rate)), baud)
                + at(Need::Write(CodeKey::new(4), 111), baud),
        );
        d.add(
            format!("switch back at {rate}: SELECT 81 = {baud}, 4 = 111"),
            at(Need::Write(CodeKey::new(81), i64::from(baud)), rate)
                + at(Need::Write(CodeKey::new(4), 111), rate),
        );
    }
    d.add(
        format!(
            "{} ENQUIRYs (8 + 10 + the value's digits characters) at {work}",
            keys.len()
        ),
        keys.iter().map(|k| at(Need::Read(*k), work)).sum(),
    );
    d
}

/// [`lustbus_pull_derivation`]'s bound.
#[allow(dead_code)] // not every bench uses every bound
pub fn lustbus_pull_bound(
    family: Family,
    keys: &[driveset_schema::CodeKey],
    baud: u32,
    transfer: Option<u32>,
) -> Duration {
    lustbus_pull_derivation(family, keys, baud, transfer).total()
}

/// The first-principles lower bound of an ECS (CAN SDO) upload: every
/// required exchange (read-back, one expedited download per code that
/// differs, one upload to verify it) is two 8-byte frames at their
/// stuff-bit-free minimum (108 bits + 3 bits interframe space = 111 bit
/// times each) plus the minimum reaction.
#[allow(dead_code)] // not every bench uses every bound
pub fn ecs_upload_bound(set: &ResolvedSet, prepared: &Prepared) -> Duration {
    let one = bits_time(2 * 111, rig::BITRATE) + REACTION;
    let (store_reads, store_writes) = store_exchanges(Family::Ecs, set);
    let n = set.values.len() + 2 * prepared.plan.writes.len() + store_reads + store_writes;
    one * u32::try_from(n).unwrap_or(u32::MAX)
}

/// The exchanges of the store step (reads, writes) a transaction owes a
/// drive whose schema keeps writes only on command (`[schema.store] keeps
/// = "on-command"`: the ECS demo fixture, CiA 301 0x1010 sub 1), on every
/// run, a re-run included (values an earlier run left in RAM are stored
/// too): the store command, and one read of every code of the set after it
/// (a drive that restarted between the verification and the store stored
/// its old values, which no acknowledgement tells). None for a drive that
/// stores every write.
pub fn store_exchanges(family: Family, set: &ResolvedSet) -> (usize, usize) {
    if rig::schema(family).store.command().is_some() {
        (set.values.len(), 1)
    } else {
        (0, 0)
    }
}
