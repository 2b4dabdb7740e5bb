//! `driveset status LINE`: the read-only drift check of a machine line.

use std::path::PathBuf;

use crate::line::{Common, STATUS, run_mode};

/// Arguments of `driveset status`.
#[derive(clap::Args)]
#[command(after_help = "\
For every selected drive: identify it, read the codes its set names, compare
the live fingerprint with the set's and print the semantic differences.
Nothing is written and the commissioning state is not touched. Writes
report.json + report.html (command \"status\") into the report directory.
A drive with an unfinished journal in the journal directory (the manifest's
journal_dir, default .driveset/journal) is reported `failed` (its values are
not trusted): run `driveset commission` (it recovers it) or `driveset recover`.

Sets naming a built-in LUSTBUS schema that lacks facts: the schema is
learned from the drive's descriptions as `commission` learns it, but
read-only: descriptions only (ENQUIRY; no substitution texts, whose reading
selects them by writing the RAM selector 108-STEXT). The file a commission
run wrote for the same descriptions (in --schema-dir, default the report
directory) is used when there is one; status writes no schema file.

Exit codes: 0 every selected drive holds its set; 1 a drive differs (drift),
was refused or has an unfinished journal; 2 usage error or a manifest with findings; 3 a bus could not
be opened, a link failed or a drive did not answer.

Examples:
  driveset status parameter-sets/demo-line/line.toml
  driveset status line.toml --only transfer")]
pub struct Args {
    /// The line manifest (TOML or YAML).
    #[arg(value_name = "LINE")]
    pub manifest: PathBuf,
    /// Only these drives (names; a bus name selects its drives).
    #[arg(long, value_name = "NAME,..", value_delimiter = ',')]
    pub only: Vec<String>,
    /// Leave these drives (or buses) out.
    #[arg(long, value_name = "NAME,..", value_delimiter = ',')]
    pub skip: Vec<String>,
    /// Label written into the report.
    #[arg(long, value_name = "TEXT")]
    pub label: Option<String>,
    /// Where report.json and report.html go.
    #[arg(long, value_name = "DIR")]
    pub report_dir: Option<PathBuf>,
    /// Learning the schema of drives whose set's schema lacks facts.
    #[command(flatten)]
    pub learn: crate::port_args::LearnArgs,
}

/// Run `driveset status`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let c = Common {
        manifest: args.manifest,
        only: args.only,
        skip: args.skip,
        label: args.label,
        report_dir: args.report_dir,
        learn: args.learn,
        rehearse: None,
        allow_missing_twins: false,
        stop_after: None,
    };
    run_mode(c, STATUS, |_| {})
}
