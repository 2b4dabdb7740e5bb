//! Every file operation on journals (the parent module's docs, "The one
//! place of file IO"; docs/journals.md, "The file": rewritten atomically,
//! temp file, fsync, rename, fsync of the directory; mode 0600). Errors
//! name what failed, for the caller's message. The engine's one file of
//! file IO: `tests/integration/tidy.rs` lets it alone.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

pub(super) fn exists(path: &Path) -> bool {
    path.exists()
}

/// The journal's text, through the schema crate's one file reader
/// (regular files only, at most 16 MiB, never a blocking open).
pub(super) fn read(path: &Path) -> Result<String, String> {
    use driveset_schema::input::{InputKind, read_input};
    let bytes = read_input(path, InputKind::JOURNAL).map_err(|e| e.detail())?;
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "is not text (invalid UTF-8 at byte {}); pass the file `driveset upload` wrote",
            e.utf8_error().valid_up_to()
        )
    })
}

/// Write `text` and a newline to `path` atomically and durably: temp
/// file `<path>.tmp` (mode 0600), fsync, rename over `path`, fsync the
/// directory.
pub(super) fn write_durable(path: &Path, text: &str) -> Result<(), (&'static str, io::Error)> {
    let mut tmp_name = path.as_os_str().to_owned();
    tmp_name.push(".tmp");
    let tmp = PathBuf::from(tmp_name);
    {
        let mut opts = OpenOptions::new();
        opts.write(true).create(true).truncate(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            opts.mode(0o600);
        }
        let mut f = opts
            .open(&tmp)
            .map_err(|e| ("create the temporary file", e))?;
        // An existing temp file keeps its old mode: force 0600.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            f.set_permissions(fs::Permissions::from_mode(0o600))
                .map_err(|e| ("restrict the temporary file to mode 0600", e))?;
        }
        f.write_all(text.as_bytes())
            .and_then(|()| f.write_all(b"\n"))
            .map_err(|e| ("write the temporary file", e))?;
        f.sync_all()
            .map_err(|e| ("flush the temporary file to disk", e))?;
    }
    fs::rename(&tmp, path).map_err(|e| ("rename the temporary file over the journal", e))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // Directory fsync makes the rename durable (Unix; a no-op elsewhere).
    #[cfg(unix)]
    File::open(&dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| ("flush the journal's directory to disk", e))?;
    #[cfg(not(unix))]
    let _ = (&dir, File::open);
    Ok(())
}

/// The regular files named `*.json` directly in `dir`; `None` when
/// `dir` does not exist.
pub(super) fn json_files(dir: &Path) -> io::Result<Option<Vec<PathBuf>>> {
    let entries = match fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    Ok(Some(
        entries
            .flatten()
            .filter(|e| {
                e.file_name().to_string_lossy().ends_with(".json")
                    && e.file_type().is_ok_and(|t| t.is_file())
            })
            .map(|e| e.path())
            .collect(),
    ))
}

/// Create `dir` if it is missing; the topmost directory this creates
/// gets a `.gitignore` holding `*`. An existing directory is left as it
/// is.
pub(super) fn create_dir_ignored(dir: &Path) -> Result<(), (&'static str, io::Error)> {
    if dir.is_dir() {
        return Ok(());
    }
    // the topmost missing ancestor
    let mut top = dir.to_path_buf();
    while let Some(parent) = top.parent() {
        if parent.as_os_str().is_empty() || parent.exists() {
            break;
        }
        top = parent.to_path_buf();
    }
    fs::create_dir_all(dir).map_err(|e| ("create the journal directory", e))?;
    fs::write(
        top.join(".gitignore"),
        "# written by driveset: journals hold old values, passwords included\n*\n",
    )
    .map_err(|e| ("write its .gitignore", e))
}
