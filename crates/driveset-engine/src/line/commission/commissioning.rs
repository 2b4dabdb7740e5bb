//! Owns `commission`'s walk (module docs of [`super`]): the journal
//! directory and the resume state a run starts from; per bus, the
//! broadcast of common values where asked; per drive, its unfinished
//! journals recovered, the resume check, then one upload of what differs
//! (over the online baud-rate switch where the bus asks for one); and the
//! drive's end in the resume state.

use driveset_link::Link;

use super::bus::{OnBus, drive_by_drive, with_broadcast};
use super::drive::{Job, take_upload};
use super::options::{LineError, LineOptions};
use super::recovery::recover_unfinished;
use super::resume::{CommissionState, Resume};
use super::run::Ctx;
use super::walk::Walk;
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::history::Unit;
use crate::journal::Unfinished;
use crate::line::manifest::{Bus, Drive, Manifest};
use crate::line::report::{BusReport, DriveReport, DriveResult};
use crate::overrides::Override;
use crate::session::LearnStep;
use crate::transfer::TransferRequest;
use crate::upload::{UploadOptions, default_journal_path, upload};

/// `commission`'s walk: brings every drive to its set.
pub(super) struct Commissioning {
    resume: Resume,
}

impl Commissioning {
    /// The walk of a run of `manifest`: its journal directory made, its
    /// resume state read (module docs of [`super`], "Resume").
    pub(super) fn start(manifest: &Manifest, opts: &LineOptions) -> Result<Self, LineError> {
        // the one way to create a journal directory: it keeps itself out of
        // git with its own .gitignore, as upload's does
        crate::journal::ensure_dir(&opts.journal_dir).map_err(LineError::JournalDir)?;
        Ok(Commissioning {
            resume: Resume::new(CommissionState::for_run(manifest, opts)?),
        })
    }
}

impl Walk for Commissioning {
    fn command(&self) -> &'static str {
        "commission"
    }

    fn learn_step(&self) -> LearnStep {
        LearnStep::Render
    }

    /// With `broadcast_common`, the bus's broadcast (module docs of
    /// [`super`], "Broadcast").
    fn bus_drives(
        &self,
        on: &OnBus<'_>,
        drives: &[&Drive],
        listed: &[&Drive],
        link: &mut Link,
        report: &mut BusReport,
    ) -> (Vec<DriveReport>, bool) {
        if on.ctx.opts.broadcast_common {
            with_broadcast(on, &self.resume, drives, listed, link, report)
        } else {
            drive_by_drive(on, drives, link, report)
        }
    }

    /// Recovery of the drive's unfinished journals, then (none recovered)
    /// the resume check, then the upload.
    fn work(
        &self,
        job: &Job<'_>,
        client: &mut dyn DriveClient,
        r: &mut DriveReport,
        unfinished: &[Unfinished],
        recovered: &mut Vec<String>,
    ) -> Result<(), EngineError> {
        recover_unfinished(client, job.d, job.ctx, job.hook, unfinished, recovered)?;
        if recovered.is_empty()
            && self
                .resume
                .still_holds(client, job.bus, job.d, r, job.hook, job.ctx)?
        {
            return Ok(());
        }
        upload_drive(job, client, r, !recovered.is_empty())
    }

    /// The drive's record in the resume state: kept when it holds its set,
    /// dropped otherwise.
    fn drive_ended(&self, ctx: &Ctx<'_>, bus: &Bus, d: &Drive, r: &DriveReport) {
        self.resume.record_drive(ctx, bus, d, r);
    }
}

/// One upload of what differs ([`crate::upload::upload`], or
/// [`crate::transfer::upload`] where the bus switches the drive to its
/// transfer rate). `recovered`: a journal of the drive was recovered
/// first, so the drive changed even if the upload writes nothing.
fn upload_drive(
    job: &Job<'_>,
    client: &mut dyn DriveClient,
    r: &mut DriveReport,
    recovered: bool,
) -> Result<(), EngineError> {
    let (d, ctx) = (job.d, job.ctx);
    let journal_path = default_journal_path(&ctx.opts.journal_dir, &*client);
    let mut uo = UploadOptions::new(&journal_path);
    uo.overrides = ctx.opts.overrides;
    let transfer = transfer_request(job.bus, d, ctx);
    uo.observer = job.hook.clone();
    let result = match &transfer {
        Some(req) => crate::transfer::upload(&mut *client, &d.set, &uo, req),
        None => upload(&mut *client, &d.set, &uo),
    };
    if let Some(rep) = result.as_ref().map_or_else(|f| f.report.as_deref(), Some) {
        let mut rec = job.rec.borrow_mut();
        rec.unit = Some(Unit::of(&d.schema, &rep.identity));
        rec.codes = crate::history::upload_codes(&d.schema, &rep.codes);
    }
    if let Some(t) = result.as_ref().map_or_else(
        |f| f.report.as_ref().and_then(|r| r.transfer.clone()),
        |r| r.transfer.clone(),
    ) {
        ctx.warn(format!("{}: {}", d.name, t.decision.summary()));
    }
    match result {
        Ok(rep) => {
            take_upload(r, &d.schema, &rep);
            // a recovered journal changed the drive: never "unchanged"
            r.result = if rep.codes_written == 0 && !recovered {
                DriveResult::Unchanged
            } else {
                DriveResult::Verified
            };
            Ok(())
        }
        Err(f) => {
            if let Some(rep) = &f.report {
                take_upload(r, &d.schema, rep);
            }
            let e = *f.error;
            if e.is_rolled_back() {
                r.result = DriveResult::RolledBack;
            }
            Err(e)
        }
    }
}

/// The online baud-rate switch the drive's upload runs in: the bus's
/// `transfer_baud`, where the drive's family can switch online.
fn transfer_request(bus: &Bus, d: &Drive, ctx: &Ctx<'_>) -> Option<TransferRequest> {
    bus.transfer_baud
        .filter(|_| d.schema.family.descriptor().line_rates.online.is_some())
        .map(|rate| {
            let mut others = bus.families.clone();
            if let Some(i) = others.iter().position(|f| *f == d.schema.family) {
                others.remove(i);
            }
            TransferRequest {
                rate,
                others,
                allow_shared: ctx.opts.overrides.allows(Override::AllowSharedTransferBaud),
            }
        })
}
