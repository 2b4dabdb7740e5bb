//! Owns the manifest finding `same-device`: two buses whose ports reach one
//! device (a tty and a symlink to it, `..` in a path, a device server by
//! name and by address, `localhost` and `127.0.0.1`), which a line run
//! would find "in use" half way through (`driveset_link::bus_id::device`).

use super::{Bus, ManifestFinding};

/// One finding per bus whose port reaches the device of an earlier bus.
pub(super) fn findings(buses: &[Bus]) -> Vec<ManifestFinding> {
    let devices: Vec<Option<String>> = buses
        .iter()
        .map(|b| driveset_link::bus_id::device(&b.port))
        .collect();
    let mut out = Vec::new();
    for (i, b) in buses.iter().enumerate() {
        let Some(dev) = &devices[i] else { continue };
        let Some(first) = (0..i).find(|&j| devices[j].as_ref() == Some(dev)) else {
            continue;
        };
        let a = &buses[first];
        out.push(
            ManifestFinding::new(
                "same-device",
                b.location.clone(),
                format!(
                    "buses `{}` ({}) and `{}` ({}) reach one device ({dev})",
                    a.name, a.port_text, b.name, b.port_text
                ),
                "one device is one bus: put the drives of both on one [[bus]]",
            )
            .related("the other bus", a.location.clone()),
        );
    }
    out
}
