//! Twins from what the engine read (docs/twins.md): a drive's capture
//! ([`of_drive`]: its values, the codes it refused and how it refused them
//! on the wire, its descriptions and texts as it sent them) and a recorded
//! bus session ([`sessions`], [`of_session`]: what a vendor tool's traffic
//! showed of each station). Pure: the engine's findings in, the
//! simulator's [`Twin`] out; reading the drive and writing the file are
//! the caller's.

use std::collections::BTreeMap;

use driveset_engine::capture::{Capture, Described, Session};
use driveset_engine::decode::{Capture as Format, Event};
use driveset_engine::env::Environment;
use driveset_engine::error::DeviceCause;
use driveset_schema::{CodeKey, RawValue, Schema};
use driveset_sim::drive::ReadRefusal;
use driveset_sim::twin::Twin;

/// What a twin says of its own making: the driveset version that wrote
/// it, the capture date (`YYYY-MM-DD`, UTC) and its source (`drive PORT
/// address N`, `capture FILE`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stamp {
    /// The driveset version.
    pub driveset: String,
    /// The capture date.
    pub captured: String,
    /// What it was captured from.
    pub source: String,
}

impl Stamp {
    /// A twin written now: this driveset, today's date (UTC) by `env`'s
    /// clock, `source`.
    pub fn now(env: &dyn Environment, source: String) -> Stamp {
        let now = env.now_utc().to_string();
        Stamp {
            driveset: env!("CARGO_PKG_VERSION").to_string(),
            captured: now.get(..10).unwrap_or(&now).to_string(),
            source,
        }
    }
}

/// The twin of a drive's capture `cap` read with `schema` at `address`:
/// `rate` the port's line rate (or CAN bit rate) when the client did not
/// say the one it talked at; `described` what a LUSTBUS drive described,
/// as it sent it.
pub fn of_drive(
    cap: &Capture,
    schema: &Schema,
    address: u8,
    stamp: Stamp,
    rate: u32,
    described: Option<Described>,
) -> Twin {
    let mut twin = Twin::new(schema.family, address, &schema.id);
    twin.driveset = stamp.driveset;
    twin.captured = stamp.captured;
    twin.identity = cap.identity.pairs();
    twin.running = cap.running;
    twin.reaction = cap.reaction;
    twin.values = cap.values.clone();
    twin.refused = cap.refused.clone();
    twin.refusals = cap
        .answers
        .iter()
        .filter_map(|(k, cause)| Some((*k, read_refusal(cause)?)))
        .collect();
    twin.secrets = cap.secrets.clone();
    twin.unread = cap.clears.clone();
    twin.unknown = cap.unread.clone();
    if let Some(source) = schema.family.descriptor().bus_write {
        twin.c0001 = c0001_of(&cap.values, schema, source.code);
    }
    // the dataset handshake's code (MC6000/7000 80-SLOAD, §11.4)
    if let Some(code) = schema.family.descriptor().dataset_code() {
        twin.sload = match cap.values.get(&CodeKey::new(code)) {
            Some(RawValue::Int(v)) => Some(*v),
            _ => None,
        }
    }
    twin.source = stamp.source;
    twin.rate = cap.rate.or(Some(rate));
    if let Some(d) = described {
        twin.layout = d.layout;
        twin.types = d.types;
        twin.descriptions = Some(d.descriptions);
        twin.texts = d.texts;
    }
    twin
}

/// How a drive refused a read on the wire, from the cause the client made
/// of it: LUSTBUS NAK (with the SIOF/SERR bits read after it, section 9.2),
/// LECOM EOT (8.H), CAN SDO abort (DS301 table 22).
fn read_refusal(cause: &DeviceCause) -> Option<ReadRefusal> {
    match cause {
        DeviceCause::Siof { bits, .. } => Some(ReadRefusal::NakSiof(bits.bits())),
        DeviceCause::NoSuchParameter { .. } | DeviceCause::SiofUnreadable => Some(ReadRefusal::Nak),
        DeviceCause::NoSuchCode { .. } => Some(ReadRefusal::NoSuchCode),
        DeviceCause::SdoAbort { code, .. } => Some(ReadRefusal::SdoAbort(code.0)),
        _ => None,
    }
}

/// The twin's `c0001`: the value in `values`, in engineering units (Tmd:
/// raw x10000, LECOM VD), of `code`, the code that says where the drive
/// takes its parameter writes from (the descriptor's
/// [`driveset_schema::family::Descriptor::bus_write`]: Tmd C0001,
/// `lecom-ab-tmd-manual.txt` §4e, §4f).
fn c0001_of(values: &BTreeMap<CodeKey, RawValue>, schema: &Schema, code: u32) -> Option<u8> {
    let Some(RawValue::Int(raw)) = values.get(&CodeKey::new(code)) else {
        return None;
    };
    let ty = schema.code(code).and_then(|c| schema.type_of(c))?;
    driveset_schema::value::raw_to_engineering(ty, *raw)
        .parse()
        .ok()
}

/// Per station address, what the decoded session `events` in `format`
/// showed of each drive, read with `schema` (the engine's
/// [`driveset_engine::capture::lecom_session`] and its siblings).
pub fn sessions(format: Format, events: &[Event], schema: &Schema) -> BTreeMap<u8, Session> {
    match format {
        Format::Lustbus => driveset_engine::capture::lustbus_session(events, schema),
        Format::Slcan => driveset_engine::capture::can_session(events, schema),
        Format::Lecom => driveset_engine::capture::lecom_session(events, schema),
    }
}

/// The twin of what a recorded session in `format` showed of the drive at
/// `address` (module docs): every value it answered or acknowledged, the
/// codes it refused (answered as the protocol refuses a read: LECOM "no
/// such code", LUSTBUS NAK, on CAN the SDO abort code it gave), the
/// schema's codes the session did not show listed as unknown; passwords
/// never kept.
pub fn of_session(
    format: Format,
    session: Session,
    schema: &Schema,
    address: u8,
    stamp: Stamp,
) -> Twin {
    let answer = match format {
        Format::Lecom => ReadRefusal::NoSuchCode,
        Format::Lustbus => ReadRefusal::Nak,
        // the abort code is each refusal's own (below); this one is never used
        Format::Slcan => ReadRefusal::SdoAbort(0x0602_0000),
    };
    let mut twin = Twin::new(schema.family, address, &schema.id);
    twin.driveset = stamp.driveset;
    twin.captured = stamp.captured;
    twin.source = stamp.source;
    for code in &schema.codes {
        for key in driveset_engine::capture::code_keys(code) {
            if schema.is_password(code) {
                twin.secrets.push(key);
            } else if code.read_clears == Some(true) {
                // the served model latches it itself
                twin.unread.push(key);
            } else if !session.values.contains_key(&key) && !session.refused.contains_key(&key) {
                twin.unknown.push(key);
            }
        }
    }
    // a password a vendor tool wrote is not kept either
    twin.values = session
        .values
        .into_iter()
        .filter(|(k, _)| !twin.secrets.contains(k))
        .collect();
    twin.refusals = session
        .refused
        .keys()
        .map(|k| {
            let answer = match session.aborts.get(k) {
                Some(&code) => ReadRefusal::SdoAbort(code),
                None => answer,
            };
            (*k, answer)
        })
        .collect();
    twin.refused = session.refused;
    if let Some(source) = schema.family.descriptor().bus_write {
        twin.c0001 = c0001_of(&twin.values, schema, source.code);
    }
    twin
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use driveset_schema::{CodeKey, RawValue, Registry};

    use super::c0001_of;

    /// The twin's `c0001` is the value of the descriptor's bus-write source
    /// (Tmd C0001) in engineering units; a family without one has none.
    #[test]
    fn c0001_is_the_descriptors_bus_write_source() {
        let reg = Registry::builtin().expect("built-in schemas");
        let tmd = reg.get("lenze-tmd").expect("tmd");
        let source = tmd.family.descriptor().bus_write.expect("tmd bus write");
        assert_eq!(source.code, 1);
        let values = BTreeMap::from([(CodeKey::new(1), RawValue::Int(30_000))]);
        assert_eq!(c0001_of(&values, &tmd, source.code), Some(3));
        assert_eq!(c0001_of(&BTreeMap::new(), &tmd, source.code), None);
        let mc = reg.get("lust-mc6000").expect("mc6000");
        assert_eq!(mc.family.descriptor().bus_write, None);
    }
}
