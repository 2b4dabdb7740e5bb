//! `driveset recover JOURNAL [--port P] [--address A]`: finish or roll back
//! an interrupted upload from its journal alone (driveset-engine's
//! `recover`). Port, address and schema come from the journal; `--port`
//! replaces the port (the adapter moved, or a `sim://` port without the
//! fault that interrupted the upload).

use std::fmt::Write as _;
use std::path::PathBuf;

use driveset_engine::journal::JournalFile;
use driveset_engine::recover::{RecoverAction, RecoverOptions, recover as engine_recover};
use serde_json::json;

use super::identify::BusFormat;
use crate::EXIT_OK;
use crate::output;
use crate::port::{self, Fail};
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
    /// The port (default: the journal's).
    #[arg(long)]
    pub port: Option<String>,
    /// The bus address (default: the journal's; another address is refused).
    #[arg(long)]
    pub address: Option<u8>,
    /// Schema id or file (default: the journal's schema id).
    #[arg(long, value_name = "ID|PATH")]
    pub schema: Option<String>,
    /// Load every *.toml schema of DIR in addition to the built-in ones (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value = "human")]
    pub format: BusFormat,
}

/// Run `driveset recover`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    recover(&args)
}

fn recover(args: &Args) -> Result<u8, Fail> {
    let jf = JournalFile::open(&args.journal)?;
    let j = &jf.journal;
    let port_text = args.port.clone().unwrap_or_else(|| j.target.port.clone());
    let address = args.address.unwrap_or(j.target.address);
    let schema_arg = args.schema.clone().unwrap_or_else(|| j.schema.clone());
    let sim = port::peek_sim_family_at(&port_text, Some(address));
    let choice = port::resolve_schema(Some(&schema_arg), &args.schemas, sim, None)?;
    let json = args.format == BusFormat::Json;
    let state = j.state;
    let finished = j.is_finished();
    drop(jf);
    if finished {
        let msg = format!(
            "{}: the transaction is already {}; nothing to do",
            args.journal.display(),
            state.as_str()
        );
        if json {
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&json!({
                    "journal": args.journal.display().to_string(),
                    "found": state,
                    "action": RecoverAction::Nothing,
                }))
                .unwrap_or_default()
            ));
        } else {
            output::emit(&format!("{msg}\n"));
        }
        return Ok(EXIT_OK);
    }
    let opened = port::open_port(&port_text)?;
    let port_name = opened.name.clone();
    let mut client = port::into_client(opened, choice.schema, address, false)?;
    let result = {
        let p = Progress::new("recover", json);
        let opts = RecoverOptions {
            observer: p.hook(),
            ..RecoverOptions::default()
        };
        let r = engine_recover(client.as_mut(), &args.journal, &opts);
        p.done();
        r
    };
    let _ = client.finish();
    let report = result?;
    if json {
        output::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&report).unwrap_or_default()
        ));
    } else {
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
        output::emit(&out);
    }
    Ok(EXIT_OK)
}
