//! `driveset identify --port P --address A [--schema ID|PATH | --protocol P]`:
//! what the drive at an address says it is (family, TYPE / identification
//! codes, software version) and whether the schema fits it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use driveset_engine::client::DriveClient;
use driveset_engine::identify::Examined;
use driveset_engine::learn::{LearnedUse, learned_use};

use crate::output::{self, OutputFormat};
use crate::port::{self, Fail};
use crate::port_args::{LearnFlags, Need, Port, PortCommand, SchemaCount, Takes};
use crate::{EXIT_FINDINGS, EXIT_OK};

/// Arguments of `driveset identify`.
#[derive(clap::Args)]
#[command(after_help = "\
The protocol comes from --schema, else from
--protocol (with its built-in schema: lustbus -> lust-mc6000 or lust-vf1000,
told apart by whether the drive answers an MC6000/7000 CODE, lecom ->
lenze-tmd, sdo -> lenze-ecs), else from read-only probes as scan does
(LUSTBUS ENQUIRY of 91-TYPE, LECOM RECEIVE of C0093 / C0200; a CAN port
speaks lenze-ecs), the same on every port, sim:// too. `uses:` says
which schema pull / diff / upload would talk with and whether it is learned
from the drive's descriptions (a learned-<family>-type<TYPE>-... file in
--schema-dir, or learned on the next pull). Nothing is written to the drive.

Exit codes: 0 identified and the schema fits, 1 identified but the schema
does not fit (another family or TYPE), 2 usage or input error, 3 bus or
device failure (no answer, ...).

Examples:
  driveset identify --port sim://mc6000?addresses=1 --address 1
  driveset identify --port /dev/ttyUSB0?baud=9600 --address 3 --protocol lecom
  driveset identify --port tcp://10.0.0.7:4001 --address 1 --schema lust-vf1000 --format json")]
pub struct Args {
    /// The port, the address, the schema and where learned schemas are
    /// looked for (default: the current directory).
    #[command(flatten)]
    pub at: Port<Args>,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        address: Need::Required,
        schema: SchemaCount::One,
        schemas: true,
        protocol: Need::Optional,
        learn: LearnFlags::Dir,
        ..Takes::NONE
    };
}

/// Run `driveset identify`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    identify(&args)
}

fn identify(args: &Args) -> Result<u8, Fail> {
    let address = args.at.address()?;
    let (mut opened, resolved) = args.at.open_resolved(address)?;
    let (choice, note) = (resolved.choice, resolved.evidence);
    let port_name = opened.name.clone();
    let schema = choice.schema;
    // A LUSTBUS schema named: the drive's own family by the read-only
    // probes, as when none is named; another family is the finding (exit
    // 1), the same on every port.
    let other = driveset_engine::identify::probe_other_family(
        &mut opened.link,
        &port_name,
        address,
        opened.connect.latency,
        &schema,
        note.as_deref(),
    )?;
    let mut client = port::into_client(opened, schema.clone(), address)?;
    report(
        args,
        &port_name,
        client.as_mut(),
        note,
        choice.path.as_deref(),
        other,
    )
}

/// `identify --format json`'s document (keys in alphabetical order, as
/// it always had them).
#[derive(serde::Serialize)]
struct IdentifyDoc<'a> {
    address: Option<u8>,
    codes: Vec<output::CodeValue<'a>>,
    fits: bool,
    learned: bool,
    learned_file: Option<String>,
    note: Option<String>,
    port: &'a str,
    protocol: &'a str,
    reason: Option<&'a String>,
    schema: &'a str,
    schema_title: &'a str,
    software: &'a Option<String>,
    would_use: &'a str,
}

fn report(
    args: &Args,
    port_name: &str,
    client: &mut dyn DriveClient,
    note: Option<String>,
    path: Option<&Path>,
    other_family: Option<String>,
) -> Result<u8, Fail> {
    let schema = client.schema().clone();
    let ex = driveset_engine::identify::examine(client, other_family)?;
    let note = ex.rate_note().or(note);
    let dir = args
        .at
        .learn
        .schema_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("."));
    // the schema directory's files, listed only when the engine asks
    let uses = learned_use(&schema, &ex.identity, path, || {
        std::fs::read_dir(&dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .collect()
    });
    client.finish()?;
    let (identity, fits) = (&ex.identity, &ex.fits);
    match args.format {
        OutputFormat::Json => {
            let doc = IdentifyDoc {
                address: args.at.address,
                codes: identity.codes.iter().map(output::CodeValue::of).collect(),
                fits: fits.is_ok(),
                learned: uses.learned,
                learned_file: uses.file.as_ref().map(|p| p.display().to_string()),
                note,
                port: port_name,
                protocol: identity.protocol.name(),
                reason: fits.as_ref().err(),
                schema: &schema.id,
                schema_title: &schema.title,
                software: &identity.software,
                would_use: &uses.would_use,
            };
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&doc).unwrap_or_default()
            ));
        }
        // `human`, the other value a bus command takes
        _ => output::emit(&human(
            args,
            port_name,
            &schema,
            &ex,
            &uses,
            note.as_deref(),
        )?),
    }
    Ok(if fits.is_ok() { EXIT_OK } else { EXIT_FINDINGS })
}

/// The report for people.
fn human(
    args: &Args,
    port_name: &str,
    schema: &driveset_schema::Schema,
    ex: &Examined,
    uses: &LearnedUse,
    note: Option<&str>,
) -> Result<String, Fail> {
    let identity = &ex.identity;
    let mut out = String::new();
    let _ = writeln!(out, "port:     {port_name}");
    let _ = writeln!(out, "address:  {}", args.at.address()?);
    let _ = writeln!(out, "family:   {}", identity.protocol);
    for c in &identity.codes {
        let _ = writeln!(out, "{}: {}", c.name, c.value);
    }
    let _ = writeln!(
        out,
        "software: {}",
        identity.software.as_deref().unwrap_or("(not reported)")
    );
    match &ex.fits {
        Ok(()) => {
            let _ = writeln!(out, "schema:   {} (fits)", schema.id);
        }
        Err(r) => {
            let _ = writeln!(out, "schema:   {} does NOT fit: {r}", schema.id);
        }
    }
    let would_use = &uses.would_use;
    let learned_text = match (&uses.file, uses.learned, schema.id == *would_use) {
        (_, false, _) => format!("{would_use} (not learned: the schema gives every fact)"),
        (Some(f), true, _) => format!("{would_use} (learned, {})", f.display()),
        (None, true, true) => format!("{would_use} (learned)"),
        (None, true, false) => format!(
            "{would_use} (learned from the drive's descriptions on pull / diff / upload; {} lacks types and ranges)",
            schema.id
        ),
    };
    let _ = writeln!(out, "uses:     {learned_text}");
    if let Some(n) = note {
        let _ = writeln!(out, "note:     {n}");
    }
    Ok(out)
}
