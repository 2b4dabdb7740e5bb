//! The validation report of `validate` and `schema check` (docs/ci.md):
//! per-file findings and input errors, rendered for people (rustc-style
//! with a source snippet, by `annotate-snippets` through the schema crate),
//! as one JSON document, as GitHub workflow annotations and as JUnit XML
//! ([`crate::junit`]); and the single finding / input error in those forms
//! that `diff`, `fingerprint` and `show` print. Text only: printing it and
//! the exit code are the caller's.

use std::fmt::Write;

use driveset_schema::{Finding, InputError, Location};

use crate::junit::FileFindings;
pub use crate::style::{Style, plural};

/// rustc-style finding, rendered by `annotate-snippets` (the schema
/// crate's [`Finding::render`]; colour on a terminal).
pub fn finding_human(f: &Finding, style: Style) -> String {
    f.render(style.colour())
}

/// rustc-style input error ([`InputError::render`]).
pub fn input_error_human(e: &InputError, style: Style) -> String {
    e.render(style.colour())
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

impl FileReport {
    /// The report of a file checked: its findings, or the input error that
    /// kept it from being read.
    pub fn of(checked: Result<Vec<Finding>, InputError>) -> Self {
        match checked {
            Ok(findings) => FileReport {
                findings,
                error: None,
            },
            Err(e) => FileReport {
                findings: Vec::new(),
                error: Some(e),
            },
        }
    }
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

    /// What the report says: a file unreadable wins over findings.
    pub fn verdict(&self) -> Verdict {
        if self.errors() > 0 {
            Verdict::Unreadable
        } else if self.findings() > 0 {
            Verdict::Findings
        } else {
            Verdict::Clean
        }
    }

    /// `3 findings in 2 of 16 files` (+ `; 1 file could not be read`).
    pub fn summary(&self, noun: Noun<'_>) -> String {
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

    /// For people: every input error and finding rustc-style, then the
    /// summary line (bold when clean, red otherwise).
    pub fn human(&self, style: Style, noun: Noun<'_>) -> String {
        let mut out = String::new();
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
        let summary = if self.verdict() == Verdict::Clean {
            style.bold(&summary)
        } else {
            style.error(&summary)
        };
        let _ = writeln!(out, "{summary}");
        out
    }

    /// GitHub workflow annotations, one line each, then the summary line.
    pub fn github(&self, noun: Noun<'_>) -> String {
        let mut out = String::new();
        for (_, r) in &self.files {
            if let Some(e) = &r.error {
                let _ = writeln!(out, "{}", input_error_github(e));
            }
            for f in &r.findings {
                let _ = writeln!(out, "{}", finding_github(f));
            }
        }
        let _ = writeln!(out, "{}", self.summary(noun));
        out
    }

    /// JUnit XML ([`crate::junit::render`], suite `driveset`).
    pub fn junit(&self) -> String {
        let files: Vec<FileFindings<'_>> = self
            .files
            .iter()
            .map(|(file, r)| FileFindings {
                file,
                findings: &r.findings,
                error: r.error.as_ref(),
            })
            .collect();
        crate::junit::render(&files, "driveset")
    }

    /// One JSON document (and a newline); `exit_code` is the one the
    /// command ends with, which the document names.
    pub fn json(&self, noun: Noun<'_>, exit_code: u8) -> String {
        let doc = ReportDoc {
            exit_code,
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
        format!(
            "{}\n",
            serde_json::to_string_pretty(&doc).unwrap_or_default()
        )
    }
}

/// What a report's files are called in its summary: one and many
/// (`("file", "files")`, `("schema", "schemas")`).
pub type Noun<'a> = (&'a str, &'a str);

/// What a validation report says, for the caller's exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Every file read, no finding.
    Clean,
    /// Every file read, at least one finding.
    Findings,
    /// A file could not be read.
    Unreadable,
}

#[cfg(test)]
mod tests {
    use std::path::Path;

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

    #[test]
    fn summary_and_verdict() {
        let mut r = Registry::builtin().unwrap();
        let l = load_set_str(
            Path::new("t.toml"),
            "schema = \"lenze-tmd\"\n[values]\nC9999 = 1\n",
            &mut r,
        )
        .unwrap();
        let mut report = Report::default();
        assert_eq!(report.verdict(), Verdict::Clean);
        report.files.push(("a.toml".into(), FileReport::default()));
        report.files.push((
            "t.toml".into(),
            FileReport {
                findings: l.findings,
                error: None,
            },
        ));
        assert_eq!(report.verdict(), Verdict::Findings);
        assert_eq!(
            report.summary(("file", "files")),
            "1 finding in 1 of 2 files"
        );
        assert!(
            report
                .human(Style::PLAIN, ("file", "files"))
                .ends_with("1 finding in 1 of 2 files\n")
        );
        let gh = report.github(("file", "files"));
        assert!(
            gh.starts_with("::error file=t.toml,line=3,col=1,title=unknown-code::"),
            "{gh}"
        );
        let json: serde_json::Value =
            serde_json::from_str(&report.json(("file", "files"), 1)).unwrap();
        assert_eq!(json["exit_code"], 1);
        assert_eq!(json["summary"]["findings"], 1);
        assert_eq!(json["files"][0]["ok"], true);
    }
}
