//! Whether a switch pays (module docs of `crate::transfer`, "When it
//! pays"): [`decide`] over the exchanges a command cannot avoid at the
//! current rate and at the transfer rate plus the switch-over and back
//! (`lustbus-protocol.txt` §10, §10.2.2), the [`Decision`] it returns and
//! the [`TransferReport`] a command ends with.

use std::fmt::Write as _;
use std::time::Duration;

use driveset_schema::CodeKey;

use super::{Codes, TransferRequest, codes_of};
use crate::client::DriveClient;

/// Whether a switch pays ([`decide`]).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Decision {
    /// The rate the line runs at.
    pub old_rate: u32,
    /// The transfer rate asked for.
    pub rate: u32,
    /// Exchanges counted.
    pub exchanges: usize,
    /// Their time at the old rate.
    #[serde(serialize_with = "ser_ms")]
    pub at_old: Duration,
    /// Their time at the transfer rate.
    #[serde(serialize_with = "ser_ms")]
    pub at_rate: Duration,
    /// Switching over and back (exchanges and EEPROM waits).
    #[serde(serialize_with = "ser_ms")]
    pub switch_over: Duration,
    /// Switch (it saves time).
    pub switch: bool,
}

fn ser_ms<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64() * 1000.0)
}

fn exchanges(n: usize) -> String {
    if n == 1 {
        "1 exchange".into()
    } else {
        format!("{n} exchanges")
    }
}

fn secs(d: Duration) -> String {
    if d >= Duration::from_secs(1) {
        format!("{:.1} s", d.as_secs_f64())
    } else {
        format!("{} ms", d.as_millis())
    }
}

impl Decision {
    /// `transfer rate 57600: saves 4.1 s of 6.0 s` or `transfer rate
    /// 57600: not switched: ...`.
    pub fn summary(&self) -> String {
        let with = self.at_rate + self.switch_over;
        if self.old_rate == self.rate {
            return format!(
                "transfer rate {}: not switched: the line already runs at {} baud",
                self.rate, self.old_rate
            );
        }
        if self.switch {
            format!(
                "transfer rate {}: saves {} of {} ({}: {} at {} baud, {} at {} baud plus {} to switch over and back)",
                self.rate,
                secs(self.at_old.saturating_sub(with)),
                secs(self.at_old),
                exchanges(self.exchanges),
                secs(self.at_old),
                self.old_rate,
                secs(self.at_rate),
                self.rate,
                secs(self.switch_over)
            )
        } else {
            format!(
                "transfer rate {}: not switched: it does not pay ({}: {} at {} baud against {} at {} baud plus {} to switch over and back)",
                self.rate,
                exchanges(self.exchanges),
                secs(self.at_old),
                self.old_rate,
                secs(self.at_rate),
                self.rate,
                secs(self.switch_over)
            )
        }
    }
}

/// What a transaction with a transfer rate did about the rate.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct TransferReport {
    /// The estimate.
    pub decision: Decision,
    /// Whether the drive was switched.
    pub switched: bool,
    /// Where the drive's rate stands at the end, for humans (`the drive
    /// runs at 9600 baud again; 81-SBAUD holds 9600 (not active)`).
    pub state: String,
}

impl TransferReport {
    /// Two lines for the report.
    pub fn render(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "{}", self.decision.summary());
        if self.switched {
            let _ = writeln!(out, "line rate: {}", self.state);
        }
        out
    }
}

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
