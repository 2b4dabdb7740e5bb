//! The spec's timing figures a plan uses (reaction times: LUSTBUS 10,
//! LECOM 8.J; the SLOAD handshake: LUSTBUS 11.4) and the expected duration
//! of a transaction on a client's wire times ([`Plan::estimate`]).

use std::time::Duration;

use driveset_proto::lustbus::Dialect;
use driveset_schema::{BusProtocol, CodeKey, Family, ResolvedSet};

use super::{Phase, Plan, Storage};
use crate::client::DriveClient;

/// The longest the MC6000/7000 dataset check may take before the upload
/// gives up (the family descriptor's SLOAD handshake, LUSTBUS 11.4).
pub const DATASET_TIMEOUT: Duration = driveset_schema::family::SLOAD.timeout;

/// The shortest interval between two SLOAD polls while the drive checks a
/// staged dataset (not a spec figure: 11.4 gives only the 10 s timeout; a
/// poll at most every 50 ms, or one measured round trip when that is
/// longer, instead of back-to-back ENQUIRYs).
pub const SLOAD_POLL_INTERVAL: Duration = Duration::from_millis(50);

/// The family that speaks the MC dialect (MC6000/7000), by its descriptor.
const MC: Family = Family::from_dialect(Dialect::Mc);

/// The family that speaks the VF1000 dialect, by its descriptor.
const VF: Family = Family::from_dialect(Dialect::Vf1000);

/// The family a LECOM line carries (its descriptor's only one, the Tmd):
/// checked when the crate is built.
const LECOM: Family = match BusProtocol::Lecom.only_family() {
    Some(f) => f,
    None => panic!("the descriptor names one family on LECOM"),
};

/// The longest reaction time of an MC6000/7000 with a KEYPAD attached
/// (the family descriptor: LUSTBUS 10, table: 1...30 ms).
pub const MC_MAX_REACTION_KEYPAD: Duration = reaction(MC, true);

/// The longest reaction time of an MC6000/7000 without KEYPAD (LUSTBUS 10:
/// 1...25 ms).
pub const MC_MAX_REACTION: Duration = reaction(MC, false);

/// The longest reaction time of a VF1000 with a KEYPAD attached (LUSTBUS
/// 10: 1...60 ms).
pub const VF_MAX_REACTION_KEYPAD: Duration = reaction(VF, true);

/// The longest reaction time of a VF1000 without KEYPAD (LUSTBUS 10:
/// 1...30 ms).
pub const VF_MAX_REACTION: Duration = reaction(VF, false);

/// The shortest reaction time of every LUSTBUS device (LUSTBUS 10: "1...";
/// the shorter of the two families' descriptor minimums).
pub const LUSTBUS_MIN_REACTION: Duration =
    shorter(MC.descriptor().reaction.min, VF.descriptor().reaction.min);

/// The shorter of `a` and `b` (a `const fn`: `Ord::min` is not one).
const fn shorter(a: Duration, b: Duration) -> Duration {
    if a.as_nanos() <= b.as_nanos() { a } else { b }
}

/// The longest reaction of `family` from its descriptor.
const fn reaction(family: Family, keypad: bool) -> Duration {
    let r = family.descriptor().reaction;
    match (keypad, r.max_with_keypad) {
        (true, Some(k)) => k,
        _ => r.max,
    }
}

/// LECOM 8.J b: "The monitoring time in the master should be approx. twice
/// as long as the maximum response time."
pub const LECOM_MONITORING_FACTOR: u32 = 2;

/// The Tmd's longest response time. FICTIONAL: the LECOM manual gives none;
/// the family descriptor assumes 20 ms, as the simulator's Tmd does.
pub const TMD_MAX_REACTION: Duration = LECOM.descriptor().reaction.max;

/// The shortest response time assumed of a Tmd, for planning (FICTIONAL,
/// as [`TMD_MAX_REACTION`]).
pub const TMD_MIN_REACTION: Duration = LECOM.descriptor().reaction.min;

/// Expected duration of a transaction, from the client's wire times and the
/// spec's store times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct TimeEstimate {
    /// Reading back every code of the set.
    pub read_back: Duration,
    /// Write exchanges (SLOAD included, VF1000 ACK delays included).
    pub writes: Duration,
    /// Verification reads (interleaved ones included).
    pub verify: Duration,
    /// Waiting for the EEPROM beyond what reads filled.
    pub waits: Duration,
    /// Everything; plus the drive's dataset check when [`Plan::dataset`]
    /// (up to [`DATASET_TIMEOUT`], not included).
    pub total: Duration,
}

impl Plan {
    /// Expected duration on `client`'s wire times, following the runner's
    /// schedule: read back the set's codes (`set_codes` of them), the
    /// dataset (SLOAD -1, staged writes, SLOAD -2, one poll), then the other
    /// writes; before an EEPROM write that would wait, verification reads
    /// of earlier writes that fit in the gap, then the rest of the gap;
    /// finally the verification reads left over, and what remains of the
    /// last EEPROM save (the transaction settles only once it is done).
    pub fn estimate(&self, set: &ResolvedSet, client: &dyn DriveClient) -> TimeEstimate {
        let mut est = TimeEstimate::default();
        for k in set.values.keys() {
            est.read_back += client.read_time(*k);
        }
        let mut t = est.read_back;
        let mut pending: std::collections::VecDeque<CodeKey> = Default::default();
        let sload = CodeKey::new(driveset_schema::family::SLOAD.code);
        if self.dataset {
            let mut d = client.write_time(sload);
            for w in self.writes.iter().filter(|w| w.phase == Phase::Dataset) {
                d += client.write_time(w.key);
                pending.push_back(w.key);
            }
            d += client.write_time(sload) + client.read_time(sload);
            est.writes += d;
            t += d;
        }
        let mut busy_until: Option<Duration> = None;
        for w in self.writes.iter().filter(|w| w.phase != Phase::Dataset) {
            if w.storage == Storage::Eeprom
                && let Some(ready) = busy_until
                && ready > t
            {
                while let Some(i) = pending
                    .iter()
                    .position(|k| t + client.read_time(*k) <= ready)
                {
                    if let Some(k) = pending.remove(i) {
                        let r = client.read_time(k);
                        est.verify += r;
                        t += r;
                    }
                }
                est.waits += ready.saturating_sub(t);
                t = t.max(ready);
            }
            let d = client.write_time(w.key) + w.ack_delay;
            est.writes += d;
            t += d;
            if !w.store_time.is_zero() {
                busy_until = Some(t + w.store_time);
            }
            pending.push_back(w.key);
        }
        for k in pending {
            let r = client.read_time(k);
            est.verify += r;
            t += r;
        }
        // the last background EEPROM save, which the transaction waits out
        // before it settles (MC6000/7000, §3)
        if let Some(ready) = busy_until
            && ready > t
        {
            est.waits += ready - t;
            t = ready;
        }
        est.total = t;
        est
    }
}
