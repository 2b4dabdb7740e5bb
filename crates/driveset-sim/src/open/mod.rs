//! Opening `sim://` ports: owns [`open_sim`] (a [`SimSpec`] to a simulated
//! bus in virtual time, the way the engine commands use
//! `--port sim://mc6000?addresses=1,2`), [`SimConfig`] (the checked
//! settings of a simulated bus, shared with `driveset sim`, which serves the
//! same drives in real time), [`SimLink`] (the open bus: a byte link or a
//! frame link plus access to the drives) and the state dump format
//! ([`StateDump`], shared with `driveset sim --dump`).
//!
//! # Families and addresses
//!
//! `FAMILY` is a [`Family`] name (`mc6000`, `mc7000`, `vf1000`, `tmd`,
//! `ecs`) or a schema id naming one (`lust-mc6000`, `lust-vf1000`,
//! `lenze-tmd`, `lenze-ecs`, the fixtures' `fictional-...-demo`).
//! Addresses: LUSTBUS 1..=30 (section 4.2), LECOM 1..=99 except the group
//! addresses 10, 20, ... 90 (§4c), CAN node ids 1..=127.
//!
//! # Mixed LUSTBUS
//!
//! `sim://lustbus?mc6000=1,2&vf1000=5,6` puts MC6000/7000 servocontrollers
//! and VF1000 inverters on one simulated line, as the LUSTBUS protocol
//! allows (section 1, joint operation of inverters and servocontrollers):
//! one address space 1..=30 across the families. Its state file (from
//! [`STATE_DIR_ENV`]) is `DIR/sim-lustbus.json`, its dump's `family` is
//! `lustbus`, each drive entry carries its own family.
//!
//! # Factory-fresh drives and the bench
//!
//! `factory=3` (one family) or `factory=mc6000*4,vf1000*3` (on
//! `sim://lustbus`) adds factory-fresh drives after those of `addresses=`;
//! `bench=true` holds only the first one still waiting for its address on
//! the bus at each open ([`crate::factory`], which owns the factory address,
//! FICTIONAL 1 on LUSTBUS, the rate and the bench rule). Their drives may
//! share an address ([`crate::bus::ByteLine::sharing_addresses`]).
//!
//! # Options
//!
//! - `seed=N`: every random choice of the drives (reaction times) and of
//!   the fault generator (unless the plan has its own `seed=`) comes from
//!   it; default 0. The same seed and the same host traffic give the same
//!   bytes at the same virtual instants.
//! - `faults=PLAN`: the [`crate::faults::FaultPlan`] grammar (`crate::faults`).
//! - `c0001=N` (Tmd, 0..=11): C0001 as set at the drive's keypad before
//!   LECOM use (lecom-ab-tmd-manual.txt §4e). Default 0, Table 1's factory
//!   setting, in which LECOM may only read (and write C0040, C0043, C0248,
//!   C0249); `c0001=2` lets LECOM program the drive, `c0001=3` also control
//!   it (§4f).
//! - `refuse=KEY,...` (`11`, `17.2`): every drive of the bus refuses to
//!   read these codes, as a drive does that hides a code in its operating
//!   state: LUSTBUS `ADR NAK` to the ENQUIRY, LECOM `STX code EOT` to the
//!   RECEIVE (8.H), CAN SDO abort 0x06010001 "attempt to read a write-only
//!   object" (DS301 table 22). Writes are not affected.
//! - `keypad=true|false`: LUSTBUS families with a KEYPAD attached (slower
//!   reactions, section 10). Not (yet) a key `driveset-link` accepts in a
//!   port string; [`SimConfig::keypad`] is set by `driveset sim --keypad`.
//! - `layout=52|43|42|34` and `types=driveset|table|C=TYPE,...`:
//!   MC6000/7000 drives send their parameter descriptions (section 11.2)
//!   in that layout and with those type characters (the readings errata
//!   L22 and L23 discuss; default 52 and driveset's characters), so that
//!   `schema pull` and the learning `pull` can be tested against each.
//! - `describe=N:ITEM[:ITEM...][;N:...]` (LUSTBUS): parameter `N`'s own
//!   description says another kind, type, range or unit than the fixture
//!   (`11:actual:binary8`, `100:min=2:max=5`, `134:unit=rpm`; grammar in
//!   [`crate::describe`]), the way a real drive may contradict the spec;
//!   the parameter itself behaves as the fixture says.
//! - `state=FILE`: load the drives' state from a dump at open if the file
//!   exists, save it back when the link is dropped (or on
//!   [`SimLink::save`]). `driveset-link`'s port parser does not accept this
//!   key yet; until it does, set the environment variable
//!   [`STATE_DIR_ENV`] (`DRIVESET_SIM_STATE_DIR=DIR`): every `sim://` bus
//!   then keeps its state in `DIR/sim-FAMILY.json` (`sim-lustbus.json` for
//!   a mixed LUSTBUS), so a sequence of CLI
//!   invocations (`upload`, then `diff --port`) sees the same drives.
//!
//! # State dumps
//!
//! JSON, one object:
//!
//! ```text
//! {"format":"driveset-sim-state 1","family":"mc6000","baud":9600,
//!  "drives":[{"family":"mc6000","address":1,"schema":"fictional-mc6000-demo",
//!             "fingerprint":"sha256:...","canonical":"driveset-canonical 1\nschema ...\n...",
//!             "slot":"mc6000@1"}]}
//! ```
//!
//! `canonical` is the drive's whole state in the canonical form
//! (docs/file-formats.md), `fingerprint` its sha256. `baud` / `bitrate` /
//! `telegrams` are informative (written by `driveset sim`, ignored on
//! load). A drive's `rate` is written only when it runs at a rate its
//! 81-SBAUD does not say (an MC6000 left at a `--transfer-baud` rate,
//! LUSTBUS 11.5) and is restored on load, so the drive stays at that rate
//! between commands as a powered drive does (`identify`, `scan` and
//! `recover` then find it by the rate search, LUSTBUS 5.1).
//!
//! Each entry also carries its drive's `slot` ([`crate::factory::DriveSlot`]: `mc6000@5`,
//! the family and the address the port names; `mc6000#2`, the port's second
//! factory MC6000) and `assigned` when its address code was written over
//! the bus (the bench moves on). Loading matches a drive by its slot, so a
//! drive whose 82-SADDR / C0009 was written is found again at its new
//! address; an entry without a slot (an older dump) or of a slot this port
//! does not have matches by family and address. A drive of the bus
//! missing from the file keeps its factory state, a drive in the file that
//! is not on the bus is ignored (and not written back); the drives the
//! bench holds off the line are written back as they were.

use std::io;
use std::path::PathBuf;

use driveset_schema::BusProtocol;

use crate::bus::BusError;
use crate::catalog::Family;
use crate::faults::FaultParseError;

/// The environment variable naming a directory where every `sim://` bus
/// keeps its state (`DIR/sim-FAMILY.json`) when the port gives no
/// `state=`.
pub const STATE_DIR_ENV: &str = "DRIVESET_SIM_STATE_DIR";

/// The `format` value of a state dump.
pub const STATE_FORMAT: &str = "driveset-sim-state 1";

/// The option keys [`SimConfig::from_spec`] understands ([`crate::port`]
/// owns the `sim://` port's keys).
pub use crate::port::OPTION_KEYS;
pub use crate::port::{MIXED_LUSTBUS as SIM_MIXED_LUSTBUS, SimSpec};

/// Why a simulated bus could not be opened, loaded or saved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimOpenError {
    /// A family the simulator does not have.
    #[error("{0}")]
    Family(String),
    /// No address given.
    #[error("no drive address given; name at least one (e.g. addresses=1)")]
    NoAddresses,
    /// An address the family's bus does not allow.
    #[error("{family}: address {address} is not allowed: {rule}")]
    BadAddress {
        /// The family.
        family: &'static str,
        /// The address.
        address: u8,
        /// The rule.
        rule: &'static str,
    },
    /// The same address twice.
    #[error("address {0} is given twice; every drive needs its own address")]
    DuplicateAddress(u8),
    /// A mixed bus with a family that cannot share a LUSTBUS line.
    #[error(
        "{family} drives cannot be on a mixed LUSTBUS (sim://lustbus holds mc6000 / mc7000 and vf1000 drives only); put them on a sim://{family} bus of their own"
    )]
    NotLustbus {
        /// The family.
        family: &'static str,
    },
    /// A [`SimConfig`] whose per-drive families do not match its addresses.
    #[error("{families} drive families for {addresses} addresses; give one family per address")]
    FamilyCount {
        /// How many families.
        families: usize,
        /// How many addresses.
        addresses: usize,
    },
    /// A line rate the simulated line does not run at.
    #[error("{baud} baud is not supported; a 7E1 line runs at one of {allowed} baud")]
    BadBaud {
        /// The rate.
        baud: u32,
        /// The allowed rates.
        allowed: String,
    },
    /// A CAN bit rate the simulated bus does not run at.
    #[error("CAN bit rate {bitrate} is not supported; use one of {allowed} bit/s")]
    BadBitrate {
        /// The rate.
        bitrate: u32,
        /// The allowed rates.
        allowed: String,
    },
    /// An option with a bad value.
    #[error("`{key}={value}`: {reason}")]
    BadOption {
        /// The key.
        key: String,
        /// The value.
        value: String,
        /// What it should be.
        reason: String,
    },
    /// An option the simulator does not know.
    #[error("unknown simulator option `{key}`; known: {}", OPTION_KEYS.join(", "))]
    UnknownOption {
        /// The key.
        key: String,
    },
    /// The fault plan does not parse.
    #[error("faults: {0}")]
    Faults(#[from] FaultParseError),
    /// The bus refused its configuration.
    #[error(transparent)]
    Bus(#[from] BusError),
    /// A drive model could not be built.
    #[error("cannot build the simulated {family} drive at address {address}: {reason}")]
    Drive {
        /// The family.
        family: &'static str,
        /// The address.
        address: u8,
        /// Why.
        reason: String,
    },
    /// A twin file or directory that cannot be served ([`crate::twin`]).
    #[error("{0}")]
    Twin(String),
    /// A data sheet that cannot be simulated ([`crate::eds`]).
    #[error("{0}")]
    Eds(String),
    /// Factory-fresh drives the bus cannot hold, or a bench without them
    /// ([`crate::factory`]).
    #[error("{0}")]
    Factory(String),
    /// The state file could not be read or written.
    #[error("simulator state file {}: cannot {op}: {source}", path.display())]
    StateIo {
        /// The file.
        path: PathBuf,
        /// What was being done.
        op: &'static str,
        /// The cause.
        #[source]
        source: io::Error,
    },
    /// The state file is not a usable dump.
    #[error(
        "simulator state file {}: {reason}; delete it to start from factory state",
        path.display()
    )]
    StateFormat {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// Parse a family as `sim://FAMILY` or `--family` gives it: a [`Family`]
/// name or a schema id naming one (`lust-mc6000`, `lenze_ecs`,
/// `fictional-vf1000-demo`): the descriptor's [`Family::from_port_name`].
pub fn parse_family(name: &str) -> Result<Family, SimOpenError> {
    Family::from_port_name(name).ok_or_else(|| {
        SimOpenError::Family(format!(
            "unknown drive family `{name}`: use one of {} (or a schema id such as lust-vf1000)",
            Family::ALL.map(Family::name).join(", ")
        ))
    })
}

/// Whether `family` runs on CAN (frames) rather than a character line
/// ([`driveset_schema::Descriptor::on_can`]).
pub fn is_can(family: Family) -> bool {
    family.descriptor().on_can()
}

/// Check that `address` is a valid drive address on `family`'s bus: the
/// descriptor's one address rule ([`driveset_schema::Descriptor::check_address`],
/// docs/architecture.md, "The family descriptor") decides; the refusal is
/// worded in the simulator's own words (`sim_address_rule`), which its
/// messages have always shown.
pub fn check_address(family: Family, address: u8) -> Result<(), SimOpenError> {
    family
        .descriptor()
        .check_address(i64::from(address))
        .map_err(|refusal| SimOpenError::BadAddress {
            family: family.name(),
            address,
            rule: sim_address_rule(refusal.bus),
        })
}

/// The simulator's words for `bus`'s drive-address rule (`sim://` and twin
/// files' messages, pinned by their tests); the rule itself is
/// [`BusProtocol::check_address`].
fn sim_address_rule(bus: BusProtocol) -> &'static str {
    match bus {
        BusProtocol::Lustbus => {
            "LUSTBUS drive addresses are 1..=30 (section 4.2; 0 is the group address)"
        }
        BusProtocol::Lecom => {
            "LECOM station addresses are 1..=99 except the group addresses 10, 20, ... 90 (§4c)"
        }
        BusProtocol::CanSdo => "CAN node ids are 1..=127",
    }
}

mod config;
mod link;
mod state;
#[cfg(test)]
mod tests;

pub use config::{SimConfig, parse_refuse, state_file_from_env};
pub use link::{SimBus, SimLink, open_sim, open_sim_with};
pub use state::{
    DriveDump, LineDrives, StateDump, byte_line_dump, frame_line_dump, parse_canonical,
};
