//! Serial device servers in raw TCP mode (`tcp://host:port`): [`TcpLink`],
//! a [`ByteLink`] over a TCP connection whose far end is a 7E1 RS-485 line.
//!
//! Connects with a timeout, sets TCP_NODELAY (a telegram is small and the
//! drive is waiting for it), implements receive deadlines with socket read
//! timeouts, and maps refused / reset / closed / timed-out connections to
//! their own [`LinkError`] variants. The line rate is configured on the
//! device server; the `baud` given here is what the server's line runs at
//! (used for wire timing), it is not sent anywhere.

use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

use crate::ByteLink;
use crate::clock::{Clock, Instant, RealClock};
use crate::error::LinkError;
use crate::spec::ALLOWED_BAUDS;

/// How long [`TcpLink::connect`] waits for each address by default.
pub const DEFAULT_CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// A connection to a serial device server in raw TCP mode.
#[derive(Debug)]
pub struct TcpLink {
    stream: TcpStream,
    name: String,
    /// [`crate::bus_id::tcp`] of the peer connected to.
    bus: String,
    baud: u32,
}

impl TcpLink {
    /// Connect to `host:port`, trying each resolved address for at most
    /// `connect_timeout`. `baud` is the server's line rate, one of
    /// [`ALLOWED_BAUDS`].
    pub fn connect(
        host: &str,
        port: u16,
        baud: u32,
        connect_timeout: Duration,
    ) -> Result<TcpLink, LinkError> {
        let name = if host.contains(':') {
            format!("tcp://[{host}]:{port}")
        } else {
            format!("tcp://{host}:{port}")
        };
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(LinkError::UnsupportedBaud { port: name, baud });
        }
        let addrs = resolve(&name, host, port)?;
        let stream = connect_stream(&name, host, &addrs, connect_timeout)?;
        TcpLink::from_stream(stream, &name, baud)
    }

    /// Wrap a connected stream (sets TCP_NODELAY).
    pub fn from_stream(stream: TcpStream, name: &str, baud: u32) -> Result<TcpLink, LinkError> {
        stream
            .set_nodelay(true)
            .map_err(|e| LinkError::io(name, "set TCP_NODELAY", e))?;
        let bus = peer_bus(&stream, name)?;
        Ok(TcpLink {
            stream,
            name: name.into(),
            bus,
            baud,
        })
    }

    /// Read without waiting; `Ok(0)` if nothing is there.
    fn read_now(&mut self, buf: &mut [u8]) -> Result<usize, LinkError> {
        self.stream
            .set_nonblocking(true)
            .map_err(|e| LinkError::io(&self.name, "poll the connection", e))?;
        let result = self.stream.read(buf);
        self.stream
            .set_nonblocking(false)
            .map_err(|e| LinkError::io(&self.name, "poll the connection", e))?;
        self.read_result(result)
    }

    fn read_result(&self, result: io::Result<usize>) -> Result<usize, LinkError> {
        read_outcome(&self.name, result)
    }
}

/// What one read from a device server's socket means: bytes, nothing yet
/// (would block, timed out, interrupted), or a closed or failed connection
/// naming `name` (shared with [`crate::rfc2217`]).
pub(crate) fn read_outcome(name: &str, result: io::Result<usize>) -> Result<usize, LinkError> {
    match result {
        Ok(0) => Err(LinkError::ConnectionClosed {
            port: name.to_string(),
        }),
        Ok(n) => Ok(n),
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
            ) =>
        {
            Ok(0)
        }
        Err(e) => Err(LinkError::io(name, "read from the device server", e)),
    }
}

/// Connect to the first of `addrs` that accepts within `connect_timeout`
/// each; errors name `name` (shared with [`crate::rfc2217`]).
pub(crate) fn connect_stream(
    name: &str,
    host: &str,
    addrs: &[SocketAddr],
    connect_timeout: Duration,
) -> Result<TcpStream, LinkError> {
    // A zero timeout is refused by std; wait at least a millisecond.
    let timeout = connect_timeout.max(Duration::from_millis(1));
    let mut last = None;
    for addr in addrs {
        match TcpStream::connect_timeout(addr, timeout) {
            Ok(stream) => return Ok(stream),
            Err(e) => last = Some(connect_error(name, *addr, timeout, e)),
        }
    }
    Err(last.unwrap_or(LinkError::Resolve {
        port: name.into(),
        host: host.into(),
        detail: "no addresses".into(),
    }))
}

/// Resolve `host:port`; errors name `name`.
/// The bus a connected stream reaches: [`crate::bus_id::tcp`] of the
/// address actually connected to (the host resolved, whichever of its
/// addresses answered), shared by [`TcpLink`] and
/// [`crate::rfc2217::Rfc2217Link`].
pub(crate) fn peer_bus(stream: &TcpStream, name: &str) -> Result<String, LinkError> {
    stream
        .peer_addr()
        .map(crate::bus_id::tcp)
        .map_err(|e| LinkError::io(name, "read the address connected to", e))
}

pub(crate) fn resolve(name: &str, host: &str, port: u16) -> Result<Vec<SocketAddr>, LinkError> {
    let addrs: Vec<SocketAddr> = (host, port)
        .to_socket_addrs()
        .map_err(|e| LinkError::Resolve {
            port: name.into(),
            host: host.into(),
            detail: e.to_string(),
        })?
        .collect();
    if addrs.is_empty() {
        return Err(LinkError::Resolve {
            port: name.into(),
            host: host.into(),
            detail: "no addresses".into(),
        });
    }
    Ok(addrs)
}

fn connect_error(name: &str, addr: SocketAddr, timeout: Duration, e: io::Error) -> LinkError {
    match e.kind() {
        io::ErrorKind::ConnectionRefused => LinkError::ConnectionRefused {
            port: name.into(),
            addr: addr.to_string(),
        },
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock => LinkError::ConnectTimeout {
            port: name.into(),
            addr: addr.to_string(),
            timeout,
        },
        _ => LinkError::io(name, "connect to the device server", e),
    }
}

impl ByteLink for TcpLink {
    fn port(&self) -> &str {
        &self.name
    }

    fn bus_id(&self) -> String {
        self.bus.clone()
    }

    fn baud(&self) -> u32 {
        self.baud
    }

    fn clock(&self) -> &dyn Clock {
        &RealClock
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        LinkError::check_seven_bit(&self.name, bytes)?;
        self.stream
            .write_all(bytes)
            .map_err(|e| LinkError::io(&self.name, "write to the device server", e))
    }

    /// A raw TCP server's serial side is set on the server: driveset
    /// cannot change it.
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        Err(LinkError::Unsupported {
            port: self.name.clone(),
            what: format!(
                "a raw tcp:// device server keeps the line rate it is configured with, so driveset cannot switch it to {baud} baud; use rfc2217://{} so driveset can set the device server's rate",
                self.name.trim_start_matches("tcp://")
            ),
        })
    }

    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let left = RealClock::remaining(deadline);
        if left.is_zero() {
            return self.read_now(buf);
        }
        self.stream
            .set_read_timeout(Some(left))
            .map_err(|e| LinkError::io(&self.name, "set the read timeout", e))?;
        let result = self.stream.read(buf);
        self.read_result(result)
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        let mut scratch = [0u8; 256];
        // Bounded: a server flooding us must not keep us here forever.
        for _ in 0..1024 {
            if self.read_now(&mut scratch)? == 0 {
                break;
            }
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), LinkError> {
        self.stream
            .flush()
            .map_err(|e| LinkError::io(&self.name, "flush to the device server", e))
    }
}

impl Drop for TcpLink {
    fn drop(&mut self) {
        // Best effort: tell the device server we are gone so it frees the
        // port for the next client. Nothing to report if it fails.
        let _ = self.stream.shutdown(Shutdown::Both);
    }
}
