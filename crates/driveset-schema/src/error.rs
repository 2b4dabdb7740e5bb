//! Owns locations in source files, validation findings and input errors
//! (the two outcomes the CLI maps to exit codes 1 and 2).

use std::fmt;
use std::ops::Range;
use std::sync::Arc;

/// A loaded text file: its display path and its text, with line starts so a
/// byte span converts to line:column.
#[derive(Debug, Clone)]
pub struct SourceFile {
    /// The path as given (relative paths stay relative), used in messages.
    pub path: String,
    /// The full text.
    pub text: Arc<str>,
    line_starts: Vec<usize>,
}

impl SourceFile {
    /// Wrap a text under a display path.
    pub fn new(path: impl Into<String>, text: impl Into<Arc<str>>) -> Self {
        let text: Arc<str> = text.into();
        let mut line_starts = vec![0];
        for (i, b) in text.bytes().enumerate() {
            if b == b'\n' {
                line_starts.push(i + 1);
            }
        }
        SourceFile {
            path: path.into(),
            text,
            line_starts,
        }
    }

    /// Byte offset of (1-based line, 0-based column in characters); clamps to the text.
    pub fn offset_of(&self, line: usize, col_chars: usize) -> usize {
        let start = match line.checked_sub(1).and_then(|l| self.line_starts.get(l)) {
            Some(s) => *s,
            None => return self.text.len(),
        };
        let rest = self.text.get(start..).unwrap_or("");
        match rest.char_indices().nth(col_chars) {
            Some((i, _)) => start + i,
            None => self.text.len(),
        }
    }

    /// Location of a byte span: 1-based line and column (column counts characters).
    pub fn location(&self, span: Range<usize>) -> Location {
        let start = span.start.min(self.text.len());
        let end = span.end.clamp(start, self.text.len());
        let line_idx = match self.line_starts.binary_search(&start) {
            Ok(i) => i,
            Err(i) => i.saturating_sub(1),
        };
        let line_start = self.line_starts.get(line_idx).copied().unwrap_or(0);
        let line_end = self
            .line_starts
            .get(line_idx + 1)
            .map(|e| e.saturating_sub(1))
            .unwrap_or(self.text.len());
        let line_text = self.text.get(line_start..line_end).unwrap_or("");
        let line_text = line_text.strip_suffix('\r').unwrap_or(line_text);
        let column = self
            .text
            .get(line_start..start)
            .map(|s| s.chars().count() + 1)
            .unwrap_or(1);
        Location {
            file: self.path.clone(),
            line: line_idx + 1,
            column,
            span: start..end,
            line_text: line_text.to_string(),
        }
    }
}

/// Where something is: file, 1-based line and column, byte span, and the text
/// of the line (so a finding renders a snippet without the file at hand).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// Display path of the file.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
    /// Byte span in the file.
    pub span: Range<usize>,
    /// The text of `line`, without its line break.
    pub line_text: String,
}

impl Location {
    /// A location with no snippet (e.g. a file that could not be read).
    pub fn file_only(file: impl Into<String>) -> Self {
        Location {
            file: file.into(),
            line: 0,
            column: 0,
            span: 0..0,
            line_text: String::new(),
        }
    }

    /// The line to show and the span's byte range in it: the whole line, or
    /// for a line longer than [`MAX_SNIPPET_CHARS`] a window of that many
    /// characters around the column, `...` marking what is cut (so one huge
    /// value cannot make a huge report).
    fn snippet_window(&self) -> (String, Range<usize>) {
        let span = self.span_in_line();
        let total = self.line_text.chars().count();
        if total <= MAX_SNIPPET_CHARS {
            return (self.line_text.clone(), span);
        }
        let col0 = self.line_text[..span.start].chars().count();
        let from = col0.saturating_sub(40);
        let byte = |chars: usize| {
            self.line_text
                .char_indices()
                .nth(chars)
                .map_or(self.line_text.len(), |(i, _)| i)
        };
        let (a, b) = (byte(from), byte(from + MAX_SNIPPET_CHARS));
        let mut text = String::new();
        if from > 0 {
            text.push_str("...");
        }
        let shift = text.len();
        text.push_str(&self.line_text[a..b]);
        let start = span.start - a + shift;
        let end = span.end.clamp(a, b) - a + shift;
        if b < self.line_text.len() {
            text.push_str("...");
        }
        (text, start..end.max(start))
    }

    /// The byte range of the span within `line_text` (clamped to the line).
    fn span_in_line(&self) -> Range<usize> {
        let line_start = self.byte_col_offset();
        let start = self
            .span
            .start
            .saturating_sub(line_start)
            .min(self.line_text.len());
        let end = self
            .span
            .end
            .saturating_sub(line_start)
            .clamp(start, self.line_text.len());
        start..end
    }

    /// Hide the text at `secret` (a byte span of the same file) in this
    /// location's line: the snippet shows `<secret>` there instead of the
    /// value. A location that is the secret's value itself then spans the
    /// mask.
    pub fn mask_secret(&mut self, secret: &Range<usize>) {
        if self.line == 0 || self.line_text.is_empty() {
            return;
        }
        let line_start = self.byte_col_offset();
        let line_end = line_start + self.line_text.len();
        if secret.start >= line_end || secret.end <= line_start {
            return;
        }
        let s = secret.start.saturating_sub(line_start);
        let e = (secret.end - line_start).min(self.line_text.len());
        if !self.line_text.is_char_boundary(s) || !self.line_text.is_char_boundary(e) {
            return;
        }
        let mask = crate::canonical::SECRET;
        let before_chars = self.line_text.get(..s).map_or(0, |t| t.chars().count());
        let value_chars = self.line_text.get(s..e).map_or(0, |t| t.chars().count());
        self.line_text.replace_range(s..e, mask);
        if self.span.start >= secret.start && self.span.start < secret.end {
            // the location is (inside) the value: point at the mask
            self.span = secret.start..secret.start + mask.len();
            self.column = before_chars + 1;
        } else if self.span.start >= secret.end {
            // after the value on the same line: shift with the text
            let (old_len, new_len) = (e - s, mask.len());
            self.span = (self.span.start + new_len).saturating_sub(old_len)
                ..(self.span.end + new_len).saturating_sub(old_len);
            self.column = (self.column + mask.chars().count())
                .saturating_sub(value_chars)
                .max(1);
        }
    }

    /// Hide the rest of this location's line from byte `from` of
    /// `line_text` on ([`Location::mask_secret`]).
    pub fn mask_line_from(&mut self, from: usize) {
        if self.line == 0 || from >= self.line_text.len() {
            return;
        }
        let start = self.byte_col_offset();
        self.mask_secret(&(start + from..start + self.line_text.len()));
    }

    /// Byte offset of the start of the line in the file (derived from span and column).
    fn byte_col_offset(&self) -> usize {
        let col_bytes: usize = self
            .line_text
            .chars()
            .take(self.column.saturating_sub(1))
            .map(char::len_utf8)
            .sum();
        self.span.start.saturating_sub(col_bytes)
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.file)
        } else {
            write!(f, "{}:{}:{}", self.file, self.line, self.column)
        }
    }
}

/// The kinds of validation findings (docs/file-formats.md, "Parameter sets").
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FindingKind {
    /// A key names no code of the schema.
    UnknownCode,
    /// The same code is given twice in one file (number and name, name and alias, ...).
    DuplicateCode,
    /// The value's kind does not fit the code (table for a plain code, text for a number, ...).
    WrongType,
    /// Outside the schema's min/max or the type's raw range.
    OutOfRange,
    /// The scaling cannot represent the value exactly.
    Unrepresentable,
    /// An enumeration label the code does not have.
    UnknownEnumLabel,
    /// A number that is not one of a complete enumeration's values.
    NotAnEnumValue,
    /// A bit-field member the code does not have.
    UnknownBitField,
    /// A value for a read-only code.
    ReadOnly,
    /// A cross-code rule of the schema is violated.
    RuleViolation,
    /// The set names a schema that is not known.
    UnknownSchema,
    /// `extends` names a missing file, forms a cycle, or a base of another schema.
    BadExtends,
    /// A value for a code whose type the schema does not know.
    UnknownType,
    /// The unit suffix does not match the code's unit.
    UnitMismatch,
    /// A problem in a schema file itself (`schema check`).
    SchemaError,
    /// A value for a code with role `command` (PROG, SLOAD, STAT reset,
    /// C0002, C0043 ...): a set never holds a command.
    Command,
    /// A control word in a state other than stopped / inhibited (a start,
    /// enable or release bit set, no inhibit bit set, a reset bit set, or a
    /// control word whose bits the schema does not describe).
    ControlWordNotStopped,
    /// A secret given as the `<secret>` placeholder (an exported or pulled
    /// set holds no secret's value).
    SecretNotGiven,
    /// A value for a RAM control value (`kind = "ram-control"`) that is
    /// not a control word or a setpoint: the drive loses it at power off
    /// (LUSTBUS §11.1, §11.2), so the set would not survive a power cycle.
    RamCode,
}

impl FindingKind {
    /// The kebab-case name shown as `error[name]` and in JSON output.
    pub fn as_str(self) -> &'static str {
        match self {
            FindingKind::UnknownCode => "unknown-code",
            FindingKind::DuplicateCode => "duplicate-code",
            FindingKind::WrongType => "wrong-type",
            FindingKind::OutOfRange => "out-of-range",
            FindingKind::Unrepresentable => "unrepresentable",
            FindingKind::UnknownEnumLabel => "unknown-enum-label",
            FindingKind::NotAnEnumValue => "not-an-enum-value",
            FindingKind::UnknownBitField => "unknown-bit-field",
            FindingKind::ReadOnly => "read-only",
            FindingKind::RuleViolation => "rule-violation",
            FindingKind::UnknownSchema => "unknown-schema",
            FindingKind::BadExtends => "bad-extends",
            FindingKind::UnknownType => "unknown-type",
            FindingKind::UnitMismatch => "unit-mismatch",
            FindingKind::SchemaError => "schema-error",
            FindingKind::Command => "command",
            FindingKind::ControlWordNotStopped => "control-word-not-stopped",
            FindingKind::SecretNotGiven => "secret-not-given",
            FindingKind::RamCode => "ram-code",
        }
    }
}

impl fmt::Display for FindingKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One validation finding: what (kind, message), where (location), what to do (help),
/// and other places involved (`related`, each with a short label).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Finding {
    /// Kind of finding.
    pub kind: FindingKind,
    /// What is wrong.
    pub message: String,
    /// What to do about it.
    pub help: String,
    /// Where.
    pub location: Location,
    /// Other places involved (the first spelling of a duplicate, the other side of a rule).
    pub related: Vec<(String, Location)>,
}

impl Finding {
    pub(crate) fn new(
        kind: FindingKind,
        location: Location,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        Finding {
            kind,
            message: cap_message(message.into()),
            help: cap_message(help.into()),
            location,
            related: Vec::new(),
        }
    }

    pub(crate) fn with_related(mut self, label: impl Into<String>, loc: Location) -> Self {
        self.related.push((label.into(), loc));
        self
    }

    /// rustc-style rendering:
    ///
    /// ```text
    /// error[out-of-range]: C0011 = 300 Hz is above the maximum 240 Hz
    ///  --> set.toml:3:9
    ///   |
    /// 3 | C0011 = 300
    ///   |         ^^^ here
    ///   |
    ///   = help: give a value from 7.5 to 240 Hz
    /// ```
    pub fn render_human(&self) -> String {
        self.render(Colour::Plain)
    }

    /// [`Finding::render_human`], in colour when `colour` is
    /// [`Colour::Styled`] (a terminal).
    pub fn render(&self, colour: Colour) -> String {
        let kind = self.kind.to_string();
        let mut places = vec![("here", &self.location)];
        places.extend(self.related.iter().map(|(l, loc)| (l.as_str(), loc)));
        render_diagnostic(Some(&kind), &self.message, &places, &self.help, colour)
    }
}

/// Whether a rendered diagnostic is plain text or carries terminal colour
/// escapes ([`render_diagnostic`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Colour {
    /// Plain text.
    Plain,
    /// Styled with ANSI colours, for a terminal.
    Styled,
}

/// A diagnostic as rustc renders one, by `annotate-snippets` (the renderer
/// rustc uses): `error[KIND]: MESSAGE`, then for each place its
/// `file:line:col` with the source line and a caret under the span (the
/// first place after `-->`, the others after `:::`), then `= help: HELP`.
/// A place without source text (a file that could not be read, an empty
/// line) shows as a note naming the file (and line:col). Ends with a
/// newline.
pub fn render_diagnostic(
    kind: Option<&str>,
    message: &str,
    places: &[(&str, &Location)],
    help: &str,
    colour: Colour,
) -> String {
    use annotate_snippets::{Level, Renderer, Snippet};
    let mut m = Level::Error.title(message);
    if let Some(k) = kind {
        m = m.id(k);
    }
    // A place without source text to show (a file that could not be read,
    // the end of an empty line) is named in a note.
    let shown = |loc: &Location| loc.line > 0 && !loc.line_text.is_empty();
    let files: Vec<String> = places
        .iter()
        .filter(|(_, loc)| !shown(loc))
        .map(|(_, loc)| match loc.line {
            0 => format!("in {}", loc.file),
            _ => format!("at {loc}"),
        })
        .collect();
    let sources: Vec<(String, Range<usize>)> = places
        .iter()
        .filter(|(_, loc)| shown(loc))
        .map(|(_, loc)| {
            let (text, span) = loc.snippet_window();
            escape_with_span(&text, span)
        })
        .collect();
    let origins: Vec<String> = places
        .iter()
        .filter(|(_, loc)| shown(loc))
        .map(|(_, loc)| escape_controls(&loc.file).into_owned())
        .collect();
    for (((label, loc), (text, span)), origin) in places
        .iter()
        .filter(|(_, loc)| shown(loc))
        .zip(&sources)
        .zip(&origins)
    {
        m = m.snippet(
            Snippet::source(text)
                .line_start(loc.line)
                .origin(origin)
                .annotation(Level::Error.span(span.clone()).label(label)),
        );
    }
    let files: Vec<String> = files
        .iter()
        .map(|f| escape_controls(f).into_owned())
        .collect();
    for f in &files {
        m = m.footer(Level::Note.title(f));
    }
    if !help.is_empty() {
        m = m.footer(Level::Help.title(help));
    }
    let renderer = match colour {
        Colour::Styled => Renderer::styled(),
        Colour::Plain => Renderer::plain(),
    };
    format!("{}\n", renderer.render(m))
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_finding_line(f, &self.location, &self.kind, &self.message, &self.help)
    }
}

/// The one-line form of a finding: `LOCATION: error[KIND]: MESSAGE`, then
/// ` (help: HELP)` where there is help. [`Finding`]'s, and the line
/// manifest's findings' in the engine.
pub fn write_finding_line(
    f: &mut fmt::Formatter<'_>,
    location: &Location,
    kind: &dyn fmt::Display,
    message: &str,
    help: &str,
) -> fmt::Result {
    write!(f, "{location}: error[{kind}]: {message}")?;
    if !help.is_empty() {
        write!(f, " (help: {help})")?;
    }
    Ok(())
}

/// Longest snippet line shown in full; a longer one shows a window around
/// the column.
pub const MAX_SNIPPET_CHARS: usize = 160;

/// Longest message kept in full; longer ones (a message quoting a huge key or
/// number from the file) are cut, so one bad value cannot make a huge report.
pub const MAX_MESSAGE_CHARS: usize = 400;

/// `text` with every control character (newline, ESC, DEL, C1 controls,
/// ...) written as its escape (`\n`, `\u{1b}`), so a key or value from a
/// file cannot reach a terminal or CI log raw (no forged lines, no escape
/// sequences). Every message, help and snippet line of a finding or input
/// error goes through it; the CLI's human renderings of names and values
/// too.
pub fn escape_controls(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// [`escape_controls`] on a snippet line, with `span` (a byte range of
/// `text`) moved to the same characters of the escaped line.
fn escape_with_span(text: &str, span: Range<usize>) -> (String, Range<usize>) {
    if !text.chars().any(char::is_control) {
        return (text.to_string(), span);
    }
    let mut out = String::with_capacity(text.len() + 8);
    let (mut start, mut end) = (None, None);
    for (i, c) in text.char_indices() {
        if i >= span.start && start.is_none() {
            start = Some(out.len());
        }
        if i >= span.end && end.is_none() {
            end = Some(out.len());
        }
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    let start = start.unwrap_or(out.len());
    let end = end.unwrap_or(out.len()).max(start);
    (out, start..end)
}

fn cap_message(m: String) -> String {
    let m = match escape_controls(&m) {
        std::borrow::Cow::Borrowed(_) => m,
        std::borrow::Cow::Owned(e) => e,
    };
    let n = m.chars().count();
    if n <= MAX_MESSAGE_CHARS {
        return m;
    }
    let head: String = m.chars().take(MAX_MESSAGE_CHARS).collect();
    format!("{head}... (message cut, {n} characters)")
}

/// What kind of input error (the CLI exits 2 for all of them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputErrorKind {
    /// The file could not be read.
    Unreadable,
    /// The path is a FIFO, socket, device or directory, not a regular file
    /// (never opened; an input error wherever the file is named, `extends`
    /// and schema paths included).
    NotRegularFile,
    /// The file is larger than its kind's cap ([`crate::input::InputKind`]).
    TooLarge,
    /// The file is not UTF-8 text or contains NUL bytes.
    Binary,
    /// The file is empty (or whitespace and comments only).
    Empty,
    /// TOML or YAML syntax error.
    Syntax,
    /// The structure is not what the format expects (unknown top-level key,
    /// missing required field, NaN/inf, ...).
    Structure,
}

/// Parameter sets, schemas and line manifests larger than this are
/// refused (4 MiB; [`crate::input::InputKind::SET`]).
pub const MAX_FILE_BYTES: u64 = 4 * 1024 * 1024;

/// An input error: the file could not be read or is not a well-formed
/// schema/set file. Carries file:line:column where known.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{location}: {message} (help: {help})")]
pub struct InputError {
    /// Kind of error.
    pub kind: InputErrorKind,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
    /// Where (line 0 when only the file is known); boxed, so a
    /// `Result<_, InputError>` stays small.
    pub location: Box<Location>,
}

impl InputError {
    /// An input error: what kind, where, what is wrong, what to do.
    pub fn new(
        kind: InputErrorKind,
        location: Location,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        InputError {
            kind,
            message: cap_message(message.into()),
            help: cap_message(help.into()),
            location: Box::new(location),
        }
    }

    /// The message without the file's name, for a caller whose own message
    /// names the file already (`journal J: cannot read it: ...`, `journal
    /// J: is a FIFO (named pipe), not a regular file; ...`), and the help.
    pub fn detail(&self) -> String {
        let file = &self.location.file;
        let m = &self.message;
        let m = if let Some(rest) = m.strip_prefix(&format!("cannot read {file}: ")) {
            format!("cannot read it: {rest}")
        } else if let Some(rest) = m.strip_prefix(&format!("{file} ")) {
            rest.to_string()
        } else {
            m.clone()
        };
        format!("{m}; {}", self.help)
    }

    /// rustc-style rendering, like [`Finding::render_human`].
    pub fn render_human(&self) -> String {
        self.render(Colour::Plain)
    }

    /// [`InputError::render_human`], in colour when `colour` is
    /// [`Colour::Styled`] (a terminal).
    pub fn render(&self, colour: Colour) -> String {
        render_diagnostic(
            None,
            &self.message,
            &[("here", &self.location)],
            &self.help,
            colour,
        )
    }
}

/// Read a file as UTF-8 text with the size, binary and empty checks of
/// [`InputErrorKind`]; only regular files (see [`crate::input::read_input`]).
pub fn read_text_file(path: &std::path::Path) -> Result<SourceFile, InputError> {
    let display = path.display().to_string();
    let bytes = crate::input::read_input(path, crate::input::InputKind::SET)?;
    source_from_bytes(&display, bytes)
}

/// The checks of [`read_text_file`] on text already in memory (one copy, into the source).
pub fn source_from_str(display: &str, text: &str) -> Result<SourceFile, InputError> {
    if text.len() as u64 > MAX_FILE_BYTES || text.contains('\0') || text.starts_with('\u{feff}') {
        return source_from_bytes(display, text.as_bytes().to_vec());
    }
    let meaningful = text.lines().any(|l| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('#') && t != "---" && t != "..."
    });
    if !meaningful {
        return source_from_bytes(display, text.as_bytes().to_vec());
    }
    Ok(SourceFile::new(display, text))
}

/// The checks of [`read_text_file`] on bytes already in memory.
pub fn source_from_bytes(display: &str, bytes: Vec<u8>) -> Result<SourceFile, InputError> {
    let loc = || Location::file_only(display.to_string());
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(InputError::new(
            InputErrorKind::TooLarge,
            loc(),
            format!("{display} is larger than {MAX_FILE_BYTES} bytes"),
            "parameter sets and schemas are small text files; check that this is the right file",
        ));
    }
    if bytes.contains(&0) {
        return Err(InputError::new(
            InputErrorKind::Binary,
            loc(),
            format!("{display} is a binary file (contains NUL bytes)"),
            "give a TOML or YAML text file",
        ));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        InputError::new(
            InputErrorKind::Binary,
            loc(),
            format!(
                "{display} is not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
            "save the file as UTF-8",
        )
    })?;
    let text = text
        .strip_prefix('\u{feff}')
        .map(str::to_string)
        .unwrap_or(text);
    let meaningful = text.lines().any(|l| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('#') && t != "---" && t != "..."
    });
    if !meaningful {
        return Err(InputError::new(
            InputErrorKind::Empty,
            loc(),
            format!("{display} is empty"),
            "a set needs at least `schema = \"...\"`",
        ));
    }
    Ok(SourceFile::new(display, text))
}

pub use crate::input::read_regular_file;

#[cfg(test)]
mod escape_tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_spans_follow() {
        assert_eq!(escape_controls("plain ü"), "plain ü");
        assert_eq!(
            escape_controls("a\u{1b}[2J\nb\t\u{7f}\u{85}"),
            "a\\u{1b}[2J\\nb\\t\\u{7f}\\u{85}"
        );
        // the span `x` after an ESC moves with the escaped text
        let (text, span) = escape_with_span("k\u{1b} = x", 5..6);
        assert_eq!(text, "k\\u{1b} = x");
        assert_eq!(&text[span], "x");
        let (text, span) = escape_with_span("\u{1b}key = 1", 0..4);
        assert_eq!(&text[span], "\\u{1b}key");
    }
}

#[cfg(test)]
mod finding_line_tests {
    use super::*;

    struct Line(&'static str);

    impl fmt::Display for Line {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            let at = Location::file_only("line.toml");
            write_finding_line(f, &at, &"unknown-key", "no such key", self.0)
        }
    }

    #[test]
    fn a_finding_line_names_the_place_the_kind_and_help_only_where_there_is_some() {
        let at = Location::file_only("line.toml").to_string();
        assert_eq!(
            Line("").to_string(),
            format!("{at}: error[unknown-key]: no such key")
        );
        assert_eq!(
            Line("remove it").to_string(),
            format!("{at}: error[unknown-key]: no such key (help: remove it)")
        );
    }
}
