//! `driveset diff A B`: semantic diff of two parameter sets of one drive
//! family (engineering units and labels), or of one set against the schema's
//! factory defaults (`--defaults`), or a unified text diff of the canonical
//! forms (`--unified`). A set against a live drive (`--port`) is `live`.

pub mod live;

use std::path::PathBuf;

use driveset_schema::Schema;
use driveset_schema::diff::Compared;

use crate::fail::Fail;
use crate::output::{self, OutputFormat};
use crate::port_args::{LearnFlags, Need, Port, PortCommand, Takes};

/// Arguments of `driveset diff`.
#[derive(clap::Args)]
#[command(after_help = "\
Lines start with `+` (only in B), `-` (only in A) or `~` (in both, changed)
and show values in engineering units with labels; a password never shows
its value: a differing one is `differs (secret)` (--unified: `<secret: old
value>` / `<secret: new value>`). With --defaults, old values are the
schema's factory defaults (`(no factory default known)` where the schema
gives none).

Exit codes: 0 same, 1 different, 2 error (unreadable or invalid set, sets of
different schemas, usage); with --port also 3 (bus or device failure).

Examples:
  driveset diff parameter-sets/tmd/base.toml parameter-sets/tmd/conveyor-3.toml
  driveset diff --defaults parameter-sets/tmd/conveyor-3.toml
  driveset diff --unified A.toml B.yaml
  driveset diff parameter-sets/mc6000/axis-1.toml --port sim://mc6000?addresses=1 --address 1")]
pub struct Args {
    /// The old set (with --defaults: the set to compare with factory defaults).
    #[arg(value_name = "A")]
    pub a: PathBuf,
    /// The new set.
    #[arg(
        value_name = "B",
        required_unless_present_any = ["defaults", "port"],
        conflicts_with_all = ["defaults", "port"]
    )]
    pub b: Option<PathBuf>,
    /// The live drive to compare A with (`--port` and `--address`; see
    /// `live`), the schema directories and, with --port, learning the
    /// schema from the drive where the set's lacks facts.
    #[command(flatten)]
    pub at: Port<Args>,
    /// Compare A with the factory defaults of its schema.
    #[arg(long, conflicts_with = "port")]
    pub defaults: bool,
    /// Unified text diff of the canonical forms (raw values) instead.
    #[arg(long, conflicts_with_all = ["format", "port"])]
    pub unified: bool,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::DIFF_FORMATS), default_value = "human")]
    pub format: OutputFormat,
    /// With --port: the transfer rate (the switch is journaled in
    /// .driveset/journal/<bus>-<address>.journal.json).
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    #[command(flatten)]
    pub transfer: crate::allow::TransferArgs,
}

/// `diff`'s port arguments (for `live`).
pub type DiffPort = Port<Args>;

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Optional,
        port_help: "Compare A with the live drive at this port (needs --address; see `diff_live`).",
        address: Need::Optional,
        address_help: "Bus address of the drive for --port.",
        together: true,
        schemas: true,
        allow_family: true,
        learn: LearnFlags::All,
        ..Takes::NONE
    };
}

/// Run `driveset diff`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    if let (Some(_), Some(address)) = (&args.at.port, args.at.address) {
        return live::run(live::LiveArgs {
            set: &args.a,
            at: &args.at,
            address,
            format: args.format,
            transfer: args.transfer,
        });
    }
    let mut registry = match output::registry(&args.at.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    let a = match output::load_valid_set(&args.a, &mut registry) {
        Ok(l) => l,
        Err(code) => return Err(crate::fail::Fail::reported(code)),
    };
    let (Some(schema), Some(set_a)) = (a.schema.clone(), a.resolved.as_ref()) else {
        return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
    };
    let b = match &args.b {
        None => None,
        Some(bp) => {
            let b = match output::load_valid_set(bp, &mut registry) {
                Ok(l) => l,
                Err(code) => return Err(Fail::reported(code)),
            };
            let Some(set_b) = b.resolved else {
                return Err(Fail::reported(crate::EXIT_INPUT));
            };
            Some((set_b, bp.display().to_string()))
        }
    };
    let a_name = args.a.display().to_string();
    let sides = Compared::of(set_a, a_name.clone(), b, &schema).map_err(|e| {
        eprintln!(
            "{}",
            output::stderr_style().error(&format!(
                "error: cannot diff sets of different schemas: {a_name} is `{}`, {} is `{}`",
                e.a,
                args.b.as_deref().unwrap_or(&args.a).display(),
                e.b
            ))
        );
        eprintln!("  = help: compare sets of one drive family");
        Fail::reported(crate::EXIT_INPUT)
    })?;
    if args.unified {
        let text = sides.unified(&schema);
        output::emit(&driveset_report::diff::unified(
            &text,
            output::stdout_style(),
        ));
        return Ok(if text.is_empty() {
            crate::EXIT_OK
        } else {
            crate::EXIT_FINDINGS
        });
    }
    let d = sides.diff(&schema).map_err(|e| {
        eprintln!("{}", output::stderr_style().error(&format!("error: {e}")));
        Fail::reported(crate::EXIT_INPUT)
    })?;
    Ok(render(
        &d,
        &schema,
        &sides.old_name,
        &sides.new_name,
        args.format == OutputFormat::Json,
    ))
}

/// Print a semantic diff, as human lines (`~`/`+`/`-` and a summary) or one
/// JSON document ([`driveset_report::diff`]), and return the exit code: 0
/// same, 1 different. The offline diff and `diff SET --port`
/// (cmd/diff/live.rs) share it, so both print the same thing.
pub(crate) fn render(
    d: &driveset_schema::Diff,
    schema: &Schema,
    old_name: &str,
    new_name: &str,
    json_out: bool,
) -> u8 {
    let sides = driveset_report::diff::Sides {
        old: old_name,
        new: new_name,
    };
    output::emit(&if json_out {
        driveset_report::diff::json(d, schema, sides)
    } else {
        driveset_report::diff::human(d, sides, output::stdout_style())
    });
    if d.is_empty() {
        crate::EXIT_OK
    } else {
        crate::EXIT_FINDINGS
    }
}
