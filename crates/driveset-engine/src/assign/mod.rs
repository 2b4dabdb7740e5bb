//! Owns `driveset address`: giving one drive, alone on its line, its bus
//! address (and with `--baud` its line rate) in stand-alone operation, the
//! journal record of that change ([`AssignRecord`]) and its recovery.
//!
//! **LUSTBUS** (`lustbus-protocol.txt` §4.1, §4.2, §5.1, §5.2, §11.5):
//!
//! 1. the address asked for is checked by
//!    [`BusProtocol::check_address`] (one rule: 1..30);
//! 2. the drive is sought at address 0 ("every device answers on this
//!    address", §4.2), at 9600 baud first and then at every other LUSTBUS
//!    rate (§5.1: "the connection will be attempted using all possible
//!    transfer rates"): an ENQUIRY of 91-TYPE. An answer at address 0 that
//!    does not decode is several devices answering at once: refused;
//! 3. the family: the MC CODE 20091 answers on a servocontroller, an
//!    inverter NAKs it (as [`crate::scan::detect_protocol`]);
//! 4. the network list of §5.2 (an ENQUIRY of 91-TYPE to 1..30): more than
//!    one answer is more than one device on the line: refused; an answer at
//!    the address asked for from another device: refused ("no address is
//!    assigned twice", §4.2);
//! 5. the drive must be at standstill (`crate::guard::standstill`: a
//!    running motor is refused unless `--allow-running`, an unknown
//!    running state unless `--allow-running-unknown`), asked while the
//!    plan reads and again before the first write;
//! 6. journal, then 82-SIOA/SADDR = N at address 0 (permit
//!    `Permit::BUS_ADDRESS`); verified at N (82 = N, 91 = the TYPE read
//!    at 0) and, when the drive had another own address before, that
//!    nothing answers there any more;
//! 7. `--baud B` last, at N: 81-SBAUD/SIOC = B (permit
//!    `Permit::LINE_RATE`); an MC6000/7000 activates it at once with
//!    4-PROG = 111 (§11.5, permit `ACTIVATE_RATE`; its ACK still comes at
//!    the old rate), the host follows and verifies 81, 82 and 91 at B; a
//!    VF1000 only at its next restart (§11.5): 81 is read back and the
//!    report says when it takes effect.
//!
//! **LECOM** (`lecom-ab-tmd-manual.txt` §4c, §4d, §4e, Table 1): the drive
//! at `--from M` (default 1, the factory C0009); refused when another
//! device answers at N; the drive at standstill (as step 5 above); C0001
//! must allow LECOM writes (2 or 3, §4e): the
//! refusal gives the advice an upload's refused write gives
//! ([`crate::error::LECOM_PROGRAMMING_ADVICE`]); C0009 = N at M, verified
//! at N; `--baud`: C0125 = the code of the rate (Table 1: 0 = 9600,
//! 1 = 4800, 2 = 2400, 3 = 1200), read back; the Tmd takes it at its next
//! power-up (the manual says it must be set "prior to attempting to
//! communicate", §4d, and names no online activation).
//!
//! **Order: the address first, the rate last.** A lone LUSTBUS drive
//! answers at address 0 whatever its own address, so a cut around the
//! address write never loses it; a cut around the rate change can (the
//! drive may run at either rate). With the address written and verified
//! first, at the rate the drive was found at (for a new drive the factory
//! 9600 baud, where a human with a keypad or any tool looks first), the
//! only step that can leave the drive at an unexpected rate is the last
//! one, after which both its addresses are known: recover (and a human)
//! search the rates at two addresses only. The VF1000 and the Tmd take a
//! new rate only at a restart, so for them the rate must be the last step
//! anyway: everything else is verified at the rate the drive still runs at.
//!
//! **Never half-done.** The journal ([`AssignRecord`] in a
//! [`crate::journal::Journal`] bound to the bus id and the new address N)
//! is on disk before the first write. [`recover()`] finds the drive (at N
//! and at the old address, at the recorded rates and then every rate of
//! the family) and finishes the change: every step is idempotent (a value
//! already in place is not written again), so a cut at any telegram ends
//! fully switched once recover ran.
//!
//! **Dry run** ([`plan()`]): every probe and read above, the refusals, and
//! the writes it would send (telegram, code, value, address, rate);
//! nothing is written and no journal is made.

mod codes;
mod learn;
mod plan;
mod probe;
mod record;
mod recover;
mod refusal;
mod report;
mod run;

use std::path::Path;
use std::sync::Arc;

use driveset_link::Link;
use driveset_schema::{BusProtocol, Family, Registry, Schema};

use crate::error::EngineError;
use crate::overrides::Overrides;
use crate::scan::ScanOptions;

pub use codes::{address_code, address_of_raw, address_raw, rate_code, rate_of_raw, rate_raw};
pub use plan::plan;
pub use record::{AssignRecord, AssignStep};
pub(crate) use recover::not_for_upload_recover;
pub use recover::{is_assign_journal, recover};
pub use refusal::AssignRefusal;
pub use report::{AssignPlan, AssignRecovered, AssignReport, PlannedWrite, RateEffect, found_text};
pub use run::run;

/// LUSTBUS rates in the order §5.1 tries them: the standard 9600 first,
/// then every other rate a LUSTBUS device runs at (§4), highest first.
pub const LUSTBUS_SEARCH: [u32; 6] = [9600, 57600, 38400, 19200, 4800, 2400];
/// LECOM rates of the Tmd (C0125), the factory 9600 first: the
/// descriptor's rates highest first ([`crate::scan::LECOM_BAUDS`]), whose
/// first is the factory 9600.
pub const LECOM_SEARCH: [u32; 4] = crate::scan::LECOM_BAUDS;

/// What `driveset address` asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AssignRequest {
    /// The bus protocol of the line (LUSTBUS or LECOM).
    pub protocol: BusProtocol,
    /// The address to give the drive.
    pub to: u8,
    /// LECOM: the address the drive answers at now (default 1, the
    /// factory C0009). LUSTBUS: unused (the drive is reached at address 0).
    pub from: Option<u8>,
    /// The line rate to give the drive too.
    pub baud: Option<u32>,
    /// Probe timeouts and tries of the searches and the scan.
    pub scan: ScanOptions,
    /// Write the address code even when the drive holds the address
    /// already ([`AssignRequest::always_write_address`]).
    pub always_write_address: bool,
    /// Prove the port holds this one device before anything is written
    /// ([`AssignRequest::alone`]).
    pub alone: bool,
    /// The named overrides of the running rule (`--allow-running`,
    /// `--allow-running-unknown`): no address or rate is written to a
    /// running drive otherwise (`crate::guard::standstill`).
    pub overrides: Overrides,
}

impl AssignRequest {
    /// A request for address `to` on a `protocol` line.
    pub fn new(protocol: BusProtocol, to: u8) -> Self {
        AssignRequest {
            protocol,
            to,
            from: None,
            baud: None,
            scan: ScanOptions::default(),
            always_write_address: false,
            alone: false,
            overrides: Overrides::none(),
        }
    }

    /// `driveset address`'s request for address `to` on a `protocol` line,
    /// from `from` (LECOM) and with the line rate `baud`, its options
    /// checked before the port is touched.
    ///
    /// # Errors
    /// [`RequestError`]: a CAN line (a node id is set on the drive), or
    /// `from` on LUSTBUS (a lone drive answers at address 0).
    pub fn checked(
        protocol: BusProtocol,
        to: u8,
        from: Option<u8>,
        baud: Option<u32>,
    ) -> Result<Self, RequestError> {
        match protocol {
            BusProtocol::CanSdo => return Err(RequestError::CanNode(protocol)),
            BusProtocol::Lustbus if from.is_some() => return Err(RequestError::FromOnLustbus),
            _ => {}
        }
        let mut req = AssignRequest::new(protocol, to);
        req.from = from;
        req.baud = baud;
        Ok(req)
    }

    /// The same, proving first that the port holds this one device
    /// (`replace`, `commission --assign`): on LECOM every station 01..99 is
    /// scanned at the rate the drive answered, and any other answer refuses
    /// ([`AssignRefusal::NotAlone`], naming who answered). LUSTBUS proves
    /// it anyway (the network list of §5.2 and the collision check at
    /// address 0).
    pub fn alone(mut self) -> Self {
        self.alone = true;
        self
    }

    /// The same, writing the address code even when the drive holds the
    /// address already: the line's first contact (`commission --assign`,
    /// `replace`) gives every unit its place explicitly, a factory-fresh
    /// unit whose manifest address is the factory one included (the write
    /// is stored; the simulator's service bench takes it as the cue that
    /// this unit is done).
    pub fn always_write_address(mut self) -> Self {
        self.always_write_address = true;
        self
    }

    /// The same with `--from`.
    pub fn from(mut self, from: u8) -> Self {
        self.from = Some(from);
        self
    }

    /// The same with `--baud`.
    pub fn baud(mut self, baud: u32) -> Self {
        self.baud = Some(baud);
        self
    }
}

/// Why `driveset address`'s options are refused before the port is
/// touched ([`AssignRequest::checked`]; an input error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// A CAN line: its node id is set on the drive.
    #[error(
        "--protocol {}: driveset address sets LUSTBUS and LECOM addresses; a CAN node id is set on the drive",
        .0.name()
    )]
    CanNode(BusProtocol),
    /// `--from` on LUSTBUS, where a lone drive answers at address 0.
    #[error(
        "--from is for LECOM: a lone LUSTBUS drive is reached at address 0 whatever its own address (lustbus-protocol.txt §4.1); leave out --from"
    )]
    FromOnLustbus,
}

/// The schema used for each family's drive (the LUSTBUS family is known
/// only once the drive answered).
#[derive(Debug, Clone, Default)]
pub struct Schemas {
    by_family: Vec<Arc<Schema>>,
}

impl Schemas {
    /// No schemas.
    pub fn new() -> Self {
        Schemas::default()
    }

    /// Each serial family's built-in schema from `registry` (by the
    /// descriptor's `schema_id`; a family on CAN has no address to set
    /// here).
    pub fn from_registry(registry: &Registry) -> Self {
        let mut s = Schemas::new();
        for f in Family::ALL.into_iter().filter(|f| !f.descriptor().on_can()) {
            if let Some(schema) = registry.get(f.descriptor().schema_id) {
                s = s.with(schema);
            }
        }
        s
    }

    /// The same, `schema` used for its family.
    pub fn with(mut self, schema: Arc<Schema>) -> Self {
        self.by_family.retain(|s| s.family != schema.family);
        self.by_family.push(schema);
        self
    }

    /// The schema of `family`.
    pub fn get(&self, family: Family) -> Option<Arc<Schema>> {
        self.by_family.iter().find(|s| s.family == family).cloned()
    }
}

/// The client for the drive at `address` of a link `driveset address`
/// keeps while it changes the drive's address: the session's borrowed-link
/// session, without learning ([`crate::session::BusSession::connect`]).
fn drive_on(
    link: &mut Link,
    schema: Arc<Schema>,
    address: u8,
) -> Result<Box<dyn crate::client::DriveClient + '_>, EngineError> {
    let port = link.port().to_string();
    Ok(crate::session::BusSession::connect(link, &port, schema, address)?.client)
}

/// [`plan()`], then [`run()`].
pub fn assign(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
    journal: &Path,
) -> Result<AssignReport, EngineError> {
    let p = plan(link, req, schemas)?;
    run(link, &p, journal)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_refuses_can_and_from_on_lustbus_before_the_port() {
        let e = AssignRequest::checked(BusProtocol::CanSdo, 3, None, None).unwrap_err();
        assert_eq!(e, RequestError::CanNode(BusProtocol::CanSdo));
        assert!(
            e.to_string()
                .starts_with("--protocol can: driveset address sets LUSTBUS and LECOM addresses"),
            "{e}"
        );
        let e = AssignRequest::checked(BusProtocol::Lustbus, 3, Some(1), None).unwrap_err();
        assert_eq!(e, RequestError::FromOnLustbus);
        assert!(e.to_string().starts_with("--from is for LECOM"), "{e}");
        let r = AssignRequest::checked(BusProtocol::Lecom, 12, Some(1), Some(4800)).unwrap();
        assert_eq!(
            r,
            AssignRequest::new(BusProtocol::Lecom, 12)
                .from(1)
                .baud(4800)
        );
        let r = AssignRequest::checked(BusProtocol::Lustbus, 5, None, Some(38400)).unwrap();
        assert_eq!((r.from, r.baud), (None, Some(38400)));
    }
}
