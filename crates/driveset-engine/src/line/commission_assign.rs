//! The line's first contact (`driveset commission LINE --assign`, issue
//! 20): every drive of the line's LUSTBUS and LECOM buses, fresh from the
//! factory, gets its manifest address and its bus's rate in stand-alone
//! operation (lustbus-protocol.txt section 4.2: "the addresses ... must be
//! set individually before connecting them to the LUSTBUS"), one at a
//! time, then the whole bus is scanned. Owns [`commission_assign`], its report
//! ([`CommissionAssignReport`]) and the final check ([`ScanRow`]).
//!
//! Per bus, in manifest order, per drive of the bus in manifest order:
//! 1. the caller's `connect` is told which drive to connect alone to the
//!    bus's port (the CLI prompts "connect NAME alone to PORT, then press
//!    Enter" and waits; it can stop the run);
//! 2. the port is opened anew (a service bench decides at open who is on
//!    the line), and [`crate::assign::assign`] gives the drive the
//!    manifest's address and the bus's rate, journalled, verified; the
//!    address is written even when the unit holds it already
//!    ([`AssignRequest::always_write_address`]); a drive whose family does
//!    not fit its set's schema is refused before anything is written;
//! 3. once every drive of the bus is done, the port is opened once more and
//!    the bus scanned (LUSTBUS 1..30, LECOM the stations): every manifest
//!    address must answer with the family of its set's schema (and a TYPE
//!    the schema allows, where it names some), and nothing may answer
//!    where the manifest has no drive.
//!
//! **A unit only once.** A unit that holds an address this run gave an
//! earlier drive of the bus is that drive's unit again (the engineer
//! connected the wrong one, or never swapped): it is refused before
//! anything is written, naming the earlier drive. The address the bus's
//! first unit was found holding is taken as the one units leave the
//! factory with (lustbus-protocol.txt §4.2: every device is set at the
//! factory to the same address): a unit holding it cannot be told from a
//! fresh one, so when a manifest address is that same address, a repeat of
//! that one unit is caught by the final scan (its first address then stays
//! silent), not before its write.
//!
//! CAN buses are not assigned this way (an ECS node id is set at the unit):
//! they are listed as skipped, with the reason. A failure on a drive stops
//! its bus (the next drive would be connected beside an unfinished one);
//! the other buses go on.

use std::path::PathBuf;
use std::time::Duration;

use driveset_link::Link;
use driveset_schema::BusProtocol;
use driveset_schema::family::TYPE;
use serde::Serialize;

use super::commission::Opener;
use super::manifest::{Bus, Drive, Manifest};
use crate::assign::{AssignRequest, Schemas};
use crate::client::IdentProtocol;
use crate::error::EngineError;
use crate::scan::{ScanOptions, lecom_addresses, lustbus_addresses, scan_lecom, scan_lustbus};

/// Why a first contact's `--port` does not fit the line
/// ([`on_service_port`]).
#[derive(Debug, thiserror::Error)]
pub enum ServicePortError {
    /// The line has not exactly one LUSTBUS / LECOM bus.
    #[error(
        "--port {port}: the line has {buses} LUSTBUS / LECOM buses; --port names the one port the drives are connected to, so it fits a line with one such bus (leave it out to use each bus's own port)"
    )]
    NotOneBus {
        /// The port given.
        port: String,
        /// How many LUSTBUS / LECOM buses the line has.
        buses: usize,
    },
    /// The port does not parse.
    #[error("--port {port}: {source}")]
    BadPort {
        /// The port given.
        port: String,
        /// Why it does not parse.
        source: Box<driveset_link::PortSpecError>,
    },
}

/// `manifest` with its one LUSTBUS / LECOM bus on `port`, the service port
/// the drives are connected to one at a time (`commission --assign
/// --port`), at the bus's rate (an opener's port through `openers`);
/// refused when the line has not exactly one such bus.
pub fn on_service_port(
    mut manifest: Manifest,
    port: &str,
    openers: &driveset_link::Openers,
) -> Result<Manifest, ServicePortError> {
    let serial: Vec<usize> = manifest
        .buses
        .iter()
        .enumerate()
        .filter(|(_, b)| b.protocol != BusProtocol::CanSdo)
        .map(|(i, _)| i)
        .collect();
    let [i] = serial[..] else {
        return Err(ServicePortError::NotOneBus {
            port: port.to_string(),
            buses: serial.len(),
        });
    };
    let spec =
        driveset_link::PortSpec::parse(port).map_err(|source| ServicePortError::BadPort {
            port: port.to_string(),
            source: Box::new(source),
        })?;
    let b = &mut manifest.buses[i];
    b.port_name = spec.to_string();
    b.port = openers.at_rate(&spec, b.rate);
    Ok(manifest)
}

/// Why one drive's assignment failed.
#[derive(Debug, thiserror::Error)]
enum AssignOneError {
    #[error("{0}")]
    Misfit(super::replace::Misfit),
    /// The unit holds an address this run gave an earlier drive of the bus
    /// (module docs, "A unit only once").
    #[error(
        "the unit on the port holds address {held}, which this run gave `{earlier}`: it is `{earlier}`'s unit again, not `{drive}`'s; nothing was written. Disconnect it and connect `{drive}`'s unit alone"
    )]
    Again {
        /// The address it holds.
        held: u8,
        /// The drive this run gave it to.
        earlier: String,
        /// The drive being assigned.
        drive: String,
    },
    #[error("{0}")]
    Engine(#[from] EngineError),
}

/// What a bus's first contact has done so far (module docs, "A unit only
/// once"): the addresses it gave, to which drive, and the address the
/// bus's first unit was found holding.
#[derive(Debug, Default)]
struct Given {
    /// (address, drive) in the order given.
    given: Vec<(u8, String)>,
    /// The own address of the first unit found (taken as the factory's).
    factory: Option<i64>,
}

impl Given {
    /// The unit found by `p` for drive `d`: refused when it holds an
    /// address this run gave, unless that is the factory's.
    fn check(&mut self, d: &Drive, p: &crate::assign::AssignPlan) -> Result<(), AssignOneError> {
        let Some(held) = p.old_address else {
            return Ok(());
        };
        let factory = *self.factory.get_or_insert(held);
        match self.given.iter().find(|(a, _)| i64::from(*a) == held) {
            Some((a, earlier)) if held != factory => Err(AssignOneError::Again {
                held: *a,
                earlier: earlier.clone(),
                drive: d.name.clone(),
            }),
            _ => Ok(()),
        }
    }
}

/// Options of [`commission_assign`].
#[derive(Debug, Clone)]
pub struct CommissionAssignOptions {
    /// Where the assignment journals go (the line's journal directory).
    pub journal_dir: PathBuf,
    /// Probe timeouts of the searches and scans.
    pub scan: ScanOptions,
    /// Drive (or bus) names to do; empty: all.
    pub only: Vec<String>,
    /// The running rule's overrides (`--allow-running`,
    /// `--allow-running-unknown`, `crate::guard::standstill`).
    pub overrides: crate::overrides::Overrides,
}

/// One drive given its address and rate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriveAssigned {
    /// The drive's name.
    pub drive: String,
    /// The manifest's address.
    pub address: u8,
    /// The bus's rate, given to the drive.
    pub rate: u32,
    /// The family that answered.
    pub family: Option<String>,
    /// LUSTBUS 91-TYPE read.
    pub type_value: Option<i64>,
    /// The rate the unit was found at.
    pub found_at: Option<u32>,
    /// Writes sent.
    pub written: Vec<String>,
    /// When a stored rate takes effect (VF1000, Tmd: at their next restart).
    pub rate_note: Option<String>,
    /// Link clock time of this drive's assignment, ms.
    pub elapsed_ms: f64,
    /// What failed, if anything (nothing further is done on the bus).
    pub error: Option<String>,
}

/// One address of the final scan.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ScanRow {
    /// The address.
    pub address: u8,
    /// The manifest's drive there.
    pub drive: Option<String>,
    /// The family the manifest's set wants there.
    pub expected: Option<String>,
    /// The family that answered (`lustbus` when only the bus is known).
    pub found: Option<String>,
    /// 91-TYPE (LUSTBUS) or C0093 (Tmd) that answered.
    pub type_value: Option<String>,
    /// Whether the address is as the manifest says.
    pub ok: bool,
}

/// One bus of the first contact.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BusAssign {
    /// The bus's name.
    pub bus: String,
    /// Its port as reports name it.
    pub port: String,
    /// Why the bus was not assigned (CAN), if so.
    pub skipped: Option<String>,
    /// The drives, in manifest order.
    pub drives: Vec<DriveAssigned>,
    /// The final scan (empty when not reached).
    pub scan: Vec<ScanRow>,
    /// Why the final scan did not run or failed, if so.
    pub scan_error: Option<String>,
    /// Link clock time of the final scan, ms.
    pub scan_ms: f64,
    /// Link clock time of the whole bus (every open's time added), ms.
    pub elapsed_ms: f64,
}

impl BusAssign {
    /// Whether every drive got its address and the scan holds.
    pub fn holds(&self) -> bool {
        self.skipped.is_some()
            || (self.scan_error.is_none()
                && self.drives.iter().all(|d| d.error.is_none())
                && !self.scan.is_empty()
                && self.scan.iter().all(|r| r.ok))
    }
}

/// The whole first contact.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CommissionAssignReport {
    /// The line's name.
    pub line: String,
    /// One entry per bus, in manifest order.
    pub buses: Vec<BusAssign>,
    /// Whether every assigned bus holds (skipped CAN buses do not count).
    pub ok: bool,
}

/// Why a drive may not be connected now: the caller stopped the run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stopped(pub String);

/// Told each drive before its assignment (module docs, step 1).
pub type Connect<'a> = dyn FnMut(&Bus, &Drive) -> Result<(), Stopped> + 'a;

fn link_ms(link: &Link) -> Duration {
    match link {
        Link::Bytes(b) => b.clock().now().since_epoch(),
        Link::Frames(f) => f.clock().now().since_epoch(),
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// The schemas the assignment identifies with: every set's schema of the
/// bus, `first` winning for its family.
fn schemas_of(drives: &[&Drive], first: &Drive) -> Schemas {
    let mut s = super::replace::known_schemas();
    for d in drives {
        s = s.with(d.schema.clone());
    }
    s.with(first.schema.clone())
}

/// Give one drive its address and rate (module docs, step 2).
fn assign_one(
    bus: &Bus,
    d: &Drive,
    drives: &[&Drive],
    opener: &Opener<'_>,
    opts: &CommissionAssignOptions,
    given: &mut Given,
) -> DriveAssigned {
    let mut out = DriveAssigned {
        drive: d.name.clone(),
        address: d.address,
        rate: bus.rate,
        family: None,
        type_value: None,
        found_at: None,
        written: Vec::new(),
        rate_note: None,
        elapsed_ms: 0.0,
        error: None,
    };
    let mut link = match opener(bus) {
        Ok(l) => l,
        Err(e) => {
            out.error = Some(format!(
                "bus `{}` ({}) could not be opened: {e}",
                bus.name, bus.port_name
            ));
            return out;
        }
    };
    let t0 = link_ms(&link);
    let mut req = AssignRequest::new(bus.protocol, d.address)
        .always_write_address()
        .alone();
    if bus.rate != 0 {
        req = req.baud(bus.rate);
    }
    req.scan = opts.scan.clone();
    req.overrides = opts.overrides;
    let schemas = schemas_of(drives, d);
    let result = (|| -> Result<crate::assign::AssignReport, AssignOneError> {
        let p = crate::assign::plan(&mut link, &req, &schemas)?;
        out.family = Some(p.family.name().to_string());
        out.type_value = p.type_value;
        out.found_at = Some(p.rate);
        given.check(d, &p)?;
        super::replace::check_spare(d, &p).map_err(AssignOneError::Misfit)?;
        let journal = crate::journal::journal_path(&opts.journal_dir, &p.bus, p.to);
        Ok(crate::assign::run(&mut link, &p, &journal)?)
    })();
    match result {
        Ok(rep) => {
            out.written = rep.written;
            out.rate_note = rep.rate_note;
            given.given.push((d.address, d.name.clone()));
        }
        Err(e) => out.error = Some(e.to_string()),
    }
    out.elapsed_ms = ms(link_ms(&link).saturating_sub(t0));
    out
}

/// The final scan of a bus (module docs, step 3).
fn final_scan(
    bus: &Bus,
    drives: &[&Drive],
    opener: &Opener<'_>,
    opts: &CommissionAssignOptions,
) -> Result<(Vec<ScanRow>, f64), String> {
    let mut link = opener(bus).map_err(|e| {
        format!(
            "bus `{}` ({}) could not be opened: {e}",
            bus.name, bus.port_name
        )
    })?;
    let t0 = link_ms(&link);
    let Link::Bytes(b) = &mut link else {
        return Err(format!("bus `{}` is not a character line", bus.name));
    };
    let lecom_schema = drives
        .iter()
        .find(|d| d.schema.family.bus() == BusProtocol::Lecom)
        .map(|d| d.schema.clone());
    let found = match bus.protocol {
        BusProtocol::Lustbus => scan_lustbus(&mut **b, &lustbus_addresses(), &opts.scan),
        _ => scan_lecom(
            &mut **b,
            lecom_schema.as_deref(),
            &lecom_addresses(),
            &opts.scan,
        ),
    }
    .map_err(|e| e.to_string())?;
    let mut addresses: Vec<u8> = drives.iter().map(|d| d.address).collect();
    addresses.extend(found.iter().map(|f| f.address));
    addresses.sort_unstable();
    addresses.dedup();
    let mut rows = Vec::new();
    for a in addresses {
        let d = drives.iter().find(|d| d.address == a);
        let f = found.iter().find(|f| f.address == a);
        let family = match f {
            None => None,
            Some(_) if bus.protocol == BusProtocol::Lustbus => {
                crate::scan::detect_protocol(&mut **b, a, &opts.scan)
                    .map_err(|e| e.to_string())?
                    .map(|x| x.protocol.name().to_string())
                    .or_else(|| Some("lustbus".to_string()))
            }
            Some(f) => Some(match f.identity.protocol {
                IdentProtocol::Family(fam) => fam.name().to_string(),
                _ => "lecom".to_string(),
            }),
        };
        let type_value = f.and_then(|f| {
            f.identity
                .value_of(TYPE)
                .or_else(|| f.identity.value_of(93))
                .map(|v| v.to_string())
        });
        let expected = d.map(|d| d.schema.family.name().to_string());
        let type_fits = match (d, f) {
            (Some(d), Some(f)) => d.schema.identify.as_ref().is_none_or(|i| {
                i.type_values.is_empty()
                    || f.identity
                        .value_of(d.schema.family.descriptor().device_type_code())
                        .and_then(crate::client::IdentValue::as_int)
                        .is_some_and(|t| i.type_values.contains(&t))
            }),
            _ => false,
        };
        let ok = d.is_some() && f.is_some() && family == expected && type_fits;
        rows.push(ScanRow {
            address: a,
            drive: d.map(|d| d.name.clone()),
            expected,
            found: family,
            type_value,
            ok,
        });
    }
    Ok((rows, ms(link_ms(&link).saturating_sub(t0))))
}

/// The line's first contact (module docs).
pub fn commission_assign(
    manifest: &Manifest,
    opts: &CommissionAssignOptions,
    opener: &Opener<'_>,
    connect: &mut Connect<'_>,
) -> CommissionAssignReport {
    let mut buses = Vec::new();
    for (bi, bus) in manifest.buses.iter().enumerate() {
        let listed: Vec<&Drive> = manifest
            .drives
            .iter()
            .filter(|d| d.bus_index == bi)
            .collect();
        let selected = |d: &Drive| {
            opts.only.is_empty() || opts.only.iter().any(|n| *n == d.name || *n == bus.name)
        };
        if !listed.iter().any(|d| selected(d)) {
            continue;
        }
        let mut b = BusAssign {
            bus: bus.name.clone(),
            port: bus.port_name.clone(),
            skipped: None,
            drives: Vec::new(),
            scan: Vec::new(),
            scan_error: None,
            scan_ms: 0.0,
            elapsed_ms: 0.0,
        };
        if bus.protocol == BusProtocol::CanSdo {
            b.skipped = Some(format!(
                "bus `{}` is a CAN bus: an ECS node id is set at the unit, not assigned over the bus; its drives are not assigned",
                bus.name
            ));
            buses.push(b);
            continue;
        }
        let mut stopped = None;
        let mut given = Given::default();
        for d in listed.iter().filter(|d| selected(d)) {
            if let Err(Stopped(why)) = connect(bus, d) {
                stopped = Some(why);
                break;
            }
            let r = assign_one(bus, d, &listed, opener, opts, &mut given);
            b.elapsed_ms += r.elapsed_ms;
            let failed = r.error.is_some();
            b.drives.push(r);
            if failed {
                break;
            }
        }
        if let Some(why) = stopped {
            b.scan_error = Some(why);
        } else if b.drives.iter().any(|d| d.error.is_some()) {
            b.scan_error = Some(format!(
                "not scanned: a drive of bus `{}` was not assigned",
                bus.name
            ));
        } else {
            match final_scan(bus, &listed, opener, opts) {
                Ok((rows, t)) => {
                    b.scan = rows;
                    b.scan_ms = t;
                    b.elapsed_ms += t;
                }
                Err(e) => b.scan_error = Some(e),
            }
        }
        buses.push(b);
    }
    let ok = buses.iter().all(BusAssign::holds);
    CommissionAssignReport {
        line: manifest.name.clone(),
        buses,
        ok,
    }
}
