//! Reports for reviewers, browsers and CI, as a library: the report of a
//! line run (`report.json`, the engine's [`LineReport`] as serde writes
//! it and [`read_report`] reads back, and a self-contained `report.html`,
//! [`html`]), JUnit XML of
//! validation findings and of a rehearsal ([`junit`], docs/ci.md) and the
//! line-oriented semantic view of a set file that `git diff` shows through
//! the `driveset` textconv driver ([`textconv`], docs/file-formats.md)
//! and the driver's `.gitattributes` lines and command ([`driver`]),
//! the validation report of `validate` and `schema check` for people, as
//! JSON and as GitHub annotations ([`validation`], docs/ci.md) and the
//! colours rendered text takes ([`style`]); the semantic diff of two sets
//! as `driveset diff` prints it ([`diff`]); a line run on the terminal,
//! its progress lines and summary table ([`mod@line`]); what long bus
//! work's phases show as on the terminal ([`progress`]); what `schema
//! import` says of a data sheet it imported or refused ([`import`]).
//! Files are written through the one writer (`driveset_schema::output`);
//! git is the caller's to run (the textconv view takes the tracked files
//! as data, the report its [`GitInfo`] from the engine's environment).

pub mod diff;
pub mod driver;
pub mod html;
pub mod import;
pub mod junit;
pub mod line;
pub mod progress;
pub mod style;
pub mod textconv;
pub mod validation;

use std::io;
use std::path::{Path, PathBuf};

use driveset_schema::InputError;

pub use driveset_engine::line::report::{GitInfo, LineReport};

/// File name of the machine-readable report.
pub const JSON_NAME: &str = "report.json";
/// File name of the HTML report.
pub const HTML_NAME: &str = "report.html";

/// What run a line report is of; its HTML title says so.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Run {
    /// A commissioning or status run on the drives.
    Commissioning,
    /// A rehearsal against twins (`commission --rehearse`, docs/twins.md).
    Rehearsal,
}

/// Why a saved report cannot be read back ([`read_report`]).
#[derive(Debug)]
pub enum ReadReportError {
    /// The file cannot be read (the one reader's refusal).
    Input(InputError),
    /// Its text is not a line report.
    NotAReport(serde_json::Error),
}

impl std::fmt::Display for ReadReportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadReportError::Input(e) => write!(f, "{}; {}", e.message, e.help),
            ReadReportError::NotAReport(e) => write!(f, "not a line report: {e}"),
        }
    }
}

impl std::error::Error for ReadReportError {}

/// Read a `report.json` written before (the hidden `driveset report`
/// renders it again) through the one reader
/// (`driveset_schema::input`, as a report: regular file, size checked).
pub fn read_report(path: &Path) -> Result<LineReport, ReadReportError> {
    let bytes = driveset_schema::input::read_input(path, driveset_schema::input::InputKind::REPORT)
        .map_err(ReadReportError::Input)?;
    serde_json::from_str(&String::from_utf8_lossy(&bytes)).map_err(ReadReportError::NotAReport)
}

/// Write `report.json` (the serde form of `report`) and `report.html` (a
/// self-contained page: inline CSS and SVG, no scripts, no external assets)
/// into `dir`, creating it if needed. Each file is written to a temporary
/// name and renamed into place, so a reader never sees half a report.
/// Returns the paths of the JSON and the HTML file.
pub fn write_reports(report: &LineReport, dir: &Path, run: Run) -> io::Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir)?;
    let mut json = serde_json::to_string_pretty(report).map_err(io::Error::other)?;
    json.push('\n');
    let json_path = dir.join(JSON_NAME);
    write_atomic(&json_path, json.as_bytes())?;
    let html_path = dir.join(HTML_NAME);
    write_atomic(&html_path, html::render(report, run).as_bytes())?;
    Ok((json_path, html_path))
}

/// Write `bytes` to `path` through the one writer
/// (`driveset_schema::output`: temporary name, fsync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    driveset_schema::output::write_output(path, bytes)
        .map_err(|e| io::Error::other(format!("{}; {}", e.message, e.help)))
}
