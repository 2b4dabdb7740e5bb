//! Whether a switch pays (module docs of `crate::transfer`, "When it
//! pays"): [`decide`] over the exchanges a command cannot avoid at the
//! current rate and at the transfer rate plus the switch-over and back
//! (`lustbus-protocol.txt` §10, §10.2.2), filling the [`Decision`] it
//! returns (the report types are `crate::rate_report`'s).

use std::time::Duration;

use driveset_schema::CodeKey;

use super::{Codes, TransferRequest, codes_of};
use crate::client::DriveClient;
use crate::rate_report::Decision;

/// One exchange's time at `to` baud, given its time at `from` baud: the
/// wire part scales with the rate, the minimum reaction `min` does not.
pub fn at_rate(t: Duration, min: Duration, from: u32, to: u32) -> Duration {
    let wire = t.saturating_sub(min).as_nanos();
    let scaled = wire * u128::from(from) / u128::from(to.max(1));
    min + Duration::from_nanos(u64::try_from(scaled).unwrap_or(u64::MAX))
}

/// Whether switching to `req.rate` pays for `reads` (codes the command
/// reads once each) and `writes` (codes it writes), see the module docs.
pub fn decide(
    client: &dyn DriveClient,
    req: &TransferRequest,
    reads: &[CodeKey],
    writes: &[CodeKey],
) -> Decision {
    let schema = client.schema();
    let old = client.line_rate().unwrap_or(req.rate);
    let min = schema.family.descriptor().reaction.min;
    let scale = |t: Duration| at_rate(t, min, old, req.rate);
    let mut at_old = Duration::ZERO;
    let mut at_new = Duration::ZERO;
    for k in reads {
        let t = client.read_time(*k);
        at_old += t;
        at_new += scale(t);
    }
    for k in writes {
        let t = client.write_time(*k);
        at_old += t;
        at_new += scale(t);
    }
    let switch_over = match codes_of(schema) {
        Some(c) => switch_over_time(client, c, old, req.rate),
        None => Duration::ZERO,
    };
    Decision {
        old_rate: old,
        rate: req.rate,
        exchanges: reads.len() + writes.len(),
        at_old,
        at_rate: at_new,
        switch_over,
        switch: old != req.rate && at_new + switch_over < at_old,
    }
}

/// The switch-over and back of the module docs, on a timeline with the
/// EEPROM store time of the SBAUD writes (§10.2.2: width x 3 x 5 ms).
fn switch_over_time(client: &dyn DriveClient, c: Codes, old: u32, rate: u32) -> Duration {
    let min = client.schema().family.descriptor().reaction.min;
    let store = client
        .schema()
        .code(c.rate.number)
        .and_then(|code| code.width)
        .map_or(Duration::from_millis(60), |w| {
            Duration::from_millis(15 * u64::from(w))
        });
    let r = client.read_time(c.rate);
    let w = client.write_time(c.rate);
    let p = client.write_time(CodeKey::new(c.online.command));
    let new = |t: Duration| at_rate(t, min, old, rate);
    // over: R W(SBAUD) W(PROG) | R, wait store, W(SBAUD before)
    let mut t = r + w;
    let stored = t + store;
    t += p + new(r);
    t = t.max(stored) + new(w);
    // back: R W(SBAUD old) W(PROG) | R (+ W(keep) R when the set changes it)
    t += new(r) + new(w) + new(p) + r;
    t
}
