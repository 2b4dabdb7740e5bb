//! `driveset upload SET --port P --address A [--dry-run] [--allow-...]
//! [--journal FILE | --journal-dir DIR]`: download a set to a drive as one
//! transaction (driveset-engine's `upload`), or print the plan.
//!
//! Journal: by default `.driveset/journal/<bus>-<address>.journal.json`
//! under the current directory, named after the drive's bus id (the bus
//! independent of the port's spelling, every character that is not a
//! letter or digit `_`; driveset-engine's `journal_path`, shared with
//! `commission`), created before the first write with mode 0600. It holds
//! old values (passwords included); a directory driveset creates gets a
//! `.gitignore` holding `*`. Before anything is sent the journal directory
//! is scanned: an unfinished journal of the same drive (same bus and
//! address, whatever its file name) refuses the upload (exit 2).
//!
//! Exit codes: 0 the drive holds the set (verified; or nothing to write),
//! 2 refused before anything was sent (another family's set without
//! `--allow-family`, a read-only code, a command, a control word that could
//! start the motor, a running drive, an unfinished journal ...)
//! or an input error, 3 bus or device failure: the error names what
//! happened to the drive: "rolled back" (it holds its old values again,
//! verified) or "holds a mix" (run `driveset recover JOURNAL`). A rolled-back
//! upload is 3, not 1: the set did not land because the bus or the drive
//! failed, and scripts must not take it for a mere difference; `--format
//! json` says `"state": "rolled-back"` to tell the two apart.

use std::path::PathBuf;

use driveset_engine::history::{DriveRecord, Slot};

use driveset_engine::dry_run::{self, DryRunOptions, Subject};
use driveset_engine::journal::JournalAt;
use driveset_engine::session;
use driveset_engine::upload::UploadOptions;

use crate::EXIT_OK;
use crate::output;
use crate::output::OutputFormat;
use crate::port::Fail;
use crate::port_args::{LearnFlags, Need, Port, PortCommand, Takes};
use crate::progress::Progress;

/// Arguments of `driveset upload`.
#[derive(clap::Args)]
#[command(after_help = "\
Identifies the drive, reads back every code of the set, writes only what
differs (MC6000/7000: CardWriteable values through the SLOAD dataset
download), verifies, and on failure restores the old values from the
journal. --dry-run prints the plan (codes, old -> new, RAM or EEPROM,
expected time) and writes nothing.

A set whose schema is a LUSTBUS schema that lacks types, kinds or ranges
(e.g. the built-in lust-mc6000) is resolved against the schema learned from
the drive's own descriptions first (the spec's facts stand; written to
--schema-dir when given; --no-learn turns it off). A set pulled by
`driveset pull` names its learned schema file already.

Answer timeouts fit the link: the spec's longest reaction + wire time +
the latency measured from the session's round trips; over a USB adapter or
a serial device server give its round-trip delay with ?latency= (e.g.
--port tcp://moxa:4001?latency=80ms). The report counts the SLOAD polls of
the MC6000/7000 dataset check and any late replies dropped.

Journal: --journal FILE, or DIR/<bus>-<address>.journal.json with
--journal-dir DIR; default .driveset/journal/<bus>-<address>.journal.json
in the current directory, <bus> the drive's bus id (tcp:127.0.0.1:4001,
serial:/dev/ttyUSB0, sim:mc6000 ...) with characters other than letters and
digits as _. It holds the old values, passwords included (mode 0600); a
journal directory driveset creates gets a .gitignore holding *. Refused
(exit 2, nothing sent) while the journal's directory holds an unfinished
journal of the same drive (same bus and address, however the port was
spelled): run `driveset recover JOURNAL` first.

Refused before anything is sent, each unless its own override:
  --allow-family           a set of another family, a drive that identifies
                           as another family (or another 91-TYPE)
  --allow-running          a drive that reports a running motor
  --allow-running-unknown  a drive whose running state cannot be known
                           (its schema names no running bit: lenze-ecs)
  --allow-address-change   a change of the drive's own bus address
Refused with no override: commands (PROG, SLOAD, STAT reset, C0002, C0043
...), a control word in any state but stopped / inhibited (CNTL = 128,
SCTL1 = { start = true }, C0040 = 1 ...), codes not in the schema,
read-only codes. --dry-run shows the same refusals.

Progress on stderr: a bar with the transaction's phase (reading, writing,
verifying, rolling back) and code i of n on a terminal with CI unset; plain
lines when a phase starts otherwise; none with --format json.

Exit codes: 0 the drive holds the set (verified), 2 refused before anything
was sent or an input error, 3 bus or device failure (the message says whether
the drive was rolled back to its old values or holds a mix and needs
`driveset recover JOURNAL`).

Examples:
  driveset upload parameter-sets/mc6000/axis-1.toml --port sim://mc6000?addresses=1 --address 1 --dry-run
  driveset upload conveyor-3.toml --port /dev/ttyUSB0 --address 3 --journal-dir /var/lib/driveset")]
pub struct Args {
    /// The set file.
    #[arg(value_name = "SET")]
    pub set: PathBuf,
    /// The port, the address and learning the schema from the drive
    /// where the set's lacks facts.
    #[command(flatten)]
    pub at: Port<Args>,
    /// Print the plan; write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Named overrides, one per refusal.
    #[command(flatten)]
    pub allow: crate::allow::AllowArgs,
    /// The transfer rate.
    #[command(flatten)]
    pub transfer: crate::allow::TransferArgs,
    /// The journal file.
    #[arg(long, value_name = "FILE", conflicts_with = "journal_dir")]
    pub journal: Option<PathBuf>,
    /// Directory for the journal (file name from port and address).
    #[arg(long, value_name = "DIR")]
    pub journal_dir: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The port.",
        address: Need::Required,
        address_help: "Bus address (the set's [drive] address is NOT used; give it).",
        schemas: true,
        // --allow-family is one of the named overrides (`AllowArgs`)
        learn: LearnFlags::All,
        ..Takes::NONE
    };
}

/// Run `driveset upload`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    upload(&args)
}

fn upload(args: &Args) -> Result<u8, Fail> {
    let overrides = args.allow.overrides()?;
    // a FIFO or device as --journal is refused before the port is opened
    // (reading it back would block or never end)
    if let Some(j) = &args.journal {
        driveset_schema::input::refuse_special_file(j, driveset_schema::input::InputKind::JOURNAL)
            .map_err(|e| Fail::input(format!("--journal {}: {}", j.display(), e.detail())))?;
    }
    let address = args.at.address()?;
    let on = args.at.set_on_drive(&args.set, address, "not uploaded")?;
    let (set, port_name, mut client) = (on.set, on.session.port, on.session.client);
    let json = args.format == OutputFormat::Json;

    let transfer = args.transfer.request(&overrides);
    if args.dry_run {
        let opts = DryRunOptions {
            overrides,
            transfer,
        };
        let result = dry_run::run(client.as_mut(), &set, &opts);
        let _ = client.finish();
        let dry = result?;
        let of = Subject {
            port: port_name,
            address,
            set: args.set.display().to_string(),
        };
        if json {
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&dry.json(&of)).unwrap_or_default()
            ));
        } else {
            output::emit(&dry.render(&of));
        }
        return Ok(EXIT_OK);
    }

    let journal = JournalAt::new(args.journal.as_deref(), args.journal_dir.as_deref())
        .path(&client.bus_id(), client.target().address);
    crate::history::begin_writing(
        "upload",
        crate::history::Context {
            sets: Some(args.set.clone()),
            ..Default::default()
        },
    )?;
    let slot = Slot {
        bus: port_name.clone(),
        address,
        ..Slot::default()
    };
    let schema = client.schema().clone();
    let mut opts = UploadOptions::new(&journal);
    opts.overrides = overrides;
    let result = {
        let p = Progress::new("upload", args.format);
        opts.observer = p.hook();
        let r = session::rate::upload(client.as_mut(), &set, &opts, transfer.as_ref());
        p.done();
        r
    };
    let _ = client.finish();
    crate::history::drive(&DriveRecord::of_upload_outcome(slot, &schema, &result));
    match result {
        Ok(report) => {
            if json {
                output::emit(&format!(
                    "{}\n",
                    serde_json::to_string_pretty(&report).unwrap_or_default()
                ));
            } else {
                let mut text = report.render();
                if report.codes_written == 0 {
                    text.push_str("nothing to write: the drive already holds the set\n");
                }
                output::emit(&text);
            }
            Ok(EXIT_OK)
        }
        Err(failure) => {
            if let Some(report) = &failure.report {
                if json {
                    output::emit(&format!(
                        "{}\n",
                        serde_json::to_string_pretty(report).unwrap_or_default()
                    ));
                } else {
                    output::emit(&report.render());
                }
            }
            Err(Fail::from(*failure.error))
        }
    }
}
