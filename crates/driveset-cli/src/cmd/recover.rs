//! `driveset recover JOURNAL [--port P] [--address A]`: finish or roll back
//! an interrupted upload from its journal alone (driveset-engine's
//! `recover`). Port, address and schema come from the journal (a `sim://`
//! port without the faults of the run that was cut; the schema by the id,
//! file and fingerprint the journal records); `--port` replaces the port
//! (the adapter moved; any spelling of the journal's bus is accepted).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use driveset_engine::assign;
use driveset_engine::history::{self, DriveRecord, Slot};
use driveset_engine::journal::{JournalFile, TxnState};
use driveset_engine::recover::{
    JournalRoute, RecoverAction, RecoverOptions, RecoverReport, recover as engine_recover, route,
};

use crate::EXIT_OK;
use crate::output;
use crate::output::OutputFormat;
use crate::port::{self, Fail};
use crate::port_args::{Need, Port, PortCommand, SchemaCount, Takes};
use crate::progress::Progress;

/// Arguments of `driveset recover`.
#[derive(clap::Args)]
#[command(after_help = "\
Reads the journal an interrupted `driveset upload` or `driveset commission`
left and checks that the port reaches the drive the journal was written
for. Refused (exit 2, nothing sent) when the port reaches another bus
(compared by bus id, so tcp://localhost:P and tcp://127.0.0.1:P are one
bus), when --address names another drive, when the schema differs or the
journal is version 1; refused after identify (exit 2, nothing written) when
the drive identifies differently, or when a planned code holds neither its
old nor its new value (someone wrote it since: the journal is stale; the
message names the codes). Otherwise it reads the set's codes and marks the
journal complete if every planned code holds its new value, else restores
the old values from the journal's backup, reads them back and marks it
rolled-back. A journal already complete or rolled-back needs nothing.

Without --port the journal's port is used (a sim:// port without the
faults= and seed= of the run that was cut); without --schema the schema the
journal records (an upload's and a `driveset address` change's alike) (its id among the known schemas when the fingerprint
matches, else its file; a schema edited since the upload is refused, exit
2). Like every bus command, recover holds the bus's lock while it runs: a
bus another driveset drives is refused with exit 3, naming that process.

Exit codes: 0 settled (complete or rolled back, verified), 2 the journal
cannot be read or does not fit the drive (bus, address, identity, schema,
stale codes), 3 bus or device failure (the journal then says what each code
holds; run recover again).

Examples:
  driveset recover .driveset/journal/serial__dev_ttyUSB0-3.journal.json
  driveset recover axis-1.journal.json --port /dev/ttyUSB1")]
pub struct Args {
    /// The journal file `driveset upload` wrote.
    #[arg(value_name = "JOURNAL")]
    pub journal: PathBuf,
    /// The port, the address and the schema (each by default the
    /// journal's).
    #[command(flatten)]
    pub at: Port<Args>,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

/// The schema to recover with: `--schema`, else the journal's (the
/// engine's [`driveset_engine::session::Catalog::for_journal_of`]).
fn journal_schema(
    args: &Args,
    j: &driveset_engine::journal::Journal,
) -> Result<port::SchemaChoice, Fail> {
    port::catalog(&args.at.schemas)
        .for_journal_of(args.at.schema(), j)
        .map_err(|e| Fail::input(port::catalog_error(&e)))
}

/// Put the recovery on the run's record, and close the sessions of this
/// station that processes killed mid-way left open with what it found
/// (the engine's [`DriveRecord::of_recover`] and [`history::recover_note`]).
fn record(
    port_name: &str,
    address: u8,
    schema: &driveset_schema::Schema,
    journal: &Path,
    result: &Result<RecoverReport, driveset_engine::error::EngineError>,
) {
    let slot = Slot {
        bus: port_name.to_string(),
        address,
        ..Slot::default()
    };
    crate::history::drive(&DriveRecord::of_recover(slot, schema, result));
    crate::history::close_interrupted(&history::recover_note(journal, result));
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Optional,
        port_help: "The port (default: the journal's).",
        address: Need::Optional,
        address_help: "The bus address (default: the journal's; another address is refused).",
        schema: SchemaCount::One,
        schema_help: "Schema id or file (default: the journal's schema, found by the id, file and fingerprint it records).",
        schemas: true,
        ..Takes::NONE
    };
}

/// Run `driveset recover`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    recover(&args)
}

fn recover(args: &Args) -> Result<u8, Fail> {
    let jf = JournalFile::open(&args.journal)?;
    let j = &jf.journal;
    // without --port, the journal's port without the keys of the run that
    // was cut (a `sim://` port's faults and their seed: they would cut the
    // recovery at the same telegram)
    let port_text = args
        .at
        .port
        .clone()
        .unwrap_or_else(|| port::without_run_keys(&j.target.port));
    let json = args.format == OutputFormat::Json;
    match route(j) {
        JournalRoute::AddressChange => {
            // the schema the change was made with (`--schema`, else the one
            // the journal records: a learned file types 81 / 82 where the
            // built-in schema does not); one no file holds any more leaves
            // the types to be learned from the drive's descriptions
            // (`assign`)
            let schema = port::catalog(&args.at.schemas)
                .for_address_journal(args.at.schema(), j)
                .map_err(|e| Fail::input(port::catalog_error(&e)))?
                .map(|c| c.schema);
            drop(jf);
            recover_address_change(&args.journal, &port_text, &args.at.schemas, schema, json)
        }
        JournalRoute::Finished(state) => {
            drop(jf);
            emit_finished(&args.journal, state, json);
            Ok(EXIT_OK)
        }
        JournalRoute::Upload => {
            let address = args.at.address.unwrap_or(j.target.address);
            let choice = journal_schema(args, j)?;
            drop(jf);
            recover_upload(args, &port_text, address, choice)
        }
    }
}

/// A journal already finished: nothing to do (no schema needed).
fn emit_finished(journal: &Path, state: TxnState, json: bool) {
    if json {
        output::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&Finished {
                action: RecoverAction::Nothing,
                found: state,
                journal: journal.display().to_string(),
            })
            .unwrap_or_default()
        ));
    } else {
        output::emit(&format!(
            "{}: the transaction is already {}; nothing to do\n",
            journal.display(),
            state.as_str()
        ));
    }
}

/// `driveset recover JOURNAL` of an upload: the drive at `address` on
/// `port_text` with the schema `choice`, settled by the engine's
/// [`engine_recover`], on the record, rendered.
fn recover_upload(
    args: &Args,
    port_text: &str,
    address: u8,
    choice: port::SchemaChoice,
) -> Result<u8, Fail> {
    crate::history::begin_writing("recover", crate::history::Context::default())?;
    let opened = port::open_port(port_text)?;
    let port_name = opened.name.clone();
    let schema = choice.schema.clone();
    let mut client = port::into_client(opened, choice.schema, address)?;
    let result = {
        let p = Progress::new("recover", args.format);
        let opts = RecoverOptions {
            observer: p.hook(),
            ..RecoverOptions::default()
        };
        let r = engine_recover(client.as_mut(), &args.journal, &opts);
        p.done();
        r
    };
    let _ = client.finish();
    record(&port_name, address, &schema, &args.journal, &result);
    let report = result?;
    if args.format == OutputFormat::Json {
        output::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&report).unwrap_or_default()
        ));
    } else {
        output::emit(&render(&port_name, address, &report));
    }
    Ok(EXIT_OK)
}

/// The human text of an upload's recovery.
fn render(port_name: &str, address: u8, report: &RecoverReport) -> String {
    let mut out = String::new();
    let action = match report.action {
        RecoverAction::Nothing => "nothing to do",
        RecoverAction::Completed => {
            "completed: the drive holds the new set (verified); journal marked complete"
        }
        RecoverAction::RolledBack => {
            "rolled back: the drive holds its old values again (verified); journal marked rolled-back"
        }
    };
    let _ = writeln!(
        out,
        "{port_name} address {address}: journal was {}; {action}",
        report.found.as_str()
    );
    if report.stored {
        let _ = writeln!(out, "store: stored (the store command was written again)");
    }
    if !report.restored.is_empty() {
        let _ = writeln!(out, "restored: {}", report.restored.join(", "));
    }
    for n in &report.notes {
        let _ = writeln!(out, "{n}");
    }
    if let Some(fp) = &report.fingerprint {
        let _ = writeln!(out, "drive holds: {fp}");
    }
    if let Some(n) = &report.target_note {
        let _ = writeln!(out, "note: {n}");
    }
    if let Some(t) = &report.transfer {
        let _ = writeln!(out, "line rate: {t}");
    }
    let _ = writeln!(out, "journal: {}", report.journal);
    out
}

/// `driveset recover JOURNAL` of an address change: the journal's port
/// (or `port`), the drive found at its old or new address and rate with
/// `schema` (the one the change was made with, which the journal records,
/// or `--schema`) for its family, the change finished and verified.
fn recover_address_change(
    journal: &Path,
    port_text: &str,
    dirs: &[PathBuf],
    schema: Option<std::sync::Arc<driveset_schema::Schema>>,
    json: bool,
) -> Result<u8, Fail> {
    let mut schemas = port::family_schemas(dirs, &[])?;
    if let Some(s) = schema {
        schemas = schemas.with(s);
    }
    let opened = port::open_port(port_text)?;
    let name = opened.name.clone();
    let mut link = opened.link;
    let r = assign::recover(&mut link, journal, &schemas)?;
    if json {
        output::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&r).unwrap_or_default()
        ));
    } else {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{name}: address change journal {}: found the drive at address {} at {} baud",
            r.journal, r.found_at.0, r.found_at.1
        );
        for w in &r.written {
            let _ = writeln!(out, "wrote {w}");
        }
        let _ = writeln!(out, "completed: {}", r.state);
        let _ = writeln!(out, "journal: {}", r.journal);
        output::emit(&out);
    }
    Ok(EXIT_OK)
}

/// `recover --format json`'s document of a journal already finished (keys
/// in alphabetical order, as it always had them).
#[derive(serde::Serialize)]
struct Finished {
    action: RecoverAction,
    found: TxnState,
    journal: String,
}
