//! JUnit XML of validation findings (`driveset validate --format junit`),
//! for CI systems that show test reports (GitLab `artifacts:reports:junit`,
//! Jenkins, Azure). Built from the same per-file findings the JSON format
//! renders: one `testsuite` per file, one `testcase` per finding with a
//! `failure` that carries `file:line:col`, one `error` testcase for a file
//! that could not be read, and one passing `testcase` for a clean file (so
//! every checked file shows up). Also a line report as JUnit XML for CI
//! test reports of a rehearsal ([`line()`], docs/ci.md).

use std::fmt::Write;

use driveset_schema::{Finding, InputError, Location};

use driveset_engine::line::report::{DriveResult, LineReport};

/// The findings of one checked file, and the input error when it could
/// not be read (what `validate` / `schema check` collect per file).
#[derive(Debug, Clone, Copy)]
pub struct FileFindings<'a> {
    /// The file as the report names it.
    pub file: &'a str,
    /// Its findings, in file order.
    pub findings: &'a [Finding],
    /// The input error, when it could not be read.
    pub error: Option<&'a InputError>,
}

/// Escape text for XML 1.0 content and attribute values. Characters XML
/// 1.0 cannot carry at all (most C0 controls) become U+FFFD.
pub fn xml_esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\t' => out.push_str("&#9;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            c if (c as u32) < 0x20 || c == '\u{fffe}' || c == '\u{ffff}' => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out
}

/// Element text: like [`xml_esc`] but keeps newlines and tabs readable.
fn text_esc(s: &str) -> String {
    xml_esc(s)
        .replace("&#10;", "\n")
        .replace("&#9;", "\t")
        .replace("&#13;", "")
}

/// `file:line:col`, or just `file` for a place without a line.
pub fn place(loc: &Location) -> String {
    if loc.line == 0 {
        loc.file.clone()
    } else {
        format!("{}:{}:{}", loc.file, loc.line, loc.column)
    }
}

fn finding_case(o: &mut String, file: &str, f: &Finding) {
    let at = place(&f.location);
    let mut body = format!("{at}: {}\n", f.message);
    for (label, loc) in &f.related {
        let _ = writeln!(body, "{}: {label}", place(loc));
    }
    if f.location.line > 0 && !f.location.line_text.is_empty() {
        let _ = writeln!(
            body,
            "  | {}",
            driveset_schema::error::escape_controls(&f.location.line_text)
        );
    }
    if !f.help.is_empty() {
        let _ = writeln!(body, "help: {}", f.help);
    }
    let line_attr = if f.location.line > 0 {
        format!(" line=\"{}\"", f.location.line)
    } else {
        String::new()
    };
    let _ = writeln!(
        o,
        "    <testcase classname=\"{}\" name=\"{}\" file=\"{}\"{line_attr}>\n      \
         <failure type=\"{}\" message=\"{}\">{}</failure>\n    </testcase>",
        xml_esc(file),
        xml_esc(&format!("{} at {at}", f.kind.as_str())),
        xml_esc(&f.location.file),
        xml_esc(f.kind.as_str()),
        xml_esc(&format!("{at}: {}", f.message)),
        text_esc(&body)
    );
}

fn error_case(o: &mut String, file: &str, e: &InputError) {
    let at = place(&e.location);
    let mut body = format!("{at}: {}\n", e.message);
    if !e.help.is_empty() {
        let _ = writeln!(body, "help: {}", e.help);
    }
    let line_attr = if e.location.line > 0 {
        format!(" line=\"{}\"", e.location.line)
    } else {
        String::new()
    };
    let _ = writeln!(
        o,
        "    <testcase classname=\"{}\" name=\"{}\" file=\"{}\"{line_attr}>\n      \
         <error type=\"input-error\" message=\"{}\">{}</error>\n    </testcase>",
        xml_esc(file),
        xml_esc(&format!("input-error at {at}")),
        xml_esc(&e.location.file),
        xml_esc(&format!("{at}: {}", e.message)),
        text_esc(&body)
    );
}

/// The findings of `files` as a JUnit XML document (`<testsuites>` root
/// named `suite`, e.g. `driveset validate`).
pub fn render(files: &[FileFindings<'_>], suite: &str) -> String {
    let mut o = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let tests: usize = files
        .iter()
        .map(|r| cases(r.findings.len(), r.error.is_some()))
        .sum();
    let findings: usize = files.iter().map(|r| r.findings.len()).sum();
    let errors = files.iter().filter(|r| r.error.is_some()).count();
    let _ = writeln!(
        o,
        "<testsuites name=\"{}\" tests=\"{tests}\" failures=\"{findings}\" errors=\"{errors}\">",
        xml_esc(suite),
    );
    for r in files {
        let file = r.file;
        let n = cases(r.findings.len(), r.error.is_some());
        let _ = writeln!(
            o,
            "  <testsuite name=\"{}\" tests=\"{n}\" failures=\"{}\" errors=\"{}\" skipped=\"0\">",
            xml_esc(file),
            r.findings.len(),
            usize::from(r.error.is_some())
        );
        if let Some(e) = r.error {
            error_case(&mut o, file, e);
        }
        for f in r.findings {
            finding_case(&mut o, file, f);
        }
        if n == 1 && r.error.is_none() && r.findings.is_empty() {
            let _ = writeln!(
                o,
                "    <testcase classname=\"{}\" name=\"valid\" file=\"{}\"/>",
                xml_esc(file),
                xml_esc(file)
            );
        }
        o.push_str("  </testsuite>\n");
    }
    o.push_str("</testsuites>\n");
    o
}

/// Test cases of one file: one per finding and error, or one passing case.
fn cases(findings: usize, error: bool) -> usize {
    (findings + usize::from(error)).max(1)
}

/// JUnit XML of a line report (one testcase per drive; a drive that does
/// not hold its set is a failure, a drive not rehearsed is skipped), for
/// CI test reports of a rehearsal (docs/ci.md).
pub fn line(r: &LineReport, not_rehearsed: &[String]) -> String {
    let failed = |res: DriveResult| {
        !matches!(
            res,
            DriveResult::Verified
                | DriveResult::Unchanged
                | DriveResult::AlreadyVerified
                | DriveResult::NotSelected
        )
    };
    let failures = r.drives.iter().filter(|d| failed(d.result)).count();
    let skipped = r
        .drives
        .iter()
        .filter(|d| d.result == DriveResult::NotSelected)
        .count();
    let mut o = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        o,
        "<testsuites name=\"{}\" tests=\"{}\" failures=\"{failures}\" errors=\"0\">",
        xml_esc(&format!("driveset rehearsal {}", r.line)),
        r.drives.len()
    );
    let _ = writeln!(
        o,
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{failures}\" errors=\"0\" skipped=\"{skipped}\">",
        xml_esc(r.label.as_deref().unwrap_or(&r.line)),
        r.drives.len()
    );
    for d in &r.drives {
        let _ = write!(
            o,
            "    <testcase classname=\"{}\" name=\"{}\" file=\"{}\"",
            xml_esc(&d.bus),
            xml_esc(&d.name),
            xml_esc(&d.set)
        );
        let result = serde_json::to_value(d.result)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default();
        if d.result == DriveResult::NotSelected {
            let why = if not_rehearsed.contains(&d.name) {
                "not rehearsed: no twin"
            } else {
                "not selected"
            };
            let _ = writeln!(o, ">\n      <skipped message=\"{why}\"/>\n    </testcase>");
        } else if failed(d.result) {
            let msg = d.error.clone().unwrap_or_else(|| result.clone());
            let _ = writeln!(
                o,
                ">\n      <failure message=\"{}\" type=\"{}\">{}</failure>\n    </testcase>",
                xml_esc(&msg),
                xml_esc(&result),
                xml_esc(&msg)
            );
        } else {
            let _ = writeln!(o, "/>");
        }
    }
    o.push_str("  </testsuite>\n</testsuites>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_for_xml() {
        assert_eq!(
            xml_esc("a<b>&\"c\"'\n\u{1}"),
            "a&lt;b&gt;&amp;&quot;c&quot;&apos;&#10;\u{fffd}"
        );
        assert_eq!(text_esc("x\n<y>"), "x\n&lt;y&gt;");
    }
}
