//! `driveset show FILE [--to toml|yaml|json|dcf]`: a set in canonical form,
//! or converted to another syntax (engineering values with labels, `extends`
//! merged; converting never changes the fingerprint), or written as a CiA
//! 306 DCF for CANopen masters (Lenze ECS sets only; driveset_schema::eds).

use std::path::PathBuf;

use driveset_schema::Format;
use driveset_schema::export::{self, Shown};

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
    /// CiA 306 device configuration file (Lenze ECS sets only).
    Dcf,
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

With --to dcf (Lenze ECS sets: schema protocol lenze-can-sdo), prints a CiA
306 DCF: one object section per value (index 24575 - code, or the `index` of
a CiA 301 object), the set's raw value as ParameterValue (FIX32 = value x
10000), the schema's default and limits; --node-id fills
[DeviceComissioning] NodeID. Password codes are written without a value.
Sets of other families are refused (exit 2).

Exit codes: 0 ok, 2 the file could not be read, the set has findings, or
--to dcf was asked of a set that is not a CANopen family.

Examples:
  driveset show parameter-sets/tmd/conveyor-3.toml
  driveset show --to yaml parameter-sets/tmd/conveyor-3.toml > conveyor-3.yaml
  driveset show --to dcf --node-id 1 parameter-sets/ecs/axis-1.toml > axis-1.dcf")]
pub struct Args {
    /// Set file.
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Convert to this syntax instead of printing the canonical form.
    #[arg(long, value_enum)]
    pub to: Option<To>,
    /// --to dcf: the node id written to [DeviceComissioning] NodeID (1..=127).
    #[allow(rustdoc::broken_intra_doc_links)] // clap's help text, printed as written
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node_id: Option<u8>,
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// Run `driveset show`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let mut registry = match output::registry(&args.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    let loaded = match output::load_valid_set(&args.file, &mut registry) {
        Ok(l) => l,
        Err(code) => return Err(crate::fail::Fail::reported(code)),
    };
    let (Some(schema), Some(set)) = (&loaded.schema, &loaded.resolved) else {
        return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
    };
    let shown = match args.to {
        None => Shown::Canonical,
        Some(To::Toml) => Shown::As(Format::Toml),
        Some(To::Yaml) => Shown::As(Format::Yaml),
        Some(To::Json) => Shown::As(Format::Json),
        Some(To::Dcf) => Shown::Dcf {
            node_id: args.node_id,
        },
    };
    let text =
        export::shown(set, schema, loaded.title.as_deref(), &args.file, shown).map_err(|e| {
            crate::fail::Fail::input(format!(
                "{}: cannot write a DCF: {}\n  = help: {}",
                args.file.display(),
                e.message,
                e.help
            ))
        })?;
    output::emit(&text);
    Ok(crate::EXIT_OK)
}
