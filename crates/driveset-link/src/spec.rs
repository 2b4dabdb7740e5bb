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

use std::collections::BTreeMap;
use std::fmt;

use crate::echo::EchoMode;
use crate::error::list;

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

const SERIAL_KEYS: &[&str] = &["baud", "echo", "latency"];
const TCP_KEYS: &[&str] = &["baud", "echo", "latency"];

/// The largest `latency=` a port takes.
pub const MAX_LATENCY: std::time::Duration = std::time::Duration::from_secs(10);
const SLCAN_KEYS: &[&str] = &["bitrate", "baud"];
const CAN_KEYS: &[&str] = &["bitrate", "baud"];
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

/// `scheme://path?k=v&...`, the keys in alphabetical order.
impl fmt::Display for OpaqueSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}://{}", self.scheme, self.path)?;
        let mut q = Query::default();
        for (key, value) in &self.query {
            q.text(key, value);
        }
        f.write_str(&q.0)
    }
}

/// A port string that does not parse: the input and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("invalid port `{input}`: {kind}")]
pub struct PortSpecError {
    /// The string given.
    pub input: String,
    /// What is wrong with it.
    pub kind: PortSpecErrorKind,
}

/// What is wrong with a port string.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PortSpecErrorKind {
    /// Nothing given.
    #[error(
        "empty; give a serial port (/dev/ttyUSB0, COM3), tcp://host:port, rfc2217://host:port, slcan://PATH, can://IFACE or sim://FAMILY"
    )]
    Empty,
    /// A scheme this crate does not know.
    #[error(
        "unknown scheme `{scheme}://`; use a serial port (/dev/ttyUSB0, COM3), tcp://, rfc2217://, slcan://, can:// or sim://"
    )]
    UnknownScheme {
        /// The scheme.
        scheme: String,
    },
    /// A scheme without the part that must follow it.
    #[error("`{scheme}://` needs {what}, e.g. {example}")]
    Missing {
        /// The scheme (`serial` for a bare path).
        scheme: &'static str,
        /// What is missing.
        what: &'static str,
        /// A correct example.
        example: &'static str,
    },
    /// `?` with nothing after it, or an empty `&&` item.
    #[error("empty option after `?` or `&`; remove it or write key=value")]
    EmptyOption,
    /// An option without `=`.
    #[error("option `{item}` is not key=value")]
    MalformedOption {
        /// The item.
        item: String,
    },
    /// An option this kind of port does not take.
    #[error("unknown option `{key}` for {scheme} ports; allowed: {}", .allowed.join(", "))]
    UnknownOption {
        /// The key.
        key: String,
        /// The kind of port.
        scheme: &'static str,
        /// The keys it takes.
        allowed: &'static [&'static str],
    },
    /// An option given twice.
    #[error("option `{key}` given twice; give it once")]
    DuplicateOption {
        /// The key.
        key: String,
    },
    /// An option whose value is not what it should be.
    #[error("`{key}={value}`: {reason}")]
    BadValue {
        /// The key.
        key: String,
        /// The value.
        value: String,
        /// What it should be.
        reason: String,
    },
    /// A 7E1 line rate driveset does not support.
    #[error(
        "baud={baud} is not supported; a 7E1 line runs at one of {} baud",
        list(ALLOWED_BAUDS)
    )]
    UnsupportedBaud {
        /// The rate.
        baud: u32,
    },
    /// A CAN bit rate slcan adapters cannot be set to.
    #[error(
        "bitrate={bitrate} is not supported; use one of {} bit/s",
        list(ALLOWED_BITRATES)
    )]
    UnsupportedBitrate {
        /// The rate.
        bitrate: u32,
    },
    /// `can://` with both `baud` and `bitrate`, different.
    #[error("baud={baud} and bitrate={bitrate} disagree; for can:// give only bitrate=")]
    ConflictingRates {
        /// `baud=`.
        baud: u32,
        /// `bitrate=`.
        bitrate: u32,
    },
    /// A bad host in `tcp://`.
    #[error("host `{host}`: {reason}")]
    BadHost {
        /// The host.
        host: String,
        /// Why.
        reason: &'static str,
    },
    /// A bad TCP port number.
    #[error("TCP port `{value}` is not a number in 1..=65535")]
    BadTcpPort {
        /// The text.
        value: String,
    },
    /// Something after `host:port` or the interface name.
    #[error("unexpected `{rest}` after {after}; {scheme}:// takes {takes} only")]
    TrailingPath {
        /// The extra text.
        rest: String,
        /// What it follows.
        after: String,
        /// The scheme.
        scheme: &'static str,
        /// What the scheme takes.
        takes: &'static str,
    },
    /// A bad SocketCAN interface name.
    #[error("interface name `{name}`: {reason}")]
    BadInterface {
        /// The name.
        name: String,
        /// Why.
        reason: &'static str,
    },
    /// A bad simulator family name.
    #[error(
        "family `{family}`: use letters, digits, `-` and `_` only (a schema name such as lust-vf1000)"
    )]
    BadFamily {
        /// The name.
        family: String,
    },
    /// A bad simulated drive address.
    #[error("address `{value}` in addresses= is not a number in 0..=255")]
    BadAddress {
        /// The text.
        value: String,
    },
    /// A simulated drive address given twice.
    #[error("address {address} appears twice in addresses=; each drive needs its own address")]
    DuplicateAddress {
        /// The address.
        address: u8,
    },
    /// A per-family address key (`mc6000=`) on a `sim://` port that is not
    /// `sim://lustbus`, or `addresses=` on `sim://lustbus`.
    #[error("{reason}")]
    MixedBus {
        /// What is wrong and what to write instead.
        reason: String,
    },
}

impl PortSpec {
    /// Parse a port string (see the module docs).
    pub fn parse(input: &str) -> Result<PortSpec, PortSpecError> {
        parse(input).map_err(|kind| PortSpecError {
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

/// Writes the canonical form: defaults not spelled out, options in a fixed
/// order (`addresses` or the per-family keys alphabetically, `baud`,
/// `bitrate`, then the rest alphabetically).
impl fmt::Display for PortSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut q = Query::default();
        match self {
            PortSpec::Serial {
                path,
                baud,
                echo,
                latency,
            } => {
                f.write_str(path)?;
                q.num("baud", *baud);
                q.echo(*echo);
                q.latency(*latency);
            }
            PortSpec::Tcp {
                host,
                port,
                baud,
                echo,
                latency,
            } => {
                write_host_port(f, "tcp", host, *port)?;
                q.num("baud", *baud);
                q.echo(*echo);
                q.latency(*latency);
            }
            PortSpec::Rfc2217 {
                host,
                port,
                baud,
                echo,
                latency,
            } => {
                write_host_port(f, "rfc2217", host, *port)?;
                q.num("baud", *baud);
                q.echo(*echo);
                q.latency(*latency);
            }
            PortSpec::Slcan {
                path,
                bitrate,
                baud,
            } => {
                write!(f, "slcan://{path}")?;
                q.num("baud", *baud);
                q.num("bitrate", *bitrate);
            }
            PortSpec::SocketCan { interface, bitrate } => {
                write!(f, "can://{interface}")?;
                q.num("bitrate", *bitrate);
            }
            PortSpec::Sim(spec) => return write!(f, "{spec}"),
        }
        f.write_str(&q.0)
    }
}

/// A rate key of an opaque port, when it is a number (the opener checks it).
fn opaque_rate(spec: &OpaqueSpec, key: &str) -> Option<u32> {
    spec.get(key).and_then(|v| v.parse().ok())
}

fn write_host_port(f: &mut fmt::Formatter<'_>, scheme: &str, host: &str, port: u16) -> fmt::Result {
    if host.contains(':') {
        write!(f, "{scheme}://[{host}]:{port}")
    } else {
        write!(f, "{scheme}://{host}:{port}")
    }
}

/// Builds `?a=1&b=2`.
#[derive(Default)]
struct Query(String);

impl Query {
    fn text(&mut self, key: &str, value: &str) {
        self.0.push(if self.0.is_empty() { '?' } else { '&' });
        self.0.push_str(key);
        self.0.push('=');
        self.0.push_str(value);
    }
    /// `echo=`, left out when it is the default (`auto`).
    fn echo(&mut self, value: Option<EchoMode>) {
        match value {
            None | Some(EchoMode::Auto) => {}
            Some(mode) => self.text("echo", mode.name()),
        }
    }
    fn num(&mut self, key: &str, value: Option<u32>) {
        if let Some(v) = value {
            self.text(key, &v.to_string());
        }
    }
    /// `latency=` in whole milliseconds, or microseconds when it has a
    /// fraction of a millisecond.
    fn latency(&mut self, value: Option<std::time::Duration>) {
        if let Some(d) = value {
            let text = if d.as_micros() % 1000 == 0 {
                format!("{}ms", d.as_millis())
            } else {
                format!("{}us", d.as_micros())
            };
            self.text("latency", &text);
        }
    }
}

/// A `latency=` value: a whole or decimal number with the unit `ms`, `s`
/// or `us` (`40ms`, `0.1s`, `16.5ms`), at most [`MAX_LATENCY`], to the
/// microsecond. `Err` says what is wrong.
pub fn parse_latency(text: &str) -> Result<std::time::Duration, String> {
    let (number, unit_us) = if let Some(n) = text.strip_suffix("ms") {
        (n, 1_000u64)
    } else if let Some(n) = text.strip_suffix("us") {
        (n, 1)
    } else if let Some(n) = text.strip_suffix('s') {
        (n, 1_000_000)
    } else {
        return Err("give a unit: e.g. latency=40ms or latency=0.1s".into());
    };
    let (whole, frac) = number.split_once('.').unwrap_or((number, ""));
    let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    if !digits(whole) || (number.contains('.') && !digits(frac)) {
        return Err("not a number with a unit (ms, s, us), e.g. latency=40ms".into());
    }
    let too_long = || format!("at most {} s", MAX_LATENCY.as_secs());
    let whole: u64 = whole.parse().map_err(|_| too_long())?;
    let mut us = whole.checked_mul(unit_us).ok_or_else(too_long)?;
    // the fraction, to the microsecond
    let mut scale = unit_us;
    for b in frac.bytes() {
        scale /= 10;
        if scale == 0 {
            if b != b'0' {
                return Err("finer than a microsecond".into());
            }
            continue;
        }
        us += u64::from(b - b'0') * scale;
    }
    let d = std::time::Duration::from_micros(us);
    if d > MAX_LATENCY {
        return Err(too_long());
    }
    Ok(d)
}

/// The items of a query (`key=value&...`), checked for their form and, with
/// `allowed`, against the keys a scheme takes.
fn query_items(
    query: Option<&str>,
    allowed: Option<(&'static str, &'static [&'static str])>,
) -> Result<BTreeMap<String, String>, PortSpecErrorKind> {
    let mut map = BTreeMap::new();
    let Some(query) = query else {
        return Ok(map);
    };
    for item in query.split('&') {
        if item.is_empty() {
            return Err(PortSpecErrorKind::EmptyOption);
        }
        let Some((key, value)) = item.split_once('=') else {
            return Err(PortSpecErrorKind::MalformedOption { item: item.into() });
        };
        if let Some((scheme, allowed)) = allowed
            && !allowed.contains(&key)
        {
            return Err(PortSpecErrorKind::UnknownOption {
                key: key.into(),
                scheme,
                allowed,
            });
        }
        if value.is_empty() {
            return Err(PortSpecErrorKind::BadValue {
                key: key.into(),
                value: String::new(),
                reason: "empty value".into(),
            });
        }
        if map.insert(key.to_string(), value.to_string()).is_some() {
            return Err(PortSpecErrorKind::DuplicateOption { key: key.into() });
        }
    }
    Ok(map)
}

/// The options after `?`, checked against the keys a scheme takes.
struct Options {
    map: BTreeMap<String, String>,
}

impl Options {
    fn parse(
        query: Option<&str>,
        scheme: &'static str,
        allowed: &'static [&'static str],
    ) -> Result<Options, PortSpecErrorKind> {
        query_items(query, Some((scheme, allowed))).map(|map| Options { map })
    }

    fn number(&mut self, key: &str) -> Result<Option<u32>, PortSpecErrorKind> {
        let Some(value) = self.map.remove(key) else {
            return Ok(None);
        };
        match value.parse::<u32>() {
            Ok(n) if n > 0 => Ok(Some(n)),
            _ => Err(PortSpecErrorKind::BadValue {
                key: key.into(),
                value,
                reason: "not a positive whole number".into(),
            }),
        }
    }

    /// `baud=`, checked against [`ALLOWED_BAUDS`].
    fn line_baud(&mut self) -> Result<Option<u32>, PortSpecErrorKind> {
        match self.number("baud")? {
            Some(baud) if !ALLOWED_BAUDS.contains(&baud) => {
                Err(PortSpecErrorKind::UnsupportedBaud { baud })
            }
            other => Ok(other),
        }
    }

    /// `echo=auto|on|off`.
    fn echo(&mut self) -> Result<Option<EchoMode>, PortSpecErrorKind> {
        let Some(value) = self.map.remove("echo") else {
            return Ok(None);
        };
        match EchoMode::parse(&value) {
            // `auto` is the default: kept as `None` so that a port string
            // and its canonical form are the same spec.
            Some(EchoMode::Auto) => Ok(None),
            Some(mode) => Ok(Some(mode)),
            None => Err(PortSpecErrorKind::BadValue {
                key: "echo".into(),
                value,
                reason: "use auto (detect, the default), on (the line returns what driveset sends: strip it) or off".into(),
            }),
        }
    }

    /// `latency=` ([`parse_latency`]).
    fn latency(&mut self) -> Result<Option<std::time::Duration>, PortSpecErrorKind> {
        let Some(value) = self.map.remove("latency") else {
            return Ok(None);
        };
        parse_latency(&value)
            .map(Some)
            .map_err(|reason| PortSpecErrorKind::BadValue {
                key: "latency".into(),
                value,
                reason,
            })
    }

    /// `bitrate=`, checked against [`ALLOWED_BITRATES`].
    fn bitrate(&mut self) -> Result<Option<u32>, PortSpecErrorKind> {
        match self.number("bitrate")? {
            Some(bitrate) => check_bitrate(bitrate).map(Some),
            None => Ok(None),
        }
    }
}

fn check_bitrate(bitrate: u32) -> Result<u32, PortSpecErrorKind> {
    if ALLOWED_BITRATES.contains(&bitrate) {
        Ok(bitrate)
    } else {
        Err(PortSpecErrorKind::UnsupportedBitrate { bitrate })
    }
}

fn parse(input: &str) -> Result<PortSpec, PortSpecErrorKind> {
    let input = input.trim();
    if input.is_empty() {
        return Err(PortSpecErrorKind::Empty);
    }
    let (body, query) = match input.split_once('?') {
        Some((body, query)) => (body, Some(query)),
        None => (input, None),
    };
    if query == Some("") {
        return Err(PortSpecErrorKind::EmptyOption);
    }
    let Some((scheme, rest)) = body.split_once("://") else {
        return parse_serial(body, query);
    };
    match scheme {
        "tcp" => parse_tcp(rest, query, "tcp"),
        "rfc2217" => parse_tcp(rest, query, "rfc2217"),
        "slcan" => parse_slcan(rest, query),
        "can" => parse_can(rest, query),
        s if OPENER_SCHEMES.contains(&s) => Ok(PortSpec::Sim(OpaqueSpec {
            scheme: s.to_string(),
            path: rest.to_string(),
            query: query_items(query, None)?,
        })),
        _ => Err(PortSpecErrorKind::UnknownScheme {
            scheme: scheme.into(),
        }),
    }
}

fn parse_serial(path: &str, query: Option<&str>) -> Result<PortSpec, PortSpecErrorKind> {
    if path.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "serial",
            what: "a device path",
            example: "/dev/ttyUSB0?baud=9600 or COM3",
        });
    }
    let mut opts = Options::parse(query, "serial", SERIAL_KEYS)?;
    let baud = opts.line_baud()?;
    let echo = opts.echo()?;
    let latency = opts.latency()?;
    Ok(PortSpec::Serial {
        path: path.into(),
        baud,
        echo,
        latency,
    })
}

/// `tcp://host:port` and `rfc2217://host:port` (`scheme`).
fn parse_tcp(
    rest: &str,
    query: Option<&str>,
    scheme: &'static str,
) -> Result<PortSpec, PortSpecErrorKind> {
    let rfc2217 = scheme == "rfc2217";
    let (example, example6): (&'static str, &'static str) = if rfc2217 {
        ("rfc2217://192.168.0.7:2217", "rfc2217://[fe80::1]:2217")
    } else {
        ("tcp://192.168.0.7:4001", "tcp://[fe80::1]:4001")
    };
    if rest.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme,
            what: "host:port",
            example,
        });
    }
    let (host_port, trailing) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, ""),
    };
    let (host, port_text) = if let Some(bracketed) = host_port.strip_prefix('[') {
        let Some((host, after)) = bracketed.split_once(']') else {
            return Err(PortSpecErrorKind::BadHost {
                host: host_port.into(),
                reason: "missing `]` after the IPv6 address",
            });
        };
        let Some(port) = after.strip_prefix(':') else {
            return Err(PortSpecErrorKind::Missing {
                scheme,
                what: "a port after the host",
                example: example6,
            });
        };
        (host, port)
    } else {
        let Some((host, port)) = host_port.rsplit_once(':') else {
            return Err(PortSpecErrorKind::Missing {
                scheme,
                what: "a port after the host",
                example,
            });
        };
        if host.contains(':') {
            return Err(PortSpecErrorKind::BadHost {
                host: host.into(),
                reason: if rfc2217 {
                    "write IPv6 addresses in brackets: rfc2217://[::1]:2217"
                } else {
                    "write IPv6 addresses in brackets: tcp://[::1]:4001"
                },
            });
        }
        (host, port)
    };
    if host.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme,
            what: "a host before the port",
            example,
        });
    }
    if host.chars().any(|c| c.is_whitespace() || c == '@') {
        return Err(PortSpecErrorKind::BadHost {
            host: host.into(),
            reason: "not a host name or IP address",
        });
    }
    let port = match port_text.parse::<u16>() {
        Ok(p) if p > 0 => p,
        _ => {
            return Err(PortSpecErrorKind::BadTcpPort {
                value: port_text.into(),
            });
        }
    };
    if !trailing.is_empty() {
        return Err(PortSpecErrorKind::TrailingPath {
            rest: trailing.into(),
            after: host_port.into(),
            scheme,
            takes: "host:port",
        });
    }
    let mut opts = Options::parse(
        query,
        if rfc2217 { "rfc2217://" } else { "tcp://" },
        TCP_KEYS,
    )?;
    let baud = opts.line_baud()?;
    let echo = opts.echo()?;
    let latency = opts.latency()?;
    let host = host.to_string();
    Ok(if rfc2217 {
        PortSpec::Rfc2217 {
            host,
            port,
            baud,
            echo,
            latency,
        }
    } else {
        PortSpec::Tcp {
            host,
            port,
            baud,
            echo,
            latency,
        }
    })
}

fn parse_slcan(path: &str, query: Option<&str>) -> Result<PortSpec, PortSpecErrorKind> {
    if path.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "slcan",
            what: "the adapter's serial device",
            example: "slcan:///dev/ttyACM0?bitrate=500000",
        });
    }
    let mut opts = Options::parse(query, "slcan://", SLCAN_KEYS)?;
    let bitrate = opts.bitrate()?;
    let baud = opts.number("baud")?;
    Ok(PortSpec::Slcan {
        path: path.into(),
        bitrate,
        baud,
    })
}

fn parse_can(rest: &str, query: Option<&str>) -> Result<PortSpec, PortSpecErrorKind> {
    if rest.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "can",
            what: "a SocketCAN interface name",
            example: "can://can0",
        });
    }
    let (interface, trailing) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, ""),
    };
    if !trailing.is_empty() {
        return Err(PortSpecErrorKind::TrailingPath {
            rest: trailing.into(),
            after: interface.into(),
            scheme: "can",
            takes: "an interface name",
        });
    }
    if interface.len() > 15 {
        return Err(PortSpecErrorKind::BadInterface {
            name: interface.into(),
            reason: "longer than 15 characters (the kernel's limit)",
        });
    }
    if !interface
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(PortSpecErrorKind::BadInterface {
            name: interface.into(),
            reason: "use letters, digits, `-`, `_` and `.` only",
        });
    }
    let mut opts = Options::parse(query, "can://", CAN_KEYS)?;
    let bitrate = opts.bitrate()?;
    let baud = opts.number("baud")?;
    let bitrate = match (baud, bitrate) {
        (Some(baud), Some(bitrate)) if baud != bitrate => {
            return Err(PortSpecErrorKind::ConflictingRates { baud, bitrate });
        }
        (Some(baud), None) => Some(check_bitrate(baud)?),
        (_, bitrate) => bitrate,
    };
    Ok(PortSpec::SocketCan {
        interface: interface.into(),
        bitrate,
    })
}
