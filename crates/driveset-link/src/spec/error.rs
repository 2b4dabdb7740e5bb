//! What is wrong with a port string ([`PortSpecError`], [`PortSpecErrorKind`]):
//! each kind says what was given, what is wrong and what to write instead.

use crate::error::list;

use super::{ALLOWED_BAUDS, ALLOWED_BITRATES};

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
