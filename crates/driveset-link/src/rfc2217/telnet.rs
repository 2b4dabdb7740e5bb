//! The telnet side of RFC 2217, pure (no IO): the option negotiation of
//! RFC 854/855 ([`Telnet`]: parsing the stream into data, commands and
//! sub-negotiations; answering each option once), the COM-PORT-OPTION
//! commands (RFC 2217 SET-BAUDRATE .. SET-STOPSIZE, PURGE-DATA) and IAC
//! escaping.

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

pub(super) fn setting_name(code: u8) -> &'static str {
    match code {
        SET_BAUDRATE => "baud rate",
        SET_DATASIZE => "data size",
        SET_PARITY => "parity",
        SET_STOPSIZE => "stop size",
        _ => "setting",
    }
}

pub(super) fn setting_value(code: u8, value: &[u8]) -> String {
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
