//! Owns which schemas a command knows and which one it talks with: the one
//! place the built-in registry is built for a command ([`Catalog`]: the
//! vendors' built-in schemas, every `*.toml` of `--schemas DIR`, the ids a
//! front end withholds), and the one resolution of a command's schema
//! arguments ([`Catalog::resolve`]: a schema named by id or file, else the
//! built-in schema of the protocol's family, else the drive's protocol
//! found by read-only probes, [`super::detect`]). The port plays no part in
//! the choice: a simulated port is resolved as a serial one is
//! (docs/architecture.md, "A simulated port is only a transport").

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_schema::{BusProtocol, Family, InputError, Registry, Schema};

use super::{OpenedPort, SessionError};

/// A schema id withheld from a user's registry, with its file and text
/// ([`Registry::withhold`]: a set naming it by id is told to name its file).
pub type Withheld = (&'static str, &'static str, &'static str);

/// The schemas a command knows (module docs).
#[derive(Debug, Clone, Default)]
pub struct Catalog {
    /// `--schemas DIR`, in order.
    pub dirs: Vec<PathBuf>,
    /// Ids withheld by id (the simulator's fictional fixtures).
    pub withheld: Vec<Withheld>,
}

/// Why a catalog could not give a schema; nothing was sent.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    /// A schema file or a `--schemas` directory does not load.
    #[error("{}", .0.message)]
    Input(Box<InputError>),
    /// `--schema ID`: neither a file nor a known id.
    #[error("unknown schema `{given}`: not a file and not one of {}", known.join(", "))]
    Unknown {
        /// What was given.
        given: String,
        /// The ids known.
        known: Vec<String>,
    },
    /// A family's built-in schema is not in the registry (a build defect).
    #[error("built-in schema `{id}` is missing")]
    MissingBuiltin {
        /// The id.
        id: &'static str,
    },
}

impl From<InputError> for CatalogError {
    fn from(e: InputError) -> Self {
        CatalogError::Input(Box::new(e))
    }
}

/// A schema and whether it came from a file.
#[derive(Debug, Clone)]
pub struct SchemaChoice {
    /// The schema.
    pub schema: Arc<Schema>,
    /// The file it was loaded from, when it was named by path.
    pub path: Option<PathBuf>,
}

/// What a command asked for ([`Catalog::resolve`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct SchemaAsk<'a> {
    /// `--schema ID|PATH`.
    pub schema: Option<&'a str>,
    /// `--protocol`: its first family's built-in schema.
    pub protocol: Option<BusProtocol>,
}

/// The schema a command talks with, and how it was found.
#[derive(Debug, Clone)]
pub struct Resolved {
    /// The schema.
    pub choice: SchemaChoice,
    /// What answered the read-only probes, when the drive's protocol was
    /// detected (`None`: named, or by `--protocol`).
    pub evidence: Option<String>,
}

impl Catalog {
    /// A catalog of the built-in schemas and `dirs`.
    pub fn new(dirs: &[PathBuf]) -> Self {
        Catalog {
            dirs: dirs.to_vec(),
            withheld: Vec::new(),
        }
    }

    /// This catalog withholding `ids` by id ([`Withheld`]).
    #[must_use]
    pub fn withholding(mut self, ids: impl IntoIterator<Item = Withheld>) -> Self {
        self.withheld.extend(ids);
        self
    }

    /// The registry: the built-in schemas, the withheld ids, then every
    /// schema of the directories.
    pub fn registry(&self) -> Result<Registry, InputError> {
        let mut r = Registry::builtin()?;
        for (id, file, text) in &self.withheld {
            r.withhold(id, file, text);
        }
        for d in &self.dirs {
            r.load_dir(d)?;
        }
        Ok(r)
    }

    /// The built-in schema of `family` (its descriptor's `schema_id`).
    pub fn builtin(&self, family: Family) -> Result<Arc<Schema>, CatalogError> {
        let id = family.descriptor().schema_id;
        self.registry()?
            .get(id)
            .ok_or(CatalogError::MissingBuiltin { id })
    }

    /// The schema `given` names: a file, else a known id.
    pub fn named(&self, given: &str) -> Result<SchemaChoice, CatalogError> {
        let mut registry = self.registry()?;
        let p = Path::new(given);
        if p.is_file() {
            let schema = registry.load_file(p)?;
            return Ok(SchemaChoice {
                schema,
                path: Some(p.to_path_buf()),
            });
        }
        registry
            .get(given)
            .map(|schema| SchemaChoice { schema, path: None })
            .ok_or_else(|| CatalogError::Unknown {
                given: given.to_string(),
                known: registry.schemas().map(|s| s.id.clone()).collect(),
            })
    }

    /// The schemas of each family `driveset address` and the recovery of
    /// an address change pick from: the built-in ones (and the
    /// directories'), on every port; then each of `given` (`--schema`,
    /// [`Catalog::named`]).
    pub fn family_schemas(&self, given: &[String]) -> Result<crate::assign::Schemas, CatalogError> {
        let mut s = crate::assign::Schemas::from_registry(&self.registry()?);
        for g in given {
            s = s.with(self.named(g)?.schema);
        }
        Ok(s)
    }

    /// The schema of `ask` without talking to a drive: named, else the
    /// built-in schema of `--protocol`'s first family (`None`: neither was
    /// given; the drive must be asked, [`Catalog::resolve`]).
    pub fn chosen(&self, ask: SchemaAsk<'_>) -> Result<Option<SchemaChoice>, CatalogError> {
        if let Some(s) = ask.schema {
            return self.named(s).map(Some);
        }
        match ask.protocol.and_then(|p| p.families().next()) {
            Some(f) => Ok(Some(SchemaChoice {
                schema: self.builtin(f)?,
                path: None,
            })),
            None => Ok(None),
        }
    }

    /// The schema `recover` finishes a journal with: `named` (`--schema`),
    /// else the journal's: its id `id` among the known schemas when one of
    /// them has the recorded `fingerprint` (a journal without one: the
    /// id), else the recorded schema file `path` when it is a file (the
    /// engine refuses it when its fingerprint differs, naming both), else
    /// what the id gives.
    pub fn for_journal(
        &self,
        named: Option<&str>,
        id: &str,
        fingerprint: Option<&str>,
        path: Option<&str>,
    ) -> Result<SchemaChoice, CatalogError> {
        if let Some(s) = named {
            return self.named(s);
        }
        let by_id = self.named(id);
        if let Ok(c) = &by_id
            && fingerprint.is_none_or(|f| f == c.schema.fingerprint)
        {
            return by_id;
        }
        match path {
            Some(p) if Path::new(p).is_file() => self.named(p),
            _ => by_id,
        }
    }

    /// [`Catalog::for_journal`] of `journal`: `named`, else the schema its
    /// id, fingerprint and file give.
    pub fn for_journal_of(
        &self,
        named: Option<&str>,
        journal: &crate::journal::Journal,
    ) -> Result<SchemaChoice, CatalogError> {
        let source = &journal.schema_source;
        self.for_journal(
            named,
            &journal.schema,
            source.schema_fingerprint.as_deref(),
            source.schema_path.as_deref(),
        )
    }

    /// The schema the recovery of an address change's `journal` uses
    /// ([`Catalog::for_journal_of`]: a learned file types 81 / 82 where
    /// the built-in schema does not): `None` when the schema the journal
    /// records is no longer to be had, the address codes' types then
    /// learned from the drive's descriptions (`assign`); `named` must
    /// resolve.
    pub fn for_address_journal(
        &self,
        named: Option<&str>,
        journal: &crate::journal::Journal,
    ) -> Result<Option<SchemaChoice>, CatalogError> {
        match self.for_journal_of(named, journal) {
            Ok(c) => Ok(Some(c)),
            Err(e) if named.is_some() => Err(e),
            Err(_) => Ok(None),
        }
    }

    /// The schema a command on the drive at `address` of `port` talks
    /// with: [`Catalog::chosen`] (a protocol of several families: the
    /// family of the drive, by the probes below), else the built-in schema
    /// of the family the drive answers the read-only probes as
    /// ([`super::detect`]; on a CAN port, the one family that speaks CAN).
    /// The same on every port; the one rule every command's schema comes
    /// from (docs/architecture.md, "One path from a port to a drive").
    pub fn resolve(
        &self,
        port: &mut OpenedPort,
        address: u8,
        ask: SchemaAsk<'_>,
    ) -> Result<Resolved, SessionError> {
        // `--protocol` of several families (LUSTBUS: MC6000/7000 or
        // VF1000), no schema named: the family by the same probes (an MC
        // answers its own CODE form of 91-TYPE, a VF1000 NAKs it); when
        // the drive speaks another protocol, the protocol's first family
        // as named (identify then says the drive is not of it)
        if ask.schema.is_none()
            && let Some(p) = ask.protocol
            && p.families().nth(1).is_some()
            && let Ok((family, evidence)) =
                super::detect(&mut port.link, &port.name, address, port.connect.latency)
            && family.bus() == p
        {
            return Ok(Resolved {
                choice: SchemaChoice {
                    schema: self.builtin(family)?,
                    path: None,
                },
                evidence: Some(evidence),
            });
        }
        if let Some(choice) = self.chosen(ask)? {
            return Ok(Resolved {
                choice,
                evidence: None,
            });
        }
        let (family, evidence) =
            super::detect(&mut port.link, &port.name, address, port.connect.latency)?;
        Ok(Resolved {
            choice: SchemaChoice {
                schema: self.builtin(family)?,
                path: None,
            },
            evidence: Some(evidence),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::journal::{Journal, SchemaSource};

    #[test]
    fn an_address_change_without_its_schema_learns_the_types_unless_one_is_named() {
        let mut j: Journal = serde_json::from_str(include_str!(
            "../../tests/data/journals/tmd-failed-upload.journal.json"
        ))
        .expect("journal");
        let c = Catalog::new(&[]);
        let found = c.for_address_journal(None, &j).expect("by id");
        assert_eq!(found.map(|c| c.schema.id.clone()), Some(j.schema.clone()));
        assert_eq!(
            c.for_journal_of(None, &j).expect("by id").schema.id,
            j.schema
        );
        j.schema = "gone-since".into();
        j.schema_source = SchemaSource::default();
        assert!(c.for_address_journal(None, &j).expect("learned").is_none());
        assert!(c.for_journal_of(None, &j).is_err());
        assert!(c.for_address_journal(Some("no-such-schema"), &j).is_err());
        let named = c.for_address_journal(Some("lenze-tmd"), &j).expect("named");
        assert_eq!(named.map(|c| c.schema.id.clone()), Some("lenze-tmd".into()));
    }
}
