//! `driveset scan --port P [--protocol lustbus|lecom|sdo] [--detect-baud]`:
//! which drives answer on a bus.

use std::fmt::Write as _;

use driveset_engine::scan::{BusScanned, ScanError, ScanOptions, ScanPlan, scan_bus};
use driveset_link::{ByteLink, Link, LinkError};

use crate::output;
use crate::output::OutputFormat;
use crate::port::{self, Fail, ProtocolArg};
use crate::port_args::{Need, Port, PortCommand, SchemaCount, Takes};
use crate::{EXIT_BUS, EXIT_OK};
use driveset_schema::BusProtocol;

/// Arguments of `driveset scan`.
#[derive(clap::Args)]
#[command(after_help = "\
LUSTBUS: an ENQUIRY of 91-TYPE (CODE 00091) to every address 1..30.
LECOM: a read of C0093 (or the schema's first identification code) to every
station 01..99 except the group addresses 10, 20 .. 90. CAN SDO: a read of
the schema's first identification code from every node id 1..127. Any
answer (a value or a refusal) counts. Nothing is written. Without
--protocol and --schema a character line is scanned as LUSTBUS, then, when
no LUSTBUS drive answers, as LECOM (a CAN port: CAN SDO), on every port.

--detect-baud tries every line rate, highest first (LUSTBUS 57600..2400,
LECOM 9600..1200), and reports the first at which a drive answers.

Exit codes: 0 drives found, 2 usage or input error, 3 bus failure or no
drive answered.

Examples:
  driveset scan --port sim://mc6000?addresses=3,7
  driveset scan --port /dev/ttyUSB0 --protocol lecom --detect-baud
  driveset scan --port slcan:///dev/ttyACM0?bitrate=500000 --protocol sdo --format json")]
pub struct Args {
    /// The port, the protocol (or the schema: it decides the protocol and
    /// the probe code).
    #[command(flatten)]
    pub at: Port<Args>,
    /// Try every line rate, highest first; report the first that answers.
    #[arg(long)]
    pub detect_baud: bool,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The port.",
        schema: SchemaCount::One,
        schema_help: "Schema id or file (decides the protocol and the probe code).",
        schemas: true,
        protocol: Need::Optional,
        protocol_help: "Protocol, when --schema does not say it (default: a CAN port sdo; a character line LUSTBUS, then LECOM).",
        ..Takes::NONE
    };
}

/// Run `driveset scan`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    scan(&args)
}

fn scan(args: &Args) -> Result<u8, Fail> {
    let plan = plan(args)?;
    let (port_name, scanned) = if args.detect_baud {
        scan_rates(args, &plan)?
    } else {
        let mut opened = port::open_port(args.at.port()?)?;
        // CAN SDO on a CAN port with a schema of another bus: the CAN
        // family's built-in schema gives the probe code
        let plan = if matches!(opened.link, Link::Frames(_)) {
            plan.on_can_port(&port::catalog(&args.at.schemas))
                .map_err(|e| Fail::input(port::catalog_error(&e)))?
        } else {
            plan
        };
        let scanned = scan_bus(&mut opened.link, &opened.name, &plan).map_err(scan_fail)?;
        (opened.name.clone(), scanned)
    };
    render(args, &port_name, &scanned);
    if scanned.found.is_empty() {
        eprintln!(
            "error: no drive answered on {port_name}; check wiring, termination and the baud rate (--detect-baud)"
        );
        return Ok(EXIT_BUS);
    }
    Ok(EXIT_OK)
}

/// The protocols to scan for, each with its schema (the probe code), and
/// the probes' options. Neither --schema nor --protocol: a CAN port speaks
/// CAN SDO; on a character line each protocol's addresses are probed in
/// turn (LUSTBUS, then LECOM) and the one that answers is the line's (the
/// same on every port).
fn plan(args: &Args) -> Result<ScanPlan, Fail> {
    let protocol_arg = match (args.at.schema(), args.at.protocol) {
        (None, None) => match port::open_port(args.at.port()?)?.link {
            Link::Frames(_) => Some(ProtocolArg(BusProtocol::CanSdo)),
            Link::Bytes(_) => None,
        },
        _ => args.at.protocol,
    };
    // the port's ?latency=: each probe waits what the clients allow it
    let options = ScanOptions::behind(
        driveset_link::PortSpec::parse(args.at.port()?)
            .ok()
            .and_then(|p| p.latency()),
    );
    ScanPlan::resolve(
        &port::catalog(&args.at.schemas),
        args.at.schema(),
        protocol_arg.map(|p| p.0),
        options,
    )
    .map_err(|e| Fail::input(port::catalog_error(&e)))
}

/// `--detect-baud`: the port opened once to check the port string and the
/// protocol, then reopened at each rate.
fn scan_rates(args: &Args, plan: &ScanPlan) -> Result<(String, BusScanned), Fail> {
    let first = port::open_port(args.at.port()?)?;
    if matches!(first.link, Link::Frames(_)) {
        return Err(Fail::input(format!(
            "{} is a CAN port; --detect-baud is for serial lines",
            first.name
        )));
    }
    let spec = first.spec.clone();
    let name = first.name.clone();
    drop(first);
    let mut reopen = |baud: u32| -> Result<Box<dyn ByteLink>, LinkError> {
        let s = port::with_rate(&spec, baud);
        match port::open_port(&s.to_string()) {
            Ok(p) => match p.link {
                Link::Bytes(l) => Ok(l),
                Link::Frames(_) => Err(LinkError::Unsupported {
                    port: s.to_string(),
                    what: "a CAN port".into(),
                }),
            },
            Err(_) => Err(LinkError::UnsupportedBaud {
                port: s.to_string(),
                baud,
            }),
        }
    };
    let scanned = driveset_engine::scan::scan_rates(plan, &mut reopen).map_err(scan_fail)?;
    Ok((name, scanned))
}

/// A scan's failure, exit code by its layer.
fn scan_fail(e: ScanError) -> Fail {
    Fail::of(e.layer(), e.to_string())
}

/// The addresses a protocol's scan probes, as the report names them.
fn range_of(p: BusProtocol) -> &'static str {
    match p {
        BusProtocol::Lustbus => "LUSTBUS addresses 1..30",
        BusProtocol::Lecom => "LECOM stations 01..99 without 10, 20 .. 90",
        BusProtocol::CanSdo => "CAN node ids 1..127",
    }
}

/// The report on stdout, human or JSON.
fn render(args: &Args, port_name: &str, s: &BusScanned) {
    match args.format {
        OutputFormat::Json => {
            let doc = ScanDoc {
                baud: s.baud,
                found: s
                    .found
                    .iter()
                    .map(|f| FoundDoc {
                        address: f.address,
                        codes: f.identity.codes.iter().map(output::CodeValue::of).collect(),
                    })
                    .collect(),
                port: port_name,
                protocol: s.protocol.name(),
            };
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&doc).unwrap_or_default()
            ));
        }
        // `human`, the other value a bus command takes
        _ => {
            // nothing found on a line whose protocol was not given: every
            // range probed
            let range = s
                .probed
                .iter()
                .map(|p| range_of(*p))
                .collect::<Vec<_>>()
                .join(", then ");
            let mut out = String::new();
            let _ = writeln!(out, "scanned {port_name} ({range})");
            match (s.baud, s.other_rate) {
                (Some(b), Some(here)) => {
                    let _ = writeln!(
                        out,
                        "baud rate: {b}, not the port's {here} (a drive left at a transfer rate by an interrupted --transfer-baud? `driveset recover JOURNAL` switches it back; or add ?baud={b} to the port)"
                    );
                }
                (Some(b), None) => {
                    let _ = writeln!(out, "baud rate: {b}");
                }
                _ => {}
            }
            for f in &s.found {
                let _ = writeln!(out, "{}", f.text());
            }
            let _ = writeln!(
                out,
                "{}",
                output::plural(s.found.len(), "drive found", "drives found")
            );
            output::emit(&out);
        }
    }
}

/// `scan --format json`'s document (keys in alphabetical order, as it
/// always had them).
#[derive(serde::Serialize)]
struct ScanDoc<'a> {
    baud: Option<u32>,
    found: Vec<FoundDoc<'a>>,
    port: &'a str,
    protocol: &'a str,
}

/// A drive that answered: its address and identity codes.
#[derive(serde::Serialize)]
struct FoundDoc<'a> {
    address: u8,
    codes: Vec<output::CodeValue<'a>>,
}
