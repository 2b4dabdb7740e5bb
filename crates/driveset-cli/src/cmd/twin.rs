//! `driveset twin capture | capture-line | from-capture` and the rehearsal
//! behind `driveset commission MANIFEST --rehearse DIR` (docs/twins.md).
//!
//! The capture reads: identify, a LUSTBUS drive's parameter descriptions
//! and substitution texts as `pull` learns them (the only write the MC's RAM
//! selector 108-STEXT, set back), and every code of the schema, through the
//! engine ([`driveset_engine::capture`]); the file is the simulator's twin
//! format ([`driveset_sim::twin`]). A rehearsal opens every bus of the
//! manifest as a simulated bus of the twins of its drives (`DIR/<drive
//! name>.twin.toml`) in virtual time and runs the line as `commission`
//! does; a rehearsal that would rehearse nothing is refused, and selected
//! drives without a twin fail it unless `--allow-missing-twins`. A
//! capture is on record (docs/history.md): each drive's values read and
//! their fingerprint; a rehearsal is not (it reads no drive).
//!
//! The work is the twin bridge's ([`driveset_twin::drive`]: a drive's
//! capture from the opened port; [`driveset_twin::recorded`]: twins from a
//! recorded session; [`driveset_twin::file`]: the file written or kept);
//! this module keeps the arguments, resolving the port and the schema,
//! the plant history's records, the calls and the lines printed.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_engine::history::Slot;
use driveset_schema::Schema;
use driveset_sim::twin::Twin;
use driveset_twin::drive::{CaptureError, Captured};

use crate::fail::Fail;
use crate::port_args::{Need, Port, PortCommand, SchemaCount, Takes};
use crate::{EXIT_OK, port};

/// `driveset twin ...`.
#[derive(clap::Subcommand)]
pub enum TwinCommand {
    /// Capture one drive into a twin file (what it answers and describes).
    Capture(CaptureArgs),
    /// Capture every drive of a line manifest into DIR/<drive name>.twin.toml.
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    CaptureLine(CaptureLineArgs),
    /// Build a twin from a recorded bus session (what `decode` reads).
    FromCapture(FromCaptureArgs),
}

/// `driveset twin capture`.
#[derive(clap::Args)]
#[command(after_help = "\
Reads the drive (identify; a LUSTBUS drive's parameter descriptions and,
MC6000/7000, its substitution texts, as `pull` learns them: the only write is
the RAM selector 108-STEXT, set back; every code of the schema): its
identity, every value, the codes it refuses to read, every description and
text as it sent them, the state that decides its refusals (Tmd C0001,
running, MC6000 SLOAD), the line rate and reaction times. Passwords are
never read; the twin lists them without a value. The schema is found as
`pull` finds it (a sim:// port's family, else the protocol probe), or given
with --schema; one that lacks facts (lust-mc6000, lust-vf1000) is learned
from the descriptions. The twin then answers only what the drive answered.

A second capture of an unchanged drive leaves the file byte-identical: when
only the date, the driveset version or reaction times inside the recorded
range differ, the previous file is kept as it is (docs/twins.md).

Exit codes: 0 written (or unchanged); 1 the drive is not of the schema's
family; 2 usage or input; 3 bus or device.

Examples:
  driveset twin capture --port /dev/ttyUSB0 --address 3 -o conveyor-3.twin.toml
  driveset twin capture --port 'sim://tmd?c0001=3' --address 4 -o t.twin.toml")]
pub struct CaptureArgs {
    /// The port, the address and the schema (as `pull` takes them).
    #[command(flatten)]
    pub at: Port<CaptureArgs>,
    /// The twin file to write (NAME.twin.toml).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
}

impl PortCommand for CaptureArgs {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "Port (as `pull --port`).",
        address: Need::Required,
        address_help: "The drive's address.",
        schema: SchemaCount::One,
        schema_help: "Schema id or file (default: as `pull` finds it).",
        schemas: true,
        protocol: Need::Optional,
        ..Takes::NONE
    };
}

/// `driveset twin capture-line`.
#[derive(clap::Args)]
#[command(after_help = "\
Captures every drive of the manifest, bus by bus, into DIR/<drive name>.twin.toml
(as `twin capture`), with each drive's set's schema as the manifest resolved it
(a learned file `pull` wrote beside the set included). A drive that cannot be
captured is reported and the others are captured all the same; the exit code
is the worst failure's (as `twin capture`), 0 when every drive was captured.

Example:
  driveset twin capture-line parameter-sets/demo-line/line.toml -o twins/")]
pub struct CaptureLineArgs {
    /// The line manifest.
    #[arg(value_name = "LINE")]
    pub manifest: PathBuf,
    /// The directory of the twins.
    #[arg(short = 'o', long = "output", value_name = "DIR")]
    pub output: PathBuf,
}

/// `driveset twin from-capture`.
#[derive(clap::Args)]
#[command(after_help = "\
Reads a recorded bus session (the raw bytes `driveset decode --protocol
lecom | lustbus | slcan` reads: what a vendor tool sent and the drives
answered) and
writes one twin per station address seen, DIR/twin-<address>.twin.toml
(rename it to <drive name>.twin.toml for a rehearsal): every value a drive
answered (RECEIVE, ENQUIRY), every value a write (SEND, SELECT) sent and the
drive acknowledged (the last one seen wins), and the codes it refused to
read (served refused alike; on CAN with the SDO abort code it gave). Codes
of the schema the session did not show
are listed as unknown ([codes] unknown); the served twin answers them with
its model's factory value. A LUSTBUS session needs --schema (it does not
name its family); an slcan session is read with lenze-ecs unless --schema
names another ECS schema (expedited SDO transfers of Lenze codes).

Exit codes: 0 written; 2 usage, input, or a session that shows no drive.

Example:
  driveset twin from-capture --protocol lecom --schema lenze-tmd session.bin -o twins/
  driveset twin from-capture --protocol lustbus --schema lust-vf1000 session.bin -o twins/
  driveset twin from-capture --protocol slcan session.slcan -o twins/")]
pub struct FromCaptureArgs {
    /// The protocol of the session (lecom, lustbus).
    #[arg(long, value_name = "P")]
    pub protocol: crate::offline::DecodeProtocol,
    /// Schema id or file (default for lecom: lenze-tmd; required for lustbus).
    #[arg(long, value_name = "ID|PATH")]
    pub schema: Option<String>,
    /// The recorded session.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// The directory of the twins (twin-<address>.twin.toml).
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    #[arg(short = 'o', long = "output", value_name = "DIR")]
    pub output: PathBuf,
}

/// Run `driveset twin ...`.
pub fn run(c: TwinCommand) -> Result<u8, Fail> {
    match c {
        TwinCommand::Capture(a) => run_capture(a),
        TwinCommand::CaptureLine(a) => run_capture_line(a),
        TwinCommand::FromCapture(a) => run_from_capture(a),
    }
}

fn run_capture(a: CaptureArgs) -> Result<u8, Fail> {
    // a FIFO or device as -o is refused before the port is opened
    crate::files::check_output("-o", &a.output)?;
    let address = a.at.address()?;
    crate::history::begin_reading(
        "twin capture",
        crate::history::Context {
            sets: Some(a.output.clone()),
            ..Default::default()
        },
    )?;
    let c = capture_drive(a.at.port()?, address, |opened| {
        Ok(a.at.resolve(opened, address)?.choice.schema)
    })?;
    crate::history::drive(&driveset_twin::history::drive_record(
        Slot {
            bus: a.at.port()?.to_string(),
            address,
            ..Slot::default()
        },
        &c.twin,
        &c.schema,
        &c.identity,
    ));
    let line = write_twin(&a.output, &c.twin, &c.schema)?;
    outln!("{line}");
    Ok(EXIT_OK)
}

fn run_capture_line(a: CaptureLineArgs) -> Result<u8, Fail> {
    let manifest = crate::line::load(&a.manifest, crate::line::LearnedSets::Counted)
        .map_err(Fail::reported)?;
    let twins = driveset_twin::line::plan(&manifest, &a.output);
    // every twin file is checked before a bus is opened
    for t in &twins {
        crate::files::check_output("", &t.out)?;
    }
    std::fs::create_dir_all(&a.output)
        .map_err(|e| Fail::input(format!("cannot create {}: {e}", a.output.display())))?;
    crate::history::begin_reading(
        "twin capture-line",
        crate::history::Context {
            label: manifest.label.clone(),
            manifest: Some(a.manifest.display().to_string()),
            sets: Some(a.manifest.clone()),
        },
    )?;
    let mut worst = EXIT_OK;
    let mut failed = Vec::new();
    for t in &twins {
        let d = t.drive;
        // the set's schema as the manifest resolved it (a learned file
        // `pull` wrote beside the set included); one that lacks facts is
        // learned from the drive, as `pull` learns it
        let captured = capture_drive(&t.port, d.address, |_| Ok(d.schema.clone()));
        let written = match captured {
            Ok(c) => {
                crate::history::drive(&t.record(&c));
                write_twin(&t.out, &c.twin, &c.schema)
            }
            Err(f) => {
                crate::history::drive(&t.failed(f.msg.clone()));
                Err(f)
            }
        };
        match written {
            Ok(line) => outln!("{}: {line}", d.name),
            Err(f) => {
                eprintln!(
                    "error: {} ({} address {}): {}",
                    d.name, t.bus.name, d.address, f.msg
                );
                failed.push(d.name.clone());
                worst = worst.max(f.code);
            }
        }
    }
    if !failed.is_empty() {
        eprintln!(
            "error: {} of {} drive(s) not captured: {}",
            failed.len(),
            manifest.drives.len(),
            failed.join(", ")
        );
    }
    Ok(worst)
}

/// Capture the drive at `address` of `port_text` into a twin
/// ([`driveset_twin::drive`]), with the schema `choose` gives for the
/// opened port (given, or found as `pull` finds it); says so on stderr
/// when a schema was learned from the drive's descriptions.
fn capture_drive(
    port_text: &str,
    address: u8,
    choose: impl FnOnce(&mut port::OpenPort) -> Result<Arc<Schema>, Fail>,
) -> Result<Captured, Fail> {
    let mut opened = port::open_port_at(port_text, Some(address))?;
    let schema = choose(&mut opened)?;
    let described = driveset_twin::drive::describe_drive(opened, schema, address, || {
        port::registry(&[]).map_err(|f| f.msg)
    })
    .map_err(capture_fail)?;
    if let Some(l) = &described.learned {
        eprintln!(
            "learned schema {} from the drive's descriptions: {} codes (the twin holds the descriptions themselves)",
            l.id, l.codes
        );
    }
    described
        .capture(&crate::env::SystemEnv)
        .map_err(capture_fail)
}

/// A capture's failure and its exit code: a schema that does not fit the
/// port is an input error, a drive of another family a finding
/// ([`port::family_exit`]), a learned schema that does not render a bus
/// failure, the rest as the engine's layers say.
fn capture_fail(e: CaptureError) -> Fail {
    match e {
        CaptureError::Fit(e) => Fail::input(e.to_string()),
        CaptureError::Registry(msg) => Fail::input(msg),
        CaptureError::Session(e) => Fail::from(e),
        CaptureError::Engine(e) => Fail::from(e),
        e @ CaptureError::Render { .. } => Fail::bus(e.to_string()),
        CaptureError::Family(cause) => Fail {
            code: port::family_exit(&cause),
            msg: CaptureError::Family(cause).to_string(),
        },
    }
}

/// Write `twin` to `path` ([`driveset_twin::file::write`]: an unchanged
/// drive keeps the file byte-identical); the line to print.
fn write_twin(path: &Path, twin: &Twin, schema: &Schema) -> Result<String, Fail> {
    let written =
        driveset_twin::file::write(path, twin, schema).map_err(|e| Fail::input(e.to_string()))?;
    Ok(format!(
        "{} {} at address {}: {} codes, {} refused, {} secret(s) not stored{}; {} ({} bytes)",
        twin.family.name(),
        twin.schema,
        twin.address,
        twin.values.len(),
        twin.refused.len(),
        twin.secrets.len(),
        if written.unchanged {
            ", unchanged since the last capture (file kept)"
        } else {
            ""
        },
        path.display(),
        written.bytes
    ))
}

fn run_from_capture(a: FromCaptureArgs) -> Result<u8, Fail> {
    let format = a.protocol.capture();
    // a bus of one family has that family's built-in schema as the default
    let schema_name = driveset_twin::recorded::schema_of(format, a.schema.as_deref())
        .map_err(|e| Fail::input(e.to_string()))?;
    let bytes =
        driveset_schema::input::read_input(&a.file, driveset_schema::input::InputKind::CAPTURE)
            .map_err(|e| Fail::input(e.to_string()))?;
    let mut registry = crate::offline::builtin_registry().map_err(Fail::from)?;
    let schema = crate::offline::load_schema(&mut registry, schema_name).map_err(Fail::from)?;
    let twins = driveset_twin::recorded::twins(
        format,
        &bytes,
        &a.file,
        registry,
        &schema,
        &crate::env::SystemEnv,
    )
    .map_err(|e| Fail::input(e.to_string()))?;
    std::fs::create_dir_all(&a.output)
        .map_err(|e| Fail::input(format!("cannot create {}: {e}", a.output.display())))?;
    for twin in twins {
        let out = driveset_twin::recorded::path_in(&a.output, twin.address);
        let line = write_twin(&out, &twin, &schema)?;
        outln!("{line}; {} code(s) unknown", twin.unknown.len());
    }
    Ok(EXIT_OK)
}
