//! Owns a one-drive command's learning orchestration: whether a command
//! learns (a LUSTBUS schema that lacks facts, unless the front end said
//! not to: [`LearnRequest`]), the session opened with the catalog's
//! registry and the request ([`open_learning`]), and a set file read for
//! a drive ([`set_on_drive`]: the set loaded, the drive reached, learned
//! from when the set's schema lacks facts, and the set resolved again
//! against what was learned). The front end parses, renders findings and
//! what was learned ([`super::LearnedReport::lines`]), nothing more
//! (docs/architecture.md, "One path from a port to a drive").

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_schema::{InputError, LoadedSet, ResolvedSet, Schema};

use super::{Catalog, LearnPolicy, LearnStep, Ports, Session, SessionError, SessionPolicy};
use super::{OpenedPort, open_port};
use crate::env::Environment;
use crate::learn::{LearnOptions, needs_learning};

/// How a one-drive command learns.
pub struct LearnRequest<'a> {
    /// How the descriptions are read and interpreted.
    pub options: LearnOptions,
    /// Learn when the schema lacks facts (`false`: `--no-learn`, the
    /// schema used as it is).
    pub learn: bool,
    /// Where the learned schema file `<id>.toml` is written (`None`: not
    /// written).
    pub dir: Option<PathBuf>,
    /// Through which it is written.
    pub env: &'a dyn Environment,
}

impl LearnRequest<'_> {
    /// Whether a session speaking `schema` learns: a LUSTBUS schema that
    /// lacks facts, unless the request says not to.
    pub fn wants(&self, schema: &Schema) -> bool {
        self.learn && needs_learning(schema)
    }
}

/// The drive at `address` of `opened`, speaking `schema` (refused when it
/// does not fit the port, [`super::check_fit`]): learned from first when
/// `learn` wants it ([`LearnRequest::wants`]), with the catalog's
/// registry, the learned file written to `learn.dir`.
pub fn open_learning(
    catalog: &Catalog,
    opened: OpenedPort,
    schema: Arc<Schema>,
    address: u8,
    learn: &LearnRequest<'_>,
) -> Result<Session, SessionError> {
    if !learn.wants(&schema) {
        return Session::open(opened, schema, address, &SessionPolicy::default());
    }
    let registry = catalog.registry().map_err(super::CatalogError::from)?;
    let policy = SessionPolicy {
        learn: Some(LearnPolicy {
            options: learn.options.clone(),
            registry: &registry,
            dir: learn.dir.clone(),
            env: learn.env,
            step: LearnStep::Render,
        }),
    };
    Session::open(opened, schema, address, &policy)
}

/// A set for a command against one drive, with the session that reaches
/// it ([`set_on_drive`]).
pub struct SetOnDrive {
    /// The drive (its client speaks the schema the set resolved against;
    /// what was learned on the way in [`Session::learned`]).
    pub session: Session,
    /// The set.
    pub set: ResolvedSet,
}

/// Why a set could not be brought to its drive.
#[derive(Debug)]
pub enum SetOnDriveError {
    /// The set file does not load; nothing was sent.
    Input(Box<InputError>),
    /// The set has findings against its schema (or against the schema
    /// learned from the drive, `learned`); nothing was written.
    Findings {
        /// The set as loaded, with its findings.
        loaded: Box<LoadedSet>,
        /// What was learned before the set was resolved again.
        learned: Option<Box<super::LearnedReport>>,
    },
    /// The port, the catalog or the drive.
    Session(SessionError),
}

impl From<SessionError> for SetOnDriveError {
    fn from(e: SessionError) -> Self {
        SetOnDriveError::Session(e)
    }
}

/// The loaded set when it has no findings and resolved.
fn valid(loaded: LoadedSet) -> Result<(Arc<Schema>, ResolvedSet), SetOnDriveError> {
    match (loaded.findings.is_empty(), &loaded.schema, &loaded.resolved) {
        (true, Some(schema), Some(set)) => Ok((schema.clone(), set.clone())),
        _ => Err(SetOnDriveError::Findings {
            loaded: Box::new(loaded),
            learned: None,
        }),
    }
}

/// Loads `set` with the catalog's registry and reaches the drive at
/// `address` of the port string `port` for it: when the set's schema is a
/// LUSTBUS schema that lacks facts (and `learn` wants it), the drive's
/// descriptions are learned first and the set is resolved again against
/// the learned schema (the set's findings against the schema that lacked
/// facts do not count); else a set with findings is refused before the
/// port is opened.
pub fn set_on_drive(
    catalog: &Catalog,
    ports: &dyn Ports,
    set: &Path,
    port: &str,
    address: u8,
    learn: &LearnRequest<'_>,
) -> Result<SetOnDrive, SetOnDriveError> {
    let registry = catalog
        .registry()
        .map_err(|e| SetOnDriveError::Input(Box::new(e)))?;
    let loaded = driveset_schema::load_set(set, &mut registry.clone())
        .map_err(|e| SetOnDriveError::Input(Box::new(e)))?;
    if let Some(base) = loaded.schema.clone().filter(|s| learn.wants(s)) {
        let opened = open_port(ports, port, Some(address)).map_err(SessionError::from)?;
        let session = open_learning(catalog, opened, base.clone(), address, learn)?;
        let mut registry = registry;
        registry.insert_as(&base.id, session.schema.clone());
        let loaded = driveset_schema::load_set(set, &mut registry)
            .map_err(|e| SetOnDriveError::Input(Box::new(e)))?;
        return match valid(loaded) {
            Ok((_, set)) => Ok(SetOnDrive { session, set }),
            Err(SetOnDriveError::Findings { loaded, .. }) => Err(SetOnDriveError::Findings {
                loaded,
                learned: session.learned.map(Box::new),
            }),
            Err(e) => Err(e),
        };
    }
    let (schema, set) = valid(loaded)?;
    let opened = open_port(ports, port, Some(address)).map_err(SessionError::from)?;
    let session = Session::open(opened, schema, address, &SessionPolicy::default())?;
    Ok(SetOnDrive { session, set })
}
