//! The manifest's address is the truth (issue 20): a line run never writes
//! a drive's bus address or line rate from its set. Owns
//! [`check_drive`], the check every line run (`commission`, `status`) makes
//! of a drive's set before it talks to the drive, and its refusal
//! [`SetBusCodes`].
//!
//! A set that gives the bus address code (role `bus-address`: LUSTBUS
//! 82-SADDR / SIOA, Tmd C0009) or the line rate code (role `baud-rate`:
//! 81-SBAUD / SIOC, C0125):
//! - with the manifest's value (the drive's `address`, its bus's `baud`):
//!   a no-op: the drive answers at that address and rate, so it holds them
//!   and the planner writes nothing for the code (the set and its
//!   fingerprint stay as the file has them);
//! - with another value: the drive is refused before anything is sent to
//!   it, naming the set's file:line, the manifest's address (or rate) and
//!   its place, and the fix (remove the code from the set; a drive gets a
//!   new address or rate only through `driveset address` / `driveset
//!   replace`, lustbus-protocol.txt section 4.2: addresses are set in
//!   stand-alone operation). `validate LINE` reports the same finding
//!   (`set-address` / `set-rate`) offline.
//!
//! A drive whose schema is learned from the drive gets the check after the
//! learning, on the set resolved against the learned schema.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use driveset_schema::Location;

use super::manifest::{Bus, Drive, Manifest, ManifestFinding, bus_code_finding};
use super::report::{DriveReport, DriveResult};

/// A drive refused because its set gives its bus address or line rate a
/// value other than the manifest's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SetBusCodes {
    /// The drive's name.
    pub drive: String,
    /// One finding per disagreeing code (`set-address`, `set-rate`), at the
    /// set's line, the manifest's place related.
    pub findings: Vec<ManifestFinding>,
}

impl fmt::Display for SetBusCodes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "refused before anything was sent to the drive: ")?;
        for (i, x) in self.findings.iter().enumerate() {
            if i > 0 {
                write!(f, "; ")?;
            }
            write!(f, "{}: {}", x.location, x.message)?;
            for (label, loc) in &x.related {
                write!(f, " ({loc}: {label})")?;
            }
        }
        let help = self
            .findings
            .first()
            .map(|x| x.help.as_str())
            .unwrap_or_default();
        write!(
            f,
            "; {help}. A line run never writes a drive's bus address or line rate: give a drive its address with `driveset address` (or `driveset replace` for an exchanged unit)"
        )
    }
}

impl std::error::Error for SetBusCodes {}

/// The check of a drive's set against the manifest (module docs): `Err`
/// when its bus address or line rate code disagrees with the manifest.
pub fn check_drive(bus: &Bus, d: &Drive) -> Result<(), SetBusCodes> {
    let findings: Vec<ManifestFinding> = d
        .set
        .values
        .keys()
        .filter(|k| {
            d.schema
                .role_of(k.number)
                .is_some_and(driveset_schema::Role::is_bus_link)
        })
        .filter_map(|k| {
            let loc = d.set_bus_codes.iter().find(|(p, _)| p == k).map_or_else(
                || Location::file_only(d.set_text.clone()),
                |(_, l)| l.clone(),
            );
            bus_code_finding(
                d,
                *k,
                &loc,
                &d.address_location,
                Some(bus),
                bus.rate_location.as_ref(),
            )
        })
        .collect();
    if findings.is_empty() {
        Ok(())
    } else {
        Err(SetBusCodes {
            drive: d.name.clone(),
            findings,
        })
    }
}

/// The selected drives of `manifest` that [`check_drive`] refuses, as
/// failed drive reports (by drive name): a line run does not touch them.
pub fn refuse_line(
    manifest: &Manifest,
    selected: &BTreeSet<String>,
) -> BTreeMap<String, DriveReport> {
    let mut out = BTreeMap::new();
    for d in manifest
        .drives
        .iter()
        .filter(|d| selected.contains(&d.name))
    {
        let bus = &manifest.buses[d.bus_index];
        if let Err(e) = check_drive(bus, d) {
            let mut r = super::commission::blank_report(d, bus, DriveResult::Failed);
            r.error = Some(e.to_string());
            out.insert(d.name.clone(), r);
        }
    }
    out
}
