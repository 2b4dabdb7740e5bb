//! Capturing one drive into a twin (docs/twins.md): owns the walk from a
//! port the caller opened to the twin of the drive at an address. A
//! LUSTBUS drive is described first, whatever the schema (every
//! description and substitution text it sends, the schema learned from
//! them when the chosen one lacks facts, as `pull` learns it:
//! [`driveset_engine::capture::describe`]); then its family is checked and
//! every code of the schema read ([`driveset_engine::capture::capture`]);
//! the twin is made of what was read ([`crate::capture::of_drive`]).
//! Opening the port (and locking its bus) and choosing the schema are the
//! caller's (the engine's session); saying what was learned is too
//! ([`Described::learned`]).

use std::sync::Arc;

use driveset_engine::capture::{capture, describe};
use driveset_engine::client::{DriveClient, Identity};
use driveset_engine::env::Environment;
use driveset_engine::error::EngineError;
use driveset_engine::learn::{LearnOptions, PullSchemaError};
use driveset_engine::session::{FitError, OpenedPort, Session, SessionError, SessionPolicy};
use driveset_link::Link;
use driveset_schema::{Registry, Schema};
use driveset_sim::twin::Twin;

use crate::capture::Stamp;

/// What the caller did: the twin, the schema it was read with (learned
/// when the chosen one lacked facts) and what the drive said it is.
#[derive(Debug)]
pub struct Captured {
    /// The twin.
    pub twin: Twin,
    /// The schema every code was read with.
    pub schema: Arc<Schema>,
    /// What the drive said it is.
    pub identity: Identity,
}

/// A schema learned from the drive's descriptions: its id and how many
/// codes it holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LearnedSchema {
    /// The learned schema's id.
    pub id: String,
    /// How many codes it holds.
    pub codes: usize,
}

/// A drive ready to be captured ([`Described::capture`]): its client,
/// what it described (a LUSTBUS drive), the schema to read with.
pub struct Described {
    client: Box<dyn DriveClient>,
    schema: Arc<Schema>,
    described: Option<driveset_engine::capture::Described>,
    port: String,
    address: u8,
    rate: u32,
    /// The schema learned from the descriptions, when the chosen one
    /// lacked facts (for the caller to say so).
    pub learned: Option<LearnedSchema>,
}

/// Why a drive could not be captured.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The schema does not fit the port's kind of link.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The schemas a learned schema is checked against could not be had.
    #[error("{0}")]
    Registry(String),
    /// The drive's session could not be opened.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The bus or the drive failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The schema learned from the descriptions does not render into a
    /// file that checks.
    #[error("{port} address {address}: {detail}; no twin written")]
    Render {
        /// The port's name.
        port: String,
        /// The drive's address.
        address: u8,
        /// What is wrong.
        detail: String,
    },
    /// The drive is not of the schema's family, or could not say which it
    /// is ([`driveset_engine::identify::check_family`]).
    #[error("{0}; no twin written")]
    Family(EngineError),
}

/// Whether the drives of `schema`'s family describe their parameters
/// (LUSTBUS 11.1, 11.2), so that [`describe_drive`] asks for the schemas
/// a learned schema is checked against.
pub fn describes(schema: &Schema) -> bool {
    schema.family.descriptor().learning.is_some()
}

/// Open the drive at `address` of `opened` for its capture with `schema`:
/// a drive whose family describes its parameters is described first
/// (module docs; `registry` gives the schemas a learned schema is checked
/// against, asked only then), any other gets its session's client.
///
/// # Errors
/// The schema does not fit the port, the session could not be opened, the
/// bus or drive failed, or the learned schema does not render.
pub fn describe_drive(
    opened: OpenedPort,
    schema: Arc<Schema>,
    address: u8,
    registry: impl FnOnce() -> Result<Registry, String>,
) -> Result<Described, CaptureError> {
    let port = opened.name.clone();
    let rate = match &opened.link {
        Link::Bytes(l) => l.baud(),
        Link::Frames(l) => l.bitrate(),
    };
    if !describes(&schema) {
        let client =
            Session::open(opened, schema.clone(), address, &SessionPolicy::default())?.client;
        return Ok(Described {
            client,
            schema,
            described: None,
            port,
            address,
            rate,
            learned: None,
        });
    }
    driveset_engine::session::check_fit(&opened, &schema)?;
    let registry = registry().map_err(CaptureError::Registry)?;
    let connect = opened.connect;
    let c = Session::lustbus(opened, schema.clone(), address)?;
    let drive = format!("{port} address {address}");
    let d = describe(
        c,
        schema,
        &LearnOptions::default(),
        &registry,
        drive,
        &connect,
    )
    .map_err(|e| match e {
        PullSchemaError::Engine(e) => CaptureError::Engine(e),
        PullSchemaError::Render(detail) => CaptureError::Render {
            port: port.clone(),
            address,
            detail,
        },
    })?;
    Ok(Described {
        client: Box::new(d.client),
        schema: d.schema,
        described: Some(d.described),
        port,
        address,
        rate,
        learned: d.learned.map(|l| LearnedSchema {
            id: l.rendered.id,
            codes: l.rendered.codes,
        }),
    })
}

impl Described {
    /// Check the drive's family, read every code of the schema and make
    /// the twin, stamped now (`env`'s clock) as read from `drive PORT
    /// address N`.
    ///
    /// # Errors
    /// The drive is not of the schema's family ([`CaptureError::Family`]),
    /// or the bus or drive failed.
    pub fn capture(mut self, env: &dyn Environment) -> Result<Captured, CaptureError> {
        if let Err(e) = driveset_engine::identify::check_family(self.client.as_mut()) {
            return Err(CaptureError::Family(e));
        }
        let cap = capture(self.client.as_mut())?;
        let stamp = Stamp::now(env, format!("drive {} address {}", self.port, self.address));
        let twin = crate::capture::of_drive(
            &cap,
            &self.schema,
            self.address,
            stamp,
            self.rate,
            self.described,
        );
        Ok(Captured {
            twin,
            schema: self.schema,
            identity: cap.identity,
        })
    }
}

#[cfg(test)]
mod tests {
    use driveset_engine::env::Memory;
    use driveset_link::{PortSpec, VirtualClock};
    use driveset_schema::Registry;
    use driveset_sim::open::open_sim;
    use driveset_sim::port::SimSpec;

    use super::*;

    /// A simulated bus of `port`, opened as the session opens one.
    fn opened(port: &str) -> OpenedPort {
        let sim = SimSpec::parse(port).expect("sim port");
        let bus = open_sim(&sim, &VirtualClock::new()).expect("simulated bus");
        OpenedPort::named(sim.name(), PortSpec::Sim(sim.to_opaque()), bus.link())
    }

    fn env() -> Memory {
        Memory::at("2026-12-07T10:11:12Z".parse().expect("timestamp"))
    }

    #[test]
    fn a_tmd_is_captured_without_describing_and_stamped_by_the_clock() {
        let schema = Registry::builtin()
            .expect("built-in schemas")
            .get("lenze-tmd")
            .expect("tmd");
        assert!(!describes(&schema));
        let d = describe_drive(opened("sim://tmd?addresses=4"), schema, 4, || {
            panic!("no registry asked for a family that does not describe")
        })
        .expect("opened");
        assert_eq!(d.learned, None);
        let c = d.capture(&env()).expect("captured");
        assert_eq!(c.twin.address, 4);
        assert_eq!(c.twin.schema, "lenze-tmd");
        assert_eq!(c.twin.captured, "2026-12-07");
        assert_eq!(c.twin.driveset, env!("CARGO_PKG_VERSION"));
        assert!(c.twin.source.ends_with(" address 4"), "{}", c.twin.source);
        assert!(c.twin.descriptions.is_none());
        assert!(!c.twin.values.is_empty());
    }

    #[test]
    fn a_schema_of_another_bus_does_not_fit_the_port() {
        let schema = Registry::builtin()
            .expect("built-in schemas")
            .get("lust-mc6000")
            .expect("mc6000");
        assert!(describes(&schema));
        let e = describe_drive(opened("sim://ecs?addresses=1"), schema, 1, || {
            Err("not asked".into())
        })
        .err()
        .expect("refused");
        assert!(matches!(e, CaptureError::Fit(_)), "{e:?}");
    }
}
