//! `driveset fingerprint FILE...`: the sha256 fingerprint of each set's
//! canonical form (docs/file-formats.md, "Canonical form and fingerprint").

use std::path::PathBuf;

use crate::output;

/// Arguments of `driveset fingerprint`.
#[derive(clap::Args)]
#[command(after_help = "\
Prints one line per set: `sha256:<hex>  FILE`. The fingerprint covers the
schema id and every raw value after `extends` is merged; the same set as
TOML, YAML or JSON has the same fingerprint.

Exit codes: 0 ok, 2 a file could not be read or the set has findings (run
`driveset validate` on it).

Example:
  driveset fingerprint parameter-sets/tmd/conveyor-3.toml")]
pub struct Args {
    /// Set files.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// Run `driveset fingerprint`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let mut registry = match output::registry(&args.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    let mut code = crate::EXIT_OK;
    for f in &args.files {
        match output::load_valid_set(f, &mut registry) {
            Ok(l) => {
                if let Some(set) = &l.resolved {
                    output::emit(&format!("{}  {}\n", set.fingerprint(), f.display()));
                }
            }
            Err(c) => code = code.max(c),
        }
    }
    Ok(code)
}
