//! The one port syntax driveset uses everywhere (command line, line
//! manifests, reports): [`PortSpec`], its parser with precise errors
//! ([`PortSpecError`]) and its canonical `Display` form.
//!
//! | form | transport |
//! | --- | --- |
//! | `/dev/ttyUSB0`, `COM3` | serial port, 7E1 ([`crate::serial`]) |
//! | `tcp://host:port` | serial device server in raw TCP mode ([`crate::tcp`]) |
//! | `rfc2217://host:port` | serial device server speaking RFC 2217 (telnet COM-PORT-OPTION: driveset sets 7E1 and the rate on the server, [`crate::rfc2217`]) |
//! | `slcan:///dev/ttyACM0?bitrate=500000` | slcan (Lawicel) USB-CAN adapter ([`crate::slcan`]) |
//! | `can://can0` | SocketCAN interface (feature `socketcan`) |
//! | `sim://...` | a port a registered [`crate::PortOpener`] opens (the simulator's `sim://FAMILY?addresses=1,2`, see driveset-sim's `open` module): this crate parses its path and keeps its query opaque ([`OpaqueSpec`]) |
//!
//! Every form takes `?baud=` (the 7E1 line rate; for slcan the rate of the
//! adapter's own serial line; for `can://` a synonym of `bitrate`), the CAN
//! forms also `bitrate=`. The character lines (serial,
//! `tcp://`, `rfc2217://`) take `echo=auto|on|off` ([`crate::echo`]: strip
//! the echo of a 2-wire RS-485 adapter; `auto`, the default, detects it
//! from the first exchange; the canonical form leaves `auto` out). Serial, `tcp://`
//! and `rfc2217://` ports take `latency=` ([`parse_latency`]: `40ms`,
//! `0.1s`), the round-trip delay the transport adds (USB adapter, device
//! server), which the clients add to their answer timeouts from the first
//! telegram on. Unknown keys are rejected by name (on `sim://` ports by
//! their opener).
//!
//! Rooms: this file holds the port kinds, the limits and the accessors;
//! `parse` the parser ([`PortSpec::parse`], [`parse_latency`]),
//! `error` what is wrong with a port string, `display` the canonical
//! form.

mod display;
mod error;
mod parse;

use std::collections::BTreeMap;

use crate::echo::EchoMode;

pub use error::{PortSpecError, PortSpecErrorKind};
pub use parse::{parse_latency, take_number};

/// The rates (baud) a LUSTBUS / LECOM line (7E1) can run at.
pub const ALLOWED_BAUDS: &[u32] = &[1200, 2400, 4800, 9600, 19200, 38400, 57600];
/// The CAN bit rates (bit/s) an slcan adapter can be set to (`S0`..`S8`).
pub const ALLOWED_BITRATES: &[u32] = &[
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];
/// The 7E1 line rate used when a port string gives none (the drives'
/// factory setting).
pub const DEFAULT_BAUD: u32 = 9600;
/// The CAN bit rate used when a port string gives none (the Lenze system
/// bus factory setting).
pub const DEFAULT_BITRATE: u32 = 500_000;
/// The rate of an slcan adapter's own serial line when none is given (USB
/// CDC adapters ignore it).
pub const DEFAULT_SLCAN_BAUD: u32 = 115_200;

pub(super) const SERIAL_KEYS: &[&str] = &["baud", "echo", "latency"];
pub(super) const TCP_KEYS: &[&str] = &["baud", "echo", "latency"];

/// The largest `latency=` a port takes.
pub const MAX_LATENCY: std::time::Duration = std::time::Duration::from_secs(10);
pub(super) const SLCAN_KEYS: &[&str] = &["bitrate", "baud"];
pub(super) const CAN_KEYS: &[&str] = &["bitrate", "baud"];
/// The schemes whose ports a registered [`crate::PortOpener`] opens: this
/// crate parses them into an [`OpaqueSpec`] and leaves their query to the
/// opener (`sim://`: the simulator).
pub const OPENER_SCHEMES: &[&str] = &["sim"];

/// Where a bus is: a parsed port string. See the module docs for the forms.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum PortSpec {
    /// A local serial port running 7E1.
    Serial {
        /// Device path (`/dev/ttyUSB0`) or name (`COM3`).
        path: String,
        /// Line rate; `None` means [`DEFAULT_BAUD`].
        baud: Option<u32>,
        /// `echo=on|off`; `None` means [`EchoMode::Auto`] (the parser
        /// gives `None` for `echo=auto`).
        echo: Option<EchoMode>,
        /// `latency=`: the round-trip delay the transport adds.
        latency: Option<std::time::Duration>,
    },
    /// A serial device server in raw TCP mode whose serial side runs 7E1.
    Tcp {
        /// Host name or IP address (IPv6 without brackets).
        host: String,
        /// TCP port.
        port: u16,
        /// The device server's line rate (for wire timing); `None` means
        /// [`DEFAULT_BAUD`].
        baud: Option<u32>,
        /// `echo=on|off`; `None` means [`EchoMode::Auto`] (the parser
        /// gives `None` for `echo=auto`).
        echo: Option<EchoMode>,
        /// `latency=`: the round-trip delay the transport adds.
        latency: Option<std::time::Duration>,
    },
    /// A serial device server speaking RFC 2217: driveset sets the line
    /// (rate, 7 data bits, even parity, 1 stop bit) on the server.
    Rfc2217 {
        /// Host name or IP address (IPv6 without brackets).
        host: String,
        /// TCP port.
        port: u16,
        /// The rate driveset sets on the server; `None` means
        /// [`DEFAULT_BAUD`].
        baud: Option<u32>,
        /// `echo=on|off`; `None` means [`EchoMode::Auto`] (the parser
        /// gives `None` for `echo=auto`).
        echo: Option<EchoMode>,
        /// `latency=`: the round-trip delay the transport adds.
        latency: Option<std::time::Duration>,
    },
    /// An slcan (Lawicel) USB-CAN adapter on a serial port.
    Slcan {
        /// The adapter's serial device.
        path: String,
        /// CAN bit rate; `None` means [`DEFAULT_BITRATE`].
        bitrate: Option<u32>,
        /// The adapter's own serial line rate; `None` means
        /// [`DEFAULT_SLCAN_BAUD`].
        baud: Option<u32>,
    },
    /// A SocketCAN network interface.
    SocketCan {
        /// Interface name (`can0`).
        interface: String,
        /// The bus bit rate (set with `ip link`; used for wire timing);
        /// `None` means [`DEFAULT_BITRATE`].
        bitrate: Option<u32>,
    },
    /// A port a registered [`crate::PortOpener`] opens (`sim://`, the
    /// simulator's in-process bus).
    Sim(OpaqueSpec),
}

/// A port of a scheme a [`crate::PortOpener`] opens ([`OPENER_SCHEMES`]):
/// the scheme, the path after `://` and the query, key by key, as given.
/// This crate checks only the query's form (`key=value` items, each key
/// once, no empty value); which keys there are and what they mean is the
/// opener's.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct OpaqueSpec {
    /// The scheme (`sim`).
    pub scheme: String,
    /// What follows `://` up to `?` (`mc6000`, `lustbus`).
    pub path: String,
    /// The query's items by key.
    pub query: BTreeMap<String, String>,
}

impl OpaqueSpec {
    /// The value of `key`, if given.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.query.get(key).map(String::as_str)
    }
}

impl PortSpec {
    /// Parse a port string (see the module docs).
    pub fn parse(input: &str) -> Result<PortSpec, PortSpecError> {
        parse::parse(input).map_err(|kind| PortSpecError {
            input: input.to_string(),
            kind,
        })
    }

    /// The 7E1 line rate this port runs at (defaults applied), or `None`
    /// for CAN ports.
    pub fn line_baud(&self) -> Option<u32> {
        match self {
            PortSpec::Serial { baud, .. }
            | PortSpec::Tcp { baud, .. }
            | PortSpec::Rfc2217 { baud, .. } => Some(baud.unwrap_or(DEFAULT_BAUD)),
            PortSpec::Sim(sim) => Some(opaque_rate(sim, "baud").unwrap_or(DEFAULT_BAUD)),
            PortSpec::Slcan { .. } | PortSpec::SocketCan { .. } => None,
        }
    }

    /// The CAN bit rate (defaults applied) for CAN ports, `None` otherwise.
    /// For an [`OpaqueSpec`] it is its `bitrate=` if that is a number, else
    /// [`DEFAULT_BITRATE`]: whether the port is a CAN one is the opener's
    /// business (as `baud=` for [`PortSpec::line_baud`]).
    pub fn can_bitrate(&self) -> Option<u32> {
        match self {
            PortSpec::Slcan { bitrate, .. } | PortSpec::SocketCan { bitrate, .. } => {
                Some(bitrate.unwrap_or(DEFAULT_BITRATE))
            }
            PortSpec::Sim(sim) => Some(opaque_rate(sim, "bitrate").unwrap_or(DEFAULT_BITRATE)),
            PortSpec::Serial { .. } | PortSpec::Tcp { .. } | PortSpec::Rfc2217 { .. } => None,
        }
    }

    /// The `echo=` mode of a character line (defaults applied), `None` for
    /// CAN and `sim://` ports (the simulator does not echo).
    pub fn echo(&self) -> Option<EchoMode> {
        match self {
            PortSpec::Serial { echo, .. }
            | PortSpec::Tcp { echo, .. }
            | PortSpec::Rfc2217 { echo, .. } => Some(echo.unwrap_or_default()),
            _ => None,
        }
    }

    /// The `latency=` of a serial, `tcp://` or `rfc2217://` port.
    pub fn latency(&self) -> Option<std::time::Duration> {
        match self {
            PortSpec::Serial { latency, .. }
            | PortSpec::Tcp { latency, .. }
            | PortSpec::Rfc2217 { latency, .. } => *latency,
            _ => None,
        }
    }

    /// The same port with `echo=` set (character lines only; other ports
    /// are returned unchanged).
    pub fn with_echo(mut self, mode: EchoMode) -> PortSpec {
        if let PortSpec::Serial { echo, .. }
        | PortSpec::Tcp { echo, .. }
        | PortSpec::Rfc2217 { echo, .. } = &mut self
        {
            *echo = (mode != EchoMode::Auto).then_some(mode);
        }
        self
    }

    /// Whether this port carries CAN frames (slcan, SocketCAN) rather than
    /// bytes. `sim://` is neither: it depends on the family.
    pub fn is_can(&self) -> bool {
        matches!(self, PortSpec::Slcan { .. } | PortSpec::SocketCan { .. })
    }
}

impl std::str::FromStr for PortSpec {
    type Err = PortSpecError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        PortSpec::parse(s)
    }
}

/// A rate key of an opaque port, when it is a number (the opener checks it).
pub(super) fn opaque_rate(spec: &OpaqueSpec, key: &str) -> Option<u32> {
    spec.get(key).and_then(|v| v.parse().ok())
}
