//! The output side every command shares: the one `--format` type and the
//! values each command takes, stdout (closed-pipe safe), colour only on a
//! terminal and never with `NO_COLOR`, the validation report in the format
//! asked for (rendered by `driveset_report::validation`), and loading the
//! registry and a valid set with their errors printed.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use driveset_report::style::Style;
pub use driveset_report::style::plural;
use driveset_report::validation::{Noun, Report, Verdict, finding_human, input_error_human};
use driveset_schema::InputError;

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

/// Colour when stdout is a terminal and `NO_COLOR` is unset or empty.
pub fn stdout_style() -> Style {
    style_if(std::io::stdout().is_terminal())
}

/// Colour when stderr is a terminal and `NO_COLOR` is unset or empty.
pub fn stderr_style() -> Style {
    style_if(std::io::stderr().is_terminal())
}

fn style_if(terminal: bool) -> Style {
    if terminal && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty()) {
        Style::COLOUR
    } else {
        Style::PLAIN
    }
}

/// The exit code of a validation report (`validate`, `schema check`): 2
/// when a file could not be read, 1 on findings, else 0.
pub fn report_exit_code(v: Verdict) -> u8 {
    match v {
        Verdict::Clean => crate::EXIT_OK,
        Verdict::Findings => crate::EXIT_FINDINGS,
        Verdict::Unreadable => crate::EXIT_INPUT,
    }
}

/// A validation report in `format` (only `human`, `json`, `github` and
/// `junit` reach one); `noun` names the files ("file", "files").
pub fn render_report(report: &Report, format: OutputFormat, noun: Noun<'_>) -> String {
    match format {
        OutputFormat::Github => report.github(noun),
        OutputFormat::Junit => report.junit(),
        OutputFormat::Json => report.json(noun, report_exit_code(report.verdict())),
        // the text forms
        OutputFormat::Human
        | OutputFormat::Text
        | OutputFormat::Table
        | OutputFormat::Csv
        | OutputFormat::Html => report.human(stdout_style(), noun),
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
    eprint!("{}", input_error_human(e, stderr_style()));
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
    let style = stderr_style();
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
