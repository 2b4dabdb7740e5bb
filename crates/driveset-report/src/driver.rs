//! The `driveset` diff driver as git is told of it (`driveset git-setup`;
//! docs/file-formats.md): the `.gitattributes` lines that send set files
//! through it ([`attribute_lines`]), merged into what a repository's file
//! already holds ([`merge_attributes`]), and the command git runs as its
//! textconv ([`command`]; the view it prints is [`crate::textconv`]'s).
//! Running git and reading and writing the file are the caller's.

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
    fn quotes_for_the_shell() {
        assert_eq!(sh_quote("/usr/bin/driveset"), "/usr/bin/driveset");
        assert_eq!(sh_quote("/a b/it's"), "'/a b/it'\\''s'");
        assert_eq!(command(Some("/a b/driveset")), "'/a b/driveset' textconv");
        assert_eq!(command(None), "driveset textconv");
    }
}
