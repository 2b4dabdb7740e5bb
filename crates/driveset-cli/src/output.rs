//! Shared rendering of findings and input errors for the offline commands
//! (`validate`, `schema check`, `diff`, `fingerprint`, `show`): human
//! (rustc-style with a source snippet, rendered by `annotate-snippets`
//! through the schema crate; colour only on a terminal and never with
//! `NO_COLOR`), JSON, and GitHub workflow annotations.

use std::fmt::Write;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use driveset_report::junit::FileFindings;
use driveset_schema::{Finding, InputError, Location};

/// The one output format type of every command's `--format`. Each command
/// accepts its own subset, with its own help per value, as one of the
/// lists below ([`formats`] makes clap check it): the values a command
/// takes and its help text are the ones it always had.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    /// Text for people (`human`).
    Human,
    /// Text for people (`text`: `replace`).
    Text,
    /// Aligned columns (`table`: the history).
    Table,
    /// JSON.
    Json,
    /// Comma-separated values.
    Csv,
    /// An HTML page.
    Html,
    /// GitHub workflow annotations.
    Github,
    /// JUnit XML.
    Junit,
}

impl OutputFormat {
    /// The value `--format` names it by.
    pub fn name(self) -> &'static str {
        match self {
            OutputFormat::Human => "human",
            OutputFormat::Text => "text",
            OutputFormat::Table => "table",
            OutputFormat::Json => "json",
            OutputFormat::Csv => "csv",
            OutputFormat::Html => "html",
            OutputFormat::Github => "github",
            OutputFormat::Junit => "junit",
        }
    }
}

/// The formats one command accepts: each with its help line.
pub type Formats = &'static [(OutputFormat, &'static str)];

/// The report commands' formats (`validate`, `schema check`).
pub const REPORT_FORMATS: Formats = &[
    (
        OutputFormat::Human,
        "rustc-style text with source snippets (colour on a terminal)",
    ),
    (OutputFormat::Json, "One JSON document on stdout"),
    (
        OutputFormat::Github,
        "GitHub workflow annotations (`::error file=..,line=..,col=..,title=..::message`)",
    ),
    (
        OutputFormat::Junit,
        "JUnit XML: a testsuite per file, a testcase per finding (GitLab, Jenkins)",
    ),
];

/// The bus commands' formats (`identify`, `scan`, `pull`, `upload`, ...).
pub const BUS_FORMATS: Formats = &[
    (OutputFormat::Human, "Text for humans"),
    (OutputFormat::Json, "One JSON document on stdout"),
];

/// `diff`'s formats.
pub const DIFF_FORMATS: Formats = &[
    (
        OutputFormat::Human,
        "One line per code: `~ C0011 max_output_frequency: 50 Hz -> 60 Hz`",
    ),
    (OutputFormat::Json, "One JSON document"),
];

/// `replace`'s formats.
pub const REPLACE_FORMATS: Formats = &[
    (OutputFormat::Text, "Human text"),
    (OutputFormat::Json, "One JSON object"),
];

/// `decode`'s formats.
pub const DECODE_FORMATS: Formats = &[
    (OutputFormat::Text, "One line per event, for people"),
    (OutputFormat::Json, "One JSON object per line per event"),
];

/// `history log`'s formats.
pub const LOG_FORMATS: Formats = &[
    (OutputFormat::Table, "Aligned columns"),
    (OutputFormat::Json, "A JSON array"),
    (OutputFormat::Csv, "Comma-separated values with a header"),
];

/// `history as-built`'s formats.
pub const BUILT_FORMATS: Formats = &[
    (OutputFormat::Table, "Text"),
    (OutputFormat::Json, "JSON"),
    (OutputFormat::Html, "An HTML page"),
];

/// The clap value parser of a command's `--format`: exactly the values of
/// `list`, each with its help (as a `ValueEnum` of them would list them).
pub fn formats(list: Formats) -> impl clap::builder::TypedValueParser<Value = OutputFormat> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        list.iter()
            .map(|(f, help)| PossibleValue::new(f.name()).help(*help)),
    )
    .map(move |name| {
        list.iter()
            .find(|(f, _)| f.name() == name)
            .map_or(OutputFormat::Human, |(f, _)| *f)
    })
}

/// One identity code a drive answered and its value, as the bus commands'
/// JSON documents list them (`identify`, `scan`).
#[derive(serde::Serialize)]
pub struct CodeValue<'a> {
    /// The code's name (`C0093`, `91-TYPE`).
    pub code: &'a str,
    /// Its value as text.
    pub value: String,
}

impl<'a> CodeValue<'a> {
    /// The code and value of an identity's code.
    pub fn of(c: &'a driveset_engine::client::IdentCode) -> Self {
        CodeValue {
            code: &c.name,
            value: c.value.to_string(),
        }
    }
}

/// Colour on or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Style {
    color: bool,
}

const RED: &str = "\x1b[1;31m";
const BOLD: &str = "\x1b[1m";
const GREEN: &str = "\x1b[32m";
const YELLOW: &str = "\x1b[33m";
const DIM_RED: &str = "\x1b[31m";
const RESET: &str = "\x1b[0m";

impl Style {
    /// No colour.
    #[cfg(test)]
    pub const PLAIN: Style = Style { color: false };

    /// Colour when stdout is a terminal and `NO_COLOR` is unset or empty.
    pub fn stdout() -> Style {
        Style {
            color: std::io::stdout().is_terminal() && no_color_unset(),
        }
    }

    /// Colour when stderr is a terminal and `NO_COLOR` is unset or empty.
    pub fn stderr() -> Style {
        Style {
            color: std::io::stderr().is_terminal() && no_color_unset(),
        }
    }

    fn paint(self, code: &str, text: &str) -> String {
        if self.color {
            format!("{code}{text}{RESET}")
        } else {
            text.to_string()
        }
    }

    /// Bold red.
    pub fn error(self, text: &str) -> String {
        self.paint(RED, text)
    }
    /// Bold.
    pub fn bold(self, text: &str) -> String {
        self.paint(BOLD, text)
    }
    /// Green (added lines).
    pub fn added(self, text: &str) -> String {
        self.paint(GREEN, text)
    }
    /// Red (removed lines).
    pub fn removed(self, text: &str) -> String {
        self.paint(DIM_RED, text)
    }
    /// Yellow (changed lines).
    pub fn changed(self, text: &str) -> String {
        self.paint(YELLOW, text)
    }
}

fn no_color_unset() -> bool {
    std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
}

/// `n thing` / `n things`.
pub fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// rustc-style finding, rendered by `annotate-snippets` (the schema
/// crate's [`Finding::render`]; colour on a terminal).
pub fn finding_human(f: &Finding, style: Style) -> String {
    f.render(if style.color {
        driveset_schema::error::Colour::Styled
    } else {
        driveset_schema::error::Colour::Plain
    })
}

/// rustc-style input error ([`InputError::render`]).
pub fn input_error_human(e: &InputError, style: Style) -> String {
    e.render(if style.color {
        driveset_schema::error::Colour::Styled
    } else {
        driveset_schema::error::Colour::Plain
    })
}

/// A line and column of a location; both `null` for a whole file.
fn line_column(loc: &Location) -> (Option<usize>, Option<usize>) {
    if loc.line == 0 {
        (None, None)
    } else {
        (Some(loc.line), Some(loc.column))
    }
}

/// A finding in the report commands' JSON: kind, message, help, file,
/// line, column, related places (keys in alphabetical order, as the
/// document always had them).
#[derive(serde::Serialize)]
pub struct FindingDoc<'a> {
    column: Option<usize>,
    file: &'a str,
    help: &'a str,
    kind: &'a str,
    line: Option<usize>,
    message: &'a str,
    related: Vec<RelatedDoc<'a>>,
    severity: &'static str,
}

/// Another place a finding names.
#[derive(serde::Serialize)]
struct RelatedDoc<'a> {
    column: Option<usize>,
    file: &'a str,
    label: &'a str,
    line: Option<usize>,
}

impl<'a> FindingDoc<'a> {
    /// The document of `f`.
    pub fn of(f: &'a Finding) -> Self {
        let (line, column) = line_column(&f.location);
        FindingDoc {
            column,
            file: &f.location.file,
            help: &f.help,
            kind: f.kind.as_str(),
            line,
            message: &f.message,
            related: f
                .related
                .iter()
                .map(|(label, loc)| {
                    let (line, column) = line_column(loc);
                    RelatedDoc {
                        column,
                        file: &loc.file,
                        label,
                        line,
                    }
                })
                .collect(),
            severity: "error",
        }
    }
}

/// An input error in the report commands' JSON: kind `input-error`,
/// message, help, file, line, column.
#[derive(serde::Serialize)]
pub struct InputErrorDoc<'a> {
    column: Option<usize>,
    file: &'a str,
    help: &'a str,
    kind: &'static str,
    line: Option<usize>,
    message: &'a str,
}

impl<'a> InputErrorDoc<'a> {
    /// The document of `e`.
    pub fn of(e: &'a InputError) -> Self {
        let (line, column) = line_column(&e.location);
        InputErrorDoc {
            column,
            file: &e.location.file,
            help: &e.help,
            kind: "input-error",
            line,
            message: &e.message,
        }
    }
}

/// The report commands' JSON document (`validate`, `schema check`).
#[derive(serde::Serialize)]
struct ReportDoc<'a> {
    exit_code: u8,
    files: Vec<FileDoc<'a>>,
    summary: SummaryDoc,
}

/// One file of the report.
#[derive(serde::Serialize)]
struct FileDoc<'a> {
    error: Option<InputErrorDoc<'a>>,
    file: &'a str,
    findings: Vec<FindingDoc<'a>>,
    ok: bool,
}

/// The report's counts and its summary line.
#[derive(serde::Serialize)]
struct SummaryDoc {
    files: usize,
    files_with_findings: usize,
    findings: usize,
    text: String,
    unreadable: usize,
}

/// Escape the message part of a workflow command.
fn gh_data(s: &str) -> String {
    s.replace('%', "%25")
        .replace('\r', "%0D")
        .replace('\n', "%0A")
}

/// Escape a property value of a workflow command.
fn gh_prop(s: &str) -> String {
    gh_data(s).replace(':', "%3A").replace(',', "%2C")
}

fn gh_line(loc: &Location, title: &str, message: &str, help: &str) -> String {
    let mut props = format!("file={}", gh_prop(&loc.file));
    if loc.line > 0 {
        let _ = write!(props, ",line={},col={}", loc.line, loc.column);
    }
    let _ = write!(props, ",title={}", gh_prop(title));
    let mut msg = message.to_string();
    if !help.is_empty() {
        let _ = write!(msg, "\nhelp: {help}");
    }
    format!("::error {props}::{}", gh_data(&msg))
}

/// A finding as one GitHub annotation line (title: the finding kind).
pub fn finding_github(f: &Finding) -> String {
    gh_line(&f.location, f.kind.as_str(), &f.message, &f.help)
}

/// An input error as one GitHub annotation line (title `input-error`).
pub fn input_error_github(e: &InputError) -> String {
    gh_line(&e.location, "input-error", &e.message, &e.help)
}

/// Findings and input errors of one file, collected for a report.
#[derive(Debug, Default)]
pub struct FileReport {
    /// Findings, in file order.
    pub findings: Vec<Finding>,
    /// The input error, when the file could not be read.
    pub error: Option<InputError>,
}

/// The report of `validate` / `schema check`: per-file findings and errors,
/// then one summary line (`N findings in M of K files`).
#[derive(Debug, Default)]
pub struct Report {
    /// Per file, in the order checked.
    pub files: Vec<(String, FileReport)>,
}

impl Report {
    /// Number of findings.
    pub fn findings(&self) -> usize {
        self.files.iter().map(|(_, r)| r.findings.len()).sum()
    }
    /// Files with at least one finding.
    pub fn files_with_findings(&self) -> usize {
        self.files
            .iter()
            .filter(|(_, r)| !r.findings.is_empty())
            .count()
    }
    /// Files that could not be read.
    pub fn errors(&self) -> usize {
        self.files.iter().filter(|(_, r)| r.error.is_some()).count()
    }

    /// Exit code: 2 when a file could not be read, 1 on findings, else 0.
    pub fn exit_code(&self) -> u8 {
        if self.errors() > 0 {
            crate::EXIT_INPUT
        } else if self.findings() > 0 {
            crate::EXIT_FINDINGS
        } else {
            crate::EXIT_OK
        }
    }

    /// `3 findings in 2 of 16 files` (+ `; 1 file could not be read`).
    pub fn summary(&self, noun: (&str, &str)) -> String {
        let mut s = format!(
            "{} in {} of {}",
            plural(self.findings(), "finding", "findings"),
            self.files_with_findings(),
            plural(self.files.len(), noun.0, noun.1)
        );
        if self.errors() > 0 {
            let _ = write!(
                s,
                "; {} could not be read",
                plural(self.errors(), noun.0, noun.1)
            );
        }
        s
    }

    /// The whole report in `format`; `noun` names the files ("file", "files").
    pub fn render(&self, format: OutputFormat, style: Style, noun: (&str, &str)) -> String {
        let mut out = String::new();
        match format {
            // the text forms (only `human` reaches a report)
            OutputFormat::Human
            | OutputFormat::Text
            | OutputFormat::Table
            | OutputFormat::Csv
            | OutputFormat::Html => {
                for (_, r) in &self.files {
                    if let Some(e) = &r.error {
                        out.push_str(&input_error_human(e, style));
                        out.push('\n');
                    }
                    for f in &r.findings {
                        out.push_str(&finding_human(f, style));
                        out.push('\n');
                    }
                }
                let summary = self.summary(noun);
                let summary = if self.exit_code() == crate::EXIT_OK {
                    style.bold(&summary)
                } else {
                    style.error(&summary)
                };
                let _ = writeln!(out, "{summary}");
            }
            OutputFormat::Github => {
                for (_, r) in &self.files {
                    if let Some(e) = &r.error {
                        let _ = writeln!(out, "{}", input_error_github(e));
                    }
                    for f in &r.findings {
                        let _ = writeln!(out, "{}", finding_github(f));
                    }
                }
                let _ = writeln!(out, "{}", self.summary(noun));
            }
            OutputFormat::Junit => {
                let files: Vec<FileFindings<'_>> = self
                    .files
                    .iter()
                    .map(|(file, r)| FileFindings {
                        file,
                        findings: &r.findings,
                        error: r.error.as_ref(),
                    })
                    .collect();
                out.push_str(&driveset_report::junit::render(&files, "driveset"));
            }
            OutputFormat::Json => {
                let doc = ReportDoc {
                    exit_code: self.exit_code(),
                    files: self
                        .files
                        .iter()
                        .map(|(path, r)| FileDoc {
                            error: r.error.as_ref().map(InputErrorDoc::of),
                            file: path,
                            findings: r.findings.iter().map(FindingDoc::of).collect(),
                            ok: r.error.is_none() && r.findings.is_empty(),
                        })
                        .collect(),
                    summary: SummaryDoc {
                        files: self.files.len(),
                        files_with_findings: self.files_with_findings(),
                        findings: self.findings(),
                        text: self.summary(noun),
                        unreadable: self.errors(),
                    },
                };
                let _ = writeln!(
                    out,
                    "{}",
                    serde_json::to_string_pretty(&doc).unwrap_or_default()
                );
            }
        }
        out
    }
}

/// Set once stdout is found closed (EPIPE) or failing: later output is dropped.
static STDOUT_GONE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Set when a write to stdout failed for another reason than a closed pipe
/// (`> /dev/full`, a full disk): the command then exits 2 ([`stdout_failed`]).
static STDOUT_FAILED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether a write to stdout failed (not a closed pipe): `main` then ends
/// the command with exit 2 whatever it would have returned below 2, since
/// its output did not arrive.
pub fn stdout_failed() -> bool {
    STDOUT_FAILED.load(std::sync::atomic::Ordering::Relaxed)
}

/// Write to stdout. Every byte the binary prints goes through here (the
/// crate denies `print!` / `println!`), so a closed stdout is handled in one
/// place: a reader that went away (`driveset decode ... | head`, EPIPE /
/// `BrokenPipe`) is not an error. The rest of the output is dropped
/// quietly, the command finishes its work (an upload or commission is never
/// cut short by a closed pipe) and exits with the code it would have had;
/// no panic, no message. Any other write error (disk full on a redirect,
/// `> /dev/full`) is said once on stderr, later output is dropped as well,
/// and the command exits 2 ([`stdout_failed`]).
pub fn emit(text: &str) {
    emit_bytes(text.as_bytes());
}

/// [`emit`] for bytes (`encode --raw`).
pub fn emit_bytes(bytes: &[u8]) {
    use std::io::Write as _;
    use std::sync::atomic::Ordering;
    if STDOUT_GONE.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(bytes).and_then(|()| out.flush()) {
        STDOUT_GONE.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            STDOUT_FAILED.store(true, Ordering::Relaxed);
            eprintln!("error: cannot write to stdout: {e}; the output is incomplete");
        }
    }
}

/// Print an input error (human, to stderr) and return exit code 2.
pub fn fail_input(e: &InputError) -> u8 {
    eprint!("{}", input_error_human(e, Style::stderr()));
    crate::EXIT_INPUT
}

/// The schemas every command knows: the four vendor schemas built in and
/// every `*.toml` schema of `dirs` (`--schemas`), from the engine's one
/// catalog ([`crate::port::catalog`]). The simulator's fictional fixture
/// schemas are not among them by id: a set names a fixture by its file
/// (`schema = "../fixtures/fictional-mc6000-demo.toml"`), or
/// `--schemas parameter-sets/fixtures` loads them.
pub fn registry(dirs: &[PathBuf]) -> Result<driveset_schema::Registry, InputError> {
    crate::port::catalog(dirs).registry()
}

/// Report a loaded set's findings on stderr (with the exit code to return),
/// or give it back when it has none.
pub fn valid_set(
    path: &Path,
    loaded: driveset_schema::LoadedSet,
) -> Result<driveset_schema::LoadedSet, u8> {
    if loaded.findings.is_empty() && loaded.resolved.is_some() && loaded.schema.is_some() {
        return Ok(loaded);
    }
    let style = Style::stderr();
    for f in &loaded.findings {
        eprintln!("{}", finding_human(f, style));
    }
    eprintln!(
        "{}",
        style.error(&format!(
            "{}: {}; fix the set first (`driveset validate {}`)",
            path.display(),
            plural(loaded.findings.len(), "finding", "findings"),
            path.display()
        ))
    );
    Err(crate::EXIT_INPUT)
}

/// Load one set for `diff`, `fingerprint` and `show`: an input error or a set
/// with findings is reported on stderr and gives the exit code to return.
pub fn load_valid_set(
    path: &Path,
    registry: &mut driveset_schema::Registry,
) -> Result<driveset_schema::LoadedSet, u8> {
    let loaded = driveset_schema::load_set(path, registry).map_err(|e| fail_input(&e))?;
    valid_set(path, loaded)
}

#[cfg(test)]
mod tests {
    use super::*;
    use driveset_schema::{Registry, load_set_str};

    #[test]
    fn findings_render_rustc_style() {
        let mut r = Registry::builtin().unwrap();
        let l = load_set_str(
            Path::new("t.toml"),
            "schema = \"lenze-tmd\"\n[values]\nC9999 = 1\n",
            &mut r,
        )
        .unwrap();
        assert_eq!(l.findings.len(), 1);
        let f = &l.findings[0];
        assert_eq!(finding_human(f, Style::PLAIN), f.render_human());
        assert_eq!(
            finding_human(f, Style::PLAIN),
            format!(
                "error[unknown-code]: {}\n --> t.toml:3:1\n  |\n3 | C9999 = 1\n  | ^^^^^ here\n  |\n  = help: {}\n",
                f.message, f.help
            )
        );
    }

    #[test]
    fn long_lines_are_windowed() {
        let text = format!("x = \"{}\"", "a".repeat(1000));
        let loc = Location {
            file: "f".into(),
            line: 1,
            column: 500,
            span: 499..502,
            line_text: text,
        };
        let e = InputError::new(driveset_schema::InputErrorKind::Syntax, loc, "m", "");
        let out = input_error_human(&e, Style::PLAIN);
        let shown = out.lines().nth(3).unwrap();
        assert!(
            shown.starts_with("1 | ...") && shown.ends_with("..."),
            "{out}"
        );
        assert!(shown.chars().count() < 200, "{out}");
    }

    #[test]
    fn github_escapes() {
        let loc = Location {
            file: "a,b:c.toml".into(),
            line: 2,
            column: 3,
            span: 0..1,
            line_text: String::new(),
        };
        assert_eq!(
            gh_line(&loc, "t", "50% done\nnext", "h"),
            "::error file=a%2Cb%3Ac.toml,line=2,col=3,title=t::50%25 done%0Anext%0Ahelp: h"
        );
    }
}
