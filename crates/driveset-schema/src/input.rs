//! The one reader of every file a command is given (sets, schemas, line
//! manifests, EDS / DCF files, journals, bus captures, simulator state):
//! regular files only, a size cap per kind of file ([`InputKind`]) checked
//! on the file's size before a byte is read, and never a blocking open (a
//! FIFO, socket, device or directory is refused from its metadata, without
//! being opened; the open itself is `O_NONBLOCK`). Every crate reads its
//! input files through [`read_input`]; docs/file-formats.md, "Input files",
//! lists the kinds and caps.

use crate::error::{InputError, InputErrorKind, Location};

/// A kind of input file: what it is called in messages and the most bytes
/// driveset reads of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputKind {
    /// What files of this kind are, plural, for messages ("journals").
    pub what: &'static str,
    /// The largest file accepted, in bytes.
    pub cap: u64,
}

const MIB: u64 = 1024 * 1024;

impl InputKind {
    /// Parameter sets, schemas and line manifests (4 MiB: the largest
    /// built-in schema is about 150 kB).
    pub const SET: InputKind = InputKind {
        what: "parameter sets, schemas and line manifests",
        cap: crate::error::MAX_FILE_BYTES,
    };
    /// Upload journals (16 MiB: a journal holds two values per code).
    pub const JOURNAL: InputKind = InputKind {
        what: "journals",
        cap: 16 * MIB,
    };
    /// CiA 306 EDS / DCF files (16 MiB: real ones are tens to hundreds of kB).
    pub const EDS: InputKind = InputKind {
        what: "EDS / DCF files",
        cap: crate::eds::reader::MAX_BYTES as u64,
    };
    /// Bus captures for `driveset decode` (16 MiB of bytes: 48 minutes at
    /// 57600 baud).
    pub const CAPTURE: InputKind = InputKind {
        what: "bus captures",
        cap: 16 * MIB,
    };
    /// Line reports read back by `driveset report` (64 MiB: a report holds
    /// every drive's values and timeline).
    pub const REPORT: InputKind = InputKind {
        what: "line reports",
        cap: 64 * MIB,
    };
    /// The line runner's own small files: resume state
    /// (`.commission-state.json`) and learned schemas (16 MiB).
    pub const LINE_STATE: InputKind = InputKind {
        what: "line state files and learned schemas",
        cap: 16 * MIB,
    };
    /// Twin files (`NAME.twin.toml`: one drive's values, about 100 kB for
    /// the largest family; 4 MiB).
    pub const TWIN: InputKind = InputKind {
        what: "twin files",
        cap: 4 * MIB,
    };
    /// Small settings files `git-setup` updates in place (`.gitattributes`,
    /// `.taplo.toml`, `.vscode/settings.json`; 4 MiB).
    pub const SETTINGS: InputKind = InputKind {
        what: "settings files",
        cap: crate::error::MAX_FILE_BYTES,
    };
    /// Simulator state dumps (`driveset sim --state`, `sim://...&state=`).
    pub const SIM_STATE: InputKind = InputKind {
        what: "simulator state files",
        cap: 16 * MIB,
    };
}

/// Reads the regular file at `path`, at most `kind.cap` bytes (see
/// [`read_regular_file`]).
///
/// # Errors
/// An [`InputError`] naming the file: unreadable, not a regular file, or
/// larger than the kind's cap.
pub fn read_input(path: &std::path::Path, kind: InputKind) -> Result<Vec<u8>, InputError> {
    read_regular_file(path, kind.cap, kind.what)
}

/// The settings file at `path` as text ([`InputKind::SETTINGS`]), or empty
/// when nothing is there yet: the one reader of the files `git-setup`
/// updates in place (docs/editors.md).
///
/// # Errors
/// As [`read_input`], and [`InputErrorKind::Binary`] for a file that is
/// not UTF-8 text.
pub fn read_settings(path: &std::path::Path) -> Result<String, InputError> {
    if !exists(path) {
        return Ok(String::new());
    }
    let bytes = read_input(path, InputKind::SETTINGS)?;
    String::from_utf8(bytes).map_err(|_| {
        InputError::new(
            InputErrorKind::Binary,
            Location::file_only(path.display().to_string()),
            format!("{} is not UTF-8 text", path.display()),
            "fix or remove the file",
        )
    })
}

/// Whether anything is at `path` (a FIFO, a directory, a dangling symlink
/// or a symlink loop count): a missing file is told apart from one that is
/// there but not readable as a file, which [`read_input`] names.
pub fn exists(path: &std::path::Path) -> bool {
    std::fs::symlink_metadata(path).is_ok()
}

/// Checks, from its metadata only, that `path` is a regular file or does
/// not exist yet: for a file a command will create or replace (`upload
/// --journal FILE`), so a FIFO or device there is refused before anything
/// else happens (before the port is opened).
///
/// # Errors
/// [`InputErrorKind::NotRegularFile`] when something other
/// than a regular file is at `path`.
pub fn refuse_special_file(path: &std::path::Path, kind: InputKind) -> Result<(), InputError> {
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if is_loop(&e) => return Err(not_a_regular_file(path, "a symlink loop", kind.what)),
        Err(_) => return Ok(()),
    };
    match not_regular(meta.file_type()) {
        None => Ok(()),
        Some(what) => Err(not_a_regular_file(path, what, kind.what)),
    }
}

fn not_a_regular_file(path: &std::path::Path, is: &str, what: &str) -> InputError {
    let display = path.display().to_string();
    InputError::new(
        InputErrorKind::NotRegularFile,
        Location::file_only(display.clone()),
        format!(
            "{display} is {is}, not a regular file; driveset reads {what} from regular files only"
        ),
        "give the path of a regular file (save a pipe's or device's data into a file first)",
    )
}

/// Whether opening failed on a symlink loop (`ELOOP`): named as such, not
/// as an unreadable file.
fn is_loop(e: &std::io::Error) -> bool {
    #[cfg(unix)]
    {
        e.raw_os_error() == Some(libc::ELOOP)
    }
    #[cfg(not(unix))]
    {
        let _ = e;
        false
    }
}

/// What a path is when it is not a regular file (`None` for a regular file).
fn not_regular(ft: std::fs::FileType) -> Option<&'static str> {
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
    if ft.is_file() {
        None
    } else {
        Some("not a regular file")
    }
}

/// Reads a **regular** file of at most `cap` bytes (the general form of
/// [`read_input`], for a kind of file this module does not list). The path's metadata is
/// checked before it is opened, so a FIFO, socket or device file is never
/// opened (opening a FIFO blocks until a writer comes); the open itself is
/// non-blocking and the opened file is checked again, so a path swapped in
/// between cannot block either. A file larger than `cap` is
/// [`InputErrorKind::TooLarge`], with the cap in the message; `what` names
/// the kind of input there ("parameter sets and schemas ...").
///
/// # Errors
/// [`InputErrorKind::Unreadable`] for a missing / unreadable path,
/// [`InputErrorKind::NotRegularFile`] for one that is not a regular file
/// (the message says what it is).
pub fn read_regular_file(
    path: &std::path::Path,
    cap: u64,
    what: &str,
) -> Result<Vec<u8>, InputError> {
    use std::io::Read as _;
    let display = path.display().to_string();
    let loc = || Location::file_only(display.clone());
    let unreadable = |e: std::io::Error| {
        InputError::new(
            InputErrorKind::Unreadable,
            loc(),
            format!("cannot read {display}: {e}"),
            "check the path and the file's permissions",
        )
    };
    let not_a_file = |kind: &str| not_a_regular_file(path, kind, what);
    let too_large = || {
        InputError::new(
            InputErrorKind::TooLarge,
            loc(),
            format!("{display} is larger than {cap} bytes"),
            format!("{what} are at most {cap} bytes; check that this is the right file"),
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| {
        if is_loop(&e) {
            not_a_file("a symlink loop")
        } else {
            unreadable(e)
        }
    })?;
    if let Some(kind) = not_regular(meta.file_type()) {
        return Err(not_a_file(kind));
    }
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        opts.custom_flags(libc::O_NONBLOCK);
    }
    let file = opts.open(path).map_err(unreadable)?;
    let meta = file.metadata().map_err(unreadable)?;
    if let Some(kind) = not_regular(meta.file_type()) {
        return Err(not_a_file(kind));
    }
    // the cap is checked on the size before a byte is read; `take` below
    // still bounds a file that grows while it is read
    if meta.len() > cap {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(unreadable)?;
    if bytes.len() as u64 > cap {
        return Err(too_large());
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cap_is_checked_on_the_size_before_reading() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("j.json");
        // sparse: 2 GB of nothing, refused from the metadata
        std::fs::File::create(&p)
            .unwrap()
            .set_len(2_000_000_000)
            .unwrap();
        let e = read_input(&p, InputKind::JOURNAL).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::TooLarge);
        assert_eq!(
            e.message,
            format!("{} is larger than 16777216 bytes", p.display())
        );
        std::fs::write(&p, b"{}").unwrap();
        assert_eq!(read_input(&p, InputKind::JOURNAL).unwrap(), b"{}");
    }

    #[test]
    fn special_files_are_refused_and_a_missing_output_path_is_fine() {
        let d = tempfile::tempdir().unwrap();
        let missing = d.path().join("new.json");
        assert!(refuse_special_file(&missing, InputKind::JOURNAL).is_ok());
        std::fs::write(&missing, "x").unwrap();
        assert!(refuse_special_file(&missing, InputKind::JOURNAL).is_ok());
        let e =
            refuse_special_file(std::path::Path::new("/dev/null"), InputKind::JOURNAL).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::NotRegularFile);
        assert_eq!(
            e.detail(),
            "is a character device, not a regular file; driveset reads journals from regular files only; give the path of a regular file (save a pipe's or device's data into a file first)"
        );
        let e = read_input(d.path(), InputKind::EDS).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::NotRegularFile);
        assert!(e.message.ends_with(
            " is a directory, not a regular file; driveset reads EDS / DCF files from regular files only"
        ));
    }

    #[test]
    fn a_settings_file_is_text_or_empty_when_missing() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(".gitattributes");
        assert_eq!(read_settings(&p).unwrap(), "");
        std::fs::write(&p, "*.toml diff=driveset\n").unwrap();
        assert_eq!(read_settings(&p).unwrap(), "*.toml diff=driveset\n");
        std::fs::write(&p, b"\xff\xfe").unwrap();
        let e = read_settings(&p).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::Binary);
        assert_eq!(
            format!("{}; {}", e.message, e.help),
            format!("{} is not UTF-8 text; fix or remove the file", p.display())
        );
        let e = read_settings(d.path()).unwrap_err();
        assert_eq!(e.kind, InputErrorKind::NotRegularFile);
        assert!(e.message.ends_with(
            " is a directory, not a regular file; driveset reads settings files from regular files only"
        ));
    }
}
