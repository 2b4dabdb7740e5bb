//! The work of `driveset sim` with no command line in it: owns the
//! command's options as plain data ([`SimOptions`]) checked into a bus
//! configuration and where to serve it ([`configure`]: a [`SimConfig`] and
//! an [`Endpoint`]), the sentence that says what is served ([`serving`]),
//! who can reach a TCP listener ([`exposure`]) and how its clients are
//! served ([`tcp_options`]), the power cycle of a state file's drives
//! ([`power_cycle`]) and what is
//! saved when serving stops ([`save`]: the event log flushed, the `--dump`
//! and `--state` files written). Each refusal is a [`SimCommandError`]
//! worded as the command has always shown it. Serving until stopped, and
//! what the command says while it serves, is `serving.rs` ([`serve`]). The
//! CLI keeps its clap arguments, the stop flag and signals, and prints
//! what it is told; docs/ports.md and docs/twins.md describe the options.

mod serving;

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};

use driveset_link::spec::{ALLOWED_BAUDS, ALLOWED_BITRATES};
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::BusProtocol;

use crate::faults::FaultPlan;
use crate::log::{EventLog, LogError};
use crate::open::{SimConfig, SimOpenError, StateDump, is_can, parse_family};
use crate::twin::TwinError;

pub use serving::{ServeFailure, ServeSetupError, Served, Told, serve};

/// What `driveset sim` was asked to serve, as given (each field is the
/// option of the same name; docs/ports.md).
#[derive(Debug, Clone, Default)]
pub struct SimOptions {
    /// `--family`: a family name or a schema id naming one, or `lustbus`
    /// (a mixed LUSTBUS of factory drives).
    pub family: Option<String>,
    /// `--twin`: a twin file, or a directory of twins served on one bus.
    pub twin: Option<PathBuf>,
    /// `--eds`: the CANopen device a CiA 306 EDS / DCF describes.
    pub eds: Option<PathBuf>,
    /// `--address`: the drives' bus addresses.
    pub addresses: Vec<u8>,
    /// `--factory`: factory-fresh drives (`N` or `FAMILY*N,...`).
    pub factory: Option<String>,
    /// `--bench`: the service bench (with `factory`).
    pub bench: bool,
    /// `--tcp`: `PORT` or `IP:PORT` to serve on (else a pseudo terminal).
    pub tcp: Option<String>,
    /// `--baud`: the rate of a 7E1 character line.
    pub baud: Option<u32>,
    /// `--bitrate`: the CAN bit rate.
    pub bitrate: Option<u32>,
    /// `--keypad`: LUSTBUS drives with a KEYPAD attached.
    pub keypad: bool,
    /// `--c0001`: the Tmd's C0001 as set at its keypad.
    pub c0001: Option<u8>,
    /// `--refuse`: codes every drive refuses to read.
    pub refuse: Option<String>,
    /// `--layout`: the MC6000/7000 description layout.
    pub layout: Option<String>,
    /// `--types`: the MC6000/7000 description type characters.
    pub types: Option<String>,
    /// `--describe`: LUSTBUS descriptions that say otherwise.
    pub describe: Option<String>,
    /// `--faults`: the fault plan.
    pub faults: Option<String>,
    /// `--seed`: the seed of every random choice.
    pub seed: u64,
    /// `--state`: the drives' state file.
    pub state: Option<PathBuf>,
    /// `--power-cycle`: power-cycle the state file's drives, serve nothing.
    pub power_cycle: bool,
}

/// Where to serve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Endpoint {
    /// A new pseudo terminal.
    Pty,
    /// A TCP listener at this address.
    Tcp(SocketAddr),
}

/// Why `driveset sim` refuses its options or could not power-cycle or
/// save its drives.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimCommandError {
    /// The simulated bus could not be configured, opened, loaded or saved.
    #[error(transparent)]
    Open(#[from] SimOpenError),
    /// A twin file or directory that cannot be served.
    #[error(transparent)]
    Twin(#[from] TwinError),
    /// The event log could not be written.
    #[error(transparent)]
    Log(#[from] LogError),
    /// A data sheet that cannot be simulated ([`crate::eds`]).
    #[error("{0}")]
    Eds(String),
    /// The simulated family's schema is not there ([`crate::catalog`]).
    #[error("{0}")]
    Schema(String),
    /// A mixed LUSTBUS without factory drives, or with addresses.
    #[error(
        "--family lustbus (a mixed LUSTBUS) takes its drives from --factory FAMILY*N,... (e.g. --factory mc6000*4,vf1000*3); serve drives at addresses with --family mc6000 or vf1000"
    )]
    MixedNeedsFactory,
    /// A state file drive saved with another schema than the family's
    /// simulated drives (a data sheet's device or a twin).
    #[error(
        "--state {}: drive {address} was saved with schema `{schema}`, not the simulated {family} drives' `{own}`; power-cycle it as it was served: add --eds FILE (a device from its data sheet) or --twin FILE",
        path.display()
    )]
    StateSchema {
        /// The state file.
        path: PathBuf,
        /// The drive's address.
        address: u8,
        /// The schema it was saved with.
        schema: String,
        /// The state file's family.
        family: String,
        /// The simulated drives' schema.
        own: String,
    },
    /// Neither a family nor a twin.
    #[error("give --family and --address, or --twin FILE")]
    NoDrives,
    /// A `--factory` value that does not parse.
    #[error("--factory {value}: {reason}")]
    Factory {
        /// The value.
        value: String,
        /// Why.
        reason: String,
    },
    /// `--baud` for drives on CAN.
    #[error(
        "--baud {baud}: {family} drives are on CAN; give the bus rate with --bitrate (one of {} bit/s)",
        join(ALLOWED_BITRATES)
    )]
    BaudOnCan {
        /// The rate given.
        baud: u32,
        /// The family's name.
        family: &'static str,
    },
    /// `--bitrate` for drives on a character line.
    #[error(
        "--bitrate {bitrate}: {family} drives are on a 7E1 character line; give its rate with --baud (one of {} baud)",
        join(ALLOWED_BAUDS)
    )]
    BitrateOnLine {
        /// The rate given.
        bitrate: u32,
        /// The family's name.
        family: &'static str,
    },
    /// `--keypad` for drives not on LUSTBUS.
    #[error("--keypad applies to the LUSTBUS families (mc6000, vf1000) only")]
    Keypad,
    /// `--c0001` for drives other than the Tmd.
    #[error("--c0001 applies to the Tmd (tmd) only")]
    C0001NotTmd,
    /// `--c0001` out of its range.
    #[error("--c0001 {0}: C0001 takes 0..=11 (Table 1; §4e)")]
    C0001Range(u8),
    /// A `--refuse` value that does not parse.
    #[error("--refuse {value}: {reason}")]
    Refuse {
        /// The value.
        value: String,
        /// Why.
        reason: String,
    },
    /// `--layout`, `--types` or `--describe` for drives not on LUSTBUS.
    #[error("--layout, --types and --describe apply to the LUSTBUS families (mc6000, vf1000) only")]
    LustbusOnly,
    /// An unknown `--layout`.
    #[error("--layout {0}: use 52, 43, 42 or 34 (errata L22)")]
    Layout(String),
    /// A `--types` value that does not parse.
    #[error("--types {value}: {reason}")]
    Types {
        /// The value.
        value: String,
        /// Why.
        reason: String,
    },
    /// A `--describe` value that does not parse.
    #[error("--describe {value}: {reason}")]
    Describe {
        /// The value.
        value: String,
        /// Why.
        reason: String,
    },
    /// A `--faults` plan that does not parse.
    #[error("--faults: {0}")]
    Faults(String),
    /// `--tcp` for CAN drives (served as an slcan adapter on a pty only).
    #[error(
        "--tcp: ecs drives are served as a simulated slcan USB-CAN adapter on a pseudo terminal only; use --pty and --port slcan:///dev/pts/N"
    )]
    TcpOnCan,
    /// A `--tcp` value that is neither a port nor an address.
    #[error(
        "--tcp `{0}`: give PORT or IP:PORT, e.g. --tcp 4001 or --tcp 127.0.0.1:4001 (--tcp 0.0.0.0:4001 serves the network)"
    )]
    Tcp(String),
    /// A power cycle without a state file.
    #[error("--power-cycle needs --state FILE")]
    PowerCycleNoState,
    /// A power cycle of a state file that is not there.
    #[error(
        "--state {}: no such state file; a power cycle needs the drives' state",
        .0.display()
    )]
    NoStateFile(PathBuf),
}

/// `PORT` (loopback) or `IP:PORT` / `[IPv6]:PORT`.
///
/// # Errors
/// [`SimCommandError::Tcp`] for anything else.
pub fn parse_tcp(text: &str) -> Result<SocketAddr, SimCommandError> {
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::from((Ipv4Addr::LOCALHOST, port)));
    }
    text.parse::<SocketAddr>()
        .map_err(|_| SimCommandError::Tcp(text.to_string()))
}

/// Check the options into a bus configuration and an endpoint: the drives
/// (`drives`), the factory-fresh ones, the line rate, the families'
/// own options, then [`SimConfig::check`] and where to serve.
///
/// # Errors
/// The first option refused ([`SimCommandError`]).
pub fn configure(o: &SimOptions) -> Result<(SimConfig, Endpoint), SimCommandError> {
    let mut config = drives(o)?;
    if let (Some(value), Some(f)) = (&o.factory, &o.family) {
        let names =
            crate::factory::parse_factory(f, config.factory_bus(), value, |n| parse_family(n).ok())
                .map_err(|reason| SimCommandError::Factory {
                    value: value.clone(),
                    reason,
                })?;
        for name in names {
            config.factory.push(parse_family(&name)?);
        }
        if config.addresses.is_empty()
            && let Some(&first) = config.factory.first()
        {
            config.family = first;
        }
    }
    config.bench = o.bench;
    rates(o, &mut config)?;
    family_options(o, &mut config)?;
    config.keypad = o.keypad;
    config.seed = o.seed;
    if let Some(plan) = &o.faults {
        config.faults =
            FaultPlan::parse(plan).map_err(|e| SimCommandError::Faults(e.to_string()))?;
    }
    config.state = o.state.clone();
    config.check()?;
    let endpoint = match &o.tcp {
        Some(_) if is_can(config.family) => return Err(SimCommandError::TcpOnCan),
        Some(text) => Endpoint::Tcp(parse_tcp(text)?),
        None => Endpoint::Pty,
    };
    Ok((config, endpoint))
}

/// The drives the options name: a data sheet's device at each address, a
/// twin or a directory of twins, a mixed LUSTBUS (its drives come from
/// `--factory`), a family at addresses, or (a power cycle) the drives of
/// the state file.
fn drives(o: &SimOptions) -> Result<SimConfig, SimCommandError> {
    if let Some(path) = &o.eds {
        let device = crate::eds::EdsDevice::load(path).map_err(SimCommandError::Eds)?;
        let addresses = match (&o.state, o.addresses.is_empty()) {
            (Some(state), true) if o.power_cycle => StateDump::read(state)?
                .drives
                .iter()
                .map(|d| d.address)
                .collect(),
            _ => o.addresses.clone(),
        };
        // the family the sheet's schema is for (CAN SDO)
        let mut c = SimConfig::new(device.schema.family, addresses);
        c.eds = Some(device);
        return Ok(c);
    }
    match (&o.twin, &o.family) {
        (Some(path), _) => {
            let twins = if path.is_dir() {
                crate::twin::load_dir(path)?
            } else {
                vec![crate::twin::load_file(path)?]
            };
            Ok(SimConfig::of_twins(twins)?)
        }
        (None, Some(f)) if f.eq_ignore_ascii_case(crate::port::MIXED_LUSTBUS) => {
            if o.factory.is_none() || !o.addresses.is_empty() {
                return Err(SimCommandError::MixedNeedsFactory);
            }
            Ok(SimConfig::mixed(&[]))
        }
        (None, Some(f)) => Ok(SimConfig::new(parse_family(f)?, o.addresses.clone())),
        (None, None) if o.power_cycle => of_state_file(o),
        (None, None) => Err(SimCommandError::NoDrives),
    }
}

/// A power cycle's drives when no family is given: the state file says
/// which drives it holds; each must be one of the family's simulated
/// drives (a data sheet's device or a twin needs its own option).
fn of_state_file(o: &SimOptions) -> Result<SimConfig, SimCommandError> {
    let path = o.state.as_deref().unwrap_or(Path::new(""));
    let dump = StateDump::read(path)?;
    let addresses = if o.addresses.is_empty() {
        dump.drives.iter().map(|d| d.address).collect()
    } else {
        o.addresses.clone()
    };
    let family = parse_family(&dump.family)?;
    let own = crate::catalog::schema(family).map_err(SimCommandError::Schema)?;
    if let Some(d) = dump.drives.iter().find(|d| d.schema != own.id) {
        return Err(SimCommandError::StateSchema {
            path: path.to_path_buf(),
            address: d.address,
            schema: d.schema.clone(),
            family: dump.family.clone(),
            own: own.id.clone(),
        });
    }
    Ok(SimConfig::new(family, addresses))
}

/// The line rate: `--bitrate` on CAN, `--baud` on a character line (the
/// other refused), and `--keypad` on LUSTBUS only.
fn rates(o: &SimOptions, config: &mut SimConfig) -> Result<(), SimCommandError> {
    let family = config.family;
    if is_can(family) {
        if let Some(baud) = o.baud {
            return Err(SimCommandError::BaudOnCan {
                baud,
                family: family.name(),
            });
        }
        if o.keypad {
            return Err(SimCommandError::Keypad);
        }
        if let Some(bitrate) = o.bitrate {
            config.bitrate = bitrate;
        }
    } else {
        if let Some(bitrate) = o.bitrate {
            return Err(SimCommandError::BitrateOnLine {
                bitrate,
                family: family.name(),
            });
        }
        if o.keypad && family.bus() != BusProtocol::Lustbus {
            return Err(SimCommandError::Keypad);
        }
        if let Some(baud) = o.baud {
            config.baud = baud;
        }
    }
    Ok(())
}

/// The families' own options: the Tmd's C0001, the refused codes, and the
/// LUSTBUS descriptions (layout, type characters, what they say).
fn family_options(o: &SimOptions, config: &mut SimConfig) -> Result<(), SimCommandError> {
    let family = config.family;
    if let Some(c) = o.c0001 {
        if family.bus() != BusProtocol::Lecom {
            return Err(SimCommandError::C0001NotTmd);
        }
        if c > 11 {
            return Err(SimCommandError::C0001Range(c));
        }
    }
    config.c0001 = o.c0001;
    if let Some(codes) = &o.refuse {
        config.refuse =
            crate::open::parse_refuse(codes).map_err(|reason| SimCommandError::Refuse {
                value: codes.clone(),
                reason,
            })?;
    }
    if (o.layout.is_some() || o.types.is_some() || o.describe.is_some())
        && family.bus() != BusProtocol::Lustbus
    {
        return Err(SimCommandError::LustbusOnly);
    }
    if let Some(l) = &o.layout {
        config.description_layout =
            McLayout::from_name(l).ok_or_else(|| SimCommandError::Layout(l.clone()))?;
    }
    if let Some(t) = &o.types {
        config.type_chars = McTypeChars::parse(t).map_err(|reason| SimCommandError::Types {
            value: t.clone(),
            reason,
        })?;
    }
    if let Some(d) = &o.describe {
        config.describe =
            crate::describe::parse(d).map_err(|reason| SimCommandError::Describe {
                value: d.clone(),
                reason,
            })?;
    }
    Ok(())
}

fn join(values: &[u32]) -> String {
    values
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// What is served, as one sentence: the drives on the line (`on_line`:
/// their addresses; with the bench only the drive on the bench), the rate,
/// the seed and the faults.
pub fn serving(config: &SimConfig, on_line: &[u8]) -> String {
    let addresses = on_line
        .iter()
        .map(u8::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    let n = on_line.len();
    let rate = if is_can(config.family) {
        format!("CAN at {} bit/s", config.bitrate)
    } else {
        format!("{} baud 7E1", config.baud)
    };
    let plural = if n == 1 { "" } else { "s" };
    let faults = if config.faults.is_empty() {
        String::new()
    } else {
        format!(", faults {}", config.faults)
    };
    let fresh = match (config.factory.len(), config.bench) {
        (0, _) => String::new(),
        (k, false) => format!("; {k} factory-fresh"),
        (k, true) => format!(
            "; service bench: {n} of {} drives on the line, {k} factory-fresh",
            config.all_drives().len()
        ),
    };
    format!(
        "serving {n} simulated {} drive{plural} (address{} {addresses}{fresh}) at {rate}, seed {}{faults}",
        config.bus_name(),
        if n == 1 { "" } else { "es" },
        config.seed
    )
}

/// Who can reach a listener at `addr` beyond this host, for the warning
/// the command gives (the simulator has no access control): `None` on
/// loopback, else every network interface (an unspecified address) or a
/// network address.
pub fn exposure(addr: SocketAddr) -> Option<&'static str> {
    if addr.ip().is_loopback() {
        return None;
    }
    Some(match addr.ip() {
        IpAddr::V4(ip) if ip.is_unspecified() => "every network interface",
        IpAddr::V6(ip) if ip.is_unspecified() => "every network interface",
        _ => "a network address",
    })
}

/// How TCP clients are served with `--idle-timeout SECONDS`: one dropped
/// after that long without sending anything (0: never).
pub fn tcp_options(idle_timeout: u64) -> crate::serve::TcpServeOptions {
    crate::serve::TcpServeOptions {
        idle_timeout: (idle_timeout > 0).then(|| std::time::Duration::from_secs(idle_timeout)),
    }
}

/// Power-cycle every drive of the state file (`config.state`): each loaded,
/// powered off and on (keeping what its kind of drive keeps), written
/// back. Gives how many drives were power-cycled.
///
/// # Errors
/// No state file given or there, or the drives could not be loaded or
/// saved.
pub fn power_cycle(config: &SimConfig) -> Result<usize, SimCommandError> {
    let Some(path) = &config.state else {
        return Err(SimCommandError::PowerCycleNoState);
    };
    if !path.exists() {
        return Err(SimCommandError::NoStateFile(path.clone()));
    }
    let at = driveset_link::Instant::from_nanos(0);
    let off = std::time::Duration::from_millis(1);
    let (dump, n) = if is_can(config.family) {
        let (mut line, drives) = config.frame_line_drives(EventLog::off())?;
        let nodes: Vec<u8> = line.drives().iter().map(|d| d.node_id()).collect();
        for node in &nodes {
            if let Some(d) = line.drive_mut(*node) {
                d.power_cycle(at, off);
            }
        }
        (
            drives.frame_line_dump(config.bus_name(), &line),
            nodes.len(),
        )
    } else {
        let (mut line, drives) = config.byte_line_drives(EventLog::off())?;
        line.power_cycle(at, None, off);
        let n = line.drives().len();
        (drives.byte_line_dump(config.bus_name(), &line), n)
    };
    dump.write(path)?;
    Ok(n)
}

/// What serving leaves behind when it stops: the event log flushed, the
/// drives' state `dump` written to `dump_to` (then `dumped` is told, so
/// the caller can say so before the state file is written) and to the
/// state file (`config.state`).
///
/// # Errors
/// The log's first write error, or a file that could not be written.
pub fn save(
    config: &SimConfig,
    dump: &StateDump,
    log: &EventLog,
    dump_to: Option<&Path>,
    dumped: impl FnOnce(&Path),
) -> Result<(), SimCommandError> {
    log.check()?;
    if let Some(path) = dump_to {
        dump.write(path)?;
        dumped(path);
    }
    if let Some(path) = &config.state {
        dump.write(path)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_port_alone_is_loopback_and_an_address_is_kept() {
        assert_eq!(
            parse_tcp("4001").unwrap(),
            SocketAddr::from((Ipv4Addr::LOCALHOST, 4001))
        );
        assert_eq!(
            parse_tcp("0.0.0.0:4001").unwrap().to_string(),
            "0.0.0.0:4001"
        );
        assert_eq!(exposure(parse_tcp("4001").unwrap()), None);
        assert_eq!(
            exposure(parse_tcp("0.0.0.0:4001").unwrap()),
            Some("every network interface")
        );
        assert_eq!(
            exposure(parse_tcp("[::]:4001").unwrap()),
            Some("every network interface")
        );
        assert_eq!(
            exposure(parse_tcp("192.0.2.1:4001").unwrap()),
            Some("a network address")
        );
        assert_eq!(tcp_options(0).idle_timeout, None);
        assert_eq!(
            tcp_options(10).idle_timeout,
            Some(std::time::Duration::from_secs(10))
        );
        assert_eq!(
            parse_tcp("nowhere").unwrap_err().to_string(),
            "--tcp `nowhere`: give PORT or IP:PORT, e.g. --tcp 4001 or --tcp 127.0.0.1:4001 (--tcp 0.0.0.0:4001 serves the network)"
        );
    }

    #[test]
    fn options_are_checked_into_a_config_and_an_endpoint() {
        let o = SimOptions {
            family: Some("mc6000".into()),
            addresses: vec![1, 2],
            baud: Some(19200),
            tcp: Some("4001".into()),
            seed: 7,
            ..SimOptions::default()
        };
        let (config, endpoint) = configure(&o).unwrap();
        assert_eq!(config.baud, 19200);
        assert_eq!(config.seed, 7);
        assert_eq!(
            endpoint,
            Endpoint::Tcp(SocketAddr::from((Ipv4Addr::LOCALHOST, 4001)))
        );
        assert_eq!(
            serving(&config, &[1, 2]),
            "serving 2 simulated mc6000 drives (addresses 1, 2) at 19200 baud 7E1, seed 7"
        );
    }

    #[test]
    fn a_power_cycle_needs_its_state_file_and_writes_it_back() {
        let dir = driveset_test_support::sim_dir();
        let state = dir.path().join("sim/bench.json");
        let mut o = SimOptions {
            family: Some("tmd".into()),
            addresses: vec![1, 2],
            power_cycle: true,
            ..SimOptions::default()
        };
        let (config, _) = configure(&o).unwrap();
        assert_eq!(
            power_cycle(&config).unwrap_err().to_string(),
            "--power-cycle needs --state FILE"
        );
        o.state = Some(state.clone());
        let (config, _) = configure(&o).unwrap();
        assert_eq!(
            power_cycle(&config).unwrap_err().to_string(),
            format!(
                "--state {}: no such state file; a power cycle needs the drives' state",
                state.display()
            )
        );
        // serving stops: the dump written where asked, then the state file
        let (line, drives) = config.byte_line_drives(EventLog::off()).unwrap();
        let dump = drives.byte_line_dump(config.bus_name(), &line);
        let dump_to = dir.path().join("sim/dump.json");
        let mut said = None;
        save(&config, &dump, &EventLog::off(), Some(&dump_to), |p| {
            said = Some(p.to_path_buf());
        })
        .unwrap();
        assert_eq!(said.as_deref(), Some(dump_to.as_path()));
        assert_eq!(
            std::fs::read(&dump_to).unwrap(),
            std::fs::read(&state).unwrap()
        );
        // the family and addresses are the state file's when not given
        let (config, _) = configure(&SimOptions {
            state: Some(state.clone()),
            power_cycle: true,
            ..SimOptions::default()
        })
        .unwrap();
        assert_eq!(config.addresses, vec![1, 2]);
        assert_eq!(power_cycle(&config).unwrap(), 2);
        assert_eq!(StateDump::read(&state).unwrap().drives.len(), 2);
    }

    #[test]
    fn refusals_name_the_option() {
        let can = SimOptions {
            family: Some("ecs".into()),
            addresses: vec![1],
            ..SimOptions::default()
        };
        let refused = |o: SimOptions| configure(&o).unwrap_err().to_string();
        assert_eq!(
            refused(SimOptions {
                tcp: Some("4001".into()),
                ..can.clone()
            }),
            SimCommandError::TcpOnCan.to_string()
        );
        assert!(
            refused(SimOptions {
                baud: Some(9600),
                ..can.clone()
            })
            .starts_with("--baud 9600: ecs drives are on CAN")
        );
        assert_eq!(
            refused(SimOptions {
                c0001: Some(2),
                ..can
            }),
            "--c0001 applies to the Tmd (tmd) only"
        );
        assert_eq!(
            refused(SimOptions::default()),
            "give --family and --address, or --twin FILE"
        );
    }
}
