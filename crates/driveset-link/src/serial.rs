//! Local serial ports through the `serialport` crate: [`SerialLink`], a
//! [`ByteLink`] for LUSTBUS / LECOM lines (7 data bits, even parity, 1 stop
//! bit at one of [`ALLOWED_BAUDS`]), opened exclusively. Also the raw
//! port helpers [`crate::slcan`] shares (8N1 adapter lines).
//!
//! The UART adds the parity bit: [`SerialLink::send`] takes plain 7-bit
//! characters and refuses bytes with bit 7 set. Received bytes are passed on
//! as read; masking bit 7 is the codec's job.

use std::io;
use std::time::Duration;

use serialport::{ClearBuffer, DataBits, FlowControl, Parity, SerialPort, StopBits};

use crate::ByteLink;
use crate::clock::{Clock, Instant, RealClock};
use crate::error::LinkError;
use crate::spec::ALLOWED_BAUDS;

/// A 7E1 serial port: a LUSTBUS or LECOM line.
pub struct SerialLink {
    port: Box<dyn SerialPort>,
    name: String,
    /// [`crate::bus_id::serial`] of the path, resolved at open.
    bus: String,
    baud: u32,
}

impl std::fmt::Debug for SerialLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SerialLink")
            .field("port", &self.name)
            .field("baud", &self.baud)
            .finish()
    }
}

impl SerialLink {
    /// Open `path` (`/dev/ttyUSB0`, `COM3`) exclusively at `baud`, 7E1, no
    /// flow control. Rates outside [`ALLOWED_BAUDS`] are refused before the
    /// port is touched.
    pub fn open(path: &str, baud: u32) -> Result<SerialLink, LinkError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(LinkError::UnsupportedBaud {
                port: path.into(),
                baud,
            });
        }
        let port = open_port(path, baud, DataBits::Seven, Parity::Even)?;
        Ok(SerialLink {
            port,
            name: path.into(),
            bus: crate::bus_id::serial(path),
            baud,
        })
    }
}

/// Open a serial port exclusively with the given framing and 1 stop bit,
/// mapping the failures to [`LinkError`]s that name the port.
pub(crate) fn open_port(
    path: &str,
    baud: u32,
    data_bits: DataBits,
    parity: Parity,
) -> Result<Box<dyn SerialPort>, LinkError> {
    serialport::new(path, baud)
        .data_bits(data_bits)
        .parity(parity)
        .stop_bits(StopBits::One)
        .flow_control(FlowControl::None)
        .exclusive(true)
        .timeout(Duration::from_millis(100))
        .open()
        .map_err(|source| open_error(path, source))
}

fn open_error(path: &str, source: serialport::Error) -> LinkError {
    match source.kind() {
        // serialport reports a failed TIOCEXCL (EBUSY) or flock as NoDevice.
        serialport::ErrorKind::NoDevice => LinkError::Busy { port: path.into() },
        serialport::ErrorKind::Io(io::ErrorKind::NotFound) => {
            LinkError::NoDevice { port: path.into() }
        }
        _ => LinkError::Serial {
            port: path.into(),
            op: "open the serial port",
            source,
        },
    }
}

/// Write all of `bytes` to a serial port.
pub(crate) fn write_all(
    port: &mut dyn SerialPort,
    name: &str,
    bytes: &[u8],
) -> Result<(), LinkError> {
    port.write_all(bytes)
        .map_err(|e| LinkError::io(name, "write to the serial port", e))
}

/// Wait until some bytes are readable or `deadline` (real time) passes;
/// read what is there into `buf`. `Ok(0)` means nothing arrived.
pub(crate) fn read_until(
    port: &mut dyn SerialPort,
    name: &str,
    buf: &mut [u8],
    deadline: Instant,
) -> Result<usize, LinkError> {
    if buf.is_empty() {
        return Ok(0);
    }
    loop {
        let left = RealClock::remaining(deadline);
        port.set_timeout(left).map_err(|source| LinkError::Serial {
            port: name.into(),
            op: "set the read timeout",
            source,
        })?;
        match port.read(buf) {
            Ok(n) => return Ok(n),
            Err(e) if e.kind() == io::ErrorKind::TimedOut => return Ok(0),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(0),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {
                if RealClock.now() >= deadline {
                    return Ok(0);
                }
            }
            Err(e) => return Err(LinkError::io(name, "read from the serial port", e)),
        }
    }
}

/// Drop whatever the port has received and not yet been read.
pub(crate) fn discard_input(port: &mut dyn SerialPort, name: &str) -> Result<(), LinkError> {
    port.clear(ClearBuffer::Input)
        .map_err(|source| LinkError::Serial {
            port: name.into(),
            op: "discard pending input",
            source,
        })
}

/// Wait until everything written has left the UART.
pub(crate) fn flush(port: &mut dyn SerialPort, name: &str) -> Result<(), LinkError> {
    port.flush()
        .map_err(|e| LinkError::io(name, "drain the serial output", e))
}

impl ByteLink for SerialLink {
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
        write_all(self.port.as_mut(), &self.name, bytes)
    }

    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        read_until(self.port.as_mut(), &self.name, buf, deadline)
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        discard_input(self.port.as_mut(), &self.name)
    }

    /// `serialport`'s `set_baud_rate` (termios / SetCommState); the port
    /// stays open, 7E1 kept.
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(LinkError::UnsupportedBaud {
                port: self.name.clone(),
                baud,
            });
        }
        flush(self.port.as_mut(), &self.name)?;
        self.port
            .set_baud_rate(baud)
            .map_err(|source| LinkError::Serial {
                port: self.name.clone(),
                op: "set the line rate",
                source,
            })?;
        self.baud = baud;
        Ok(())
    }

    fn flush(&mut self) -> Result<(), LinkError> {
        flush(self.port.as_mut(), &self.name)
    }
}
