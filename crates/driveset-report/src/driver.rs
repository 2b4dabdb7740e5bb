//! The `driveset` diff driver as git is told of it (`driveset git-setup`;
//! docs/file-formats.md): the `.gitattributes` lines that send set files
//! through it ([`attribute_lines`]), merged into what a repository's file
//! already holds ([`merge_attributes`]) and written back through the one
//! writer ([`update_attributes`]), and the command git runs as its
//! textconv ([`command`]; the view it prints is [`crate::textconv`]'s).
//! Running git is the caller's.

use std::path::Path;

use driveset_schema::InputError;
use driveset_schema::output::{self, OutputError};

/// The git configuration key of the driver's textconv command.
pub const TEXTCONV_KEY: &str = "diff.driveset.textconv";

/// The attribute lines for set files under `dir` (relative to the top of
/// the work tree; `.` or empty: everywhere).
pub fn attribute_lines(dir: &str) -> Vec<String> {
    let dir = dir.trim_matches('/');
    ["toml", "yaml", "yml"]
        .iter()
        .map(|ext| {
            if dir.is_empty() || dir == "." {
                format!("*.{ext} diff=driveset")
            } else {
                format!("{dir}/**/*.{ext} diff=driveset")
            }
        })
        .collect()
}

/// `existing` plus every line of `want` it lacks (compared with surrounding
/// whitespace trimmed and inner runs of blanks collapsed); `None` when
/// nothing is missing.
pub fn merge_attributes(existing: &str, want: &[String]) -> Option<String> {
    let norm = |l: &str| l.split_whitespace().collect::<Vec<_>>().join(" ");
    let have: Vec<String> = existing.lines().map(norm).collect();
    let missing: Vec<&String> = want.iter().filter(|w| !have.contains(&norm(w))).collect();
    if missing.is_empty() {
        return None;
    }
    let mut out = existing.to_string();
    if !out.is_empty() && !out.ends_with('\n') {
        out.push('\n');
    }
    if !existing.contains("driveset") {
        out.push_str("# semantic diffs of parameter sets (driveset git-setup)\n");
    }
    for m in missing {
        out.push_str(m);
        out.push('\n');
    }
    Some(out)
}

/// What [`update_attributes`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Attributes {
    /// Every line was there already; the file is untouched.
    UpToDate,
    /// The missing lines were added (the file written, or created).
    Written,
}

/// Why `.gitattributes` could not be updated.
#[derive(Debug)]
pub enum AttributesError {
    /// It is there but is no regular file (the one writer's refusal).
    Target(OutputError),
    /// It cannot be read as text (the one reader's refusal, or not UTF-8).
    Read(InputError),
    /// Writing it failed.
    Write(OutputError),
}

impl std::fmt::Display for AttributesError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AttributesError::Target(e) | AttributesError::Write(e) => {
                write!(f, "{}: {}", e.path.display(), e.detail())
            }
            AttributesError::Read(e) => write!(f, "{}; {}", e.message, e.help),
        }
    }
}

impl std::error::Error for AttributesError {}

/// Add to the `.gitattributes` file at `path` the lines of the set files
/// under each of `sets` ([`attribute_lines`], [`merge_attributes`]): the
/// file read through the one reader (a settings file: regular, at most
/// `MAX_FILE_BYTES`, UTF-8; none yet is empty), written back through the
/// one writer only when a line is missing.
pub fn update_attributes(path: &Path, sets: &[String]) -> Result<Attributes, AttributesError> {
    output::check_target(path).map_err(AttributesError::Target)?;
    let existing = driveset_schema::input::read_settings(path).map_err(AttributesError::Read)?;
    let want: Vec<String> = sets.iter().flat_map(|d| attribute_lines(d)).collect();
    match merge_attributes(&existing, &want) {
        None => Ok(Attributes::UpToDate),
        Some(text) => {
            output::write_output(path, text.as_bytes()).map_err(AttributesError::Write)?;
            Ok(Attributes::Written)
        }
    }
}

/// Quote a word for the shell git runs the textconv command with.
fn sh_quote(s: &str) -> String {
    if !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"/._-+:=@%,".contains(&b))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// The command git runs as the textconv driver: `driveset textconv`, or
/// with `exe` (the binary's absolute path, when `driveset` is not on
/// `PATH`) that path, quoted for the shell.
pub fn command(exe: Option<&str>) -> String {
    match exe {
        Some(exe) => format!("{} textconv", sh_quote(exe)),
        None => "driveset textconv".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merges_without_duplicates() {
        let want = attribute_lines("parameter-sets/");
        assert_eq!(want[0], "parameter-sets/**/*.toml diff=driveset");
        let merged = merge_attributes("*.png binary", &want).unwrap();
        assert!(merged.starts_with("*.png binary\n# semantic diffs"));
        assert_eq!(merged.matches("diff=driveset").count(), 3);
        assert_eq!(merge_attributes(&merged, &want), None);
        // an existing line written with other spacing counts
        let partial = "parameter-sets/**/*.toml   diff=driveset\n";
        let m = merge_attributes(partial, &want).unwrap();
        assert_eq!(m.matches("*.toml").count(), 1);
        assert_eq!(attribute_lines(".")[1], "*.yaml diff=driveset");
    }

    #[test]
    fn updates_the_file_once() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(".gitattributes");
        std::fs::write(&p, "*.png binary\n").unwrap();
        let sets = ["parameter-sets".to_string()];
        assert_eq!(update_attributes(&p, &sets).unwrap(), Attributes::Written);
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("*.png binary\n# semantic diffs"), "{text}");
        assert_eq!(update_attributes(&p, &sets).unwrap(), Attributes::UpToDate);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), text);
        std::fs::write(&p, [0xff, 0xfe]).unwrap();
        let e = update_attributes(&p, &sets).unwrap_err().to_string();
        assert!(
            e.ends_with("is not UTF-8 text; fix or remove the file"),
            "{e}"
        );
    }

    #[test]
    fn quotes_for_the_shell() {
        assert_eq!(sh_quote("/usr/bin/driveset"), "/usr/bin/driveset");
        assert_eq!(sh_quote("/a b/it's"), "'/a b/it'\\''s'");
        assert_eq!(command(Some("/a b/driveset")), "'/a b/driveset' textconv");
        assert_eq!(command(None), "driveset textconv");
    }
}
