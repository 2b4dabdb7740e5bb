//! Seeded campaigns for journals bound to their drive (issue 10): per
//! family, on a simulated bus with two drives of the family (`A`, the
//! target, and its neighbour `B`) and a memory event log:
//!
//! - [`Scenario::OtherAddress`]: an upload to `A` is cut (cable pulled at a
//!   seeded telegram for 600 s); `recover` aimed at `B` is refused
//!   ([`Mismatch::Address`]) with not one byte on the bus; then `recover`
//!   at `A` settles the drive to exactly its old or its new set; where it
//!   is the new set, the drive is power-cycled and must still hold it.
//! - [`Scenario::OtherSpelling`]: the upload goes through
//!   `tcp://127.0.0.1:4001`; `recover` through another bus
//!   (`tcp://127.0.0.1:4002`) is refused ([`Mismatch::Bus`], no byte on
//!   either bus); an upload through `tcp://localhost:4001` (the same bus id)
//!   is refused by the guard (same journal name, no byte); `recover`
//!   through `tcp://localhost:4001` settles the drive.
//! - [`Scenario::Stale`]: after the cut, a later upload of another set is
//!   refused by the guard; forced past it (a journal in another directory,
//!   the old one deleted by nobody) it lands; `recover` of the stale
//!   journal is then refused ([`Mismatch::Stale`]) naming exactly the codes
//!   that hold neither value, with no write telegram, the drive still
//!   holding the later set (MC6000: SLOAD not left at -1).
//! - [`commission_kills`]: a `commission` killed at the first, middle and
//!   last telegram of every phase of a clean run; `status` then reports the
//!   drive failed (no write telegram), an `upload` sees the commission's
//!   journal, and a rerun recovers it: never "unchanged", exit 0, every
//!   journal settled, every drive holding its set, also after a power
//!   cycle.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// A client on a link the test keeps, with the default connect options.
fn client_on(
    link: &mut driveset_link::Link,
    schema: std::sync::Arc<driveset_schema::Schema>,
    address: u8,
) -> Result<Box<dyn driveset_engine::client::DriveClient + '_>, driveset_engine::error::EngineError>
{
    driveset_engine::connect::connect_on(link, schema, address, &Default::default())
}
use driveset_engine::env::{Environment, Memory};
use driveset_engine::error::{EngineError, ErrorKind, InputFailure, Refused};
use driveset_engine::journal::{JournalFile, Mismatch, NotJournalDrive, journal_path};
use driveset_engine::line::commission::{LineOptions, Verdict, commission};
use driveset_engine::line::manifest::{Manifest, load_manifest};
use driveset_engine::line::report::DriveResult;
use driveset_engine::line::status::status;
use driveset_engine::recover::{RecoverAction, RecoverOptions, recover};
use driveset_engine::upload::{UploadOptions, default_journal_path, upload};

/// A line run's world here: a fixed time, files (the resume state) in
/// memory; the journals are real files in the temporary directory.
fn memory_env() -> Arc<dyn Environment> {
    Arc::new(Memory::at(jiff::Timestamp::UNIX_EPOCH))
}
use driveset_link::{ByteLink, CanFrame, Clock, FrameLink, Instant, Link, LinkError, VirtualClock};
use driveset_schema::schema::StorageKind;
use driveset_schema::{CodeKey, RawValue, Registry, ResolvedSet, Schema};
use driveset_sim::catalog::Family;
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::{Dir, Event, EventLog};
use driveset_sim::open::{SimConfig, SimLink, open_sim_with};

use super::campaign_rig as rig;
use driveset_test_support::sim_openers;

/// The scenarios of [`journal_campaign`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Scenario {
    /// `recover --address B` with `A`'s journal.
    OtherAddress,
    /// Another bus, and another spelling of the same bus.
    OtherSpelling,
    /// A journal made stale by a later upload.
    Stale,
}

/// How one run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Outcome {
    /// The cut came before the journal was written (nothing to bind).
    NoJournal,
    /// The refusals held and recover at the right drive restored the old set.
    RefusedThenOld,
    /// The refusals held and recover found the new set complete.
    RefusedThenNew,
    /// Stale: recover refused naming the stale codes; the later set stays.
    RefusedStale,
}

/// The two addresses: the target `A` and its neighbour `B`.
pub fn addresses(family: Family) -> (u8, u8) {
    match family {
        Family::Tmd => (11, 12),
        _ => (1, 2),
    }
}

/// A link under another port spelling and bus id (a `tcp://` device server
/// standing in for the simulated bus).
#[derive(Debug)]
pub struct Spelled<L> {
    pub inner: L,
    pub port: String,
    pub bus: String,
}

impl<L: ByteLink> ByteLink for Spelled<L> {
    fn port(&self) -> &str {
        &self.port
    }
    fn bus_id(&self) -> String {
        self.bus.clone()
    }
    fn baud(&self) -> u32 {
        self.inner.baud()
    }
    fn clock(&self) -> &dyn Clock {
        self.inner.clock()
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.inner.send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        self.inner.recv(buf, deadline)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.inner.discard_input()
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        self.inner.flush()
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.inner.set_baud(baud)
    }
}

impl<L: FrameLink> FrameLink for Spelled<L> {
    fn port(&self) -> &str {
        &self.port
    }
    fn bus_id(&self) -> String {
        self.bus.clone()
    }
    fn bitrate(&self) -> u32 {
        self.inner.bitrate()
    }
    fn clock(&self) -> &dyn Clock {
        self.inner.clock()
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.inner.send(frame)
    }
    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        self.inner.recv(deadline)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.inner.discard_input()
    }
}

/// A simulated bus of two drives with a memory log.
pub struct Bus2 {
    pub sim: SimLink,
    pub log: EventLog,
    pub family: Family,
}

impl Bus2 {
    pub fn new(family: Family, seed: u64, faults: FaultPlan) -> Bus2 {
        let (a, b) = addresses(family);
        let mut config = SimConfig::new(family, vec![a, b]);
        if family == Family::Tmd {
            // C0001 = 3 at the keypad: LECOM may write (manual §4e).
            config.c0001 = Some(3);
        }
        config.seed = seed;
        config.faults = faults;
        let log = EventLog::memory();
        let sim = open_sim_with(&config, &VirtualClock::new(), "sim", log.clone()).expect("sim");
        Bus2 { sim, log, family }
    }

    /// A link to the bus spelled `port`, with bus id `bus`.
    pub fn link(&self, port: &str, bus: &str) -> Link {
        match self.sim.link() {
            Link::Bytes(l) => Link::Bytes(Box::new(Spelled {
                inner: l,
                port: port.into(),
                bus: bus.into(),
            })),
            Link::Frames(l) => Link::Frames(Box::new(Spelled {
                inner: l,
                port: port.into(),
                bus: bus.into(),
            })),
        }
    }

    pub fn state(&self, address: u8) -> ResolvedSet {
        self.sim.state(address).expect("drive")
    }

    pub fn events(&self) -> Vec<Event> {
        self.log.events()
    }

    pub fn sleep(&self, d: Duration) {
        self.sim.clock().sleep(d);
    }
}

/// Whether a host line of the log is a write (LUSTBUS SELECT / LECOM SEND
/// carry STX; an SDO download request has command specifier 0 or 1).
pub fn is_write(family: Family, e: &Event) -> bool {
    if e.dir != Dir::Host {
        return false;
    }
    if family == Family::Ecs {
        let first = e.hex.split(' ').next().unwrap_or("");
        return u8::from_str_radix(first, 16).is_ok_and(|b| b >> 5 <= 1);
    }
    e.text.contains("<STX>")
}

fn traffic(events: &[Event]) -> usize {
    events
        .iter()
        .filter(|e| matches!(e.dir, Dir::Host | Dir::Drive))
        .count()
}

/// The campaign's two sets: the generated full set (step 1) and a later
/// one (step 2), both without RAM values.
pub fn two_sets(family: Family) -> (ResolvedSet, ResolvedSet) {
    let schema = rig::schema(family);
    let strip = |full: ResolvedSet| {
        let mut set = ResolvedSet::new(&schema);
        for (k, v) in &full.values {
            let ram = schema
                .code(k.number)
                .is_some_and(|c| matches!(c.kind, Some(StorageKind::RamControl)));
            if !ram {
                set.insert(*k, v.clone());
            }
        }
        set
    };
    (
        strip(rig::full_set(family, 1)),
        strip(rig::full_set(family, 2)),
    )
}

pub fn fingerprint_over(schema: &Schema, state: &ResolvedSet, set: &ResolvedSet) -> String {
    let mut r = ResolvedSet::new(schema);
    for k in set.values.keys() {
        if let Some(v) = state.values.get(k) {
            r.insert(*k, v.clone());
        }
    }
    r.fingerprint()
}

const PORT: &str = "tcp://127.0.0.1:4001";
const BUS: &str = "tcp:127.0.0.1:4001";
const PORT_LOCALHOST: &str = "tcp://localhost:4001";
const PORT_OTHER: &str = "tcp://127.0.0.1:4002";
const BUS_OTHER: &str = "tcp:127.0.0.1:4002";

/// Telegrams a clean upload of `set` to `A` takes.
fn clean_telegrams(family: Family, set: &ResolvedSet) -> u64 {
    let bus = Bus2::new(family, 0, FaultPlan::default());
    let dir = tempfile::tempdir().expect("tempdir");
    let mut link = bus.link(PORT, BUS);
    let mut c = client_on(&mut link, rig::schema(family), addresses(family).0).expect("client");
    upload(&mut *c, set, &UploadOptions::new(dir.path().join("j.json"))).expect("clean upload");
    bus.events().iter().filter(|e| e.dir == Dir::Host).count() as u64
}

/// Per family and scenario, the outcome counts.
pub type Table = BTreeMap<(Scenario, Outcome), usize>;

/// Run `runs` seeds of every scenario for `family`; panics on the first
/// broken expectation with the seed.
pub fn journal_campaign(family: Family, first: u64, runs: u64) -> Table {
    let schema = rig::schema(family);
    let (set1, set2) = two_sets(family);
    let clean = clean_telegrams(family, &set1);
    let mut table = Table::new();
    for scenario in [
        Scenario::OtherAddress,
        Scenario::OtherSpelling,
        Scenario::Stale,
    ] {
        for seed in first..first + runs {
            // cut in the last four fifths of the upload: mostly mid-write
            let at = clean / 5 + (seed.wrapping_mul(0x9E37_79B9) % (clean - clean / 5).max(1));
            let mut plan = FaultPlan::parse(&format!("cable@{at}+600s")).expect("plan");
            plan.seed = Some(seed);
            let out = one(family, &schema, &set1, &set2, scenario, seed, plan.clone())
                .unwrap_or_else(|why| {
                    panic!(
                        "journal campaign {} {scenario:?} seed {seed} faults `{plan}`: {why}",
                        family.name()
                    )
                });
            *table.entry((scenario, out)).or_default() += 1;
        }
    }
    table
}

fn expect_mismatch(
    r: Result<impl std::fmt::Debug, EngineError>,
    want: &Mismatch,
    message: &str,
) -> Result<(), String> {
    match r {
        Err(e)
            if matches!(
                *e.kind,
                ErrorKind::Refusal(Refused::NotJournalDrive(NotJournalDrive { .. }))
            ) =>
        {
            let ErrorKind::Refusal(Refused::NotJournalDrive(NotJournalDrive { mismatch, .. })) =
                &*e.kind
            else {
                return Err(format!("not a journal refusal: {e}"));
            };
            if mismatch != want {
                return Err(format!("refused with {mismatch:?}, want {want:?}: {e}"));
            }
            if e.to_string() != message {
                return Err(format!("message\n  got:  {e}\n  want: {message}"));
            }
            Ok(())
        }
        other => Err(format!("want a {want:?} refusal, got {other:?}")),
    }
}

fn one(
    family: Family,
    schema: &Arc<Schema>,
    set1: &ResolvedSet,
    set2: &ResolvedSet,
    scenario: Scenario,
    seed: u64,
    plan: FaultPlan,
) -> Result<Outcome, String> {
    let (a, b) = addresses(family);
    let bus = Bus2::new(family, seed, plan);
    let dir = tempfile::tempdir().expect("tempdir");
    let old_a = bus.state(a);
    let old_fp = fingerprint_over(schema, &old_a, set1);
    let new_fp = set1.fingerprint();
    let journal = journal_path(dir.path(), BUS, a);
    let mut link = bus.link(PORT, BUS);
    {
        let mut c = client_on(&mut link, schema.clone(), a).expect("client");
        if default_journal_path(dir.path(), &*c) != journal {
            return Err("the journal name is not the bus id's".into());
        }
        if upload(&mut *c, set1, &UploadOptions::new(&journal)).is_ok() {
            return Err("the cut upload completed".into());
        }
    }
    let unsettled = JournalFile::open(&journal).is_ok_and(|j| !j.journal.state.is_settled());
    if !unsettled {
        if journal.exists() {
            // settled by the upload itself (refused or rolled back before the cut bit)
            let now = fingerprint_over(schema, &bus.state(a), set1);
            if now != old_fp {
                return Err("a settled journal but the drive does not hold its old set".into());
            }
        }
        return Ok(Outcome::NoJournal);
    }
    bus.sleep(Duration::from_secs(700)); // the cable is back
    let jtext = journal.display().to_string();
    match scenario {
        Scenario::OtherAddress => {
            let before = bus.events().len();
            let (sa, sb) = (bus.state(a), bus.state(b));
            {
                let mut c = client_on(&mut link, schema.clone(), b).expect("client");
                expect_mismatch(
                    recover(&mut *c, &journal, &RecoverOptions::default()),
                    &Mismatch::Address,
                    &format!(
                        "{PORT} address {b}: refused to recover journal {jtext}: it belongs to the drive at address {a} on bus `{BUS}`, not the one at address {b}; nothing was sent. Recover at address {a} (leave out --address)"
                    ),
                )?;
            }
            let ev = bus.events();
            if traffic(&ev[before..]) != 0 {
                return Err(format!(
                    "bytes crossed the bus during the refused recover: {:?}",
                    &ev[before..]
                ));
            }
            if bus.state(a) != sa || bus.state(b) != sb {
                return Err("a refused recover changed a drive".into());
            }
        }
        Scenario::OtherSpelling => {
            // another bus with a drive at the same address
            let other = Bus2::new(family, seed, FaultPlan::default());
            let so = other.state(a);
            let mut olink = other.link(PORT_OTHER, BUS_OTHER);
            {
                let mut c = client_on(&mut olink, schema.clone(), a).expect("client");
                expect_mismatch(
                    recover(&mut *c, &journal, &RecoverOptions::default()),
                    &Mismatch::Bus,
                    &format!(
                        "{PORT_OTHER} address {a}: refused to recover journal {jtext}: it belongs to the drive at address {a} on bus `{BUS}` (port {PORT}), but this port reaches bus `{BUS_OTHER}`; nothing was sent. Recover through a port to that bus"
                    ),
                )?;
            }
            if traffic(&other.events()) != 0 || other.state(a) != so {
                return Err("the refused recover touched the other bus".into());
            }
            // the same bus spelled otherwise: the guard sees the journal
            let before = bus.events().len();
            let mut llink = bus.link(PORT_LOCALHOST, BUS);
            {
                let mut c = client_on(&mut llink, schema.clone(), a).expect("client");
                let j2 = default_journal_path(dir.path(), &*c);
                if j2 != journal {
                    return Err(format!(
                        "another spelling names another journal: {}",
                        j2.display()
                    ));
                }
                let state = JournalFile::open(&journal).expect("journal").journal.state;
                match upload(&mut *c, set1, &UploadOptions::new(&j2)) {
                    Err(f) => {
                        let want = format!(
                            "journal {jtext}: the drive at {PORT_LOCALHOST} address {a} has an unfinished transaction ({jtext} (state {})); nothing was sent. Run `driveset recover {jtext}` first",
                            state.as_str()
                        );
                        if !matches!(
                            *f.error.kind,
                            ErrorKind::Input(InputFailure::Journal { .. })
                        ) || f.to_string() != want
                        {
                            return Err(format!("guard\n  got:  {f}\n  want: {want}"));
                        }
                    }
                    Ok(_) => return Err("the guard let an upload through another spelling".into()),
                }
            }
            if traffic(&bus.events()[before..]) != 0 {
                return Err("the guarded upload sent bytes".into());
            }
            link = llink;
        }
        Scenario::Stale => {
            let before = bus.events().len();
            {
                let mut c = client_on(&mut link, schema.clone(), a).expect("client");
                match upload(&mut *c, set2, &UploadOptions::new(&journal)) {
                    Err(f)
                        if matches!(
                            *f.error.kind,
                            ErrorKind::Input(InputFailure::Journal { .. })
                        ) => {}
                    other => {
                        return Err(format!("guard did not block: {:?}", other.map(|r| r.state)));
                    }
                }
            }
            if traffic(&bus.events()[before..]) != 0 {
                return Err("the guarded upload sent bytes".into());
            }
            // forced past the guard, deleting nothing: another journal directory
            let dir2 = tempfile::tempdir().expect("tempdir");
            {
                let mut c = client_on(&mut link, schema.clone(), a).expect("client");
                upload(
                    &mut *c,
                    set2,
                    &UploadOptions::new(dir2.path().join("later.json")),
                )
                .map_err(|f| format!("the later upload failed: {f}"))?;
            }
            let now = bus.state(a);
            let j = JournalFile::open(&journal).expect("journal").journal;
            let old: BTreeMap<CodeKey, RawValue> =
                j.backup_values().expect("backup").into_iter().collect();
            let new: BTreeMap<CodeKey, RawValue> =
                j.new_values().expect("plan").into_iter().collect();
            let mut order: Vec<(CodeKey, String)> = j
                .plan
                .iter()
                .map(|p| {
                    (
                        CodeKey {
                            number: p.number,
                            subcode: p.subcode,
                        },
                        p.code.clone(),
                    )
                })
                .collect();
            for bk in &j.backup {
                let k = CodeKey {
                    number: bk.number,
                    subcode: bk.subcode,
                };
                if !order.iter().any(|(o, _)| *o == k) {
                    order.push((k, bk.code.clone()));
                }
            }
            let stale: Vec<String> = order
                .iter()
                .filter(|(k, _)| {
                    let v = now.values.get(k);
                    v != old.get(k) && v != new.get(k)
                })
                .map(|(_, c)| c.clone())
                .collect();
            if stale.is_empty() {
                return Err("the later set left no planned code stale".into());
            }
            let before = bus.events().len();
            {
                let mut c = client_on(&mut link, schema.clone(), a).expect("client");
                expect_mismatch(
                    recover(&mut *c, &journal, &RecoverOptions::default()),
                    &Mismatch::Stale {
                        codes: stale.clone(),
                    },
                    &format!(
                        "{PORT} address {a}: refused to recover journal {jtext}: {} {} neither the old nor the new value the journal records (written since the transaction was cut); nothing was written. The journal is stale: compare the drive with its set (`driveset diff SET --port ...`), upload the set again if needed, then delete the journal",
                        stale.join(", "),
                        if stale.len() == 1 { "holds" } else { "hold" }
                    ),
                )?;
            }
            let ev = bus.events();
            if let Some(w) = ev[before..].iter().find(|e| is_write(family, e)) {
                return Err(format!("the refused recover wrote: {w:?}"));
            }
            if bus.state(a) != now {
                return Err("the refused recover changed the drive".into());
            }
            if fingerprint_over(schema, &bus.state(a), set2) != set2.fingerprint() {
                return Err("the drive no longer holds the later set".into());
            }
            if family == Family::Mc6000
                && bus.state(a).values.get(&CodeKey::new(80)) == Some(&RawValue::Int(-1))
            {
                return Err("SLOAD left at -1".into());
            }
            return Ok(Outcome::RefusedStale);
        }
    }
    // recover at the right drive settles it
    let mut c = client_on(&mut link, schema.clone(), a).expect("client");
    let mut action = None;
    let mut last = String::new();
    for _ in 0..3 {
        match recover(&mut *c, &journal, &RecoverOptions::default()) {
            Ok(r) => {
                if scenario == Scenario::OtherSpelling && r.target_note.is_none() {
                    return Err("recover through another spelling gave no note".into());
                }
                action = Some(r.action);
                break;
            }
            Err(e) => {
                last = e.to_string();
                c.clock().sleep(Duration::from_secs(90));
            }
        }
    }
    let Some(action) = action else {
        return Err(format!("recover at the right drive failed: {last}"));
    };
    let now = fingerprint_over(schema, &bus.state(a), set1);
    let b_now = bus.state(b);
    drop(c);
    let _ = b_now;
    if now == new_fp {
        // "complete" only for what the drive keeps: power-cycled, it
        // still holds the new set but for its RAM values ([`kept_part`])
        bus.sim.power_cycle(a, Duration::from_millis(1))?;
        let kept = kept_part(schema, set1);
        let now = fingerprint_over(schema, &bus.state(a), &kept);
        if now != kept.fingerprint() {
            return Err(format!(
                "recover did {action:?} and the drive held the new set, but after a power cycle it holds {now} over the codes it keeps (new {}): the set was not stored",
                kept.fingerprint()
            ));
        }
        Ok(Outcome::RefusedThenNew)
    } else if now == old_fp {
        if action == RecoverAction::Completed {
            return Err("completed but the drive holds the old set".into());
        }
        Ok(Outcome::RefusedThenOld)
    } else {
        Err(format!("recover did {action:?} but the drive holds a mix"))
    }
}

/// Render a table as `scenario outcome count` lines.
pub fn render(family: Family, table: &Table) -> String {
    let mut s = String::new();
    for ((sc, out), n) in table {
        let _ = writeln!(s, "journal campaign {} {sc:?} {out:?} {n}", family.name());
    }
    s
}

// ---------------------------------------------------------------------------
// commission killed at every phase
// ---------------------------------------------------------------------------

/// The panic payload of a kill.
struct Killed;

/// A link that dies (panics: the process is gone) before its `kill_at`-th
/// send, counting sends in `count`; with `watch`, records the journal
/// states of the directory before every send (a phase map of a clean run).
#[derive(Debug)]
struct Kill<L> {
    inner: L,
    count: Arc<AtomicU64>,
    kill_at: Option<u64>,
    watch: Option<(PathBuf, Arc<std::sync::Mutex<Vec<String>>>)>,
}

fn phase_of(dir: &Path) -> String {
    let mut phases = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        let mut names: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
        names.sort();
        for p in names {
            if let Ok(j) = JournalFile::open(&p) {
                phases.push(format!(
                    "{}:{}",
                    j.journal.target.address,
                    j.journal.state.as_str()
                ));
            }
        }
    }
    if phases.is_empty() {
        "no-journal".into()
    } else {
        phases.join(",")
    }
}

impl<L> Kill<L> {
    fn before_send(&self) {
        let n = self.count.fetch_add(1, Ordering::SeqCst) + 1;
        if let Some((dir, rec)) = &self.watch {
            rec.lock().unwrap().push(phase_of(dir));
        }
        if self.kill_at == Some(n) {
            std::panic::panic_any(Killed);
        }
    }
}

impl<L: ByteLink> ByteLink for Kill<L> {
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
        self.before_send();
        self.inner.send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        self.inner.recv(buf, deadline)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.inner.discard_input()
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        self.inner.flush()
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.inner.set_baud(baud)
    }
}

impl<L: FrameLink> FrameLink for Kill<L> {
    fn port(&self) -> &str {
        self.inner.port()
    }
    fn bus_id(&self) -> String {
        self.inner.bus_id()
    }
    fn bitrate(&self) -> u32 {
        self.inner.bitrate()
    }
    fn clock(&self) -> &dyn Clock {
        self.inner.clock()
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.before_send();
        self.inner.send(frame)
    }
    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        self.inner.recv(deadline)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.inner.discard_input()
    }
}

fn kill_link(
    sim: &SimLink,
    count: &Arc<AtomicU64>,
    kill_at: Option<u64>,
    watch: Option<(PathBuf, Arc<std::sync::Mutex<Vec<String>>>)>,
) -> Link {
    match sim.link() {
        Link::Bytes(l) => Link::Bytes(Box::new(Kill {
            inner: l,
            count: count.clone(),
            kill_at,
            watch,
        })),
        Link::Frames(l) => Link::Frames(Box::new(Kill {
            inner: l,
            count: count.clone(),
            kill_at,
            watch,
        })),
    }
}

/// A line of one bus: the family's two demo-line drives.
fn line_manifest(family: Family, dir: &Path) -> Manifest {
    let sets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../parameter-sets/demo-line/sets");
    let (port, protocol, rate, names): (&str, &str, &str, [(&str, u8); 2]) = match family {
        Family::Mc6000 => (
            "sim://mc6000",
            "lustbus",
            "baud = 9600",
            [("press-axis-1", 1), ("press-axis-2", 2)],
        ),
        Family::Vf1000 => (
            "sim://vf1000",
            "lustbus",
            "baud = 9600",
            [("conveyor-5", 5), ("conveyor-6", 6)],
        ),
        Family::Tmd => (
            "sim://tmd?c0001=3",
            "lecom",
            "baud = 9600",
            [("transfer-11", 11), ("transfer-12", 12)],
        ),
        Family::Ecs => (
            "sim://ecs",
            "can",
            "bitrate = 500000",
            [("handling-1", 1), ("handling-2", 2)],
        ),
    };
    let mut text = format!(
        "[line]\nname = \"kill-{}\"\n\n[[bus]]\nname = \"bus\"\nport = \"{port}\"\nprotocol = \"{protocol}\"\n{rate}\n",
        family.name()
    );
    for (name, address) in names {
        let _ = write!(
            text,
            "\n[[drive]]\nname = \"{name}\"\nbus = \"bus\"\naddress = {address}\nset = \"{}\"\n",
            sets.join(format!("{name}.toml")).display()
        );
    }
    let path = dir.join("line.toml");
    std::fs::write(&path, text).expect("manifest");
    let mut reg = Registry::builtin().expect("registry");
    let loaded = load_manifest(&path, &mut reg, &sim_openers()).expect("manifest loads");
    assert!(
        loaded.findings.is_empty(),
        "{:?}",
        loaded
            .findings
            .iter()
            .map(|f| f.render_human())
            .collect::<Vec<_>>()
    );
    loaded.manifest.expect("manifest")
}

fn sim_for(m: &Manifest) -> (SimLink, EventLog) {
    let driveset_link::PortSpec::Sim(spec) = &m.buses[0].port else {
        panic!("not a sim port")
    };
    let spec = driveset_sim::port::SimSpec::from_opaque(spec).expect("sim port");
    let mut config = SimConfig::from_spec(&spec).expect("config");
    config.addresses = m.drives.iter().map(|d| d.address).collect();
    let log = EventLog::memory();
    let sim = open_sim_with(
        &config,
        &VirtualClock::new(),
        &m.buses[0].port_name,
        log.clone(),
    )
    .expect("sim");
    (sim, log)
}

/// Counts of the commission-kill scenario: per phase killed in, runs.
pub type KillTable = BTreeMap<String, usize>;

/// Kill a `commission` of `family`'s two-drive line at the first, middle and
/// last telegram of every phase of a clean run, then check `status`, the
/// guard of `upload`, and a rerun (module docs).
pub fn commission_kills(family: Family) -> KillTable {
    let schema = rig::schema(family);
    // the phase map of a clean run
    let base = tempfile::tempdir().expect("tempdir");
    let m = line_manifest(family, base.path());
    let (sim, _) = sim_for(&m);
    let count = Arc::new(AtomicU64::new(0));
    let jdir = base.path().join("journal");
    let rec = Arc::new(std::sync::Mutex::new(Vec::new()));
    let mut opts = LineOptions::new(base.path().join("report"), memory_env());
    opts.journal_dir = jdir.clone();
    let opener = |_: &driveset_engine::line::manifest::Bus| {
        Ok(kill_link(
            &sim,
            &count,
            None,
            Some((jdir.clone(), rec.clone())),
        ))
    };
    let clean = commission(&m, &opts, &opener).expect("clean run");
    assert_eq!(
        clean.verdict(),
        Verdict::Holds,
        "{}: clean commission",
        family.name()
    );
    let phases = rec.lock().unwrap().clone();
    // first, middle, last telegram of every phase
    let mut points: BTreeMap<String, Vec<u64>> = BTreeMap::new();
    for (i, p) in phases.iter().enumerate() {
        points.entry(p.clone()).or_default().push(i as u64 + 1);
    }
    let mut kills: Vec<(String, u64)> = Vec::new();
    for (p, ns) in &points {
        let mut pick = vec![ns[0], ns[ns.len() / 2], ns[ns.len() - 1]];
        pick.dedup();
        for n in pick {
            kills.push((p.clone(), n));
        }
    }
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if info.payload().downcast_ref::<Killed>().is_none()
            && !info
                .payload()
                .downcast_ref::<String>()
                .is_some_and(|s| s.contains("bus thread panicked"))
        {
            prev(info);
        }
    }));
    let mut table = KillTable::new();
    for (phase, n) in kills {
        kill_run(family, &schema, &phase, n).unwrap_or_else(|why| {
            panic!(
                "commission kill {} at telegram {n} ({phase}): {why}",
                family.name()
            )
        });
        *table.entry(phase).or_default() += 1;
    }
    let _ = std::panic::take_hook();
    table
}

fn kill_run(family: Family, schema: &Arc<Schema>, phase: &str, n: u64) -> Result<(), String> {
    let base = tempfile::tempdir().expect("tempdir");
    let m = line_manifest(family, base.path());
    let (sim, log) = sim_for(&m);
    let jdir = base.path().join("journal");
    let mut opts = LineOptions::new(base.path().join("report"), memory_env());
    opts.journal_dir = jdir.clone();
    let count = Arc::new(AtomicU64::new(0));
    let opener =
        |_: &driveset_engine::line::manifest::Bus| Ok(kill_link(&sim, &count, Some(n), None));
    let killed = catch_unwind(AssertUnwindSafe(|| commission(&m, &opts, &opener)));
    if killed.is_ok() {
        return Err("the run was not killed".into());
    }
    // the journals the kill left
    let unfinished: Vec<(u8, PathBuf)> = std::fs::read_dir(&jdir)
        .map(|rd| {
            rd.flatten()
                .filter_map(|e| {
                    let j = JournalFile::open(&e.path()).ok()?;
                    (!j.journal.state.is_settled()).then(|| (j.journal.target.address, e.path()))
                })
                .collect()
        })
        .unwrap_or_default();
    let fresh = Arc::new(AtomicU64::new(0));
    let opener = |_: &driveset_engine::line::manifest::Bus| Ok(kill_link(&sim, &fresh, None, None));
    // status: the drive with an unfinished journal is failed; nothing written
    let before = log.events().len();
    let st = status(&m, &opts, &opener).map_err(|e| e.to_string())?;
    if let Some(w) = log.events()[before..].iter().find(|e| is_write(family, e)) {
        return Err(format!("status wrote: {w:?}"));
    }
    for d in &st.report.drives {
        let open = unfinished.iter().find(|(a, _)| *a == d.address);
        if let Some((_, p)) = open {
            let want_start = format!("journal {}: the drive at ", p.display());
            if d.result != DriveResult::Failed
                || !d.error.as_deref().is_some_and(|e| {
                    e.starts_with(&want_start)
                        && e.ends_with(&format!(
                            "its values are not trusted. Run `driveset commission` (it recovers the journal first) or `driveset recover {}`",
                            p.display()
                        ))
                })
            {
                return Err(format!("status of {}: {:?} {:?}", d.name, d.result, d.error));
            }
        }
    }
    if !unfinished.is_empty() && st.verdict() != Verdict::Differs {
        return Err(format!(
            "status {:?} with an unfinished journal",
            st.verdict()
        ));
    }
    // an upload sees the commission's journal (guard by drive)
    for (a, p) in &unfinished {
        let drive = m.drives.iter().find(|d| d.address == *a).expect("drive");
        let mut link = Bus2 {
            sim: sim.clone(),
            log: log.clone(),
            family,
        }
        .link("tcp://elsewhere:1", &sim_bus_id(&sim));
        let mut c = client_on(&mut link, schema.clone(), *a).expect("client");
        let before = log.events().len();
        match upload(
            &mut *c,
            &drive.set,
            &UploadOptions::new(jdir.join("by-upload.json")),
        ) {
            Err(f)
                if matches!(
                    *f.error.kind,
                    ErrorKind::Input(InputFailure::Journal { .. })
                ) && f.to_string().contains(&p.display().to_string()) => {}
            other => {
                return Err(format!(
                    "upload beside the commission journal: {:?}",
                    other.map(|r| r.state)
                ));
            }
        }
        if traffic(&log.events()[before..]) != 0 {
            return Err("the guarded upload sent bytes".into());
        }
    }
    // rerun: recovers, never "unchanged", exit 0
    let rerun = commission(&m, &opts, &opener).map_err(|e| e.to_string())?;
    if rerun.verdict() != Verdict::Holds {
        return Err(format!(
            "rerun {:?}: {:?}",
            rerun.verdict(),
            rerun
                .report
                .drives
                .iter()
                .map(|d| (&d.name, d.result, &d.error))
                .collect::<Vec<_>>()
        ));
    }
    for d in &rerun.report.drives {
        if unfinished.iter().any(|(a, _)| *a == d.address) {
            if d.result != DriveResult::Verified {
                return Err(format!(
                    "{} with an unfinished journal ended {:?}",
                    d.name, d.result
                ));
            }
            if !rerun
                .warnings
                .iter()
                .any(|w| w.starts_with(&format!("{}: recovered the unfinished journal ", d.name)))
            {
                return Err(format!(
                    "no recovery warning for {}: {:?}",
                    d.name, rerun.warnings
                ));
            }
        }
        let state = sim.state(d.address).expect("drive");
        let drive = m.drives.iter().find(|x| x.name == d.name).expect("drive");
        if fingerprint_over(&drive.schema, &state, &drive.set) != drive.set.fingerprint() {
            return Err(format!("{} does not hold its set after the rerun", d.name));
        }
        // verified only for what the drive keeps: power-cycled, it still
        // holds its set but for its RAM values (a demo conveyor's FSSIO
        // setpoint is an FSEL/ISEL variable, RAM under CSEL = SIO, §11.1:
        // run state the machine's control sets again)
        sim.power_cycle(d.address, Duration::from_millis(1))?;
        let state = sim.state(d.address).expect("drive");
        let kept = kept_part(&drive.schema, &drive.set);
        if fingerprint_over(&drive.schema, &state, &kept) != kept.fingerprint() {
            return Err(format!(
                "{} held its set after the rerun but not after a power cycle: it was not stored",
                d.name
            ));
        }
    }
    for e in std::fs::read_dir(&jdir).expect("journal dir").flatten() {
        if let Ok(j) = JournalFile::open(&e.path())
            && !j.journal.state.is_settled()
        {
            return Err(format!(
                "{} still unfinished after the rerun",
                e.path().display()
            ));
        }
    }
    let _ = phase;
    Ok(())
}

fn sim_bus_id(sim: &SimLink) -> String {
    match sim.link() {
        Link::Bytes(l) => l.bus_id(),
        Link::Frames(l) => l.bus_id(),
    }
}

/// The codes of `set` a drive keeps over a power cycle: all but RAM values
/// and FSEL/ISEL variables (`lustbus-protocol.txt` §11.1, §11.2.1: lost at
/// power down, or RAM under 2-CSEL = SIO).
fn kept_part(schema: &Schema, set: &ResolvedSet) -> ResolvedSet {
    let mut kept = ResolvedSet::new(schema);
    for (k, v) in &set.values {
        let volatile = schema.code(k.number).is_some_and(|c| {
            matches!(
                c.kind,
                Some(StorageKind::RamControl | StorageKind::RamActual | StorageKind::FselIsel)
            )
        });
        if !volatile {
            kept.insert(*k, v.clone());
        }
    }
    kept
}
