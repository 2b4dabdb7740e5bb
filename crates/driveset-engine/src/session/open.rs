//! Owns the first steps of a session: a port string opened and its bus
//! locked, and the check that a schema can talk over it. The engine does no
//! IO of its own (docs/architecture.md): the front end opens transports and
//! the simulator through [`Ports`] and takes the advisory bus locks through
//! it; this module is the one sequence every command runs them in, so no
//! command drives a bus another process holds, however it spelled the port
//! (docs/architecture.md, "One path from a port to a drive"):
//!
//! 1. the port string parsed ([`PortSpec::parse`]);
//! 2. the bus its spelling names locked before it is opened
//!    ([`Ports::bus_before_open`]: serial, slcan, SocketCAN, a simulated
//!    bus with a state file), so a port another driveset holds is refused
//!    naming the holder before its open would fail on TIOCEXCL (or, for a
//!    simulated bus, read and later write back the state file the other
//!    process drives);
//! 3. the port opened ([`Ports::open`]);
//! 4. the bus the opened link reaches locked ([`driveset_link::Link::bus_id`]),
//!    whatever transport it is (a simulated bus that lives in this process
//!    only names the process in its id, so no other process shares it).
//!
//! [`check_fit`] is the refusal before anything is sent when a schema's
//! protocol does not run on the port's kind of link. Which drive answers is
//! identify's finding, the same on every port: a simulated port is only a
//! transport (docs/architecture.md).

use driveset_link::{Link, LinkError, LockError, PortSpec, PortSpecError};
use driveset_schema::{BusProtocol, Family, Schema};

use crate::connect::ConnectOptions;

/// A port the front end opened for one command: what reports call it, its
/// parsed form, its transport, and what its string says about talking to
/// its drives.
pub struct OpenedPort {
    /// The port as reports name it (canonical form, without `state=`).
    pub name: String,
    /// The parsed port (a `sim://` port with the drive a command on one
    /// drive asked for).
    pub spec: PortSpec,
    /// The transport (a simulated bus stays alive while any handle of it
    /// does).
    pub link: Link,
    /// The port's `latency=` and the like.
    pub connect: ConnectOptions,
}

impl std::fmt::Debug for OpenedPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpenedPort")
            .field("name", &self.name)
            .field("spec", &self.spec)
            .finish_non_exhaustive()
    }
}

impl OpenedPort {
    /// A real port as the front end opened it.
    pub fn real(spec: PortSpec, link: Link) -> Self {
        OpenedPort {
            name: spec.to_string(),
            connect: ConnectOptions::of(&spec),
            spec,
            link,
        }
    }

    /// A port the front end opened, named `name` in reports (an opener's
    /// canonical form), with its spec's connect options.
    pub fn named(name: String, spec: PortSpec, link: Link) -> Self {
        OpenedPort {
            name,
            connect: ConnectOptions::of(&spec),
            spec,
            link,
        }
    }
}

/// How the front end opens ports and takes bus locks (module docs): the
/// CLI opens real ports with `driveset-link` and `sim://` ports with the
/// simulator, and locks buses in `driveset_link::lock`'s directory for the
/// rest of the process.
pub trait Ports {
    /// Open `spec` (parsed from `port` as given) for a command on the drive
    /// at `address` (`None`: the whole bus; a `sim://FAMILY` port without
    /// `addresses=` then simulates one drive there). Nothing is locked.
    fn open(
        &self,
        port: &str,
        spec: PortSpec,
        address: Option<u8>,
    ) -> Result<OpenedPort, PortError>;

    /// The bus `spec` (parsed from `port`) reaches, when its spelling says
    /// so before it is opened (step 2 of the module docs): by default
    /// [`driveset_link::bus_id::before_open`] (serial, slcan, SocketCAN); a
    /// front end whose own ports name their bus (a simulated bus with a
    /// state file) says so too, so a bus another process holds is not
    /// even opened.
    fn bus_before_open(&self, port: &str, spec: &PortSpec) -> Option<String> {
        let _ = port;
        driveset_link::bus_id::before_open(spec)
    }

    /// Take the advisory lock of bus `bus` until the process ends; a bus
    /// this process holds already stays held.
    fn lock(&self, bus: &str) -> Result<(), LockError>;
}

/// Why a port could not be opened for a session.
#[derive(Debug, thiserror::Error)]
pub enum PortError {
    /// The port string does not parse.
    #[error(
        "{0}; ports look like /dev/ttyUSB0?baud=9600, tcp://host:4001, slcan:///dev/ttyACM0?bitrate=500000 or sim://mc6000?addresses=1"
    )]
    BadPort(PortSpecError),
    /// The port's own settings are wrong (a simulated bus's drives, its
    /// state file, its twins).
    #[error("{port}: {detail}")]
    Settings {
        /// The port as reports name it.
        port: String,
        /// What is wrong, and what to write instead.
        detail: String,
    },
    /// The transport could not be opened.
    #[error("cannot open {port}: {source}")]
    Open {
        /// The port.
        port: String,
        /// What the transport said.
        source: LinkError,
    },
    /// Another process holds the bus, or its lock cannot be taken; nothing
    /// was sent.
    #[error(transparent)]
    Busy(#[from] LockError),
}

impl PortError {
    /// The layer this failure comes from ([`crate::error::Layer`]): a bad
    /// port string or settings are the command's input; a transport that
    /// does not open or a bus another process holds are the link's.
    pub fn layer(&self) -> crate::error::Layer {
        use crate::error::Layer;
        match self {
            PortError::BadPort(_) | PortError::Settings { .. } => Layer::Input,
            PortError::Open { .. } | PortError::Busy(_) => Layer::Link,
        }
    }
}

/// Open `port` for a command on the drive at `address` (`None`: the whole
/// bus) and lock its bus, in the module docs' order.
pub fn open_port(
    ports: &dyn Ports,
    port: &str,
    address: Option<u8>,
) -> Result<OpenedPort, PortError> {
    let spec = PortSpec::parse(port).map_err(PortError::BadPort)?;
    if let Some(bus) = ports.bus_before_open(port, &spec) {
        ports.lock(&bus)?;
    }
    let opened = ports.open(port, spec, address)?;
    ports.lock(&opened.link.bus_id())?;
    Ok(opened)
}

/// Why a schema cannot talk over a port ([`check_fit`]); nothing was sent.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FitError {
    /// A CAN SDO schema on a character line.
    #[error(
        "schema `{schema}` speaks CAN SDO, but {port} is a character line (LUSTBUS / LECOM); use a CAN port (slcan://..., can://..., sim://ecs?...)"
    )]
    CanOnLine {
        /// Schema id.
        schema: String,
        /// The port.
        port: String,
    },
    /// A LUSTBUS or LECOM schema on a CAN port.
    #[error(
        "schema `{schema}` speaks {protocol}, but {port} is a CAN port; use a serial line (/dev/ttyUSB0, tcp://..., sim://mc6000?...)"
    )]
    LineOnCan {
        /// Schema id.
        schema: String,
        /// The schema's protocol as schemas spell it.
        protocol: &'static str,
        /// The port.
        port: String,
    },
}

/// Check that `schema` can talk over `port`: the protocol's kind of link
/// (a character line for LUSTBUS and LECOM, CAN for SDO). Which family
/// answers is identify's finding (`identify::check_family`, which
/// `--allow-family` lets through), the same on every port, not the port's.
pub fn check_fit(port: &OpenedPort, schema: &Schema) -> Result<(), FitError> {
    let want = schema.family.bus();
    let protocol_of = |f: Family| f.descriptor().schema_protocol;
    match (want, matches!(port.link, Link::Frames(_))) {
        (BusProtocol::CanSdo, false) => {
            return Err(FitError::CanOnLine {
                schema: schema.id.clone(),
                port: port.name.clone(),
            });
        }
        (BusProtocol::Lustbus | BusProtocol::Lecom, true) => {
            return Err(FitError::LineOnCan {
                schema: schema.id.clone(),
                protocol: protocol_of(schema.family),
                port: port.name.clone(),
            });
        }
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::cell::RefCell;

    use super::*;

    /// Opens every port as an in-memory line; records what was locked.
    struct Recorder {
        locked: RefCell<Vec<String>>,
    }

    impl Ports for Recorder {
        fn open(
            &self,
            _port: &str,
            spec: PortSpec,
            _address: Option<u8>,
        ) -> Result<OpenedPort, PortError> {
            self.locked.borrow_mut().push(format!("open {spec}"));
            let clock = driveset_link::VirtualClock::new();
            let (host, _drive) = driveset_link::mem::byte_pair(&clock, 9600).unwrap();
            Ok(OpenedPort::real(spec, Link::Bytes(Box::new(host))))
        }

        fn lock(&self, bus: &str) -> Result<(), LockError> {
            let bus = if bus.starts_with("mem:") {
                "mem:N"
            } else {
                bus
            };
            self.locked.borrow_mut().push(format!("lock {bus}"));
            Ok(())
        }
    }

    fn recorder() -> Recorder {
        Recorder {
            locked: RefCell::new(Vec::new()),
        }
    }

    #[test]
    fn a_serial_port_is_locked_before_and_after_it_is_opened() {
        let ports = recorder();
        open_port(&ports, "/dev/ttyDRIVESET-none?baud=9600", Some(1)).unwrap();
        assert_eq!(
            ports.locked.into_inner(),
            [
                "lock serial:/dev/ttyDRIVESET-none",
                "open /dev/ttyDRIVESET-none?baud=9600",
                "lock mem:N"
            ]
        );
    }

    #[test]
    fn a_tcp_port_is_locked_once_opened() {
        let ports = recorder();
        open_port(&ports, "tcp://127.0.0.1:4001", None).unwrap();
        assert_eq!(
            ports.locked.into_inner(),
            ["open tcp://127.0.0.1:4001", "lock mem:N"]
        );
    }

    #[test]
    fn a_bad_port_string_is_refused_before_anything_is_opened() {
        let ports = recorder();
        let e = open_port(&ports, "tcp://", None).unwrap_err();
        assert_eq!(e.layer(), crate::error::Layer::Input);
        assert!(
            e.to_string()
                .ends_with("; ports look like /dev/ttyUSB0?baud=9600, tcp://host:4001, slcan:///dev/ttyACM0?bitrate=500000 or sim://mc6000?addresses=1"),
            "{e}"
        );
        assert!(ports.locked.into_inner().is_empty());
    }
}
