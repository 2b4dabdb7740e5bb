//! `driveset validate PATH...`: check parameter sets against the schema of
//! their drive family, with no hardware. Directories are searched recursively
//! for `*.toml`, `*.yaml` and `*.yml`.
//!
//! Schema files met on the way (a TOML file with a top-level `[schema]`
//! table, e.g. the fixture schemas under `parameter-sets/fixtures/`) are not
//! sets: they are checked with the `schema check` rules instead, so a broken
//! fixture still fails the run, and counted as checked files.

use std::path::{Path, PathBuf};

use driveset_schema::Registry;
use driveset_schema::check::{Checked, check_set_or_schema};
use driveset_schema::walk::collect;

use driveset_report::validation::{FileReport, Report};

use crate::output::OutputFormat;

/// Arguments of `driveset validate`.
#[derive(clap::Args)]
#[command(after_help = "\
Every finding is printed with file:line:column and a source snippet, then one
summary line: `N findings in M of K files`.

Schema files found while walking directories (TOML files with a top-level
[schema] table, such as parameter-sets/fixtures/*.toml) are checked with the
`driveset schema check` rules instead of being read as sets.

Exit codes: 0 no findings, 1 findings, 2 a file could not be read or parsed
(malformed TOML/YAML, binary, empty, larger than 4 MiB, unknown top-level key,
NaN/inf, ...) or a usage error.

Examples:
  driveset validate parameter-sets/
  driveset validate --format github parameter-sets/
  driveset validate --schemas my-schemas/ line-2/*.toml")]
pub struct Args {
    /// Set files or directories (searched recursively for *.toml, *.yaml, *.yml).
    #[arg(required = true, value_name = "PATH")]
    pub paths: Vec<PathBuf>,
    /// Output format.
    #[arg(long, value_parser = crate::output::formats(crate::output::REPORT_FORMATS), default_value = "human")]
    pub format: OutputFormat,
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// Check one file: a line manifest by its own checks, a schema file by
/// `schema check`'s, anything else as a set.
fn check_file(path: &Path, registry: &mut Registry) -> Checked {
    // a line manifest (top-level [line] table or bus list): its own checks
    if driveset_engine::line::manifest::is_manifest(path) {
        return driveset_engine::line::manifest::validate_manifest(path, &crate::port::openers())
            .map(|f| f.iter().map(|f| f.to_finding()).collect());
    }
    check_set_or_schema(path, registry)
}

/// Run `driveset validate`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let mut registry = match crate::output::registry(&args.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    let mut report = Report::default();
    for p in &args.paths {
        let mut files = Vec::new();
        if let Err(e) = collect(p, &mut files) {
            report
                .files
                .push((p.display().to_string(), FileReport::of(Err(e))));
            continue;
        }
        for f in files {
            let r = FileReport::of(check_file(&f, &mut registry));
            report.files.push((f.display().to_string(), r));
        }
    }
    crate::output::emit(&crate::output::render_report(
        &report,
        args.format,
        ("file", "files"),
    ));
    Ok(crate::output::report_exit_code(report.verdict()))
}
