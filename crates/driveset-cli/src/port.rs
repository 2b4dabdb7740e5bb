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
//! line, CAN SDO a CAN port; a mismatch is refused before anything is sent.
//! A `sim://` port is only a transport: past its opener ([`CliPorts`],
//! [`openers`]) nothing here or in the engine asks whether a port is
//! simulated (docs/architecture.md, "A simulated port is only a transport").
//!
//! Errors carry their exit code ([`Fail`], the CLI's one error
//! convention): 2 for usage and input (a bad port string, a schema that
//! does not fit the port, a refusal before anything was sent), 3 for bus
//! and device failures.

use std::path::PathBuf;
use std::sync::Arc;

use driveset_engine::assign::Schemas;
use driveset_engine::client::DriveClient;
use driveset_engine::session::{
    self, Catalog, OpenedPort, PortError, Ports, SchemaAsk, Session, SessionPolicy,
};
use driveset_link::{LockError, OpenOptions, Openers, PortSpec};
use driveset_schema::{Family, Registry, Schema};
use driveset_sim::open::SimLink;
use driveset_sim::port::{SimOpener, SimSpec};

pub use crate::fail::{Fail, family_exit};

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
        let bus = open_sim(&sim)?;
        let spec = PortSpec::Sim(sim.to_opaque());
        Ok(OpenedPort::named(sim.name(), spec, bus.link()))
    }

    fn bus_before_open(&self, port: &str, spec: &PortSpec) -> Option<String> {
        if !matches!(spec, PortSpec::Sim(_)) {
            return driveset_link::bus_id::before_open(spec);
        }
        SimOpener::default().bus_before_open(port)
    }

    fn lock(&self, bus: &str) -> Result<(), LockError> {
        lock_bus(bus)
    }
}

/// The simulated bus `sim` describes, in virtual time
/// ([`SimOpener::open_bus`]).
fn open_sim(sim: &SimSpec) -> Result<SimLink, PortError> {
    SimOpener::default()
        .open_bus(sim)
        .map_err(|e| PortError::Settings {
            port: sim.name(),
            detail: e.to_string(),
        })
}

/// The port openers the CLI registers for the schemes `driveset-link` does
/// not open itself: the simulator's for `sim://`.
pub fn openers() -> Openers {
    Openers::none().with(Arc::new(SimOpener::default()))
}

/// `spec` at another line rate (`baud=` on a character line, `bitrate=`
/// on CAN); an opener's port through its opener.
pub fn with_rate(spec: &PortSpec, rate: u32) -> PortSpec {
    openers().at_rate(spec, rate)
}

/// The port `recorded` (a journal's) as a later command reaches the same
/// drives: without the keys of the run that recorded it, through its
/// opener ([`driveset_link::PortOpener::without_run_keys`]); a port
/// `driveset-link` opens itself, as recorded.
pub fn without_run_keys(recorded: &str) -> String {
    match PortSpec::parse(recorded) {
        Ok(PortSpec::Sim(o)) => match openers().get(&o.scheme) {
            Some(opener) => PortSpec::Sim(opener.without_run_keys(&o)).to_string(),
            None => recorded.to_string(),
        },
        _ => recorded.to_string(),
    }
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

/// Open `spec` as a raw link (no session, no lock: the caller holds the
/// bus's lock already), through the registered openers, as `doctor`
/// reopens a port at each rate it tries.
pub fn reopen(spec: &PortSpec) -> Result<driveset_link::Link, driveset_link::LinkError> {
    driveset_link::open_with(spec, &OpenOptions::default(), &openers())
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

/// Check that `schema` can talk over `port` (the engine's
/// [`session::check_fit`]: the protocol's kind of link).
pub fn check_fit(port: &OpenPort, schema: &Schema) -> Result<(), Fail> {
    session::check_fit(port, schema).map_err(|e| Fail::input(e.to_string()))
}

/// A client for the drive at `address` on `port`, speaking `schema`'s
/// protocol, through the engine's session (which checks that the schema
/// fits the port first, [`driveset_engine::session::check_fit`]).
pub fn into_client(
    port: OpenPort,
    schema: Arc<Schema>,
    address: u8,
) -> Result<Box<dyn DriveClient>, Fail> {
    Ok(Session::open(port, schema, address, &SessionPolicy::default())?.client)
}

/// The schemas every command knows: the engine's [`Catalog`] of the
/// built-in schemas and `--schemas DIR`, with the simulator's fictional
/// fixtures withheld by id (a set names a fixture by its file, or
/// `--schemas parameter-sets/fixtures` loads them).
pub fn catalog(dirs: &[PathBuf]) -> Catalog {
    Catalog::new(dirs).withholding(driveset_sim::catalog::withheld())
}

/// The schemas of each family `driveset address` and the recovery of an
/// address change pick from ([`Catalog::family_schemas`]).
pub fn family_schemas(dirs: &[PathBuf], given: &[String]) -> Result<Schemas, Fail> {
    catalog(dirs)
        .family_schemas(given)
        .map_err(|e| Fail::input(catalog_error(&e)))
}

/// The registry of [`catalog`].
pub fn registry(dirs: &[PathBuf]) -> Result<Registry, Fail> {
    catalog(dirs)
        .registry()
        .map_err(|e| Fail::input(e.render_human_string()))
}

pub use driveset_engine::session::SchemaChoice;

/// The schema `--schema ID|PATH` names, else the built-in schema of
/// `--protocol` ([`Catalog::chosen`]); neither: an error that says to
/// give one (the commands that ask the drive use [`Catalog::resolve`]).
pub fn resolve_schema(
    arg: Option<&str>,
    dirs: &[PathBuf],
    protocol: Option<ProtocolArg>,
) -> Result<SchemaChoice, Fail> {
    let ask = SchemaAsk {
        schema: arg,
        protocol: protocol.map(|p| p.0),
    };
    catalog(dirs)
        .chosen(ask)
        .map_err(|e| Fail::input(catalog_error(&e)))?
        .ok_or_else(|| {
            Fail::input(
                "say which drive family is on the bus: --schema ID|PATH, or --protocol lustbus|lecom|sdo",
            )
        })
}

/// A catalog error as one text (an input error rendered as the CLI
/// renders them).
pub fn catalog_error(e: &session::CatalogError) -> String {
    match e {
        session::CatalogError::Input(i) => i.render_human_string(),
        other => other.to_string(),
    }
}

/// An [`driveset_schema::InputError`] as one human text.
trait RenderString {
    fn render_human_string(&self) -> String;
}

impl RenderString for driveset_schema::InputError {
    fn render_human_string(&self) -> String {
        driveset_report::validation::input_error_human(self, crate::output::stderr_style())
            .trim_end()
            .trim_start_matches("error: ")
            .to_string()
    }
}
