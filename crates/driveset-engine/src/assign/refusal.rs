//! Owns why `driveset address` refuses ([`AssignRefusal`], wrapped into
//! [`Refusal::Assign`]) and the checks that raise those refusals before
//! anything is written: the address rule ([`BusProtocol::check_address`]),
//! the family's line rates (`lustbus-protocol.txt` §4,
//! `lecom-ab-tmd-manual.txt` C0125) and a schema that types the codes.

use std::fmt;

use driveset_link::LinkError;
use driveset_schema::{BusProtocol, CodeKey, Family, Schema};
use serde::{Deserialize, Serialize};

use super::report::list;
use crate::client::Target;
use crate::error::{EngineError, Refusal};
use crate::plan::code_label;

/// Why `address` refuses before anything is written (wrapped into
/// [`Refusal::Assign`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "assign", rename_all = "snake_case")]
pub enum AssignRefusal {
    /// The address asked for is not a drive's own address.
    InvalidAddress {
        /// The address.
        address: i64,
        /// `--to` or `--from`.
        option: String,
        /// The protocol's rule, from [`BusProtocol::check_address`].
        rule: String,
    },
    /// `--baud` is not a rate of the drive's family (or of the protocol).
    InvalidRate {
        /// The rate asked for.
        baud: u32,
        /// Who runs at which rates.
        who: String,
        /// The rates.
        rates: String,
    },
    /// Answers at address 0 that do not decode: several devices answer.
    Collision {
        /// The rate they were heard at.
        baud: u32,
        /// What was heard.
        heard: String,
        /// Who the network list at that rate finds (empty: nobody, or not
        /// asked).
        #[serde(default)]
        found: String,
    },
    /// The network list (1..30) found more than one device.
    MoreThanOne {
        /// Who answered where.
        found: String,
    },
    /// A port that must hold one device (`replace`, `commission --assign`:
    /// [`super::AssignRequest::alone`]) holds more.
    NotAlone {
        /// What was scanned.
        scanned: String,
        /// Who answered where.
        found: String,
    },
    /// Another device answers at the address asked for.
    Taken {
        /// The address.
        address: u8,
        /// What answered there.
        answer: String,
    },
    /// C0001 does not let LECOM write (§4e).
    LecomReadOnly {
        /// C0001 as read.
        c0001: String,
    },
    /// The schema cannot write the code (no type for it).
    SchemaLacks {
        /// Schema id.
        schema: String,
        /// The code.
        code: String,
    },
    /// The port is not a character line.
    NotSerial {
        /// The protocol asked for.
        protocol: String,
    },
    /// No schema for the family the drive identified as.
    NoSchema {
        /// The family.
        family: String,
    },
    /// The journal belongs to `driveset address`: recover it with
    /// [`recover()`](super::recover()), not the upload's recover.
    AssignJournal {
        /// The journal file.
        journal: String,
    },
    /// The journal does not fit the drive found (another TYPE / identity).
    NotTheDrive {
        /// What differs.
        detail: String,
    },
}

impl fmt::Display for AssignRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AssignRefusal::InvalidAddress {
                address,
                option,
                rule,
            } => write!(
                f,
                "{option} {address}: {rule}; nothing was sent. Give an address the rule allows"
            ),
            AssignRefusal::InvalidRate { baud, who, rates } => write!(
                f,
                "--baud {baud}: {who} runs at {rates} baud (lustbus-protocol.txt §4, lecom-ab-tmd-manual.txt C0125); nothing was written. Pick one of these"
            ),
            AssignRefusal::Collision { baud, heard, found } => {
                let list = if found.is_empty() {
                    String::new()
                } else {
                    format!("; the network list at {baud} baud finds {found}")
                };
                write!(
                    f,
                    "the answers at address 0 at {baud} baud do not decode ({heard}): more than one device answers (lustbus-protocol.txt §4.2: every device answers at address 0){list}; nothing was written. Connect the drive alone and run again"
                )
            }
            AssignRefusal::NotAlone { scanned, found } => write!(
                f,
                "the service port holds more than one device (a scan of {scanned} finds {found}); a spare must be alone on its port; nothing was written. Connect the spare alone and run again"
            ),
            AssignRefusal::MoreThanOne { found } => write!(
                f,
                "the line holds more than one device (the network list of lustbus-protocol.txt §5.2 finds {found}); nothing was written. Connect the drive alone and run again"
            ),
            AssignRefusal::Taken { address, answer } => write!(
                f,
                "address {address} is taken: another device answers there ({answer}); nothing was written. No address may be assigned twice (lustbus-protocol.txt §4.2, lecom-ab-tmd-manual.txt §4c): pick a free address or disconnect that device"
            ),
            AssignRefusal::LecomReadOnly { c0001 } => write!(
                f,
                "C0001 = {c0001}: LECOM may read but not write (lecom-ab-tmd-manual.txt §4e, §4f); nothing was written; {}",
                crate::error::LECOM_PROGRAMMING_ADVICE
            ),
            AssignRefusal::SchemaLacks { schema, code } => write!(
                f,
                "schema `{schema}` gives no type for {code}, so its value cannot be written; nothing was written. Give --schema with a schema that types it (one learned from the drive by `driveset schema pull`)"
            ),
            AssignRefusal::NotSerial { protocol } => write!(
                f,
                "{protocol} addresses are set over a character line, and this port is a CAN bus; nothing was sent"
            ),
            AssignRefusal::NoSchema { family } => write!(
                f,
                "no schema for the {family} the drive identifies as; nothing was written. Give --schema"
            ),
            AssignRefusal::AssignJournal { journal } => write!(
                f,
                "journal {journal} records a `driveset address` change; nothing was sent. Run `driveset recover {journal}` (it finishes the address change)"
            ),
            AssignRefusal::NotTheDrive { detail } => write!(
                f,
                "{detail}; nothing was written. Connect the drive the journal belongs to"
            ),
        }
    }
}

pub(super) fn target(port: &str, address: u8) -> Target {
    Target {
        port: port.to_string(),
        address,
    }
}

pub(super) fn refuse(port: &str, address: u8, r: AssignRefusal) -> EngineError {
    EngineError::refused(target(port, address), Refusal::from(r))
}

pub(super) fn link_err(port: &str, address: u8, e: LinkError) -> EngineError {
    EngineError::link(target(port, address), e)
}

pub(super) fn check_address(
    protocol: BusProtocol,
    port: &str,
    option: &str,
    a: u8,
) -> Result<(), EngineError> {
    protocol.check_address(i64::from(a)).map_err(|refusal| {
        refuse(
            port,
            a,
            AssignRefusal::InvalidAddress {
                address: i64::from(a),
                option: option.to_string(),
                rule: refusal.rule.to_string(),
            },
        )
    })
}

/// The family's rates check for `--baud`.
pub(super) fn check_family_rate(port: &str, family: Family, baud: u32) -> Result<(), EngineError> {
    let d = family.descriptor();
    if d.line_rates.rates.contains(&baud) {
        return Ok(());
    }
    Err(refuse(
        port,
        0,
        AssignRefusal::InvalidRate {
            baud,
            who: format!("a {}", d.title),
            rates: list(d.line_rates.rates),
        },
    ))
}

pub(super) fn need_type(schema: &Schema, port: &str, key: CodeKey) -> Result<(), EngineError> {
    let typed = schema
        .code(key.number)
        .is_some_and(|c| schema.type_of(c).is_some());
    if typed {
        Ok(())
    } else {
        Err(refuse(
            port,
            0,
            AssignRefusal::SchemaLacks {
                schema: schema.id.clone(),
                code: code_label(schema, key),
            },
        ))
    }
}
