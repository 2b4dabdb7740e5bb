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
use std::sync::Arc;

use driveset_schema::error::read_text_file;
use driveset_schema::schema::BUILTIN_FILES;
use driveset_schema::{InputError, Schema, check_schema};

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
        for (path, _) in BUILTIN_FILES {
            let id = path
                .rsplit('/')
                .next()
                .and_then(|f| f.strip_suffix(".toml"))
                .unwrap_or(path);
            let fr = match registry.get(id) {
                Some(s) => FileReport {
                    findings: check_schema(&s),
                    error: None,
                },
                None => FileReport {
                    findings: Vec::new(),
                    error: Some(InputError {
                        kind: driveset_schema::InputErrorKind::Structure,
                        message: format!("built-in schema {path} has no id `{id}`"),
                        help: "the file name and the id of a built-in schema agree".into(),
                        location: Box::new(driveset_schema::Location::file_only(path)),
                    }),
                },
            };
            report.files.push((path.to_string(), fr));
        }
    } else {
        let mut files = Vec::new();
        for p in &args.files {
            if p.is_dir() {
                let mut found = Vec::new();
                if let Err(e) = driveset_schema::walk::collect(p, &mut found) {
                    report.files.push((
                        p.display().to_string(),
                        FileReport {
                            findings: Vec::new(),
                            error: Some(e),
                        },
                    ));
                }
                files.extend(
                    found
                        .into_iter()
                        .filter(|f| f.extension().is_some_and(|e| e == "toml")),
                );
            } else {
                files.push(p.clone());
            }
        }
        check_files(&files, &registry, &mut report);
    }
    output::emit(&output::render_report(
        &report,
        args.format,
        ("schema file", "schema files"),
    ));
    Ok(output::report_exit_code(report.verdict()))
}

/// Check files in order; a fixture whose base comes later is retried after it.
fn check_files(files: &[PathBuf], registry: &driveset_schema::Registry, report: &mut Report) {
    let mut loaded: Vec<Arc<Schema>> = Vec::new();
    let mut results: Vec<Option<FileReport>> = files.iter().map(|_| None).collect();
    let mut pending: Vec<usize> = (0..files.len()).collect();
    loop {
        let mut retry = Vec::new();
        let before = pending.len();
        for &i in &pending {
            let path = &files[i];
            let fr = match read_text_file(path) {
                Err(e) => FileReport {
                    findings: Vec::new(),
                    error: Some(e),
                },
                Ok(source) => {
                    match driveset_schema::check::check_schema_source(source, registry, &loaded) {
                        Ok((s, findings)) => {
                            loaded.push(s);
                            FileReport {
                                findings,
                                error: None,
                            }
                        }
                        Err(e) => {
                            let unknown_base = e.message.starts_with("base schema `")
                                && e.message.ends_with("` is not known");
                            if unknown_base {
                                retry.push(i);
                            }
                            FileReport {
                                findings: Vec::new(),
                                error: Some(e),
                            }
                        }
                    }
                }
            };
            results[i] = Some(fr);
        }
        if retry.is_empty() || retry.len() == before {
            break;
        }
        pending = retry;
    }
    for (path, r) in files.iter().zip(results) {
        report
            .files
            .push((path.display().to_string(), r.unwrap_or_default()));
    }
}
