//! driveset-link owns the byte and frame transports between driveset and
//! the drives, and the clock the engine and the simulator run on.
//!
//! - [`clock`]: [`Clock`], [`Instant`], [`RealClock`], [`VirtualClock`].
//! - [`ByteLink`]: a LUSTBUS / LECOM line (ASCII 7E1 over RS-485), as a
//!   local [`serial::SerialLink`], a [`tcp::TcpLink`] to a serial device
//!   server in raw mode, an [`rfc2217::Rfc2217Link`] to a device server
//!   speaking RFC 2217 (which sets 7E1 and the rate on the server), or one
//!   end of an in-memory [`mem::byte_pair`]; [`echo::EchoLink`] strips the
//!   echo of 2-wire RS-485 adapters (`?echo=auto|on|off`).
//! - [`FrameLink`]: a CAN bus (Lenze system bus), as an
//!   [`slcan::SlcanLink`] USB-CAN adapter, a SocketCAN interface (feature
//!   `socketcan`), or one end of an in-memory [`mem::frame_pair`].
//! - [`spec`]: the port syntax ([`PortSpec`]) and [`open`], which opens the
//!   real transports from it.
//! - [`usb`]: what Linux says of a USB serial adapter (its latency timer).
//!
//! Links move bytes and frames only: framing, checksums, masking bit 7 and
//! retries are the codecs' (driveset-proto) and the engine's business.
//! Receive deadlines are [`Instant`]s of the link's own [`ByteLink::clock`]
//! / [`FrameLink::clock`].
//!
//! A request and its reply on an in-memory line, in virtual time:
//!
//! ```
//! use driveset_link::{ByteLink, Clock, Instant, VirtualClock, mem};
//!
//! let clock = VirtualClock::new();
//! let (mut host, mut drive) = mem::byte_pair(&clock, 9600)?;
//! host.send(b"\x04@00091\x05")?; // 8 characters: 8 x 10 / 9600 s
//! let mut buf = [0u8; 32];
//! let n = drive.recv(&mut buf, clock.deadline_in(std::time::Duration::from_millis(100)))?;
//! assert_eq!(&buf[..n], b"\x04@00091\x05");
//! assert_eq!(clock.now(), Instant::from_nanos(8_333_333));
//! # Ok::<(), driveset_link::LinkError>(())
//! ```

#![warn(missing_docs)]

pub mod bus_id;
pub mod clock;
pub mod echo;
pub mod error;
pub mod lock;
pub mod mem;
pub mod rfc2217;
pub mod serial;
pub mod slcan;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;
pub mod spec;
pub mod tcp;
pub mod usb;

mod open;

pub use clock::{Clock, Instant, RealClock, VirtualClock};
pub use driveset_proto::can::CanFrame;
pub use echo::{EchoLink, EchoMode};
pub use error::LinkError;
pub use lock::{BusLock, LockError};
pub use open::{Link, OpenOptions, Openers, PortOpener, PortShape, open, open_with};
pub use spec::{OpaqueSpec, PortSpec, PortSpecError, PortSpecErrorKind};

/// A byte line to LUSTBUS / LECOM drives (7E1; the transport adds parity).
///
/// All methods take `&mut self`: one transaction at a time per line.
pub trait ByteLink: Send + std::fmt::Debug {
    /// The port, as errors and reports name it.
    fn port(&self) -> &str;

    /// Which bus this is, independent of how its port was spelled (see
    /// [`bus_id`]): journals record it so a transaction stays bound to its
    /// drive, name their file by it and lock it. No default: every link
    /// and every wrapper says which bus it is (a wrapper asks the link it
    /// wraps), so no spelling of a port can stand in for its bus.
    fn bus_id(&self) -> String;

    /// The line rate in baud (for wire-time calculations).
    fn baud(&self) -> u32;

    /// The clock whose instants [`ByteLink::recv`] deadlines are in.
    fn clock(&self) -> &dyn Clock;

    /// Send `bytes` (7-bit characters; a byte with bit 7 set is refused
    /// with [`LinkError::NotSevenBit`] and nothing is sent).
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError>;

    /// Wait until at least one byte has arrived or `deadline` has passed,
    /// then copy what has arrived (up to `buf.len()`) into `buf`. Returns
    /// the count; `0` means nothing arrived by the deadline.
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError>;

    /// Drop everything received and not yet read (before a new request,
    /// so a late answer to the previous one cannot be taken for its reply).
    fn discard_input(&mut self) -> Result<(), LinkError>;

    /// Wait until everything sent has left the transport.
    fn flush(&mut self) -> Result<(), LinkError>;

    /// Set the host side of the line to `baud` (one of [`spec::ALLOWED_BAUDS`]),
    /// after the drives were told to change their rate (LUSTBUS 11.5: an
    /// MC6000/7000 activates a new 81-SBAUD at 4-PROG = 111). Characters
    /// still in the transport were sent at the old rate: call
    /// [`ByteLink::flush`] first. Default: [`LinkError::Unsupported`] naming
    /// the port (a transport that cannot change its rate).
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        Err(LinkError::Unsupported {
            port: self.port().to_string(),
            what: format!(
                "this transport cannot change its line rate (asked for {baud} baud); reopen the port at that rate"
            ),
        })
    }
}

impl<L: ByteLink + ?Sized> ByteLink for Box<L> {
    fn port(&self) -> &str {
        (**self).port()
    }
    fn bus_id(&self) -> String {
        (**self).bus_id()
    }
    fn baud(&self) -> u32 {
        (**self).baud()
    }
    fn clock(&self) -> &dyn Clock {
        (**self).clock()
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        (**self).send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        (**self).recv(buf, deadline)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        (**self).discard_input()
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        (**self).flush()
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        (**self).set_baud(baud)
    }
}

/// A CAN bus (classic CAN 2.0 frames of [`driveset_proto::can`]).
pub trait FrameLink: Send + std::fmt::Debug {
    /// The port, as errors and reports name it.
    fn port(&self) -> &str;

    /// Which bus this is, independent of how its port was spelled (see
    /// [`bus_id`]). No default, as [`ByteLink::bus_id`].
    fn bus_id(&self) -> String;

    /// The bus bit rate in bit/s (for wire-time calculations).
    fn bitrate(&self) -> u32;

    /// The clock whose instants [`FrameLink::recv`] deadlines are in.
    fn clock(&self) -> &dyn Clock;

    /// Send one frame.
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError>;

    /// The next frame received by `deadline`, or `None`.
    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError>;

    /// Drop every frame received and not yet read.
    fn discard_input(&mut self) -> Result<(), LinkError>;
}
impl<L: FrameLink + ?Sized> FrameLink for Box<L> {
    fn port(&self) -> &str {
        (**self).port()
    }
    fn bus_id(&self) -> String {
        (**self).bus_id()
    }
    fn bitrate(&self) -> u32 {
        (**self).bitrate()
    }
    fn clock(&self) -> &dyn Clock {
        (**self).clock()
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        (**self).send(frame)
    }
    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        (**self).recv(deadline)
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        (**self).discard_input()
    }
}
