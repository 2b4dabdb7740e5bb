//! Upload time against the link's latency, in virtual time (`cargo bench
//! -p driveset-engine --bench latency`).
//!
//! For each serial family (MC6000, VF1000 at 9600 baud, Tmd; the upload
//! benchmark's full sets from `tests/integration/support/campaign_rig.rs`, drives with
//! the spec's minimum reaction of 1 ms) the full upload with verification
//! runs on an in-memory line with an added one-way latency of 0, 5, 16, 40
//! and 100 ms (each way, constant). The table shows the upload's time on
//! the virtual clock next to `bound + N x 2 x latency`: the upload
//! benchmark's lower bound (`support/bound.rs`: the `N` required exchanges
//! at their cheapest, plus the store time that cannot overlap) plus one
//! round trip of latency per required exchange. The ratio shows what the
//! client spends beyond what the latency forces (extra SLOAD polls, the
//! running-motor check, the EOT, waiting for an EEPROM while the latency
//! would have hidden it, and timeouts if any: retries and late replies are
//! printed too).
//!
//! The last column: the upload benchmark's first-principles bound (none
//! can go under it: `upload.rs` docs, "The first-principles bound") plus
//! the same round trips, and the ratio against it (a run under it fails
//! the benchmark).
//!
//! The delay model: a request leaves the host `latency` before it reaches
//! the line (the host's send returns then), and a reply is seen by the host
//! `latency` after it left the drive. ECS (CAN) is not part of it: issue 11
//! is about serial lines.

#[path = "../tests/integration/support/campaign_rig.rs"]
mod rig;

#[path = "support/bound.rs"]
mod bound;

use std::collections::VecDeque;
use std::time::Duration;

use bound::{REACTION, lower_bound, lustbus_upload_bound};
use driveset_engine::client::{DriveClient, LecomClient, LustbusClient};
use driveset_engine::upload::{UploadOptions, prepare, upload};
use driveset_link::{ByteLink, Clock, Instant, LinkError};
use driveset_sim::catalog::{self, Family};
use driveset_sim::drive::ReactionTime;
use driveset_sim::log::EventLog;

/// A byte link with a constant one-way latency each way (module docs):
/// every character the drive sends is seen by the host `one_way` after it
/// arrived at the line's end.
#[derive(Debug)]
struct Delayed<L> {
    inner: L,
    one_way: Duration,
    /// Characters arrived, with the instant the host sees them.
    arrived: VecDeque<(Instant, u8)>,
}

impl<L: ByteLink> ByteLink for Delayed<L> {
    fn port(&self) -> &str {
        self.inner.port()
    }
    fn bus_id(&self) -> String {
        self.inner.bus_id()
    }
    fn baud(&self) -> u32 {
        self.inner.baud()
    }
    fn clock(&self) -> &dyn Clock {
        self.inner.clock()
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.inner.clock().sleep(self.one_way);
        self.inner.send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        loop {
            let now = self.inner.clock().now();
            if self.arrived.front().is_some_and(|(at, _)| *at <= now) {
                let mut n = 0;
                while n < buf.len()
                    && let Some(&(at, byte)) = self.arrived.front()
                    && at <= now
                {
                    buf[n] = byte;
                    n += 1;
                    self.arrived.pop_front();
                }
                return Ok(n);
            }
            let wake = self
                .arrived
                .front()
                .map_or(deadline, |(at, _)| (*at).min(deadline));
            if wake <= now {
                return Ok(0);
            }
            // One character at a time, so each is stamped with its arrival.
            let mut one = [0u8; 1];
            if self.inner.recv(&mut one, wake)? == 1 {
                let at = self.inner.clock().now() + self.one_way;
                self.arrived.push_back((at, one[0]));
            }
        }
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.arrived.clear();
        self.inner.discard_input()
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        self.inner.flush()
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.inner.set_baud(baud)
    }
}

const LATENCIES_MS: [u64; 5] = [0, 5, 16, 40, 100];

fn main() {
    let mut rows = Vec::new();
    for family in [Family::Mc6000, Family::Vf1000, Family::Tmd] {
        let set = rig::full_set(family, 1);
        for ms in LATENCIES_MS {
            let one_way = Duration::from_millis(ms);
            let log = EventLog::memory();
            let rig::Bus::Byte(b) = rig::bus(
                family,
                Some(ReactionTime::fixed(REACTION)),
                7,
                None,
                log.clone(),
            ) else {
                panic!("{} is not a serial family", family.name());
            };
            let link = Delayed {
                inner: b,
                one_way,
                arrived: VecDeque::new(),
            };
            let schema = catalog::schema(family).expect("schema");
            let mut c: Box<dyn DriveClient> = match family {
                Family::Tmd => Box::new(LecomClient::new(link, schema, rig::ADDRESS).expect("c")),
                _ => Box::new(LustbusClient::new(link, schema, rig::ADDRESS).expect("c")),
            };
            let dir = tempfile::tempdir().expect("tempdir");
            let opts = UploadOptions::new(dir.path().join("journal.json"));
            let prepared = prepare(&mut *c, &set, driveset_engine::overrides::Overrides::none())
                .expect("prepare");
            let skip = log.events().len();
            let report = upload(&mut *c, &set, &opts).unwrap_or_else(|f| {
                panic!(
                    "{} at {ms} ms: {f}\n{}",
                    family.name(),
                    f.report.as_ref().map(|r| r.render()).unwrap_or_default()
                )
            });
            let events = log.events();
            let b = lower_bound(family, &set, &prepared, &events[skip..]);
            let round_trips = one_way * 2 * u32::try_from(b.exchanges).expect("count");
            let bound = b.bound + round_trips;
            // the first-principles bound (upload.rs docs) plus the same
            // round trips; none for Tmd
            let principled = matches!(family, Family::Mc6000 | Family::Vf1000).then(|| {
                lustbus_upload_bound(family, &set, &prepared, rig::BAUD, None) + round_trips
            });
            if let Some(p) = principled {
                assert!(
                    report.elapsed >= p,
                    "{} at {ms} ms: {:?} under its first-principles bound {p:?}",
                    family.name(),
                    report.elapsed
                );
            }
            rows.push(format!(
                "| {} | {ms} ms | {} codes, {} written | {:.3} s | {:.3} s + {} x {} ms = {:.3} s | {:.4} | {} | {} | {} | {} | {} |",
                family.name(),
                set.values.len(),
                report.codes_written,
                report.elapsed.as_secs_f64(),
                b.bound.as_secs_f64(),
                b.exchanges,
                2 * ms,
                bound.as_secs_f64(),
                report.elapsed.as_secs_f64() / bound.as_secs_f64(),
                report.telegrams,
                report.retries,
                report.late_replies,
                report.sload_polls.map_or("-".to_string(), |n| n.to_string()),
                principled.map_or("-".to_string(), |p| format!(
                    "{:.3} s = {:.4}",
                    p.as_secs_f64(),
                    report.elapsed.as_secs_f64() / p.as_secs_f64()
                )),
            ));
        }
    }
    println!();
    println!(
        "| family | latency each way | set | time | bound + N x round trip | ratio | telegrams | retries | late replies | SLOAD polls | first-principles bound + N x round trip = ratio |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
}
