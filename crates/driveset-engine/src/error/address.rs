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

use super::Refusal;
use super::form::RefusalForm;

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
/// done.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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
    pub(super) fn form(self) -> RefusalForm {
        let address = u8::try_from(self.refusal.address).unwrap_or(u8::MAX);
        let node = u32::try_from(self.refusal.address).unwrap_or(u32::MAX);
        match (self.refusal.bus, self.doing) {
            (BusProtocol::Lustbus, AddressUse::Client) => RefusalForm::LustbusAddress { address },
            (BusProtocol::Lecom, AddressUse::Client) => RefusalForm::LecomAddress { address },
            (BusProtocol::CanSdo, AddressUse::Client | AddressUse::Doctor) => {
                RefusalForm::SdoNode { node }
            }
            (BusProtocol::Lustbus, AddressUse::Scan) => RefusalForm::ScanLustbusAddress { address },
            (BusProtocol::Lecom, AddressUse::Scan) => RefusalForm::ScanLecomAddress { address },
            (BusProtocol::CanSdo, AddressUse::Scan) => RefusalForm::ScanCanNode { node },
            (BusProtocol::Lustbus, AddressUse::Doctor) => {
                RefusalForm::DoctorLustbusAddress { address }
            }
            (BusProtocol::Lecom, AddressUse::Doctor) => RefusalForm::DoctorLecomAddress { address },
        }
    }

    /// Back from the JSON form: the refusal is the rule's again.
    pub(super) fn from_form(form: RefusalForm) -> Result<Self, String> {
        let (doing, bus, address) = match form {
            RefusalForm::LustbusAddress { address } => {
                (AddressUse::Client, BusProtocol::Lustbus, i64::from(address))
            }
            RefusalForm::LecomAddress { address } => {
                (AddressUse::Client, BusProtocol::Lecom, i64::from(address))
            }
            RefusalForm::SdoNode { node } => {
                (AddressUse::Client, BusProtocol::CanSdo, i64::from(node))
            }
            RefusalForm::ScanLustbusAddress { address } => {
                (AddressUse::Scan, BusProtocol::Lustbus, i64::from(address))
            }
            RefusalForm::ScanLecomAddress { address } => {
                (AddressUse::Scan, BusProtocol::Lecom, i64::from(address))
            }
            RefusalForm::ScanCanNode { node } => {
                (AddressUse::Scan, BusProtocol::CanSdo, i64::from(node))
            }
            RefusalForm::DoctorLustbusAddress { address } => {
                (AddressUse::Doctor, BusProtocol::Lustbus, i64::from(address))
            }
            RefusalForm::DoctorLecomAddress { address } => {
                (AddressUse::Doctor, BusProtocol::Lecom, i64::from(address))
            }
            other => return Err(format!("{other:?} is not an address refusal")),
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
