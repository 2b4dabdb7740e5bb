//! `driveset show FILE [--to toml|yaml|json]`: a set in canonical form, or
//! converted to another syntax (engineering values with labels, `extends`
//! merged). Converting never changes the fingerprint.

use std::path::PathBuf;

use driveset_schema::{Format, export};

use crate::output;

/// Target syntax of `show --to`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum To {
    /// TOML set file.
    Toml,
    /// YAML set file.
    Yaml,
    /// JSON set file (read back by driveset as YAML; save it as *.json).
    Json,
}

/// Arguments of `driveset show`.
#[derive(clap::Args)]
#[command(after_help = "\
Without --to, prints the canonical form the fingerprint is computed from
(`driveset-canonical 1`, `schema <id>`, one `CODE raw` line per value).

With --to, prints the set in that syntax: `extends` merged, values in
engineering units with labels, the schema named by its id. A set whose schema
was loaded from a file (a fixture) names that schema's id, so reading the
converted file elsewhere needs `--schemas DIR` with that schema file.

Exit codes: 0 ok, 2 the file could not be read or the set has findings.

Examples:
  driveset show parameter-sets/tmd/conveyor-3.toml
  driveset show --to yaml parameter-sets/tmd/conveyor-3.toml > conveyor-3.yaml")]
pub struct Args {
    /// Set file.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Convert to this syntax instead of printing the canonical form.
    #[arg(long, value_enum)]
    pub to: Option<To>,
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// Run `driveset show`.
pub fn run(args: Args) -> anyhow::Result<u8> {
    let mut registry = match output::registry(&args.schemas) {
        Ok(r) => r,
        Err(e) => return Ok(output::fail_input(&e)),
    };
    let loaded = match output::load_valid_set(&args.file, &mut registry) {
        Ok(l) => l,
        Err(code) => return Ok(code),
    };
    let (Some(schema), Some(set)) = (&loaded.schema, &loaded.resolved) else {
        return Ok(crate::EXIT_INPUT);
    };
    let text = match args.to {
        None => set.canonical(),
        Some(to) => {
            let format = match to {
                To::Toml => Format::Toml,
                To::Yaml => Format::Yaml,
                To::Json => Format::Json,
            };
            export(set, schema, loaded.title.as_deref(), format)
        }
    };
    output::emit(&text);
    Ok(crate::EXIT_OK)
}
