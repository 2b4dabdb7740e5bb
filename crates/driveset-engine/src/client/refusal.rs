//! The refusals the clients raise themselves, beside the clients: what a
//! LECOM telegram (`lecom-ab-tmd-manual.txt`, sections 8.D and 8.J) or a
//! CAN SDO transfer (DS301) cannot carry, found before anything is sent.
//! Each is gathered into [`Refusal`] by `From` (`Refusal::Lecom`,
//! `Refusal::Sdo`), renders its message through `Display`, and keeps the
//! JSON kind journals hold (`lecom_group`, `no_sdo_index` ...).

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::error::Refusal;

/// What the LECOM client cannot send (sections 8.D and 8.J).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind")]
pub enum LecomRefusal {
    /// A MULTICAST group that does not exist (section 8.J: groups 1..9,
    /// addresses 10..90).
    #[serde(rename = "lecom_group")]
    Group {
        /// The tens digit given.
        tens: u8,
    },
    /// A code LECOM cannot address (section 8.D: code up to 65535,
    /// subcode up to 255).
    #[serde(rename = "lecom_unaddressable")]
    Unaddressable {
        /// The code.
        code: String,
    },
    /// A value the schema's LECOM format cannot carry.
    #[serde(rename = "lecom_value")]
    Value {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
        /// What the codec said.
        detail: String,
    },
}

impl fmt::Display for LecomRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LecomRefusal::Group { tens } => write!(
                f,
                "group {tens} does not exist: groups are 1..9 (addresses 10..90, section 8.J)"
            ),
            LecomRefusal::Unaddressable { code } => write!(
                f,
                "{code} cannot be addressed on LECOM (code above 65535 or subcode above 255, section 8.D)"
            ),
            LecomRefusal::Value {
                code,
                value,
                detail,
            } => write!(f, "{code} = {value}: {detail}"),
        }
    }
}

impl From<LecomRefusal> for Refusal {
    fn from(refusal: LecomRefusal) -> Self {
        Refusal::Lecom(refusal)
    }
}

/// What the CAN SDO client cannot transfer (DS301).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind")]
pub enum SdoRefusal {
    /// A code with no SDO index (above the schema's index base, or a
    /// subcode above 255).
    #[serde(rename = "no_sdo_index")]
    NoIndex {
        /// The code.
        code: String,
        /// The index base in use.
        base: u32,
    },
    /// A type that does not travel over CAN SDO.
    #[serde(rename = "not_sdo_type")]
    NotSdoType {
        /// The code.
        code: String,
        /// The type's name (`?` when the schema gives none).
        ty: String,
    },
    /// A value that does not fit the code's CAN format.
    #[serde(rename = "not_can_format")]
    NotCanFormat {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
    },
}

impl fmt::Display for SdoRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SdoRefusal::NoIndex { code, base } => write!(
                f,
                "{code} has no SDO index (code above the index base {base} or subcode above 255)"
            ),
            SdoRefusal::NotSdoType { code, ty } => {
                write!(f, "{code}: type {ty} does not travel over CAN SDO")
            }
            SdoRefusal::NotCanFormat { code, value } => {
                write!(f, "{code} = {value} does not fit its CAN format")
            }
        }
    }
}

impl From<SdoRefusal> for Refusal {
    fn from(refusal: SdoRefusal) -> Self {
        Refusal::Sdo(refusal)
    }
}
