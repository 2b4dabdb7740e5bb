//! `driveset schema check [FILES...]`: validate schema files themselves
//! (docs/file-formats.md, "Schema files"): duplicate numbers and names,
//! unknown types, min/max/default the type cannot hold or outside the range,
//! enumeration values outside the type, bit fields outside the word or
//! overlapping, rules naming unknown codes, fixture marking and `extends`.
//! Its other subcommands are its own modules: `pull`, `import`,
//! `json_schema`.

pub mod import;
pub mod json_schema;
pub mod pull;

use std::path::PathBuf;

use driveset_schema::check::{check_builtin_schemas, check_schema_files};

use driveset_report::validation::{FileReport, Report};

use crate::output::{self, OutputFormat};

/// `driveset schema ...`.
#[derive(clap::Subcommand)]
pub enum SchemaCommand {
    /// Validate schema files (the four built-in schemas when no FILE is given).
    #[command(after_help = "\
Without FILE, checks the four built-in schemas (schemas/*.toml as built into
the binary). A directory stands for every *.toml in it. Fixture schemas may
`extends` a built-in schema or a schema given earlier on the command line.

Exit codes: 0 no findings, 1 findings, 2 a file could not be read or parsed.

Examples:
  driveset schema check
  driveset schema check parameter-sets/fixtures/")]
    Check(CheckArgs),
    /// Build a schema file from a LUSTBUS drive's own parameter descriptions.
    Pull(pull::Args),
    /// Build a Lenze ECS schema file from a CiA 306 EDS / DCF data sheet.
    Import(import::Args),
    /// Write the JSON Schema of a schema's set files, for the editors' TOML and YAML servers.
    JsonSchema(json_schema::Args),
}

/// Arguments of `driveset schema check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// Schema files or directories of schema files (default: the built-in schemas).
    #[arg(value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::REPORT_FORMATS), default_value = "human")]
    pub format: OutputFormat,
    /// Load every *.toml schema of DIR first, so fixtures can extend them (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// Run `driveset schema ...`.
pub fn run(cmd: SchemaCommand) -> Result<u8, crate::fail::Fail> {
    match cmd {
        SchemaCommand::Check(a) => check(a),
        SchemaCommand::Pull(a) => pull::run(a),
        SchemaCommand::Import(a) => import::run(a),
        SchemaCommand::JsonSchema(a) => json_schema::run(a),
    }
}

fn check(args: CheckArgs) -> Result<u8, crate::fail::Fail> {
    let registry = match output::registry(&args.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    let mut report = Report::default();
    if args.files.is_empty() {
        for (path, checked) in check_builtin_schemas(&registry) {
            report
                .files
                .push((path.to_string(), FileReport::of(checked)));
        }
    } else {
        let (files, failed) = driveset_schema::walk::schema_files(&args.files);
        for (p, e) in failed {
            report
                .files
                .push((p.display().to_string(), FileReport::of(Err(e))));
        }
        for (path, checked) in files.iter().zip(check_schema_files(&files, &registry)) {
            report
                .files
                .push((path.display().to_string(), FileReport::of(checked)));
        }
    }
    output::emit(&output::render_report(
        &report,
        args.format,
        ("schema file", "schema files"),
    ));
    Ok(output::report_exit_code(report.verdict()))
}
