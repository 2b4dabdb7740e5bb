//! Owns the seam between the loop every line run shares and what a run
//! does with each drive (module docs of [`super`]). The loop (`run`, `bus`,
//! `drive`) selects, opens each bus, takes its drives in turn, learns a
//! drive's schema where its set asks, connects, looks up its unfinished
//! journals, counts its telegrams and puts it on the run's record; a
//! [`Walk`] says what is done with the drive then: `commission`
//! ([`super::commissioning`]) brings it to its set, `status`
//! ([`crate::line::status`]) reads it and writes nothing.

use driveset_link::Link;

use super::bus::{OnBus, drive_by_drive};
use super::drive::Job;
use super::run::Ctx;
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::Unfinished;
use crate::line::manifest::{Bus, Drive};
use crate::line::report::{BusReport, DriveReport};
use crate::session::LearnStep;

/// What a line run does with each drive, over the loop every run shares.
pub(in crate::line) trait Walk: Sync {
    /// The report's `command`.
    fn command(&self) -> &'static str;

    /// How a drive whose set's schema lacks facts learns it
    /// ([`crate::session::LearnStep`]; module docs of [`super`], "Learning
    /// the schema").
    fn learn_step(&self) -> LearnStep;

    /// The selected `drives` of a bus whose link is open (`listed`: every
    /// drive the manifest puts on it): their reports and whether the bus
    /// failed. Drive by drive unless the walk does them otherwise.
    fn bus_drives(
        &self,
        on: &OnBus<'_>,
        drives: &[&Drive],
        listed: &[&Drive],
        link: &mut Link,
        report: &mut BusReport,
    ) -> (Vec<DriveReport>, bool) {
        let _ = listed;
        drive_by_drive(on, drives, link, report)
    }

    /// The drive's work once its client is connected: `unfinished` its
    /// unfinished journals (found by bus and address); `recovered` gets a
    /// note per journal recovered (warned also when a later step fails).
    fn work(
        &self,
        job: &Job<'_>,
        client: &mut dyn DriveClient,
        r: &mut DriveReport,
        unfinished: &[Unfinished],
        recovered: &mut Vec<String>,
    ) -> Result<(), EngineError>;

    /// Drive `d` on bus `bus` ended with `r` (also when it never got to
    /// its work).
    fn drive_ended(&self, ctx: &Ctx<'_>, bus: &Bus, d: &Drive, r: &DriveReport) {
        let _ = (ctx, bus, d, r);
    }
}
