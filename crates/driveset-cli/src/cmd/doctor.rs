//! `driveset doctor --port P [--address N] [--protocol lustbus|lecom|can]`:
//! the read-only first check of a new line (driveset-engine's `doctor`
//! module does the protocol work): which rates answer, round trips, echo,
//! parity, the USB adapter's latency timer, and what to change.
//!
//! The latency timers come from `SYSFS/bus/usb-serial/devices/*/
//! latency_timer` (driveset-link's `usb::latency_timers`), `SYSFS` being
//! `/sys` unless `--sysfs DIR` points at another tree (tests use a fake
//! one).

use std::fmt::Write as _;
use std::path::PathBuf;

use driveset_engine::doctor::{
    DoctorOptions, DoctorProtocol, DoctorReport, DoctorVerdict, ProbeResult, line_at, ms,
    protocol_on, run as doctor_run, run_can,
};
use driveset_link::{EchoMode, Link, PortSpec};

use crate::output;
use crate::output::OutputFormat;
use crate::port::{self, Fail};
use crate::port_args::{Need, Port, PortCommand, Takes};
use crate::{EXIT_BUS, EXIT_FINDINGS, EXIT_OK};

/// Arguments of `driveset doctor`.
#[derive(clap::Args)]
#[command(after_help = "\
Read-only: the only telegrams sent are reads of an identification code
(LUSTBUS: ENQUIRY of 91-TYPE; LECOM: RECEIVE of C0093; CAN: an SDO upload
of the schema's first identification code). Nothing in a drive changes.

Checks: which rates a drive answers at (the port's first, then every other
rate of the protocol, highest first: LUSTBUS 5.1; only the port's on a raw
tcp:// server, whose rate is set on the server, and on a pty); round-trip times over
--probes exchanges (min / median / p95 / max against the wire time); echo
of driveset's own bytes (2-wire RS-485 adapters); parity trouble (a 7E1
line read as 8 data bits shows the parity bit in bit 7; bad BCCs); the USB
adapter's latency timer (/sys/bus/usb-serial/devices/*/latency_timer);
then one advice line per thing to change.

Without --protocol the drive's protocol is found by the read-only probes
identify uses (at --address, else LUSTBUS address 1 / LECOM station 01).
Without --address: LUSTBUS address 0 (every drive answers; give the
address on a line with several drives), LECOM station 01, CAN node 1.

Exit codes: 0 a drive answers and nothing needs changing, 1 a drive
answers but there is advice, 2 usage or input error, 3 nothing answered
or the port failed.

Examples:
  driveset doctor --port /dev/ttyUSB0 --protocol lustbus --address 1
  driveset doctor --port rfc2217://10.0.0.7:2217?baud=19200 --protocol lecom
  driveset doctor --port sim://mc6000?addresses=1 --format json")]
pub struct Args {
    /// The port, the drive's address and the protocol.
    #[command(flatten)]
    pub at: Port<Args>,
    /// Round-trip probes at the answering rate.
    #[arg(long, value_name = "N", default_value_t = 20)]
    pub probes: u32,
    /// Answer timeout per probe, in milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 300)]
    pub timeout: u64,
    /// Root of the sysfs tree to read USB adapters' latency timers from.
    #[arg(long, value_name = "DIR", default_value = "/sys")]
    pub sysfs: PathBuf,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The port (the echo= option is ignored: the doctor looks at the raw bytes).",
        address: Need::Optional,
        address_help: "The drive's address (LUSTBUS 0..30, LECOM 01..99, CAN node id).",
        protocol: Need::Optional,
        protocol_help: "Protocol (default: found by the read-only probes; a CAN port: can).",
        ..Takes::NONE
    };
}

/// Run `driveset doctor`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    doctor(&args)
}

/// The port string raw: echo stripping off.
fn raw_at(spec: &PortSpec) -> PortSpec {
    spec.clone().with_echo(EchoMode::Off)
}

fn doctor(args: &Args) -> Result<u8, Fail> {
    let mut opened = port::open_port(args.at.port()?)?;
    let protocol = protocol(args, &mut opened)?;
    let mut options = DoctorOptions::new(protocol);
    options.address = args.at.address;
    options.probes = args.probes.max(1);
    options.timeout = std::time::Duration::from_millis(args.timeout.max(1));
    options.fixed_rate = DoctorOptions::fixed_rate_of(&opened.spec);
    let name = opened.name.clone();
    let report = match protocol {
        DoctorProtocol::CanSdo => {
            let schema =
                port::resolve_schema(None, &[], Some(port::ProtocolArg(DoctorProtocol::CanSdo)))?
                    .schema;
            let Link::Frames(mut link) = opened.link else {
                return Err(Fail::input(format!(
                    "{name} is a character line: use --protocol lustbus or lecom"
                )));
            };
            run_can(link.as_mut(), &schema, &options)?
        }
        _ => {
            if matches!(opened.link, Link::Frames(_)) {
                return Err(Fail::input(format!(
                    "{name} is a CAN port: use --protocol can"
                )));
            }
            let timers = driveset_link::usb::latency_timers(&args.sysfs, &opened.spec);
            let port_baud = opened.spec.line_baud().unwrap_or(9600);
            let spec = opened.spec.clone();
            // each rate reopens the port raw (echo stripping off) and sets
            // the host's side to the rate, whatever transport it is: the
            // drives keep their own rates
            drop(opened.link);
            let raw = raw_at(&spec);
            let mut open = |baud: u32| line_at(port::reopen(&raw)?, &raw.to_string(), baud);
            doctor_run(&name, port_baud, &mut open, &options, timers)?
        }
    };
    match args.format {
        OutputFormat::Json => output::emit(&format!(
            "{}\n",
            serde_json::to_string_pretty(&report).unwrap_or_default()
        )),
        // `human`, the other value a bus command takes
        _ => output::emit(&human(&report)),
    }
    Ok(match report.verdict() {
        DoctorVerdict::Silent => EXIT_BUS,
        DoctorVerdict::Fine => EXIT_OK,
        DoctorVerdict::Advice => EXIT_FINDINGS,
    })
}

/// Without --protocol: the engine's [`driveset_engine::doctor::protocol_on`]
/// (a CAN port speaks CAN SDO; on a character line the drive's, by the
/// read-only probes).
fn protocol(args: &Args, opened: &mut port::OpenPort) -> Result<DoctorProtocol, Fail> {
    let Some(p) = args.at.protocol else {
        let name = opened.name.clone();
        let latency = opened.connect.latency;
        return protocol_on(&mut opened.link, &name, args.at.address, latency).map_err(
            |e| match e {
                driveset_engine::session::SessionError::NoAnswer { .. } => Fail {
                    code: EXIT_BUS,
                    msg: format!(
                        "{e}; or say which protocol the line speaks: --protocol lustbus|lecom|can"
                    ),
                },
                other => other.into(),
            },
        );
    };
    Ok(p.0)
}

/// The human report.
pub fn human(r: &DoctorReport) -> String {
    let mut out = String::new();
    let proto = match r.protocol {
        DoctorProtocol::Lustbus => "LUSTBUS",
        DoctorProtocol::Lecom => "LECOM-A/B",
        DoctorProtocol::CanSdo => "CAN SDO",
    };
    let who = match (r.protocol, r.address) {
        (DoctorProtocol::Lustbus, 0) => "address 0 (any drive)".to_string(),
        (DoctorProtocol::CanSdo, a) => format!("node {a}"),
        (_, a) => format!("address {a}"),
    };
    let unit = if r.protocol == DoctorProtocol::CanSdo {
        "bit/s"
    } else {
        "baud"
    };
    let _ = writeln!(
        out,
        "doctor {} ({proto}, {who}; read-only: reads {} only)",
        r.port, r.probe
    );
    match &r.fixed_rate {
        Some(why) => {
            let _ = writeln!(out, "rates: only the port's ({why}):");
        }
        None => {
            let _ = writeln!(out, "rates:");
        }
    }
    for x in &r.rates {
        let what = match &x.result {
            ProbeResult::Answer { value } => format!("answers ({value})"),
            ProbeResult::Garbled { detail } => format!("garbled: {detail}"),
            ProbeResult::Silent => "silent".to_string(),
        };
        let mark = if x.baud == r.port_baud {
            " (the port's)"
        } else {
            ""
        };
        let _ = writeln!(out, "  {:>7} {unit}{mark}: {what}", x.baud);
    }
    match &r.round_trips {
        Some(t) => {
            let _ = writeln!(
                out,
                "round trips at {} {unit}: {} of {} answered; min {}, median {}, p95 {}, max {}; wire time {}",
                t.baud,
                t.answered,
                t.probes,
                ms(t.min_us),
                ms(t.median_us),
                ms(t.p95_us),
                ms(t.max_us),
                ms(t.wire_us)
            );
        }
        None => {
            let _ = writeln!(out, "round trips: none (nothing answered)");
        }
    }
    if r.protocol != DoctorProtocol::CanSdo {
        let _ = writeln!(
            out,
            "echo: {}",
            if r.echo.echo {
                format!(
                    "yes, {} of {} exchanges came back starting with driveset's own bytes",
                    r.echo.echoed, r.echo.exchanges
                )
            } else {
                format!("none ({} exchanges with an answer)", r.echo.exchanges)
            }
        );
        let p = &r.parity;
        let _ = writeln!(
            out,
            "parity: {}: {} of {} answer bytes with bit 7 set, {} with odd 8-bit weight, {} bad BCC, {} garbled",
            if p.read_as_8_bits {
                "7E1 read as 8 data bits"
            } else if p.high_bit > 0 || p.garbled > 0 {
                "trouble"
            } else {
                "ok"
            },
            p.high_bit,
            p.bytes,
            p.odd_weight,
            p.bad_bcc,
            p.garbled
        );
        let timers: Vec<String> = r
            .latency_timers
            .iter()
            .map(|t| {
                format!(
                    "{} {} ms{}",
                    t.device,
                    t.ms,
                    if t.this_port { " (this port)" } else { "" }
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "latency timer: {}",
            if timers.is_empty() {
                "none found (no USB serial adapter in /sys/bus/usb-serial, or not Linux)"
                    .to_string()
            } else {
                timers.join(", ")
            }
        );
    }
    if r.advice.is_empty() {
        let _ = writeln!(out, "advice: none, the line looks fine");
    } else {
        let _ = writeln!(out, "advice:");
        for a in &r.advice {
            let _ = writeln!(out, "  - {a}");
        }
    }
    out
}
