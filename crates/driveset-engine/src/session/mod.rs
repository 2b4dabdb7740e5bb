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
//!
//! A line's bus keeps its link from drive to drive: each drive's session
//! borrows it ([`bus::BusSession`], learning as [`Session::open`] does,
//! through the one implementation in `reach`; `status` learns with
//! [`LearnStep::ReuseEarlier`]). What a line does to its bus rather than
//! to one drive — the LUSTBUS SELECT to address 31 and the transactions
//! parked around it, the LECOM MULTICAST — keeps its protocol's client
//! from [`crate::connect::lustbus_on`] / [`crate::connect::lecom_on`].

pub mod bus;
pub mod catalog;
pub mod learning;
pub mod on_drive;
pub mod open;
pub mod rate;
mod reach;

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

pub use bus::BusSession;
pub use catalog::{Catalog, CatalogError, Resolved, SchemaAsk, SchemaChoice};
pub use learning::{LearnDoc, LearnStep, LearnSummary, LearnedReport, learn_on};
pub use on_drive::{LearnRequest, SetOnDrive, SetOnDriveError, open_learning, set_on_drive};
pub use open::{FitError, OpenedPort, PortError, Ports, check_fit, open_port};

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
    /// Render (and write), or reuse an earlier file (`status`).
    pub step: LearnStep,
}

/// How a session reaches its drive.
#[derive(Default)]
pub struct SessionPolicy<'a> {
    /// Learn the schema from the drive when it lacks facts (`None`: use
    /// the schema as it is, `--no-learn`).
    pub learn: Option<LearnPolicy<'a>>,
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
    /// The schema named does not load or is not known ([`Catalog`]).
    #[error(transparent)]
    Catalog(#[from] CatalogError),
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
    /// [`LearnStep::ReuseEarlier`]: the learned schema file an earlier run
    /// wrote does not load.
    #[error("learned schema {}: {detail}", path.display())]
    Earlier {
        /// The file.
        path: PathBuf,
        /// What the schema reader said.
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
    /// The layer this failure comes from ([`crate::error::Layer`]): the
    /// engine's and the port's own; the command's input (a schema that does
    /// not fit, is not known or missing, a learned schema file, a CAN port
    /// where a line is needed); the drive (its descriptions do not render);
    /// the link (nothing answered the probes).
    pub fn layer(&self) -> crate::error::Layer {
        use crate::error::Layer;
        match self {
            SessionError::Engine(e) => e.layer(),
            SessionError::Port(e) => e.layer(),
            SessionError::Fit(_)
            | SessionError::Catalog(_)
            | SessionError::MissingBuiltin { .. }
            | SessionError::File { .. }
            | SessionError::Earlier { .. }
            | SessionError::DetectOnCan { .. }
            | SessionError::LustbusOnCan { .. } => Layer::Input,
            SessionError::Render { .. } => Layer::Device,
            SessionError::NoAnswer { .. } => Layer::Link,
        }
    }
}

/// The drive's family at `address` of an open character line, by the
/// read-only probes `scan` uses ([`crate::scan::probes_text`], and the MC
/// CODE 20091 after an answered TYPE), and what answered; on a CAN port
/// the one family that speaks CAN (a node's protocol is not probed: its
/// identify says whether it is one). Nothing is written.
///
/// The probes wait as the clients do for a first contact
/// ([`ScanOptions::first_contact`]: `latency`, the port's `?latency=`, plus
/// the floor; without one the first-contact allowance), so a drive behind
/// a slow device server is found.
pub fn detect(
    link: &mut Link,
    port: &str,
    address: u8,
    latency: Option<std::time::Duration>,
) -> Result<(driveset_schema::Family, String), SessionError> {
    let Link::Bytes(line) = link else {
        let mut on_can = driveset_schema::Family::ALL
            .into_iter()
            .filter(|f| f.descriptor().on_can());
        return match (on_can.next(), on_can.next()) {
            (Some(f), None) => Ok((
                f,
                format!("{port} is a CAN port: {} speaks CAN SDO", f.name()),
            )),
            _ => Err(SessionError::DetectOnCan {
                port: port.to_string(),
            }),
        };
    };
    let opts = ScanOptions::first_contact(latency);
    if let Some(d) = detect_protocol(line.as_mut(), address, &opts)? {
        return Ok((d.protocol, d.evidence));
    }
    // Nobody at the port's rate: a servo may have been left at a transfer
    // rate (--transfer-baud); LUSTBUS 5.1 tries every rate, as `scan` does.
    // The port's rate is set back, so the command's own search (identify's)
    // finds the drive there and says so.
    let here = line.baud();
    let mut found = None;
    for r in crate::scan::LUSTBUS_BAUDS
        .iter()
        .copied()
        .filter(|r| *r != here)
    {
        if line.set_baud(r).is_err() {
            break;
        }
        if let Some(d) = detect_protocol(line.as_mut(), address, &opts)? {
            found = Some((d.protocol, d.evidence));
            break;
        }
    }
    if line.baud() != here {
        line.set_baud(here).map_err(|e| {
            EngineError::link(
                crate::client::Target {
                    port: port.to_string(),
                    address,
                },
                e,
            )
        })?;
    }
    found.ok_or_else(|| SessionError::NoAnswer {
        port: port.to_string(),
        address,
        probes: crate::scan::probes_text(),
    })
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
        check_fit(&port, &schema)?;
        let way = reach::Owned {
            link: port.link,
            options: port.connect,
        };
        let reached = reach::reach(way, &port.name, schema, address, policy)?;
        Ok(Session {
            port: port.name,
            address,
            schema: reached.schema,
            client: reached.client,
            learned: reached.learned,
        })
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
