//! The typed [`Refusal`]s: why an operation was refused before anything
//! was sent (a safety rule, or input the engine cannot carry out), with
//! their messages (`Display`) and their JSON form (`kind` tagged, as
//! journals record them), and the small types they carry ([`LinkKind`],
//! [`LustbusCodeProblem`]).

use std::fmt;

use serde::{Deserialize, Serialize};

use super::address::AddressRefused;
use super::form::RefusalForm;
use crate::client::{LecomRefusal, SdoRefusal};
use crate::plan::Problem;

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

/// Why a LUSTBUS code has no CODE field ([`Refusal::LustbusCode`],
/// sections 2.4.1 and 2.4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LustbusCodeProblem {
    /// A subcode: LUSTBUS parameters have none.
    HasSubcode,
    /// A compatible parameter number the codec cannot address.
    NotAddressable,
    /// Above 99 on a VF1000.
    AboveVf1000Range,
    /// Above 999 on an MC6000/7000.
    AboveMcRange,
}

impl fmt::Display for LustbusCodeProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LustbusCodeProblem::HasSubcode => {
                "has a subcode; LUSTBUS parameters have none (check the schema)"
            }
            LustbusCodeProblem::NotAddressable => "cannot be addressed",
            LustbusCodeProblem::AboveVf1000Range => "is above 99, the VF1000 range (section 2.4.1)",
            LustbusCodeProblem::AboveMcRange => {
                "is above 999, the MC6000/7000 range (section 2.4.2)"
            }
        })
    }
}

/// Why an operation was refused before anything was sent (a safety rule,
/// or input the engine cannot carry out). Codes are named as humans spell
/// them (`C0011`, `428-RSIO`); values as the client shows them (passwords
/// never shown).
///
/// Its JSON form (journals) is `RefusalForm`'s (`form.rs`), one `kind` per rule.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(into = "RefusalForm", try_from = "RefusalForm")]
pub enum Refusal {
    /// The planner's (or the set check's) problems, every one found
    /// ([`crate::plan::check_set`], [`crate::plan::plan`]).
    Plan {
        /// One or more problems.
        problems: Vec<Problem>,
    },
    /// A code the client's schema does not know.
    UnknownCode {
        /// Schema id.
        schema: String,
        /// The code.
        code: String,
    },
    /// A write of a code the schema marks read-only.
    ReadOnly {
        /// The code.
        code: String,
        /// Schema id.
        schema: String,
    },
    /// The family has no dataset download handshake (only MC6000/7000 do).
    NoDatasetHandshake,
    /// A LUSTBUS broadcast (address 31, section 4.2) the client will not send.
    Broadcast {
        /// The code.
        code: String,
        /// Why not.
        why: String,
    },
    /// Broadcast values a drive's dataset does not stage.
    BroadcastNotStaged {
        /// The codes.
        codes: Vec<String>,
    },
    /// A transaction step called out of order (a caller's mistake).
    StepOutOfOrder {
        /// The step called.
        step: String,
        /// The step that must come first.
        before: String,
    },
    /// The write guard ([`crate::guard`]): a command, whatever asked for it
    /// (only the engine's own named operations pass, with their permit).
    GuardCommand {
        /// The code.
        code: String,
        /// The value (never a password's).
        value: String,
    },
    /// The write guard: a control word value that is not a stopped or
    /// inhibited state (it would start, enable or release the drive, or is
    /// a reset command), whatever asked for it.
    GuardControlWord {
        /// The code.
        code: String,
        /// The value.
        value: String,
        /// The state the value puts the drive in.
        why: String,
    },
    /// The write guard: a permit used for a code or value it does not name
    /// (a caller's mistake; nothing is sent).
    GuardPermit {
        /// The permit's name.
        permit: String,
        /// The code.
        code: String,
        /// The value.
        value: String,
    },
    /// A LUSTBUS drive listed on a CAN bus.
    LustbusOnCan,
    /// The client of one protocol was given a schema of another.
    WrongClient {
        /// Schema id.
        schema: String,
        /// The schema's family.
        family: String,
        /// The client's protocol.
        protocol: driveset_schema::BusProtocol,
    },
    /// The port opened a link the schema's protocol does not run on.
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
    Encode {
        /// The operation, where named.
        what: Option<String>,
        /// What the codec said.
        detail: String,
    },
    /// A code LUSTBUS cannot address.
    LustbusCode {
        /// The code.
        code: String,
        /// Why.
        problem: LustbusCodeProblem,
    },
    /// The schema gives no LUSTBUS type or width for a written code.
    NoWireType {
        /// The code.
        code: String,
        /// Schema id.
        schema: String,
        /// The family.
        family: String,
    },
    /// A LUSTBUS value that is not an integer.
    NotInteger {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
    },
    /// A value that does not fit the code's LUSTBUS type.
    DoesNotFit {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
        /// The type's name.
        ty: String,
    },
    /// A code that is not CardWriteable, written during a dataset download
    /// (section 11.4).
    NotCardWriteable {
        /// The code.
        code: String,
    },
    /// The VF1000 has no SLOAD handshake (section 11.4).
    Vf1000NoDataset,
    /// A dataset write or commit without an open download.
    NoDatasetOpen,
    /// 108-STEXT on a drive other than an MC6000/7000 (section 11.3).
    StextMcOnly,
    /// The schema lacks 80-SLOAD.
    NoSload {
        /// Schema id.
        schema: String,
    },
    /// A live diff of a set of another schema.
    SetSchema {
        /// The set's schema.
        set: String,
        /// The client's schema.
        schema: String,
    },
    /// A live diff of codes the schema does not know.
    CodesNotInSchema {
        /// Schema id.
        schema: String,
        /// The codes.
        codes: Vec<String>,
    },
    /// The diff itself refused (schemas differ).
    Diff {
        /// What the diff said.
        detail: String,
    },
    /// The drive's TYPE is not one of the schema's (LUSTBUS 91-TYPE).
    WrongType {
        /// The TYPE code as the schema spells it.
        code: String,
        /// What the drive reported (`None`: nothing readable).
        found: Option<i64>,
        /// Schema id.
        schema: String,
        /// The schema's TYPE values.
        expected: Vec<i64>,
    },
    /// A schema with no code to probe a CAN scan with.
    NoProbeCode {
        /// Schema id.
        schema: String,
    },
    /// `doctor`: a CAN port given to the character-line check.
    DoctorCanPort,
    /// `--transfer-baud` cannot be used here (another family, a rate the
    /// drive does not run at, a port that cannot change its rate, a
    /// running drive, a shared bus without its override): what and what
    /// to do, as [`crate::transfer`] words it.
    TransferRate {
        /// The reason and the remedy.
        detail: String,
    },
    /// `driveset address` refused before writing ([`crate::assign`]).
    Assign {
        /// Which rule and what to do.
        #[serde(flatten)]
        refusal: crate::assign::AssignRefusal,
    },
    /// An address that is no drive's own ([`AddressRefused`]: the schema's
    /// rule, [`driveset_schema::BusProtocol::check_address`], and what was
    /// being done).
    Address(AddressRefused),
    /// What the LECOM client cannot send ([`LecomRefusal`]).
    Lecom(LecomRefusal),
    /// What the CAN SDO client cannot transfer ([`SdoRefusal`]).
    Sdo(SdoRefusal),
}

impl From<crate::assign::AssignRefusal> for Refusal {
    fn from(refusal: crate::assign::AssignRefusal) -> Self {
        Refusal::Assign { refusal }
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Plan { problems } => {
                if problems.len() == 1 {
                    write!(f, "{}", problems[0])
                } else {
                    write!(f, "{} problems: ", problems.len())?;
                    for (i, p) in problems.iter().enumerate() {
                        if i > 0 {
                            f.write_str("; ")?;
                        }
                        write!(f, "{p}")?;
                    }
                    Ok(())
                }
            }
            Refusal::UnknownCode { schema, code } => write!(
                f,
                "schema `{schema}` has no code {code}; check the set names the right drive family"
            ),
            Refusal::ReadOnly { code, schema } => write!(
                f,
                "{code} is read-only in schema `{schema}`; remove it from the set"
            ),
            Refusal::NoDatasetHandshake => {
                f.write_str("this drive family has no dataset download handshake")
            }
            Refusal::Broadcast { code, why } => {
                write!(f, "broadcast (address 31) of {code}: {why}")
            }
            Refusal::BroadcastNotStaged { codes } => write!(
                f,
                "broadcast of {} refused: not a value this drive's dataset stages",
                codes.join(", ")
            ),
            Refusal::StepOutOfOrder { step, before } => {
                write!(f, "transaction step `{step}` called before `{before}`")
            }
            Refusal::LustbusOnCan => f.write_str("a LUSTBUS drive on a CAN bus"),
            Refusal::WrongClient {
                schema,
                family,
                protocol,
            } => write!(
                f,
                "schema `{schema}` is not a {} family ({family} drives); pick the client of its protocol",
                protocol_label(*protocol)
            ),
            Refusal::LinkMisfit {
                schema,
                family,
                bus,
                link,
            } => write!(
                f,
                "schema `{schema}` is for {family} drives ({bus}), which do not run on {link}"
            ),
            Refusal::Encode { what, detail } => match what {
                Some(w) => write!(f, "{w}: {detail}"),
                None => f.write_str(detail),
            },
            Refusal::LustbusCode { code, problem } => write!(f, "{code} {problem}"),
            Refusal::NoWireType {
                code,
                schema,
                family,
            } => write!(
                f,
                "{code}: schema `{schema}` gives no {family} type or width, so the value cannot be encoded; add `type` to the schema"
            ),
            Refusal::NotInteger { code, value } => {
                write!(f, "{code}: LUSTBUS parameters hold integers, not {value}")
            }
            Refusal::DoesNotFit { code, value, ty } => {
                write!(f, "{code}: {value} does not fit {ty}")
            }
            Refusal::GuardCommand { code, value } => write!(
                f,
                "{code} = {value} is a command: driveset never writes one (only its own named steps: the SLOAD handshake, PROG = 111 activating a rate); run it on the drive itself"
            ),
            Refusal::GuardControlWord { code, value, why } => write!(
                f,
                "{code} = {value} {why}: driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control"
            ),
            Refusal::GuardPermit {
                permit,
                code,
                value,
            } => write!(
                f,
                "the {permit} permit does not cover {code} = {value}; nothing was sent"
            ),
            Refusal::NotCardWriteable { code } => write!(
                f,
                "{code} is not CardWriteable: during a dataset download the drive ACKs it but does not take the value (section 11.4); write it after dataset_commit"
            ),
            Refusal::Vf1000NoDataset => f.write_str(
                "the VF1000 has no dataset download handshake (SLOAD is MC6000/7000 only, section 11.4)",
            ),
            Refusal::NoDatasetOpen => {
                f.write_str("no dataset download is open; call dataset_begin first")
            }
            Refusal::StextMcOnly => {
                f.write_str("108-STEXT substitution texts are MC6000/7000 only (section 11.3)")
            }
            Refusal::NoSload { schema } => write!(
                f,
                "schema `{schema}` has no 80-SLOAD; the dataset download needs it"
            ),
            Refusal::SetSchema { set, schema } => write!(
                f,
                "the set is for schema `{set}`, the drive is read with schema `{schema}`; compare a set of this drive family"
            ),
            Refusal::CodesNotInSchema { schema, codes } => write!(
                f,
                "codes not in schema `{schema}`: {}; remove them from the set",
                codes.join(", ")
            ),
            Refusal::Diff { detail } => f.write_str(detail),
            Refusal::WrongType {
                code,
                found,
                schema,
                expected,
            } => write!(
                f,
                "the drive reports {code} = {}, which is not a `{schema}` type ({expected:?}); use the set and schema of the drive's family",
                found.map_or_else(|| "nothing".to_string(), |t| t.to_string()),
            ),
            Refusal::NoProbeCode { schema } => {
                write!(f, "schema `{schema}` has no code to probe with")
            }
            Refusal::DoctorCanPort => f.write_str("CAN ports are checked by run_can"),
            Refusal::TransferRate { detail } => f.write_str(detail),
            Refusal::Assign { refusal } => write!(f, "{refusal}"),
            Refusal::Address(refused) => write!(f, "{refused}"),
            Refusal::Lecom(refusal) => write!(f, "{refusal}"),
            Refusal::Sdo(refusal) => write!(f, "{refusal}"),
        }
    }
}
