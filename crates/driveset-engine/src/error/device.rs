//! What a drive itself said was wrong, as opposed to a transport failure:
//! [`DeviceCause`] with the protocol's own typed indication (LUSTBUS
//! SIOF/SERR bits, section 9.2; LECOM C0068 bits 4..7 and C1962, Table 1
//! and section 8.J c; SDO abort codes, DS301 table 22), its cause, raw
//! indication and remedy.

use std::fmt;

use driveset_proto::can::{AbortCode, Index, Subindex};
use driveset_proto::lecom::{CommunicationError, ExtendedError, OperatingStatus};
use driveset_proto::lustbus::Siof;
use serde::{Deserialize, Serialize};

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
