//! The one address refusal ([`Refusal::Address`]): an address that is no
//! drive's own, refused by the schema's rule ([`BusProtocol::check_address`]:
//! LUSTBUS 1..30, section 4.2; LECOM stations 01..99 without 00 and the
//! group addresses 10..90, section 8.J; CAN node ids 1..127, DS301) and
//! rendered from its typed [`AddressRefusal`], worded for what was being
//! done ([`AddressUse`]: a client, a scan, `doctor`).
//!
//! One exception to the rule, kept as it was: LUSTBUS address 0 (every
//! drive answers, stand-alone operation with a single drive on the line,
//! sections 4.1 and 4.2) is taken by a client and by `doctor`, and refused
//! by a scan (every drive would answer at once).

use std::fmt;

use driveset_proto::can::NodeIdError;
use driveset_schema::{AddressRefusal, BusProtocol};

use serde::{Deserialize, Serialize};

use super::Refusal;

/// What was being done when an address was refused: the message says it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddressUse {
    /// A client was opened for the drive at the address.
    Client,
    /// A scan was given the address as a target.
    Scan,
    /// `doctor` was asked to probe the address.
    Doctor,
}

/// [`Refusal::Address`]: the schema's typed refusal and what was being
/// done. Its JSON is `AddressForm`'s, the kinds journals hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "AddressForm", try_from = "AddressForm")]
pub struct AddressRefused {
    /// What was being done.
    pub doing: AddressUse,
    /// What [`BusProtocol::check_address`] said (the bus and the address).
    pub refusal: AddressRefusal,
}

impl AddressRefused {
    /// A client's address check: the bus's rule, LUSTBUS 0 taken (a single
    /// drive on the line, section 4.2).
    pub fn check_client(bus: BusProtocol, address: u8) -> Result<(), Refusal> {
        Self::check(AddressUse::Client, bus, address)
    }

    /// A scan target's check: the bus's rule, LUSTBUS 0 refused (every
    /// drive would answer at once, section 4.2).
    pub fn check_scan(bus: BusProtocol, address: u8) -> Result<(), Refusal> {
        Self::check(AddressUse::Scan, bus, address)
    }

    /// `doctor`'s check: the bus's rule, LUSTBUS 0 taken (every drive
    /// answers, stand-alone operation, section 4.1).
    pub fn check_doctor(bus: BusProtocol, address: u8) -> Result<(), Refusal> {
        Self::check(AddressUse::Doctor, bus, address)
    }

    fn check(doing: AddressUse, bus: BusProtocol, address: u8) -> Result<(), Refusal> {
        match bus.check_address(i64::from(address)) {
            Ok(()) => Ok(()),
            Err(_) if doing.takes_lustbus_zero() && bus == BusProtocol::Lustbus && address == 0 => {
                Ok(())
            }
            Err(refusal) => Err(Refusal::Address(AddressRefused { doing, refusal })),
        }
    }

    /// The address as given.
    pub fn address(&self) -> i64 {
        self.refusal.address
    }

    /// The JSON form (the kinds journals have always recorded).
    fn form(self) -> AddressForm {
        let address = u8::try_from(self.refusal.address).unwrap_or(u8::MAX);
        let node = u32::try_from(self.refusal.address).unwrap_or(u32::MAX);
        match (self.refusal.bus, self.doing) {
            (BusProtocol::Lustbus, AddressUse::Client) => AddressForm::LustbusAddress { address },
            (BusProtocol::Lecom, AddressUse::Client) => AddressForm::LecomAddress { address },
            (BusProtocol::CanSdo, AddressUse::Client | AddressUse::Doctor) => {
                AddressForm::SdoNode { node }
            }
            (BusProtocol::Lustbus, AddressUse::Scan) => AddressForm::ScanLustbusAddress { address },
            (BusProtocol::Lecom, AddressUse::Scan) => AddressForm::ScanLecomAddress { address },
            (BusProtocol::CanSdo, AddressUse::Scan) => AddressForm::ScanCanNode { node },
            (BusProtocol::Lustbus, AddressUse::Doctor) => {
                AddressForm::DoctorLustbusAddress { address }
            }
            (BusProtocol::Lecom, AddressUse::Doctor) => AddressForm::DoctorLecomAddress { address },
        }
    }

    /// Back from the JSON form: the refusal is the rule's again.
    fn from_form(form: AddressForm) -> Result<Self, String> {
        let (doing, bus, address) = match form {
            AddressForm::LustbusAddress { address } => {
                (AddressUse::Client, BusProtocol::Lustbus, i64::from(address))
            }
            AddressForm::LecomAddress { address } => {
                (AddressUse::Client, BusProtocol::Lecom, i64::from(address))
            }
            AddressForm::SdoNode { node } => {
                (AddressUse::Client, BusProtocol::CanSdo, i64::from(node))
            }
            AddressForm::ScanLustbusAddress { address } => {
                (AddressUse::Scan, BusProtocol::Lustbus, i64::from(address))
            }
            AddressForm::ScanLecomAddress { address } => {
                (AddressUse::Scan, BusProtocol::Lecom, i64::from(address))
            }
            AddressForm::ScanCanNode { node } => {
                (AddressUse::Scan, BusProtocol::CanSdo, i64::from(node))
            }
            AddressForm::DoctorLustbusAddress { address } => {
                (AddressUse::Doctor, BusProtocol::Lustbus, i64::from(address))
            }
            AddressForm::DoctorLecomAddress { address } => {
                (AddressUse::Doctor, BusProtocol::Lecom, i64::from(address))
            }
        };
        match bus.check_address(address) {
            Err(refusal) => Ok(AddressRefused { doing, refusal }),
            Ok(()) => Err(format!(
                "address {address} is a {} drive address, not a refused one",
                super::refusal::protocol_label(bus)
            )),
        }
    }
}

/// [`AddressRefused`]'s JSON form: one `kind` per bus and use, as journals
/// have always recorded them (the address as given).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum AddressForm {
    LecomAddress { address: u8 },
    SdoNode { node: u32 },
    LustbusAddress { address: u8 },
    ScanLustbusAddress { address: u8 },
    ScanLecomAddress { address: u8 },
    ScanCanNode { node: u32 },
    DoctorLustbusAddress { address: u8 },
    DoctorLecomAddress { address: u8 },
}

impl From<AddressRefused> for AddressForm {
    fn from(refused: AddressRefused) -> Self {
        refused.form()
    }
}

impl TryFrom<AddressForm> for AddressRefused {
    type Error = String;

    fn try_from(form: AddressForm) -> Result<Self, String> {
        AddressRefused::from_form(form)
    }
}

impl AddressUse {
    /// Whether LUSTBUS address 0 is taken (a client and `doctor`: a single
    /// drive on the line answers it, sections 4.1 and 4.2).
    fn takes_lustbus_zero(self) -> bool {
        matches!(self, AddressUse::Client | AddressUse::Doctor)
    }
}

impl fmt::Display for AddressRefused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let address = self.refusal.address;
        let node = NodeIdError(u32::try_from(address).unwrap_or(u32::MAX));
        match (self.refusal.bus, self.doing) {
            (BusProtocol::Lustbus, AddressUse::Client) => write!(
                f,
                "LUSTBUS address {address} is not a drive address: use 1..30, or 0 with a single drive on the line (31 is the broadcast address, section 4.2)"
            ),
            (BusProtocol::Lecom, AddressUse::Client) => write!(
                f,
                "LECOM address {address} is not a station: use 01..99 except 00 and the group addresses 10, 20, .. 90 (BROADCAST / MULTICAST, section 8.J; use broadcast() for those)"
            ),
            (BusProtocol::CanSdo, AddressUse::Client | AddressUse::Doctor) => {
                write!(f, "{node}: 0 addresses no SDO server (DS301)")
            }
            (BusProtocol::Lustbus, AddressUse::Scan) => write!(
                f,
                "{address} is not a scan target: LUSTBUS drive addresses are 1..30 (0 makes every drive answer at once, 31 is the broadcast address, section 4.2)"
            ),
            (BusProtocol::Lecom, AddressUse::Scan) => write!(
                f,
                "{address:02} is not a scan target: LECOM stations are 01..99 without 00 and the group addresses 10..90 (section 8.J)"
            ),
            (BusProtocol::CanSdo, AddressUse::Scan) => write!(
                f,
                "{node}: node 0 is no SDO server and cannot be a scan target (DS301)"
            ),
            (BusProtocol::Lustbus, AddressUse::Doctor) => write!(
                f,
                "{address} is not a LUSTBUS drive address: use 1..30, or 0 (every drive answers, stand-alone operation, section 4.1)"
            ),
            (BusProtocol::Lecom, AddressUse::Doctor) => write!(
                f,
                "{address:02} is not a LECOM station: use 01..99 without 00 and the group addresses 10..90 (section 8.J)"
            ),
        }
    }
}
