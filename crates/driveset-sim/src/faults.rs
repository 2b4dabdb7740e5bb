//! Fault injection: owns [`FaultPlan`] (what can go wrong on a simulated
//! bus, parsed from and printed as the `--faults` / `sim://...?faults=`
//! string) and [`FaultInjector`] (the seeded state that decides, telegram by
//! telegram, which fault happens).
//!
//! # The fault string
//!
//! Items separated by `,` (blanks around items are ignored; an empty string
//! is "no faults"):
//!
//! ```text
//! flip=P          per host telegram: one character of it arrives at the drives
//!                 with one bit flipped and a parity error; per reply: one bit of
//!                 one reply character flipped (the host sees a wrong character)
//! lose=P          per reply: the reply never reaches the host
//! truncate=P      per reply: only its first k characters arrive (0 <= k < len)
//! garbage=P       per host telegram: 1..=3 noise characters reach the host right
//!                 after its telegram (before any reply)
//! power-cycle@W[:addr=A][:off=D]
//!                 power cut of drive A (default: every drive) at W, back after
//!                 D (default 500ms)
//! cable@W+D       cable pulled at W for D: nothing crosses in either direction
//! seed=N          seed of the fault generator (default: the run's seed)
//! ```
//!
//! `P` is a probability `0..=1` (`0.01`). `W` is either a host telegram
//! number `N` (1-based: the event happens at the end of the N-th host
//! telegram, after the drives heard it, so a reply to it is lost), or a
//! duration since the bus started (`1500ms`, `2s`). Durations are an integer
//! followed by `ns`, `us`, `ms` or `s`. [`FaultPlan`]'s `Display` prints the
//! canonical form: rates in the order above (zero rates left out), events in
//! the given order, then the seed; default options are left out.
//!
//! On a CAN bus (`crate::can_bus`) `flip` means an error frame and an
//! automatic retransmission (what a CAN controller does with a corrupted
//! frame), `lose` a node that does not answer; `truncate` and `garbage` do
//! not apply there.
//!
//! # Reproducibility
//!
//! Every decision comes from one [`SimRng`] seeded from the plan's `seed`
//! (or the run's seed), drawn in a fixed order per host telegram and per
//! reply, so the same seed and the same host traffic give the same faults.

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

use crate::rng::SimRng;

/// The component number the fault generator derives its stream from.
const FAULT_COMPONENT: u64 = 0xFA17;

/// Default off time of a power cycle.
pub const DEFAULT_OFF: Duration = Duration::from_millis(500);

/// The keys the fault string knows, for error messages.
pub const FAULT_KEYS: &str = "flip=P, lose=P, truncate=P, garbage=P, power-cycle@N[:addr=A][:off=D], cable@N+D, seed=N (N a host telegram number or a time like 1500ms, D a duration like 500ms)";

/// When a scheduled event happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trigger {
    /// At the end of the N-th host telegram (1-based).
    Telegram(u64),
    /// This long after the bus started.
    Time(Duration),
}

/// What a scheduled event does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Power cut of one drive (`Some(address)`) or all of them.
    PowerCycle {
        /// The drive's bus address (node id on CAN), or every drive.
        addr: Option<u8>,
        /// How long the power stays off.
        off: Duration,
    },
    /// The cable is pulled for this long.
    Cable {
        /// How long nothing crosses.
        duration: Duration,
    },
}

/// One scheduled fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scheduled {
    /// When.
    pub at: Trigger,
    /// What.
    pub action: Action,
}

/// What can go wrong on a simulated bus, and with which seed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FaultPlan {
    /// Probability per host telegram and per reply of a flipped bit.
    pub flip: f64,
    /// Probability per reply that it is lost.
    pub lose: f64,
    /// Probability per reply that it is cut short.
    pub truncate: f64,
    /// Probability per host telegram of noise characters towards the host.
    pub garbage: f64,
    /// Scheduled events, in the order given.
    pub events: Vec<Scheduled>,
    /// Seed of the fault generator; `None` takes the run's seed.
    pub seed: Option<u64>,
}

/// A fault string that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("invalid fault item `{item}`: {reason}; valid items: {FAULT_KEYS}")]
pub struct FaultParseError {
    /// The offending item, as given.
    pub item: String,
    /// What is wrong with it.
    pub reason: String,
}

fn bad(item: &str, reason: impl Into<String>) -> FaultParseError {
    FaultParseError {
        item: item.to_string(),
        reason: reason.into(),
    }
}

/// Parse a duration: an integer followed by `ns`, `us`, `ms` or `s`.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let s = s.trim();
    let split = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
    let (num, unit) = s.split_at(split);
    if num.is_empty() {
        return Err(format!(
            "`{s}` is not a duration: give an integer with a unit (500ms, 2s)"
        ));
    }
    let n: u64 = num
        .parse()
        .map_err(|_| format!("`{num}` is too large for a duration"))?;
    let d = match unit {
        "ns" => Some(Duration::from_nanos(n)),
        "us" => n.checked_mul(1_000).map(Duration::from_nanos),
        "ms" => Some(Duration::from_millis(n)),
        "s" => Some(Duration::from_secs(n)),
        "" => {
            return Err(format!(
                "`{s}` has no unit: write {s}ms or {s}s (units: ns, us, ms, s)"
            ));
        }
        other => {
            return Err(format!(
                "unknown time unit `{other}` in `{s}`: use ns, us, ms or s"
            ));
        }
    };
    d.ok_or_else(|| format!("`{s}` is too large for a duration"))
}

/// Print a duration in the largest unit that keeps it exact.
pub fn format_duration(d: Duration) -> String {
    let ns = d.as_nanos();
    if ns == 0 {
        "0ms".into()
    } else if ns.is_multiple_of(1_000_000_000) {
        format!("{}s", ns / 1_000_000_000)
    } else if ns.is_multiple_of(1_000_000) {
        format!("{}ms", ns / 1_000_000)
    } else if ns.is_multiple_of(1_000) {
        format!("{}us", ns / 1_000)
    } else {
        format!("{ns}ns")
    }
}

fn parse_trigger(item: &str, s: &str) -> Result<Trigger, FaultParseError> {
    let s = s.trim();
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) {
        let n: u64 = s
            .parse()
            .map_err(|_| bad(item, format!("telegram number `{s}` is too large")))?;
        if n == 0 {
            return Err(bad(item, "host telegrams count from 1: use @1 or later"));
        }
        return Ok(Trigger::Telegram(n));
    }
    parse_duration(s).map(Trigger::Time).map_err(|e| {
        bad(
            item,
            format!("after `@` give a host telegram number (120) or a time (1500ms): {e}"),
        )
    })
}

fn format_trigger(t: Trigger) -> String {
    match t {
        Trigger::Telegram(n) => n.to_string(),
        Trigger::Time(d) => format_duration(d),
    }
}

fn parse_probability(item: &str, v: &str) -> Result<f64, FaultParseError> {
    let p: f64 = v.trim().parse().map_err(|_| {
        bad(
            item,
            format!("`{v}` is not a number: give a probability like 0.01"),
        )
    })?;
    if !p.is_finite() || !(0.0..=1.0).contains(&p) {
        return Err(bad(item, format!("probability {v} is outside 0..=1")));
    }
    Ok(p)
}

impl FromStr for FaultPlan {
    type Err = FaultParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut plan = FaultPlan::default();
        for raw in s.split(',') {
            let item = raw.trim();
            if item.is_empty() {
                if s.trim().is_empty() {
                    continue;
                }
                return Err(bad(
                    item,
                    "empty item (two commas in a row, or a trailing comma)",
                ));
            }
            if let Some(rest) = item.strip_prefix("power-cycle@") {
                let mut parts = rest.split(':');
                let at = parse_trigger(item, parts.next().unwrap_or(""))?;
                let mut addr = None;
                let mut off = DEFAULT_OFF;
                for opt in parts {
                    match opt.split_once('=') {
                        Some(("addr", v)) => {
                            addr = Some(v.trim().parse::<u8>().map_err(|_| {
                                bad(item, format!("address `{v}` is not a number 0..=255"))
                            })?);
                        }
                        Some(("off", v)) => {
                            off = parse_duration(v).map_err(|e| bad(item, e))?;
                        }
                        _ => {
                            return Err(bad(
                                item,
                                format!("unknown power-cycle option `{opt}`: use addr=A or off=D"),
                            ));
                        }
                    }
                }
                plan.events.push(Scheduled {
                    at,
                    action: Action::PowerCycle { addr, off },
                });
                continue;
            }
            if let Some(rest) = item.strip_prefix("cable@") {
                let Some((when, dur)) = rest.split_once('+') else {
                    return Err(bad(item, "a pulled cable needs a duration: cable@N+500ms"));
                };
                let at = parse_trigger(item, when)?;
                let duration = parse_duration(dur).map_err(|e| bad(item, e))?;
                plan.events.push(Scheduled {
                    at,
                    action: Action::Cable { duration },
                });
                continue;
            }
            let Some((key, value)) = item.split_once('=') else {
                return Err(bad(item, "unknown item"));
            };
            match key.trim() {
                "flip" => plan.flip = parse_probability(item, value)?,
                "lose" => plan.lose = parse_probability(item, value)?,
                "truncate" => plan.truncate = parse_probability(item, value)?,
                "garbage" => plan.garbage = parse_probability(item, value)?,
                "seed" => {
                    plan.seed = Some(value.trim().parse().map_err(|_| {
                        bad(
                            item,
                            format!("seed `{value}` is not an unsigned 64-bit integer"),
                        )
                    })?);
                }
                other => return Err(bad(item, format!("unknown key `{other}`"))),
            }
        }
        Ok(plan)
    }
}

impl fmt::Display for FaultPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut items: Vec<String> = Vec::new();
        for (key, p) in [
            ("flip", self.flip),
            ("lose", self.lose),
            ("truncate", self.truncate),
            ("garbage", self.garbage),
        ] {
            if p != 0.0 {
                items.push(format!("{key}={p}"));
            }
        }
        for e in &self.events {
            match e.action {
                Action::PowerCycle { addr, off } => {
                    let mut s = format!("power-cycle@{}", format_trigger(e.at));
                    if let Some(a) = addr {
                        s.push_str(&format!(":addr={a}"));
                    }
                    if off != DEFAULT_OFF {
                        s.push_str(&format!(":off={}", format_duration(off)));
                    }
                    items.push(s);
                }
                Action::Cable { duration } => items.push(format!(
                    "cable@{}+{}",
                    format_trigger(e.at),
                    format_duration(duration)
                )),
            }
        }
        if let Some(seed) = self.seed {
            items.push(format!("seed={seed}"));
        }
        f.write_str(&items.join(","))
    }
}

impl FaultPlan {
    /// No faults at all.
    pub fn none() -> Self {
        FaultPlan::default()
    }

    /// Parse a fault string (see the module docs).
    pub fn parse(s: &str) -> Result<Self, FaultParseError> {
        s.parse()
    }

    /// Whether the plan injects nothing.
    pub fn is_empty(&self) -> bool {
        self.flip == 0.0
            && self.lose == 0.0
            && self.truncate == 0.0
            && self.garbage == 0.0
            && self.events.is_empty()
    }
}

/// A flipped bit: which character of a telegram and which bit (0..=6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Flip {
    /// Index of the character in the telegram / reply.
    pub index: usize,
    /// Bit number 0..=6.
    pub bit: u8,
}

/// What happens to one reply on its way to the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplyFault {
    /// Arrives intact.
    None,
    /// Never arrives.
    Lose,
    /// Only the first `keep` characters arrive.
    Truncate {
        /// Characters that arrive.
        keep: usize,
    },
    /// One bit of one character is flipped.
    Flip(Flip),
}

/// The seeded decision maker of a [`FaultPlan`]: one per bus.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    plan: FaultPlan,
    rng: SimRng,
}

impl FaultInjector {
    /// The injector for `plan`, seeded from the plan's seed or else
    /// `run_seed`.
    pub fn new(plan: FaultPlan, run_seed: u64) -> Self {
        let seed = plan.seed.unwrap_or(run_seed);
        FaultInjector {
            plan,
            rng: SimRng::derive(seed, FAULT_COMPONENT),
        }
    }

    /// An injector that never injects anything.
    pub fn none() -> Self {
        FaultInjector::new(FaultPlan::none(), 0)
    }

    /// The plan.
    pub fn plan(&self) -> &FaultPlan {
        &self.plan
    }

    fn pick_flip(&mut self, len: usize) -> Flip {
        let last = u64::try_from(len.saturating_sub(1)).unwrap_or(u64::MAX);
        let index = usize::try_from(self.rng.range_u64(0, last)).unwrap_or(0);
        let bit = self.rng.range_u64(0, 6) as u8;
        Flip { index, bit }
    }

    /// Decide on a host telegram of `len` characters: a flipped character
    /// on its way to the drives, or none.
    pub fn host_flip(&mut self, len: usize) -> Option<Flip> {
        if len == 0 || !self.rng.chance(self.plan.flip) {
            return None;
        }
        Some(self.pick_flip(len))
    }

    /// Decide whether noise reaches the host after a host telegram: 1..=3
    /// random 7-bit characters.
    pub fn garbage(&mut self) -> Option<Vec<u8>> {
        if !self.rng.chance(self.plan.garbage) {
            return None;
        }
        let n = self.rng.range_u64(1, 3);
        Some((0..n).map(|_| self.rng.range_u64(0, 0x7F) as u8).collect())
    }

    /// Decide what happens to a reply of `len` characters (lose, then
    /// truncate, then flip are drawn in that order; the first that happens
    /// wins).
    pub fn reply(&mut self, len: usize) -> ReplyFault {
        if len == 0 {
            return ReplyFault::None;
        }
        if self.rng.chance(self.plan.lose) {
            return ReplyFault::Lose;
        }
        if self.rng.chance(self.plan.truncate) {
            let keep = usize::try_from(
                self.rng
                    .range_u64(0, u64::try_from(len - 1).unwrap_or(u64::MAX)),
            )
            .unwrap_or(0);
            return ReplyFault::Truncate { keep };
        }
        if self.rng.chance(self.plan.flip) {
            return ReplyFault::Flip(self.pick_flip(len));
        }
        ReplyFault::None
    }

    /// Decide whether a CAN frame is hit by a flipped bit (error frame and
    /// retransmission).
    pub fn frame_flip(&mut self) -> bool {
        self.rng.chance(self.plan.flip)
    }

    /// Decide whether a CAN reply is lost.
    pub fn frame_lose(&mut self) -> bool {
        self.rng.chance(self.plan.lose)
    }
}

/// The scheduled events of a plan, with what has fired: shared by the byte
/// and CAN buses.
#[derive(Debug, Clone, Default)]
pub struct Schedule {
    pending: Vec<Scheduled>,
}

impl Schedule {
    /// The events of `plan`, none fired yet.
    pub fn new(plan: &FaultPlan) -> Self {
        Schedule {
            pending: plan.events.clone(),
        }
    }

    /// Take the events triggered by host telegram number `n`.
    pub fn take_telegram(&mut self, n: u64) -> Vec<Scheduled> {
        let (hit, rest) = self
            .pending
            .drain(..)
            .partition(|e| e.at == Trigger::Telegram(n));
        self.pending = rest;
        hit
    }

    /// The earliest time-triggered event still pending, as an offset from
    /// the bus start.
    pub fn next_time(&self) -> Option<Duration> {
        self.pending
            .iter()
            .filter_map(|e| match e.at {
                Trigger::Time(d) => Some(d),
                Trigger::Telegram(_) => None,
            })
            .min()
    }

    /// Take the time-triggered events due at `elapsed` since the bus start
    /// (offset `<= elapsed`), earliest first (ties in the given order).
    pub fn take_due(&mut self, elapsed: Duration) -> Vec<Scheduled> {
        let (mut hit, rest): (Vec<_>, Vec<_>) = self
            .pending
            .drain(..)
            .partition(|e| matches!(e.at, Trigger::Time(d) if d <= elapsed));
        self.pending = rest;
        hit.sort_by_key(|e| match e.at {
            Trigger::Time(d) => d,
            Trigger::Telegram(_) => Duration::ZERO,
        });
        hit
    }
}

/// Windows of a pulled cable on a bus: `[from, until)` on the bus clock.
#[derive(Debug, Clone, Default)]
pub struct CableWindows {
    windows: Vec<(driveset_link::Instant, driveset_link::Instant)>,
}

impl CableWindows {
    /// Add a window.
    pub fn pull(&mut self, from: driveset_link::Instant, until: driveset_link::Instant) {
        self.windows.push((from, until));
    }

    /// Pull the cable at `at` for `duration` (a scheduled `cable@...` fault)
    /// and log it; returns when it is plugged back. The caller drops what is
    /// in flight in `at..until`.
    pub fn pull_logged(
        &mut self,
        at: driveset_link::Instant,
        duration: std::time::Duration,
        log: &crate::log::EventLog,
    ) -> driveset_link::Instant {
        let until = at + duration;
        self.pull(at, until);
        log.push(crate::log::Event::note(
            at.as_nanos(),
            None,
            "cable-pulled",
            format!(
                "nothing crosses for {}, until t_ns={}",
                format_duration(duration),
                until.as_nanos()
            ),
        ));
        until
    }

    /// Whether the cable is out at `t`.
    pub fn down(&self, t: driveset_link::Instant) -> bool {
        self.windows.iter().any(|&(a, b)| a <= t && t < b)
    }
}
