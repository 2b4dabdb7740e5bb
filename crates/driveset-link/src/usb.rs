//! Owns what Linux says of the USB serial adapters behind serial ports:
//! each adapter's latency timer (`SYSFS/bus/usb-serial/devices/DEVICE/
//! latency_timer`, the milliseconds an FTDI-style adapter holds received
//! bytes before passing them on), the port's own adapter marked
//! ([`latency_timers`]). `driveset doctor` reports them and advises on a
//! slow one (docs/ports.md). Nothing is written.

use std::path::Path;

use crate::PortSpec;

/// A USB serial adapter's latency timer as Linux shows it
/// (`/sys/bus/usb-serial/devices/DEVICE/latency_timer`).
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct LatencyTimer {
    /// The device (`ttyUSB0`).
    pub device: String,
    /// The file it was read from.
    pub path: String,
    /// The timer in milliseconds.
    pub ms: u32,
    /// Whether it is the port's adapter.
    pub this_port: bool,
}

/// The latency timers of the USB serial adapters under `sysfs` (`/sys`,
/// or a fake tree in tests), sorted by device, the adapter of `spec` (a
/// serial port, its path resolved through symlinks) marked. None when
/// the directory cannot be read (no adapter, or not Linux); a timer that
/// cannot be read or parsed is left out.
pub fn latency_timers(sysfs: &Path, spec: &PortSpec) -> Vec<LatencyTimer> {
    let dir = sysfs.join("bus/usb-serial/devices");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let own = match spec {
        PortSpec::Serial { path, .. } => {
            let p = Path::new(path);
            let real = std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
            real.file_name().map(|n| n.to_string_lossy().into_owned())
        }
        _ => None,
    };
    let mut out: Vec<LatencyTimer> = entries
        .filter_map(Result::ok)
        .filter_map(|e| {
            let device = e.file_name().to_string_lossy().into_owned();
            let path = e.path().join("latency_timer");
            let text = std::fs::read_to_string(&path).ok()?;
            let ms = text.trim().parse::<u32>().ok()?;
            Some(LatencyTimer {
                this_port: own.as_deref() == Some(device.as_str()),
                device,
                path: path.display().to_string(),
                ms,
            })
        })
        .collect();
    out.sort_by(|a, b| a.device.cmp(&b.device));
    out
}
