//! A journal on disk (docs/journals.md): [`JournalFile`] (created,
//! replaced, opened, persisted durably), the one naming scheme
//! ([`journal_path`], "One name per drive"), the guard's scan for a
//! drive's unfinished journals ([`unfinished_for`], "The guard: one
//! transaction per drive") and the journal directory ([`ensure_dir`],
//! "Where journals live"). The file operations themselves are `store`'s.

use std::path::{Path, PathBuf};

use super::Mismatch;
use super::records::Journal;
use super::store;
use super::{JOURNAL_SUFFIX, JOURNAL_VERSION, OLDEST_JOURNAL_VERSION};
use crate::client::Target;
use crate::error::EngineError;

/// A journal on disk: the content and where it lives.
#[derive(Debug)]
pub struct JournalFile {
    path: PathBuf,
    /// The content last written.
    pub journal: Journal,
}

fn jerr(path: &Path, detail: impl Into<String>) -> EngineError {
    EngineError::journal(path.display().to_string(), detail.into())
}

impl JournalFile {
    /// Create a new journal at `path` and make it durable. Refuses to
    /// replace a journal of an unfinished transaction.
    pub fn create(path: &Path, journal: Journal) -> Result<Self, EngineError> {
        if store::exists(path) {
            match JournalFile::open(path) {
                Ok(existing) if !existing.journal.is_finished() => {
                    return Err(jerr(
                        path,
                        format!(
                            "holds an unfinished transaction (state {}); nothing was sent to the drive. Run `driveset recover {}` first",
                            existing.journal.state.as_str(),
                            path.display()
                        ),
                    ));
                }
                Ok(_) => {}
                Err(_) => {
                    return Err(jerr(
                        path,
                        "exists and is not a readable journal; nothing was sent to the drive. Move it away or choose another journal path",
                    ));
                }
            }
        }
        let f = JournalFile {
            path: path.to_path_buf(),
            journal,
        };
        f.persist()?;
        Ok(f)
    }

    /// Replace the journal at `path` with `journal` (the caller's own
    /// journal of this transaction: [`crate::transfer`] records a rate
    /// switch before the upload plans) and make it durable.
    pub fn replace(path: &Path, journal: Journal) -> Result<Self, EngineError> {
        let f = JournalFile {
            path: path.to_path_buf(),
            journal,
        };
        f.persist()?;
        Ok(f)
    }

    /// Read a journal (versions [`OLDEST_JOURNAL_VERSION`]..=[`JOURNAL_VERSION`]).
    pub fn open(path: &Path) -> Result<Self, EngineError> {
        let text = store::read(path).map_err(|e| jerr(path, e))?;
        let journal: Journal = serde_json::from_str(&text).map_err(|e| {
            jerr(
                path,
                format!("is not a driveset journal ({e}); pass the file `driveset upload` wrote"),
            )
        })?;
        if !(OLDEST_JOURNAL_VERSION..=JOURNAL_VERSION).contains(&journal.journal_version) {
            return Err(jerr(
                path,
                format!(
                    "has journal version {}, this driveset reads versions {OLDEST_JOURNAL_VERSION} to {JOURNAL_VERSION}; use the driveset release that wrote it",
                    journal.journal_version
                ),
            ));
        }
        Ok(JournalFile {
            path: path.to_path_buf(),
            journal,
        })
    }

    /// Where the journal lives.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Write the current content atomically and durably: temp file (0600),
    /// fsync, rename over the journal, fsync the directory.
    pub fn persist(&self) -> Result<(), EngineError> {
        let path = &self.path;
        let text = serde_json::to_string_pretty(&self.journal)
            .map_err(|e| jerr(path, format!("cannot encode it: {e}")))?;
        store::write_durable(path, &text).map_err(|(what, e)| {
            jerr(
                path,
                format!(
                    "cannot {what}: {e}; check the directory exists, is writable and has space"
                ),
            )
        })
    }
}

/// The journal file name of the drive at `address` on bus `bus_id`
/// (module docs, "One naming scheme"): the bus id's file stem
/// ([`driveset_link::bus_id::file_stem`]: every character but
/// `[A-Za-z0-9]` replaced by `_`, long ids cut with a hash), then
/// `-ADDRESS` and [`JOURNAL_SUFFIX`]. `tcp:127.0.0.1:4001` at 3 ->
/// `tcp_127_0_0_1_4001-3.journal.json`.
pub fn journal_file_name(bus_id: &str, address: u8) -> String {
    format!(
        "{}-{address}{JOURNAL_SUFFIX}",
        driveset_link::bus_id::file_stem(bus_id)
    )
}

/// `dir` joined with [`journal_file_name`].
pub fn journal_path(dir: &Path, bus_id: &str, address: u8) -> PathBuf {
    dir.join(journal_file_name(bus_id, address))
}

/// The journal directory a command uses: the one given (`--journal-dir`,
/// a line manifest's `journal_dir`), else [`super::DEFAULT_JOURNAL_DIR`]
/// under the current directory.
pub fn journal_dir_or_default(dir: Option<&Path>) -> PathBuf {
    dir.map_or_else(
        || PathBuf::from(super::DEFAULT_JOURNAL_DIR),
        Path::to_path_buf,
    )
}

/// Where a one-drive command's journal goes, as it was told
/// (docs/journals.md, "Where journals live"): a file named outright
/// (`--journal FILE`), else a directory (`--journal-dir DIR`, by default
/// [`super::DEFAULT_JOURNAL_DIR`]) the file is named in by the drive's
/// bus and address ([`journal_path`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum JournalAt {
    /// This file.
    File(PathBuf),
    /// A file named in this directory (`None`: the default one).
    Dir(Option<PathBuf>),
}

impl JournalAt {
    /// `file` when given (it wins over `dir`), else `dir`.
    pub fn new(file: Option<&Path>, dir: Option<&Path>) -> Self {
        match file {
            Some(f) => JournalAt::File(f.to_path_buf()),
            None => JournalAt::Dir(dir.map(Path::to_path_buf)),
        }
    }

    /// The journal's path for the drive at `address` on bus `bus_id`.
    pub fn path(&self, bus_id: &str, address: u8) -> PathBuf {
        match self {
            JournalAt::File(f) => f.clone(),
            JournalAt::Dir(dir) => {
                journal_path(&journal_dir_or_default(dir.as_deref()), bus_id, address)
            }
        }
    }
}

/// An unfinished journal of a drive, found by [`unfinished_for`].
#[derive(Debug, Clone)]
pub struct Unfinished {
    /// The file.
    pub path: PathBuf,
    /// Its content.
    pub journal: Journal,
}

/// Every journal in `dir` (not in subdirectories) of an unfinished
/// transaction of the drive at `address` on bus `bus` (reached through
/// `port`), found by content, not by file name (module docs), sorted by
/// path. A missing directory holds none; files that are not journals are
/// passed over.
pub fn unfinished_for(
    dir: &Path,
    bus: &str,
    port: &str,
    address: u8,
) -> Result<Vec<Unfinished>, EngineError> {
    let files = match store::json_files(dir) {
        Ok(Some(f)) => f,
        Ok(None) => return Ok(Vec::new()),
        Err(e) => {
            return Err(jerr(
                dir,
                format!(
                    "cannot list the journal directory: {e}; nothing was sent. Check it is readable"
                ),
            ));
        }
    };
    let mut out = Vec::new();
    for path in files {
        let Ok(jf) = JournalFile::open(&path) else {
            continue;
        };
        if !jf.journal.is_finished() && jf.journal.target.is_drive(bus, port, address) {
            out.push(Unfinished {
                path,
                journal: jf.journal,
            });
        }
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// The refusal for a drive with unfinished journals (nothing was sent).
pub fn unfinished_error(target: &Target, found: &[Unfinished]) -> EngineError {
    let list: Vec<String> = found
        .iter()
        .map(|u| format!("{} (state {})", u.path.display(), u.journal.state.as_str()))
        .collect();
    let first = found
        .first()
        .map(|u| u.path.display().to_string())
        .unwrap_or_default();
    EngineError::journal(
        first.clone(),
        format!(
            "the drive at {target} has an unfinished transaction ({}); nothing was sent. Run `driveset recover {first}` first",
            list.join(", ")
        ),
    )
}

/// Create the journal directory `dir` if it is missing; the topmost
/// directory this creates gets a `.gitignore` holding `*` (module docs).
/// An existing directory is left as it is.
pub fn ensure_dir(dir: &Path) -> Result<(), EngineError> {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    store::create_dir_ignored(dir).map_err(|(what, e)| {
        jerr(
            dir,
            format!("cannot {what}: {e}; nothing was sent. Check the directory can be created"),
        )
    })
}

/// [`Mismatch::Version`] for a journal that records no bus (version 1).
pub(crate) fn version_refusal(target: &Target, path: &Path, version: u32) -> EngineError {
    EngineError::not_journal_drive(
        target.clone(),
        path.display().to_string(),
        Mismatch::Version,
        format!(
            "it has journal version {version}, which does not record the drive's bus, so driveset cannot check that it reaches the drive the journal was written for; nothing was sent. Finish it with the driveset release that wrote it, or restore the drive by hand from the journal's backup"
        ),
    )
}
