//! `driveset pull --port P --address A [--schema S] -o FILE [--changed-only]
//! [--to toml|yaml]`: read every readable code of a drive into a set file;
//! without a schema the protocol is probed, and a LUSTBUS schema that lacks
//! facts is learned from the drive first (driveset-engine's `session::open_learning`).
//!
//! The file starts with comments naming the port, the address, what the
//! drive said it is and the fingerprint, and carries the same facts in the
//! `[drive]` table (docs/file-formats.md: informational, ignored by the
//! loader), so `driveset validate` / `driveset fingerprint` read it back to
//! the same fingerprint. Passwords are not read (they would land in the file);
//! the bus address and line rate codes are left out unless --keep-bus-codes
//! (the line manifest gives them; docs/file-formats.md, "The manifest's
//! address is the truth"), and the report names them in one line.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use driveset_engine::client::DriveClient;
use driveset_engine::history::{DriveRecord, Slot};
use driveset_engine::pull::{ForFile, PullOptions, Pulled, SetFileFrom};
use driveset_engine::session::{self, rate::ReadRate};
use driveset_schema::export::pulled;
use driveset_schema::{Format, Schema};

use crate::EXIT_OK;
use crate::output;
use crate::output::{self as output_format, OutputFormat as BusFormat};
use crate::port::{self, Fail};
use crate::port_args::{LearnFlags, Need, Port, PortCommand, SchemaCount, Takes};
use crate::progress::Progress;

/// `--to` of `pull`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PullTo {
    /// TOML.
    Toml,
    /// YAML.
    Yaml,
}

/// Arguments of `driveset pull`.
#[derive(clap::Args)]
#[command(after_help = "\
Reads every code of the schema the drive lets read, except status codes whose
reading clears them (85-SIOF/SERR), passwords, and codes without a type; codes
the drive refuses are skipped and listed. The set is written in engineering
units with labels, TOML or YAML by the file's extension (or --to), with the
drive's identity and the fingerprint in comments and the [drive] table.
`driveset fingerprint FILE` gives the same fingerprint.

Without --schema (and not on a sim:// port, whose family names its schema)
the protocol and family are found by read-only probes, as scan finds them:
LUSTBUS ENQUIRY of 91-TYPE (and of the MC CODE 20091), LECOM RECEIVE of
C0093 / C0200. Where the schema lacks a code's type, kind or range (the
built-in lust-vf1000 / lust-mc6000 hold only what the LUSTBUS spec
documents), the drive's own parameter descriptions are read and the schema
learned: the spec's facts stand, the drive's fill in the rest. The learned
schema is written beside the set (or into --schema-dir) as
learned-<family>-type<TYPE>-<software>.toml and the set names it, so
`driveset validate FILE` works offline. --description-layout and
--type-chars override how MC6000/7000 descriptions are read (errata L22,
L23); --no-learn pulls with the schema as it is.

Commands and control words (schema role `command` / `control-word`) are left
out too: a set cannot hold them. The bus address and line rate codes (role
`bus-address` / `baud-rate`: LUSTBUS 82-SIOA/SADDR and 81-SIOC/SBAUD, Tmd
C0009 and C0125) are left out unless --keep-bus-codes is given: the line
manifest gives each drive its address and each bus its rate, and a set copied
for another drive must not carry this drive's (`driveset validate MANIFEST`
reports a set whose codes disagree with the manifest). Passwords are never read: the file says
which password codes were left out and holds no value of them.

A code that cannot be read (refused, no answer, a VALUE its type cannot
hold) is reported, listed in the file's header, and the pull carries on.

Exit codes: 0 written, 1 the schema does not fit the drive (nothing written;
--allow-family pulls anyway) or a code could not be read (the file is written
without it), 2 usage or input error, 3 bus or device failure.

Examples:
  driveset pull --port /dev/ttyUSB0 --address 3 -o axis-3.toml
  driveset pull --port 'sim://mc6000?layout=43&types=table' --address 1 --schema lust-mc6000 -o axis-1.toml
  driveset pull --port sim://mc6000?addresses=1 --address 1 -o axis-1.toml
  driveset pull --port /dev/ttyUSB0 --address 3 --schema lenze-tmd -o conveyor-3.yaml --changed-only")]
pub struct Args {
    /// The port, the address, the schema (default: as identify finds it),
    /// `--allow-family` and learning the schema from the drive.
    #[command(flatten)]
    pub at: Port<Args>,
    /// The set file to write.
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// Leave out values equal to the schema's factory default.
    #[arg(long)]
    pub changed_only: bool,
    /// File syntax (default: by the extension; .yaml/.yml YAML, else TOML).
    #[arg(long, value_enum)]
    pub to: Option<PullTo>,
    /// Keep the bus address and line rate codes (roles bus-address,
    /// baud-rate) in the set; by default they are left out, as the line
    /// manifest gives them.
    #[arg(long)]
    pub keep_bus_codes: bool,
    /// Removed: use --allow-family.
    #[arg(long, hide = true)]
    pub force: bool,
    /// The transfer rate (the switch is journaled in
    /// .driveset/journal/<bus>-<address>.journal.json).
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    #[command(flatten)]
    pub transfer: crate::allow::TransferArgs,
    /// Output format of the report on stdout.
    #[arg(long, value_parser = output_format::formats(output_format::BUS_FORMATS), default_value = "human")]
    pub format: BusFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The port.",
        address: Need::Required,
        address_help: "Bus address.",
        schema: SchemaCount::One,
        schema_help: "Schema id or file (default: the built-in schema of the family the drive answers the read-only probes as).",
        schemas: true,
        protocol: Need::Optional,
        allow_family: true,
        learn: LearnFlags::All,
        ..Takes::NONE
    };
}

/// Run `driveset pull`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    // a FIFO or device as -o is refused before the port is opened
    crate::files::check_output("-o", &args.output)?;
    pull(&args)
}

fn pull(args: &Args) -> Result<u8, Fail> {
    let address = args.at.address()?;
    // on record before the first read (docs/history.md)
    crate::history::begin_reading(
        "pull",
        crate::history::Context {
            sets: Some(args.output.clone()),
            ..Default::default()
        },
    )?;
    // No schema: find the protocol as `scan` does, on every port.
    let (opened, resolved) = args.at.open_resolved(address)?;
    let (choice, detected) = (resolved.choice, resolved.evidence);
    let format = file_format(args);
    if args.force {
        return Err(Fail::input("--force was replaced by --allow-family"));
    }
    let port_name = opened.name.clone();
    // A LUSTBUS schema that lacks facts: learn them from the drive and
    // write the learned schema beside the set (or into --schema-dir).
    let set_dir = pulled::set_dir(&args.output);
    let dir = args.at.learn.schema_dir.clone().unwrap_or(set_dir.clone());
    let on = args
        .at
        .open_learning(opened, choice.schema.clone(), address, Some(dir))?;
    let (mut client, schema, learned) = (on.client, on.schema, on.learned);
    let schema_path = match &learned {
        Some(r) => r.file.clone(),
        None => choice.path.clone(),
    };
    if let Some(r) = &learned
        && args.format == BusFormat::Human
    {
        for l in r.lines() {
            eprintln!("{l}");
        }
    }
    if !args.at.allow_family
        && let Err(e) = driveset_engine::identify::check_family(client.as_mut())
    {
        return Err(Fail {
            code: port::family_exit(&e),
            msg: format!("{e}; nothing written (pass --allow-family to pull anyway)"),
        });
    }
    let pulled = read(args, client.as_mut())?;
    client.finish()?;
    // every value read, actual values included, on record
    let file = pulled.for_file(&schema);
    let slot = Slot {
        bus: args.at.port()?.to_string(),
        address,
        ..Slot::default()
    };
    crate::history::drive(&DriveRecord::of_pull(slot, &schema, &file));
    let done = Done {
        port: &port_name,
        address,
        schema: &schema,
        file: &file,
        schema_path: schema_path.as_deref(),
        learned: learned.as_ref(),
        detected: detected.as_deref(),
    };
    let from = SetFileFrom {
        port: &port_name,
        address,
        schema_ref: &pulled::schema_ref(done.schema_path, &schema.id, &set_dir),
        changed_only: args.changed_only,
    };
    let text = file.text(&schema, &from, format);
    crate::files::write_output("-o", &args.output, text.as_bytes())?;
    output::emit(&match args.format {
        BusFormat::Json => render_json(args, &done),
        _ => render_human(args, &done),
    });
    if file.failed.is_empty() {
        Ok(EXIT_OK)
    } else {
        for s in &file.failed {
            eprintln!(
                "error: {port_name} address {}: {} could not be read: {}",
                address, s.code, s.reason
            );
        }
        Ok(crate::EXIT_FINDINGS)
    }
}

/// Every readable code of the drive, at the transfer rate if one is asked
/// (the switch journaled), the progress shown and the transfer's note on
/// stderr.
fn read(args: &Args, client: &mut dyn DriveClient) -> Result<Pulled, Fail> {
    let quiet = args.format == BusFormat::Json;
    let popts = PullOptions {
        changed_only: args.changed_only,
        include_passwords: false,
        keep_bus_codes: args.keep_bus_codes,
    };
    let mut transfer_note = None;
    let pulled = {
        let p = Progress::new("pull", args.format);
        let req = args
            .transfer
            .request(&driveset_engine::overrides::Overrides::none());
        let journal_dir = Path::new(driveset_engine::journal::DEFAULT_JOURNAL_DIR);
        let rate = ReadRate::of(req.as_ref(), journal_dir);
        let r = session::rate::pull(client, &popts, rate, &p.hook()).map(|(x, t)| {
            transfer_note = t.map(|t| t.render());
            x
        });
        p.done();
        r?
    };
    if let Some(t) = &transfer_note
        && !quiet
    {
        eprint!("{t}");
    }
    Ok(pulled)
}

/// The set file's syntax: `--to`, else by the extension (.yaml/.yml YAML,
/// else TOML).
fn file_format(args: &Args) -> Format {
    match args.to {
        Some(PullTo::Yaml) => Format::Yaml,
        Some(PullTo::Toml) => Format::Toml,
        None => Format::by_extension(&args.output),
    }
}

/// What a pull did, for the set file and the report on stdout.
struct Done<'a> {
    port: &'a str,
    address: u8,
    schema: &'a Schema,
    /// The pull, its actual values out of the set, the bus codes left out
    /// and the codes that could not be read.
    file: &'a ForFile,
    schema_path: Option<&'a Path>,
    learned: Option<&'a session::LearnedReport>,
    detected: Option<&'a str>,
}

/// The report of `--format json`: its keys in the order JSON documents
/// of the CLI have always had them (sorted; nested documents as values,
/// so theirs are too).
#[derive(serde::Serialize)]
struct PullDoc<'a> {
    actual_values: &'a [String],
    address: u8,
    detected: Option<&'a str>,
    dropped_defaults: usize,
    elapsed_ms: f64,
    file: String,
    fingerprint: &'a str,
    full_fingerprint: &'a str,
    identity: serde_json::Value,
    learned: Option<session::LearnDoc<'a>>,
    left_out_bus_codes: &'a [String],
    not_readable: usize,
    port: &'a str,
    read: usize,
    schema: &'a str,
    schema_file: Option<String>,
    skipped: serde_json::Value,
    values: usize,
}

/// The report of `--format json`.
fn render_json(args: &Args, d: &Done<'_>) -> String {
    let pulled = &d.file.pulled;
    let doc = PullDoc {
        actual_values: &d.file.actual,
        address: d.address,
        detected: d.detected,
        dropped_defaults: pulled.dropped_defaults,
        elapsed_ms: pulled.elapsed.as_secs_f64() * 1000.0,
        file: args.output.display().to_string(),
        fingerprint: &pulled.fingerprint,
        full_fingerprint: &pulled.full_fingerprint,
        identity: serde_json::to_value(&pulled.identity).unwrap_or_default(),
        learned: d.learned.map(session::LearnedReport::doc),
        left_out_bus_codes: &d.file.bus_codes,
        not_readable: d.file.failed.len(),
        port: d.port,
        read: pulled.read,
        schema: &d.schema.id,
        schema_file: d.schema_path.map(|p| p.display().to_string()),
        skipped: serde_json::to_value(&pulled.skipped).unwrap_or_default(),
        values: pulled.set.values.len(),
    };
    format!(
        "{}\n",
        serde_json::to_string_pretty(&doc).unwrap_or_default()
    )
}

/// The report for people.
fn render_human(args: &Args, d: &Done<'_>) -> String {
    let pulled = &d.file.pulled;
    let bus_codes = &d.file.bus_codes;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "pulled {} values from {} address {} into {} ({:.3} s on the bus)",
        pulled.set.values.len(),
        d.port,
        d.address,
        args.output.display(),
        pulled.elapsed.as_secs_f64()
    );
    if args.changed_only {
        let _ = writeln!(
            out,
            "left out {} values equal to the factory default",
            pulled.dropped_defaults
        );
    }
    let not_read = d.file.not_read();
    if !not_read.is_empty() {
        let _ = writeln!(out, "not read: {}", not_read.join(", "));
    }
    if !bus_codes.is_empty() {
        let _ = writeln!(
            out,
            "left out {}: the line manifest gives the drive's address and the bus's rate (--keep-bus-codes keeps them)",
            bus_codes.join(", ")
        );
    }
    let _ = writeln!(out, "fingerprint: {}", pulled.fingerprint);
    if let Some(det) = d.detected {
        let _ = writeln!(
            out,
            "protocol: {} ({det})",
            port::protocol_name(d.schema.family)
        );
    }
    if let Some(p) = d.schema_path {
        let _ = writeln!(out, "schema: {} ({})", d.schema.id, p.display());
    }
    out
}
