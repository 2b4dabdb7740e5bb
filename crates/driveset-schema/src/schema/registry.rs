//! The [`Registry`] of known schemas: the built-in files (one per drive
//! family), files loaded by path or directory, and schemas withheld with
//! the reason (a schema file that failed to load); the schema an offline
//! command's `--schema ID_OR_PATH` names ([`Registry::id_or_file`]).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{InputError, InputErrorKind, Location, SourceFile, read_text_file};

use super::{Schema, parse_schema};

/// The schema file names embedded in the crate (docs: "one file per drive family").
pub const BUILTIN_FILES: [(&str, &str); 4] = [
    (
        "schemas/lenze-tmd.toml",
        include_str!("../../../../schemas/lenze-tmd.toml"),
    ),
    (
        "schemas/lenze-ecs.toml",
        include_str!("../../../../schemas/lenze-ecs.toml"),
    ),
    (
        "schemas/lust-vf1000.toml",
        include_str!("../../../../schemas/lust-vf1000.toml"),
    ),
    (
        "schemas/lust-mc6000.toml",
        include_str!("../../../../schemas/lust-mc6000.toml"),
    ),
];

/// Known schemas by id: the built-ins plus files loaded by path or directory.
#[derive(Debug, Clone, Default)]
pub struct Registry {
    schemas: BTreeMap<String, Arc<Schema>>,
    by_path: HashMap<PathBuf, String>,
    /// The source text each schema was parsed from, by id: the same file
    /// reached twice (embedded and on disk, or by two relative paths) is one
    /// schema, not a clash.
    texts: HashMap<String, Arc<str>>,
    /// Schema ids a set may not name by id, with the file that holds each
    /// (the simulator's fictional fixtures): see [`Registry::withhold`].
    withheld: BTreeMap<String, String>,
}

impl Registry {
    /// Withhold `id` from sets that name it by id: such a set gets a
    /// finding that names `file`, where the schema is (the simulator's
    /// fictional fixture schemas, which belong to the simulator and the
    /// examples, not to a user's registry). A schema of that id added
    /// later (`--schemas DIR`, a set naming the file) is known as usual.
    ///
    /// `text` is the fixture's own text: a schema of that id with any other
    /// text is refused when added ([`Registry::add_source`]), so no file
    /// (`--schemas DIR`, a set naming a file) can take a fixture's id and
    /// give its codes other facts.
    pub fn withhold(&mut self, id: &str, file: &str, text: &str) {
        self.withheld.insert(id.to_string(), file.to_string());
        self.texts.insert(id.to_string(), Arc::from(text));
    }

    /// The file of a withheld schema id ([`Registry::withhold`]).
    pub fn withheld(&self, id: &str) -> Option<&str> {
        self.withheld.get(id).map(String::as_str)
    }

    /// An empty registry.
    pub fn new() -> Self {
        Registry::default()
    }

    /// The four built-in schemas (`schemas/*.toml`, embedded at build time).
    pub fn builtin() -> Result<Self, InputError> {
        let mut r = Registry::new();
        for (path, text) in BUILTIN_FILES {
            r.add_source(SourceFile::new(path, text))?;
        }
        Ok(r)
    }

    /// Add a schema from text (`extends` resolves against schemas already here).
    /// A second schema with an id already known is an error.
    pub fn add_source(&mut self, source: SourceFile) -> Result<Arc<Schema>, InputError> {
        let text = source.text.clone();
        let schema = {
            let lookup = |id: &str| self.schemas.get(id).cloned();
            parse_schema(source, &lookup)?
        };
        if let (Some(file), None) = (self.withheld.get(&schema.id), self.schemas.get(&schema.id))
            && self.texts.get(&schema.id).is_some_and(|t| **t != *text)
        {
            return Err(InputError::new(
                InputErrorKind::Structure,
                schema.id_loc.clone(),
                format!(
                    "schema id `{}` is the id of the simulator's fixture schema {file}",
                    schema.id
                ),
                "give each schema file its own id (a schema file cannot reuse a built-in or fixture id)",
            ));
        }
        if let Some(prev) = self.schemas.get(&schema.id) {
            if self.texts.get(&schema.id).is_some_and(|t| **t == *text) {
                return Ok(prev.clone());
            }
            return Err(InputError::new(
                InputErrorKind::Structure,
                schema.id_loc.clone(),
                format!(
                    "schema id `{}` is already defined by {}",
                    schema.id, prev.path
                ),
                "give each schema file its own id (a schema file cannot reuse a built-in or fixture id)",
            ));
        }
        let schema = Arc::new(schema);
        self.schemas.insert(schema.id.clone(), schema.clone());
        self.texts.insert(schema.id.clone(), text);
        Ok(schema)
    }

    /// Make `id` name `schema` (replacing what it named): a set naming a
    /// built-in schema is then resolved against a schema learned from the
    /// drive that extends it (driveset-engine's `learn`).
    pub fn insert_as(&mut self, id: &str, schema: Arc<Schema>) {
        self.schemas.insert(id.to_string(), schema);
        self.texts.remove(id);
    }

    /// Load a schema file by path (cached: loading the same file twice returns the first).
    pub fn load_file(&mut self, path: &Path) -> Result<Arc<Schema>, InputError> {
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some(s) = self.by_path.get(&key).and_then(|id| self.schemas.get(id)) {
            return Ok(s.clone());
        }
        let source = read_text_file(path)?;
        let s = self.add_source(source)?;
        self.by_path.insert(key, s.id.clone());
        Ok(s)
    }

    /// Load every `*.toml` of a directory (sorted by name; fixtures whose base
    /// is in the same directory load after it).
    pub fn load_dir(&mut self, dir: &Path) -> Result<Vec<Arc<Schema>>, InputError> {
        let rd = std::fs::read_dir(dir).map_err(|e| {
            InputError::new(
                InputErrorKind::Unreadable,
                Location::file_only(dir.display().to_string()),
                format!("cannot read directory {}: {e}", dir.display()),
                "check the path",
            )
        })?;
        let mut paths: Vec<PathBuf> = rd
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        let mut out = Vec::new();
        let mut pending = paths;
        // retry files whose base is not loaded yet, as long as progress is made
        loop {
            let mut next = Vec::new();
            let mut last_err = None;
            let before = pending.len();
            for p in pending {
                match self.load_file(&p) {
                    Ok(s) => out.push(s),
                    Err(e) => {
                        last_err = Some(e);
                        next.push(p);
                    }
                }
            }
            if next.is_empty() {
                return Ok(out);
            }
            if next.len() == before {
                return Err(last_err.unwrap_or_else(|| {
                    InputError::new(
                        InputErrorKind::Structure,
                        Location::file_only(dir.display().to_string()),
                        "cannot load schemas",
                        "",
                    )
                }));
            }
            pending = next;
        }
    }

    /// Schema by id.
    pub fn get(&self, id: &str) -> Option<Arc<Schema>> {
        self.schemas.get(id).cloned()
    }

    /// The schema `--schema ID_OR_PATH` names for the commands that read no
    /// drive (`decode`, `encode`, `twin from-capture`): a known id first,
    /// else a schema file.
    ///
    /// # Errors
    /// [`NamedSchemaError`]: neither a known id nor a file, or a file that
    /// does not load.
    pub fn id_or_file(&mut self, arg: &str) -> Result<Arc<Schema>, NamedSchemaError> {
        if let Some(s) = self.get(arg) {
            return Ok(s);
        }
        let path = Path::new(arg);
        if !path.exists() {
            return Err(NamedSchemaError::NoSuch {
                arg: arg.to_string(),
                ids: self.schemas().map(|s| s.id.clone()).collect(),
            });
        }
        self.load_file(path).map_err(|e| NamedSchemaError::Load {
            arg: arg.to_string(),
            detail: e.render_human(),
        })
    }

    /// All schemas, by id.
    pub fn schemas(&self) -> impl Iterator<Item = &Arc<Schema>> {
        self.schemas.values()
    }
}

/// Why `--schema ID_OR_PATH` names no schema ([`Registry::id_or_file`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NamedSchemaError {
    /// Neither a known id nor an existing file.
    #[error(
        "--schema {arg}: no built-in schema has that id and no such file exists; built-in ids: {}",
        ids.join(", ")
    )]
    NoSuch {
        /// What was given.
        arg: String,
        /// The ids known.
        ids: Vec<String>,
    },
    /// The file does not load (the input error rendered).
    #[error("--schema {arg}: cannot load the schema file: {detail}")]
    Load {
        /// What was given.
        arg: String,
        /// The input error, rendered for people.
        detail: String,
    },
}
