//! The hidden `driveset report` (render a saved report.json again) and
//! the CLI's side of the reports, which are `driveset-report`'s: which run
//! a line report is of (a rehearsal's command is the twin bridge's).

use std::path::{Path, PathBuf};

use driveset_report::ReadReportError;
pub use driveset_report::{HTML_NAME, JSON_NAME, LineReport, Run, write_atomic};

/// Arguments of the hidden `driveset report` (render a saved report again).
#[derive(clap::Args)]
pub struct Args {
    /// A report.json written by `driveset commission` / `status`.
    #[arg(value_name = "REPORT_JSON")]
    pub input: PathBuf,
    /// Folder to write report.json and report.html into [default: the input's folder].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Run `driveset report`: read a report.json, write report.json + report.html.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let report = match driveset_report::read_report(&args.input) {
        Ok(r) => r,
        Err(ReadReportError::Input(e)) => {
            return Err(crate::fail::Fail::input(format!(
                "{}\n  = help: {}",
                e.message, e.help
            )));
        }
        Err(ReadReportError::NotAReport(e)) => {
            return Err(crate::fail::Fail::input(format!(
                "{}: not a line report: {e}\n  = help: give the report.json that `driveset commission` wrote",
                args.input.display()
            )));
        }
    };
    let dir = args.out.clone().unwrap_or_else(|| {
        args.input
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    });
    let (json, html) = write_reports(&report, &dir)?;
    outln!("{}\n{}", json.display(), html.display());
    Ok(crate::EXIT_OK)
}

/// Write `report.json` and `report.html` into `dir`
/// ([`driveset_report::write_reports`]); a rehearsal's report (its command
/// the twin bridge's [`driveset_twin::REHEARSE_COMMAND`]) is titled as one.
pub fn write_reports(report: &LineReport, dir: &Path) -> std::io::Result<(PathBuf, PathBuf)> {
    let run = if report.command == driveset_twin::REHEARSE_COMMAND {
        Run::Rehearsal
    } else {
        Run::Commissioning
    };
    driveset_report::write_reports(report, dir, run)
}
