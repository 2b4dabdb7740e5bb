//! Serial device servers speaking RFC 2217 (`rfc2217://host:port`):
//! [`Rfc2217Link`], a [`ByteLink`] over a telnet connection with the
//! COM-PORT-OPTION (option 44), so driveset sets the server's serial side
//! itself (rate, 7 data bits, even parity, 1 stop bit) instead of relying
//! on the server's configuration as raw `tcp://` does. ser2net, pyserial's
//! `serial.rfc2217.PortManager` and most device servers offer it.
//!
//! The telnet part ([`Telnet`], pure: no IO) follows RFC 854/855 and
//! RFC 2217:
//!
//! - Opening: driveset sends `IAC WILL BINARY`, `IAC DO BINARY`, `IAC WILL
//!   COM-PORT-OPTION` and waits for the server's `DO COM-PORT-OPTION` (or
//!   `WILL`). Requests for other options are answered once: `DO SGA` for
//!   the server's `WILL SUPPRESS-GO-AHEAD`, `DONT` for any other `WILL`
//!   (the server's `ECHO` included: it would return driveset's bytes),
//!   `WONT` for any `DO` besides BINARY and COM-PORT-OPTION. A `DONT` /
//!   `WONT COM-PORT-OPTION` is an error: the server is not an RFC 2217
//!   server (use `tcp://`).
//! - Line settings (RFC 2217 "SET-BAUDRATE" etc., client to server codes
//!   1..4): `IAC SB 44 1 <baud, 4 bytes big-endian> IAC SE`, `IAC SB 44 2 7
//!   IAC SE` (7 data bits), `IAC SB 44 3 3 IAC SE` (even parity), `IAC SB
//!   44 4 1 IAC SE` (1 stop bit). The server confirms each with its code
//!   plus 100 and the value it now uses; a different value is an error
//!   naming both.
//! - Data: `0xFF` (IAC) is doubled in both directions; telnet commands
//!   and sub-negotiations inside the data stream (e.g. NOTIFY-MODEMSTATE,
//!   107) are taken out and ignored.
//! - [`ByteLink::discard_input`] sends PURGE-DATA (`IAC SB 44 12 1 IAC
//!   SE`: purge the server's receive buffer) and drops what has arrived;
//!   the server's confirmation (112) is ignored when it comes.
//!
//! Rooms: this file holds the link ([`Rfc2217Link`]: connecting,
//! negotiating, the line settings and the data stream over a socket);
//! `telnet` the pure telnet codec and the COM-PORT-OPTION commands.

mod telnet;
#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::Duration;

use crate::ByteLink;
use crate::clock::{Clock, Instant, RealClock};
use crate::error::LinkError;
use crate::spec::ALLOWED_BAUDS;

pub use telnet::{
    BINARY, COM_PORT_OPTION, DO, DONT, IAC, PARITY_EVEN, PURGE_DATA, PURGE_RECEIVE, SB, SE,
    SERVER_OFFSET, SET_BAUDRATE, SET_DATASIZE, SET_PARITY, SET_STOPSIZE, SGA, STOPSIZE_1, Telnet,
    TelnetEvent, WILL, WONT, com_port_command, escape, line_settings,
};
use telnet::{setting_name, setting_value};

/// A connection to an RFC 2217 device server, its serial side set to 7E1
/// at the link's rate.
#[derive(Debug)]
pub struct Rfc2217Link {
    stream: TcpStream,
    name: String,
    /// [`crate::bus_id::tcp`] of the server connected to.
    bus: String,
    baud: u32,
    telnet: Telnet,
    data: VecDeque<u8>,
}

impl Rfc2217Link {
    /// Connect to `host:port`, negotiate COM-PORT-OPTION and set the
    /// server's line to `baud` 7E1. `timeout` bounds the connection and,
    /// separately, the negotiation.
    pub fn connect(
        host: &str,
        port: u16,
        baud: u32,
        timeout: Duration,
    ) -> Result<Rfc2217Link, LinkError> {
        let name = if host.contains(':') {
            format!("rfc2217://[{host}]:{port}")
        } else {
            format!("rfc2217://{host}:{port}")
        };
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(LinkError::UnsupportedBaud { port: name, baud });
        }
        let addrs = crate::tcp::resolve(&name, host, port)?;
        let stream = crate::tcp::connect_stream(&name, host, &addrs, timeout)?;
        Rfc2217Link::negotiate(stream, &name, baud, timeout)
    }

    /// Negotiate on a connected stream (see the module docs).
    pub fn negotiate(
        stream: TcpStream,
        name: &str,
        baud: u32,
        timeout: Duration,
    ) -> Result<Rfc2217Link, LinkError> {
        stream
            .set_nodelay(true)
            .map_err(|e| LinkError::io(name, "set TCP_NODELAY", e))?;
        let bus = crate::tcp::peer_bus(&stream, name)?;
        let mut link = Rfc2217Link {
            stream,
            name: name.into(),
            bus,
            baud,
            telnet: Telnet::new(),
            data: VecDeque::new(),
        };
        let opening = link.telnet.opening();
        link.write_raw(&opening)?;
        let deadline = RealClock.deadline_in(timeout);
        // 1. The server accepts COM-PORT-OPTION.
        let mut accepted = false;
        while !accepted {
            let events = link.read_events(deadline)?;
            if events.is_none() {
                return Err(LinkError::Rfc2217 {
                    port: link.name.clone(),
                    detail: format!(
                        "the server did not accept the telnet COM-PORT-OPTION (RFC 2217) within {timeout:?}; \
                         it may be a raw TCP server: use tcp://{} and set 7E1 and the rate on the server",
                        link.name.trim_start_matches("rfc2217://")
                    ),
                });
            }
            for e in events.unwrap_or_default() {
                match e {
                    TelnetEvent::Negotiate(cmd @ (DONT | WONT), COM_PORT_OPTION) => {
                        return Err(LinkError::Rfc2217 {
                            port: link.name.clone(),
                            detail: format!(
                                "the server refused the telnet COM-PORT-OPTION ({}): it does not let driveset set the line; \
                                 use tcp://{} and set 7E1 at {baud} baud on the server",
                                if cmd == DONT { "DONT" } else { "WONT" },
                                link.name.trim_start_matches("rfc2217://")
                            ),
                        });
                    }
                    TelnetEvent::Negotiate(cmd @ (DO | WILL), COM_PORT_OPTION) => {
                        let answer = link.telnet.answer(cmd, COM_PORT_OPTION);
                        link.write_raw(&answer)?;
                        accepted = true;
                    }
                    other => link.handle(other)?,
                }
            }
        }
        // 2. The line settings, each confirmed with the server's value.
        let settings = line_settings(baud);
        let mut out = Vec::new();
        for (code, value) in &settings {
            out.extend(com_port_command(*code, value));
        }
        link.write_raw(&out)?;
        let mut pending: Vec<(u8, Vec<u8>)> = settings;
        while !pending.is_empty() {
            let Some(events) = link.read_events(deadline)? else {
                let missing: Vec<&str> = pending.iter().map(|(c, _)| setting_name(*c)).collect();
                return Err(LinkError::Rfc2217 {
                    port: link.name.clone(),
                    detail: format!(
                        "the server did not confirm the {} within {timeout:?}; check that it is an RFC 2217 server",
                        missing.join(", ")
                    ),
                });
            };
            for e in events {
                match e {
                    TelnetEvent::Sub(sub)
                        if sub.len() >= 2
                            && sub[0] == COM_PORT_OPTION
                            && sub[1] > SERVER_OFFSET =>
                    {
                        let code = sub[1] - SERVER_OFFSET;
                        if let Some(i) = pending.iter().position(|(c, _)| *c == code) {
                            let (_, want) = pending.remove(i);
                            let got = &sub[2..];
                            if got != want.as_slice() {
                                return Err(LinkError::Rfc2217 {
                                    port: link.name.clone(),
                                    detail: format!(
                                        "the server set the {} to {} instead of {}: its serial port cannot run a 7E1 line at {baud} baud; \
                                         check the server's port or pick a rate it supports",
                                        setting_name(code),
                                        setting_value(code, got),
                                        setting_value(code, &want)
                                    ),
                                });
                            }
                        }
                    }
                    other => link.handle(other)?,
                }
            }
        }
        Ok(link)
    }

    /// Handle one event outside the negotiation steps: data is kept,
    /// option requests are answered, the rest is ignored.
    fn handle(&mut self, event: TelnetEvent) -> Result<(), LinkError> {
        match event {
            TelnetEvent::Data(b) => self.data.push_back(b),
            TelnetEvent::Negotiate(cmd, option) => {
                let answer = self.telnet.answer(cmd, option);
                if !answer.is_empty() {
                    self.write_raw(&answer)?;
                }
            }
            TelnetEvent::Sub(_) | TelnetEvent::Command(_) => {}
        }
        Ok(())
    }

    fn write_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.stream
            .write_all(bytes)
            .map_err(|e| LinkError::io(&self.name, "write to the device server", e))
    }

    /// Read once (until `deadline`); `None` if nothing arrived.
    fn read_events(&mut self, deadline: Instant) -> Result<Option<Vec<TelnetEvent>>, LinkError> {
        let mut buf = [0u8; 512];
        let n = self.read_once(&mut buf, deadline)?;
        if n == 0 {
            return Ok(None);
        }
        let mut events = Vec::new();
        self.telnet.feed(&buf[..n], &mut events);
        Ok(Some(events))
    }

    fn read_once(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        let left = RealClock::remaining(deadline);
        let nonblocking = left.is_zero();
        let setup = if nonblocking {
            self.stream.set_nonblocking(true)
        } else {
            self.stream
                .set_nonblocking(false)
                .and_then(|()| self.stream.set_read_timeout(Some(left)))
        };
        setup.map_err(|e| LinkError::io(&self.name, "set the read timeout", e))?;
        let result = self.stream.read(buf);
        if nonblocking {
            self.stream
                .set_nonblocking(false)
                .map_err(|e| LinkError::io(&self.name, "poll the connection", e))?;
        }
        crate::tcp::read_outcome(&self.name, result)
    }

    fn pump(&mut self, deadline: Instant) -> Result<bool, LinkError> {
        match self.read_events(deadline)? {
            None => Ok(false),
            Some(events) => {
                for e in events {
                    self.handle(e)?;
                }
                Ok(true)
            }
        }
    }
}

impl ByteLink for Rfc2217Link {
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
        let escaped = escape(bytes);
        self.write_raw(&escaped)
    }

    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        if buf.is_empty() {
            return Ok(0);
        }
        // Telnet traffic alone (a modem-state notification) does not count
        // as arrived data: keep waiting until data or the deadline.
        while self.data.is_empty() {
            if !self.pump(deadline)? {
                break;
            }
        }
        let n = buf.len().min(self.data.len());
        for (slot, b) in buf.iter_mut().zip(self.data.drain(..n)) {
            *slot = b;
        }
        Ok(n)
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.write_raw(&com_port_command(PURGE_DATA, &[PURGE_RECEIVE]))?;
        let now = RealClock.now();
        // Bounded: a server flooding us must not keep us here forever.
        for _ in 0..1024 {
            if !self.pump(now)? {
                break;
            }
        }
        self.data.clear();
        Ok(())
    }

    fn flush(&mut self) -> Result<(), LinkError> {
        self.stream
            .flush()
            .map_err(|e| LinkError::io(&self.name, "flush to the device server", e))
    }

    /// RFC 2217 SET-BAUDRATE (`IAC SB 44 1 <baud, 4 bytes big-endian> IAC
    /// SE`), then waits (up to 2 s) for the server's confirmation (code
    /// 101) with the same rate; data arriving meanwhile is kept.
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        if !ALLOWED_BAUDS.contains(&baud) {
            return Err(LinkError::UnsupportedBaud {
                port: self.name.clone(),
                baud,
            });
        }
        let value = baud.to_be_bytes();
        self.write_raw(&com_port_command(SET_BAUDRATE, &value))?;
        let deadline = RealClock.deadline_in(Duration::from_secs(2));
        loop {
            let Some(events) = self.read_events(deadline)? else {
                return Err(LinkError::Rfc2217 {
                    port: self.name.clone(),
                    detail: format!(
                        "the server did not confirm the baud rate {baud} within 2 s; check that it is an RFC 2217 server"
                    ),
                });
            };
            let mut confirmed = None;
            for e in events {
                match e {
                    TelnetEvent::Sub(sub)
                        if sub.len() >= 2
                            && sub[0] == COM_PORT_OPTION
                            && sub[1] == SERVER_OFFSET + SET_BAUDRATE =>
                    {
                        confirmed = Some(sub[2..].to_vec());
                    }
                    other => self.handle(other)?,
                }
            }
            if let Some(got) = confirmed {
                if got != value {
                    return Err(LinkError::Rfc2217 {
                        port: self.name.clone(),
                        detail: format!(
                            "the server set the baud rate to {} instead of {baud}: its serial port cannot run at that rate; pick a rate it supports",
                            setting_value(SET_BAUDRATE, &got)
                        ),
                    });
                }
                self.baud = baud;
                return Ok(());
            }
        }
    }
}

impl Drop for Rfc2217Link {
    fn drop(&mut self) {
        // Best effort: free the server's port for the next client.
        let _ = self.stream.shutdown(Shutdown::Both);
    }
}
