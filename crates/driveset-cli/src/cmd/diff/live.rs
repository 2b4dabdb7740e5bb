//! `driveset diff SET --port P --address A`: a set against what the drive
//! at the address holds for the set's codes (driveset-engine's `live_diff`),
//! with the offline diff's output and exit codes: old (`---`) is the drive,
//! new (`+++`) the set, so the lines read as what an upload would change.
//! The read is on record (docs/history.md; `DriveRecord::of_live_diff`):
//! each code of the set, what the drive holds, the fingerprint of it.

use std::path::Path;

use driveset_engine::history::{DriveRecord, Slot};
use driveset_engine::session::{self, rate::ReadRate};

use crate::output::OutputFormat;
use crate::port::Fail;

/// What `diff --port` needs.
#[derive(Debug, Clone)]
pub struct LiveArgs<'a> {
    /// The set file.
    pub set: &'a Path,
    /// The port arguments (`--port`, `--schemas`, learning).
    pub at: &'a super::DiffPort,
    /// The address.
    pub address: u8,
    /// Output.
    pub format: OutputFormat,
    /// `--transfer-baud`.
    pub transfer: crate::allow::TransferArgs,
}

/// Run `driveset diff SET --port P --address A`.
pub fn run(args: LiveArgs<'_>) -> Result<u8, crate::fail::Fail> {
    live(&args)
}

fn live(args: &LiveArgs<'_>) -> Result<u8, Fail> {
    crate::history::begin_reading(
        "diff",
        crate::history::Context {
            sets: Some(args.set.to_path_buf()),
            ..Default::default()
        },
    )?;
    let on = args
        .at
        .set_on_drive(args.set, args.address, "not compared")?;
    let (schema, set, port_name, mut client) = (
        on.session.schema,
        on.set,
        on.session.port,
        on.session.client,
    );
    let identity = if args.at.allow_family {
        client.identify()?
    } else {
        driveset_engine::identify::check_family(client.as_mut())?
    };
    let req = args
        .transfer
        .request(&driveset_engine::overrides::Overrides::none());
    let journal_dir = Path::new(driveset_engine::journal::DEFAULT_JOURNAL_DIR);
    let rate = ReadRate::of(req.as_ref(), journal_dir);
    let d = session::rate::live_diff(client.as_mut(), &set, rate).map(|(d, t)| {
        if let Some(t) = t
            && args.format == OutputFormat::Human
        {
            eprint!("{}", t.render());
        }
        d
    });
    let _ = client.finish();
    let d = d?;
    let slot = Slot {
        bus: args.at.port()?.to_string(),
        address: args.address,
        ..Slot::default()
    };
    crate::history::drive(&DriveRecord::of_live_diff(
        slot, &schema, &identity, &set, &d,
    ));
    let old_name = format!("{port_name} address {}", args.address);
    let new_name = args.set.display().to_string();
    Ok(super::render(
        &d,
        &schema,
        &old_name,
        &new_name,
        args.format == OutputFormat::Json,
    ))
}
