//! Owns the `serde` forms of proto's types (feature `serde`): each is the
//! raw number the drive sent or the telegram carried, so a journal or a
//! report holds what was on the wire and reads back to the same value.
//!
//! - [`lustbus::Siof`]: the 85-SIOF/SERR byte (`lustbus-protocol.txt` §9.2).
//! - [`lecom::OperatingStatus`]: the C0068 word, [`lecom::ExtendedError`]
//!   the C1962 code (`lecom-ab-tmd-manual.txt` Table 1, §8.J).
//! - [`can::AbortCode`], [`can::Index`], [`can::Subindex`]: the SDO abort
//!   code and the object it names (`lenze-system-bus-can-sdo.txt`, DS301
//!   table 22).

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::{can, lecom, lustbus};

/// A newtype over an unsigned integer, serialised as that integer.
macro_rules! as_number {
    ($ty:ty, $raw:ty) => {
        impl Serialize for $ty {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                self.0.serialize(s)
            }
        }

        impl<'de> Deserialize<'de> for $ty {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                <$raw>::deserialize(d).map(Self)
            }
        }
    };
}

as_number!(lustbus::Siof, u8);
as_number!(lecom::OperatingStatus, u16);
as_number!(can::AbortCode, u32);
as_number!(can::Index, u16);
as_number!(can::Subindex, u8);

impl Serialize for lecom::ExtendedError {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u32(self.code())
    }
}

impl<'de> Deserialize<'de> for lecom::ExtendedError {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        u32::deserialize(d).map(Self::from_code)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip<T>(v: T, json: &str)
    where
        T: Serialize + for<'de> Deserialize<'de> + PartialEq + core::fmt::Debug,
    {
        assert_eq!(serde_json::to_string(&v).expect("serialises"), json);
        assert_eq!(serde_json::from_str::<T>(json).expect("reads back"), v);
    }

    #[test]
    fn every_type_is_its_raw_number() {
        round_trip(lustbus::Siof(0x84), "132");
        round_trip(lecom::OperatingStatus(0x0050), "80");
        round_trip(lecom::ExtendedError::from_code(212), "212");
        round_trip(lecom::ExtendedError::Undocumented(77), "77");
        round_trip(can::AbortCode(0x0601_0002), "100728834");
        round_trip(can::Index(0x4C6D), "19565");
        round_trip(can::Subindex(3), "3");
        assert!(serde_json::from_str::<can::Subindex>("256").is_err());
    }
}
