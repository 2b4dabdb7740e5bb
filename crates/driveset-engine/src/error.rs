//! The engine's errors: what failed, on which bus, address and code, and
//! what to do. Owns [`EngineError`] (a target and a boxed [`ErrorKind`], so
//! a `Result<_, EngineError>` stays small), the typed [`Refusal`]s (a
//! safety or input rule said no before anything was sent), and the typed
//! [`DeviceCause`]s (what a drive itself said: LUSTBUS SIOF/SERR bits,
//! section 9.2; LECOM C0068 bits 4..7 and C1962, Table 1 and section 8.J c;
//! SDO abort codes, DS301 table 22), kept apart from transport failures.
//! Every variant renders the message the CLI prints through `Display`.

use std::fmt;

use driveset_link::LinkError;
use driveset_proto::can::{AbortCode, Index, NodeIdError, Subindex};
use driveset_proto::lecom::{CommunicationError, ExtendedError, OperatingStatus};
use driveset_proto::lustbus::Siof;
use serde::{Deserialize, Serialize};

use crate::client::Target;
use crate::plan::Problem;

/// Every way an engine operation fails: where ([`EngineError::target`]) and
/// what ([`EngineError::kind`], boxed).
#[derive(Debug)]
pub struct EngineError {
    /// The drive (port and bus address); `None` for a failure that is not
    /// about one drive (a journal file that cannot be read).
    pub target: Option<Target>,
    /// What failed.
    pub kind: Box<ErrorKind>,
}

/// What failed ([`EngineError::kind`]).
#[derive(Debug)]
pub enum ErrorKind {
    /// The transport failed (port gone, connection reset ...).
    Link(LinkError),
    /// No (valid) answer after every retry.
    NoAnswer {
        /// The operation (`read C0011`, `write 428-RSIO` ...).
        what: String,
        /// How many times it was sent.
        tries: u32,
    },
    /// The drive refused an operation and said why.
    Device {
        /// The operation.
        what: String,
        /// The drive's own cause.
        cause: DeviceCause,
    },
    /// The drive restarted (power-on indication) in the middle of the work:
    /// whatever was written since the last verified point is void.
    Restarted {
        /// The operation during which it was noticed.
        what: String,
    },
    /// A safety or input rule refused the operation before anything was sent.
    Refused(Refusal),
    /// A transaction journal could not be written or read (nothing further
    /// is sent to the drive while its backup is not safely on disk).
    Journal {
        /// The journal file.
        path: String,
        /// What failed and what to do.
        detail: String,
    },
    /// An upload did not land and was rolled back: the drive holds its old
    /// values again (read back and compared).
    RolledBack {
        /// The journal file.
        journal: String,
        /// Why it did not land (code, cause; passwords never shown).
        detail: String,
        /// The failure that started the roll back.
        cause: EngineError,
    },
    /// An upload (or a recovery) failed and the drive could not be brought
    /// back to either the old or the new set: it holds a mix. The backup is
    /// in the journal.
    Inconsistent {
        /// The journal file.
        journal: String,
        /// Which codes hold what, and the failure.
        detail: String,
    },
    /// `recover` refused a journal: the drive it reaches is not the drive
    /// the journal was written for, or a planned code holds neither its old
    /// nor its new value. Nothing was written (for `Version`, `Schema`,
    /// `Bus` and `Address` nothing was sent at all).
    NotJournalDrive {
        /// The journal file.
        journal: String,
        /// What did not match.
        mismatch: Mismatch,
        /// What differs and what to do.
        detail: String,
    },
    /// The drive's answer could not be understood.
    Protocol {
        /// The operation.
        what: String,
        /// What was wrong with the answer.
        detail: String,
    },
}

impl EngineError {
    /// An error about the drive at `target`.
    pub fn new(target: Target, kind: ErrorKind) -> Self {
        EngineError {
            target: Some(target),
            kind: Box::new(kind),
        }
    }

    /// [`ErrorKind::Refused`].
    pub fn refused(target: Target, refusal: Refusal) -> Self {
        Self::new(target, ErrorKind::Refused(refusal))
    }

    /// [`ErrorKind::Link`].
    pub fn link(target: Target, source: LinkError) -> Self {
        Self::new(target, ErrorKind::Link(source))
    }

    /// [`ErrorKind::Device`].
    pub fn device(target: Target, what: impl Into<String>, cause: DeviceCause) -> Self {
        Self::new(
            target,
            ErrorKind::Device {
                what: what.into(),
                cause,
            },
        )
    }

    /// [`ErrorKind::NoAnswer`].
    pub fn no_answer(target: Target, what: impl Into<String>, tries: u32) -> Self {
        Self::new(
            target,
            ErrorKind::NoAnswer {
                what: what.into(),
                tries,
            },
        )
    }

    /// [`ErrorKind::Restarted`].
    pub fn restarted(target: Target, what: impl Into<String>) -> Self {
        Self::new(target, ErrorKind::Restarted { what: what.into() })
    }

    /// [`ErrorKind::Protocol`].
    pub fn protocol(target: Target, what: impl Into<String>, detail: impl Into<String>) -> Self {
        Self::new(
            target,
            ErrorKind::Protocol {
                what: what.into(),
                detail: detail.into(),
            },
        )
    }

    /// [`ErrorKind::Journal`]: no drive is named.
    pub fn journal(path: impl Into<String>, detail: impl Into<String>) -> Self {
        EngineError {
            target: None,
            kind: Box::new(ErrorKind::Journal {
                path: path.into(),
                detail: detail.into(),
            }),
        }
    }

    /// [`ErrorKind::RolledBack`].
    pub fn rolled_back(
        target: Target,
        journal: impl Into<String>,
        detail: impl Into<String>,
        cause: EngineError,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::RolledBack {
                journal: journal.into(),
                detail: detail.into(),
                cause,
            },
        )
    }

    /// [`ErrorKind::Inconsistent`].
    pub fn inconsistent(
        target: Target,
        journal: impl Into<String>,
        detail: impl Into<String>,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::Inconsistent {
                journal: journal.into(),
                detail: detail.into(),
            },
        )
    }

    /// [`ErrorKind::NotJournalDrive`].
    pub fn not_journal_drive(
        target: Target,
        journal: impl Into<String>,
        mismatch: Mismatch,
        detail: impl Into<String>,
    ) -> Self {
        Self::new(
            target,
            ErrorKind::NotJournalDrive {
                journal: journal.into(),
                mismatch,
                detail: detail.into(),
            },
        )
    }

    /// What failed.
    pub fn kind(&self) -> &ErrorKind {
        &self.kind
    }

    /// The refusal, for [`ErrorKind::Refused`].
    pub fn refusal(&self) -> Option<&Refusal> {
        match &*self.kind {
            ErrorKind::Refused(r) => Some(r),
            _ => None,
        }
    }

    /// The drive's cause, for [`ErrorKind::Device`].
    pub fn device_cause(&self) -> Option<&DeviceCause> {
        match &*self.kind {
            ErrorKind::Device { cause, .. } => Some(cause),
            _ => None,
        }
    }

    /// Whether this is [`ErrorKind::Refused`].
    pub fn is_refused(&self) -> bool {
        matches!(*self.kind, ErrorKind::Refused(_))
    }
}

impl fmt::Display for EngineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = self.target.as_ref();
        let at = |f: &mut fmt::Formatter<'_>| match t {
            Some(t) => write!(f, "{t}: "),
            None => Ok(()),
        };
        match &*self.kind {
            ErrorKind::Journal { path, detail } => write!(f, "journal {path}: {detail}"),
            kind => {
                at(f)?;
                match kind {
                    ErrorKind::Link(source) => write!(f, "{source}"),
                    ErrorKind::NoAnswer { what, tries } => write!(
                        f,
                        "no answer to {what} after {tries} tries; check wiring, address and baud rate"
                    ),
                    ErrorKind::Device { what, cause } => write!(
                        f,
                        "{what} refused: {} ({}); {}",
                        cause.cause(),
                        cause.raw(),
                        cause.remedy()
                    ),
                    ErrorKind::Restarted { what } => write!(
                        f,
                        "the drive restarted during {what} (power-on flag set); the transaction is void and must be redone"
                    ),
                    ErrorKind::Refused(reason) => write!(f, "refused: {reason}"),
                    ErrorKind::RolledBack {
                        journal, detail, ..
                    } => write!(
                        f,
                        "the upload did not land and was rolled back: {detail}; the drive holds its old values again (verified); journal {journal}"
                    ),
                    ErrorKind::Inconsistent { journal, detail } => write!(
                        f,
                        "the drive holds a mix of old and new values: {detail}; the backup is in {journal}: run `driveset recover {journal}` once the drive answers again"
                    ),
                    ErrorKind::NotJournalDrive {
                        journal, detail, ..
                    } => write!(f, "refused to recover journal {journal}: {detail}"),
                    ErrorKind::Protocol { what, detail } => {
                        write!(f, "unexpected answer to {what}: {detail}")
                    }
                    ErrorKind::Journal { .. } => Ok(()),
                }
            }
        }
    }
}

impl std::error::Error for EngineError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &*self.kind {
            ErrorKind::Link(source) => Some(source),
            ErrorKind::RolledBack { cause, .. } => Some(cause),
            _ => None,
        }
    }
}

/// Why `recover` refused a journal ([`ErrorKind::NotJournalDrive`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Mismatch {
    /// A journal version that does not record the drive's bus (1).
    Version,
    /// The client's schema is not the journal's.
    Schema,
    /// The port reaches another bus.
    Bus,
    /// Another bus address.
    Address,
    /// The drive identifies differently (identify codes, family, software).
    Identity,
    /// These planned codes hold neither their old nor their new value.
    Stale {
        /// The codes, as humans spell them.
        codes: Vec<String>,
    },
}

/// How a refusal names a client's protocol: `LUSTBUS`, `LECOM`, `CAN SDO`.
fn protocol_label(p: driveset_schema::BusProtocol) -> &'static str {
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
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
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
    /// A LECOM address that is no station (section 8.J).
    LecomAddress {
        /// The address.
        address: u8,
    },
    /// A LECOM MULTICAST group that does not exist (section 8.J).
    LecomGroup {
        /// The tens digit given.
        tens: u8,
    },
    /// A code LECOM cannot address (section 8.D).
    LecomUnaddressable {
        /// The code.
        code: String,
    },
    /// A value the schema's LECOM format cannot carry.
    LecomValue {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
        /// What the codec said.
        detail: String,
    },
    /// The codec could not build the telegram (or the SDO transfer).
    Encode {
        /// The operation, where named.
        what: Option<String>,
        /// What the codec said.
        detail: String,
    },
    /// A CAN node id that addresses no SDO server (DS301).
    SdoNode {
        /// The node id given.
        node: u32,
    },
    /// A code with no SDO index.
    NoSdoIndex {
        /// The code.
        code: String,
        /// The index base in use.
        base: u32,
    },
    /// A type that does not travel over CAN SDO.
    NotSdoType {
        /// The code.
        code: String,
        /// The type's name (`?` when the schema gives none).
        ty: String,
    },
    /// A value that does not fit the code's CAN format.
    NotCanFormat {
        /// The code.
        code: String,
        /// The value as shown.
        value: String,
    },
    /// A LUSTBUS address that is no drive address (section 4.2).
    LustbusAddress {
        /// The address.
        address: u8,
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
    /// A LUSTBUS scan target that is no single drive (section 4.2).
    ScanLustbusAddress {
        /// The address.
        address: u8,
    },
    /// A LECOM scan target that is no station (section 8.J).
    ScanLecomAddress {
        /// The address.
        address: u8,
    },
    /// A CAN scan target that is no SDO server (DS301).
    ScanCanNode {
        /// The node id given.
        node: u32,
    },
    /// A schema with no code to probe a CAN scan with.
    NoProbeCode {
        /// Schema id.
        schema: String,
    },
    /// `doctor`: a LUSTBUS address it cannot probe (section 4.1).
    DoctorLustbusAddress {
        /// The address.
        address: u8,
    },
    /// `doctor`: a LECOM address it cannot probe (section 8.J).
    DoctorLecomAddress {
        /// The address.
        address: u8,
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
            Refusal::LecomAddress { address } => write!(
                f,
                "LECOM address {address} is not a station: use 01..99 except 00 and the group addresses 10, 20, .. 90 (BROADCAST / MULTICAST, section 8.J; use broadcast() for those)"
            ),
            Refusal::LecomGroup { tens } => write!(
                f,
                "group {tens} does not exist: groups are 1..9 (addresses 10..90, section 8.J)"
            ),
            Refusal::LecomUnaddressable { code } => write!(
                f,
                "{code} cannot be addressed on LECOM (code above 65535 or subcode above 255, section 8.D)"
            ),
            Refusal::LecomValue {
                code,
                value,
                detail,
            } => write!(f, "{code} = {value}: {detail}"),
            Refusal::Encode { what, detail } => match what {
                Some(w) => write!(f, "{w}: {detail}"),
                None => f.write_str(detail),
            },
            Refusal::SdoNode { node } => write!(
                f,
                "{}: 0 addresses no SDO server (DS301)",
                NodeIdError(*node)
            ),
            Refusal::NoSdoIndex { code, base } => write!(
                f,
                "{code} has no SDO index (code above the index base {base} or subcode above 255)"
            ),
            Refusal::NotSdoType { code, ty } => {
                write!(f, "{code}: type {ty} does not travel over CAN SDO")
            }
            Refusal::NotCanFormat { code, value } => {
                write!(f, "{code} = {value} does not fit its CAN format")
            }
            Refusal::LustbusAddress { address } => write!(
                f,
                "LUSTBUS address {address} is not a drive address: use 1..30, or 0 with a single drive on the line (31 is the broadcast address, section 4.2)"
            ),
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
            Refusal::ScanLustbusAddress { address } => write!(
                f,
                "{address} is not a scan target: LUSTBUS drive addresses are 1..30 (0 makes every drive answer at once, 31 is the broadcast address, section 4.2)"
            ),
            Refusal::ScanLecomAddress { address } => write!(
                f,
                "{address:02} is not a scan target: LECOM stations are 01..99 without 00 and the group addresses 10..90 (section 8.J)"
            ),
            Refusal::ScanCanNode { node } => write!(
                f,
                "{}: node 0 is no SDO server and cannot be a scan target (DS301)",
                NodeIdError(*node)
            ),
            Refusal::NoProbeCode { schema } => {
                write!(f, "schema `{schema}` has no code to probe with")
            }
            Refusal::DoctorLustbusAddress { address } => write!(
                f,
                "{address} is not a LUSTBUS drive address: use 1..30, or 0 (every drive answers, stand-alone operation, section 4.1)"
            ),
            Refusal::DoctorLecomAddress { address } => write!(
                f,
                "{address:02} is not a LECOM station: use 01..99 without 00 and the group addresses 10..90 (section 8.J)"
            ),
            Refusal::DoctorCanPort => f.write_str("CAN ports are checked by run_can"),
            Refusal::TransferRate { detail } => f.write_str(detail),
            Refusal::Assign { refusal } => write!(f, "{refusal}"),
        }
    }
}

/// Which LUSTBUS register holds the error bits: `SIOF` on the VF1000,
/// `SERR` on the MC6000/7000 (both parameter 85, section 9.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SiofRegister {
    /// VF1000.
    Siof,
    /// MC6000/7000.
    Serr,
}

impl fmt::Display for SiofRegister {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SiofRegister::Siof => "SIOF",
            SiofRegister::Serr => "SERR",
        })
    }
}

/// What the client concluded from a NAK and the SIOF/SERR bits read after
/// it (section 9.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SiofVerdict {
    /// EEPROM busy (04H) over every allowed repetition.
    EepromBusy {
        /// The repetitions allowed.
        repeats: u32,
    },
    /// No bit set: the drive refused without recording a cause.
    Unrecorded,
    /// Checksum error (08H) over every repetition.
    Checksum,
    /// A failing bit (the table's causes and remedies).
    Failed,
    /// 40H "no change" to SLOAD = -1: the drive is not at standstill
    /// (section 11.4).
    NotAtStandstill,
    /// 108-STEXT refused: the drive has no substitution texts.
    NoSubstitutionTexts,
}

/// What a drive itself said was wrong (as opposed to a transport failure),
/// with the protocol's own typed indication.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DeviceCause {
    /// LUSTBUS: a NAK, and the SIOF/SERR bits read after it (section 9.2).
    Siof {
        /// SIOF or SERR.
        register: SiofRegister,
        /// The bits.
        bits: Siof,
        /// What the client made of them.
        verdict: SiofVerdict,
    },
    /// LUSTBUS: SIOF/SERR itself could not be read (NAK to ENQUIRY 00085).
    SiofUnreadable,
    /// LUSTBUS: NAK to an ENQUIRY.
    NoSuchParameter {
        /// The CODE field (`20300`).
        parameter: String,
    },
    /// LUSTBUS: SLOAD still -1 / -2 at the deadline (section 11.4).
    DatasetStillChecking {
        /// The deadline, milliseconds.
        timeout_ms: u64,
        /// The last SLOAD value.
        sload: i64,
    },
    /// LUSTBUS: SLOAD > 0, the drive rejected the dataset at a parameter
    /// (section 11.4).
    DatasetRejected {
        /// The parameter number SLOAD reported.
        parameter: u32,
        /// It as the schema names it.
        name: String,
        /// Whether it was the backup (roll back) that was rejected.
        backup: bool,
    },
    /// LECOM: `EOT` to a RECEIVE, no such code (section 8.H).
    NoSuchCode {
        /// The code field (`STX code EOT`).
        code: String,
    },
    /// LECOM: NAK to a SEND, with C0068 (bits 4..7: the communication
    /// error) and, for causes that fail, C1962 where the schema has it
    /// (Table 1, section 8.J c).
    LecomNak {
        /// The C0068 word.
        status: OperatingStatus,
        /// C1962, where read.
        extended: Option<ExtendedError>,
    },
    /// CAN: an SDO abort (DS301 table 22; Lenze's codes).
    SdoAbort {
        /// The abort code.
        code: AbortCode,
        /// The index it named.
        index: Index,
        /// The subindex it named.
        subindex: Subindex,
    },
}

impl DeviceCause {
    /// Short cause as the spec names it (e.g. `"EEPROM busy"`,
    /// `"invalid value"`, `"no access permission"`).
    pub fn cause(&self) -> String {
        match self {
            DeviceCause::Siof { bits, verdict, .. } => match verdict {
                SiofVerdict::EepromBusy { .. } => "EEPROM busy".into(),
                SiofVerdict::Unrecorded => "refused (NAK) without a recorded cause".into(),
                SiofVerdict::Checksum => "checksum error".into(),
                SiofVerdict::Failed => bits
                    .causes()
                    .map(|c| format!("{} ({})", c.descriptor.to_lowercase(), c.cause))
                    .collect::<Vec<_>>()
                    .join(", "),
                SiofVerdict::NotAtStandstill => "the drive is not at standstill: SLOAD = -1 (register a download) is only taken at standstill".into(),
                SiofVerdict::NoSubstitutionTexts => "refused (NAK)".into(),
            },
            DeviceCause::SiofUnreadable => "SIOF/SERR cannot be read".into(),
            DeviceCause::NoSuchParameter { .. } => {
                "no such parameter, or read-protected in the current operating state".into()
            }
            DeviceCause::DatasetStillChecking { timeout_ms, .. } => {
                format!("the drive was still checking the dataset after {timeout_ms} ms")
            }
            DeviceCause::DatasetRejected { .. } => "dataset rejected".into(),
            DeviceCause::NoSuchCode { .. } => "no such code in this controller".into(),
            DeviceCause::LecomNak { status, .. } => {
                let comm = status.last_communication_error();
                if comm == CommunicationError::NoFault {
                    "refused (NAK) without a recorded communication error".into()
                } else {
                    comm.text().into()
                }
            }
            DeviceCause::SdoAbort { code, .. } => {
                code.text().unwrap_or("unknown abort code").into()
            }
        }
    }

    /// The raw indication (`SERR 80H invalid value`, `NAK; C0068 = H0050,
    /// bits 4..7 = 5`, `SDO abort 0x06010002 at index 0x4C6D subindex 0`).
    pub fn raw(&self) -> String {
        match self {
            DeviceCause::Siof { register, bits, .. } => format!("{register} {bits}"),
            DeviceCause::SiofUnreadable => "NAK to ENQUIRY 00085".into(),
            DeviceCause::NoSuchParameter { parameter } => format!("NAK to ENQUIRY {parameter}"),
            DeviceCause::DatasetStillChecking { sload, .. } => format!("SLOAD = {sload}"),
            DeviceCause::DatasetRejected { parameter, .. } => format!("SLOAD = {parameter}"),
            DeviceCause::NoSuchCode { code } => format!("STX {code} EOT"),
            DeviceCause::LecomNak { status, extended } => {
                let mut raw = format!(
                    "NAK; C0068 = H{:04X}, bits 4..7 = {}",
                    status.0,
                    status.last_communication_error().nibble()
                );
                if let Some(x) = extended {
                    raw.push_str(&format!("; C1962 = {x}"));
                }
                raw
            }
            DeviceCause::SdoAbort {
                code,
                index,
                subindex,
            } => format!(
                "SDO abort 0x{:08X} at index {index} subindex {subindex}",
                code.0
            ),
        }
    }

    /// What to do about it (the spec's remedy where it gives one).
    pub fn remedy(&self) -> String {
        match self {
            DeviceCause::Siof { bits, verdict, .. } => match verdict {
                SiofVerdict::EepromBusy { repeats } => format!(
                    "the EEPROM stayed busy over {repeats} repetitions; wait and retry the write"
                ),
                SiofVerdict::Unrecorded => {
                    "check the value and the drive's operating state, then retry".into()
                }
                SiofVerdict::Checksum => "check the line (termination, noise), then retry".into(),
                SiofVerdict::Failed => bits
                    .causes()
                    .filter(|c| c.flag != Siof::POWER_ON)
                    .map(|c| c.remedy)
                    .collect::<Vec<_>>()
                    .join("; "),
                SiofVerdict::NotAtStandstill => {
                    "stop the drive (section 11.4), then start the download again".into()
                }
                SiofVerdict::NoSubstitutionTexts => {
                    "the drive has no substitution texts (not an MC6000/7000?)".into()
                }
            },
            DeviceCause::SiofUnreadable => {
                "the drive does not answer its error word: check it is a LUSTBUS drive".into()
            }
            DeviceCause::NoSuchParameter { .. } => "check the drive is the family the schema names and the parameter is readable at this user level".into(),
            DeviceCause::DatasetStillChecking { .. } => {
                "repeat the download or restart the drive (section 11.4)".into()
            }
            DeviceCause::DatasetRejected { name, backup, .. } => {
                if *backup {
                    format!("the drive refuses its own old value of {name}; restore it by hand")
                } else {
                    format!("fix the value of {name}")
                }
            }
            DeviceCause::NoSuchCode { .. } => {
                "check the set's schema matches the drive (family, software version)".into()
            }
            DeviceCause::LecomNak { status, .. } => {
                lecom_remedy(status.last_communication_error()).into()
            }
            DeviceCause::SdoAbort { code, .. } => code
                .hint()
                .unwrap_or("not a DS301 abort code; see the drive's manual")
                .into(),
        }
    }
}

impl fmt::Display for DeviceCause {
    /// `cause (raw); remedy`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}); {}", self.cause(), self.raw(), self.remedy())
    }
}

/// The advice for a LECOM write the drive refuses for want of access
/// (C0068 cause 6: C0001 not 2 or 3, a password, a running drive;
/// `lecom-ab-tmd-manual.txt` §4e): the upload's refused write and
/// `driveset address`'s C0001 check give the same.
pub const LECOM_PROGRAMMING_ADVICE: &str = "the code cannot be written now: inhibit the controller (many codes are writable only at standstill), check the user password C0094, or set C0001 to 2 or 3 at the keypad so LECOM may program the drive (§4e)";

/// What to do about a communication error (C0068 bits 4..7).
fn lecom_remedy(e: CommunicationError) -> &'static str {
    match e {
        CommunicationError::NoFault => {
            "the drive refused without recording a cause; check the value against the code's range and the drive's state"
        }
        CommunicationError::ChecksumError
        | CommunicationError::ProtocolFrameError
        | CommunicationError::InterruptedByNewTelegram => {
            "transmission faults persisted over every repetition; check termination, wiring and that only one master talks"
        }
        CommunicationError::InvalidCodeNumber => {
            "the drive does not have this code (or cannot write it); check the set's schema matches the drive"
        }
        CommunicationError::InvalidVariable => {
            "the value is not allowed; choose a value inside the code's range"
        }
        CommunicationError::NoAccessPermission => LECOM_PROGRAMMING_ADVICE,
        CommunicationError::GeneralFault => "repeat; if it persists, check the drive",
        CommunicationError::Reserved | CommunicationError::Undocumented(_) => {
            "undocumented communication error; check the drive"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn target() -> Target {
        Target {
            port: "sim://demo".into(),
            address: 1,
        }
    }

    fn s(x: &str) -> String {
        x.to_string()
    }

    #[test]
    fn every_refusal_renders_its_message() {
        let cases: Vec<(Refusal, &str)> = vec![
            (
                Refusal::UnknownCode {
                    schema: s("lust-mc6000"),
                    code: s("999"),
                },
                "schema `lust-mc6000` has no code 999; check the set names the right drive family",
            ),
            (
                Refusal::ReadOnly {
                    code: s("91-TYPE"),
                    schema: s("lust-mc6000"),
                },
                "91-TYPE is read-only in schema `lust-mc6000`; remove it from the set",
            ),
            (
                Refusal::NoDatasetHandshake,
                "this drive family has no dataset download handshake",
            ),
            (
                Refusal::Broadcast {
                    code: s("85-SERR"),
                    why: s(
                        "a numerically compatible code (81..85, 91; section 5.2) is never broadcast",
                    ),
                },
                "broadcast (address 31) of 85-SERR: a numerically compatible code (81..85, 91; section 5.2) is never broadcast",
            ),
            (
                Refusal::BroadcastNotStaged {
                    codes: vec![s("416-A"), s("417-B")],
                },
                "broadcast of 416-A, 417-B refused: not a value this drive's dataset stages",
            ),
            (
                Refusal::StepOutOfOrder {
                    step: s("commit"),
                    before: s("open_dataset"),
                },
                "transaction step `commit` called before `open_dataset`",
            ),
            (Refusal::LustbusOnCan, "a LUSTBUS drive on a CAN bus"),
            (
                Refusal::WrongClient {
                    schema: s("lenze-tmd"),
                    family: s("tmd"),
                    protocol: driveset_schema::BusProtocol::Lustbus,
                },
                "schema `lenze-tmd` is not a LUSTBUS family (tmd drives); pick the client of its protocol",
            ),
            (
                Refusal::WrongClient {
                    schema: s("lust-mc6000"),
                    family: s("mc6000"),
                    protocol: driveset_schema::BusProtocol::Lecom,
                },
                "schema `lust-mc6000` is not a LECOM family (mc6000 drives); pick the client of its protocol",
            ),
            (
                Refusal::WrongClient {
                    schema: s("lenze-tmd"),
                    family: s("tmd"),
                    protocol: driveset_schema::BusProtocol::CanSdo,
                },
                "schema `lenze-tmd` is not a CAN SDO family (tmd drives); pick the client of its protocol",
            ),
            (
                Refusal::LinkMisfit {
                    schema: s("lenze-ecs"),
                    family: s("ecs"),
                    bus: s("CAN SDO"),
                    link: LinkKind::CharacterLine,
                },
                "schema `lenze-ecs` is for ecs drives (CAN SDO), which do not run on a character line",
            ),
            (
                Refusal::LinkMisfit {
                    schema: s("lenze-tmd"),
                    family: s("tmd"),
                    bus: s("LECOM"),
                    link: LinkKind::CanBus,
                },
                "schema `lenze-tmd` is for tmd drives (LECOM), which do not run on a CAN bus",
            ),
            (
                Refusal::LecomAddress { address: 20 },
                "LECOM address 20 is not a station: use 01..99 except 00 and the group addresses 10, 20, .. 90 (BROADCAST / MULTICAST, section 8.J; use broadcast() for those)",
            ),
            (
                Refusal::LecomGroup { tens: 12 },
                "group 12 does not exist: groups are 1..9 (addresses 10..90, section 8.J)",
            ),
            (
                Refusal::LecomUnaddressable { code: s("C70000") },
                "C70000 cannot be addressed on LECOM (code above 65535 or subcode above 255, section 8.D)",
            ),
            (
                Refusal::LecomValue {
                    code: s("C0011"),
                    value: s("raw 12"),
                    detail: s("the schema gives no LECOM format"),
                },
                "C0011 = raw 12: the schema gives no LECOM format",
            ),
            (
                Refusal::Encode {
                    what: Some(s("read C0011")),
                    detail: s("too long"),
                },
                "read C0011: too long",
            ),
            (
                Refusal::Encode {
                    what: None,
                    detail: s("too long"),
                },
                "too long",
            ),
            (
                Refusal::SdoNode { node: 0 },
                "node id 0 is out of range 1..=127: 0 addresses no SDO server (DS301)",
            ),
            (
                Refusal::NoSdoIndex {
                    code: s("C30000"),
                    base: 24575,
                },
                "C30000 has no SDO index (code above the index base 24575 or subcode above 255)",
            ),
            (
                Refusal::NotSdoType {
                    code: s("C0093"),
                    ty: s("?"),
                },
                "C0093: type ? does not travel over CAN SDO",
            ),
            (
                Refusal::NotCanFormat {
                    code: s("C0011"),
                    value: s("\"x\""),
                },
                "C0011 = \"x\" does not fit its CAN format",
            ),
            (
                Refusal::LustbusAddress { address: 31 },
                "LUSTBUS address 31 is not a drive address: use 1..30, or 0 with a single drive on the line (31 is the broadcast address, section 4.2)",
            ),
            (
                Refusal::LustbusCode {
                    code: s("300-X"),
                    problem: LustbusCodeProblem::HasSubcode,
                },
                "300-X has a subcode; LUSTBUS parameters have none (check the schema)",
            ),
            (
                Refusal::LustbusCode {
                    code: s("7-X"),
                    problem: LustbusCodeProblem::NotAddressable,
                },
                "7-X cannot be addressed",
            ),
            (
                Refusal::LustbusCode {
                    code: s("120-X"),
                    problem: LustbusCodeProblem::AboveVf1000Range,
                },
                "120-X is above 99, the VF1000 range (section 2.4.1)",
            ),
            (
                Refusal::LustbusCode {
                    code: s("1200"),
                    problem: LustbusCodeProblem::AboveMcRange,
                },
                "1200 is above 999, the MC6000/7000 range (section 2.4.2)",
            ),
            (
                Refusal::NoWireType {
                    code: s("300-X"),
                    schema: s("lust-mc6000"),
                    family: s("MC6000/7000"),
                },
                "300-X: schema `lust-mc6000` gives no MC6000/7000 type or width, so the value cannot be encoded; add `type` to the schema",
            ),
            (
                Refusal::NotInteger {
                    code: s("300-X"),
                    value: s("\"a\""),
                },
                "300-X: LUSTBUS parameters hold integers, not \"a\"",
            ),
            (
                Refusal::DoesNotFit {
                    code: s("300-X"),
                    value: s("raw 70000"),
                    ty: s("USIGN16"),
                },
                "300-X: raw 70000 does not fit USIGN16",
            ),
            (
                Refusal::NotCardWriteable {
                    code: s("428-RSIO"),
                },
                "428-RSIO is not CardWriteable: during a dataset download the drive ACKs it but does not take the value (section 11.4); write it after dataset_commit",
            ),
            (
                Refusal::Vf1000NoDataset,
                "the VF1000 has no dataset download handshake (SLOAD is MC6000/7000 only, section 11.4)",
            ),
            (
                Refusal::NoDatasetOpen,
                "no dataset download is open; call dataset_begin first",
            ),
            (
                Refusal::StextMcOnly,
                "108-STEXT substitution texts are MC6000/7000 only (section 11.3)",
            ),
            (
                Refusal::NoSload { schema: s("x") },
                "schema `x` has no 80-SLOAD; the dataset download needs it",
            ),
            (
                Refusal::SetSchema {
                    set: s("a"),
                    schema: s("b"),
                },
                "the set is for schema `a`, the drive is read with schema `b`; compare a set of this drive family",
            ),
            (
                Refusal::CodesNotInSchema {
                    schema: s("b"),
                    codes: vec![s("7"), s("8")],
                },
                "codes not in schema `b`: 7, 8; remove them from the set",
            ),
            (
                Refusal::Diff {
                    detail: s("schemas differ"),
                },
                "schemas differ",
            ),
            (
                Refusal::WrongType {
                    code: s("91-TYPE"),
                    found: Some(9999),
                    schema: s("lust-mc6000"),
                    expected: vec![1234, 1235],
                },
                "the drive reports 91-TYPE = 9999, which is not a `lust-mc6000` type ([1234, 1235]); use the set and schema of the drive's family",
            ),
            (
                Refusal::WrongType {
                    code: s("91-TYPE"),
                    found: None,
                    schema: s("x"),
                    expected: vec![1],
                },
                "the drive reports 91-TYPE = nothing, which is not a `x` type ([1]); use the set and schema of the drive's family",
            ),
            (
                Refusal::ScanLustbusAddress { address: 0 },
                "0 is not a scan target: LUSTBUS drive addresses are 1..30 (0 makes every drive answer at once, 31 is the broadcast address, section 4.2)",
            ),
            (
                Refusal::ScanLecomAddress { address: 5 },
                "05 is not a scan target: LECOM stations are 01..99 without 00 and the group addresses 10..90 (section 8.J)",
            ),
            (
                Refusal::ScanCanNode { node: 0 },
                "node id 0 is out of range 1..=127: node 0 is no SDO server and cannot be a scan target (DS301)",
            ),
            (
                Refusal::NoProbeCode { schema: s("x") },
                "schema `x` has no code to probe with",
            ),
            (
                Refusal::DoctorLustbusAddress { address: 31 },
                "31 is not a LUSTBUS drive address: use 1..30, or 0 (every drive answers, stand-alone operation, section 4.1)",
            ),
            (
                Refusal::DoctorLecomAddress { address: 0 },
                "00 is not a LECOM station: use 01..99 without 00 and the group addresses 10..90 (section 8.J)",
            ),
            (Refusal::DoctorCanPort, "CAN ports are checked by run_can"),
            (
                Refusal::Plan {
                    problems: vec![Problem::Running],
                },
                "the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running",
            ),
            (
                Refusal::Plan {
                    problems: vec![
                        Problem::ReadOnly { code: s("91-TYPE") },
                        Problem::NotInSchema {
                            code: s("999"),
                            schema: s("x"),
                        },
                    ],
                },
                "2 problems: 91-TYPE: read-only (an actual value); remove it from the set; code 999 is not in schema `x`; remove it from the set (or fix the number)",
            ),
        ];
        for (refusal, want) in cases {
            assert_eq!(refusal.to_string(), want, "{refusal:?}");
            let e = EngineError::refused(target(), refusal);
            assert_eq!(
                e.to_string(),
                format!("sim://demo address 1: refused: {want}")
            );
        }
    }

    #[test]
    fn every_device_cause_renders_cause_raw_and_remedy() {
        let siof = |bits: u8, verdict| DeviceCause::Siof {
            register: SiofRegister::Serr,
            bits: Siof(bits),
            verdict,
        };
        let cases: Vec<(DeviceCause, &str, &str, &str)> = vec![
            (
                siof(0x80, SiofVerdict::Failed),
                "invalid value (The transfer parameter value is not permissible)",
                "SERR 80H Invalid value",
                "Choose a different value",
            ),
            (
                DeviceCause::Siof {
                    register: SiofRegister::Siof,
                    bits: Siof(0x21),
                    verdict: SiofVerdict::Failed,
                },
                "power on (Bit is set for each ON), no parameter (There is no parameter for the given number)",
                "SIOF 21H Power on, No parameter",
                "General service error or error in the software of the Host computer.",
            ),
            (
                siof(0x04, SiofVerdict::EepromBusy { repeats: 5 }),
                "EEPROM busy",
                "SERR 04H EEPROM busy",
                "the EEPROM stayed busy over 5 repetitions; wait and retry the write",
            ),
            (
                siof(0x00, SiofVerdict::Unrecorded),
                "refused (NAK) without a recorded cause",
                "SERR 00H no error",
                "check the value and the drive's operating state, then retry",
            ),
            (
                siof(0x08, SiofVerdict::Checksum),
                "checksum error",
                "SERR 08H Checksum error",
                "check the line (termination, noise), then retry",
            ),
            (
                siof(0x40, SiofVerdict::NotAtStandstill),
                "the drive is not at standstill: SLOAD = -1 (register a download) is only taken at standstill",
                "SERR 40H No change",
                "stop the drive (section 11.4), then start the download again",
            ),
            (
                siof(0x40, SiofVerdict::NoSubstitutionTexts),
                "refused (NAK)",
                "SERR 40H No change",
                "the drive has no substitution texts (not an MC6000/7000?)",
            ),
            (
                DeviceCause::SiofUnreadable,
                "SIOF/SERR cannot be read",
                "NAK to ENQUIRY 00085",
                "the drive does not answer its error word: check it is a LUSTBUS drive",
            ),
            (
                DeviceCause::NoSuchParameter {
                    parameter: s("20300"),
                },
                "no such parameter, or read-protected in the current operating state",
                "NAK to ENQUIRY 20300",
                "check the drive is the family the schema names and the parameter is readable at this user level",
            ),
            (
                DeviceCause::DatasetStillChecking {
                    timeout_ms: 10000,
                    sload: -2,
                },
                "the drive was still checking the dataset after 10000 ms",
                "SLOAD = -2",
                "repeat the download or restart the drive (section 11.4)",
            ),
            (
                DeviceCause::DatasetRejected {
                    parameter: 100,
                    name: s("100-KPSC1"),
                    backup: false,
                },
                "dataset rejected",
                "SLOAD = 100",
                "fix the value of 100-KPSC1",
            ),
            (
                DeviceCause::DatasetRejected {
                    parameter: 100,
                    name: s("100-KPSC1"),
                    backup: true,
                },
                "dataset rejected",
                "SLOAD = 100",
                "the drive refuses its own old value of 100-KPSC1; restore it by hand",
            ),
            (
                DeviceCause::NoSuchCode { code: s("0B") },
                "no such code in this controller",
                "STX 0B EOT",
                "check the set's schema matches the drive (family, software version)",
            ),
            (
                DeviceCause::LecomNak {
                    status: OperatingStatus(0x0050),
                    extended: None,
                },
                "invalid variable",
                "NAK; C0068 = H0050, bits 4..7 = 5",
                "the value is not allowed; choose a value inside the code's range",
            ),
            (
                DeviceCause::LecomNak {
                    status: OperatingStatus(0x0060),
                    extended: Some(ExtendedError::from_code(0)),
                },
                "no access permission",
                "NAK; C0068 = H0060, bits 4..7 = 6; C1962 = no fault (0)",
                "the code cannot be written now: inhibit the controller (many codes are writable only at standstill), check the user password C0094, or set C0001 to 2 or 3 at the keypad so LECOM may program the drive (§4e)",
            ),
            (
                DeviceCause::LecomNak {
                    status: OperatingStatus(0x0000),
                    extended: None,
                },
                "refused (NAK) without a recorded communication error",
                "NAK; C0068 = H0000, bits 4..7 = 0",
                "the drive refused without recording a cause; check the value against the code's range and the drive's state",
            ),
            (
                DeviceCause::SdoAbort {
                    code: AbortCode(0x0601_0002),
                    index: Index(0x4C6D),
                    subindex: Subindex(0),
                },
                "Attempt to write a read only object",
                "SDO abort 0x06010002 at index 0x4C6D subindex 0",
                AbortCode(0x0601_0002).hint().unwrap_or("?"),
            ),
            (
                DeviceCause::SdoAbort {
                    code: AbortCode(0x1234_5678),
                    index: Index(0x5FFE),
                    subindex: Subindex(3),
                },
                "unknown abort code",
                "SDO abort 0x12345678 at index 0x5FFE subindex 3",
                "not a DS301 abort code; see the drive's manual",
            ),
        ];
        for (c, cause, raw, remedy) in cases {
            assert_eq!(
                (c.cause().as_str(), c.raw().as_str(), c.remedy().as_str()),
                (cause, raw, remedy),
                "{c:?}"
            );
            let e = EngineError::device(target(), "write 100-KPSC1 (raw 2097)", c);
            assert_eq!(
                e.to_string(),
                format!(
                    "sim://demo address 1: write 100-KPSC1 (raw 2097) refused: {cause} ({raw}); {remedy}"
                )
            );
        }
    }

    #[test]
    fn device_causes_and_refusals_round_trip_through_json_with_stable_tags() {
        let c = DeviceCause::Siof {
            register: SiofRegister::Serr,
            bits: Siof(0x80),
            verdict: SiofVerdict::Failed,
        };
        let j = serde_json::to_string(&c).expect("json");
        assert_eq!(
            j,
            r#"{"kind":"siof","register":"serr","bits":128,"verdict":{"kind":"failed"}}"#
        );
        assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
        let c = DeviceCause::LecomNak {
            status: OperatingStatus(0x0050),
            extended: Some(ExtendedError::from_code(0)),
        };
        let j = serde_json::to_string(&c).expect("json");
        assert_eq!(j, r#"{"kind":"lecom_nak","status":80,"extended":0}"#);
        assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
        let c = DeviceCause::LecomNak {
            status: OperatingStatus(0x0010),
            extended: None,
        };
        let j = serde_json::to_string(&c).expect("json");
        assert_eq!(j, r#"{"kind":"lecom_nak","status":16,"extended":null}"#);
        assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
        let r = Refusal::WrongClient {
            schema: s("lenze-tmd"),
            family: s("tmd"),
            protocol: driveset_schema::BusProtocol::CanSdo,
        };
        let j = serde_json::to_string(&r).expect("json");
        assert_eq!(
            j,
            r#"{"kind":"wrong_client","schema":"lenze-tmd","family":"tmd","protocol":"can"}"#
        );
        assert_eq!(serde_json::from_str::<Refusal>(&j).expect("back"), r);
        let bad = j.replace(r#""can""#, r#""modbus""#);
        assert_eq!(
            serde_json::from_str::<Refusal>(&bad)
                .expect_err("unknown protocol")
                .to_string(),
            "unknown bus protocol `modbus`"
        );
        let c = DeviceCause::SdoAbort {
            code: AbortCode(0x0601_0002),
            index: Index(0x4C6D),
            subindex: Subindex(0),
        };
        let j = serde_json::to_string(&c).expect("json");
        assert_eq!(
            j,
            r#"{"kind":"sdo_abort","code":100728834,"index":19565,"subindex":0}"#
        );
        assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
        let r = Refusal::Plan {
            problems: vec![Problem::AddressChange {
                code: s("82-SADDR"),
                old: s("1"),
                new: s("4"),
            }],
        };
        let j = serde_json::to_string(&r).expect("json");
        assert_eq!(
            j,
            r#"{"kind":"plan","problems":[{"kind":"address_change","code":"82-SADDR","old":"1","new":"4"}]}"#
        );
        assert_eq!(serde_json::from_str::<Refusal>(&j).expect("back"), r);
    }

    #[test]
    fn a_journal_error_names_no_drive_and_the_error_stays_small() {
        let e = EngineError::journal("/tmp/j.journal.json", "cannot write: disk full");
        assert_eq!(e.target, None);
        assert_eq!(
            e.to_string(),
            "journal /tmp/j.journal.json: cannot write: disk full"
        );
        // a target and a box: what `Result<_, EngineError>` carries
        assert!(std::mem::size_of::<EngineError>() <= 48);
        let inner = EngineError::no_answer(target(), "read C0011", 3);
        let rolled = EngineError::rolled_back(target(), "j.json", "C0011 failed", inner);
        assert_eq!(
            std::error::Error::source(&rolled).map(ToString::to_string),
            Some(s(
                "sim://demo address 1: no answer to read C0011 after 3 tries; check wiring, address and baud rate"
            ))
        );
    }
}
