//! The error type of every transport in this crate: [`LinkError`]. Each
//! variant names the port (its canonical port string), says what failed and
//! what to do about it.

use std::io;
use std::time::Duration;

use crate::spec::{ALLOWED_BAUDS, ALLOWED_BITRATES};

/// Format a list of numbers as `a, b, c`.
pub(crate) fn list(values: &[u32]) -> String {
    values
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Why a transport could not be opened or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// A 7E1 line was asked to run at a rate driveset does not support.
    #[error(
        "{port}: {baud} baud is not supported; LUSTBUS and LECOM lines (7E1) run at {} baud: pick one of these and set the drives to match",
        list(ALLOWED_BAUDS)
    )]
    UnsupportedBaud {
        /// The port.
        port: String,
        /// The rejected rate.
        baud: u32,
    },

    /// A CAN bit rate that slcan adapters cannot be set to.
    #[error(
        "{port}: CAN bit rate {bitrate} is not supported; use one of {} bit/s (the drives' system bus rate)",
        list(ALLOWED_BITRATES)
    )]
    UnsupportedBitrate {
        /// The port.
        port: String,
        /// The rejected rate.
        bitrate: u32,
    },

    /// A byte with bit 7 set was handed to a 7-bit line. The UART adds the
    /// parity bit; the codec must hand over plain 7-bit characters.
    #[error(
        "{port}: byte 0x{byte:02X} at offset {offset} of the telegram has bit 7 set; a 7E1 line carries 7-bit characters (this is a codec bug, please report it)"
    )]
    NotSevenBit {
        /// The port.
        port: String,
        /// Offset of the byte in the buffer passed to `send`.
        offset: usize,
        /// The byte.
        byte: u8,
    },

    /// A CAN frame that is not valid (identifier or length out of range).
    #[error(
        "{port}: cannot send this CAN frame: {source} (this is a bug in the caller, please report it)"
    )]
    InvalidFrame {
        /// The port.
        port: String,
        /// What is wrong with it.
        source: driveset_proto::can::FrameError,
    },

    /// The port is held by another program.
    #[error(
        "{port} is in use by another program (or another driveset run): close it and try again"
    )]
    Busy {
        /// The port.
        port: String,
    },

    /// The serial device does not exist.
    #[error(
        "{port}: no such serial device; check the path (`/dev/ttyUSB0`, `COM3`) and that the adapter is plugged in"
    )]
    NoDevice {
        /// The port.
        port: String,
    },

    /// A serial port could not be opened or configured.
    #[error(
        "{port}: cannot {op}: {source}; check the path, that the adapter is plugged in and that you may use it (on Linux: the `dialout` group)"
    )]
    Serial {
        /// The port.
        port: String,
        /// What was being done.
        op: &'static str,
        /// The cause.
        source: serialport::Error,
    },

    /// An IO operation on an open transport failed.
    #[error("{port}: {op} failed: {source}; check the cable and the adapter, then retry")]
    Io {
        /// The port.
        port: String,
        /// What was being done.
        op: &'static str,
        /// The cause.
        source: io::Error,
    },

    /// A host name did not resolve.
    #[error("{port}: cannot resolve host `{host}`: {detail}; check the name or use an IP address")]
    Resolve {
        /// The port.
        port: String,
        /// The host.
        host: String,
        /// Why.
        detail: String,
    },

    /// Nothing listens on the device server's port.
    #[error(
        "{port}: connection refused by {addr}; check that the device server is on and its port is in raw TCP mode"
    )]
    ConnectionRefused {
        /// The port.
        port: String,
        /// The address tried.
        addr: String,
    },

    /// The device server did not answer the connection attempt in time.
    #[error(
        "{port}: no answer from {addr} within {timeout:?}; check the address, the network and any firewall"
    )]
    ConnectTimeout {
        /// The port.
        port: String,
        /// The address tried.
        addr: String,
        /// The connect timeout.
        timeout: Duration,
    },

    /// The device server reset the connection.
    #[error(
        "{port}: connection reset by the device server; another client may have taken the port: reconnect"
    )]
    ConnectionReset {
        /// The port.
        port: String,
    },

    /// The other end closed the connection.
    #[error(
        "{port}: the other end closed the connection; check the device server (or adapter) and reconnect"
    )]
    ConnectionClosed {
        /// The port.
        port: String,
    },

    /// The slcan adapter refused a command or said something unexpected.
    #[error("{port}: slcan adapter {detail}; unplug and replug the adapter, then retry")]
    Slcan {
        /// The port.
        port: String,
        /// What happened.
        detail: String,
    },

    /// An RFC 2217 device server refused or did not confirm the telnet
    /// COM-PORT-OPTION or a line setting.
    #[error("{port}: {detail}")]
    Rfc2217 {
        /// The port.
        port: String,
        /// What went wrong and what to do.
        detail: String,
    },

    /// A port of a scheme no registered [`crate::PortOpener`] opens
    /// (`sim://` without the simulator's opener).
    #[error("{port}: open sim:// ports through the simulator (driveset-sim), not driveset-link")]
    SimPort {
        /// The port.
        port: String,
    },

    /// A transport this build does not include.
    #[error("{port}: {what}")]
    Unsupported {
        /// The port.
        port: String,
        /// What is missing and how to get it.
        what: String,
    },
}

impl LinkError {
    /// An [`LinkError::Io`] with the port and the operation, mapping the
    /// kinds that have their own variant (reset, closed).
    pub(crate) fn io(port: &str, op: &'static str, source: io::Error) -> Self {
        match source.kind() {
            io::ErrorKind::ConnectionReset | io::ErrorKind::ConnectionAborted => {
                LinkError::ConnectionReset { port: port.into() }
            }
            io::ErrorKind::BrokenPipe | io::ErrorKind::UnexpectedEof => {
                LinkError::ConnectionClosed { port: port.into() }
            }
            _ => LinkError::Io {
                port: port.into(),
                op,
                source,
            },
        }
    }

    /// The error for a 7-bit line handed a byte with bit 7 set, if any.
    pub(crate) fn check_seven_bit(port: &str, bytes: &[u8]) -> Result<(), LinkError> {
        match bytes.iter().enumerate().find(|(_, b)| **b & 0x80 != 0) {
            Some((offset, &byte)) => Err(LinkError::NotSevenBit {
                port: port.into(),
                offset,
                byte,
            }),
            None => Ok(()),
        }
    }
}
