//! `--port` for the bus commands (`identify`, `scan`, `pull`, `diff --port`,
//! `upload`, `recover`, `schema pull`): open a port string as a
//! [`DriveClient`] for a schema.
//!
//! - Real ports (`/dev/ttyUSB0`, `COM3`, `tcp://host:port`,
//!   `rfc2217://host:port`, `slcan://...`, `can://...`) are opened by
//!   `driveset-link` and run on its `RealClock`; its `open` hands the
//!   character lines out behind an `EchoLink` with the port's `echo=`
//!   (default `auto`), so every serial protocol gets the echo of a 2-wire
//!   RS-485 adapter stripped.
//! - `sim://FAMILY?addresses=1,2` ports are opened in-process by
//!   `driveset-sim` on a `VirtualClock`: the simulated bus runs in virtual
//!   time, so a whole upload takes milliseconds of real time. The port's
//!   query is the simulator's ([`driveset_sim::port`]: its keys, checks and
//!   messages); the CLI registers the simulator's opener ([`openers`]) and
//!   passes port strings through as given. The drives' state persists
//!   between CLI runs with `state=FILE` in the port string or with the
//!   simulator's `DRIVESET_SIM_STATE_DIR=DIR`.
//!
//! The schema decides the protocol: LUSTBUS and LECOM need a character
//! line, CAN SDO a CAN port; a mismatch is refused before anything is sent,
//! as is a schema of another family than a `sim://` port simulates.
//!
//! Errors carry their exit code ([`Fail`], the CLI's one error
//! convention): 2 for usage and input (a bad port string, a schema that
//! does not fit the port, a refusal before anything was sent), 3 for bus
//! and device failures.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_engine::client::DriveClient;
use driveset_engine::connect::ConnectOptions;
use driveset_engine::session::{
    self, FitPolicy, OpenedPort, PortError, Ports, Session, SessionPolicy, SimulatedDrives,
};
use driveset_link::{LockError, OpenOptions, Openers, PortSpec, VirtualClock};
use driveset_schema::{Family, Registry, Schema};
use driveset_sim::log::EventLog;
use driveset_sim::open::{SimLink, open_sim_with};
use driveset_sim::port::{SimOpener, SimSpec};

pub use crate::fail::{Fail, engine_exit};

pub use crate::args::BusArg as ProtocolArg;

/// Name of a family's protocol as schemas spell it (`[schema] protocol`).
pub fn protocol_name(f: Family) -> &'static str {
    f.descriptor().schema_protocol
}

/// An open port: the engine session's ([`driveset_engine::session::open_port`]).
pub type OpenPort = OpenedPort;

/// How the CLI opens ports and takes bus locks for the engine's session
/// ([`Ports`]): real ports with `driveset-link`, `sim://` ports in-process
/// with the simulator (module docs), locks in `driveset_link::lock`'s
/// directory for the rest of the process ([`lock_bus`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct CliPorts;

impl Ports for CliPorts {
    fn open(
        &self,
        port: &str,
        spec: PortSpec,
        address: Option<u8>,
    ) -> Result<OpenedPort, PortError> {
        if !matches!(spec, PortSpec::Sim(_)) {
            let link = driveset_link::open(&spec, &OpenOptions::default()).map_err(|source| {
                PortError::Open {
                    port: spec.to_string(),
                    source,
                }
            })?;
            return Ok(OpenedPort::real(spec, link));
        }
        // The simulator's port: opened here rather than through
        // `driveset_link::open_with`, because the session also asks the
        // simulated bus which drives it holds.
        let mut sim = SimSpec::parse(port).map_err(PortError::BadPort)?;
        if let Some(a) = address
            && !sim.names_drives()
        {
            sim.addresses.push(a);
        }
        let (bus, in_process) = open_sim(&sim)?;
        let drives = bus
            .addresses()
            .into_iter()
            .filter_map(|a| bus.family_of(a).map(|f| (f, a)))
            .collect();
        let spec = PortSpec::Sim(sim.to_opaque());
        Ok(OpenedPort {
            name: sim.name(),
            connect: ConnectOptions::of(&spec),
            spec,
            link: bus.link(),
            simulated: Some(SimulatedDrives {
                drives,
                mixed: bus.is_mixed(),
                in_process,
            }),
        })
    }

    fn bus_before_open(&self, port: &str, spec: &PortSpec) -> Option<String> {
        if !matches!(spec, PortSpec::Sim(_)) {
            return driveset_link::bus_id::before_open(spec);
        }
        // a simulated bus with a state file is that file's bus (the
        // simulator's `SimConfig::bus_id`); one without lives here only
        let sim = SimSpec::parse(port).ok()?;
        let config = SimOpener::default().config(&sim).ok()?;
        config.state.is_some().then(|| config.bus_id())
    }

    fn lock(&self, bus: &str) -> Result<(), LockError> {
        lock_bus(bus)
    }
}

/// The simulated bus `sim` describes, in virtual time, and whether it lives
/// in this process only (no state file).
fn open_sim(sim: &SimSpec) -> Result<(SimLink, bool), PortError> {
    let name = sim.name();
    let settings = |detail: String| PortError::Settings {
        port: name.clone(),
        detail,
    };
    let config = SimOpener::default()
        .config(sim)
        .map_err(|e| settings(e.to_string()))?;
    let bus = open_sim_with(&config, &VirtualClock::new(), &name, EventLog::off())
        .map_err(|e| settings(e.to_string()))?;
    Ok((bus, config.state.is_none()))
}

/// The port openers the CLI registers for the schemes `driveset-link` does
/// not open itself: the simulator's for `sim://`.
pub fn openers() -> Openers {
    Openers::none().with(Arc::new(SimOpener::default()))
}

/// `spec` at another line rate (`baud=` on a character line, `bitrate=`
/// on CAN); an opener's port through its opener.
pub fn with_rate(spec: &PortSpec, rate: u32) -> PortSpec {
    let mut s = spec.clone();
    match &mut s {
        PortSpec::Serial { baud: b, .. }
        | PortSpec::Tcp { baud: b, .. }
        | PortSpec::Rfc2217 { baud: b, .. } => *b = Some(rate),
        PortSpec::Sim(o) => {
            if let Some(opener) = openers().get(&o.scheme) {
                *o = opener.with_rate(o, rate);
            }
        }
        PortSpec::Slcan { bitrate, .. } => *bitrate = Some(rate),
        PortSpec::SocketCan { .. } => {}
    }
    s
}

/// The family a `sim://` port names, without opening it (on a mixed
/// LUSTBUS, `sim://lustbus?mc6000=..&vf1000=..`, the first family key's).
pub fn peek_sim_family(port: &str) -> Option<Family> {
    peek_sim_family_at(port, None)
}

/// The family of the drive at `address` on a `sim://` port, without
/// opening it; without an address, or at one the port does not list, as
/// [`peek_sim_family`].
pub fn peek_sim_family_at(port: &str, address: Option<u8>) -> Option<Family> {
    let s = SimSpec::parse(port).ok()?;
    if s.is_twin() {
        // a twin bus: the family of the twin at the address (else the first)
        let twins = driveset_sim::port::twins_of(&s).ok()?;
        let at = address.and_then(|a| twins.iter().find(|t| t.address == a));
        return at.or(twins.first()).map(|t| t.family);
    }
    let drives = s.drives();
    let name = address
        .and_then(|a| drives.iter().find(|d| d.1 == a))
        .or(drives.first())
        .map_or(s.family.as_str(), |d| d.0);
    driveset_sim::open::parse_family(name).ok()
}

/// Open a port string (see the module docs).
pub fn open_port(port: &str) -> Result<OpenPort, Fail> {
    open_port_at(port, None)
}

/// Open a port string for a command on one drive: a `sim://FAMILY` port
/// without `addresses=` simulates one drive at `address`. The port's bus is
/// locked (the engine's [`driveset_engine::session::open_port`]).
pub fn open_port_at(port: &str, address: Option<u8>) -> Result<OpenPort, Fail> {
    Ok(session::open_port(&CliPorts, port, address)?)
}

/// The simulated bus behind a `sim://` port [`open_port`] opened (its
/// `spec`), opened again as the simulator's own object, for what asks the
/// bus itself rather than its drives (`doctor` sets its line rate). The
/// port's first link is dropped first, so a state file is read as written.
pub fn sim_bus(spec: &PortSpec) -> Result<SimLink, Fail> {
    let PortSpec::Sim(o) = spec else {
        return Err(Fail::input(format!("{spec} is not a sim:// port")));
    };
    let sim = SimSpec::from_opaque(o).map_err(|e| Fail::input(e.to_string()))?;
    Ok(open_sim(&sim)?.0)
}

/// The bus locks this process holds ([`lock_bus`]), until it exits.
static BUS_LOCKS: std::sync::Mutex<Vec<driveset_link::BusLock>> = std::sync::Mutex::new(Vec::new());

/// Take the advisory lock of bus `bus_id` for the rest of the command
/// (`driveset_link::lock`, in [`driveset_link::lock::lock_dir`]): refused,
/// exit 3 (the bus is busy; nothing was sent), naming the process that
/// holds it. A bus this process locked already (a command that opens its
/// port again, a line run's second pass) stays locked. Every command that
/// talks to drives opens its port through the engine's
/// [`session::open_port`], which locks through here ([`CliPorts`]), so two
/// processes never drive one bus at once, whatever each spelled its port.
pub fn lock_bus(bus_id: &str) -> Result<(), LockError> {
    let mut held = BUS_LOCKS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if held.iter().any(|l| l.bus() == bus_id) {
        return Ok(());
    }
    let holder = driveset_link::lock::Holder {
        pid: std::process::id(),
        command: std::env::args()
            .nth(1)
            .map_or_else(|| "driveset".to_string(), |c| format!("driveset {c}")),
        since: format!("{:.3}", jiff::Timestamp::now()),
    };
    let lock = driveset_link::BusLock::acquire(&driveset_link::lock::lock_dir(), bus_id, &holder)?;
    held.push(lock);
    Ok(())
}

/// Check that `schema` can talk over `port` to the drive at `address`
/// (the engine's [`session::check_fit`]; another family of the same
/// protocol on a `sim://` port passes with `allow_family`,
/// `--allow-family`).
pub fn check_fit(
    port: &OpenPort,
    schema: &Schema,
    address: Option<u8>,
    allow_family: bool,
) -> Result<(), Fail> {
    session::check_fit(port, schema, address, FitPolicy { allow_family })
        .map_err(|e| Fail::input(e.to_string()))
}

/// A client for the drive at `address` on `port`, speaking `schema`'s
/// protocol, through the engine's session (which checks that the schema
/// fits the port first, [`driveset_engine::session::check_fit`]).
pub fn into_client(
    port: OpenPort,
    schema: Arc<Schema>,
    address: u8,
    allow_family: bool,
) -> Result<Box<dyn DriveClient>, Fail> {
    let policy = SessionPolicy {
        fit: FitPolicy { allow_family },
        ..SessionPolicy::default()
    };
    Ok(Session::open(port, schema, address, &policy)?.client)
}

/// The schemas every command knows ([`crate::output::registry`]).
pub fn registry(dirs: &[PathBuf]) -> Result<Registry, Fail> {
    crate::output::registry(dirs).map_err(|e| Fail::input(e.render_human_string()))
}

/// The schemas a command on `port` knows: [`registry`], plus the
/// simulator's fixture schemas when `port` is a `sim://` port
/// ([`crate::output::sim_registry`]).
pub fn registry_for(port: &str, dirs: &[PathBuf]) -> Result<Registry, Fail> {
    if matches!(PortSpec::parse(port), Ok(PortSpec::Sim(_))) {
        crate::output::sim_registry(dirs).map_err(|e| Fail::input(e.render_human_string()))
    } else {
        registry(dirs)
    }
}

/// A schema and whether it came from a file.
#[derive(Debug, Clone)]
pub struct SchemaChoice {
    /// The schema.
    pub schema: Arc<Schema>,
    /// The file it was loaded from, when `--schema` named a path.
    pub path: Option<PathBuf>,
}

/// The schema to talk with: `--schema ID|PATH`, else the schema of the
/// family a `sim://` port simulates, else the built-in schema of
/// `--protocol` (LUSTBUS: `lust-mc6000`).
pub fn resolve_schema(
    arg: Option<&str>,
    dirs: &[PathBuf],
    sim: Option<Family>,
    protocol: Option<ProtocolArg>,
) -> Result<SchemaChoice, Fail> {
    // On a `sim://` port the simulator's fixture schemas are known by id.
    let mut registry = match sim {
        Some(_) => {
            crate::output::sim_registry(dirs).map_err(|e| Fail::input(e.render_human_string()))?
        }
        None => registry(dirs)?,
    };
    if let Some(a) = arg {
        let p = Path::new(a);
        if p.is_file() {
            let schema = registry
                .load_file(p)
                .map_err(|e| Fail::input(e.render_human_string()))?;
            return Ok(SchemaChoice {
                schema,
                path: Some(p.to_path_buf()),
            });
        }
        return registry
            .get(a)
            .map(|schema| SchemaChoice { schema, path: None })
            .ok_or_else(|| {
                let known: Vec<String> = registry.schemas().map(|s| s.id.clone()).collect();
                Fail::input(format!(
                    "unknown schema `{a}`: not a file and not one of {}",
                    known.join(", ")
                ))
            });
    }
    if let Some(f) = sim {
        let schema = driveset_sim::catalog::schema(f).map_err(Fail::input)?;
        return Ok(SchemaChoice { schema, path: None });
    }
    let id = match protocol.and_then(|p| p.0.families().next()) {
        Some(f) => f.descriptor().schema_id,
        None => {
            return Err(Fail::input(
                "say which drive family is on the bus: --schema ID|PATH, or --protocol lustbus|lecom|sdo",
            ));
        }
    };
    registry
        .get(id)
        .map(|schema| SchemaChoice { schema, path: None })
        .ok_or_else(|| Fail::input(format!("built-in schema `{id}` is missing")))
}

/// An [`driveset_schema::InputError`] as one human text.
trait RenderString {
    fn render_human_string(&self) -> String;
}

impl RenderString for driveset_schema::InputError {
    fn render_human_string(&self) -> String {
        crate::output::input_error_human(self, crate::output::Style::stderr())
            .trim_end()
            .trim_start_matches("error: ")
            .to_string()
    }
}
