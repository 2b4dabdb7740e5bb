//! An in-memory fake [`DriveClient`] for the transaction tests: a
//! `BTreeMap` drive, a virtual clock, fixed wire times, MC6000-like EEPROM
//! busy times and SLOAD staging, scripted failures, an operation log and
//! snapshots (drive + journal file) before every mutating operation, so a
//! crash can be simulated at every point.
#![allow(dead_code)]

pub mod schemas;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{
    ClientStats, DatasetDownload, DatasetOutcome, DriveClient, IdentCode, IdentProtocol,
    IdentValue, Identity, Target,
};
use driveset_engine::error::{DeviceCause, EngineError, SiofRegister, SiofVerdict};
use driveset_engine::guard::Permit;
use driveset_proto::lustbus::Siof;

/// An MC6000 refusal with these SERR bits (section 9.2).
fn serr(bits: Siof) -> DeviceCause {
    DeviceCause::Siof {
        register: SiofRegister::Serr,
        bits,
        verdict: SiofVerdict::Failed,
    }
}
use driveset_link::{Clock, Instant, VirtualClock};
use driveset_schema::error::SourceFile;
use driveset_schema::schema::StorageKind;
use driveset_schema::{CodeKey, Family, RawValue, Registry, ResolvedSet, Schema};

pub fn schema(text: &str) -> Arc<Schema> {
    let mut r = Registry::new();
    r.add_source(SourceFile::new("fixture.toml", text))
        .expect("fixture schema parses")
}

pub fn mc_schema() -> Arc<Schema> {
    schema(schemas::MC)
}

pub fn tmd_schema() -> Arc<Schema> {
    schema(schemas::TMD)
}

/// The drive's state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Drive {
    pub values: BTreeMap<CodeKey, RawValue>,
    /// MC dataset download in progress: staged CardWriteable values.
    pub staged: Option<BTreeMap<CodeKey, RawValue>>,
    pub running: Option<bool>,
    pub identity: Identity,
    /// Codes the drive says do not exist.
    pub missing: BTreeSet<CodeKey>,
    /// The drive rejects the next dataset at this parameter.
    pub reject_dataset_at: Option<u32>,
    /// Writes of this code are ACKed but not taken.
    pub ignore_writes_to: Option<CodeKey>,
}

impl Drive {
    pub fn new(family: Family, values: impl IntoIterator<Item = (CodeKey, RawValue)>) -> Self {
        Drive {
            values: values.into_iter().collect(),
            staged: None,
            running: Some(false),
            identity: Identity {
                protocol: IdentProtocol::Family(family),
                codes: vec![IdentCode::new(
                    CodeKey::new(91),
                    "91 TYPE",
                    IdentValue::Int(4711),
                )],
                software: None,
            },
            missing: BTreeSet::new(),
            reject_dataset_at: None,
            ignore_writes_to: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Op {
    Identify,
    Running,
    Read(CodeKey),
    Write(CodeKey, RawValue),
    Begin,
    Commit,
}

#[derive(Debug, Clone)]
pub struct Snapshot {
    pub drive: Drive,
    pub journal: Option<Vec<u8>>,
    pub op: Op,
}

pub struct FakeClient {
    pub target: Target,
    pub schema: Arc<Schema>,
    pub clock: VirtualClock,
    pub drive: Drive,
    /// (instant in ns, op) for every operation that reached the drive.
    pub log: Vec<(u64, Op)>,
    pub read_time: Duration,
    pub write_time: Duration,
    /// MC EEPROM store time per byte (zero: no busy time).
    pub store_per_byte: Duration,
    pub dataset: bool,
    pub busy_until: Instant,
    /// Journal to inspect at the first write and to snapshot.
    pub journal: Option<PathBuf>,
    /// The journal's state and backup size as seen at the first write.
    pub journal_at_first_write: Option<(String, usize, usize)>,
    pub snapshots: Vec<Snapshot>,
    /// The n-th write (1-based, counted over the client's life) fails with a device error.
    pub fail_write: Option<usize>,
    /// Further writes (1-based) that fail with a device error.
    pub also_fail_writes: Vec<usize>,
    /// After this many writes every operation fails (cable pulled).
    pub dead_after_writes: Option<usize>,
    /// The n-th writes (1-based) find the drive restarted.
    pub restart_at_writes: Vec<usize>,
    pub writes: usize,
    pub stats: ClientStats,
}

impl FakeClient {
    pub fn new(schema: Arc<Schema>, drive: Drive) -> Self {
        let mc = schema.family == driveset_schema::Family::Mc6000;
        FakeClient {
            target: Target {
                port: "fake0".into(),
                address: 1,
            },
            schema,
            clock: VirtualClock::new(),
            drive,
            log: Vec::new(),
            read_time: Duration::from_millis(10),
            write_time: Duration::from_millis(20),
            store_per_byte: if mc {
                Duration::from_millis(15)
            } else {
                Duration::ZERO
            },
            dataset: mc,
            busy_until: Instant::ZERO,
            journal: None,
            journal_at_first_write: None,
            snapshots: Vec::new(),
            fail_write: None,
            also_fail_writes: Vec::new(),
            dead_after_writes: None,
            restart_at_writes: Vec::new(),
            writes: 0,
            stats: ClientStats::default(),
        }
    }

    pub fn with_journal(mut self, path: &Path) -> Self {
        self.journal = Some(path.to_path_buf());
        self
    }

    fn now(&self) -> u64 {
        self.clock.now().as_nanos()
    }

    fn dead(&self) -> bool {
        self.dead_after_writes.is_some_and(|n| self.writes >= n)
    }

    fn no_answer(&self, what: String) -> EngineError {
        EngineError::no_answer(self.target.clone(), what, 3)
    }

    fn snapshot(&mut self, op: Op) {
        let journal = self.journal.as_ref().and_then(|p| std::fs::read(p).ok());
        self.snapshots.push(Snapshot {
            drive: self.drive.clone(),
            journal,
            op,
        });
    }

    fn is_eeprom(&self, key: CodeKey) -> Option<u8> {
        let c = self.schema.code(key.number)?;
        (c.kind == Some(StorageKind::Eeprom)).then_some(c.width.unwrap_or(4))
    }

    fn is_cw(&self, key: CodeKey) -> bool {
        self.schema
            .code(key.number)
            .is_some_and(|c| c.card_writeable == Some(true))
    }

    pub fn writes_logged(&self) -> Vec<CodeKey> {
        self.log
            .iter()
            .filter_map(|(_, o)| match o {
                Op::Write(k, _) => Some(*k),
                _ => None,
            })
            .collect()
    }

    /// The operations that changed or could change the drive, in order:
    /// the log without its reads, identifies and running checks.
    pub fn changes_logged(&self) -> Vec<Op> {
        self.log
            .iter()
            .map(|(_, o)| o.clone())
            .filter(|o| !matches!(o, Op::Read(_) | Op::Identify | Op::Running))
            .collect()
    }

    pub fn values_of(&self, keys: impl IntoIterator<Item = CodeKey>) -> ResolvedSet {
        let mut s = ResolvedSet::new(&self.schema);
        for k in keys {
            if let Some(v) = self.drive.values.get(&k) {
                s.insert(k, v.clone());
            }
        }
        s
    }
}

impl DriveClient for FakeClient {
    fn target(&self) -> &Target {
        &self.target
    }
    fn bus_id(&self) -> String {
        format!("fake:{}", self.target.port)
    }
    fn schema(&self) -> &Arc<Schema> {
        &self.schema
    }
    fn clock(&self) -> &dyn Clock {
        &self.clock
    }
    fn identify(&mut self) -> Result<Identity, EngineError> {
        if self.dead() {
            return Err(self.no_answer("identify".into()));
        }
        self.log.push((self.now(), Op::Identify));
        Ok(self.drive.identity.clone())
    }
    fn read(&mut self, key: CodeKey) -> Result<RawValue, EngineError> {
        if self.dead() {
            return Err(self.no_answer(format!("read {}", key.number)));
        }
        self.stats.telegrams += 1;
        self.log.push((self.now(), Op::Read(key)));
        self.clock.sleep(self.read_time);
        if key.number == 80 && self.dataset {
            return Ok(RawValue::Int(if self.drive.staged.is_some() {
                -1
            } else {
                0
            }));
        }
        if self.drive.missing.contains(&key) {
            return Err(EngineError::device(
                self.target.clone(),
                format!("read {}", key.number),
                serr(Siof::NO_PARAMETER),
            ));
        }
        self.drive
            .values
            .get(&key)
            .cloned()
            .ok_or_else(|| self.no_answer(format!("read {} (not in the fake)", key.number)))
    }
    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        _permit: Permit,
    ) -> Result<(), EngineError> {
        if self.writes == 0
            && let Some(p) = &self.journal
        {
            let seen = std::fs::read_to_string(p).ok().and_then(|t| {
                let v: serde_json::Value = serde_json::from_str(&t).ok()?;
                Some((
                    v["state"].as_str()?.to_string(),
                    v["backup"].as_array()?.len(),
                    v["plan"].as_array()?.len(),
                ))
            });
            self.journal_at_first_write = Some(seen.unwrap_or(("missing".into(), 0, 0)));
        }
        self.snapshot(Op::Write(key, raw.clone()));
        if self.dead() {
            return Err(self.no_answer(format!("write {}", key.number)));
        }
        self.writes += 1;
        self.stats.telegrams += 1;
        if self.restart_at_writes.contains(&self.writes) {
            self.drive.staged = None;
            return Err(EngineError::restarted(
                self.target.clone(),
                format!("write {}", key.number),
            ));
        }
        if self.fail_write == Some(self.writes) || self.also_fail_writes.contains(&self.writes) {
            self.log.push((self.now(), Op::Write(key, raw.clone())));
            self.clock.sleep(self.write_time);
            return Err(EngineError::device(
                self.target.clone(),
                format!("write {}", key.number),
                serr(Siof::INVALID_VALUE),
            ));
        }
        // the client waits itself if the EEPROM is busy
        if self.is_eeprom(key).is_some() && self.drive.staged.is_none() {
            self.clock.sleep_until(self.busy_until);
        }
        self.log.push((self.now(), Op::Write(key, raw.clone())));
        self.clock.sleep(self.write_time);
        if self.drive.ignore_writes_to == Some(key) {
            return Ok(());
        }
        if let Some(staged) = &mut self.drive.staged {
            let cw = self
                .schema
                .code(key.number)
                .is_some_and(|c| c.card_writeable == Some(true));
            if cw {
                staged.insert(key, raw.clone());
            }
            return Ok(());
        }
        self.drive.values.insert(key, raw.clone());
        if let Some(w) = self.is_eeprom(key)
            && !self.store_per_byte.is_zero()
        {
            self.busy_until = self.clock.now() + self.store_per_byte * u32::from(w);
        }
        Ok(())
    }
    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        if self.drive.staged.is_some() || self.is_eeprom(key).is_none() {
            return None;
        }
        (self.busy_until > self.clock.now()).then_some(self.busy_until)
    }
    fn read_time(&self, _key: CodeKey) -> Duration {
        self.read_time
    }
    fn write_time(&self, _key: CodeKey) -> Duration {
        self.write_time
    }
    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        if self.dead() {
            return Err(self.no_answer("running".into()));
        }
        self.log.push((self.now(), Op::Running));
        Ok(self.drive.running)
    }
    fn stats(&self) -> ClientStats {
        self.stats
    }
    fn finish(&mut self) -> Result<(), EngineError> {
        Ok(())
    }
    fn dataset(&mut self) -> Option<&mut dyn DatasetDownload> {
        if self.dataset { Some(self) } else { None }
    }
}

/// SLOAD staging (an MC-like drive); `commit` is the trait's `end` then
/// `await_outcome`.
impl DatasetDownload for FakeClient {
    fn begin(&mut self) -> Result<(), EngineError> {
        self.snapshot(Op::Begin);
        if self.dead() {
            return Err(self.no_answer("write 80-SLOAD = -1".into()));
        }
        self.log.push((self.now(), Op::Begin));
        self.clock.sleep(self.write_time);
        self.stats.telegrams += 1;
        self.drive.staged = Some(BTreeMap::new());
        Ok(())
    }
    fn end(&mut self) -> Result<Instant, EngineError> {
        self.snapshot(Op::Commit);
        if self.dead() {
            return Err(self.no_answer("write 80-SLOAD = -2".into()));
        }
        self.log.push((self.now(), Op::Commit));
        self.clock.sleep(self.write_time);
        self.stats.telegrams += 1;
        Ok(self.clock.now())
    }
    fn await_outcome(
        &mut self,
        _ended: Instant,
        _timeout: Duration,
    ) -> Result<DatasetOutcome, EngineError> {
        if self.dead() {
            return Err(self.no_answer("poll 80-SLOAD".into()));
        }
        self.clock.sleep(self.read_time);
        self.stats.telegrams += 1;
        let staged = self.drive.staged.take().unwrap_or_default();
        if let Some(p) = self.drive.reject_dataset_at.take() {
            return Ok(DatasetOutcome::Rejected { parameter: p });
        }
        let _ = self.is_cw(CodeKey::new(0));
        self.drive.values.extend(staged);
        Ok(DatasetOutcome::Accepted)
    }
}

/// A set of `schema` with these raw values.
pub fn set_of(schema: &Schema, values: &[(CodeKey, i64)]) -> ResolvedSet {
    let mut s = ResolvedSet::new(schema);
    for (k, v) in values {
        s.insert(*k, RawValue::Int(*v));
    }
    s
}

pub fn k(n: u32) -> CodeKey {
    CodeKey::new(n)
}
