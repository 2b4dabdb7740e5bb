//! Bus identities: which physical bus a link reaches, independent of how
//! its port string was spelled ([`crate::ByteLink::bus_id`],
//! [`crate::FrameLink::bus_id`]). Journals record it so that a transaction
//! stays bound to its drive (DESIGN.md "Transactions", "Journals bound to
//! their drive").
//!
//! | transport | bus id | e.g. |
//! | --- | --- | --- |
//! | serial port | `serial:` + the canonical device path (symlinks such as `/dev/serial/by-id/...` resolved) | `serial:/dev/ttyUSB0` |
//! | TCP device server | `tcp:` + the address actually connected to (host resolved) | `tcp:127.0.0.1:4001` |
//! | slcan adapter | `slcan:` + canonical device path + `?bitrate=` | `slcan:/dev/ttyACM0?bitrate=500000` |
//! | SocketCAN | `can:` + interface | `can:can0` |
//! | simulated bus | `sim:` + bus name (+ `@` canonical state file) | `sim:mc6000@/tmp/s/sim-mc6000.json` |
//!
//! The line rate is not part of the id: a drive is on its bus at whatever
//! rate it answers.

use std::path::Path;

/// A device path with symlinks and `.`/`..` resolved (`/dev/serial/by-id/x`
/// -> `/dev/ttyUSB0`); a path that cannot be resolved (`COM3`, a device not
/// there) as given.
pub fn canonical_device(path: &str) -> String {
    std::fs::canonicalize(Path::new(path))
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| path.to_string())
}

/// A file path that may not exist yet, canonical: the canonical parent
/// directory joined with the file name; as given if even the parent cannot
/// be resolved.
pub fn canonical_file(path: &Path) -> String {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p.display().to_string();
    }
    match (path.parent(), path.file_name()) {
        (Some(dir), Some(name)) => {
            let dir = if dir.as_os_str().is_empty() {
                Path::new(".")
            } else {
                dir
            };
            match std::fs::canonicalize(dir) {
                Ok(d) => d.join(name).display().to_string(),
                Err(_) => path.display().to_string(),
            }
        }
        _ => path.display().to_string(),
    }
}

/// `serial:` + [`canonical_device`].
pub fn serial(path: &str) -> String {
    format!("serial:{}", canonical_device(path))
}

/// `tcp:` + the peer address (`127.0.0.1:4001`, `[::1]:4001`).
pub fn tcp(peer: std::net::SocketAddr) -> String {
    format!("tcp:{peer}")
}

/// `slcan:` + [`canonical_device`] + `?bitrate=N`.
pub fn slcan(path: &str, bitrate: u32) -> String {
    format!("slcan:{}?bitrate={bitrate}", canonical_device(path))
}

/// `mem:` + a number unique in the process: one in-memory pair
/// ([`crate::mem::byte_pair`], [`crate::mem::frame_pair`]), both of its
/// ends, is one bus; two pairs are two buses.
pub fn mem() -> String {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    format!(
        "mem:{}",
        NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    )
}

/// `can:` + interface name.
pub fn socketcan(interface: &str) -> String {
    format!("can:{interface}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_paths_resolve_symlinks() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("ttyX");
        std::fs::write(&real, "").unwrap();
        let link = dir.path().join("by-id-link");
        #[cfg(unix)]
        std::os::unix::fs::symlink(&real, &link).unwrap();
        #[cfg(unix)]
        assert_eq!(
            serial(&link.display().to_string()),
            serial(&real.display().to_string())
        );
        let canon = std::fs::canonicalize(&real).unwrap();
        assert_eq!(
            serial(&real.display().to_string()),
            format!("serial:{}", canon.display())
        );
        assert_eq!(serial("COM3"), "serial:COM3");
        assert_eq!(slcan("COM4", 500_000), "slcan:COM4?bitrate=500000");
        assert_eq!(socketcan("can0"), "can:can0");
    }

    #[test]
    fn files_that_do_not_exist_yet_resolve_through_their_directory() {
        let dir = tempfile::tempdir().unwrap();
        let canon = std::fs::canonicalize(dir.path()).unwrap();
        let spelled = dir.path().join(".").join("state.json");
        assert_eq!(
            canonical_file(&spelled),
            canon.join("state.json").display().to_string()
        );
    }
}
