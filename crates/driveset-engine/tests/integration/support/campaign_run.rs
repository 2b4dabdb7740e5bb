//! Seeded fault campaigns: many uploads with injected faults (`FaultPlan`),
//! `recover` where the run was cut, and the transaction invariant after
//! each: the drive holds exactly the old set or exactly the new one over the
//! set's codes, and every failure names the target and a cause; after every
//! run that ends complete the drive is power-cycled and must still hold the
//! new set (`[schema.store]`: the ECS demo axes keep writes only once
//! stored).
#![allow(dead_code, clippy::large_enum_variant)]

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::Arc;
use std::time::{Duration, Instant as WallInstant};

use driveset_engine::client::{CanClient, DriveClient, LecomClient, LustbusClient, LustbusOptions};
use driveset_engine::journal::JournalFile;
use driveset_engine::recover::{RecoverAction, RecoverOptions, recover};
use driveset_engine::upload::{UploadOptions, upload};
use driveset_schema::schema::StorageKind;
use driveset_schema::{ResolvedSet, Schema};
use driveset_sim::bus::SimByteBus;
use driveset_sim::can_bus::SimCanBus;
use driveset_sim::catalog::Family;
use driveset_sim::faults::FaultPlan;
use driveset_sim::log::EventLog;

use super::campaign_rig as rig;

/// A client that keeps its concrete bus type, so the drive's state can be
/// read after the run.
enum Rig {
    Lust(LustbusClient<SimByteBus>),
    Lecom(LecomClient<SimByteBus>),
    Can(CanClient<SimCanBus>),
}

impl Rig {
    fn new(family: Family, seed: u64, faults: &FaultPlan) -> Rig {
        // drives keep their default (random, seeded) reaction times here
        let bus = rig::bus(family, None, seed, Some(faults), EventLog::off());
        let schema = rig::schema(family);
        match bus {
            rig::Bus::Byte(b) if family == Family::Tmd => {
                Rig::Lecom(LecomClient::new(b, schema, rig::ADDRESS).expect("client"))
            }
            rig::Bus::Byte(b) => Rig::Lust(
                LustbusClient::with_options(b, schema, rig::ADDRESS, LustbusOptions::default())
                    .expect("client"),
            ),
            rig::Bus::Can(b) => Rig::Can(CanClient::new(b, schema, rig::ADDRESS).expect("client")),
        }
    }

    fn client(&mut self) -> &mut dyn DriveClient {
        match self {
            Rig::Lust(c) => c,
            Rig::Lecom(c) => c,
            Rig::Can(c) => c,
        }
    }

    fn state(&self) -> ResolvedSet {
        match self {
            Rig::Lust(c) => c.link().drives()[0].state(),
            Rig::Lecom(c) => c.link().drives()[0].state(),
            Rig::Can(c) => c.link().drives()[0].state(),
        }
    }

    /// Power off and on again (1 ms off): the drive keeps what its kind of
    /// drive keeps (RAM lost; an ECS's writes lost until stored).
    fn power_cycle(&mut self) {
        let now = self.client().clock().now();
        let off = Duration::from_millis(1);
        match self {
            Rig::Lust(c) => c
                .link_mut()
                .drive_mut(rig::ADDRESS)
                .map(|d| d.power_cycle(now, off)),
            Rig::Lecom(c) => c
                .link_mut()
                .drive_mut(rig::ADDRESS)
                .map(|d| d.power_cycle(now, off)),
            Rig::Can(c) => c
                .link_mut()
                .drive_mut(rig::ADDRESS)
                .map(|d| d.power_cycle(now, off)),
        }
        .expect("the campaign's drive");
    }

    fn telegrams(&self) -> u64 {
        match self {
            Rig::Lust(c) => c.link().line().telegrams(),
            Rig::Lecom(c) => c.link().line().telegrams(),
            Rig::Can(c) => c.link().line().telegrams(),
        }
    }
}

/// How one run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// The upload completed; the drive holds the new set.
    Clean,
    /// The upload failed, reported it, and left the old set (rolled back,
    /// or refused / stopped before the first write).
    FailedReported,
    /// The run was cut; `recover` put the old set back (or found it).
    RecoveredToOld,
    /// The run was cut; `recover` found the new set complete.
    RecoveredToNew,
}

/// The campaign's set for a family: the generated full set without RAM
/// values (volatile: a power cycle after a verified upload resets them to
/// the factory value, which no transaction can prevent) and without
/// FSEL/ISEL variables (RAM or EEPROM by 2-CSEL, `lustbus-protocol.txt`
/// §11.1: the campaign power-cycles after every complete run).
pub fn campaign_set(family: Family) -> ResolvedSet {
    let schema = rig::schema(family);
    let full = rig::full_set(family, 1);
    let mut set = ResolvedSet::new(&schema);
    for (k, v) in &full.values {
        let ram = schema.code(k.number).is_some_and(|c| {
            matches!(
                c.kind,
                Some(StorageKind::RamControl | StorageKind::FselIsel)
            )
        });
        if !ram {
            set.insert(*k, v.clone());
        }
    }
    set
}

fn fingerprint_over(schema: &Schema, state: &ResolvedSet, set: &ResolvedSet) -> String {
    let mut r = ResolvedSet::new(schema);
    for k in set.values.keys() {
        if let Some(v) = state.values.get(k) {
            r.insert(*k, v.clone());
        }
    }
    r.fingerprint()
}

/// splitmix64.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.below(hi - lo + 1)
    }
    fn prob(&mut self, lo_permille: u64, hi_permille: u64) -> String {
        format!("0.{:03}", self.range(lo_permille, hi_permille))
    }
}

/// The fault plan of run `seed`, given how many telegrams a clean upload takes.
pub fn fault_plan(seed: u64, clean_telegrams: u64) -> FaultPlan {
    let mut r = Rng(seed ^ 0xC0FF_EE00_D15E_A5E5);
    let at = |r: &mut Rng| r.range(1, clean_telegrams + 5);
    let text = match r.below(7) {
        0 => format!("flip={}", r.prob(2, 30)),
        1 => format!("lose={}", r.prob(5, 50)),
        2 => format!("power-cycle@{}:off={}ms", at(&mut r), r.range(10, 2000)),
        // shorter than the client's retries
        3 => format!("cable@{}+{}ms", at(&mut r), r.range(5, 80)),
        // longer than the client's retries: the run is cut
        4 => format!("cable@{}+{}ms", at(&mut r), r.range(1000, 60_000)),
        5 => format!(
            "flip={},lose={},truncate={},garbage={},power-cycle@{}:off={}ms",
            r.prob(1, 10),
            r.prob(1, 20),
            r.prob(1, 10),
            r.prob(1, 10),
            at(&mut r),
            r.range(10, 1500)
        ),
        _ => format!(
            "lose={},cable@{}+{}ms",
            r.prob(1, 20),
            at(&mut r),
            r.range(100, 30_000)
        ),
    };
    let mut plan = FaultPlan::parse(&text).expect("fault plan");
    plan.seed = Some(seed);
    plan
}

/// Outcome counts of a campaign.
#[derive(Debug, Default)]
pub struct Summary {
    pub counts: BTreeMap<Kind, usize>,
    pub runs: usize,
    pub recover_calls: usize,
}

impl Summary {
    pub fn render(&self, family: Family, took: Duration) -> String {
        let mut s = format!(
            "campaign {}: {} runs in {:.1} s:",
            family.name(),
            self.runs,
            took.as_secs_f64()
        );
        for (k, n) in &self.counts {
            let name = match k {
                Kind::Clean => "clean",
                Kind::FailedReported => "failed-reported",
                Kind::RecoveredToOld => "recovered-to-old",
                Kind::RecoveredToNew => "recovered-to-new",
            };
            let _ = write!(s, " {name} {n},");
        }
        let _ = write!(s, " recover calls {}", self.recover_calls);
        s
    }
}

/// Run `runs` seeded uploads of `family` starting at seed `first`; panics
/// on the first broken invariant with the seed and the fault plan.
pub fn campaign(family: Family, first: u64, runs: u64) -> Summary {
    let wall = WallInstant::now();
    let schema: Arc<Schema> = rig::schema(family);
    let set = campaign_set(family);
    let new_fp = set.fingerprint();
    let dir = tempfile::tempdir().expect("tempdir");
    // a clean run: how many telegrams an upload takes
    let mut probe = Rig::new(family, first, &FaultPlan::default());
    let old_fp = fingerprint_over(&schema, &probe.state(), &set);
    assert_ne!(old_fp, new_fp, "{}: the set changes nothing", family.name());
    upload(
        probe.client(),
        &set,
        &UploadOptions::new(dir.path().join("probe.json")),
    )
    .unwrap_or_else(|f| panic!("{}: clean upload fails: {f}", family.name()));
    let clean = probe.telegrams();
    let mut summary = Summary::default();
    for seed in first..first + runs {
        let plan = fault_plan(seed, clean);
        let kind = one_run(family, &schema, &set, seed, &plan, dir.path(), &mut summary)
            .unwrap_or_else(|why| {
                panic!(
                    "campaign {} seed {seed} faults `{plan}`: {why}\nreplay: one_run(Family::{:?}, seed {seed}, faults \"{plan}\")",
                    family.name(),
                    family
                )
            });
        *summary.counts.entry(kind).or_default() += 1;
        summary.runs += 1;
    }
    eprintln!("{}", summary.render(family, wall.elapsed()));
    summary
}

/// One seeded run; `Err` says which invariant broke.
pub fn one_run(
    family: Family,
    schema: &Arc<Schema>,
    set: &ResolvedSet,
    seed: u64,
    plan: &FaultPlan,
    dir: &std::path::Path,
    summary: &mut Summary,
) -> Result<Kind, String> {
    let mut rig = Rig::new(family, seed, plan);
    let old_fp = fingerprint_over(schema, &rig.state(), set);
    let new_fp = set.fingerprint();
    let journal = dir.join(format!("{}-{seed}.json", family.name()));
    let _ = std::fs::remove_file(&journal);
    let target = rig.client().target().clone();
    let result = upload(rig.client(), set, &UploadOptions::new(&journal));
    let holds = |rig: &Rig| fingerprint_over(schema, &rig.state(), set);
    let kind = match result {
        Ok(report) => {
            let now = holds(&rig);
            if now != new_fp {
                return Err(format!(
                    "upload reported {} but the drive holds {} (new {new_fp}, old {old_fp})\n{}",
                    report.state.as_str(),
                    now,
                    report.render()
                ));
            }
            Kind::Clean
        }
        Err(failure) => {
            let msg = failure.to_string();
            let port = target.port.clone();
            if msg.trim().is_empty()
                || !msg.contains(&port)
                || msg.len() < target.to_string().len() + 12
            {
                return Err(format!(
                    "failure not reported with target and cause: `{msg}`"
                ));
            }
            let unsettled = journal.exists()
                && JournalFile::open(&journal)
                    .map(|j| !j.journal.state.is_settled())
                    .unwrap_or(true);
            if !unsettled {
                let now = holds(&rig);
                if now != old_fp && now != new_fp {
                    return Err(format!(
                        "upload failed (`{msg}`) with a settled journal but the drive holds a mix ({now}; old {old_fp}, new {new_fp})"
                    ));
                }
                if now == new_fp {
                    return Err(format!(
                        "upload failed (`{msg}`) but the drive holds the new set"
                    ));
                }
                Kind::FailedReported
            } else {
                // later, the cable is back / the operator runs recover
                let mut last = String::new();
                let mut action = None;
                for _ in 0..5 {
                    rig.client().clock().sleep(Duration::from_secs(90));
                    summary.recover_calls += 1;
                    match recover(rig.client(), &journal, &RecoverOptions::default()) {
                        Ok(r) => {
                            action = Some(r.action);
                            break;
                        }
                        Err(e) => {
                            let t = e.to_string();
                            if t.trim().is_empty() || !t.contains(&port) && !t.contains("journal") {
                                return Err(format!("recover failed without a cause: `{t}`"));
                            }
                            last = t;
                        }
                    }
                }
                let Some(action) = action else {
                    return Err(format!(
                        "upload failed (`{msg}`), recover failed 5 times, last: {last}"
                    ));
                };
                let now = holds(&rig);
                if now == new_fp {
                    Kind::RecoveredToNew
                } else if now == old_fp {
                    if action == RecoverAction::Completed {
                        return Err("recover said completed but the drive holds the old set".into());
                    }
                    Kind::RecoveredToOld
                } else {
                    return Err(format!(
                        "upload failed (`{msg}`), recover did {action:?}, the drive holds a mix ({now}; old {old_fp}, new {new_fp})"
                    ));
                }
            }
        }
    };
    // "complete" only for what the drive keeps: power-cycled, it still
    // holds the new set
    if matches!(kind, Kind::Clean | Kind::RecoveredToNew) {
        rig.power_cycle();
        let now = holds(&rig);
        if now != new_fp {
            return Err(format!(
                "{kind:?}, but after a power cycle the drive holds {now} (new {new_fp}, old {old_fp}): the set was not stored"
            ));
        }
    }
    Ok(kind)
}
