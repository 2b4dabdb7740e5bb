//! Read-only LUSTBUS probes on a bare [`LustLine`] (scan, `driveset
//! address`'s lone-device check, replace): an ENQUIRY at an address, no
//! client, no session bookkeeping (`lustbus-protocol.txt` sections 5.2,
//! 6.1).

use std::time::Duration;

use driveset_link::{ByteLink, LinkError};
use driveset_proto::lustbus::{Address, Enquiry, ParameterCode, Reply};
use driveset_schema::family::TYPE;

use super::encoding::parse_hex;
use super::line::{LustLine, Outcome};

/// Reads 91-TYPE (CODE `00091`, section 5.2) at `address` on `line`: the
/// scan probe. `Ok(None)` when nothing answers, `Ok(Some(None))` when a
/// drive answers NAK, `Ok(Some(Some(type)))` with a value.
pub(crate) fn probe_type<L: ByteLink>(
    line: &mut LustLine<L>,
    address: Address,
    timeout: Duration,
    tries: u32,
) -> Result<Option<Option<i64>>, LinkError> {
    let code = ParameterCode::new(TYPE).unwrap_or(ParameterCode::POSMOD);
    probe_code(line, address, code, timeout, tries)
}

/// What one read-only ENQUIRY probe heard (`driveset address`'s lone
/// device check, [`crate::assign`]): unlike [`probe_code`] it tells
/// garbage (several devices answering at once, §4.2) from silence.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Heard {
    /// A value reply (`None`: not a hex number).
    Value(Option<i64>),
    /// A NAK (or ACK) reply.
    Nak,
    /// Something arrived that does not decode.
    Garbled(String),
    /// Nothing.
    Nothing,
}

/// An ENQUIRY of `code` at `address`, up to `tries` times: the first
/// reply that decodes, else whether garbage arrived.
pub(crate) fn probe_heard<L: ByteLink>(
    line: &mut LustLine<L>,
    address: Address,
    code: ParameterCode,
    timeout: Duration,
    tries: u32,
) -> Result<Heard, LinkError> {
    let bytes = Enquiry::new(address, code).encode();
    let mut garbled = None;
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            line.stats.retries += 1;
        }
        match line.exchange(&bytes, address, Some(code), timeout, Duration::ZERO)? {
            Outcome::Reply(Reply::Value(v)) => {
                return Ok(Heard::Value(parse_hex(v.value.as_bytes())));
            }
            Outcome::Reply(_) => return Ok(Heard::Nak),
            Outcome::Garbled(g) => garbled = Some(g),
            Outcome::NoAnswer => {}
        }
    }
    Ok(garbled.map_or(Heard::Nothing, Heard::Garbled))
}

/// An ENQUIRY of `code` at `address` (a read-only probe): `Ok(None)` when
/// nothing answers, `Ok(Some(None))` for a NAK, `Ok(Some(Some(value)))`.
pub(crate) fn probe_code<L: ByteLink>(
    line: &mut LustLine<L>,
    address: Address,
    code: ParameterCode,
    timeout: Duration,
    tries: u32,
) -> Result<Option<Option<i64>>, LinkError> {
    let bytes = Enquiry::new(address, code).encode();
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            line.stats.retries += 1;
        }
        match line.exchange(&bytes, address, Some(code), timeout, Duration::ZERO)? {
            Outcome::Reply(Reply::Value(v)) => return Ok(Some(parse_hex(v.value.as_bytes()))),
            Outcome::Reply(_) => return Ok(Some(None)),
            // Garbage at the right time: something is there (two drives on
            // one address, a drive at another rate); a retry may tell more.
            Outcome::Garbled(_) | Outcome::NoAnswer => {}
        }
    }
    Ok(None)
}
