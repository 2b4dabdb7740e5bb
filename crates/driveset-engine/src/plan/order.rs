//! How the drive keeps a code's value ([`Storage`]) and which phase of the
//! transaction its write belongs to ([`Phase`]; the write order of the
//! parent module's docs, LUSTBUS 11.1 / 11.4 / 11.5, LECOM manual §4e).

use driveset_schema::schema::StorageKind;
use driveset_schema::{Code, CodeKey, Role, Schema};

/// How a code's value is kept by the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Storage {
    /// RAM (control value): taken at once, no store time.
    Ram,
    /// FSEL/ISEL variable: RAM at CSEL = 3, EEPROM otherwise (LUSTBUS 11.1).
    FselIsel,
    /// EEPROM: MC6000/7000 store it in the background (width x 15 ms),
    /// VF1000 delay the ACK.
    Eeprom,
    /// MC6000/7000 CardWriteable: taken by the SLOAD dataset download.
    CardWriteable,
    /// The schema does not say (Lenze families).
    Unspecified,
}

impl Storage {
    /// Every storage kind, in declaration order.
    pub const ALL: [Storage; 5] = [
        Storage::Ram,
        Storage::FselIsel,
        Storage::Eeprom,
        Storage::CardWriteable,
        Storage::Unspecified,
    ];

    /// Name as in journals and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Storage::Ram => "ram",
            Storage::FselIsel => "fsel-isel",
            Storage::Eeprom => "eeprom",
            Storage::CardWriteable => "card-writeable",
            Storage::Unspecified => "unspecified",
        }
    }
}

/// Which part of the transaction a write belongs to (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// MC6000/7000 SLOAD dataset download.
    Dataset,
    /// Configuration values.
    Stored,
    /// RAM control values and commands.
    Control,
    /// Operating mode / control source switches.
    Mode,
    /// Bus address and baud rate of the drive's serial interface, last:
    /// the rest of the set must land while the link is as it was.
    Link,
}

impl Phase {
    /// Every phase, in write order.
    pub const ALL: [Phase; 5] = [
        Phase::Dataset,
        Phase::Stored,
        Phase::Control,
        Phase::Mode,
        Phase::Link,
    ];

    /// Name as in journals and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Dataset => "dataset",
            Phase::Stored => "stored",
            Phase::Control => "control",
            Phase::Mode => "mode",
            Phase::Link => "link",
        }
    }
}

/// Rank of a [`Phase::Mode`] write: the operating mode first, then the
/// control source (see the module docs, "mode").
pub(super) fn mode_rank(schema: &Schema, number: u32) -> u8 {
    match schema.role_of(number) {
        Some(Role::OperatingMode) => 0,
        Some(Role::ControlSource) => 1,
        _ => 0,
    }
}

pub(super) fn storage_of(code: &Code, dataset: bool) -> Storage {
    if dataset && code.card_writeable == Some(true) {
        return Storage::CardWriteable;
    }
    match code.kind {
        Some(StorageKind::RamControl) | Some(StorageKind::RamActual) => Storage::Ram,
        Some(StorageKind::FselIsel) => Storage::FselIsel,
        Some(StorageKind::Eeprom) => Storage::Eeprom,
        None if code.card_writeable == Some(true) => Storage::Eeprom,
        None => Storage::Unspecified,
    }
}

pub(super) fn phase_of(schema: &Schema, key: CodeKey, storage: Storage) -> Phase {
    let role = schema.role_of(key.number);
    if storage == Storage::CardWriteable {
        Phase::Dataset
    } else if matches!(role, Some(Role::BusAddress | Role::BaudRate)) {
        Phase::Link
    } else if matches!(role, Some(Role::OperatingMode | Role::ControlSource)) {
        Phase::Mode
    } else if matches!(storage, Storage::Ram | Storage::FselIsel)
        || matches!(
            role,
            Some(Role::ControlWord | Role::Command | Role::Setpoint)
        )
    {
        Phase::Control
    } else {
        Phase::Stored
    }
}
