//! Owns decoding a captured bus byte stream telegram by telegram (`driveset
//! decode`): the capture formats ([`Capture`]: LUSTBUS, LECOM-A/B, slcan
//! lines carrying CAN SDO), the events they give ([`Event`]: byte range,
//! direction, kind, address, code with its schema name, value as sent and
//! in engineering units, BCC, meaning, details) and the rules that make a
//! stretch of bytes an error (garbage, BCC mismatch, malformed or cut-off
//! frames, replies the specs rule out).
//!
//! Pure: bytes and schemas in, events out. The framing is proto's stream
//! parsers' ([`driveset_proto::lustbus::Sniffer`],
//! [`driveset_proto::lecom::BusSniffer`], proto's slcan codec); this module
//! adds the schemas' names, types and units and the protocol's rules about
//! who may answer whom. What a capture is read from and the schema it is
//! decoded with: [`input`]; the CLI renders the events.
//! The other way, [`encode`]: one telegram from a readable description
//! (`driveset encode`).

pub mod encode;
mod event;
pub mod input;
pub mod lecom;
pub mod lustbus;
pub mod slcan;

use std::fmt::Write as _;
use std::sync::Arc;

use driveset_proto::lustbus::Dialect;
use driveset_schema::{BusProtocol, Registry, Schema};

pub use event::{Bcc, DRIVE_TO_HOST, Event, HOST_TO_DRIVE};
pub use input::{CaptureGiven, CaptureInputError, MAX_CAPTURE_BYTES, SchemaMisfit};

/// The format of a capture: a bus protocol's byte stream, or slcan lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Capture {
    /// LUSTBUS (Lust VF1000, MC6000/7000).
    Lustbus,
    /// LECOM-A/B (Lenze Tmd).
    Lecom,
    /// slcan (Lawicel) lines carrying CAN SDO frames (Lenze ECS).
    Slcan,
}

impl Capture {
    /// The bus protocol the capture carries (the family descriptor's).
    pub fn bus(self) -> BusProtocol {
        match self {
            Capture::Lustbus => BusProtocol::Lustbus,
            Capture::Lecom => BusProtocol::Lecom,
            Capture::Slcan => BusProtocol::CanSdo,
        }
    }
}

/// What the annotators need: the schema registry, a forced schema, a forced
/// LUSTBUS family.
#[derive(Debug, Clone)]
pub struct Context {
    /// The schemas a LUSTBUS capture's family picks from (by the CODE
    /// layout, when neither `schema` nor `family` is given).
    pub registry: Registry,
    /// The schema for names, types and units.
    pub schema: Option<Arc<Schema>>,
    /// The LUSTBUS wire dialect, when known.
    pub family: Option<Dialect>,
}

/// Decode `capture` as `format`, handing each event to `each` as soon as
/// it is complete (so memory grows with one event, not with the capture:
/// `driveset decode` writes each out at once). A telegram carrying a
/// secret's value reaches `each` masked ([`Event::mask_secret`]).
pub fn decode_each(format: Capture, capture: &[u8], ctx: &Context, each: &mut dyn FnMut(Event)) {
    let mut masked = |mut e: Event| {
        if e.secret {
            e.mask_secret();
        }
        each(e);
    };
    match format {
        Capture::Lustbus => lustbus::decode(capture, ctx, &mut masked),
        Capture::Lecom => lecom::decode(capture, ctx, &mut masked),
        Capture::Slcan => slcan::decode(capture, ctx, &mut masked),
    }
}

/// [`decode_each`], collected.
pub fn decode(format: Capture, capture: &[u8], ctx: &Context) -> Vec<Event> {
    let mut out = Vec::new();
    decode_each(format, capture, ctx, &mut |e| out.push(e));
    out
}

/// Whether any event is an error (the capture holds bad telegrams).
pub fn has_errors(events: &[Event]) -> bool {
    events.iter().any(|e| e.error.is_some())
}

/// `04 40 30`.
pub fn hex_spaced(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{b:02X}");
    }
    s
}

/// An event for skipped garbage.
pub(crate) fn garbage_event(capture: &[u8], start: u64, end: u64, len: u64) -> Event {
    let mut e = Event::new(capture, start, end, "GARBAGE");
    let shown: Vec<u8> = e
        .bytes
        .split(' ')
        .take(16)
        .filter_map(|h| u8::from_str_radix(h, 16).ok())
        .collect();
    let more = if len > 16 { " ..." } else { "" };
    e.error = Some(format!(
        "{len} byte(s) {}{more} belong to no telegram; skipped",
        hex_spaced(&shown)
    ));
    e
}
