//! The CLI's side of the one writer (`driveset_schema::output`): an output
//! argument checked while the arguments are resolved ([`check_output`],
//! before any bus is opened) and a file written through the writer with
//! its directory created ([`write_output`]), both failing as input errors
//! (exit 2) that name the argument.

use std::path::Path;

use driveset_schema::output::{self, OutputError};

use crate::fail::Fail;

fn fail(flag: &str, e: &OutputError) -> Fail {
    let flag = if flag.is_empty() {
        String::new()
    } else {
        format!("{flag} ")
    };
    Fail::input(format!("{flag}{}: {}", e.path.display(), e.detail()))
}

/// Refuses an output argument `flag PATH` whose target exists and is not a
/// regular file (FIFO, device, directory, symlink loop): called before the
/// command opens its port.
///
/// # Errors
/// An input failure naming the argument and what is there.
pub fn check_output(flag: &str, path: &Path) -> Result<(), Fail> {
    output::check_target(path).map_err(|e| fail(flag, &e))
}

/// Writes `bytes` to `path` through the one writer, creating its directory
/// first.
///
/// # Errors
/// An input failure naming the argument: not a regular file, or the file
/// system's refusal.
pub fn write_output(flag: &str, path: &Path, bytes: &[u8]) -> Result<(), Fail> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| Fail::input(format!("cannot create {}: {e}", dir.display())))?;
    }
    output::write_output(path, bytes).map_err(|e| fail(flag, &e))
}
