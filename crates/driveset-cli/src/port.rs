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
use driveset_engine::session::{OpenedPort as SessionPort, Session, SessionPolicy};
use driveset_link::{Link, OpenOptions, Openers, PortSpec, VirtualClock};
use driveset_schema::{BusProtocol, Family, Registry, Schema};
use driveset_sim::log::EventLog;
use driveset_sim::open::{SimLink, open_sim_with};
use driveset_sim::port::{SimOpener, SimSpec};

pub use crate::fail::{Fail, engine_exit};

pub use crate::args::BusArg as ProtocolArg;

/// Name of a family's protocol as schemas spell it (`[schema] protocol`).
pub fn protocol_name(f: Family) -> &'static str {
    f.descriptor().schema_protocol
}

/// An open port.
#[derive(Debug)]
pub struct OpenPort {
    /// The port as reports name it (canonical form, without `state=`).
    pub name: String,
    /// The parsed port.
    pub spec: PortSpec,
    /// The transport.
    pub link: Link,
    /// The simulated bus behind a `sim://` port.
    pub sim: Option<SimLink>,
}

impl OpenPort {
    /// The family a `sim://` port simulates (on a mixed LUSTBUS,
    /// `sim://lustbus`, the family of its first drive).
    pub fn sim_family(&self) -> Option<Family> {
        self.sim.as_ref().map(SimLink::family)
    }

    /// The family of the simulated drive at `address`; on a mixed LUSTBUS
    /// without an address, or at an address it does not have, the family
    /// of the bus that speaks `schema`'s protocol, if any, else the first.
    fn sim_family_for(&self, schema: &Schema, address: Option<u8>) -> Option<Family> {
        let sim = self.sim.as_ref()?;
        if let Some(f) = address.and_then(|a| sim.family_of(a)) {
            return Some(f);
        }
        let families = sim.families();
        families
            .iter()
            .copied()
            .find(|&f| f == schema.family)
            .or_else(|| families.first().copied())
    }
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
/// without `addresses=` simulates one drive at `address`.
pub fn open_port_at(port: &str, address: Option<u8>) -> Result<OpenPort, Fail> {
    let bad_port = |e: driveset_link::PortSpecError| {
        Fail::input(format!(
            "{e}; ports look like /dev/ttyUSB0?baud=9600, tcp://host:4001, slcan:///dev/ttyACM0?bitrate=500000 or sim://mc6000?addresses=1"
        ))
    };
    let spec = PortSpec::parse(port).map_err(bad_port)?;
    if !matches!(spec, PortSpec::Sim(_)) {
        lock_before_open(&spec)?;
        let link = driveset_link::open(&spec, &OpenOptions::default())
            .map_err(|e| Fail::bus(format!("cannot open {spec}: {e}")))?;
        lock_bus(&link.bus_id())?;
        return Ok(OpenPort {
            name: spec.to_string(),
            link,
            sim: None,
            spec,
        });
    }
    // The simulator's port: opened here rather than through
    // `driveset_link::open_with`, because the commands also ask the
    // simulated bus which drives it holds.
    let mut sim = SimSpec::parse(port).map_err(bad_port)?;
    if let Some(a) = address
        && !sim.names_drives()
    {
        sim.addresses.push(a);
    }
    let name = sim.name();
    let config = SimOpener::default()
        .config(&sim)
        .map_err(|e| Fail::input(format!("{name}: {e}")))?;
    let clock = VirtualClock::new();
    let bus = open_sim_with(&config, &clock, &name, EventLog::off())
        .map_err(|e| Fail::input(format!("{name}: {e}")))?;
    if config.state.is_some() {
        lock_bus(&bus.link().bus_id())?;
    }
    Ok(OpenPort {
        name,
        link: bus.link(),
        sim: Some(bus),
        spec: PortSpec::Sim(sim.to_opaque()),
    })
}

/// The bus locks this process holds ([`lock_bus`]), until it exits.
static BUS_LOCKS: std::sync::Mutex<Vec<driveset_link::BusLock>> = std::sync::Mutex::new(Vec::new());

/// Take the advisory lock of bus `bus_id` for the rest of the command
/// (`driveset_link::lock`, in [`driveset_link::lock::lock_dir`]): refused,
/// exit 3 (the bus is busy; nothing was sent), naming the process that
/// holds it. A bus this process locked already (a command that opens its
/// port again, a line run's second pass) stays locked. Every command that
/// talks to drives opens its port through here (or [`lock_port`]), so two
/// processes never drive one bus at once, whatever each spelled its port.
pub fn lock_bus(bus_id: &str) -> Result<(), Fail> {
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
    let lock = driveset_link::BusLock::acquire(&driveset_link::lock::lock_dir(), bus_id, &holder)
        .map_err(|e| Fail::bus(e.to_string()))?;
    held.push(lock);
    Ok(())
}

/// [`lock_bus`] before `spec` is opened, when its spelling says the bus
/// (`driveset_link::bus_id::before_open`: serial, slcan, SocketCAN): a
/// port another driveset holds is refused naming the holder, before its
/// open would fail on TIOCEXCL.
pub fn lock_before_open(spec: &PortSpec) -> Result<(), Fail> {
    match driveset_link::bus_id::before_open(spec) {
        Some(bus) => lock_bus(&bus),
        None => Ok(()),
    }
}

/// [`lock_bus`] for a link opened from `spec` (a line's bus): a simulated
/// bus without a state file lives in this process only, so there is
/// nothing another process could drive and nothing is locked.
pub fn lock_port(spec: &PortSpec, link: &Link) -> Result<(), Fail> {
    if let PortSpec::Sim(o) = spec {
        let private = SimSpec::from_opaque(o)
            .ok()
            .and_then(|s| SimOpener::default().config(&s).ok())
            .is_some_and(|c| c.state.is_none());
        if private {
            return Ok(());
        }
    }
    lock_bus(&link.bus_id())
}

/// Check that `schema` can talk over `port`: the protocol's kind of link,
/// and on `sim://` the simulated family (another family of the same
/// protocol passes with `allow_family`, `--allow-family`): on a mixed LUSTBUS (`sim://lustbus`) the
/// family of the drive at `address`.
pub fn check_fit(
    port: &OpenPort,
    schema: &Schema,
    address: Option<u8>,
    allow_family: bool,
) -> Result<(), Fail> {
    let want = schema.family.bus();
    let is_frames = matches!(port.link, Link::Frames(_));
    match (want, is_frames) {
        (BusProtocol::CanSdo, false) => {
            return Err(Fail::input(format!(
                "schema `{}` speaks CAN SDO, but {} is a character line (LUSTBUS / LECOM); use a CAN port (slcan://..., can://..., sim://ecs?...)",
                schema.id, port.name
            )));
        }
        (BusProtocol::Lustbus | BusProtocol::Lecom, true) => {
            return Err(Fail::input(format!(
                "schema `{}` speaks {}, but {} is a CAN port; use a serial line (/dev/ttyUSB0, tcp://..., sim://mc6000?...)",
                schema.id,
                protocol_name(schema.family),
                port.name
            )));
        }
        _ => {}
    }
    if let Some(f) = port.sim_family_for(schema, address) {
        let holds = match (address, port.sim.as_ref().is_some_and(SimLink::is_mixed)) {
            (Some(a), true) => format!("has a {} drive at address {a}", f.name()),
            _ => format!("simulates {} drives", f.name()),
        };
        let sim_proto = f;
        if sim_proto.bus() != want {
            return Err(Fail::input(format!(
                "{} {holds} ({}), schema `{}` is for {}; use a set / schema of that family",
                port.name,
                protocol_name(sim_proto),
                schema.id,
                protocol_name(schema.family)
            )));
        }
        if sim_proto != schema.family && !allow_family {
            return Err(Fail::input(format!(
                "{} {holds} ({}), schema `{}` is for {}; use a set / schema of that family, or pass --allow-family",
                port.name,
                protocol_name(sim_proto),
                schema.id,
                protocol_name(schema.family)
            )));
        }
    }
    Ok(())
}

/// A client for the drive at `address` on `port`, speaking `schema`'s
/// protocol (after [`check_fit`]), through the engine's session.
pub fn client(
    port: &OpenPort,
    schema: Arc<Schema>,
    address: u8,
    allow_family: bool,
) -> Result<Box<dyn DriveClient>, Fail> {
    check_fit(port, &schema, Some(address), allow_family)?;
    let opened = port.session_port()?;
    Ok(Session::open(opened, schema, address, &SessionPolicy::default())?.client)
}

/// A fresh byte-link handle of the port (sim ports hand out any number;
/// a real port hands out its one link once).
pub fn byte_link(port: &OpenPort) -> Result<Box<dyn driveset_link::ByteLink>, Fail> {
    if let Some(sim) = &port.sim {
        return sim.byte_link().ok_or_else(|| {
            Fail::input(format!("{} is a CAN bus, not a character line", port.name))
        });
    }
    Err(Fail::input(format!(
        "{}: the link was already taken; open the port again",
        port.name
    )))
}

fn frame_link(port: &OpenPort) -> Result<Box<dyn driveset_link::FrameLink>, Fail> {
    if let Some(sim) = &port.sim {
        return sim.frame_link().ok_or_else(|| {
            Fail::input(format!("{} is a character line, not a CAN bus", port.name))
        });
    }
    Err(Fail::input(format!(
        "{}: the link was already taken; open the port again",
        port.name
    )))
}

impl OpenPort {
    /// The engine's view of a `sim://` port: a fresh handle of its link
    /// (the simulated bus stays with `self`).
    fn session_port(&self) -> Result<SessionPort, Fail> {
        let link = match &self.link {
            Link::Bytes(_) => Link::Bytes(byte_link(self)?),
            Link::Frames(_) => Link::Frames(frame_link(self)?),
        };
        Ok(SessionPort {
            name: self.name.clone(),
            link,
            connect: connect_options(&self.spec),
        })
    }

    /// The port as the engine's session takes it, and the simulated bus
    /// behind a `sim://` port, which the caller keeps alive while the
    /// session's client talks over it.
    pub fn into_session_port(self) -> Result<(SessionPort, Option<SimLink>), Fail> {
        if self.sim.is_some() {
            let port = self.session_port()?;
            return Ok((port, self.sim));
        }
        let port = SessionPort {
            connect: connect_options(&self.spec),
            name: self.name,
            link: self.link,
        };
        Ok((port, None))
    }
}

/// Like [`client`], consuming the port (the only way for a real port, whose
/// one transport moves into the client).
pub fn into_client(
    port: OpenPort,
    schema: Arc<Schema>,
    address: u8,
    allow_family: bool,
) -> Result<Box<dyn DriveClient>, Fail> {
    if port.sim.is_some() {
        return client(&port, schema, address, allow_family);
    }
    check_fit(&port, &schema, Some(address), allow_family)?;
    let (opened, _) = port.into_session_port()?;
    Ok(Session::open(opened, schema, address, &SessionPolicy::default())?.client)
}

/// What the port string says about talking to its drives (`latency=`).
pub fn connect_options(spec: &PortSpec) -> ConnectOptions {
    ConnectOptions {
        latency: spec.latency(),
    }
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
