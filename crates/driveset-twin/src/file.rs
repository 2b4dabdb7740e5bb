//! Writing a twin file (docs/twins.md, "Capturing again"): owns the
//! choice between keeping the file a twin replaces and writing the new
//! text ([`driveset_sim::twin::keep_or_replace`]: an unchanged drive keeps
//! its file byte-identical), the read of the old file through the one
//! reader and the write through the one writer
//! ([`driveset_schema::output`]), and a twin file's name in a directory
//! ([`path_in`]).

use std::path::{Path, PathBuf};

use driveset_schema::Schema;
use driveset_schema::output::{self, OutputError};
use driveset_sim::twin::{TWIN_SUFFIX, Twin, keep_or_replace};

/// What [`write()`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Written {
    /// The file was kept as it was (only stamps or reaction times inside
    /// the recorded range differed).
    pub unchanged: bool,
    /// The file's length in bytes.
    pub bytes: usize,
}

/// Why a twin file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum TwinWriteError {
    /// The target is not a regular file, or the file system refused it.
    #[error("{}: {}", .0.path.display(), .0.detail())]
    Output(OutputError),
    /// The file's directory could not be created.
    #[error("cannot create {}: {source}", dir.display())]
    CreateDir {
        /// The directory.
        dir: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// The twin file of the drive `name` in `dir`: `DIR/<name>.twin.toml`.
pub fn path_in(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}{TWIN_SUFFIX}"))
}

/// Write `twin` (read with `schema`) to `path`, or keep the file there
/// when it already says the same ([`keep_or_replace`]); the file it
/// replaces is read through the one reader (absent or unreadable: written
/// anew), the new one written through the one writer, its directory
/// created first.
///
/// # Errors
/// The target is not a regular file, its directory cannot be created, or
/// the file system refused the write.
pub fn write(path: &Path, twin: &Twin, schema: &Schema) -> Result<Written, TwinWriteError> {
    output::check_target(path).map_err(TwinWriteError::Output)?;
    let old = driveset_schema::input::read_input(path, driveset_schema::input::InputKind::TWIN)
        .ok()
        .and_then(|b| String::from_utf8(b).ok());
    let text = keep_or_replace(old.as_deref(), twin, Some(schema));
    let unchanged = old.as_deref() == Some(text.as_str());
    if !unchanged {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| TwinWriteError::CreateDir {
                dir: dir.to_path_buf(),
                source,
            })?;
        }
        output::write_output(path, text.as_bytes()).map_err(TwinWriteError::Output)?;
    }
    Ok(Written {
        unchanged,
        bytes: text.len(),
    })
}

#[cfg(test)]
mod tests {
    use driveset_schema::{CodeKey, RawValue, Registry};

    use super::*;

    #[test]
    fn a_second_write_of_the_same_twin_keeps_the_file() {
        let schema = Registry::builtin()
            .expect("built-in schemas")
            .get("lenze-tmd")
            .expect("tmd");
        let dir = tempfile::tempdir().expect("temp dir");
        let path = path_in(&dir.path().join("twins"), "conveyor-3");
        assert!(path.ends_with("twins/conveyor-3.twin.toml"));
        let mut twin = Twin::new(schema.family, 3, &schema.id);
        twin.values.insert(CodeKey::new(11), RawValue::Int(500_000));
        let first = write(&path, &twin, &schema).expect("written");
        assert!(!first.unchanged);
        let text = std::fs::read_to_string(&path).expect("file");
        assert_eq!(first.bytes, text.len());
        let again = write(&path, &twin, &schema).expect("kept");
        assert_eq!(
            again,
            Written {
                unchanged: true,
                bytes: text.len()
            }
        );
    }

    #[test]
    fn a_directory_in_the_way_is_refused_naming_the_file() {
        let schema = Registry::builtin()
            .expect("built-in schemas")
            .get("lenze-tmd")
            .expect("tmd");
        let dir = tempfile::tempdir().expect("temp dir");
        let twin = Twin::new(schema.family, 3, &schema.id);
        let e = write(dir.path(), &twin, &schema).expect_err("a directory");
        assert!(matches!(e, TwinWriteError::Output(_)), "{e:?}");
        assert!(
            e.to_string()
                .starts_with(&format!("{}: ", dir.path().display())),
            "{e}"
        );
    }
}
