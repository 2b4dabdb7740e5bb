//! The transfer rate (`--transfer-baud RATE`): owns switching an
//! MC6000/7000 and the host's port to a faster line rate for one
//! transaction and back (`lustbus-protocol.txt` §11.5), the search for a
//! drive left at another rate (§5.1), the estimate of whether a switch
//! pays, and the switch's record in the journal
//! ([`crate::journal::TransferRecord`]).
//!
//! **The switch** (§11.5: "first set the new Baudrate. Then use the value
//! 111 in the 4-PROG parameter to order the servocontroller to activate
//! the Baudrate"; §4: servocontrollers run at 2400..57600 Bd, inverters at
//! most 9600):
//!
//! 1. at the old rate: read 81-SBAUD (what its EEPROM holds, `before`);
//!    journal the record (`switching`); write SBAUD = RATE; write PROG =
//!    111 (the ACK still comes at the old rate);
//! 2. the host's port to RATE ([`crate::client::SerialLine::set_rate`]); confirm
//!    contact by reading SBAUD (= RATE); write SBAUD = `before` again
//!    **without** activating it, so that the EEPROM never keeps the
//!    transfer rate: a drive restarted in the middle comes back at its own
//!    rate; journal `at-transfer-rate`;
//! 3. the transaction (its read-back sees the drive's own SBAUD; a set
//!    that holds SBAUD writes it as any other code, not activated);
//! 4. back: read SBAUD (`keep`: what the transaction left in EEPROM);
//!    write SBAUD = old rate, PROG = 111 (ACK at RATE), port to the old
//!    rate, confirm (SBAUD = old rate); write SBAUD = `keep` without
//!    activating it and read it back; journal `back`.
//!
//! What stays in EEPROM is therefore the set's SBAUD when the transaction
//! wrote one, else the drive's own. Only the MC6000/7000 family descriptor
//! names an online activation ([`driveset_schema::family::OnlineBaud`]);
//! VF1000, Tmd and ECS are refused. A running drive is refused (the switch
//! needs standstill: the running check of the upload, without override). A
//! bus shared with drives that cannot follow (VF1000: 9600 Bd at most) is
//! refused unless [`crate::overrides::Override::AllowSharedTransferBaud`]: while the MC talks
//! at RATE they see garbage, and their watchdog (84-SIOT) may fire.
//!
//! **When it pays.** [`decide`] estimates the exchanges the command cannot
//! avoid (the read-back of every code of the set, every code pulled) at the
//! current rate and at RATE, plus the switch-over exchanges above (with the
//! EEPROM store time of the SBAUD writes, §10.2.2). Wire time scales with
//! the rate, the §10 minimum reaction does not. It switches only when the
//! sum at RATE is smaller; the report says which and why.
//!
//! **Failure.** A link failure after the switch searches for the drive
//! (§5.1: the current rate, the transfer rate, the old rate, then every
//! rate of the family) and switches it back; the upload's backup is never
//! touched. When the drive cannot be found the error says at which rate it
//! may run, and the journal keeps the record open, so `driveset recover`
//! ([`find_drive`], `finish_rate`) searches again before it completes or rolls back.
//!
//! **Rooms.** This module holds the request ([`TransferRequest`]) and the
//! family's rate codes; [`check`] (what needs no telegram) is in
//! `check.rs`, [`decide`] and the report of the decision in `decide.rs`,
//! the switch over and back and the search in `switch.rs`, the journal
//! record's bookkeeping in `record.rs`, a switched session ([`begin`],
//! `end`) in `session.rs`, the commands run at a transfer rate
//! ([`upload`], [`pull`], [`live_diff`]) in `commands.rs`, and `recover`'s
//! part ([`find_drive`], `finish_rate`) in `recovery.rs`, the refusal
//! ([`TransferRefusal`]) in `refusal.rs`.

mod check;
mod commands;
mod decide;
mod record;
mod recovery;
mod refusal;
mod session;
mod switch;

use driveset_schema::family::{Family, OnlineBaud};
use driveset_schema::{CodeKey, RawValue, Schema};

use crate::client::Target;
use crate::error::EngineError;

pub use crate::rate_report::{Decision, TransferReport};
pub use check::check;
pub use commands::{live_diff, pull, pull_exchanges, upload, upload_exchanges};
pub use decide::{at_rate, decide};
pub use recovery::find_drive;
pub(crate) use recovery::finish_rate;
pub(crate) use recovery::judged_rate;
pub use refusal::TransferRefusal;
pub use session::{Session, begin};
pub use switch::search;

/// What the command asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TransferRequest {
    /// The transfer rate (baud).
    pub rate: u32,
    /// The families of the other drives on the same bus, where known (a
    /// line manifest's bus); empty for a single-drive command.
    pub others: Vec<Family>,
    /// [`crate::overrides::Override::AllowSharedTransferBaud`] given.
    pub allow_shared: bool,
}

impl TransferRequest {
    /// A request for `rate` on a bus of one drive.
    pub fn new(rate: u32) -> Self {
        TransferRequest {
            rate,
            others: Vec::new(),
            allow_shared: false,
        }
    }
}

/// The codes and values of a family's online rate change.
#[derive(Debug, Clone, Copy)]
struct Codes {
    rate: CodeKey,
    online: OnlineBaud,
}

fn refuse(target: &Target, reason: String) -> EngineError {
    EngineError::refused(target.clone(), TransferRefusal::Rate { detail: reason })
}

fn codes_of(schema: &Schema) -> Option<Codes> {
    let r = schema.family.descriptor().line_rates;
    Some(Codes {
        rate: CodeKey::new(r.code?),
        online: r.online?,
    })
}

/// The rate code's value as a rate.
fn as_rate(v: &RawValue) -> Option<u32> {
    match v {
        RawValue::Int(i) => u32::try_from(*i).ok(),
        _ => None,
    }
}
