//! The typed [`Refusal`]s: why an operation was refused before anything
//! was sent (a safety rule, or input the engine cannot carry out), with
//! their messages (`Display`) and their JSON form (`kind` tagged, as
//! journals record them), and the small type they carry ([`LinkKind`]).

use std::fmt;

use serde::{Deserialize, Serialize};

use super::address::AddressRefused;
use crate::client::lustbus::LustbusRefusal;
use crate::client::{LecomRefusal, SdoRefusal};
use crate::doctor::DoctorRefusal;
use crate::guard::GuardRefusal;
use crate::identify::IdentifyRefusal;
use crate::live::LiveRefusal;
use crate::plan::Problem;
use crate::scan::ScanRefusal;
use crate::transfer::TransferRefusal;
use crate::upload::UploadRefusal;

/// How a refusal names a client's protocol: `LUSTBUS`, `LECOM`, `CAN SDO`.
pub(super) fn protocol_label(p: driveset_schema::BusProtocol) -> &'static str {
    match p {
        driveset_schema::BusProtocol::Lustbus => "LUSTBUS",
        driveset_schema::BusProtocol::Lecom => "LECOM",
        driveset_schema::BusProtocol::CanSdo => "CAN SDO",
    }
}

/// The kind of link a port opened ([`Refusal::LinkMisfit`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkKind {
    /// A byte stream (serial line, TCP, RFC 2217).
    CharacterLine,
    /// CAN frames.
    CanBus,
}

impl fmt::Display for LinkKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LinkKind::CharacterLine => "a character line",
            LinkKind::CanBus => "a CAN bus",
        })
    }
}

/// Why an operation was refused before anything was sent (a safety rule,
/// or input the engine cannot carry out). Codes are named as humans spell
/// them (`C0011`, `428-RSIO`); values as the client shows them (passwords
/// never shown).
///
/// The rules one room raises are its own sub-enum beside it, gathered here
/// by `From`: the write guard's ([`GuardRefusal`]), the LUSTBUS client's
/// ([`LustbusRefusal`]), the LECOM and SDO clients' ([`LecomRefusal`],
/// [`SdoRefusal`]), the live diff's ([`LiveRefusal`]), the transaction's ([`UploadRefusal`]), `--transfer-baud`'s
/// ([`TransferRefusal`]), `driveset address`'s
/// ([`crate::assign::AssignRefusal`]), identify's family check
/// ([`IdentifyRefusal`]), a scan's ([`ScanRefusal`]), `doctor`'s
/// ([`DoctorRefusal`]) and the one address rule
/// ([`AddressRefused`]); the rules several rooms raise stay flat here.
///
/// Its JSON form (journals) is one flat list of `kind`s, whichever enum
/// holds the rule (`form.rs`): the flat variants' is derived here
/// (`remote = "Self"`: the inherent `Refusal::serialize` /
/// `Refusal::deserialize` that `form.rs`'s trait impls call, which know
/// only the flat variants; read and write a refusal through serde's traits,
/// `serde_json::from_str` ...), each sub-enum's beside it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(
    remote = "Self",
    tag = "kind",
    rename_all = "snake_case",
    expecting = "internally tagged enum RefusalForm"
)]
pub enum Refusal {
    /// The planner's (or the set check's) problems, every one found
    /// ([`crate::plan::check_set`], [`crate::plan::plan`]).
    #[error("{}", Problems(.problems))]
    Plan {
        /// One or more problems.
        problems: Vec<Problem>,
    },
    /// A code the client's schema does not know.
    #[error("schema `{schema}` has no code {code}; check the set names the right drive family")]
    UnknownCode {
        /// Schema id.
        schema: String,
        /// The code.
        code: String,
    },
    /// A write of a code the schema marks read-only.
    #[error("{code} is read-only in schema `{schema}`; remove it from the set")]
    ReadOnly {
        /// The code.
        code: String,
        /// Schema id.
        schema: String,
    },
    /// The family has no dataset download handshake (only MC6000/7000 do).
    #[error("this drive family has no dataset download handshake")]
    NoDatasetHandshake,
    /// A LUSTBUS drive listed on a CAN bus.
    #[error("a LUSTBUS drive on a CAN bus")]
    LustbusOnCan,
    /// The client of one protocol was given a schema of another.
    #[error(
        "schema `{schema}` is not a {} family ({family} drives); pick the client of its protocol",
        protocol_label(*.protocol)
    )]
    WrongClient {
        /// Schema id.
        schema: String,
        /// The schema's family.
        family: String,
        /// The client's protocol.
        protocol: driveset_schema::BusProtocol,
    },
    /// The port opened a link the schema's protocol does not run on.
    #[error("schema `{schema}` is for {family} drives ({bus}), which do not run on {link}")]
    LinkMisfit {
        /// Schema id.
        schema: String,
        /// The schema's family.
        family: String,
        /// The family's bus, as its title reads.
        bus: String,
        /// What the port opened.
        link: LinkKind,
    },
    /// The codec could not build the telegram (or the SDO transfer).
    #[error("{}", Named(.what.as_deref(), .detail))]
    Encode {
        /// The operation, where named.
        what: Option<String>,
        /// What the codec said.
        detail: String,
    },
    /// `identify`'s family check refused the drive ([`crate::identify`]).
    #[error(transparent)]
    #[serde(skip)]
    Identify(#[from] IdentifyRefusal),
    /// A scan refused before probing ([`crate::scan`]).
    #[error(transparent)]
    #[serde(skip)]
    Scan(#[from] ScanRefusal),
    /// `doctor` refused a port ([`crate::doctor`]).
    #[error(transparent)]
    #[serde(skip)]
    Doctor(#[from] DoctorRefusal),
    /// The write guard refused ([`crate::guard`]).
    #[error(transparent)]
    #[serde(skip)]
    Guard(#[from] GuardRefusal),
    /// What the LUSTBUS client cannot (or will not now) send.
    #[error(transparent)]
    #[serde(skip)]
    Lustbus(#[from] LustbusRefusal),
    /// The transaction refused a step ([`crate::upload`]).
    #[error(transparent)]
    #[serde(skip)]
    Upload(#[from] UploadRefusal),
    /// A live diff refused ([`crate::live`]).
    #[error(transparent)]
    #[serde(skip)]
    Live(#[from] LiveRefusal),
    /// `--transfer-baud` cannot be used here ([`crate::transfer`]).
    #[error(transparent)]
    #[serde(skip)]
    Transfer(#[from] TransferRefusal),
    /// `driveset address` refused before writing ([`crate::assign`]).
    #[error("{refusal}")]
    Assign {
        /// Which rule and what to do.
        #[serde(flatten)]
        refusal: crate::assign::AssignRefusal,
    },
    /// An address that is no drive's own ([`AddressRefused`]: the schema's
    /// rule, [`driveset_schema::BusProtocol::check_address`], and what was
    /// being done).
    #[error("{0}")]
    #[serde(skip)]
    Address(AddressRefused),
    /// What the LECOM client cannot send ([`LecomRefusal`]).
    #[error("{0}")]
    #[serde(skip)]
    Lecom(LecomRefusal),
    /// What the CAN SDO client cannot transfer ([`SdoRefusal`]).
    #[error("{0}")]
    #[serde(skip)]
    Sdo(SdoRefusal),
}

impl From<crate::assign::AssignRefusal> for Refusal {
    fn from(refusal: crate::assign::AssignRefusal) -> Self {
        Refusal::Assign { refusal }
    }
}

/// [`Refusal::Plan`]'s message: the one problem, or their count and each.
struct Problems<'a>(&'a [Problem]);

impl fmt::Display for Problems<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let [one] = self.0 {
            return write!(f, "{one}");
        }
        write!(f, "{} problems: ", self.0.len())?;
        for (i, p) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            write!(f, "{p}")?;
        }
        Ok(())
    }
}

/// [`Refusal::Encode`]'s message: the operation, where named, and what the
/// codec said.
struct Named<'a>(Option<&'a str>, &'a str);

impl fmt::Display for Named<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(what) => write!(f, "{what}: {}", self.1),
            None => f.write_str(self.1),
        }
    }
}
