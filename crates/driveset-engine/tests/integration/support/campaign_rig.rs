//! Shared by the upload benchmark (`benches/upload.rs`) and the fault
//! campaigns (`tests/campaign*.rs`): simulated drives of every family on a
//! virtual bus, a client for each, and a generated "full" set that changes
//! every writable code of the family's schema.
#![allow(dead_code)]

use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{
    CanClient, CanOptions, DriveClient, LecomClient, LustbusClient, LustbusOptions,
};
use driveset_engine::upload::{CodeOutcome, UploadOptions, upload};
use driveset_link::VirtualClock;
use driveset_proto::can::NodeId;
use driveset_schema::schema::{Access, EnumSource, StorageKind};
use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};
use driveset_sim::bus::SimByteBus;
use driveset_sim::can_bus::SimCanBus;
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::ReactionTime;
use driveset_sim::ecs::EcsDrive;
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::EventLog;
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::tmd::{TmdDrive, TmdOptions};
use driveset_sim::vf1000::Vf1000;

/// Bus address / node id of the simulated drive.
pub const ADDRESS: u8 = 1;

/// Line rate of the character buses, and the CAN bit rate.
pub const BAUD: u32 = 9600;
/// CAN bit rate.
pub const BITRATE: u32 = 500_000;

/// A simulated bus with one drive of a family on it.
pub enum Bus {
    Byte(SimByteBus),
    Can(SimCanBus),
}

/// The drive's full parameter state (every code).
pub fn drive_state(bus: &Bus) -> ResolvedSet {
    match bus {
        Bus::Byte(b) => b.drives()[0].state(),
        Bus::Can(b) => b.drives()[0].state(),
    }
}

/// A bus with one `family` drive (reaction `reaction`, seed `seed`) and
/// `faults` (run seed `seed`), logging into `log`.
pub fn bus(
    family: Family,
    reaction: Option<ReactionTime>,
    seed: u64,
    faults: Option<&FaultPlan>,
    log: EventLog,
) -> Bus {
    let clock = VirtualClock::new();
    match family {
        Family::Mc6000 | Family::Vf1000 | Family::Tmd => {
            let drive: Box<dyn driveset_sim::drive::ByteDrive> = match family {
                Family::Mc6000 => {
                    let mut o = LustOptions::new(ADDRESS).seed(seed);
                    if let Some(r) = reaction {
                        o = o.reaction(r);
                    }
                    Box::new(Mc6000::new(o).expect("mc6000"))
                }
                Family::Vf1000 => {
                    let mut o = LustOptions::new(ADDRESS).seed(seed);
                    if let Some(r) = reaction {
                        o = o.reaction(r);
                    }
                    Box::new(Vf1000::new(o).expect("vf1000"))
                }
                _ => {
                    // C0001 = 3: LECOM programs the drive (§4e)
                    let mut o = TmdOptions::at(ADDRESS).c0001(3);
                    o.seed = seed;
                    if let Some(r) = reaction {
                        o.reaction = r;
                    }
                    Box::new(TmdDrive::new(o).expect("tmd"))
                }
            };
            let mut b = SimByteBus::new(&clock, BAUD, vec![drive])
                .expect("bus")
                .with_log(log);
            if let Some(f) = faults {
                b = b.with_faults(f.clone(), seed);
            }
            Bus::Byte(b)
        }
        Family::Ecs => {
            let mut d = EcsDrive::new(NodeId::new(ADDRESS).expect("node"), seed).expect("ecs");
            if let Some(r) = reaction {
                d = d.with_reaction(r);
            }
            let mut b = SimCanBus::new(&clock, BITRATE, vec![Box::new(d)])
                .expect("bus")
                .with_log(log);
            if let Some(f) = faults {
                b = b.with_faults(f.clone(), seed);
            }
            Bus::Can(b)
        }
    }
}

/// A client of the family's protocol on `bus` (which it owns).
pub fn client(family: Family, bus: Bus, lust: LustbusOptions) -> Box<dyn DriveClient> {
    let schema = catalog::schema(family).expect("schema");
    match bus {
        Bus::Byte(b) => match family {
            Family::Tmd => Box::new(LecomClient::new(b, schema, ADDRESS).expect("client")),
            _ => Box::new(LustbusClient::with_options(b, schema, ADDRESS, lust).expect("client")),
        },
        Bus::Can(b) => Box::new(
            CanClient::with_options(b, schema, ADDRESS, CanOptions::default()).expect("client"),
        ),
    }
}

/// Codes a generated set leaves alone: the bus link (address, baud,
/// watchdog), the control words (start the motor), commands, handshakes and
/// status words.
fn excluded(family: Family, number: u32) -> bool {
    let list: &[u32] = match family {
        // 4-PROG, 80-SLOAD, 81-SBAUD, 82-SADDR, 83/84 watchdog, 85-SERR,
        // 91-TYPE, 108-STEXT text selector, 416-SCTL1 control word,
        // 470-CANAD / 471-CANBD (CAN node address, baud), 700-SCTL2 control
        // word 2, 704-RJOG jog command, 708-ERCLR clear error memory,
        // 402-CLSEL control location (2 = SIO keeps control on the bus)
        Family::Mc6000 => &[
            4, 80, 81, 82, 83, 84, 85, 91, 108, 402, 416, 470, 471, 700, 704, 708,
        ],
        // 3-CNTL, 11-STAT, 71-PROG, 81..85, 91
        Family::Vf1000 => &[3, 11, 71, 81, 82, 83, 84, 85, 91],
        // C0001 program source, C0002 command, C0009 address, C0040 enable,
        // C0043 trip reset, C0125 baud, C0135 control word, C0248/C0249 bank
        Family::Tmd => &[1, 2, 9, 40, 43, 125, 135, 248, 249],
        Family::Ecs => &[],
    };
    list.contains(&number)
}

fn raw_bounds(schema: &Schema, code: &driveset_schema::Code) -> (Option<i64>, Option<i64>) {
    let f = |fact: &Option<driveset_schema::schema::Fact>| match fact {
        Some(f) => match schema.fact_raw(code, f) {
            Ok(RawValue::Int(v)) => Some(v),
            _ => None,
        },
        None => None,
    };
    (f(&code.min), f(&code.max))
}

/// Whether a family's generated set also changes enumerated and bit-field
/// codes. The MC6000 set is the benchmark's "full set (200+ EEPROM codes of
/// mixed width)"; the other families keep their plain numeric codes (their
/// enumerations include interface and control settings the lists above do
/// not name).
fn changes_enums(family: Family) -> bool {
    family == Family::Mc6000
}

/// Another value from `listed` (raw values, in the schema's order): the one
/// `step` places after `old` (wrapping) that lies within min/max.
fn other_listed(
    listed: &[i64],
    old: i64,
    step: i64,
    bounds: (Option<i64>, Option<i64>),
) -> Option<i64> {
    let (min, max) = bounds;
    let ok: Vec<i64> = listed
        .iter()
        .copied()
        .filter(|v| min.is_none_or(|m| *v >= m) && max.is_none_or(|m| *v <= m))
        .collect();
    let n = ok.len();
    if n == 0 {
        return None;
    }
    let at = ok.iter().position(|v| *v == old).unwrap_or(n - 1);
    let step = usize::try_from(step.unsigned_abs()).ok()?.max(1);
    (1..n).map(|k| ok[(at + step * k) % n]).find(|v| *v != old)
}

/// The raw values an enumeration lists (a code's: scaled like its values;
/// a bit-field member's: the field's values).
fn listed(
    schema: &Schema,
    code: &driveset_schema::Code,
    src: &EnumSource,
    member: bool,
) -> Vec<i64> {
    let Some(e) = schema.enum_of(src) else {
        return Vec::new();
    };
    e.entries
        .iter()
        .filter_map(|(v, label, _)| {
            if member {
                Some(*v)
            } else {
                schema.enum_value(code, label)
            }
        })
        .collect()
}

/// Another valid combination of a bit-field code: the first member whose
/// field can change (to another listed value, or its lowest bit flipped),
/// the other bits kept, within min/max.
fn other_bits_value(
    schema: &Schema,
    code: &driveset_schema::Code,
    old: i64,
    step: i64,
    bounds: (Option<i64>, Option<i64>),
) -> Option<i64> {
    let (min, max) = bounds;
    for b in &code.bits {
        let bits = b.msb.checked_sub(b.lsb)? + 1;
        if bits >= 63 {
            continue;
        }
        let mask = (1i64 << bits) - 1;
        let field = (old >> b.lsb) & mask;
        let new_field = match &b.values {
            Some(src) => other_listed(
                &listed(schema, code, src, true),
                field,
                step,
                (Some(0), Some(mask)),
            ),
            None => Some(field ^ 1),
        };
        let Some(f) = new_field else { continue };
        let new = (old & !(mask << b.lsb)) | (f << b.lsb);
        if new != old && min.is_none_or(|m| new >= m) && max.is_none_or(|m| new <= m) {
            return Some(new);
        }
    }
    None
}

/// Candidate set: every writable integer code of the schema that the drive
/// holds, changed by `step` (or `-step` at the top of its range), except
/// `skip` and the codes [`excluded`] lists. Where [`changes_enums`], an
/// enumerated code moves to another listed value and a bit-field code to
/// another valid combination (a partial enumeration without another listed
/// value is stepped like a number); passwords are never changed.
pub fn candidate_set(
    family: Family,
    schema: &Schema,
    state: &ResolvedSet,
    step: i64,
    skip: &BTreeSet<CodeKey>,
) -> ResolvedSet {
    let mut set = ResolvedSet::new(schema);
    for (k, v) in &state.values {
        let Some(code) = schema.code(k.number) else {
            continue;
        };
        if excluded(family, k.number)
            || skip.contains(k)
            || code.access == Some(Access::Ro)
            || code.kind == Some(StorageKind::RamActual)
            || code.read_clears == Some(true)
            || schema.is_password(code)
        {
            continue;
        }
        let RawValue::Int(old) = v else { continue };
        let (min, max) = raw_bounds(schema, code);
        if code.values.is_some() || !code.bits.is_empty() {
            if !changes_enums(family) {
                continue;
            }
            let new = match &code.values {
                Some(src) => {
                    other_listed(&listed(schema, code, src, false), *old, step, (min, max))
                }
                None => other_bits_value(schema, code, *old, step, (min, max)),
            };
            if let Some(new) = new {
                set.insert(*k, RawValue::Int(new));
                continue;
            }
            // a partial enumeration takes other values in range: step it
            if code.values.is_none() || code.values_partial != Some(true) {
                continue;
            }
        }
        let up = old + step;
        let down = old - step;
        let new = if max.is_none_or(|m| up <= m) && min.is_none_or(|m| up >= m) {
            up
        } else if min.is_none_or(|m| down >= m) && max.is_none_or(|m| down <= m) {
            down
        } else {
            continue;
        };
        set.insert(*k, RawValue::Int(new));
    }
    set
}

/// A set over (nearly) every writable code of `family` that a factory-fresh
/// simulated drive takes: the candidate set with the codes the drive or the
/// planner refuse removed (found by uploading to a scratch drive).
pub fn full_set(family: Family, step: i64) -> ResolvedSet {
    let schema = catalog::schema(family).expect("schema");
    let mut skip = BTreeSet::new();
    let dir = tempfile::tempdir().expect("tempdir");
    for round in 0..50 {
        let b = bus(
            family,
            Some(ReactionTime::fixed(ms(1))),
            0,
            None,
            EventLog::off(),
        );
        let state = drive_state(&b);
        let set = candidate_set(family, &schema, &state, step, &skip);
        let mut c = client(family, b, LustbusOptions::default());
        let journal = dir.path().join(format!("probe-{round}.json"));
        match upload(&mut *c, &set, &UploadOptions::new(&journal)) {
            Ok(_) => return set,
            Err(f) => {
                let before = skip.len();
                if let Some(r) = &f.report {
                    for code in &r.codes {
                        if matches!(code.outcome, CodeOutcome::Failed(_)) {
                            skip.insert(CodeKey {
                                number: code.number,
                                subcode: code.subcode,
                            });
                        }
                    }
                }
                // a refusal or a dataset rejection names the code in the message
                let text = f.to_string();
                for k in set.values.keys() {
                    let label = schema.display_code(k.number, k.subcode);
                    if text.contains(&format!("{label}:"))
                        || text.contains(&format!("{label} "))
                        || text.contains(&format!("parameter {label}"))
                    {
                        skip.insert(*k);
                    }
                }
                assert!(
                    skip.len() > before,
                    "{}: cannot build a full set: {text}",
                    family.name()
                );
            }
        }
    }
    panic!("{}: no full set after 50 rounds", family.name());
}

/// Milliseconds.
pub const fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// The schema of a family.
pub fn schema(family: Family) -> Arc<Schema> {
    catalog::schema(family).expect("schema")
}
