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
use std::path::{Component, Path, PathBuf};

use driveset_engine::history::{self, DriveRecord, Slot, Unit};
use driveset_engine::pull::{PullOptions, Pulled};
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

/// `to` relative to the directory `from` (both made absolute).
pub fn relative_path(to: &Path, from_dir: &Path) -> PathBuf {
    let abs = |p: &Path| {
        let p = if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir().unwrap_or_default().join(p)
        };
        p.canonicalize().unwrap_or(p)
    };
    let to = abs(to);
    let from = abs(from_dir);
    let t: Vec<Component> = to.components().collect();
    let f: Vec<Component> = from.components().collect();
    let common = t.iter().zip(&f).take_while(|(a, b)| a == b).count();
    if common <= 1 {
        // nothing shared but the root: an absolute path reads better
        return to;
    }
    let mut out = PathBuf::new();
    for _ in common..f.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
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
    let set_dir = args
        .output
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
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
        let r = session::rate::pull(client.as_mut(), &popts, rate, &p.hook()).map(|(x, t)| {
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
    client.finish()?;
    // every value read, actual values included, on record
    let read = history::values_read(&schema, &pulled.set);
    // Read-only codes (actual values) are read but cannot be part of a set
    // (`validate` refuses them): they go into the header as comments.
    let mut pulled = pulled;
    let actual = pulled::take_actual_values(&mut pulled.set, &schema);
    pulled.fingerprint = pulled.set.fingerprint();
    crate::history::drive(&DriveRecord::of_read(
        Slot {
            bus: args.at.port()?.to_string(),
            address,
            ..Slot::default()
        },
        Unit::of(&schema, &pulled.identity),
        &schema.id,
        pulled.fingerprint.clone(),
        "read",
        read,
    ));
    let bus_codes = left_out_bus_codes(&schema, &pulled);
    let failed: Vec<_> = pulled
        .skipped
        .iter()
        .filter(|s| s.failed)
        .cloned()
        .collect();

    let done = Done {
        port: &port_name,
        address,
        schema: &schema,
        pulled: &pulled,
        actual: &actual,
        failed: failed.len(),
        bus_codes: &bus_codes,
        schema_path: schema_path.as_deref(),
        learned: learned.as_ref(),
        detected: detected.as_deref(),
    };
    let text = set_file(args, &done, &set_dir, format);
    crate::files::write_output("-o", &args.output, text.as_bytes())?;
    output::emit(&match args.format {
        BusFormat::Json => render_json(args, &done),
        _ => render_human(args, &done),
    });
    if failed.is_empty() {
        Ok(EXIT_OK)
    } else {
        for s in &failed {
            eprintln!(
                "error: {port_name} address {}: {} could not be read: {}",
                address, s.code, s.reason
            );
        }
        Ok(crate::EXIT_FINDINGS)
    }
}

/// The set file's syntax: `--to`, else by the extension (.yaml/.yml YAML,
/// else TOML).
fn file_format(args: &Args) -> Format {
    match args.to {
        Some(PullTo::Yaml) => Format::Yaml,
        Some(PullTo::Toml) => Format::Toml,
        None => match args.output.extension().and_then(|e| e.to_str()) {
            Some("yaml" | "yml") => Format::Yaml,
            _ => Format::Toml,
        },
    }
}

/// The bus address / line rate codes left out (the manifest owns them).
fn left_out_bus_codes(schema: &Schema, pulled: &Pulled) -> Vec<String> {
    pulled
        .skipped
        .iter()
        .filter(|s| {
            !s.failed
                && schema
                    .role_of(s.number)
                    .is_some_and(driveset_schema::Role::is_bus_link)
        })
        .map(|s| s.code.clone())
        .collect()
}

/// What a pull did, for the set file and the report on stdout.
struct Done<'a> {
    port: &'a str,
    address: u8,
    schema: &'a Schema,
    pulled: &'a Pulled,
    /// The read-only actual values taken out of the set.
    actual: &'a [String],
    /// How many codes could not be read.
    failed: usize,
    /// The bus address / line rate codes left out.
    bus_codes: &'a [String],
    schema_path: Option<&'a Path>,
    learned: Option<&'a session::LearnedReport>,
    detected: Option<&'a str>,
}

/// The set file's text (driveset-schema's [`pulled::pulled_file`]).
fn set_file(args: &Args, d: &Done<'_>, set_dir: &Path, format: Format) -> String {
    let pulled = d.pulled;
    // The schema reference: a file named by path stays a path (relative to
    // the set file), an id stays an id.
    let schema_ref = match d.schema_path {
        Some(p) => relative_path(p, set_dir).display().to_string(),
        None => d.schema.id.clone(),
    };
    let identity = pulled.identity.pairs();
    let not_read: Vec<(&str, &str)> = pulled
        .skipped
        .iter()
        .map(|s| (s.code.as_str(), s.reason.as_str()))
        .collect();
    let file = pulled::Pulled {
        from: pulled::PulledFrom {
            port: d.port,
            address: d.address,
            protocol: pulled.identity.protocol.name(),
            identity: &identity,
            software: pulled.identity.software.as_deref(),
        },
        schema_ref: &schema_ref,
        fingerprint: &pulled.fingerprint,
        changed_only: args
            .changed_only
            .then_some((pulled.dropped_defaults, pulled.full_fingerprint.as_str())),
        actual: d.actual,
        not_read: &not_read,
    };
    pulled::pulled_file(&pulled.set, d.schema, &file, format)
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
    learned: Option<serde_json::Value>,
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
    let pulled = d.pulled;
    let doc = PullDoc {
        actual_values: d.actual,
        address: d.address,
        detected: d.detected,
        dropped_defaults: pulled.dropped_defaults,
        elapsed_ms: pulled.elapsed.as_secs_f64() * 1000.0,
        file: args.output.display().to_string(),
        fingerprint: &pulled.fingerprint,
        full_fingerprint: &pulled.full_fingerprint,
        identity: serde_json::to_value(&pulled.identity).unwrap_or_default(),
        learned: d.learned.map(session::LearnedReport::json),
        left_out_bus_codes: d.bus_codes,
        not_readable: d.failed,
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
    let pulled = d.pulled;
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
    let not_read: Vec<&str> = pulled
        .skipped
        .iter()
        .map(|s| s.code.as_str())
        .filter(|c| !d.bus_codes.iter().any(|b| b == c))
        .collect();
    if !not_read.is_empty() {
        let _ = writeln!(out, "not read: {}", not_read.join(", "));
    }
    if !d.bus_codes.is_empty() {
        let _ = writeln!(
            out,
            "left out {}: the line manifest gives the drive's address and the bus's rate (--keep-bus-codes keeps them)",
            d.bus_codes.join(", ")
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
