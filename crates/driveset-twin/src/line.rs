//! Capturing every drive of a line manifest (`driveset twin capture-line`,
//! docs/twins.md): owns the walk's plan, drive by drive in the manifest's
//! order: the port of its bus, its twin file `DIR/<drive name>.twin.toml`
//! ([`crate::file::path_in`]), its slot in the plant history
//! (docs/history.md) and the history record of its capture ([`LineTwin::record`]:
//! what it holds of its set; [`LineTwin::failed`]: why it was not
//! captured). Each drive is captured with the schema of its set as the
//! manifest resolved it ([`crate::drive`]); opening each port, the calls
//! and what is said of each drive are the caller's, per drive, so one
//! drive's failure does not stop the others.

use std::path::{Path, PathBuf};

use driveset_engine::history::{DriveRecord, Slot};
use driveset_engine::line::manifest::{Bus, Drive, Manifest};

use crate::drive::Captured;

/// One drive of the manifest to capture.
#[derive(Debug)]
pub struct LineTwin<'m> {
    /// The drive (its name, address and set's schema).
    pub drive: &'m Drive,
    /// Its bus.
    pub bus: &'m Bus,
    /// Its bus's port, as the manifest gives it.
    pub port: String,
    /// Its twin file.
    pub out: PathBuf,
    /// Where it sits in the plant history.
    pub slot: Slot,
}

/// Every drive of `manifest`, in its order, with its twin file in `dir`.
pub fn plan<'m>(manifest: &'m Manifest, dir: &Path) -> Vec<LineTwin<'m>> {
    manifest
        .drives
        .iter()
        .map(|d| {
            let bus = &manifest.buses[d.bus_index];
            LineTwin {
                drive: d,
                bus,
                port: bus.port.to_string(),
                out: crate::file::path_in(dir, &d.name),
                slot: Slot {
                    line: Some(manifest.name.clone()),
                    drive: Some(d.name.clone()),
                    bus: bus.name.clone(),
                    address: d.address,
                },
            }
        })
        .collect()
}

impl LineTwin<'_> {
    /// The history record of the drive's capture: each code of its set,
    /// what the drive holds or that it differs
    /// ([`crate::history::line_record`]).
    pub fn record(&self, c: &Captured) -> DriveRecord {
        crate::history::line_record(
            self.slot.clone(),
            self.drive,
            &c.twin,
            &c.schema,
            &c.identity,
        )
    }

    /// The history record of a drive not captured, saying `error`
    /// ([`crate::history::failed_record`]).
    pub fn failed(&self, error: String) -> DriveRecord {
        crate::history::failed_record(self.slot.clone(), self.drive, error)
    }
}
