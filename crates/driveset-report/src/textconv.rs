//! The semantic, line-oriented view of a set file that `git diff` shows
//! through the `driveset` diff driver (`driveset git-setup` configures
//! `diff.driveset.textconv = driveset textconv`). One line per code, sorted
//! by code, with the code's name and the value in engineering units with
//! labels (`C0011 maximum_output_frequency = 60 Hz`), `extends` merged, so
//! a changed value shows as one `-`/`+` pair of readable lines.
//!
//! git hands textconv a temporary copy named `XXXXXX_<basename>` outside the
//! work tree, so relative `schema` and `extends` paths cannot be resolved
//! from the file's own place. The file is therefore anchored at the
//! directory of the tracked file of the same name (`git ls-files`, run in
//! the repository git runs the driver in); where several tracked files
//! share the name, the first one under which the set loads without findings
//! wins. A file that is not a set here (a schema file, a syntax error, an
//! unknown schema) is printed unchanged, so its diff is the plain text diff.
//! The tracked files come from the caller (it runs git).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use driveset_schema::validate::display_value;
use driveset_schema::{CodeStyle, FindingKind, LoadedSet, Registry, Schema, load_set_str};

/// The name git's temporary copy stands for: `AbC12x_name.toml` -> `name.toml`.
fn original_name(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let in_temp = path
        .parent()
        .is_some_and(|p| p.starts_with(std::env::temp_dir()));
    let b = name.as_bytes();
    if in_temp && b.len() > 7 && b[6] == b'_' && b[..6].iter().all(u8::is_ascii_alphanumeric) {
        name[7..].to_string()
    } else {
        name
    }
}

/// Directories to anchor the file at, best first (`tracked`: the files of
/// the work tree git runs the driver in, as paths from its top).
fn anchors(path: &Path, name: &str, tracked: impl FnOnce() -> Vec<PathBuf>) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let own = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let own_is_temp = own.starts_with(std::env::temp_dir());
    if !own_is_temp {
        out.push(own.clone());
    }
    for p in tracked() {
        if p.file_name().is_some_and(|n| n.to_string_lossy() == name)
            && let Some(dir) = p.parent()
            && !out.iter().any(|d| d == dir)
        {
            out.push(dir.to_path_buf());
        }
    }
    if own_is_temp {
        out.push(own);
    }
    out
}

fn label(schema: &Schema, number: u32, subcode: Option<u32>) -> String {
    let code = schema.display_code(number, subcode);
    match schema.code(number) {
        Some(c) if !c.name.is_empty() && schema.code_style == CodeStyle::Lenze => {
            format!("{code} {}", c.name)
        }
        _ => code,
    }
}

/// A finding that only says a base set could not be read (expected when
/// no anchor fits).
fn base_unreadable(f: &driveset_schema::Finding) -> bool {
    f.kind == FindingKind::BadExtends && f.message.contains("cannot be read")
}

fn semantic(l: &LoadedSet, extends: &[String]) -> Option<String> {
    let (schema, set) = (l.schema.as_ref()?, l.resolved.as_ref()?);
    let mut o = String::new();
    let _ = writeln!(o, "schema {}", schema.id);
    if let Some(t) = &l.title {
        let _ = writeln!(o, "title {}", serde_json::to_string(t).unwrap_or_default());
    }
    for e in extends {
        let _ = writeln!(o, "extends {e}");
    }
    for (key, raw) in &set.values {
        let value = match schema.code(key.number) {
            Some(c) => display_value(schema, c, raw),
            None => format!("{raw:?}"),
        };
        let _ = writeln!(o, "{} = {value}", label(schema, key.number, key.subcode));
    }
    for f in l.findings.iter().filter(|f| !base_unreadable(f)) {
        let at = if f.location.line > 0 {
            format!("line {}: ", f.location.line)
        } else {
            String::new()
        };
        let _ = writeln!(o, "! {}: {at}{}", f.kind.as_str(), f.message);
    }
    Some(o)
}

/// The `extends` entries the file names (for a header line each).
fn extends_of(text: &str, path: &Path) -> Vec<String> {
    use driveset_schema::doc::{self, NodeKind, Syntax};
    let Ok(source) =
        driveset_schema::error::source_from_bytes(&path.display().to_string(), text.into())
    else {
        return Vec::new();
    };
    let Ok(d) = doc::parse(source, Syntax::from_path(path)) else {
        return Vec::new();
    };
    match d.root.get("extends").map(|e| &e.value.kind) {
        Some(NodeKind::Str(s)) => vec![s.clone()],
        Some(NodeKind::Array(items)) => items
            .iter()
            .filter_map(|n| match &n.kind {
                NodeKind::Str(s) => Some(s.clone()),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// The semantic view of the set file at `path` (see the module docs); the
/// file's text unchanged when it is not a set driveset can read here.
/// `tracked` gives the tracked files of the repository git runs the
/// driver in (`git ls-files` joined to `git rev-parse --show-toplevel`;
/// none outside one), asked once the file is read.
pub fn render(
    path: &Path,
    registry: &Registry,
    tracked: impl FnOnce() -> Vec<PathBuf>,
) -> std::io::Result<String> {
    let bytes = driveset_schema::input::read_input(path, driveset_schema::input::InputKind::SET)
        .map_err(|e| std::io::Error::other(format!("{}; {}", e.message, e.help)))?;
    let Ok(text) = String::from_utf8(bytes.clone()) else {
        return Ok(String::from_utf8_lossy(&bytes).into_owned());
    };
    let name = original_name(path);
    let mut fallback: Option<LoadedSet> = None;
    for dir in anchors(path, &name, tracked) {
        let anchored = dir.join(&name);
        let mut reg = registry.clone();
        let Ok(l) = load_set_str(&anchored, &text, &mut reg) else {
            continue;
        };
        if l.schema.is_none() {
            continue;
        }
        if l.findings.is_empty() {
            return Ok(semantic(&l, &extends_of(&text, &anchored)).unwrap_or(text));
        }
        let better = |f: &LoadedSet| f.findings.len() > l.findings.len();
        if fallback.as_ref().is_none_or(better) {
            fallback = Some(l);
        }
    }
    Ok(match fallback {
        Some(l) => semantic(&l, &extends_of(&text, path)).unwrap_or(text),
        None => text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_git_temp_prefix_only_in_temp_dir() {
        let t = std::env::temp_dir();
        assert_eq!(
            original_name(&t.join("Ab3xYz_conveyor-3.toml")),
            "conveyor-3.toml"
        );
        assert_eq!(
            original_name(Path::new("sets/Ab3xYz_c.toml")),
            "Ab3xYz_c.toml"
        );
        assert_eq!(original_name(&t.join("short.toml")), "short.toml");
    }

    #[test]
    fn renders_names_and_units() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pump.toml");
        std::fs::write(
            &p,
            "schema = \"lenze-tmd\"\ntitle = \"Pump\"\n[values]\nC0011 = \"60 Hz\"\nC0010 = 5\n",
        )
        .unwrap();
        let reg = Registry::builtin().unwrap();
        let out = render(&p, &reg, Vec::new).unwrap();
        assert!(
            out.starts_with("schema lenze-tmd\ntitle \"Pump\"\n"),
            "{out}"
        );
        let c10 = out.find("C0010 ").unwrap();
        let c11 = out
            .find("C0011 maximum_output_frequency = 60 Hz\n")
            .unwrap();
        assert!(c10 < c11, "{out}");
        // not a set: the text unchanged
        std::fs::write(&p, "x = [").unwrap();
        assert_eq!(render(&p, &reg, Vec::new).unwrap(), "x = [");
    }
}
