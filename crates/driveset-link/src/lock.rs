//! Owns the advisory lock per bus ([`BusLock`]): two processes never drive
//! one bus at once, however each spelled its port. The lock is an
//! exclusive `flock` on `DIR/<bus id stem>.lock` ([`crate::bus_id::file_stem`]
//! of the link's [`crate::ByteLink::bus_id`] / [`crate::FrameLink::bus_id`]),
//! so `/dev/ttyUSB0` and a `/dev/serial/by-id/...` symlink to it, or
//! `tcp://localhost:P` and `tcp://127.0.0.1:P`, take one lock. The
//! directory is [`lock_dir`]: `DRIVESET_LOCK_DIR`, else
//! `$XDG_RUNTIME_DIR/driveset`, else `driveset-locks-USER` in the system's
//! temporary directory (one per user and machine, not per journal
//! directory, so two commands with different `--journal-dir` still exclude
//! each other; two users' commands on one serial port are kept apart by
//! `TIOCEXCL`).
//!
//! The holder writes who it is into the file (pid, command, since when);
//! a refused command reads it back to name the holder. The kernel drops
//! the lock when the holder's file is closed, also when the process is
//! killed (`kill -9`): a stale file is never a stale lock.
//!
//! Serial ports are also opened with `TIOCEXCL` ([`crate::serial`]), which
//! keeps out even programs that know nothing of this lock.

use std::fs::{File, OpenOptions};
use std::io::{Read as _, Seek as _, Write as _};
use std::path::{Path, PathBuf};

/// Who holds a bus lock, as written into the lock file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Holder {
    /// Process id.
    pub pid: u32,
    /// The command (`driveset upload`), without its arguments.
    pub command: String,
    /// When it took the lock (RFC 3339, as the holder wrote it).
    pub since: String,
}

impl Holder {
    fn to_text(&self) -> String {
        format!(
            "pid={}\ncommand={}\nsince={}\n",
            self.pid,
            one_line(&self.command),
            one_line(&self.since)
        )
    }

    /// The holder a lock file names; `None` for a file being written or
    /// not written by [`BusLock::acquire`].
    fn parse(text: &str) -> Option<Holder> {
        let mut pid = None;
        let mut command = None;
        let mut since = None;
        for line in text.lines() {
            match line.split_once('=') {
                Some(("pid", v)) => pid = v.parse().ok(),
                Some(("command", v)) => command = Some(v.to_string()),
                Some(("since", v)) => since = Some(v.to_string()),
                _ => {}
            }
        }
        Some(Holder {
            pid: pid?,
            command: command?,
            since: since?,
        })
    }
}

impl std::fmt::Display for Holder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pid {} (`{}`, since {})",
            self.pid, self.command, self.since
        )
    }
}

/// Control characters of a holder's text as `?`: the file is one field a
/// line, and its text reaches a terminal in the refusal.
fn one_line(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect()
}

/// Why a bus lock was not taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds the bus.
    #[error(
        "bus `{bus}` is in use by {}; nothing was sent. Wait until that command ends (or stop it), then run this one again (lock {})",
        holder.as_ref().map_or_else(|| "another process".to_string(), |h| format!("another process: {h}")),
        path.display()
    )]
    Held {
        /// The bus id.
        bus: String,
        /// The lock file.
        path: PathBuf,
        /// Who holds it, if the file says.
        holder: Option<Holder>,
    },
    /// The lock directory or file cannot be used.
    #[error(
        "cannot lock bus `{bus}`: {what} {}: {source}; nothing was sent. Make the directory writable or set DRIVESET_LOCK_DIR to one that is",
        path.display()
    )]
    Io {
        /// The bus id.
        bus: String,
        /// What failed.
        what: &'static str,
        /// The directory or file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
}

/// The directory bus locks live in (module docs): `DRIVESET_LOCK_DIR`,
/// else `$XDG_RUNTIME_DIR/driveset`, else `driveset-locks-USER` in
/// [`std::env::temp_dir`] (per user, as the runtime directory is: a
/// directory another user created could not take this user's lock files).
pub fn lock_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("DRIVESET_LOCK_DIR").filter(|d| !d.is_empty()) {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_RUNTIME_DIR").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join("driveset");
    }
    let user = ["USER", "LOGNAME"]
        .iter()
        .find_map(|k| std::env::var(k).ok().filter(|u| !u.is_empty()))
        .map_or_else(|| "default".to_string(), |u| crate::bus_id::file_stem(&u));
    std::env::temp_dir().join(format!("driveset-locks-{user}"))
}

/// The lock file of bus `bus_id` in `dir`.
pub fn lock_path(dir: &Path, bus_id: &str) -> PathBuf {
    dir.join(format!("{}.lock", crate::bus_id::file_stem(bus_id)))
}

/// A held bus lock; dropping it (or the process ending) releases it.
#[derive(Debug)]
pub struct BusLock {
    bus: String,
    path: PathBuf,
    _file: File,
}

impl BusLock {
    /// Take the lock of bus `bus_id` in `dir` (created if missing) for
    /// `holder`, without waiting: [`LockError::Held`] naming the holder
    /// when another open file holds it (another process, or another
    /// [`BusLock`] of this one).
    pub fn acquire(dir: &Path, bus_id: &str, holder: &Holder) -> Result<BusLock, LockError> {
        let io = |what, path: &Path| {
            let bus = bus_id.to_string();
            let path = path.to_path_buf();
            move |source| LockError::Io {
                bus,
                what,
                path,
                source,
            }
        };
        std::fs::create_dir_all(dir).map_err(io("create the lock directory", dir))?;
        let path = lock_path(dir, bus_id);
        let mut file = open_lock_file(&path).map_err(io("open the lock file", &path))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut text = String::new();
                let _ = file.read_to_string(&mut text);
                return Err(LockError::Held {
                    bus: bus_id.to_string(),
                    path,
                    holder: Holder::parse(&text),
                });
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(io("lock the lock file", &path)(e));
            }
        }
        let written = file
            .set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| file.write_all(holder.to_text().as_bytes()))
            .and_then(|()| file.flush());
        written.map_err(io("write the lock file", &path))?;
        Ok(BusLock {
            bus: bus_id.to_string(),
            path,
            _file: file,
        })
    }

    /// The bus locked.
    pub fn bus(&self) -> &str {
        &self.bus
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Open (or create) a lock file read-write, mode 0644 (the holder's pid
/// and command are no secret; another user's refused command can name
/// them).
fn open_lock_file(path: &Path) -> std::io::Result<File> {
    let mut o = OpenOptions::new();
    o.read(true).write(true).create(true).truncate(false);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        o.mode(0o644);
    }
    o.open(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn holder(pid: u32) -> Holder {
        Holder {
            pid,
            command: "driveset upload".into(),
            since: "2026-12-02T06:00:00.000Z".into(),
        }
    }

    #[test]
    fn a_second_lock_of_one_bus_is_refused_naming_the_holder_until_the_first_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let first = BusLock::acquire(dir.path(), "tcp:127.0.0.1:4001", &holder(41)).unwrap();
        assert_eq!(first.path(), dir.path().join("tcp_127_0_0_1_4001.lock"));
        let err = BusLock::acquire(dir.path(), "tcp:127.0.0.1:4001", &holder(42)).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "bus `tcp:127.0.0.1:4001` is in use by another process: pid 41 (`driveset upload`, since 2026-12-02T06:00:00.000Z); nothing was sent. Wait until that command ends (or stop it), then run this one again (lock {})",
                first.path().display()
            )
        );
        // another bus is free
        let other = BusLock::acquire(dir.path(), "tcp:127.0.0.1:4002", &holder(42)).unwrap();
        assert_eq!(other.bus(), "tcp:127.0.0.1:4002");
        drop(first);
        let again = BusLock::acquire(dir.path(), "tcp:127.0.0.1:4001", &holder(43)).unwrap();
        let text = std::fs::read_to_string(again.path()).unwrap();
        assert_eq!(
            text,
            "pid=43\ncommand=driveset upload\nsince=2026-12-02T06:00:00.000Z\n"
        );
    }

    #[test]
    fn a_holder_text_with_control_characters_stays_one_field_a_line() {
        let h = Holder {
            pid: 7,
            command: "driveset\nupload\x1b[2J".into(),
            since: "now".into(),
        };
        assert_eq!(
            h.to_text(),
            "pid=7\ncommand=driveset?upload?[2J\nsince=now\n"
        );
        assert_eq!(Holder::parse("pid=7\n"), None);
        assert_eq!(Holder::parse(&holder(9).to_text()), Some(holder(9)));
    }

    #[test]
    fn a_directory_that_cannot_be_made_is_an_io_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("f");
        std::fs::write(&file, "").unwrap();
        let err = BusLock::acquire(&file.join("sub"), "can:can0", &holder(1)).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.starts_with(&format!(
                "cannot lock bus `can:can0`: create the lock directory {}: ",
                file.join("sub").display()
            )),
            "{msg}"
        );
        assert!(msg.ends_with("; nothing was sent. Make the directory writable or set DRIVESET_LOCK_DIR to one that is"), "{msg}");
    }
}
