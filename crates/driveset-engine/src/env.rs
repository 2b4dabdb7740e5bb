//! The world a line run needs beyond its links and their clocks: wall-clock
//! time for the report's `started` / `finished` and the resume state's
//! `verified_at`, the git commit of the sets, the small files a line
//! run keeps (the resume state, learned schemas), and the plant history
//! its drives go on record in ([`crate::history`]). The engine does none of
//! this itself: the CLI implements [`Environment`] (system time, `git`,
//! the file system), tests implement it with a fixed time.
//!
//! The journal is not here: it is the engine's durable store, with its own
//! durability rules, and keeps its file operations in one place
//! ([`crate::journal`]'s store functions).

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use crate::history::History;
use crate::line::report::GitInfo;

/// What a line run asks of the world (module docs).
pub trait Environment: Send + Sync {
    /// Now, wall-clock UTC.
    fn now_utc(&self) -> jiff::Timestamp;

    /// HEAD and dirtiness of the git work tree holding `dir` (an empty path
    /// is the current directory); `None` outside a work tree.
    fn git_info(&self, dir: &Path) -> Option<GitInfo>;

    /// The text of the file at `path`; `Ok(None)` when there is none.
    fn read_file(&self, path: &Path) -> io::Result<Option<String>>;

    /// Write `text` to `path` so that a reader sees the old or the new
    /// file, never part of one (temp file, rename), creating the parent
    /// directories.
    fn write_file(&self, path: &Path, text: &str) -> io::Result<()>;

    /// Create the directory `dir` and its parents.
    fn create_dir(&self, dir: &Path) -> io::Result<()>;

    /// Where the run's drives go on record ([`crate::history`]): the
    /// session the front end opened for this run; none when history is off.
    fn history(&self) -> Option<&dyn History> {
        None
    }
}

/// An [`Environment`] whose [`history`](Environment::history) is
/// `history` (the session the front end opened for this run; none when
/// history is off or no session is open) and everything else `inner`'s:
/// the front end's system environment, recording.
#[derive(Debug, Clone, Default)]
pub struct WithHistory<E, H> {
    /// The clock, git and the files.
    pub inner: E,
    /// The run's record.
    pub history: Option<H>,
}

impl<E: Environment, H: History> Environment for WithHistory<E, H> {
    fn now_utc(&self) -> jiff::Timestamp {
        self.inner.now_utc()
    }

    fn git_info(&self, dir: &Path) -> Option<GitInfo> {
        self.inner.git_info(dir)
    }

    fn read_file(&self, path: &Path) -> io::Result<Option<String>> {
        self.inner.read_file(path)
    }

    fn write_file(&self, path: &Path, text: &str) -> io::Result<()> {
        self.inner.write_file(path, text)
    }

    fn create_dir(&self, dir: &Path) -> io::Result<()> {
        self.inner.create_dir(dir)
    }

    fn history(&self) -> Option<&dyn History> {
        self.history.as_ref().map(|h| h as &dyn History)
    }
}

/// An [`Environment`] that touches nothing: a fixed wall-clock time, the
/// git commit it is given, files in memory. For tests and benchmarks (the
/// way `VirtualClock` stands in for a real clock); one value shared by
/// several runs keeps their files, so a resumed run sees its state.
#[derive(Debug)]
pub struct Memory {
    now: jiff::Timestamp,
    git: Option<GitInfo>,
    files: Mutex<BTreeMap<PathBuf, String>>,
}

impl Memory {
    /// Always `now`, outside any git work tree, no files.
    pub fn at(now: jiff::Timestamp) -> Self {
        Memory {
            now,
            git: None,
            files: Mutex::new(BTreeMap::new()),
        }
    }

    /// Report `git` for every directory.
    pub fn with_git(mut self, git: GitInfo) -> Self {
        self.git = Some(git);
        self
    }

    /// The file at `path`, if one was written.
    pub fn file(&self, path: &Path) -> Option<String> {
        self.lock().get(path).cloned()
    }

    /// The paths written, in order.
    pub fn paths(&self) -> Vec<PathBuf> {
        self.lock().keys().cloned().collect()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<PathBuf, String>> {
        self.files.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl Environment for Memory {
    fn now_utc(&self) -> jiff::Timestamp {
        self.now
    }

    fn git_info(&self, _dir: &Path) -> Option<GitInfo> {
        self.git.clone()
    }

    fn read_file(&self, path: &Path) -> io::Result<Option<String>> {
        Ok(self.file(path))
    }

    fn write_file(&self, path: &Path, text: &str) -> io::Result<()> {
        self.lock().insert(path.to_path_buf(), text.to_string());
        Ok(())
    }

    fn create_dir(&self, _dir: &Path) -> io::Result<()> {
        Ok(())
    }
}

/// A wall-clock instant as reports write it: RFC 3339, UTC, milliseconds
/// (`2026-12-01T22:44:20.123Z`).
pub fn rfc3339(t: jiff::Timestamp) -> String {
    format!("{t:.3}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_has_milliseconds_and_z() {
        let t: jiff::Timestamp = "2026-12-01T22:44:20.1234Z".parse().unwrap();
        assert_eq!(rfc3339(t), "2026-12-01T22:44:20.123Z");
        let t = jiff::Timestamp::from_second(0).unwrap();
        assert_eq!(rfc3339(t), "1970-01-01T00:00:00.000Z");
        // a leap-year day the hand-written civil-from-days code had to get right
        let t: jiff::Timestamp = "2024-02-29T23:59:59.999Z".parse().unwrap();
        assert_eq!(rfc3339(t), "2024-02-29T23:59:59.999Z");
    }
}
