//! The parts of a [`super::Transaction`]'s state, one concern each: the drive it
//! is for ([`Drive`]), its journal ([`JournalState`]), every code's record
//! ([`Codes`], [`CodeRecord`]), the current attempt ([`Attempt`]), the
//! MC6000/7000 dataset handshake ([`DatasetState`]), what the report says
//! ([`Progress`]) and the clock and telegram counts across clients
//! ([`Counters`]).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use super::CodeOutcome;
use crate::client::{ClientStats, DriveClient, Identity, Target};
use crate::journal::{JournalFile, TxnState};
use crate::plan::{Phase, Plan, PlanOptions, Storage};

/// The drive a transaction is for: its schema, where it is, what it said
/// it is, and what the planner knows of it.
#[derive(Debug)]
pub(super) struct Drive {
    pub(super) schema: Arc<Schema>,
    pub(super) target: Target,
    pub(super) identity: Identity,
    pub(super) popts: PlanOptions,
}

/// The transaction's journal, once [`super::Transaction::journal`] created it.
#[derive(Debug, Default)]
pub(super) struct JournalState {
    pub(super) file: Option<JournalFile>,
    /// The state the journal on disk holds (the last one persisted).
    pub(super) on_disk: Option<TxnState>,
    /// Writes recorded since the last persist.
    pub(super) since_persist: usize,
}

/// One code of a transaction: everything the runner knows about it.
#[derive(Debug, Clone, Default)]
pub(super) struct CodeRecord {
    /// The old value (the first attempt's), once the code was planned.
    pub(super) backup: Option<RawValue>,
    /// The set's value, once the code was planned.
    pub(super) new: Option<RawValue>,
    /// Old and new value for humans.
    pub(super) texts: (String, String),
    /// How the drive keeps it.
    pub(super) storage: Option<Storage>,
    /// The phase of the latest plan that wrote it.
    pub(super) phase: Option<Phase>,
    /// What happened to it.
    pub(super) outcome: CodeOutcome,
    /// A write was sent to it in some attempt (it may have landed).
    pub(super) touched: bool,
    /// The value the latest read-back found equal to the set's.
    pub(super) unchanged: Option<RawValue>,
    /// The value read back equal to the set's after writing it.
    pub(super) verified: Option<RawValue>,
}

/// The current attempt's plan and its progress.
#[derive(Debug)]
pub(super) struct Attempt {
    pub(super) plan: Plan,
    /// New values of the planned writes.
    pub(super) expected: BTreeMap<CodeKey, RawValue>,
    /// Written, not yet read back (oldest first).
    pub(super) pending: VecDeque<CodeKey>,
    /// The dataset's writes, in plan order.
    pub(super) staged: Vec<CodeKey>,
    /// Dataset writes a broadcast sends instead of this drive's own
    /// SELECT ([`super::Transaction::expect_broadcast`]).
    pub(super) broadcast: BTreeSet<CodeKey>,
    /// Broadcast codes already repaired by an own write.
    pub(super) repaired: BTreeSet<CodeKey>,
}

/// Every code the transaction planned or found unchanged.
#[derive(Debug, Default)]
pub(super) struct Codes {
    /// Each code's record.
    pub(super) records: BTreeMap<CodeKey, CodeRecord>,
    /// Planned codes in write order (latest plan; earlier attempts' extra
    /// codes after).
    pub(super) order: Vec<CodeKey>,
}

impl Codes {
    /// Old values by code (the journal's backup).
    pub(super) fn backup(&self) -> BTreeMap<CodeKey, RawValue> {
        self.records
            .iter()
            .filter_map(|(k, r)| r.backup.clone().map(|v| (*k, v)))
            .collect()
    }

    /// The planned codes' new values.
    pub(super) fn new_values(&self) -> BTreeMap<CodeKey, RawValue> {
        self.records
            .iter()
            .filter_map(|(k, r)| r.new.clone().map(|v| (*k, v)))
            .collect()
    }

    /// Codes a write was sent to.
    pub(super) fn touched(&self) -> BTreeSet<CodeKey> {
        self.records
            .iter()
            .filter(|(_, r)| r.touched)
            .map(|(k, _)| *k)
            .collect()
    }

    /// Write order with each code's phase.
    pub(super) fn phased_order(&self) -> Vec<(CodeKey, Phase)> {
        self.order
            .iter()
            .filter_map(|k| self.records.get(k).and_then(|r| r.phase).map(|p| (*k, p)))
            .collect()
    }

    pub(super) fn set_outcome(&mut self, key: CodeKey, outcome: CodeOutcome) {
        self.records.entry(key).or_default().outcome = outcome;
    }

    /// What the drive holds now, over the set's codes (verified or found
    /// unchanged), in `schema`.
    pub(super) fn after(&self, schema: &Schema, set: &ResolvedSet) -> ResolvedSet {
        let mut after = ResolvedSet::new(schema);
        for k in set.values.keys() {
            if let Some(r) = self.records.get(k)
                && let Some(v) = r.verified.as_ref().or(r.unchanged.as_ref())
            {
                after.insert(*k, v.clone());
            }
        }
        after
    }
}

/// The MC6000/7000 dataset handshake (`lustbus-protocol.txt` §11.4).
#[derive(Debug, Default)]
pub(super) struct DatasetState {
    /// A dataset download was opened in some attempt (a rollback downloads
    /// the backup again).
    pub(super) touched: bool,
    /// When SLOAD = -2 was ACKed ([`super::Transaction::end_dataset`]).
    pub(super) ended: Option<driveset_link::Instant>,
    /// The handshake's outcome for the report.
    pub(super) note: Option<String>,
}

/// What the transaction has done so far, for the report.
#[derive(Debug, Default)]
pub(super) struct Progress {
    /// Attempts begun (a drive restart voids one).
    pub(super) attempts: u32,
    /// Writes acknowledged.
    pub(super) written: usize,
    /// Verification reads done in EEPROM gaps.
    pub(super) interleaved: usize,
    /// The first attempt's fingerprint of what the drive held.
    pub(super) fingerprint_before: String,
    /// After a rollback that left a control word stopped instead of
    /// restoring its running value: the fingerprint of what the drive
    /// holds (read back), which is then not `fingerprint_before`.
    pub(super) rolled_back_to: Option<String>,
    /// Notes for the report.
    pub(super) warnings: Vec<String>,
    /// The store command was acknowledged ([`super::Transaction::store`]).
    pub(super) stored: bool,
    /// The store command was sent (it may have stored, acknowledged or
    /// not): a rollback stores the restored values again.
    pub(super) store_sent: bool,
}

/// When the transaction began, and the telegram counts of the clients its
/// steps went through ([`super::Transaction::attach`], [`super::Transaction::detach`]).
#[derive(Debug)]
pub(super) struct Counters {
    pub(super) start: driveset_link::Instant,
    /// The attached client's counters when it was attached.
    stats0: ClientStats,
    /// What earlier (detached) clients did.
    carried: ClientStats,
}

impl Counters {
    /// Counting from now, through `client`.
    pub(super) fn new(client: &dyn DriveClient) -> Self {
        Counters {
            start: client.clock().now(),
            stats0: client.stats(),
            carried: ClientStats::default(),
        }
    }

    /// Keep what `client` did since it was attached.
    pub(super) fn detach(&mut self, client: &dyn DriveClient) {
        self.carried = stats_add(self.carried, stats_since(client.stats(), self.stats0));
        self.stats0 = client.stats();
    }

    /// Count `client`'s telegrams from now.
    pub(super) fn attach(&mut self, client: &dyn DriveClient) {
        self.stats0 = client.stats();
    }

    /// Everything so far, `client` being the one attached.
    pub(super) fn total(&self, client: &dyn DriveClient) -> ClientStats {
        stats_add(self.carried, stats_since(client.stats(), self.stats0))
    }
}

fn stats_add(a: ClientStats, b: ClientStats) -> ClientStats {
    ClientStats {
        telegrams: a.telegrams + b.telegrams,
        retries: a.retries + b.retries,
        sent: a.sent + b.sent,
        received: a.received + b.received,
        late: a.late + b.late,
        sload_polls: a.sload_polls + b.sload_polls,
        restarts: a.restarts + b.restarts,
    }
}

fn stats_since(now: ClientStats, then: ClientStats) -> ClientStats {
    ClientStats {
        telegrams: now.telegrams.saturating_sub(then.telegrams),
        retries: now.retries.saturating_sub(then.retries),
        sent: now.sent.saturating_sub(then.sent),
        received: now.received.saturating_sub(then.received),
        late: now.late.saturating_sub(then.late),
        sload_polls: now.sload_polls.saturating_sub(then.sload_polls),
        restarts: now.restarts.saturating_sub(then.restarts),
    }
}
