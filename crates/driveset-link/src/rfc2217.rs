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

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::Duration;

use crate::ByteLink;
use crate::clock::{Clock, Instant, RealClock};
use crate::error::LinkError;
use crate::spec::ALLOWED_BAUDS;

/// Telnet "interpret as command".
pub const IAC: u8 = 0xFF;
/// Telnet DONT.
pub const DONT: u8 = 0xFE;
/// Telnet DO.
pub const DO: u8 = 0xFD;
/// Telnet WONT.
pub const WONT: u8 = 0xFC;
/// Telnet WILL.
pub const WILL: u8 = 0xFB;
/// Telnet sub-negotiation begin.
pub const SB: u8 = 0xFA;
/// Telnet sub-negotiation end.
pub const SE: u8 = 0xF0;
/// Telnet option BINARY (RFC 856).
pub const BINARY: u8 = 0;
/// Telnet option SUPPRESS-GO-AHEAD (RFC 858).
pub const SGA: u8 = 3;
/// Telnet option COM-PORT-OPTION (RFC 2217).
pub const COM_PORT_OPTION: u8 = 44;

/// RFC 2217 SET-BAUDRATE (client to server).
pub const SET_BAUDRATE: u8 = 1;
/// RFC 2217 SET-DATASIZE.
pub const SET_DATASIZE: u8 = 2;
/// RFC 2217 SET-PARITY.
pub const SET_PARITY: u8 = 3;
/// RFC 2217 SET-STOPSIZE.
pub const SET_STOPSIZE: u8 = 4;
/// RFC 2217 PURGE-DATA.
pub const PURGE_DATA: u8 = 12;
/// Server-to-client codes are the client's + 100.
pub const SERVER_OFFSET: u8 = 100;
/// SET-PARITY value EVEN.
pub const PARITY_EVEN: u8 = 3;
/// SET-STOPSIZE value 1.
pub const STOPSIZE_1: u8 = 1;
/// PURGE-DATA value: the access server's receive buffer.
pub const PURGE_RECEIVE: u8 = 1;

/// One thing the telnet parser found in the stream from the server.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TelnetEvent {
    /// A data byte (IAC IAC already undone).
    Data(u8),
    /// DO / DONT / WILL / WONT and the option.
    Negotiate(u8, u8),
    /// A sub-negotiation's bytes between `IAC SB` and `IAC SE` (IAC IAC
    /// undone), starting with the option.
    Sub(Vec<u8>),
    /// Another telnet command (NOP, GA, ...).
    Command(u8),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum ParseState {
    #[default]
    Data,
    Iac,
    Negotiate(u8),
    Sub,
    SubIac,
}

/// The telnet side of an RFC 2217 connection, without IO: parses what the
/// server sends ([`Telnet::feed`]) and builds what driveset sends.
#[derive(Debug)]
pub struct Telnet {
    state: ParseState,
    sub: Vec<u8>,
    /// Options we have answered or requested, per direction, so that each
    /// request is answered once (no negotiation loops, RFC 854).
    said_us: [Option<bool>; 256],
    said_them: [Option<bool>; 256],
}

impl Default for Telnet {
    fn default() -> Self {
        Telnet::new()
    }
}

impl Telnet {
    /// A parser at the start of a connection.
    pub fn new() -> Self {
        Telnet {
            state: ParseState::Data,
            sub: Vec::new(),
            said_us: [None; 256],
            said_them: [None; 256],
        }
    }

    /// What driveset sends first: `IAC WILL BINARY`, `IAC DO BINARY`,
    /// `IAC WILL COM-PORT-OPTION`.
    pub fn opening(&mut self) -> Vec<u8> {
        self.said_us[BINARY as usize] = Some(true);
        self.said_them[BINARY as usize] = Some(true);
        self.said_us[COM_PORT_OPTION as usize] = Some(true);
        vec![
            IAC,
            WILL,
            BINARY,
            IAC,
            DO,
            BINARY,
            IAC,
            WILL,
            COM_PORT_OPTION,
        ]
    }

    /// Parse bytes from the server into events.
    pub fn feed(&mut self, bytes: &[u8], out: &mut Vec<TelnetEvent>) {
        for &b in bytes {
            self.state = match (self.state, b) {
                (ParseState::Data, IAC) => ParseState::Iac,
                (ParseState::Data, _) => {
                    out.push(TelnetEvent::Data(b));
                    ParseState::Data
                }
                (ParseState::Iac, IAC) => {
                    out.push(TelnetEvent::Data(IAC));
                    ParseState::Data
                }
                (ParseState::Iac, DO | DONT | WILL | WONT) => ParseState::Negotiate(b),
                (ParseState::Iac, SB) => {
                    self.sub.clear();
                    ParseState::Sub
                }
                (ParseState::Iac, _) => {
                    out.push(TelnetEvent::Command(b));
                    ParseState::Data
                }
                (ParseState::Negotiate(cmd), _) => {
                    out.push(TelnetEvent::Negotiate(cmd, b));
                    ParseState::Data
                }
                (ParseState::Sub, IAC) => ParseState::SubIac,
                (ParseState::Sub, _) => {
                    self.sub.push(b);
                    ParseState::Sub
                }
                (ParseState::SubIac, IAC) => {
                    self.sub.push(IAC);
                    ParseState::Sub
                }
                (ParseState::SubIac, SE) => {
                    out.push(TelnetEvent::Sub(std::mem::take(&mut self.sub)));
                    ParseState::Data
                }
                // IAC followed by anything else inside a sub-negotiation:
                // a malformed one; end it there (RFC 855 leaves it open).
                (ParseState::SubIac, _) => {
                    out.push(TelnetEvent::Sub(std::mem::take(&mut self.sub)));
                    ParseState::Data
                }
            };
        }
    }

    /// The answer to a server's DO / DONT / WILL / WONT (empty when none
    /// is due: already said, or an acknowledgement of our request).
    pub fn answer(&mut self, cmd: u8, option: u8) -> Vec<u8> {
        let o = option as usize;
        match cmd {
            DO => {
                let ours = matches!(option, BINARY | COM_PORT_OPTION);
                if self.said_us[o] == Some(ours) {
                    return Vec::new();
                }
                self.said_us[o] = Some(ours);
                vec![IAC, if ours { WILL } else { WONT }, option]
            }
            WILL => {
                let want = matches!(option, BINARY | SGA | COM_PORT_OPTION);
                if self.said_them[o] == Some(want) {
                    return Vec::new();
                }
                self.said_them[o] = Some(want);
                vec![IAC, if want { DO } else { DONT }, option]
            }
            DONT => {
                let was = self.said_us[o] == Some(true);
                self.said_us[o] = Some(false);
                if was {
                    vec![IAC, WONT, option]
                } else {
                    Vec::new()
                }
            }
            WONT => {
                let was = self.said_them[o] == Some(true);
                self.said_them[o] = Some(false);
                if was {
                    vec![IAC, DONT, option]
                } else {
                    Vec::new()
                }
            }
            _ => Vec::new(),
        }
    }
}

/// `IAC SB COM-PORT-OPTION code value... IAC SE`, IAC in the value doubled.
pub fn com_port_command(code: u8, value: &[u8]) -> Vec<u8> {
    let mut out = vec![IAC, SB, COM_PORT_OPTION, code];
    out.extend(escape(value));
    out.extend_from_slice(&[IAC, SE]);
    out
}

/// The four settings of a 7E1 line at `baud`, in the order sent.
pub fn line_settings(baud: u32) -> Vec<(u8, Vec<u8>)> {
    vec![
        (SET_BAUDRATE, baud.to_be_bytes().to_vec()),
        (SET_DATASIZE, vec![7]),
        (SET_PARITY, vec![PARITY_EVEN]),
        (SET_STOPSIZE, vec![STOPSIZE_1]),
    ]
}

/// Data with every IAC (0xFF) doubled.
pub fn escape(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len());
    for &b in data {
        out.push(b);
        if b == IAC {
            out.push(IAC);
        }
    }
    out
}

fn setting_name(code: u8) -> &'static str {
    match code {
        SET_BAUDRATE => "baud rate",
        SET_DATASIZE => "data size",
        SET_PARITY => "parity",
        SET_STOPSIZE => "stop size",
        _ => "setting",
    }
}

fn setting_value(code: u8, value: &[u8]) -> String {
    match (code, value) {
        (SET_BAUDRATE, [a, b, c, d]) => u32::from_be_bytes([*a, *b, *c, *d]).to_string(),
        (SET_PARITY, [p]) => match p {
            1 => "NONE".into(),
            2 => "ODD".into(),
            3 => "EVEN".into(),
            4 => "MARK".into(),
            5 => "SPACE".into(),
            _ => format!("code {p}"),
        },
        (SET_STOPSIZE, [s]) => match s {
            1 => "1".into(),
            2 => "2".into(),
            3 => "1.5".into(),
            _ => format!("code {s}"),
        },
        (_, [v]) => v.to_string(),
        _ => format!("{value:02X?}"),
    }
}

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

#[cfg(test)]
mod tests {
    use std::net::TcpListener;
    use std::thread;

    use super::*;

    #[test]
    fn parser_splits_data_commands_and_subnegotiations() {
        let mut t = Telnet::new();
        let mut ev = Vec::new();
        // Split at every awkward place: inside IAC IAC, inside SB.
        let stream: &[u8] = &[
            b'A', IAC, IAC, b'B', IAC, WILL, 1, IAC, SB, 44, 107, IAC, IAC, 0x30, IAC, SE, IAC,
            0xF1, b'C',
        ];
        for chunk in stream.chunks(3) {
            t.feed(chunk, &mut ev);
        }
        assert_eq!(
            ev,
            vec![
                TelnetEvent::Data(b'A'),
                TelnetEvent::Data(0xFF),
                TelnetEvent::Data(b'B'),
                TelnetEvent::Negotiate(WILL, 1),
                TelnetEvent::Sub(vec![44, 107, 0xFF, 0x30]),
                TelnetEvent::Command(0xF1),
                TelnetEvent::Data(b'C'),
            ]
        );
    }

    #[test]
    fn options_are_answered_once() {
        let mut t = Telnet::new();
        assert_eq!(t.opening(), vec![IAC, WILL, 0, IAC, DO, 0, IAC, WILL, 44]);
        // Acknowledgements of our requests need no answer.
        assert_eq!(t.answer(DO, BINARY), Vec::<u8>::new());
        assert_eq!(t.answer(DO, COM_PORT_OPTION), Vec::<u8>::new());
        assert_eq!(t.answer(WILL, BINARY), Vec::<u8>::new());
        // The server offers: SGA yes, ECHO no, COM-PORT yes; once each.
        assert_eq!(t.answer(WILL, SGA), vec![IAC, DO, SGA]);
        assert_eq!(t.answer(WILL, SGA), Vec::<u8>::new());
        assert_eq!(t.answer(WILL, 1), vec![IAC, DONT, 1]);
        assert_eq!(t.answer(WILL, 1), Vec::<u8>::new());
        assert_eq!(t.answer(WILL, 44), vec![IAC, DO, 44]);
        // An option we do not do (TERMINAL-TYPE).
        assert_eq!(t.answer(DO, 24), vec![IAC, WONT, 24]);
        assert_eq!(t.answer(DO, 24), Vec::<u8>::new());
        // Withdrawing an enabled option is acknowledged.
        assert_eq!(t.answer(DONT, BINARY), vec![IAC, WONT, BINARY]);
        assert_eq!(t.answer(WONT, 24), Vec::<u8>::new());
    }

    #[test]
    fn settings_and_escaping_bytes() {
        assert_eq!(
            com_port_command(SET_BAUDRATE, &57600u32.to_be_bytes()),
            vec![IAC, SB, 44, 1, 0x00, 0x00, 0xE1, 0x00, IAC, SE]
        );
        // 16777215 = 0x00FFFFFF: every IAC in the value doubled.
        assert_eq!(
            com_port_command(SET_BAUDRATE, &0x00FF_FFFFu32.to_be_bytes()),
            vec![IAC, SB, 44, 1, 0, IAC, IAC, IAC, IAC, IAC, IAC, IAC, SE]
        );
        assert_eq!(escape(&[1, 0xFF, 2]), vec![1, 0xFF, 0xFF, 2]);
        assert_eq!(setting_value(SET_PARITY, &[1]), "NONE");
        assert_eq!(setting_value(SET_BAUDRATE, &9600u32.to_be_bytes()), "9600");
    }

    /// Reads exactly `n` bytes from the fake server's connection.
    fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
        let mut buf = vec![0u8; n];
        s.set_read_timeout(Some(Duration::from_secs(10)))
            .expect("timeout");
        s.read_exact(&mut buf).expect("read from the client");
        buf
    }

    /// A fake server: `script` runs on the accepted connection.
    fn fake_server(
        script: impl FnOnce(TcpStream) + Send + 'static,
    ) -> (u16, thread::JoinHandle<()>) {
        let l = TcpListener::bind("127.0.0.1:0").expect("bind");
        let port = l.local_addr().expect("addr").port();
        let h = thread::spawn(move || {
            let (s, _) = l.accept().expect("accept");
            script(s);
        });
        (port, h)
    }

    const OPENING: [u8; 9] = [IAC, WILL, 0, IAC, DO, 0, IAC, WILL, 44];

    fn settings_bytes(baud: u32) -> Vec<u8> {
        let mut v = Vec::new();
        for (c, val) in line_settings(baud) {
            v.extend(com_port_command(c, &val));
        }
        v
    }

    fn confirm(baud: u32, parity: u8) -> Vec<u8> {
        let mut v = Vec::new();
        v.extend(com_port_command(101, &baud.to_be_bytes()));
        v.extend(com_port_command(102, &[7]));
        v.extend(com_port_command(103, &[parity]));
        v.extend(com_port_command(104, &[1]));
        v
    }

    #[test]
    fn negotiates_7e1_and_moves_data_with_exact_bytes() {
        let (port, h) = fake_server(|mut s| {
            assert_eq!(read_n(&mut s, 9), OPENING);
            // Like pyserial's PortManager: WILL ECHO, WILL SGA, DO BINARY,
            // WILL COM-PORT, then DO COM-PORT.
            s.write_all(&[
                IAC, WILL, 1, IAC, WILL, 3, IAC, DO, 0, IAC, WILL, 44, IAC, DO, 44,
            ])
            .expect("write");
            // The client's answers: DONT ECHO, DO SGA, DO COM-PORT.
            assert_eq!(
                read_n(&mut s, 9),
                vec![IAC, DONT, 1, IAC, DO, 3, IAC, DO, 44]
            );
            let want: Vec<u8> = vec![
                IAC, SB, 44, 1, 0x00, 0x00, 0x4B, 0x00, IAC, SE, // 19200 baud
                IAC, SB, 44, 2, 7, IAC, SE, // 7 data bits
                IAC, SB, 44, 3, 3, IAC, SE, // even parity
                IAC, SB, 44, 4, 1, IAC, SE, // 1 stop bit
            ];
            assert_eq!(settings_bytes(19200), want);
            assert_eq!(read_n(&mut s, want.len()), want);
            // Confirmation, a modem-state notification in between.
            let mut c = confirm(19200, PARITY_EVEN);
            c.extend_from_slice(&[IAC, SB, 44, 107, 0x30, IAC, SE]);
            s.write_all(&c).expect("write");
            // Data: the request, then the reply with a doubled IAC and a
            // notification inside it.
            assert_eq!(read_n(&mut s, 9), b"\x04AA00091\x05");
            s.write_all(&[0x02, b'1', IAC, SB, 44, 107, 0, IAC, SE, IAC, IAC, 0x03])
                .expect("write");
            // discard_input: PURGE-DATA receive buffer.
            assert_eq!(read_n(&mut s, 7), vec![IAC, SB, 44, 12, 1, IAC, SE]);
            let mut rest = Vec::new();
            let _ = s.read_to_end(&mut rest);
            assert_eq!(rest, Vec::<u8>::new());
        });
        let mut link =
            Rfc2217Link::connect("127.0.0.1", port, 19200, Duration::from_secs(10)).expect("open");
        assert_eq!(link.port(), format!("rfc2217://127.0.0.1:{port}"));
        assert_eq!(link.baud(), 19200);
        link.send(b"\x04AA00091\x05").expect("send");
        let mut got = Vec::new();
        let mut buf = [0u8; 16];
        while got.len() < 4 {
            let n = link
                .recv(&mut buf, RealClock.deadline_in(Duration::from_secs(10)))
                .expect("recv");
            assert!(n > 0, "the reply did not come");
            got.extend_from_slice(&buf[..n]);
        }
        assert_eq!(got, vec![0x02, b'1', 0xFF, 0x03]);
        link.discard_input().expect("discard");
        drop(link);
        h.join().expect("server");
    }

    #[test]
    fn set_baud_sends_set_baudrate_and_needs_the_servers_confirmation() {
        let (port, h) = fake_server(|mut s| {
            assert_eq!(read_n(&mut s, 9), OPENING);
            s.write_all(&[IAC, DO, 44]).expect("write");
            let want = settings_bytes(9600);
            assert_eq!(read_n(&mut s, want.len()), want);
            s.write_all(&confirm(9600, PARITY_EVEN)).expect("write");
            // set_baud(57600): SET-BAUDRATE 0x0000E100; confirmed, with a
            // data byte before the confirmation (kept for recv)
            assert_eq!(
                read_n(&mut s, 10),
                vec![IAC, SB, 44, 1, 0x00, 0x00, 0xE1, 0x00, IAC, SE]
            );
            let mut c = vec![b'x'];
            c.extend(com_port_command(101, &57600u32.to_be_bytes()));
            s.write_all(&c).expect("write");
            // set_baud(38400): the server answers 19200
            assert_eq!(
                read_n(&mut s, 10),
                vec![IAC, SB, 44, 1, 0x00, 0x00, 0x96, 0x00, IAC, SE]
            );
            s.write_all(&com_port_command(101, &19200u32.to_be_bytes()))
                .expect("write");
            let mut rest = Vec::new();
            let _ = s.read_to_end(&mut rest);
        });
        let mut link =
            Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_secs(10)).expect("open");
        link.set_baud(57600).expect("57600");
        assert_eq!(link.baud(), 57600);
        let mut buf = [0u8; 4];
        let n = link
            .recv(&mut buf, RealClock.deadline_in(Duration::from_secs(5)))
            .expect("recv");
        assert_eq!(&buf[..n], b"x");
        let err = link.set_baud(38400).expect_err("other rate");
        assert_eq!(
            err.to_string(),
            format!(
                "rfc2217://127.0.0.1:{port}: the server set the baud rate to 19200 instead of 38400: its serial port cannot run at that rate; pick a rate it supports"
            )
        );
        assert_eq!(link.baud(), 57600);
        drop(link);
        h.join().expect("server");
    }

    #[test]
    fn a_server_that_sets_other_parity_is_an_error_naming_both() {
        let (port, h) = fake_server(|mut s| {
            assert_eq!(read_n(&mut s, 9), OPENING);
            s.write_all(&[IAC, DO, 44]).expect("write");
            let want = settings_bytes(9600);
            assert_eq!(read_n(&mut s, want.len()), want);
            s.write_all(&confirm(9600, 1)).expect("write");
            let _ = read_n(&mut s, 0);
        });
        let err = Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_secs(10))
            .expect_err("parity NONE");
        assert_eq!(
            err.to_string(),
            format!(
                "rfc2217://127.0.0.1:{port}: the server set the parity to NONE instead of EVEN: its serial port cannot run a 7E1 line at 9600 baud; check the server's port or pick a rate it supports"
            )
        );
        h.join().expect("server");
    }

    #[test]
    fn a_server_refusing_com_port_option_is_an_error() {
        let (port, h) = fake_server(|mut s| {
            assert_eq!(read_n(&mut s, 9), OPENING);
            s.write_all(&[IAC, DONT, 44]).expect("write");
            // The client says nothing more and closes.
            let mut rest = Vec::new();
            let _ = s.read_to_end(&mut rest);
            assert_eq!(rest, Vec::<u8>::new());
        });
        let err = Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_secs(10))
            .expect_err("refused");
        assert_eq!(
            err.to_string(),
            format!(
                "rfc2217://127.0.0.1:{port}: the server refused the telnet COM-PORT-OPTION (DONT): it does not let driveset set the line; use tcp://127.0.0.1:{port} and set 7E1 at 9600 baud on the server"
            )
        );
        h.join().expect("server");
    }

    #[test]
    fn a_raw_server_times_out_with_advice() {
        let (port, h) = fake_server(|mut s| {
            assert_eq!(read_n(&mut s, 9), OPENING);
            let mut rest = Vec::new();
            let _ = s.read_to_end(&mut rest);
        });
        let err = Rfc2217Link::connect("127.0.0.1", port, 9600, Duration::from_millis(200))
            .expect_err("silent");
        assert_eq!(
            err.to_string(),
            format!(
                "rfc2217://127.0.0.1:{port}: the server did not accept the telnet COM-PORT-OPTION (RFC 2217) within 200ms; it may be a raw TCP server: use tcp://127.0.0.1:{port} and set 7E1 and the rate on the server"
            )
        );
        h.join().expect("server");
    }
}
