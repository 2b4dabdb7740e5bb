//! The `--dry-run` text of a plan ([`Plan::render`]): its writes by phase,
//! old -> new in engineering units, storage, and the expected time.

use std::fmt::Write as _;

use super::{DATASET_TIMEOUT, Phase, Plan, Storage, TimeEstimate};

impl Plan {
    /// The `--dry-run` text: codes, old -> new (engineering units, labels;
    /// passwords redacted), storage, and the expected time.
    pub fn render(&self, estimate: Option<&TimeEstimate>) -> String {
        let mut out = String::new();
        let total = self.writes.len() + self.unchanged.len();
        let _ = writeln!(
            out,
            "plan: {} of {total} codes differ (schema {}, set {})",
            self.writes.len(),
            self.schema,
            self.set_fingerprint
        );
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        let mut phase = None;
        for w in &self.writes {
            if phase != Some(w.phase) {
                phase = Some(w.phase);
                let head = match w.phase {
                    Phase::Dataset => {
                        "dataset download (SLOAD = -1, CardWriteable values, SLOAD = -2, drive checks the set):"
                    }
                    Phase::Stored => "configuration values:",
                    Phase::Control => "control values (act at once):",
                    Phase::Mode => "operating mode / control source:",
                    Phase::Link => {
                        "serial interface (last; baud rates take effect after a restart):"
                    }
                };
                let _ = writeln!(out, "  {head}");
            }
            let storage = match (w.storage, w.width) {
                (Storage::Ram, _) => "RAM".to_string(),
                (Storage::FselIsel, _) => "FSEL/ISEL (RAM at CSEL=3, else EEPROM)".to_string(),
                (Storage::Eeprom, Some(b)) => format!("EEPROM {b} B"),
                (Storage::Eeprom, None) => "EEPROM".to_string(),
                (Storage::CardWriteable, Some(b)) => format!("CardWriteable, EEPROM {b} B"),
                (Storage::CardWriteable, None) => "CardWriteable".to_string(),
                (Storage::Unspecified, _) => "stored by the drive".to_string(),
            };
            let mut extra = String::new();
            if !w.store_time.is_zero() {
                let _ = write!(extra, ", store {} ms", w.store_time.as_millis());
            }
            if !w.ack_delay.is_zero() {
                let _ = write!(extra, ", ACK delay {} ms", w.ack_delay.as_millis());
            }
            let _ = writeln!(
                out,
                "    {}: {} -> {}  [{storage}{extra}]",
                w.label, w.old_text, w.new_text
            );
        }
        if let Some(e) = estimate {
            let _ = write!(
                out,
                "expected time: {:.3} s (read back {:.3} s, writes {:.3} s, verify {:.3} s, EEPROM waits {:.3} s)",
                e.total.as_secs_f64(),
                e.read_back.as_secs_f64(),
                e.writes.as_secs_f64(),
                e.verify.as_secs_f64(),
                e.waits.as_secs_f64()
            );
            if self.dataset {
                let _ = write!(
                    out,
                    " plus the drive's dataset check (up to {} s)",
                    DATASET_TIMEOUT.as_secs()
                );
            }
            out.push('\n');
        }
        out
    }
}
