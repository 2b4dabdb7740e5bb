//! Owns the walk from a path given on the command line to the files under
//! it that `driveset validate`, `schema check` and the editor's
//! associations read: set, schema and manifest files (`*.toml`, `*.yaml`,
//! `*.yml`), each real path once, hidden entries skipped; the schema files
//! of `schema check`'s paths ([`schema_files`]). Nothing is opened here:
//! reading is [`crate::input`]'s.

use std::path::{Path, PathBuf};

use crate::error::{InputError, InputErrorKind, Location};

/// Set and schema file extensions searched in directories.
const EXTENSIONS: [&str; 3] = ["toml", "yaml", "yml"];

/// Files under `path` (a file as given, a directory recursively, sorted).
///
/// Each real path is visited once: directories and files are keyed by their
/// canonical path, so a symlink loop (`a/loop -> ..`) or two links back to a
/// parent cost one visit each instead of an endless or exponential walk.
/// Hidden entries are skipped. Entries are not opened here: a FIFO, socket
/// or device file named `*.toml` is listed and then refused by the reader
/// (exit 2, "not a regular file") without ever being opened.
pub fn collect(path: &Path, out: &mut Vec<PathBuf>) -> Result<(), InputError> {
    let mut visited = std::collections::HashSet::new();
    walk(path, out, &mut visited)
}

fn walk(
    path: &Path,
    out: &mut Vec<PathBuf>,
    visited: &mut std::collections::HashSet<PathBuf>,
) -> Result<(), InputError> {
    let meta = std::fs::metadata(path)
        .map_err(|e| unreadable(path, format!("cannot read {}: {e}", path.display())))?;
    let real = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if !visited.insert(real) {
        return Ok(());
    }
    if !meta.is_dir() {
        out.push(path.to_path_buf());
        return Ok(());
    }
    let rd = std::fs::read_dir(path).map_err(|e| {
        unreadable(
            path,
            format!("cannot read directory {}: {e}", path.display()),
        )
    })?;
    let mut entries: Vec<PathBuf> = rd.filter_map(Result::ok).map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        let hidden = p
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with('.'));
        if hidden {
            continue;
        }
        // metadata follows symlinks; a dangling link is listed (the reader
        // then says it cannot be read)
        if std::fs::metadata(&p).is_ok_and(|m| m.is_dir()) {
            walk(&p, out, visited)?;
        } else if p
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        {
            let real = std::fs::canonicalize(&p).unwrap_or_else(|_| p.clone());
            if visited.insert(real) {
                out.push(p);
            }
        }
    }
    Ok(())
}

/// The schema files `schema check` reads for `paths`: a file as given, a
/// directory's `*.toml` files ([`collect`]); and each directory that could
/// not be walked whole with its error (the files found before it are kept).
pub fn schema_files(paths: &[PathBuf]) -> (Vec<PathBuf>, Vec<(PathBuf, InputError)>) {
    let (mut files, mut failed) = (Vec::new(), Vec::new());
    for p in paths {
        if !p.is_dir() {
            files.push(p.clone());
            continue;
        }
        let mut found = Vec::new();
        if let Err(e) = collect(p, &mut found) {
            failed.push((p.clone(), e));
        }
        files.extend(
            found
                .into_iter()
                .filter(|f| f.extension().is_some_and(|e| e == "toml")),
        );
    }
    (files, failed)
}

/// An input error of the walk itself (a path that cannot be read).
fn unreadable(path: &Path, message: String) -> InputError {
    InputError {
        kind: InputErrorKind::Unreadable,
        message,
        help: "check the path".to_string(),
        location: Box::new(Location::file_only(path.display().to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schema_files_are_the_tomls_of_a_directory_and_files_as_given() {
        let dir = std::env::temp_dir().join(format!("driveset-walk-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).expect("dir");
        for f in ["a.toml", "b.yaml", "sub/c.toml", ".hidden.toml"] {
            std::fs::write(dir.join(f), "").expect("file");
        }
        let given = dir.join("b.yaml");
        let missing = dir.join("missing");
        let (files, failed) = schema_files(&[dir.clone(), given.clone(), missing.clone()]);
        assert_eq!(
            files,
            [dir.join("a.toml"), dir.join("sub/c.toml"), given, missing]
        );
        assert!(failed.is_empty());
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
