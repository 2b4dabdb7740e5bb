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

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_engine::capture::{Capture, capture, describe};
use driveset_engine::client::{DriveClient, IdentProtocol, Identity};
use driveset_engine::env::Environment;
use driveset_engine::error::DeviceCause;
use driveset_engine::history::{self, DriveRecord, Slot, Unit};
use driveset_engine::learn::{LearnOptions, PullSchemaError};
use driveset_engine::line::manifest::{Bus, Manifest};
use driveset_engine::line::report::{DriveResult, LineReport};
use driveset_engine::session::Session;
use driveset_link::{Link, VirtualClock};
use driveset_schema::{CodeKey, Family, RawValue, ResolvedSet, Schema};
use driveset_sim::drive::ReadRefusal;
use driveset_sim::log::EventLog;
use driveset_sim::open::{SimConfig, open_sim_with};
use driveset_sim::twin::{TWIN_SUFFIX, Twin, keep_or_replace, load_file};

use crate::fail::Fail;
use crate::port_args::{Need, Port, PortCommand, SchemaCount, Takes};
use crate::{EXIT_OK, port};

/// The `command` of a rehearsal's report (report.json; the HTML title
/// then says rehearsal).
pub const REHEARSE_COMMAND: &str = "rehearse";

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
    pub protocol: super::decode::DecodeProtocol,
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
    crate::history::begin(
        "twin capture",
        crate::history::Context {
            sets: Some(a.output.clone()),
            ..Default::default()
        },
        false,
    )?;
    let (twin, schema, identity) = capture_drive(a.at.port()?, address, |opened| {
        Ok(a.at.resolve(opened, address)?.choice.schema)
    })?;
    let read = read_set(&schema, &twin);
    crate::history::drive(&DriveRecord::of_read(
        Slot {
            bus: a.at.port()?.to_string(),
            address,
            ..Slot::default()
        },
        Unit::of(&schema, &identity),
        &schema.id,
        read.fingerprint(),
        "read",
        history::values_read(&schema, &read),
    ));
    let line = write_twin(&a.output, &twin, &schema)?;
    outln!("{line}");
    Ok(EXIT_OK)
}

fn run_capture_line(a: CaptureLineArgs) -> Result<u8, Fail> {
    let manifest = crate::line::load(&a.manifest, true).map_err(Fail::reported)?;
    // every twin file is checked before a bus is opened
    for d in &manifest.drives {
        crate::files::check_output("", &a.output.join(format!("{}{TWIN_SUFFIX}", d.name)))?;
    }
    std::fs::create_dir_all(&a.output)
        .map_err(|e| Fail::input(format!("cannot create {}: {e}", a.output.display())))?;
    crate::history::begin(
        "twin capture-line",
        crate::history::Context {
            label: manifest.label.clone(),
            manifest: Some(a.manifest.display().to_string()),
            sets: Some(a.manifest.clone()),
        },
        false,
    )?;
    let mut worst = EXIT_OK;
    let mut failed = Vec::new();
    for d in &manifest.drives {
        let bus = &manifest.buses[d.bus_index];
        let port_text = bus.port.to_string();
        let out = a.output.join(format!("{}{TWIN_SUFFIX}", d.name));
        // the set's schema as the manifest resolved it (a learned file
        // `pull` wrote beside the set included); one that lacks facts is
        // learned from the drive, as `pull` learns it
        let slot = Slot {
            line: Some(manifest.name.clone()),
            drive: Some(d.name.clone()),
            bus: bus.name.clone(),
            address: d.address,
        };
        let captured = capture_drive(&port_text, d.address, |_| Ok(d.schema.clone()));
        let written = match captured {
            Ok((t, s, identity)) => {
                crate::history::drive(&line_record(slot, d, &t, &s, &identity));
                write_twin(&out, &t, &s)
            }
            Err(f) => {
                crate::history::drive(&DriveRecord {
                    result: "failed".into(),
                    error: Some(f.msg.clone()),
                    fingerprint_before: None,
                    fingerprint_after: None,
                    ..DriveRecord::of_read(
                        slot,
                        Unit {
                            family: IdentProtocol::Family(d.schema.family).name().to_string(),
                            ..Unit::default()
                        },
                        &d.schema.id,
                        String::new(),
                        "failed",
                        Vec::new(),
                    )
                });
                Err(f)
            }
        };
        match written {
            Ok(line) => outln!("{}: {line}", d.name),
            Err(f) => {
                eprintln!(
                    "error: {} ({} address {}): {}",
                    d.name, bus.name, d.address, f.msg
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

/// Every value a capture read, as a set of `schema` (its fingerprint is
/// what the history records of a `twin capture`).
fn read_set(schema: &Schema, twin: &Twin) -> ResolvedSet {
    let mut set = ResolvedSet::new(schema);
    set.values = twin.values.clone();
    set
}

/// The history record of a line drive's capture: each code of its set,
/// what the drive holds (`read`) or that it differs (`drift`), as `status`
/// records it; a drive whose set waits for the learned schema (empty
/// here): every value read.
fn line_record(
    slot: Slot,
    d: &driveset_engine::line::manifest::Drive,
    twin: &Twin,
    schema: &Schema,
    identity: &Identity,
) -> DriveRecord {
    let unit = Unit::of(schema, identity);
    if d.set.values.is_empty() {
        let read = read_set(schema, twin);
        return DriveRecord::of_read(
            slot,
            unit,
            &schema.id,
            read.fingerprint(),
            "read",
            history::values_read(schema, &read),
        );
    }
    let mut live = d.set.clone();
    live.values = d
        .set
        .values
        .keys()
        .filter_map(|k| Some((*k, twin.values.get(k)?.clone())))
        .collect();
    let mut record = DriveRecord::of_read(
        slot,
        unit,
        &schema.id,
        live.fingerprint(),
        if live.values == d.set.values {
            "unchanged"
        } else {
            "drift"
        },
        history::read_codes(schema, &live, &d.set),
    );
    record.set_fingerprint = Some(d.set.fingerprint());
    record
}

/// Capture the drive at `address` of `port_text` into a twin, with the
/// schema `choose` gives for the opened port (given, or found as `pull`
/// finds it). A LUSTBUS drive is described first, whatever the schema
/// ([`describe`]: every description and substitution text it sends, the
/// schema learned from them when the chosen one lacks facts, as `pull`
/// learns it); then every code of the schema is read ([`capture`]). Gives
/// the twin, the schema and what the drive said it is.
pub fn capture_drive(
    port_text: &str,
    address: u8,
    choose: impl FnOnce(&mut port::OpenPort) -> Result<Arc<Schema>, Fail>,
) -> Result<(Twin, Arc<Schema>, Identity), Fail> {
    let mut opened = port::open_port_at(port_text, Some(address))?;
    let schema = choose(&mut opened)?;
    let port_name = opened.name.clone();
    let rate = match &opened.link {
        Link::Bytes(l) => l.baud(),
        Link::Frames(l) => l.bitrate(),
    };
    let mut described = None;
    let mut schema = schema;
    // a family whose drives describe their parameters (LUSTBUS 11.1, 11.2)
    let describes = schema.family.descriptor().learning.is_some();
    let mut client: Box<dyn DriveClient> = if describes {
        port::check_fit(&opened, &schema)?;
        let registry = port::registry(&[])?;
        let connect = opened.connect;
        let c = Session::lustbus(opened, schema.clone(), address)?;
        let drive = format!("{port_name} address {address}");
        let d = describe(
            c,
            schema,
            &LearnOptions::default(),
            &registry,
            drive,
            &connect,
        )
        .map_err(|e| match e {
            PullSchemaError::Engine(e) => Fail::from(e),
            PullSchemaError::Render(detail) => Fail {
                code: crate::EXIT_BUS,
                msg: format!("{port_name} address {address}: {detail}; no twin written"),
            },
        })?;
        if let Some(l) = &d.learned {
            eprintln!(
                "learned schema {} from the drive's descriptions: {} codes (the twin holds the descriptions themselves)",
                l.rendered.id, l.rendered.codes
            );
        }
        schema = d.schema;
        described = Some(d.described);
        Box::new(d.client)
    } else {
        port::into_client(opened, schema.clone(), address)?
    };
    if let Err(e) = driveset_engine::identify::check_family(client.as_mut()) {
        return Err(Fail {
            code: if e.is_refused() {
                crate::EXIT_FINDINGS
            } else {
                port::engine_exit(&e)
            },
            msg: format!("{e}; no twin written"),
        });
    }
    let cap = capture(client.as_mut())?;
    let mut twin = twin_of(&cap, &schema, address);
    twin.source = format!("drive {port_name} address {address}");
    twin.rate = cap.rate.or(Some(rate));
    if let Some(d) = described {
        twin.layout = d.layout;
        twin.types = d.types;
        twin.descriptions = Some(d.descriptions);
        twin.texts = d.texts;
    }
    Ok((twin, schema, cap.identity))
}

/// The twin of a capture (without source, rate and description layout).
fn twin_of(cap: &Capture, schema: &Schema, address: u8) -> Twin {
    let mut twin = Twin::new(schema.family, address, &schema.id);
    twin.driveset = env!("CARGO_PKG_VERSION").to_string();
    twin.captured = today();
    twin.identity = cap.identity.pairs();
    twin.running = cap.running;
    twin.reaction = cap.reaction;
    twin.values = cap.values.clone();
    twin.refused = cap.refused.clone();
    twin.refusals = cap
        .answers
        .iter()
        .filter_map(|(k, cause)| Some((*k, read_refusal(cause)?)))
        .collect();
    twin.secrets = cap.secrets.clone();
    twin.unread = cap.clears.clone();
    twin.unknown = cap.unread.clone();
    if let Some(source) = schema.family.descriptor().bus_write {
        twin.c0001 = c0001_of(&cap.values, schema, source.code);
    }
    // the dataset handshake's code (MC6000/7000 80-SLOAD, §11.4)
    if let Some(code) = schema.family.descriptor().dataset_code() {
        twin.sload = match cap.values.get(&CodeKey::new(code)) {
            Some(RawValue::Int(v)) => Some(*v),
            _ => None,
        }
    }
    twin
}

/// How a drive refused a read on the wire, from the cause the client made
/// of it: LUSTBUS NAK (with the SIOF/SERR bits read after it, section 9.2),
/// LECOM EOT (8.H), CAN SDO abort (DS301 table 22).
fn read_refusal(cause: &DeviceCause) -> Option<ReadRefusal> {
    match cause {
        DeviceCause::Siof { bits, .. } => Some(ReadRefusal::NakSiof(bits.bits())),
        DeviceCause::NoSuchParameter { .. } | DeviceCause::SiofUnreadable => Some(ReadRefusal::Nak),
        DeviceCause::NoSuchCode { .. } => Some(ReadRefusal::NoSuchCode),
        DeviceCause::SdoAbort { code, .. } => Some(ReadRefusal::SdoAbort(code.0)),
        _ => None,
    }
}

/// The twin's `c0001`: the value in `values`, in engineering units (Tmd:
/// raw x10000, LECOM VD), of `code`, the code that says where the drive
/// takes its parameter writes from (the descriptor's
/// [`driveset_schema::family::Descriptor::bus_write`]: Tmd C0001,
/// `lecom-ab-tmd-manual.txt` §4e, §4f).
fn c0001_of(values: &BTreeMap<CodeKey, RawValue>, schema: &Schema, code: u32) -> Option<u8> {
    let Some(RawValue::Int(raw)) = values.get(&CodeKey::new(code)) else {
        return None;
    };
    let ty = schema.code(code).and_then(|c| schema.type_of(c))?;
    driveset_schema::value::raw_to_engineering(ty, *raw)
        .parse()
        .ok()
}

fn today() -> String {
    let now = crate::env::SystemEnv.now_utc().to_string();
    now.get(..10).unwrap_or(&now).to_string()
}

/// Write `twin` to `path` ([`keep_or_replace`]: an unchanged drive keeps
/// the file byte-identical); the line to print.
fn write_twin(path: &Path, twin: &Twin, schema: &Schema) -> Result<String, Fail> {
    crate::files::check_output("", path)?;
    // the file it replaces, through the one reader (absent or unreadable:
    // written anew)
    let old = driveset_schema::input::read_input(path, driveset_schema::input::InputKind::TWIN)
        .ok()
        .and_then(|b| String::from_utf8(b).ok());
    let text = keep_or_replace(old.as_deref(), twin, Some(schema));
    let unchanged = old.as_deref() == Some(text.as_str());
    if !unchanged {
        crate::files::write_output("", path, text.as_bytes())?;
    }
    Ok(format!(
        "{} {} at address {}: {} codes, {} refused, {} secret(s) not stored{}; {} ({} bytes)",
        twin.family.name(),
        twin.schema,
        twin.address,
        twin.values.len(),
        twin.refused.len(),
        twin.secrets.len(),
        if unchanged {
            ", unchanged since the last capture (file kept)"
        } else {
            ""
        },
        path.display(),
        text.len()
    ))
}

fn run_from_capture(a: FromCaptureArgs) -> Result<u8, Fail> {
    use super::decode::DecodeProtocol;
    // the session's families are its bus's; a bus of one family has that
    // family's built-in schema as the default
    let bus = a.protocol.capture().bus();
    let families: Vec<Family> = bus.families().collect();
    let default_schema = bus.only_family().map(|f| f.descriptor().schema_id);
    let answer = match a.protocol {
        DecodeProtocol::Lecom => ReadRefusal::NoSuchCode,
        DecodeProtocol::Lustbus => ReadRefusal::Nak,
        // the abort code is each refusal's own (below); this one is never used
        DecodeProtocol::Slcan => ReadRefusal::SdoAbort(0x0602_0000),
    };
    let Some(schema_name) = a.schema.as_deref().or(default_schema) else {
        return Err(Fail::input(
            "twin from-capture --protocol lustbus: give the drives' schema with --schema (an MC6000/7000 or VF1000 schema id or file, e.g. lust-vf1000): a LUSTBUS session does not say which family it talks to",
        ));
    };
    let bytes =
        driveset_schema::input::read_input(&a.file, driveset_schema::input::InputKind::CAPTURE)
            .map_err(|e| Fail::input(e.to_string()))?;
    let mut registry = super::decode::builtin_registry().map_err(Fail::from)?;
    let schema = super::decode::load_schema(&mut registry, schema_name).map_err(Fail::from)?;
    if !families.contains(&schema.family) {
        return Err(Fail::input(format!(
            "--schema {}: a {} schema; a {} session needs a schema of {}",
            schema.id,
            schema.family.name(),
            bus.name(),
            families
                .iter()
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(" or ")
        )));
    }
    let ctx = driveset_engine::decode::Context {
        registry,
        schema: Some(schema.clone()),
        family: None,
    };
    let events = driveset_engine::decode::decode(a.protocol.capture(), &bytes, &ctx);
    let sessions = match a.protocol {
        DecodeProtocol::Lustbus => driveset_engine::capture::lustbus_session(&events, &schema),
        DecodeProtocol::Slcan => driveset_engine::capture::can_session(&events, &schema),
        DecodeProtocol::Lecom => driveset_engine::capture::lecom_session(&events, &schema),
    };
    if sessions.is_empty() {
        return Err(Fail::input(format!(
            "{}: the session shows no drive answering (no VALUE, no acknowledged write); is it a {} capture?",
            a.file.display(),
            bus.name()
        )));
    }
    std::fs::create_dir_all(&a.output)
        .map_err(|e| Fail::input(format!("cannot create {}: {e}", a.output.display())))?;
    for (address, session) in sessions {
        let mut twin = Twin::new(schema.family, address, &schema.id);
        twin.driveset = env!("CARGO_PKG_VERSION").to_string();
        twin.captured = today();
        twin.source = format!("capture {}", a.file.display());
        for code in &schema.codes {
            for key in driveset_engine::capture::code_keys(code) {
                if schema.is_password(code) {
                    twin.secrets.push(key);
                } else if code.read_clears == Some(true) {
                    // the served model latches it itself
                    twin.unread.push(key);
                } else if !session.values.contains_key(&key) && !session.refused.contains_key(&key)
                {
                    twin.unknown.push(key);
                }
            }
        }
        // a password a vendor tool wrote is not kept either
        twin.values = session
            .values
            .into_iter()
            .filter(|(k, _)| !twin.secrets.contains(k))
            .collect();
        twin.refusals = session
            .refused
            .keys()
            .map(|k| {
                let answer = match session.aborts.get(k) {
                    Some(&code) => ReadRefusal::SdoAbort(code),
                    None => answer,
                };
                (*k, answer)
            })
            .collect();
        twin.refused = session.refused;
        if let Some(source) = schema.family.descriptor().bus_write {
            twin.c0001 = c0001_of(&twin.values, &schema, source.code);
        }
        let out = a.output.join(format!("twin-{address}{TWIN_SUFFIX}"));
        let line = write_twin(&out, &twin, &schema)?;
        outln!("{line}; {} code(s) unknown", twin.unknown.len());
    }
    Ok(EXIT_OK)
}

/// The twins of a rehearsal: per drive of `manifest`, its twin in `dir`
/// (`None`: not rehearsed). A rehearsal that would rehearse nothing is an
/// input error (exit 2): `dir` missing or not a directory, holding no twin,
/// or no twin of any drive of `selected`.
pub fn rehearsal_twins(
    manifest: &Manifest,
    dir: &Path,
    selected: &std::collections::BTreeSet<String>,
) -> Result<BTreeMap<String, Option<Twin>>, Fail> {
    let capture = format!(
        "capture the line's twins into it with `driveset twin capture-line {} -o {}`",
        manifest.path.display(),
        dir.display()
    );
    if !dir.is_dir() {
        let what = if dir.exists() {
            "is not a directory"
        } else {
            "no such directory"
        };
        return Err(Fail::input(format!(
            "--rehearse {}: {what}; {capture}",
            dir.display()
        )));
    }
    let any_twin = std::fs::read_dir(dir)
        .map_err(|e| Fail::input(format!("--rehearse {}: cannot read: {e}", dir.display())))?
        .filter_map(Result::ok)
        .any(|e| e.file_name().to_string_lossy().ends_with(TWIN_SUFFIX));
    if !any_twin {
        return Err(Fail::input(format!(
            "--rehearse {}: the directory holds no twin (*{TWIN_SUFFIX}); {capture}",
            dir.display()
        )));
    }
    let mut out = BTreeMap::new();
    for d in &manifest.drives {
        let file = dir.join(format!("{}{TWIN_SUFFIX}", d.name));
        // a file that is there but is no regular file is an error naming
        // it (the reader says what it is), not a drive without a twin
        let twin = if std::fs::symlink_metadata(&file).is_ok() {
            let t = load_file(&file).map_err(|e| Fail::input(e.to_string()))?;
            if t.address != d.address {
                return Err(Fail::input(format!(
                    "{}: the twin is of address {}, the manifest puts {} at address {}; capture it again (driveset twin capture-line)",
                    file.display(),
                    t.address,
                    d.name,
                    d.address
                )));
            }
            Some(t)
        } else {
            None
        };
        out.insert(d.name.clone(), twin);
    }
    if !selected
        .iter()
        .any(|n| out.get(n).is_some_and(Option::is_some))
    {
        let names: Vec<String> = selected
            .iter()
            .map(|n| format!("{n}{TWIN_SUFFIX}"))
            .collect();
        return Err(Fail::input(format!(
            "--rehearse {}: no twin of any selected drive (looked for {}); {capture}",
            dir.display(),
            names.join(", ")
        )));
    }
    Ok(out)
}

/// The opener of a rehearsal: each bus a simulated bus of its drives'
/// twins, in virtual time.
pub fn rehearsal_opener(
    manifest: &Manifest,
    twins: &BTreeMap<String, Option<Twin>>,
) -> impl Fn(&Bus) -> Result<Link, String> + Sync + use<> {
    let mut per_bus: BTreeMap<String, Vec<Twin>> = BTreeMap::new();
    for d in &manifest.drives {
        if let Some(Some(t)) = twins.get(&d.name) {
            per_bus
                .entry(manifest.buses[d.bus_index].name.clone())
                .or_default()
                .push(t.clone());
        }
    }
    move |bus: &Bus| {
        let twins = per_bus
            .get(&bus.name)
            .cloned()
            .ok_or_else(|| format!("no twin for any drive of bus {}", bus.name))?;
        let config = SimConfig::of_twins(twins).map_err(|e| e.to_string())?;
        open_sim_with(
            &config,
            &VirtualClock::new(),
            &bus.port_name,
            EventLog::off(),
        )
        .map(|l| l.link())
        .map_err(|e| e.to_string())
    }
}

/// The label of a rehearsal report: it is a rehearsal, of which twins, and
/// which selected drives were not rehearsed (`missing`: no twin).
pub fn rehearsal_label(
    dir: &Path,
    twins: &BTreeMap<String, Option<Twin>>,
    missing: &[String],
) -> String {
    let mut dates: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (name, t) in twins {
        if let Some(t) = t {
            dates.entry(t.captured.as_str()).or_default().push(name);
        }
    }
    let mut s = format!("REHEARSAL against the twins in {}", dir.display());
    let list: Vec<String> = dates
        .iter()
        .map(|(date, names)| format!("captured {date}: {}", names.join(", ")))
        .collect();
    if !list.is_empty() {
        let _ = write!(s, " ({})", list.join("; "));
    }
    if !missing.is_empty() {
        let _ = write!(s, "; not rehearsed (no twin): {}", missing.join(", "));
    }
    s
}

/// JUnit XML of a line report (one testcase per drive; a drive that does
/// not hold its set is a failure, a drive not rehearsed is skipped), for
/// CI test reports of a rehearsal (docs/ci.md).
pub fn line_junit(r: &LineReport, not_rehearsed: &[String]) -> String {
    use crate::report::junit::xml_esc;
    let failed = |res: DriveResult| {
        !matches!(
            res,
            DriveResult::Verified
                | DriveResult::Unchanged
                | DriveResult::AlreadyVerified
                | DriveResult::NotSelected
        )
    };
    let failures = r.drives.iter().filter(|d| failed(d.result)).count();
    let skipped = r
        .drives
        .iter()
        .filter(|d| d.result == DriveResult::NotSelected)
        .count();
    let mut o = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        o,
        "<testsuites name=\"{}\" tests=\"{}\" failures=\"{failures}\" errors=\"0\">",
        xml_esc(&format!("driveset rehearsal {}", r.line)),
        r.drives.len()
    );
    let _ = writeln!(
        o,
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{failures}\" errors=\"0\" skipped=\"{skipped}\">",
        xml_esc(r.label.as_deref().unwrap_or(&r.line)),
        r.drives.len()
    );
    for d in &r.drives {
        let _ = write!(
            o,
            "    <testcase classname=\"{}\" name=\"{}\" file=\"{}\"",
            xml_esc(&d.bus),
            xml_esc(&d.name),
            xml_esc(&d.set)
        );
        let result = serde_json::to_value(d.result)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default();
        if d.result == DriveResult::NotSelected {
            let why = if not_rehearsed.contains(&d.name) {
                "not rehearsed: no twin"
            } else {
                "not selected"
            };
            let _ = writeln!(o, ">\n      <skipped message=\"{why}\"/>\n    </testcase>");
        } else if failed(d.result) {
            let msg = d.error.clone().unwrap_or_else(|| result.clone());
            let _ = writeln!(
                o,
                ">\n      <failure message=\"{}\" type=\"{}\">{}</failure>\n    </testcase>",
                xml_esc(&msg),
                xml_esc(&result),
                xml_esc(&msg)
            );
        } else {
            let _ = writeln!(o, "/>");
        }
    }
    o.push_str("  </testsuite>\n</testsuites>\n");
    o
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use driveset_schema::{CodeKey, RawValue, Registry};

    use super::c0001_of;

    /// The twin's `c0001` is the value of the descriptor's bus-write source
    /// (Tmd C0001) in engineering units; a family without one has none.
    #[test]
    fn c0001_is_the_descriptors_bus_write_source() {
        let reg = Registry::builtin().expect("built-in schemas");
        let tmd = reg.get("lenze-tmd").expect("tmd");
        let source = tmd.family.descriptor().bus_write.expect("tmd bus write");
        assert_eq!(source.code, 1);
        let values = BTreeMap::from([(CodeKey::new(1), RawValue::Int(30_000))]);
        assert_eq!(c0001_of(&values, &tmd, source.code), Some(3));
        assert_eq!(c0001_of(&BTreeMap::new(), &tmd, source.code), None);
        let mc = reg.get("lust-mc6000").expect("mc6000");
        assert_eq!(mc.family.descriptor().bus_write, None);
    }
}
