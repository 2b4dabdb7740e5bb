//! `driveset schema json-schema SCHEMA [-o FILE]` and `--all -o DIR`: write
//! the JSON Schema of a schema's set files (`driveset_ide::json_schema`) for the
//! editors' TOML (taplo) and YAML (yaml-language-server) support.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_schema::{Registry, Schema};

use crate::fail::Fail;
use driveset_ide::json_schema::{every, json_schema};

/// Arguments of `driveset schema json-schema`.
#[derive(clap::Args)]
#[command(after_help = "\
SCHEMA is a schema id (lenze-tmd, lenze-ecs, lust-vf1000, lust-mc6000, or
one loaded with --schemas) or a schema file: a learned (`schema pull`) or
imported (`schema import`) one beside the sets. The JSON Schema (draft-07)
describes a set file of that schema for taplo (TOML) and yaml-language-server
(YAML): completion, hover and checks of every code. `driveset git-setup
--json-schemas DIR` associates them with the repository's sets.

Exit codes: 0 written, 2 unknown schema, unreadable schema file or output.

Examples:
  driveset schema json-schema lenze-tmd -o .driveset/lenze-tmd.schema.json
  driveset schema json-schema parameter-sets/mc6000/learned.toml
  driveset schema json-schema --all -o .driveset/")]
pub struct Args {
    /// Schema id or schema file.
    #[arg(
        value_name = "SCHEMA",
        required_unless_present = "all",
        conflicts_with = "all"
    )]
    pub schema: Option<String>,
    /// Write one JSON Schema per known schema, `ID.schema.json`, into the directory -o names.
    #[arg(long, requires = "output")]
    pub all: bool,
    /// Output file (a directory with --all; default: stdout).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// A schema by id, else a schema file by path.
pub fn lookup(registry: &mut Registry, name: &str) -> Result<Arc<Schema>, Fail> {
    if let Some(s) = registry.get(name) {
        return Ok(s);
    }
    let path = Path::new(name);
    if path.exists() {
        return registry.load_file(path).map_err(|e| Fail::from(&e));
    }
    let ids: Vec<String> = registry.schemas().map(|s| s.id.clone()).collect();
    Err(Fail::input(format!(
        "unknown schema `{name}`: neither a known id ({}) nor a file",
        ids.join(", ")
    )))
}

fn write(path: &Path, text: &str) -> Result<(), Fail> {
    crate::files::write_output("", path, text.as_bytes())
}

/// Run `driveset schema json-schema`.
pub fn run(args: Args) -> Result<u8, Fail> {
    let mut registry = crate::output::registry(&args.schemas).map_err(|e| Fail::from(&e))?;
    if args.all {
        let dir = args.output.unwrap_or_default();
        std::fs::create_dir_all(&dir)
            .map_err(|e| Fail::input(format!("cannot create {}: {e}", dir.display())))?;
        for (name, text) in every(&registry) {
            let path = dir.join(name);
            write(&path, &text)?;
            eprintln!("wrote {}", path.display());
        }
        return Ok(crate::EXIT_OK);
    }
    let name = args.schema.unwrap_or_default();
    let schema = lookup(&mut registry, &name)?;
    let text = json_schema(&schema);
    match &args.output {
        Some(p) => write(p, &text)?,
        None => crate::output::emit(&text),
    }
    Ok(crate::EXIT_OK)
}
