//! SocketCAN interfaces (`can://can0`, Linux, cargo feature `socketcan`):
//! [`SocketCanLink`], a [`FrameLink`] on a raw CAN socket.
//!
//! The bit rate is a property of the interface, set by the administrator
//! (`ip link set can0 type can bitrate 500000`); the `bitrate` given here is
//! what the bus runs at, used for wire timing only. Error frames are not
//! requested from the kernel and are skipped if they arrive.

use std::io;
use std::time::Duration;

use socketcan::{
    CanFrame as SocketFrame, CanSocket, EmbeddedFrame, ExtendedId, Id, Socket, StandardId,
};

use crate::clock::{Clock, Instant, RealClock};
use crate::error::LinkError;
use crate::spec::ALLOWED_BITRATES;
use crate::{CanFrame, FrameLink};

/// A raw CAN socket bound to one interface.
#[derive(Debug)]
pub struct SocketCanLink {
    socket: CanSocket,
    name: String,
    bitrate: u32,
}

impl SocketCanLink {
    /// Open a raw CAN socket on `interface` (`can0`). `bitrate` is the
    /// interface's configured rate, one of [`ALLOWED_BITRATES`].
    pub fn open(interface: &str, bitrate: u32) -> Result<SocketCanLink, LinkError> {
        let name = format!("can://{interface}");
        if !ALLOWED_BITRATES.contains(&bitrate) {
            return Err(LinkError::UnsupportedBitrate {
                port: name,
                bitrate,
            });
        }
        let socket = CanSocket::open(interface).map_err(|e| match e.kind() {
            io::ErrorKind::NotFound => LinkError::NoDevice { port: name.clone() },
            _ => LinkError::Unsupported {
                port: name.clone(),
                what: format!(
                    "cannot open the CAN interface: {e}; check `ip link show {interface}` (it must exist and be up)"
                ),
            },
        })?;
        Ok(SocketCanLink {
            socket,
            name,
            bitrate,
        })
    }

    fn to_socket_frame(&self, frame: &CanFrame) -> Result<SocketFrame, LinkError> {
        let invalid = |source| LinkError::InvalidFrame {
            port: self.name.clone(),
            source,
        };
        frame.validate().map_err(invalid)?;
        let id: Id = if frame.extended {
            ExtendedId::new(frame.id).map(Id::Extended)
        } else {
            u16::try_from(frame.id)
                .ok()
                .and_then(StandardId::new)
                .map(Id::Standard)
        }
        .ok_or_else(|| LinkError::Unsupported {
            port: self.name.clone(),
            what: format!("CAN identifier 0x{:X} cannot be sent", frame.id),
        })?;
        let built = if frame.rtr {
            SocketFrame::new_remote(id, usize::from(frame.len))
        } else {
            SocketFrame::new(id, frame.payload())
        };
        built.ok_or_else(|| LinkError::Unsupported {
            port: self.name.clone(),
            what: format!("CAN frame {frame:?} cannot be built for SocketCAN"),
        })
    }
}

/// The proto frame for a received data or remote frame; `None` for error
/// frames.
fn from_socket_frame(frame: &SocketFrame) -> Option<CanFrame> {
    let (id, extended) = match frame.id() {
        Id::Standard(id) => (u32::from(id.as_raw()), false),
        Id::Extended(id) => (id.as_raw(), true),
    };
    let len = u8::try_from(frame.dlc().min(8)).unwrap_or(8);
    match frame {
        SocketFrame::Data(_) if extended => CanFrame::new_extended(id, frame.data()).ok(),
        SocketFrame::Data(_) => CanFrame::new(id, frame.data()).ok(),
        SocketFrame::Remote(_) if extended => CanFrame::new_remote_extended(id, len).ok(),
        SocketFrame::Remote(_) => CanFrame::new_remote(id, len).ok(),
        SocketFrame::Error(_) => None,
    }
}

impl FrameLink for SocketCanLink {
    fn port(&self) -> &str {
        &self.name
    }

    fn bus_id(&self) -> String {
        crate::bus_id::socketcan(self.name.strip_prefix("can://").unwrap_or(&self.name))
    }

    fn bitrate(&self) -> u32 {
        self.bitrate
    }

    fn clock(&self) -> &dyn Clock {
        &RealClock
    }

    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let frame = self.to_socket_frame(frame)?;
        self.socket
            .write_frame_insist(&frame)
            .map_err(|e| LinkError::io(&self.name, "send a CAN frame", e))
    }

    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        loop {
            let left: Duration = RealClock::remaining(deadline);
            match self.socket.read_frame_timeout(left) {
                Ok(frame) => {
                    if let Some(frame) = from_socket_frame(&frame) {
                        return Ok(Some(frame));
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                    ) =>
                {
                    return Ok(None);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(LinkError::io(&self.name, "receive a CAN frame", e)),
            }
            if RealClock.now() >= deadline {
                return Ok(None);
            }
        }
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        // Bounded: a busy bus must not keep us here forever.
        for _ in 0..4096 {
            match self.socket.read_frame_timeout(Duration::ZERO) {
                Ok(_) => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                    ) =>
                {
                    return Ok(());
                }
                Err(e) => return Err(LinkError::io(&self.name, "discard CAN input", e)),
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_convert_both_ways() {
        let frames = [
            CanFrame::new(0x601, &[0x40, 0x00, 0x20, 0x00]).unwrap(),
            CanFrame::new_extended(0x1ABC_DEF0, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap(),
            CanFrame::new_remote(0x7FF, 2).unwrap(),
            CanFrame::new(0x000, &[]).unwrap(),
        ];
        for frame in frames {
            let id: Id = if frame.extended {
                Id::Extended(ExtendedId::new(frame.id).unwrap())
            } else {
                Id::Standard(StandardId::new(frame.id as u16).unwrap())
            };
            let sock = if frame.rtr {
                SocketFrame::new_remote(id, usize::from(frame.len)).unwrap()
            } else {
                SocketFrame::new(id, frame.payload()).unwrap()
            };
            assert_eq!(from_socket_frame(&sock), Some(frame));
        }
    }
}
