//! The journal file's content (docs/journals.md, "The file"): [`Journal`]
//! and its parts, the state ([`TxnState`]), the drive it is bound to
//! ([`JournalTarget`], [`JournalIdentity`], [`SchemaSource`]), the backup
//! and the plan, the transitions, and the transfer-rate record
//! ([`TransferRecord`], "The transfer-rate record"). Serde gives the JSON
//! form; the fixtures under `tests/data/journals/` hold it.

use std::path::Path;

use driveset_schema::{CodeKey, RawValue};
use serde::{Deserialize, Serialize};

use super::failure::{CodeHolding, FailureCause};
use super::value::{JournalValue, raw_values};
use crate::client::{DriveClient, IdentProtocol, Identity, Target};
use crate::plan::{Phase, Storage};

/// Where a transaction stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TxnState {
    /// Journal written, nothing sent to the drive yet.
    Planned,
    /// Writes in progress (on MC6000/7000: the dataset download is staged).
    Writing,
    /// MC6000/7000: the drive accepted the dataset (SLOAD = 0); the
    /// non-CardWriteable writes follow.
    Committed,
    /// Every write acknowledged; the last verification reads run.
    Verifying,
    /// Every written code read back equal; the store command of a drive
    /// that keeps writes only on command is being sent (`[schema.store]`).
    /// `recover` stores again.
    Storing,
    /// The old values are being restored.
    RollingBack,
    /// Final: the drive holds the new set (verified).
    Complete,
    /// Final: the drive holds its old values again (verified).
    RolledBack,
    /// Final until recovered: the drive holds a mix; `holding` says what.
    Failed,
}

impl TxnState {
    /// Name as written in the journal.
    pub fn as_str(self) -> &'static str {
        match self {
            TxnState::Planned => "planned",
            TxnState::Writing => "writing",
            TxnState::Committed => "committed",
            TxnState::Verifying => "verifying",
            TxnState::Storing => "storing",
            TxnState::RollingBack => "rolling-back",
            TxnState::Complete => "complete",
            TxnState::RolledBack => "rolled-back",
            TxnState::Failed => "failed",
        }
    }

    /// Whether nothing is left to do (`complete` or `rolled-back`).
    pub fn is_settled(self) -> bool {
        matches!(self, TxnState::Complete | TxnState::RolledBack)
    }
}

/// Port, address and bus as recorded.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct JournalTarget {
    /// Port as the user wrote it.
    pub port: String,
    /// Bus address / node id.
    pub address: u8,
    /// The bus ([`DriveClient::bus_id`]); `None` in version 1 journals.
    #[serde(default)]
    pub bus: Option<String>,
}

impl JournalTarget {
    /// The target of `client`: its port, address and bus.
    pub fn of(client: &dyn DriveClient) -> Self {
        let t: &Target = client.target();
        JournalTarget {
            port: t.port.clone(),
            address: t.address,
            bus: Some(client.bus_id()),
        }
    }

    /// Whether this is the drive at `address` on bus `bus` (reached through
    /// `port`): same bus id and address; a version 1 journal (no bus id)
    /// by the port string as written.
    pub fn is_drive(&self, bus: &str, port: &str, address: u8) -> bool {
        self.address == address
            && match &self.bus {
                Some(b) => b == bus,
                None => self.port == port,
            }
    }
}

/// Where the journal's schema came from ([`Journal::schema_source`]), so
/// that `recover` converts with the very schema the upload used, without
/// `--schema`: its file (absolute) when it was read from one, and its
/// fingerprint ([`driveset_schema::Schema::fingerprint`]).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SchemaSource {
    /// The schema file, absolute; absent for a built-in schema (and in
    /// journals of releases before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema_path: Option<String>,
    /// `sha256:` of the schema's text (chained over its base's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema_fingerprint: Option<String>,
}

impl SchemaSource {
    /// The source of `schema`: its file, absolute, when
    /// [`driveset_schema::Schema::path`] names a file on disk (a built-in's
    /// `schemas/x.toml` names none outside a checkout; `recover` looks the
    /// id up among the known schemas first and takes the file only when
    /// none of them has the fingerprint), and its fingerprint.
    pub fn of(schema: &driveset_schema::Schema) -> Self {
        let file = Path::new(&schema.path);
        let schema_path = file
            .is_file()
            .then(|| std::fs::canonicalize(file).ok())
            .flatten()
            .map(|p| p.display().to_string());
        SchemaSource {
            schema_path,
            schema_fingerprint: Some(schema.fingerprint.clone()),
        }
    }
}

/// The drive's identity as recorded ([`Identity`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct JournalIdentity {
    /// Who answered, written as [`IdentProtocol::name`] writes it
    /// (`lustbus-mc`, `lustbus-vf1000`, `lecom`, `lenze-can-sdo`, a bus's
    /// name such as `lustbus`, or `""`); any other name is a journal error.
    #[serde(
        serialize_with = "names::write_ident_protocol",
        deserialize_with = "names::ident_protocol"
    )]
    pub protocol: IdentProtocol,
    /// Identification codes and their values as text.
    pub codes: Vec<(String, String)>,
    /// Software version, where known.
    pub software: Option<String>,
}

impl From<&Identity> for JournalIdentity {
    fn from(i: &Identity) -> Self {
        JournalIdentity {
            protocol: i.protocol,
            codes: i.pairs(),
            software: i.software.clone(),
        }
    }
}

impl JournalIdentity {
    /// Whether a freshly read identity is the same drive kind.
    pub fn matches(&self, other: &Identity) -> bool {
        self.same_protocol(other.protocol)
            && self.codes == other.pairs()
            && self.software == other.software
    }

    /// Whether `protocol` is the one recorded: by the name both write
    /// (`lecom` is Tmd's family and the LECOM bus alike, as the journal
    /// has always compared them).
    pub fn same_protocol(&self, protocol: IdentProtocol) -> bool {
        self.protocol.name() == protocol.name()
    }
}

/// One backed-up value: a planned code's value before the transaction.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BackupEntry {
    /// Code number.
    pub number: u32,
    /// Subcode.
    pub subcode: Option<u32>,
    /// Code as humans spell it (`C0011`, `428-RSIO`).
    pub code: String,
    /// A password: redact when showing.
    pub secret: bool,
    /// The old raw value.
    pub old: JournalValue,
}

impl BackupEntry {
    /// The code.
    pub fn key(&self) -> CodeKey {
        CodeKey {
            number: self.number,
            subcode: self.subcode,
        }
    }
}

/// One planned write, in write order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlanEntryRecord {
    /// Code number.
    pub number: u32,
    /// Subcode.
    pub subcode: Option<u32>,
    /// Code as humans spell it.
    pub code: String,
    /// A password: redact when showing.
    pub secret: bool,
    /// How the drive keeps it: `ram`, `fsel-isel`, `eeprom`,
    /// `card-writeable`, `unspecified` (an unknown name is a journal error).
    #[serde(deserialize_with = "names::storage")]
    pub storage: Storage,
    /// Byte width, where the schema gives it.
    pub width: Option<u8>,
    /// Its phase: `dataset`, `stored`, `control`, `mode`, `link` (an
    /// unknown name is a journal error).
    #[serde(deserialize_with = "names::phase")]
    pub phase: Phase,
    /// The new raw value.
    pub new: JournalValue,
}

impl PlanEntryRecord {
    /// The code.
    pub fn key(&self) -> CodeKey {
        CodeKey {
            number: self.number,
            subcode: self.subcode,
        }
    }
}

/// A state transition.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Transition {
    /// The state entered.
    pub state: TxnState,
    /// The client clock's instant, nanoseconds since its epoch.
    pub at_ns: u64,
    /// Why (failure cause, dataset outcome ...).
    pub note: Option<String>,
}

/// The journal file's content.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Journal {
    /// [`JOURNAL_VERSION`](super::JOURNAL_VERSION).
    pub journal_version: u32,
    /// Current state.
    pub state: TxnState,
    /// Port and address.
    pub target: JournalTarget,
    /// What the drive said it is.
    pub identity: JournalIdentity,
    /// Schema id.
    pub schema: String,
    /// The schema's file and fingerprint (absent in journals of releases
    /// before they were recorded): `recover` finds the schema from them.
    #[serde(flatten)]
    pub schema_source: SchemaSource,
    /// Fingerprint of the set being uploaded.
    pub set_fingerprint: String,
    /// Fingerprint of the drive's values of the set's codes before the upload.
    pub fingerprint_before: String,
    /// Whether the MC6000/7000 SLOAD dataset handshake is used.
    pub dataset: bool,
    /// Attempt number (a drive restart voids an attempt; it is redone once).
    pub attempt: u32,
    /// Old values of every planned code (the first attempt's values are kept).
    pub backup: Vec<BackupEntry>,
    /// The planned writes, in write order.
    pub plan: Vec<PlanEntryRecord>,
    /// The set's other codes, which the drive already held (value = old =
    /// new); recovery reads them too to fingerprint the whole set.
    #[serde(default)]
    pub unchanged: Vec<BackupEntry>,
    /// Codes written (acknowledged) so far, canonical spelling; advisory:
    /// recovery reads the drive rather than trusting this list.
    pub written: Vec<String>,
    /// Codes whose new value a LUSTBUS broadcast (SELECT to address 31,
    /// section 4.2; `commission --broadcast-common`) sends into this
    /// drive's dataset download instead of a SELECT of its own, canonical
    /// spelling. No receipt says whether they landed, so they may be in
    /// the drive's dataset though `written` does not list them; recovery
    /// reads the drive anyway (a dataset download left open is rolled
    /// back).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub broadcast: Vec<String>,
    /// State transitions.
    pub transitions: Vec<Transition>,
    /// Why the transaction failed, if it did (the message, as shown).
    pub failure: Option<String>,
    /// The same, typed (absent in journals of releases before it was
    /// added, and while nothing failed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_cause: Option<FailureCause>,
    /// For `failed`: what each planned code holds.
    #[serde(default)]
    pub holding: Vec<CodeHolding>,
    /// A transfer-rate switch (`--transfer-baud`, [`crate::transfer`]):
    /// the drive may run at another rate than its port's until the record
    /// says `back`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transfer: Option<TransferRecord>,
    /// An address change (`driveset address`, [`crate::assign`]): the
    /// drive may answer at its old or its new address, at the old or the
    /// new rate, until the change is complete.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assign: Option<crate::assign::AssignRecord>,
}

/// Where a transfer-rate switch stands ([`TransferRecord::state`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TransferState {
    /// Recorded before the first telegram of the switch: the drive's rate
    /// code may hold the transfer rate (in EEPROM) and it may be active.
    Switching,
    /// The drive runs at the transfer rate; its rate code holds its own
    /// value again (not active).
    AtTransferRate,
    /// Switching back: the drive may run at either rate.
    SwitchingBack,
    /// Final: the drive runs at the old rate again and its rate code holds
    /// [`TransferRecord::stored`].
    Back,
}

impl TransferState {
    /// Name as written in the journal.
    pub fn as_str(self) -> &'static str {
        match self {
            TransferState::Switching => "switching",
            TransferState::AtTransferRate => "at-transfer-rate",
            TransferState::SwitchingBack => "switching-back",
            TransferState::Back => "back",
        }
    }
}

/// A transfer-rate switch (LUSTBUS 11.5: 81-SBAUD, then 4-PROG = 111).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TransferRecord {
    /// The rate code as humans spell it (`81-SBAUD`).
    pub code: String,
    /// The rate the port (and the drive) ran at before the switch.
    pub old_rate: u32,
    /// The transfer rate.
    pub transfer_rate: u32,
    /// The rate code's value before the switch (what it holds in EEPROM;
    /// not necessarily the active rate).
    pub before: JournalValue,
    /// Where the switch stands.
    pub state: TransferState,
    /// When the drive was told to switch (client clock, ns).
    pub switched_at_ns: Option<u64>,
    /// When it ran at the old rate again.
    pub back_at_ns: Option<u64>,
    /// What the rate code holds at the end (the set's value, or `before`).
    pub stored: Option<JournalValue>,
    /// What the rate code is to hold once the drive runs at the old rate
    /// again: decided once, at the first telegram of the switch back
    /// (`before` when the switch-over itself failed, else what the
    /// transaction left in it), so that a switch back cut anywhere and
    /// resumed by `recover` writes the same value, never the transfer
    /// rate nor the old rate it wrote on the way. Absent in journals of
    /// releases before it was added, and before the switch back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keep: Option<JournalValue>,
}

impl TransferRecord {
    /// Whether the drive is known to run at the old rate again.
    pub fn is_back(&self) -> bool {
        self.state == TransferState::Back
    }
}

impl Journal {
    /// Backup values by code.
    pub fn backup_values(&self) -> Result<Vec<(CodeKey, RawValue)>, String> {
        let entries = self
            .backup
            .iter()
            .map(|b| (b.key(), b.code.as_str(), &b.old));
        raw_values(entries, "backup value")
    }

    /// Planned new values by code, in write order.
    pub fn new_values(&self) -> Result<Vec<(CodeKey, RawValue)>, String> {
        let entries = self.plan.iter().map(|p| (p.key(), p.code.as_str(), &p.new));
        raw_values(entries, "planned value")
    }

    /// Values of the set's codes the upload did not need to write.
    pub fn unchanged_values(&self) -> Result<Vec<(CodeKey, RawValue)>, String> {
        let entries = self
            .unchanged
            .iter()
            .map(|b| (b.key(), b.code.as_str(), &b.old));
        raw_values(entries, "value")
    }

    /// Whether nothing is left to do: the transaction is settled and no
    /// transfer-rate switch is left open ([`TransferRecord::is_back`]).
    pub fn is_finished(&self) -> bool {
        self.state.is_settled() && self.transfer.as_ref().is_none_or(TransferRecord::is_back)
    }

    /// Enter a state, recording the instant and a note.
    pub fn transition(&mut self, state: TxnState, at_ns: u64, note: Option<String>) {
        self.state = state;
        self.transitions.push(Transition { state, at_ns, note });
    }
}

/// Reading the journal's typed names (the plan entries' `storage`,
/// `phase`; the identity's `protocol`): the name as [`Storage::as_str`] /
/// [`Phase::as_str`] / [`IdentProtocol::name`] write it; any other is an
/// error naming the field and the names it may hold, which
/// [`super::JournalFile::open`] reports with the file.
mod names {
    use driveset_schema::{BusProtocol, Family};
    use serde::de::{Deserialize, Deserializer, Error};
    use serde::ser::Serializer;

    use crate::client::IdentProtocol;
    use crate::plan::{Phase, Storage};

    /// The value of `field` among `all`, by `name_of`.
    fn named<'de, D: Deserializer<'de>, T: Copy>(
        de: D,
        field: &str,
        all: &[T],
        name_of: fn(T) -> &'static str,
    ) -> Result<T, D::Error> {
        let name = String::deserialize(de)?;
        all.iter()
            .copied()
            .find(|t| name_of(*t) == name)
            .ok_or_else(|| {
                let names: Vec<&str> = all.iter().map(|t| name_of(*t)).collect();
                D::Error::custom(format!(
                    "plan entry `{field}`: unknown name `{name}`, expected one of {}",
                    names.join(", ")
                ))
            })
    }

    pub(super) fn storage<'de, D: Deserializer<'de>>(de: D) -> Result<Storage, D::Error> {
        named(de, "storage", &Storage::ALL, Storage::as_str)
    }

    pub(super) fn phase<'de, D: Deserializer<'de>>(de: D) -> Result<Phase, D::Error> {
        named(de, "phase", &Phase::ALL, Phase::as_str)
    }

    /// Every protocol a journal's identity may name, in the order a name
    /// is looked up: not identified (`""`), the families (their schema
    /// protocols), the buses (their names; `lecom` is found as Tmd's
    /// family first, which writes the same name).
    fn ident_protocols() -> Vec<IdentProtocol> {
        let mut all = vec![IdentProtocol::Unknown];
        all.extend(Family::ALL.map(IdentProtocol::Family));
        all.extend(BusProtocol::ALL.map(IdentProtocol::Bus));
        all
    }

    /// The recorded protocol of `name`, if the engine writes it.
    pub(super) fn ident_protocol_named(name: &str) -> Option<IdentProtocol> {
        ident_protocols().into_iter().find(|p| p.name() == name)
    }

    pub(super) fn ident_protocol<'de, D: Deserializer<'de>>(
        de: D,
    ) -> Result<IdentProtocol, D::Error> {
        let name = String::deserialize(de)?;
        ident_protocol_named(&name).ok_or_else(|| {
            let mut names: Vec<&str> = Vec::new();
            for n in ident_protocols().iter().map(|p| p.name()) {
                if !n.is_empty() && !names.contains(&n) {
                    names.push(n);
                }
            }
            D::Error::custom(format!(
                "identity `protocol`: unknown name `{name}`, expected one of {}",
                names.join(", ")
            ))
        })
    }

    pub(super) fn write_ident_protocol<S: Serializer>(
        protocol: &IdentProtocol,
        ser: S,
    ) -> Result<S::Ok, S::Error> {
        ser.serialize_str(protocol.name())
    }
}

#[cfg(test)]
mod tests {
    use driveset_schema::{BusProtocol, Family};

    use super::*;

    /// Every protocol an identity can hold is written as its name and
    /// read back as a protocol of that name (`lecom`: Tmd's family, the
    /// same name as the LECOM bus).
    #[test]
    fn every_identity_protocol_is_written_by_its_name_and_read_back() {
        let mut all = vec![IdentProtocol::Unknown];
        all.extend(Family::ALL.map(IdentProtocol::Family));
        all.extend(BusProtocol::ALL.map(IdentProtocol::Bus));
        for p in all {
            let id = JournalIdentity {
                protocol: p,
                codes: vec![],
                software: None,
            };
            let v = serde_json::to_value(&id).expect("json");
            assert_eq!(v["protocol"], p.name(), "{p:?}");
            let back: JournalIdentity = serde_json::from_value(v).expect("read back");
            assert_eq!(back.protocol.name(), p.name(), "{p:?}");
            assert!(back.same_protocol(p), "{p:?}");
        }
        assert_eq!(
            names::ident_protocol_named("lecom"),
            Some(IdentProtocol::Family(Family::Tmd))
        );
        assert_eq!(names::ident_protocol_named("LUSTBUS-MC"), None);
    }
}
