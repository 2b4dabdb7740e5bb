//! Owns the journal record of an address change ([`AssignRecord`], where
//! it stands: [`AssignStep`]) and the journal made of a plan, bound to the
//! bus id and the new address, on disk before the first write.

use serde::{Deserialize, Serialize};

use driveset_schema::BusProtocol;

use super::AssignPlan;
use crate::error::EngineError;
use crate::journal::{
    JOURNAL_VERSION, Journal, JournalFile, JournalIdentity, JournalTarget, SchemaSource, TxnState,
};

/// Where an address change stands ([`AssignRecord::step`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AssignStep {
    /// Journalled; nothing written yet.
    Planned,
    /// The address write is under way (it may have landed).
    Address,
    /// The address is verified at the new address.
    AddressVerified,
    /// The rate change is under way: the drive may run at either rate.
    Rate,
    /// Everything written and verified.
    Done,
}

/// The journal's record of an address change (`driveset address`),
/// enough for [`recover()`](super::recover()) to find the drive and finish.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AssignRecord {
    /// `lustbus` or `lecom` (an unknown name is a journal error, never a guess).
    pub protocol: BusProtocol,
    /// The family name.
    pub family: String,
    /// The address the drive was reached at (LUSTBUS 0, LECOM `--from`).
    pub from: u8,
    /// Its own address before, where known.
    pub old_address: Option<i64>,
    /// The new address.
    pub to: u8,
    /// The rate the drive ran at.
    pub old_rate: u32,
    /// The new rate (`None`: unchanged).
    pub rate: Option<u32>,
    /// LUSTBUS 91-TYPE the drive answered with.
    pub type_value: Option<i64>,
    /// Where it stands.
    pub step: AssignStep,
}

pub(super) fn record_of(p: &AssignPlan) -> AssignRecord {
    AssignRecord {
        protocol: p.protocol,
        family: p.family.name().to_string(),
        from: p.reached_at,
        old_address: p.old_address,
        to: p.to,
        old_rate: p.rate,
        rate: p.baud.filter(|b| *b != p.rate || p.rate_effect.is_some()),
        type_value: p.type_value,
        step: AssignStep::Planned,
    }
}

pub(super) fn new_journal(p: &AssignPlan, at_ns: u64, record: AssignRecord) -> Journal {
    let mut j = Journal {
        journal_version: JOURNAL_VERSION,
        state: TxnState::Planned,
        target: JournalTarget {
            port: p.port.clone(),
            address: p.to,
            bus: Some(p.bus.clone()),
        },
        identity: JournalIdentity::from(&p.identity),
        schema: p.schema.id.clone(),
        schema_source: SchemaSource::of(&p.schema),
        set_fingerprint: String::new(),
        fingerprint_before: String::new(),
        dataset: false,
        attempt: 0,
        backup: Vec::new(),
        plan: Vec::new(),
        unchanged: Vec::new(),
        written: Vec::new(),
        broadcast: Vec::new(),
        transitions: Vec::new(),
        failure: None,
        failure_cause: None,
        holding: Vec::new(),
        transfer: None,
        assign: Some(record),
    };
    j.transition(
        TxnState::Planned,
        at_ns,
        Some(format!(
            "address: the drive at address {} to address {}{}",
            p.reached_at,
            p.to,
            p.baud.map_or_else(String::new, |b| format!(
                ", line rate {} to {b} baud",
                p.rate
            ))
        )),
    );
    j
}

pub(super) fn set_step(jf: &mut JournalFile, step: AssignStep) -> Result<(), EngineError> {
    if let Some(r) = &mut jf.journal.assign {
        r.step = step;
    }
    jf.persist()
}
