//! The JSON form of a [`Refusal`], as journals record it: one flat list of
//! `kind`s, whichever enum holds the rule, so old journals still read and
//! new ones read the same. The flat variants are written and read by
//! `Refusal`'s own derive (`remote = "Self"`), each sub-enum by its own
//! beside the room that raises it (`#[serde(tag = "kind")]`, its variants
//! renamed to the kinds journals hold: `guard_command`, `lustbus_code`,
//! `lecom_group` ...), the address refusal by `AddressForm` (`address.rs`).
//! [`Kind`] names every kind, in the order journals' readers have always
//! listed them in an error, and whose it is.

use serde::de::value::Error as ValueError;
use serde::de::{Error as _, IntoDeserializer};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::Value;

use super::{AddressRefused, Refusal};
use crate::client::lustbus::LustbusRefusal;
use crate::client::{LecomRefusal, SdoRefusal};
use crate::doctor::DoctorRefusal;
use crate::guard::GuardRefusal;
use crate::identify::IdentifyRefusal;
use crate::live::LiveRefusal;
use crate::scan::ScanRefusal;
use crate::transfer::TransferRefusal;
use crate::upload::UploadRefusal;

impl Serialize for Refusal {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Refusal::Guard(r) => r.serialize(s),
            Refusal::Lustbus(r) => r.serialize(s),
            Refusal::Live(r) => r.serialize(s),
            Refusal::Upload(r) => r.serialize(s),
            Refusal::Transfer(r) => r.serialize(s),
            Refusal::Address(r) => r.serialize(s),
            Refusal::Lecom(r) => r.serialize(s),
            Refusal::Sdo(r) => r.serialize(s),
            Refusal::Identify(r) => r.serialize(s),
            Refusal::Scan(r) => r.serialize(s),
            Refusal::Doctor(r) => r.serialize(s),
            flat => Refusal::serialize(flat, s),
        }
    }
}

impl<'de> Deserialize<'de> for Refusal {
    /// The `kind` says whose the rule is; the enum that holds it reads the
    /// rest (its errors as they were: an unknown kind, a field of the
    /// wrong type, an address that is a drive's own).
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut value = Value::deserialize(d)?;
        // the tag: the object's `kind`, or a sequence's first item (both
        // as internally tagged enums read them)
        let tag = match &mut value {
            Value::Object(map) => match map.get_mut("kind") {
                Some(tag) => Some(tag),
                None => return Err(D::Error::missing_field("kind")),
            },
            Value::Array(items) => items.first_mut(),
            _ => None,
        };
        let Some(tag) = tag else {
            return Refusal::deserialize(value).map_err(D::Error::custom);
        };
        let kind = match tag.as_u64() {
            Some(index) => Kind::deserialize(index.into_deserializer()),
            None => Kind::deserialize(&*tag).map_err(ValueError::custom),
        }
        .map_err(D::Error::custom)?;
        // by its name, which the enum that holds it knows (a kind given by
        // its index reads as the same kind)
        *tag = Value::from(kind.name());
        match kind.room() {
            Room::Flat => Refusal::deserialize(value),
            Room::Guard => GuardRefusal::deserialize(value).map(Refusal::Guard),
            Room::Lustbus => LustbusRefusal::deserialize(value).map(Refusal::Lustbus),
            Room::Live => LiveRefusal::deserialize(value).map(Refusal::Live),
            Room::Upload => UploadRefusal::deserialize(value).map(Refusal::Upload),
            Room::Transfer => TransferRefusal::deserialize(value).map(Refusal::Transfer),
            Room::Address => AddressRefused::deserialize(value).map(Refusal::Address),
            Room::Lecom => LecomRefusal::deserialize(value).map(Refusal::Lecom),
            Room::Sdo => SdoRefusal::deserialize(value).map(Refusal::Sdo),
            Room::Identify => IdentifyRefusal::deserialize(value).map(Refusal::Identify),
            Room::Scan => ScanRefusal::deserialize(value).map(Refusal::Scan),
            Room::Doctor => DoctorRefusal::deserialize(value).map(Refusal::Doctor),
        }
        .map_err(D::Error::custom)
    }
}

/// Whose a kind is: `Refusal`'s flat variants or a sub-enum's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Room {
    Flat,
    Guard,
    Lustbus,
    Live,
    Upload,
    Transfer,
    Address,
    Lecom,
    Sdo,
    Identify,
    Scan,
    Doctor,
}

/// Every refusal kind journals hold, in the order an unknown kind's error
/// has always listed them (and a kind's index has always counted).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case", variant_identifier)]
enum Kind {
    Plan,
    UnknownCode,
    ReadOnly,
    NoDatasetHandshake,
    Broadcast,
    BroadcastNotStaged,
    StepOutOfOrder,
    GuardCommand,
    GuardControlWord,
    GuardPermit,
    LustbusOnCan,
    WrongClient,
    LinkMisfit,
    LecomAddress,
    LecomGroup,
    LecomUnaddressable,
    LecomValue,
    Encode,
    SdoNode,
    NoSdoIndex,
    NotSdoType,
    NotCanFormat,
    LustbusAddress,
    LustbusCode,
    NoWireType,
    NotInteger,
    DoesNotFit,
    NotCardWriteable,
    Vf1000NoDataset,
    NoDatasetOpen,
    StextMcOnly,
    NoSload,
    SetSchema,
    CodesNotInSchema,
    Diff,
    WrongType,
    ScanLustbusAddress,
    ScanLecomAddress,
    ScanCanNode,
    NoProbeCode,
    DoctorLustbusAddress,
    DoctorLecomAddress,
    DoctorCanPort,
    TransferRate,
    Assign,
    GuardRunning,
    GuardRunningUnknown,
}

impl Kind {
    /// The kind as journals spell it: its variant's name in snake case, as
    /// `rename_all` spells it.
    fn name(self) -> String {
        let mut name = String::new();
        for (i, c) in format!("{self:?}").chars().enumerate() {
            if c.is_uppercase() && i > 0 {
                name.push('_');
            }
            name.push(c.to_ascii_lowercase());
        }
        name
    }

    /// Whose the kind is.
    fn room(self) -> Room {
        match self {
            Kind::GuardCommand
            | Kind::GuardControlWord
            | Kind::GuardPermit
            | Kind::GuardRunning
            | Kind::GuardRunningUnknown => Room::Guard,
            Kind::Broadcast
            | Kind::LustbusCode
            | Kind::NoWireType
            | Kind::NotInteger
            | Kind::DoesNotFit
            | Kind::NotCardWriteable
            | Kind::Vf1000NoDataset
            | Kind::NoDatasetOpen
            | Kind::StextMcOnly
            | Kind::NoSload => Room::Lustbus,
            Kind::SetSchema | Kind::CodesNotInSchema | Kind::Diff => Room::Live,
            Kind::BroadcastNotStaged | Kind::StepOutOfOrder => Room::Upload,
            Kind::TransferRate => Room::Transfer,
            Kind::LecomAddress
            | Kind::SdoNode
            | Kind::LustbusAddress
            | Kind::ScanLustbusAddress
            | Kind::ScanLecomAddress
            | Kind::ScanCanNode
            | Kind::DoctorLustbusAddress
            | Kind::DoctorLecomAddress => Room::Address,
            Kind::LecomGroup | Kind::LecomUnaddressable | Kind::LecomValue => Room::Lecom,
            Kind::NoSdoIndex | Kind::NotSdoType | Kind::NotCanFormat => Room::Sdo,
            Kind::WrongType => Room::Identify,
            Kind::NoProbeCode => Room::Scan,
            Kind::DoctorCanPort => Room::Doctor,
            Kind::Plan
            | Kind::UnknownCode
            | Kind::ReadOnly
            | Kind::NoDatasetHandshake
            | Kind::LustbusOnCan
            | Kind::WrongClient
            | Kind::LinkMisfit
            | Kind::Encode
            | Kind::Assign => Room::Flat,
        }
    }
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;
    use serde::de::IntoDeserializer;
    use serde::de::value::Error;

    use super::Kind;

    /// Every kind's name is the one its `rename_all` reads, by index.
    #[test]
    fn every_kind_s_name_reads_back_as_that_kind() {
        let mut index = 0u64;
        while let Ok(kind) = Kind::deserialize(IntoDeserializer::<Error>::into_deserializer(index))
        {
            let by_name = Kind::deserialize(IntoDeserializer::<Error>::into_deserializer(
                kind.name().as_str(),
            ));
            assert_eq!(by_name, Ok(kind), "{}", kind.name());
            index += 1;
        }
        assert_eq!(index, 47);
    }
}
