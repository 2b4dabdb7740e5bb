//! Owns what a command reports about a transfer rate (`--transfer-baud`):
//! whether a switch pays ([`Decision`], the estimate `crate::transfer`'s
//! `decide` makes, module docs of `crate::transfer`, "When it pays") and
//! what a transaction did about the rate ([`TransferReport`]). Plain data
//! and its rendering, between the transfer-rate switch that fills it and
//! the reports that carry it (upload, pull, live diff, the dry run), so
//! that `crate::upload` needs nothing of the switch itself.

use std::fmt::Write as _;
use std::time::Duration;

/// Whether a switch pays (`crate::transfer::decide`).
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
