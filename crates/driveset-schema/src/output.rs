//! The one writer of every file driveset writes (sets, schemas, twins,
//! reports, JSON Schemas, line state, simulator state and logs), beside the
//! one reader ([`crate::input`]). A target that exists and is not a regular
//! file (FIFO, socket, device, directory, symlink loop) is refused from its
//! metadata without being opened ([`check_target`], which commands call
//! while resolving their arguments, before a bus is opened); a symlink is
//! followed to the file it names, which is replaced, not the link; the
//! bytes go to a temporary file beside that file, are fsynced and renamed
//! over it, then the directory is fsynced; the file keeps the mode of the
//! file it replaces (a new file gets `0666` less the umask, or `0600` for
//! [`write_private`]). docs/file-formats.md, "Output files". The journal
//! keeps its own store (driveset-engine `journal/store.rs`), which holds
//! the same rules.

use std::io::Write as _;
use std::path::{Path, PathBuf};

/// How many symlinks are followed before a target is called a loop (the
/// kernel's own limit, `MAXSYMLINKS`).
const MAX_HOPS: usize = 40;

/// What is wrong with an output target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputErrorKind {
    /// The target exists and is not a regular file (FIFO, socket, device,
    /// directory) or is a symlink loop.
    NotRegularFile,
    /// The file system refused an operation (permissions, space, a missing
    /// directory).
    Io,
}

/// A file driveset cannot write: which, what is wrong, what to do.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message} (help: {help})")]
pub struct OutputError {
    /// What kind of failure.
    pub kind: OutputErrorKind,
    /// The target as given.
    pub path: PathBuf,
    /// What is wrong, naming the file.
    pub message: String,
    /// What to do.
    pub help: String,
}

impl OutputError {
    /// The message without the file's name (`is a FIFO (named pipe), ...`),
    /// and the help, for a caller whose own message names the file
    /// (`-o FILE: ...`).
    pub fn detail(&self) -> String {
        let file = self.path.display().to_string();
        let m = self
            .message
            .strip_prefix(&format!("{file} "))
            .unwrap_or(&self.message);
        format!("{m}; {}", self.help)
    }

    fn not_regular(path: &Path, is: &str) -> Self {
        let file = path.display();
        OutputError {
            kind: OutputErrorKind::NotRegularFile,
            path: path.into(),
            message: format!(
                "{file} is {is}, not a regular file; driveset writes only regular files"
            ),
            help: "give the path of a regular file or of one that does not exist yet".into(),
        }
    }

    fn io(path: &Path, op: &str, e: &std::io::Error) -> Self {
        OutputError {
            kind: OutputErrorKind::Io,
            path: path.into(),
            message: format!("cannot write {}: {op}: {e}", path.display()),
            help: "check the directory exists and that you may write in it".into(),
        }
    }
}

/// What a file type is when it is not a regular file (`None` for one).
fn what_is(ft: std::fs::FileType) -> Option<&'static str> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if ft.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if ft.is_socket() {
            return Some("a socket");
        }
        if ft.is_char_device() {
            return Some("a character device");
        }
        if ft.is_block_device() {
            return Some("a block device");
        }
    }
    if ft.is_dir() {
        return Some("a directory");
    }
    (!ft.is_file()).then_some("not a regular file")
}

/// The file a write to `path` replaces: `path` itself, or the file its
/// symlinks name (followed hop by hop, so a dangling link names the file it
/// will create), and that file's metadata when it exists.
fn resolve(path: &Path) -> Result<(PathBuf, Option<std::fs::Metadata>), OutputError> {
    let mut at = path.to_path_buf();
    for _ in 0..MAX_HOPS {
        let meta = match std::fs::symlink_metadata(&at) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((at, None)),
            Err(e) => return Err(OutputError::io(path, "cannot look at it", &e)),
        };
        if !meta.file_type().is_symlink() {
            if let Some(is) = what_is(meta.file_type()) {
                return Err(OutputError::not_regular(path, is));
            }
            return Ok((at, Some(meta)));
        }
        let link = std::fs::read_link(&at)
            .map_err(|e| OutputError::io(path, "cannot read the symlink", &e))?;
        at = match at.parent() {
            Some(dir) if link.is_relative() => dir.join(link),
            _ => link,
        };
    }
    Err(OutputError::not_regular(path, "a symlink loop"))
}

/// Checks, from metadata only, that `path` can be written: it does not
/// exist, or is (or names through its symlinks) a regular file. Commands
/// call it for each output argument while resolving their arguments, so a
/// FIFO, device, directory or symlink loop is refused (exit 2) before any
/// bus is opened.
///
/// # Errors
/// [`OutputErrorKind::NotRegularFile`] saying what is there.
pub fn check_target(path: &Path) -> Result<(), OutputError> {
    resolve(path).map(|_| ())
}

/// Writes `bytes` to `path` ([`check_target`] first): temporary file beside
/// the file written, fsync, rename, directory fsync. A new file gets `0666`
/// less the umask; a replaced file keeps its mode.
///
/// # Errors
/// [`OutputError`]: not a regular file, or the file system's refusal.
pub fn write_output(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_with_mode(path, bytes, 0o666)
}

/// [`write_output`] for a file that holds secrets (simulator state: a
/// drive's memory holds its passwords): a new file is `0600`; a replaced
/// file keeps its mode.
///
/// # Errors
/// As [`write_output`].
pub fn write_private(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_with_mode(path, bytes, 0o600)
}

fn write_with_mode(path: &Path, bytes: &[u8], new_mode: u32) -> Result<(), OutputError> {
    let (target, old) = resolve(path)?;
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let (tmp, mut file) = create_temp(&dir, &name, new_mode)
        .map_err(|e| OutputError::io(path, "cannot create a temporary file beside it", &e))?;
    let result = (|| {
        if let Some(old) = &old {
            file.set_permissions(old.permissions())
                .map_err(|e| ("cannot keep its mode", e))?;
        }
        file.write_all(bytes).map_err(|e| ("write", e))?;
        file.sync_all().map_err(|e| ("fsync", e))?;
        drop(file);
        std::fs::rename(&tmp, &target).map_err(|e| ("rename the temporary file over it", e))
    })();
    if let Err((op, e)) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(OutputError::io(path, op, &e));
    }
    // the rename is durable once the directory is synced (best effort: not
    // every file system lets a directory be opened)
    if let Ok(d) = std::fs::File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// A new temporary file `.NAME.PID.N.tmp` in `dir`, never an existing one.
fn create_temp(dir: &Path, name: &str, mode: u32) -> std::io::Result<(PathBuf, std::fs::File)> {
    let mut n = 0u32;
    loop {
        let tmp = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
        let mut opts = std::fs::OpenOptions::new();
        opts.write(true).create_new(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt as _;
            opts.mode(mode);
        }
        #[cfg(not(unix))]
        let _ = mode;
        match opts.open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && n < 100 => n += 1,
            Err(e) => return Err(e),
        }
    }
}

/// Opens a log that is written as it grows (the simulator's `--log`), so
/// it cannot be renamed into place: [`check_target`] first (a FIFO or
/// device is refused, never opened), then created or truncated `0600` (a
/// bus capture; an existing file is restricted to `0600` too).
///
/// # Errors
/// As [`write_output`].
pub fn create_log(path: &Path) -> Result<std::fs::File, OutputError> {
    let (target, _) = resolve(path)?;
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create(true).truncate(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        // never block on a FIFO swapped in after the check
        opts.mode(0o600).custom_flags(libc::O_NONBLOCK);
    }
    let file = opts
        .open(&target)
        .map_err(|e| OutputError::io(path, "cannot create it", &e))?;
    let meta = file
        .metadata()
        .map_err(|e| OutputError::io(path, "cannot look at it", &e))?;
    if let Some(is) = what_is(meta.file_type()) {
        return Err(OutputError::not_regular(path, is));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        file.set_permissions(std::fs::Permissions::from_mode(0o600))
            .map_err(|e| OutputError::io(path, "cannot restrict it to 0600", &e))?;
    }
    Ok(file)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt as _;

    fn mode(p: &Path) -> u32 {
        std::fs::metadata(p).unwrap().permissions().mode() & 0o777
    }

    #[test]
    fn a_symlink_is_followed_and_the_mode_is_kept() {
        let d = tempfile::tempdir().unwrap();
        let real = d.path().join("real.toml");
        write_output(&real, b"old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = d.path().join("link.toml");
        std::os::unix::fs::symlink("real.toml", &link).unwrap();
        write_output(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        assert_eq!(mode(&real), 0o640);
        // no temporary file left behind
        let names: Vec<String> = std::fs::read_dir(d.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        // a dangling link names the file it creates
        let dangling = d.path().join("dangling");
        std::os::unix::fs::symlink("made.toml", &dangling).unwrap();
        write_private(&dangling, b"x").unwrap();
        assert_eq!(std::fs::read(d.path().join("made.toml")).unwrap(), b"x");
        assert_eq!(mode(&d.path().join("made.toml")), 0o600);
    }

    #[test]
    fn special_targets_and_loops_are_refused_without_being_opened() {
        let d = tempfile::tempdir().unwrap();
        let fifo = d.path().join("f");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        let e = write_output(&fifo, b"x").unwrap_err();
        assert_eq!(e.kind, OutputErrorKind::NotRegularFile);
        assert_eq!(
            e.detail(),
            "is a FIFO (named pipe), not a regular file; driveset writes only regular files; give the path of a regular file or of one that does not exist yet"
        );
        let loop_a = d.path().join("a");
        std::os::unix::fs::symlink("b", &loop_a).unwrap();
        std::os::unix::fs::symlink("a", d.path().join("b")).unwrap();
        let e = check_target(&loop_a).unwrap_err();
        assert!(
            e.message.ends_with(
                " is a symlink loop, not a regular file; driveset writes only regular files"
            ),
            "{}",
            e.message
        );
        let zero = d.path().join("z");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        assert!(
            check_target(&zero)
                .unwrap_err()
                .message
                .contains("is a character device")
        );
        assert!(
            check_target(d.path())
                .unwrap_err()
                .message
                .contains("is a directory")
        );
        assert!(create_log(&fifo).is_err());
        assert!(check_target(&d.path().join("new")).is_ok());
    }
}
