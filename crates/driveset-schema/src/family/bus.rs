//! The bus protocols (LUSTBUS, LECOM-A/B, CAN SDO) and their address rules:
//! a drive's own addresses, the group and broadcast addresses, the one
//! typed address refusal (`lustbus-protocol.txt` §4.2; `lecom-ab-tmd-manual.txt`
//! §4c; `lenze-system-bus-can-sdo.txt`, node ids), and a protocol's serde form (its name).

use super::*;

/// The bus protocol a family speaks (what a port carries).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BusProtocol {
    /// LUSTBUS (ISO 1745 fast select, ASCII 7E1): VF1000 and MC6000/7000
    /// share one line (`lustbus-protocol.txt` §1).
    Lustbus,
    /// LECOM-A/B (DIN 66019, ASCII 7E1): Tmd.
    Lecom,
    /// Lenze system bus (CAN), SDO: ECS.
    CanSdo,
}

/// Why an address is not a drive's own address on a bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddressProblem {
    /// A group or broadcast address.
    Group,
    /// Outside the protocol's range.
    OutOfRange,
}

impl AddressProblem {
    /// Kebab-case kind for findings.
    pub fn kind(self) -> &'static str {
        match self {
            AddressProblem::Group => "group-address",
            AddressProblem::OutOfRange => "address-out-of-range",
        }
    }
}

impl BusProtocol {
    /// Every bus protocol.
    pub const ALL: [BusProtocol; 3] = [
        BusProtocol::Lustbus,
        BusProtocol::Lecom,
        BusProtocol::CanSdo,
    ];

    /// Name in manifests, `--protocol` and reports.
    pub fn name(self) -> &'static str {
        match self {
            BusProtocol::Lustbus => "lustbus",
            BusProtocol::Lecom => "lecom",
            BusProtocol::CanSdo => "can",
        }
    }

    /// Other accepted spellings.
    pub fn aliases(self) -> &'static [&'static str] {
        match self {
            BusProtocol::CanSdo => &["sdo"],
            _ => &[],
        }
    }

    /// One line for `--help`.
    pub fn title(self) -> &'static str {
        match self {
            BusProtocol::Lustbus => "LUSTBUS (Lust VF1000, MC6000/7000)",
            BusProtocol::Lecom => "LECOM-A/B (Lenze Tmd)",
            BusProtocol::CanSdo => "CAN SDO over the Lenze system bus (Lenze ECS)",
        }
    }

    /// Parse a name or alias (any case).
    pub fn parse(s: &str) -> Option<BusProtocol> {
        let s = s.to_ascii_lowercase();
        BusProtocol::ALL
            .into_iter()
            .find(|p| p.name() == s || p.aliases().contains(&s.as_str()))
    }

    /// The families this protocol carries.
    pub fn families(self) -> impl Iterator<Item = Family> {
        Family::ALL.into_iter().filter(move |f| f.bus() == self)
    }

    /// The one family this protocol carries, when it carries only one
    /// (LECOM: Tmd; CAN SDO: ECS); `None` for LUSTBUS, whose line is
    /// shared by VF1000 and MC6000/7000 (`lustbus-protocol.txt` §1).
    /// A `const fn`, so that constants of that family's figures (the
    /// planner's LECOM reaction times) ask the bus too.
    pub const fn only_family(self) -> Option<Family> {
        let mut found = None;
        let mut i = 0;
        while i < Family::ALL.len() {
            let f = Family::ALL[i];
            if f.descriptor().bus as u8 == self as u8 {
                if found.is_some() {
                    return None;
                }
                found = Some(f);
            }
            i += 1;
        }
        found
    }

    /// Every line rate a drive on this bus may run at, highest first: the
    /// union of its families' [`LineRates::rates`] (LUSTBUS §4: the
    /// servocontrollers' 2400..57600 hold the inverters' 2400..9600; LECOM:
    /// the Tmd's C0125 rates); empty for CAN. What a baud scan tries.
    pub const fn line_rates(self) -> &'static [u32] {
        match self {
            BusProtocol::Lustbus => super::mc6000::SERVO_RATES,
            BusProtocol::Lecom => super::tmd::TMD.line_rates.rates,
            BusProtocol::CanSdo => &[],
        }
    }

    /// Whether a drive of `family` runs on this bus.
    pub fn carries(self, family: Family) -> bool {
        family.bus() == self
    }

    /// Every address a drive of this protocol may have as its own.
    pub fn drive_addresses(self) -> RangeInclusive<u8> {
        match self {
            BusProtocol::Lustbus => 1..=30,
            BusProtocol::Lecom => 1..=99,
            BusProtocol::CanSdo => 1..=127,
        }
    }

    /// The address every drive executes without answering (LUSTBUS 31,
    /// §4.2; LECOM 00, the broadcast address). CAN SDO has none.
    pub fn broadcast_address(self) -> Option<u8> {
        match self {
            BusProtocol::Lustbus => Some(31),
            BusProtocol::Lecom => Some(0),
            BusProtocol::CanSdo => None,
        }
    }

    /// Whether `address` addresses several drives at once (LUSTBUS 0 and
    /// 31; LECOM 00 and the group addresses 10, 20 .. 90).
    pub fn is_group_address(self, address: i64) -> bool {
        match self {
            BusProtocol::Lustbus => matches!(address, 0 | 31),
            BusProtocol::Lecom => (0..=90).contains(&address) && address % 10 == 0,
            BusProtocol::CanSdo => false,
        }
    }

    /// Every address a telegram of this protocol can carry: a drive's own,
    /// the group and the broadcast addresses (LUSTBUS 0..31, §4.2; LECOM
    /// 00..99; CAN node ids 1..127).
    pub fn wire_addresses(self) -> RangeInclusive<u8> {
        match self {
            BusProtocol::Lustbus => 0..=31,
            BusProtocol::Lecom => 0..=99,
            BusProtocol::CanSdo => 1..=127,
        }
    }

    /// The rule [`BusProtocol::wire_addresses`] follows, in words.
    pub fn wire_address_rule(self) -> &'static str {
        match self {
            BusProtocol::Lustbus => "LUSTBUS addresses are 0..31 (0 all devices, 31 broadcast)",
            BusProtocol::Lecom => {
                "LECOM addresses are 00..99 (00 broadcast, 10, 20, ... 90 groups)"
            }
            BusProtocol::CanSdo => "CAN node ids are 1..127",
        }
    }

    /// Check a drive's own address. The one address rule: every refusal
    /// of an address as a drive's own (manifest, simulator, CLI, engine) is
    /// rendered from the [`AddressRefusal`] it returns.
    pub fn check_address(self, address: i64) -> Result<(), AddressRefusal> {
        let refuse = |problem, rule| {
            Err(AddressRefusal {
                bus: self,
                address,
                problem,
                rule,
            })
        };
        if self.is_group_address(address) {
            return refuse(
                AddressProblem::Group,
                match self {
                    BusProtocol::Lustbus => {
                        "LUSTBUS address 0 is the group address and 31 the broadcast address; a drive needs its own address 1..30"
                    }
                    _ => {
                        "LECOM 00 is the broadcast address and 10, 20, ... 90 are group addresses; a drive needs its own address 1..99 not ending in 0"
                    }
                },
            );
        }
        let r = self.drive_addresses();
        if address < i64::from(*r.start()) || address > i64::from(*r.end()) {
            return refuse(
                AddressProblem::OutOfRange,
                match self {
                    BusProtocol::Lustbus => "LUSTBUS drive addresses are 1..30",
                    BusProtocol::Lecom => "LECOM station addresses are 1..99",
                    BusProtocol::CanSdo => "CAN node ids are 1..127",
                },
            );
        }
        Ok(())
    }
}

/// Why [`BusProtocol::check_address`] refused an address as a drive's own:
/// the one typed address refusal. Its `Display` is `address A: RULE`;
/// callers that say more (the bus's name, the manifest line) add it around
/// [`AddressRefusal::rule`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("address {address}: {rule}")]
pub struct AddressRefusal {
    /// The bus protocol whose rule refused it.
    pub bus: BusProtocol,
    /// The address refused.
    pub address: i64,
    /// Group / broadcast or out of range.
    pub problem: AddressProblem,
    /// The rule, in words (LUSTBUS §4.2, LECOM §4c, CAN node ids).
    pub rule: &'static str,
}

impl AddressRefusal {
    /// Kebab-case kind for findings ([`AddressProblem::kind`]).
    pub fn kind(&self) -> &'static str {
        self.problem.kind()
    }

    /// What to do about it: `give the drive its own address 1..30`.
    pub fn hint(&self) -> String {
        let r = self.bus.drive_addresses();
        format!("give the drive its own address {}..{}", r.start(), r.end())
    }
}

/// A bus protocol is written by its name (`lustbus`, `lecom`, `can`), as
/// manifests, reports and refusals spell it.
impl serde::Serialize for BusProtocol {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for BusProtocol {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = <String as serde::Deserialize>::deserialize(d)?;
        BusProtocol::parse(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("unknown bus protocol `{name}`")))
    }
}

impl fmt::Display for BusProtocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
