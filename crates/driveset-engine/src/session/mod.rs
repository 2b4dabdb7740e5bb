//! Owns the one path from a port string to a ready client for one drive:
//! the port opened and its bus locked ([`open`]: through the front end's
//! [`Ports`]), the schema checked against the port ([`check_fit`]), the
//! drive's protocol found by read-only probes when no schema is named
//! ([`detect`]), a LUSTBUS schema that lacks facts learned from the drive's
//! own descriptions and written through the [`Environment`]
//! ([`learning`]), and the client that speaks the schema in the end
//! ([`Session::open`], [`Session::open_port`]). The front end opens
//! transports and takes bus locks when the session asks ([`Ports`]) and
//! renders what the session returns; it builds no client and writes no
//! learned file itself (docs/architecture.md, "One path from a
//! port to a drive").

pub mod learning;
pub mod lustbus_family;
pub mod open;
pub mod rate;

use std::path::PathBuf;
use std::sync::Arc;

use driveset_link::{ByteLink, Link};
use driveset_schema::{Registry, Schema};

use crate::client::{DriveClient, LustbusClient};
use crate::connect;
use crate::env::Environment;
use crate::error::EngineError;
use crate::learn::LearnOptions;
use crate::scan::{ScanOptions, detect_protocol};

pub use learning::{LearnedReport, learn_on};
pub use open::{
    FitError, FitPolicy, OpenedPort, PortError, Ports, SimulatedDrives, check_fit, open_port,
};

/// Learning a LUSTBUS schema that lacks facts from the drive's
/// descriptions ([`learning`]).
pub struct LearnPolicy<'a> {
    /// How the descriptions are read and interpreted.
    pub options: LearnOptions,
    /// The schemas the learned schema is checked against (holds the base).
    pub registry: &'a Registry,
    /// Where the learned schema file `<id>.toml` is written (`None`: not
    /// written).
    pub dir: Option<PathBuf>,
    /// Through which the file is written.
    pub env: &'a dyn Environment,
}

/// How a session reaches its drive.
#[derive(Default)]
pub struct SessionPolicy<'a> {
    /// Learn the schema from the drive when it lacks facts (`None`: use
    /// the schema as it is, `--no-learn`).
    pub learn: Option<LearnPolicy<'a>>,
    /// What [`check_fit`] lets through.
    pub fit: FitPolicy,
}

/// A drive reached through a port: the client speaking `schema`, and what
/// was learned on the way.
pub struct Session {
    /// The port as reports name it.
    pub port: String,
    /// The drive's address (node id on CAN).
    pub address: u8,
    /// The schema the client speaks (the learned one, after learning).
    pub schema: Arc<Schema>,
    /// The client.
    pub client: Box<dyn DriveClient>,
    /// What learning did, when it ran.
    pub learned: Option<LearnedReport>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field("port", &self.port)
            .field("address", &self.address)
            .field("schema", &self.schema.id)
            .field("learned", &self.learned.as_ref().map(|l| &l.id))
            .finish_non_exhaustive()
    }
}

/// Why a session could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The bus or the drive failed, or the engine refused (a schema whose
    /// protocol does not run on the port's kind of link, say).
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The port could not be opened or its bus locked ([`open_port`]).
    #[error(transparent)]
    Port(#[from] PortError),
    /// The schema cannot talk over the port ([`check_fit`]).
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The learned schema does not render into a file that checks.
    #[error("{port} address {address}: {detail}")]
    Render {
        /// The port.
        port: String,
        /// The drive.
        address: u8,
        /// What the check said.
        detail: String,
    },
    /// The learned schema file could not be written.
    #[error("cannot {action} {}: {detail}", path.display())]
    File {
        /// `create` (the directory) or `write` (the file).
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// What the file system said.
        detail: String,
    },
    /// [`detect`] on a CAN port: a node's protocol is not probed.
    #[error(
        "{port} is a CAN port: say which schema the node speaks (--schema lenze-ecs or a schema file)"
    )]
    DetectOnCan {
        /// The port.
        port: String,
    },
    /// [`detect`]: nothing answered the read-only probes.
    #[error(
        "{port} address {address}: no drive answered the read-only probes ({probes}); check wiring, address and baud rate, or name the schema with --schema"
    )]
    NoAnswer {
        /// The port.
        port: String,
        /// The address probed.
        address: u8,
        /// The probes sent ([`crate::scan::probes_text`]).
        probes: String,
    },
    /// A family's built-in schema is not in the registry given.
    #[error("built-in schema {id} is missing")]
    MissingBuiltin {
        /// The schema id.
        id: &'static str,
    },
    /// A LUSTBUS client was asked for on a CAN port.
    #[error("{port} is a CAN port; LUSTBUS needs a character line")]
    LustbusOnCan {
        /// The port.
        port: String,
    },
}

impl SessionError {
    /// Whether nothing reached a drive because the command's input was
    /// wrong (the CLI's exit 2) rather than the bus or drive failing
    /// (exit 3).
    pub fn is_input(&self) -> bool {
        match self {
            SessionError::Engine(e) => e.is_refused(),
            SessionError::Port(e) => e.is_input(),
            SessionError::Fit(_)
            | SessionError::MissingBuiltin { .. }
            | SessionError::File { .. }
            | SessionError::DetectOnCan { .. }
            | SessionError::LustbusOnCan { .. } => true,
            SessionError::Render { .. } | SessionError::NoAnswer { .. } => false,
        }
    }
}

/// The drive's family at `address` of an open character line, by the
/// read-only probes `scan` uses ([`crate::scan::probes_text`], and the MC
/// CODE 20091 after an answered TYPE), and what answered.
/// Nothing is written.
pub fn detect(
    link: &mut Link,
    port: &str,
    address: u8,
) -> Result<(driveset_schema::Family, String), SessionError> {
    let Link::Bytes(line) = link else {
        return Err(SessionError::DetectOnCan {
            port: port.to_string(),
        });
    };
    match detect_protocol(line.as_mut(), address, &ScanOptions::default())? {
        Some(d) => Ok((d.protocol, d.evidence)),
        None => Err(SessionError::NoAnswer {
            port: port.to_string(),
            address,
            probes: crate::scan::probes_text(),
        }),
    }
}

impl Session {
    /// The drive at `address` of the port string `port`, speaking
    /// `schema`: the port opened and its bus locked through `ports`
    /// ([`open_port`]), then [`Session::open`].
    pub fn open_port(
        ports: &dyn Ports,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
        policy: &SessionPolicy<'_>,
    ) -> Result<Session, SessionError> {
        let opened = open_port(ports, port, Some(address))?;
        Session::open(opened, schema, address, policy)
    }

    /// The drive at `address` of `port`, speaking `schema`: a schema that
    /// cannot talk over the port is refused before anything is sent
    /// ([`check_fit`]); learned from the drive first when `policy` says so
    /// and the schema lacks facts ([`crate::learn::needs_learning`]).
    pub fn open(
        port: OpenedPort,
        schema: Arc<Schema>,
        address: u8,
        policy: &SessionPolicy<'_>,
    ) -> Result<Session, SessionError> {
        check_fit(&port, &schema, Some(address), policy.fit)?;
        let learn = policy
            .learn
            .as_ref()
            .filter(|_| crate::learn::needs_learning(&schema));
        match (learn, port.link) {
            (Some(learn), Link::Bytes(line)) => {
                let mut base = connect::lustbus(line, schema.clone(), address, &port.connect)?;
                let learned = learn_on(&mut base, &schema, &port.name, learn)?;
                let client = connect::lustbus(
                    base.into_link(),
                    learned.schema.clone(),
                    address,
                    &port.connect,
                )?;
                Ok(Session {
                    port: port.name,
                    address,
                    schema: learned.schema.clone(),
                    client: Box::new(client),
                    learned: Some(learned),
                })
            }
            (_, link) => Ok(Session {
                client: connect::connect_with(link, schema.clone(), address, &port.connect)?,
                port: port.name,
                address,
                schema,
                learned: None,
            }),
        }
    }

    /// A LUSTBUS client for the drive at `address` of `port` (schema pull,
    /// a twin's MC descriptions, the MC-or-VF1000 probe): refused on a CAN
    /// port.
    pub fn lustbus(
        port: OpenedPort,
        schema: Arc<Schema>,
        address: u8,
    ) -> Result<LustbusClient<Box<dyn ByteLink>>, SessionError> {
        match port.link {
            Link::Bytes(line) => Ok(connect::lustbus(line, schema, address, &port.connect)?),
            Link::Frames(_) => Err(SessionError::LustbusOnCan { port: port.name }),
        }
    }
}
