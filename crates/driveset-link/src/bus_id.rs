//! Bus identities: which physical bus a link reaches, independent of how
//! its port string was spelled ([`crate::ByteLink::bus_id`],
//! [`crate::FrameLink::bus_id`]). Journals record it so that a transaction
//! stays bound to its drive (docs/journals.md, "One name per drive";
//! docs/ports.md, "The bus a port reaches, and its lock").
//!
//! | transport | bus id | e.g. |
//! | --- | --- | --- |
//! | serial port | `serial:` + the canonical device path (symlinks such as `/dev/serial/by-id/...` resolved) | `serial:/dev/ttyUSB0` |
//! | TCP device server, raw or RFC 2217 | `tcp:` + the address actually connected to (host resolved; IPv4-mapped and `::1` as IPv4, [`tcp`]) | `tcp:127.0.0.1:4001` |
//! | slcan adapter | `slcan:` + canonical device path + `?bitrate=` | `slcan:/dev/ttyACM0?bitrate=500000` |
//! | SocketCAN | `can:` + interface | `can:can0` |
//! | simulated bus | `sim:` + bus name (+ `@` canonical state file) | `sim:mc6000@/tmp/s/sim-mc6000.json` |
//! | in-memory pair (tests) | `mem:` + a number unique in the process | `mem:7` |
//!
//! The traits have no default: every link and every wrapper says which bus
//! it is, a wrapper by asking the link it wraps. [`before_open`] gives the
//! id of a port whose spelling says it, so a program can lock the bus
//! ([`crate::lock`]) before opening it.
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

/// A bus id as a file name stem (journals, bus locks): every character
/// but `[A-Za-z0-9]` replaced by `_`; an id longer than 96 characters is
/// cut there and gets `-` and the FNV-1a 64 hash of the whole id, so two
/// long ids that share their first 96 characters stay apart.
/// `tcp:127.0.0.1:4001` -> `tcp_127_0_0_1_4001`.
pub fn file_stem(bus_id: &str) -> String {
    const MAX: usize = 96;
    let clean: String = bus_id
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if clean.len() <= MAX {
        return clean;
    }
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bus_id.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{}-{h:016x}", &clean[..MAX])
}

/// The bus a port reaches when its spelling alone says it (a serial
/// device, an slcan adapter, a SocketCAN interface: what the opened link's
/// `bus_id` will be), so a program can lock the bus before it opens the
/// port; `None` for a TCP or RFC 2217 host (the address connected to is
/// known only after connecting) and for an opener's port.
pub fn before_open(spec: &crate::PortSpec) -> Option<String> {
    use crate::PortSpec;
    match spec {
        PortSpec::Serial { path, .. } => Some(serial(path)),
        PortSpec::Slcan { path, bitrate, .. } => {
            Some(slcan(path, bitrate.unwrap_or(crate::spec::DEFAULT_BITRATE)))
        }
        PortSpec::SocketCan { interface, .. } => Some(socketcan(interface)),
        PortSpec::Tcp { .. } | PortSpec::Rfc2217 { .. } | PortSpec::Sim(_) => None,
    }
}

/// The device a port reaches, without opening it, for telling whether two
/// ports of one line manifest are one device: a serial or slcan port's
/// canonical device path (whatever its rate), a SocketCAN interface, a TCP
/// or RFC 2217 port's address with its host resolved (a name lookup, no
/// connection; in the spelling of [`tcp`], so `localhost`, `127.0.0.1` and
/// `::ffff:127.0.0.1` are one). `None` for an opener's port (`sim://`)
/// and a host that does not resolve.
pub fn device(spec: &crate::PortSpec) -> Option<String> {
    use crate::PortSpec;
    use std::net::ToSocketAddrs as _;
    match spec {
        PortSpec::Serial { path, .. } | PortSpec::Slcan { path, .. } => {
            Some(format!("device:{}", canonical_device(path)))
        }
        PortSpec::SocketCan { interface, .. } => Some(socketcan(interface)),
        PortSpec::Tcp { host, port, .. } | PortSpec::Rfc2217 { host, port, .. } => {
            let addr = (host.as_str(), *port).to_socket_addrs().ok()?.next()?;
            Some(tcp(addr))
        }
        PortSpec::Sim(_) => None,
    }
}

/// Every bus a TCP or RFC 2217 port may reach, without connecting: the
/// [`tcp`] id of each address its host resolves to (a name lookup; none
/// when it does not resolve); empty for any other port.
pub fn tcp_candidates(spec: &crate::PortSpec) -> Vec<String> {
    use crate::PortSpec;
    use std::net::ToSocketAddrs as _;
    match spec {
        PortSpec::Tcp { host, port, .. } | PortSpec::Rfc2217 { host, port, .. } => {
            match (host.as_str(), *port).to_socket_addrs() {
                Ok(addrs) => addrs.map(tcp).collect(),
                Err(_) => Vec::new(),
            }
        }
        _ => Vec::new(),
    }
}

/// `serial:` + [`canonical_device`].
pub fn serial(path: &str) -> String {
    format!("serial:{}", canonical_device(path))
}

/// `tcp:` + the peer address in one spelling per device: an IPv4-mapped
/// IPv6 address (`[::ffff:127.0.0.1]:4001`) as its IPv4 address, and the
/// IPv6 loopback `[::1]` as `127.0.0.1` (one machine, one port), so
/// `localhost`, `127.0.0.1`, `::1` and `::ffff:127.0.0.1` are one bus, as
/// a device server's name and its address are (the host is resolved
/// before it is connected to).
pub fn tcp(peer: std::net::SocketAddr) -> String {
    use std::net::{IpAddr, Ipv4Addr, SocketAddr};
    let ip = match peer.ip() {
        IpAddr::V6(v6) if v6.is_loopback() => IpAddr::V4(Ipv4Addr::LOCALHOST),
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(IpAddr::V6(v6), IpAddr::V4),
        v4 => v4,
    };
    format!("tcp:{}", SocketAddr::new(ip, peer.port()))
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
    fn one_tcp_id_for_every_spelling_of_an_address() {
        let id = |s: &str| tcp(s.parse().unwrap());
        assert_eq!(id("127.0.0.1:4001"), "tcp:127.0.0.1:4001");
        assert_eq!(id("[::ffff:127.0.0.1]:4001"), "tcp:127.0.0.1:4001");
        assert_eq!(id("[::1]:4001"), "tcp:127.0.0.1:4001");
        assert_eq!(id("[::ffff:10.0.0.5]:4001"), "tcp:10.0.0.5:4001");
        assert_eq!(id("[2001:db8::5]:4001"), "tcp:[2001:db8::5]:4001");
    }

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
    fn a_symlink_chain_and_dot_dot_spellings_are_one_device() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("ttyUSB7");
        std::fs::write(&real, "").unwrap();
        std::fs::create_dir(dir.path().join("by-id")).unwrap();
        let hop = dir.path().join("by-id/usb-FTDI_FT232R-if00-port0");
        let hop2 = dir.path().join("serial0");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink("../ttyUSB7", &hop).unwrap();
            std::os::unix::fs::symlink(&hop, &hop2).unwrap();
            let want = serial(&real.display().to_string());
            assert_eq!(serial(&hop.display().to_string()), want);
            assert_eq!(serial(&hop2.display().to_string()), want);
            let dotted = dir.path().join("by-id/../ttyUSB7");
            assert_eq!(serial(&dotted.display().to_string()), want);
            assert_eq!(
                slcan(&hop.display().to_string(), 500_000),
                slcan(&real.display().to_string(), 500_000)
            );
        }
    }

    #[test]
    fn tcp_ids_are_the_peer_address_and_mem_pairs_are_apart() {
        let v4: std::net::SocketAddr = "127.0.0.1:4001".parse().unwrap();
        let v6: std::net::SocketAddr = "[::1]:4001".parse().unwrap();
        assert_eq!(tcp(v4), "tcp:127.0.0.1:4001");
        assert_eq!(tcp(v6), "tcp:127.0.0.1:4001");
        let (a, b) = (mem(), mem());
        assert!(a.starts_with("mem:") && b.starts_with("mem:"), "{a} {b}");
        assert_ne!(a, b);
    }

    #[test]
    fn a_tcp_port_may_reach_every_address_its_host_resolves_to() {
        let ids = |p: &str| tcp_candidates(&crate::PortSpec::parse(p).unwrap());
        assert_eq!(ids("tcp://127.0.0.1:4001"), vec!["tcp:127.0.0.1:4001"]);
        assert_eq!(ids("rfc2217://127.0.0.1:4002"), vec!["tcp:127.0.0.1:4002"]);
        assert!(ids("tcp://localhost:4001").contains(&"tcp:127.0.0.1:4001".to_string()));
        assert!(ids("COM3?baud=19200").is_empty());
        assert!(ids("sim://tmd?addresses=1").is_empty());
    }

    #[test]
    fn ports_whose_spelling_says_their_bus_give_it_before_they_are_opened() {
        let id = |p: &str| before_open(&crate::PortSpec::parse(p).unwrap());
        assert_eq!(id("COM3?baud=19200"), Some("serial:COM3".into()));
        assert_eq!(id("slcan://COM4"), Some("slcan:COM4?bitrate=500000".into()));
        assert_eq!(id("can://can0?bitrate=250000"), Some("can:can0".into()));
        assert_eq!(id("tcp://localhost:4001"), None);
        assert_eq!(id("rfc2217://localhost:4001"), None);
        assert_eq!(id("sim://tmd?addresses=1"), None);
    }

    #[test]
    fn file_stems_keep_letters_and_digits_and_cut_long_ids_with_a_hash() {
        assert_eq!(file_stem("tcp:127.0.0.1:4001"), "tcp_127_0_0_1_4001");
        assert_eq!(file_stem("serial:/dev/ttyUSB0"), "serial__dev_ttyUSB0");
        let long_a = format!("serial:/{}a", "x".repeat(120));
        let long_b = format!("serial:/{}b", "x".repeat(120));
        let (sa, sb) = (file_stem(&long_a), file_stem(&long_b));
        assert_eq!(sa.len(), 96 + 1 + 16);
        assert_eq!(sa[..96], sb[..96]);
        assert_ne!(sa, sb);
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
