//! slcan (Lawicel) USB-CAN adapters on a serial port
//! (`slcan:///dev/ttyACM0?bitrate=500000`): [`SlcanLink`], a [`FrameLink`]
//! that drives the adapter with the codec of [`driveset_proto::can::slcan`].
//!
//! Open sequence: `C\r` (close, in case a previous run left the channel
//! open; CR, BELL or silence are all fine), `Sn\r` (bit rate, `S0`..`S8`)
//! and `O\r` (open), each of the last two must be answered with CR; a BELL
//! or no answer is an error that says which command failed. A transmitted
//! frame is answered by CR or `z`/`Z` (accepted) or BELL (refused: transmit
//! buffer full, bus off). Adapters that do not acknowledge transmits at all
//! are detected on the first send and not waited for again. Frames that
//! arrive while a reply is awaited are kept for [`FrameLink::recv`].
//! Dropping the link closes the channel (`C\r`, best effort).

use std::collections::VecDeque;
use std::io::Write;
use std::time::Duration;

use driveset_proto::can::slcan::{
    Bitrate, ResponseDecoder, SlcanCommand, SlcanError, SlcanResponse,
};
use serialport::{DataBits, Parity, SerialPort};

use crate::CanFrame;
use crate::FrameLink;
use crate::clock::{Clock, Instant, RealClock};
use crate::error::LinkError;
use crate::serial;

/// What the adapter said to a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reply {
    /// CR, `z` or `Z`.
    Accepted,
    /// BELL.
    Refused,
    /// Nothing before the deadline.
    Silent,
}

/// An slcan adapter with its channel open at a fixed bit rate.
pub struct SlcanLink {
    port: Box<dyn SerialPort>,
    name: String,
    /// [`crate::bus_id::slcan`] of the adapter's device, resolved at open.
    bus: String,
    bitrate: u32,
    reply_timeout: Duration,
    decoder: ResponseDecoder,
    /// Decoded responses not yet looked at.
    inbox: VecDeque<Result<SlcanResponse, SlcanError>>,
    /// Frames received while waiting for a reply.
    frames: VecDeque<CanFrame>,
    /// Whether the adapter answers transmitted frames (learnt on the first
    /// send).
    acks_transmits: bool,
}

impl std::fmt::Debug for SlcanLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlcanLink")
            .field("port", &self.name)
            .field("bitrate", &self.bitrate)
            .field("acks_transmits", &self.acks_transmits)
            .finish()
    }
}

impl SlcanLink {
    /// Open the adapter on `path` (8N1 at `baud`, exclusively; USB CDC
    /// adapters ignore the rate), set `bitrate` (one of
    /// [`crate::spec::ALLOWED_BITRATES`]) and open the CAN channel. Each
    /// command may take `reply_timeout` to be answered.
    pub fn open(
        path: &str,
        bitrate: u32,
        baud: u32,
        reply_timeout: Duration,
    ) -> Result<SlcanLink, LinkError> {
        let name = format!("slcan://{path}");
        let rate = Bitrate::from_bits_per_second(bitrate).ok_or(LinkError::UnsupportedBitrate {
            port: name.clone(),
            bitrate,
        })?;
        let port =
            serial::open_port(path, baud, DataBits::Eight, Parity::None).map_err(|e| match e {
                // Name the port as the user wrote it.
                LinkError::Busy { .. } => LinkError::Busy { port: name.clone() },
                LinkError::NoDevice { .. } => LinkError::NoDevice { port: name.clone() },
                other => other,
            })?;
        SlcanLink::start(port, &name, rate, reply_timeout)
    }

    /// Run the open sequence on an already open serial port.
    pub fn start(
        port: Box<dyn SerialPort>,
        name: &str,
        bitrate: Bitrate,
        reply_timeout: Duration,
    ) -> Result<SlcanLink, LinkError> {
        let device = name.strip_prefix("slcan://").unwrap_or(name);
        let mut link = SlcanLink {
            port,
            name: name.into(),
            bus: crate::bus_id::slcan(device, bitrate.bits_per_second()),
            bitrate: bitrate.bits_per_second(),
            reply_timeout,
            decoder: ResponseDecoder::new(),
            inbox: VecDeque::new(),
            frames: VecDeque::new(),
            acks_transmits: true,
        };
        serial::discard_input(link.port.as_mut(), &link.name)?;
        // Close first: refused or unanswered when already closed, fine.
        link.command(SlcanCommand::Close)?;
        link.expect_accepted(SlcanCommand::SetBitrate(bitrate), "set the bit rate")?;
        link.expect_accepted(SlcanCommand::Open, "open the CAN channel")?;
        Ok(link)
    }

    /// Send a command and wait for its reply.
    fn command(&mut self, command: SlcanCommand) -> Result<Reply, LinkError> {
        let line = self.encode(&command)?;
        serial::write_all(self.port.as_mut(), &self.name, &line)?;
        let deadline = RealClock.deadline_in(self.reply_timeout);
        self.wait_reply(deadline)
    }

    fn expect_accepted(&mut self, command: SlcanCommand, what: &str) -> Result<(), LinkError> {
        let shown = self.shown(&command);
        match self.command(command)? {
            Reply::Accepted => Ok(()),
            Reply::Refused => Err(LinkError::Slcan {
                port: self.name.clone(),
                detail: format!("refused `{shown}` ({what}, answered BELL)"),
            }),
            Reply::Silent => Err(LinkError::Slcan {
                port: self.name.clone(),
                detail: format!(
                    "did not answer `{shown}` ({what}) within {:?}; is this an slcan adapter, on the right port and serial rate?",
                    self.reply_timeout
                ),
            }),
        }
    }

    fn encode(&self, command: &SlcanCommand) -> Result<Vec<u8>, LinkError> {
        command.to_bytes().map_err(|e| LinkError::Slcan {
            port: self.name.clone(),
            detail: format!("cannot be sent this frame: {e}"),
        })
    }

    /// A command as text for messages, without its CR.
    fn shown(&self, command: &SlcanCommand) -> String {
        let bytes = command.to_bytes().unwrap_or_default();
        String::from_utf8_lossy(bytes.strip_suffix(b"\r").unwrap_or(&bytes)).into_owned()
    }

    /// The next decoded response, reading from the port until `deadline`.
    fn next_response(
        &mut self,
        deadline: Instant,
    ) -> Result<Option<Result<SlcanResponse, SlcanError>>, LinkError> {
        let mut buf = [0u8; 256];
        loop {
            if let Some(response) = self.inbox.pop_front() {
                return Ok(Some(response));
            }
            let n = serial::read_until(self.port.as_mut(), &self.name, &mut buf, deadline)?;
            if n == 0 {
                return Ok(None);
            }
            for &byte in buf.iter().take(n) {
                if let Some(response) = self.decoder.push(byte) {
                    self.inbox.push_back(response);
                }
            }
        }
    }

    /// Wait for CR / `z` / `Z` or BELL, keeping frames that arrive
    /// meanwhile and skipping lines that do not decode.
    fn wait_reply(&mut self, deadline: Instant) -> Result<Reply, LinkError> {
        loop {
            match self.next_response(deadline)? {
                None => return Ok(Reply::Silent),
                Some(Ok(SlcanResponse::Ok | SlcanResponse::TransmitAck { .. })) => {
                    return Ok(Reply::Accepted);
                }
                Some(Ok(SlcanResponse::Error)) => return Ok(Reply::Refused),
                Some(Ok(SlcanResponse::Received { frame, .. })) => self.frames.push_back(frame),
                Some(Ok(_)) | Some(Err(_)) => {}
            }
        }
    }
}

impl FrameLink for SlcanLink {
    fn port(&self) -> &str {
        &self.name
    }

    fn bus_id(&self) -> String {
        self.bus.clone()
    }

    fn bitrate(&self) -> u32 {
        self.bitrate
    }

    fn clock(&self) -> &dyn Clock {
        &RealClock
    }

    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let command = SlcanCommand::Transmit(*frame);
        let line = self.encode(&command)?;
        serial::write_all(self.port.as_mut(), &self.name, &line)?;
        if !self.acks_transmits {
            return Ok(());
        }
        let deadline = RealClock.deadline_in(self.reply_timeout);
        match self.wait_reply(deadline)? {
            Reply::Accepted => Ok(()),
            Reply::Refused => Err(LinkError::Slcan {
                port: self.name.clone(),
                detail: format!(
                    "refused frame `{}` (BELL: transmit buffer full or bus off; check the bus wiring, termination and bit rate)",
                    self.shown(&command)
                ),
            }),
            Reply::Silent => {
                self.acks_transmits = false;
                Ok(())
            }
        }
    }

    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        if let Some(frame) = self.frames.pop_front() {
            return Ok(Some(frame));
        }
        loop {
            match self.next_response(deadline)? {
                None => return Ok(None),
                Some(Ok(SlcanResponse::Received { frame, .. })) => return Ok(Some(frame)),
                Some(Ok(SlcanResponse::Error)) => {
                    return Err(LinkError::Slcan {
                        port: self.name.clone(),
                        detail: "reported an error (BELL) while receiving".into(),
                    });
                }
                // Late acknowledgements, status lines: nothing for the caller.
                Some(Ok(_)) => {}
                Some(Err(e)) => {
                    return Err(LinkError::Slcan {
                        port: self.name.clone(),
                        detail: format!("sent a line that does not decode: {e}"),
                    });
                }
            }
        }
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.frames.clear();
        self.inbox.clear();
        self.decoder = ResponseDecoder::new();
        serial::discard_input(self.port.as_mut(), &self.name)
    }
}

impl Drop for SlcanLink {
    fn drop(&mut self) {
        // Best effort: leave the adapter closed for the next user.
        if let Ok(line) = SlcanCommand::Close.to_bytes() {
            let _ = self.port.write_all(&line);
            let _ = self.port.flush();
        }
    }
}
