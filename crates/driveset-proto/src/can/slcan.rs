//! slcan (Lawicel CANUSB ASCII protocol) framing: owns [`SlcanCommand`]
//! (host -> adapter), [`SlcanResponse`] (adapter -> host), [`Bitrate`] and the
//! streaming decoders for both directions ([`ResponseDecoder`] for the host,
//! [`CommandDecoder`] for an adapter or a simulated one).
//!
//! Every message is one line ended by CR (0x0D); the adapter answers a
//! command with CR (OK) or BELL (0x07, error). Frames: `tIIILDD..` (11-bit),
//! `TIIIIIIIILDD..` (29-bit), `rIIIL` / `RIIIIIIIIL` (remote). With
//! timestamps on (`Z1`) the adapter appends 4 hex digits (milliseconds,
//! wrapping at 60000) to every received frame. Adapters in auto-poll mode
//! acknowledge a transmitted `t`/`T` with `z\r`/`Z\r`.
//!
//! Interoperates with python-can's `slcan` interface, which sends
//! `C\r`, `Sn\r`, an empty line `\r` (its empty CAN FD data bitrate), `O\r`
//! and frames in upper-case hex, and reads lines ended by CR or BELL.
//! python-can maps `S7` to 750 kbit/s and adds `S9` = 83.3 kbit/s; this
//! module follows Lawicel (S7 = 800 kbit/s, no S9): see
//! `docs/errata/can.md`. CAN FD (`d`, `D`, `b`, `B`, `Yn`) is not supported.
//!
//! Decoders accept hex in either case, skip a LF at the start of a line
//! (CRLF senders), report an undecodable line as one error and carry on
//! with the next line, and bound their buffer to [`MAX_LINE`] bytes.

use super::frame::{CanFrame, FrameError, MAX_EXTENDED_ID, MAX_STANDARD_ID};

/// Carriage return: ends every line; alone, the adapter's OK.
pub const CR: u8 = 0x0D;
/// BELL: the adapter's error response.
pub const BELL: u8 = 0x07;
/// Longest line either decoder buffers, without its CR
/// (`T` + 8 + 1 + 16 + 4-digit timestamp = 30).
pub const MAX_LINE: usize = 32;

/// The CAN bitrates of the `Sn` command (Lawicel CANUSB manual).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Bitrate {
    /// `S0`: 10 kbit/s.
    K10,
    /// `S1`: 20 kbit/s.
    K20,
    /// `S2`: 50 kbit/s.
    K50,
    /// `S3`: 100 kbit/s.
    K100,
    /// `S4`: 125 kbit/s.
    K125,
    /// `S5`: 250 kbit/s.
    K250,
    /// `S6`: 500 kbit/s.
    K500,
    /// `S7`: 800 kbit/s (python-can: 750 kbit/s).
    K800,
    /// `S8`: 1 Mbit/s.
    M1,
}

impl Bitrate {
    /// All, in `S0`..`S8` order.
    pub const ALL: [Bitrate; 9] = [
        Bitrate::K10,
        Bitrate::K20,
        Bitrate::K50,
        Bitrate::K100,
        Bitrate::K125,
        Bitrate::K250,
        Bitrate::K500,
        Bitrate::K800,
        Bitrate::M1,
    ];

    /// The `n` of `Sn`.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The bitrate of `Sn`.
    pub const fn from_code(n: u8) -> Option<Bitrate> {
        if (n as usize) < Self::ALL.len() {
            Some(Self::ALL[n as usize])
        } else {
            None
        }
    }

    /// Bits per second.
    pub const fn bits_per_second(self) -> u32 {
        match self {
            Bitrate::K10 => 10_000,
            Bitrate::K20 => 20_000,
            Bitrate::K50 => 50_000,
            Bitrate::K100 => 100_000,
            Bitrate::K125 => 125_000,
            Bitrate::K250 => 250_000,
            Bitrate::K500 => 500_000,
            Bitrate::K800 => 800_000,
            Bitrate::M1 => 1_000_000,
        }
    }

    /// The table entry for a rate in bit/s.
    pub fn from_bits_per_second(bps: u32) -> Option<Bitrate> {
        Self::ALL.into_iter().find(|b| b.bits_per_second() == bps)
    }
}

/// A line from host to adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlcanCommand {
    /// `Sn`: set a standard bitrate (channel closed).
    SetBitrate(Bitrate),
    /// `sxxyy`: set SJA1000 BTR0/BTR1 directly.
    SetBtr {
        /// BTR0.
        btr0: u8,
        /// BTR1.
        btr1: u8,
    },
    /// `O`: open the channel.
    Open,
    /// `L`: open the channel listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `t`/`T`/`r`/`R`: transmit a frame.
    Transmit(CanFrame),
    /// `V`: ask for the hardware and software version.
    Version,
    /// `N`: ask for the serial number.
    SerialNumber,
    /// `F`: ask for the status flags.
    StatusFlags,
    /// `Z0`/`Z1`: timestamps off/on.
    Timestamps(bool),
    /// An empty line (python-can sends one after `Sn` when no CAN FD data
    /// bitrate is set). Lawicel adapters answer CR.
    Empty,
}

/// A line from adapter to host.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlcanResponse {
    /// CR alone: the command was accepted.
    Ok,
    /// BELL: the command was refused.
    Error,
    /// A received frame, with the `Z1` timestamp (ms) if present.
    Received {
        /// The frame.
        frame: CanFrame,
        /// 4-digit timestamp, milliseconds.
        timestamp: Option<u16>,
    },
    /// `z` / `Z`: a transmitted `t` / `T` frame was queued (auto-poll mode).
    TransmitAck {
        /// `Z`: the frame was extended.
        extended: bool,
    },
    /// `Vhhss`: hardware and software version, as the four characters sent.
    Version([u8; 4]),
    /// `Nxxxx`: serial number, as the four characters sent.
    SerialNumber([u8; 4]),
    /// `Fxx`: status flags (bit 0 RX FIFO full, 1 TX FIFO full, 2 error
    /// warning, 3 data overrun, 5 error passive, 6 arbitration lost, 7 bus
    /// error).
    StatusFlags(u8),
}

/// Why a line is not a valid slcan message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SlcanError {
    /// The first character is no command this side understands.
    #[error("unknown slcan command 0x{0:02X}")]
    UnknownCommand(u8),
    /// Known but unsupported here (CAN FD, filters, polling, ...).
    #[error("unsupported slcan command {:?}", char::from(*.0))]
    Unsupported(u8),
    /// The line has the wrong length for its command.
    #[error("slcan {:?} line has the wrong length {}", char::from(*.0), .1)]
    BadLength(u8, usize),
    /// A character is not a hex digit where one is expected.
    #[error("slcan line has a non-hex character where a hex digit belongs")]
    BadHex,
    /// DLC digit above 8.
    #[error("slcan DLC {0:?} is not 0..8")]
    BadDlc(char),
    /// `Sn` with `n` above 8.
    #[error("slcan bitrate S{0:?} is not S0..S8")]
    BadBitrate(char),
    /// An argument is not valid (e.g. `Z2`, a non-printable version).
    #[error("slcan {:?} line has an invalid argument", char::from(*.0))]
    BadArgument(u8),
    /// The identifier does not fit 11 / 29 bits.
    #[error("slcan identifier 0x{0:X} out of range")]
    IdOutOfRange(u32),
    /// More than [`MAX_LINE`] bytes before the CR: discarded.
    #[error("slcan line longer than {MAX_LINE} bytes discarded")]
    LineTooLong,
    /// A frame to encode is not valid.
    #[error(transparent)]
    Frame(#[from] FrameError),
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

fn push_hex(out: &mut Vec<u8>, value: u32, digits: u32) {
    for i in (0..digits).rev() {
        out.push(HEX[((value >> (4 * i)) & 0xF) as usize]);
    }
}

fn hex_digit(c: u8) -> Result<u32, SlcanError> {
    match c {
        b'0'..=b'9' => Ok(u32::from(c - b'0')),
        b'A'..=b'F' => Ok(u32::from(c - b'A' + 10)),
        b'a'..=b'f' => Ok(u32::from(c - b'a' + 10)),
        _ => Err(SlcanError::BadHex),
    }
}

fn hex(s: &[u8]) -> Result<u32, SlcanError> {
    s.iter()
        .try_fold(0u32, |acc, &c| Ok((acc << 4) | hex_digit(c)?))
}

fn encode_frame(out: &mut Vec<u8>, f: &CanFrame) -> Result<(), SlcanError> {
    f.validate()?;
    let kind = match (f.extended, f.rtr) {
        (false, false) => b't',
        (true, false) => b'T',
        (false, true) => b'r',
        (true, true) => b'R',
    };
    out.push(kind);
    push_hex(out, f.id, if f.extended { 8 } else { 3 });
    out.push(b'0' + f.len);
    for &b in f.payload() {
        push_hex(out, u32::from(b), 2);
    }
    Ok(())
}

/// Parses `t`/`T`/`r`/`R` (and CANDapter's `x` = `T`) lines; returns the
/// frame and the rest of the line after the data.
fn decode_frame(line: &[u8]) -> Result<(CanFrame, &[u8]), SlcanError> {
    let kind = line.first().copied().unwrap_or(0);
    let (extended, rtr) = match kind {
        b't' => (false, false),
        b'T' | b'x' => (true, false),
        b'r' => (false, true),
        b'R' => (true, true),
        _ => return Err(SlcanError::UnknownCommand(kind)),
    };
    let id_len = if extended { 8 } else { 3 };
    let head = 1 + id_len + 1;
    if line.len() < head {
        return Err(SlcanError::BadLength(kind, line.len()));
    }
    let id = hex(&line[1..1 + id_len])?;
    let max = if extended {
        MAX_EXTENDED_ID
    } else {
        MAX_STANDARD_ID
    };
    if id > max {
        return Err(SlcanError::IdOutOfRange(id));
    }
    let dlc_char = line[head - 1];
    let len = match dlc_char {
        b'0'..=b'8' => dlc_char - b'0',
        _ => return Err(SlcanError::BadDlc(char::from(dlc_char))),
    };
    let mut frame = CanFrame {
        id,
        data: [0; 8],
        len,
        extended,
        rtr,
    };
    let mut rest = &line[head..];
    if !rtr {
        let n = usize::from(len);
        if rest.len() < 2 * n {
            return Err(SlcanError::BadLength(kind, line.len()));
        }
        for (i, pair) in rest[..2 * n].chunks_exact(2).enumerate() {
            frame.data[i] = hex(pair)? as u8;
        }
        rest = &rest[2 * n..];
    }
    Ok((frame, rest))
}

impl SlcanCommand {
    /// Appends the line, CR included. Fails only for an invalid frame.
    pub fn encode(&self, out: &mut Vec<u8>) -> Result<(), SlcanError> {
        match self {
            SlcanCommand::SetBitrate(b) => out.extend_from_slice(&[b'S', b'0' + b.code()]),
            SlcanCommand::SetBtr { btr0, btr1 } => {
                out.push(b's');
                push_hex(out, u32::from(*btr0), 2);
                push_hex(out, u32::from(*btr1), 2);
            }
            SlcanCommand::Open => out.push(b'O'),
            SlcanCommand::ListenOnly => out.push(b'L'),
            SlcanCommand::Close => out.push(b'C'),
            SlcanCommand::Transmit(f) => encode_frame(out, f)?,
            SlcanCommand::Version => out.push(b'V'),
            SlcanCommand::SerialNumber => out.push(b'N'),
            SlcanCommand::StatusFlags => out.push(b'F'),
            SlcanCommand::Timestamps(on) => out.extend_from_slice(&[b'Z', b'0' + u8::from(*on)]),
            SlcanCommand::Empty => {}
        }
        out.push(CR);
        Ok(())
    }

    /// The line as a new vector.
    pub fn to_bytes(&self) -> Result<Vec<u8>, SlcanError> {
        let mut v = Vec::with_capacity(MAX_LINE);
        self.encode(&mut v)?;
        Ok(v)
    }

    /// Decodes one line, without its CR.
    pub fn decode(line: &[u8]) -> Result<Self, SlcanError> {
        let Some(&c) = line.first() else {
            return Ok(SlcanCommand::Empty);
        };
        let bare = |cmd| {
            if line.len() == 1 {
                Ok(cmd)
            } else {
                Err(SlcanError::BadLength(c, line.len()))
            }
        };
        match c {
            b'S' => match line {
                [_, d] => Bitrate::from_code(d.wrapping_sub(b'0'))
                    .map(SlcanCommand::SetBitrate)
                    .ok_or(SlcanError::BadBitrate(char::from(*d))),
                _ => Err(SlcanError::BadLength(c, line.len())),
            },
            b's' => match line {
                [_, a, b, x, y] => Ok(SlcanCommand::SetBtr {
                    btr0: hex(&[*a, *b])? as u8,
                    btr1: hex(&[*x, *y])? as u8,
                }),
                _ => Err(SlcanError::BadLength(c, line.len())),
            },
            b'O' => bare(SlcanCommand::Open),
            b'L' => bare(SlcanCommand::ListenOnly),
            b'C' => bare(SlcanCommand::Close),
            b'V' => bare(SlcanCommand::Version),
            b'N' => bare(SlcanCommand::SerialNumber),
            b'F' => bare(SlcanCommand::StatusFlags),
            b'Z' => match line {
                [_, b'0'] => Ok(SlcanCommand::Timestamps(false)),
                [_, b'1'] => Ok(SlcanCommand::Timestamps(true)),
                [_, _] => Err(SlcanError::BadArgument(c)),
                _ => Err(SlcanError::BadLength(c, line.len())),
            },
            b't' | b'T' | b'r' | b'R' => {
                let (frame, rest) = decode_frame(line)?;
                if rest.is_empty() {
                    Ok(SlcanCommand::Transmit(frame))
                } else {
                    Err(SlcanError::BadLength(c, line.len()))
                }
            }
            b'd' | b'D' | b'b' | b'B' | b'Y' | b'P' | b'A' | b'X' | b'W' | b'M' | b'm' | b'U'
            | b'Q' | b'v' => Err(SlcanError::Unsupported(c)),
            _ => Err(SlcanError::UnknownCommand(c)),
        }
    }
}

fn printable4(s: &[u8]) -> Option<[u8; 4]> {
    let a: [u8; 4] = s.try_into().ok()?;
    a.iter().all(u8::is_ascii_graphic).then_some(a)
}

impl SlcanResponse {
    /// Appends the bytes: a line with its CR, or BELL alone.
    pub fn encode(&self, out: &mut Vec<u8>) -> Result<(), SlcanError> {
        match self {
            SlcanResponse::Ok => {}
            SlcanResponse::Error => {
                out.push(BELL);
                return Ok(());
            }
            SlcanResponse::Received { frame, timestamp } => {
                encode_frame(out, frame)?;
                if let Some(t) = timestamp {
                    push_hex(out, u32::from(*t), 4);
                }
            }
            SlcanResponse::TransmitAck { extended } => {
                out.push(if *extended { b'Z' } else { b'z' })
            }
            SlcanResponse::Version(v) => {
                out.push(b'V');
                out.extend_from_slice(v);
            }
            SlcanResponse::SerialNumber(n) => {
                out.push(b'N');
                out.extend_from_slice(n);
            }
            SlcanResponse::StatusFlags(f) => {
                out.push(b'F');
                push_hex(out, u32::from(*f), 2);
            }
        }
        out.push(CR);
        Ok(())
    }

    /// The bytes as a new vector.
    pub fn to_bytes(&self) -> Result<Vec<u8>, SlcanError> {
        let mut v = Vec::with_capacity(MAX_LINE);
        self.encode(&mut v)?;
        Ok(v)
    }

    /// Decodes one line, without its CR (an empty line is [`Self::Ok`]).
    pub fn decode(line: &[u8]) -> Result<Self, SlcanError> {
        let Some(&c) = line.first() else {
            return Ok(SlcanResponse::Ok);
        };
        match c {
            b't' | b'T' | b'r' | b'R' | b'x' => {
                let (frame, rest) = decode_frame(line)?;
                let timestamp = match rest.len() {
                    0 => None,
                    4 => Some(hex(rest)? as u16),
                    _ => return Err(SlcanError::BadLength(c, line.len())),
                };
                Ok(SlcanResponse::Received { frame, timestamp })
            }
            b'z' | b'Z' if line.len() == 1 => Ok(SlcanResponse::TransmitAck {
                extended: c == b'Z',
            }),
            b'z' | b'Z' => Err(SlcanError::BadLength(c, line.len())),
            b'V' | b'N' => {
                if line.len() != 5 {
                    return Err(SlcanError::BadLength(c, line.len()));
                }
                let v = printable4(&line[1..]).ok_or(SlcanError::BadArgument(c))?;
                Ok(if c == b'V' {
                    SlcanResponse::Version(v)
                } else {
                    SlcanResponse::SerialNumber(v)
                })
            }
            b'F' => match line {
                [_, a, b] => Ok(SlcanResponse::StatusFlags(hex(&[*a, *b])? as u8)),
                _ => Err(SlcanError::BadLength(c, line.len())),
            },
            b'd' | b'D' | b'b' | b'B' => Err(SlcanError::Unsupported(c)),
            _ => Err(SlcanError::UnknownCommand(c)),
        }
    }
}

/// What the line buffer produced.
enum Line<'a> {
    Complete(&'a [u8]),
    Bell,
    TooLong,
}

/// A bounded line accumulator shared by both decoders.
#[derive(Debug, Clone, PartialEq, Eq)]
struct LineBuffer {
    buf: [u8; MAX_LINE],
    len: usize,
    overflow: bool,
    discarded: u64,
}

impl LineBuffer {
    const fn new() -> Self {
        LineBuffer {
            buf: [0; MAX_LINE],
            len: 0,
            overflow: false,
            discarded: 0,
        }
    }

    fn push(&mut self, byte: u8, bell_ends: bool) -> Option<Line<'_>> {
        match byte {
            CR => {
                let len = core::mem::take(&mut self.len);
                if core::mem::take(&mut self.overflow) {
                    return Some(Line::TooLong);
                }
                Some(Line::Complete(&self.buf[..len]))
            }
            BELL if bell_ends => {
                self.discarded += self.len as u64;
                self.len = 0;
                self.overflow = false;
                Some(Line::Bell)
            }
            b'\n' if self.len == 0 && !self.overflow => None,
            _ => {
                if self.overflow {
                    self.discarded += 1;
                } else if self.len < MAX_LINE {
                    self.buf[self.len] = byte;
                    self.len += 1;
                } else {
                    self.discarded += self.len as u64 + 1;
                    self.len = 0;
                    self.overflow = true;
                }
                None
            }
        }
    }
}

/// Host side: decodes what the adapter sends, byte by byte.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResponseDecoder {
    line: LineBuffer,
}

impl Default for ResponseDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl ResponseDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        ResponseDecoder {
            line: LineBuffer::new(),
        }
    }

    /// Feeds one byte; returns a message or an error when a line ends (CR)
    /// or on BELL. A BELL in the middle of a line drops the partial line.
    pub fn push(&mut self, byte: u8) -> Option<Result<SlcanResponse, SlcanError>> {
        match self.line.push(byte, true)? {
            Line::Complete(l) => Some(SlcanResponse::decode(l)),
            Line::Bell => Some(Ok(SlcanResponse::Error)),
            Line::TooLong => Some(Err(SlcanError::LineTooLong)),
        }
    }

    /// Feeds bytes as they arrived; returns everything they complete.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Result<SlcanResponse, SlcanError>> {
        bytes.iter().filter_map(|&b| self.push(b)).collect()
    }

    /// Bytes dropped so far (overlong lines, partial lines before a BELL).
    pub fn discarded(&self) -> u64 {
        self.line.discarded
    }

    /// Bytes of an unfinished line held.
    pub fn pending(&self) -> usize {
        self.line.len
    }
}

/// Adapter side: decodes what the host sends, byte by byte. (BELL has no
/// meaning in this direction and is an ordinary, invalid, character.)
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandDecoder {
    line: LineBuffer,
}

impl Default for CommandDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl CommandDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        CommandDecoder {
            line: LineBuffer::new(),
        }
    }

    /// Feeds one byte; returns a command or an error when a line ends. On an
    /// error the adapter answers BELL.
    pub fn push(&mut self, byte: u8) -> Option<Result<SlcanCommand, SlcanError>> {
        match self.line.push(byte, false)? {
            Line::Complete(l) => Some(SlcanCommand::decode(l)),
            Line::Bell | Line::TooLong => Some(Err(SlcanError::LineTooLong)),
        }
    }

    /// Feeds bytes as they arrived; returns everything they complete.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Result<SlcanCommand, SlcanError>> {
        bytes.iter().filter_map(|&b| self.push(b)).collect()
    }

    /// Bytes dropped so far (overlong lines).
    pub fn discarded(&self) -> u64 {
        self.line.discarded
    }

    /// Bytes of an unfinished line held.
    pub fn pending(&self) -> usize {
        self.line.len
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(c: SlcanCommand) -> String {
        String::from_utf8(c.to_bytes().unwrap()).unwrap()
    }

    fn resp(r: SlcanResponse) -> String {
        String::from_utf8(r.to_bytes().unwrap()).unwrap()
    }

    #[test]
    fn frames_exact_strings() {
        let sdo = CanFrame::new(0x605, &[0x23, 0xF4, 0x5F, 0x00, 0x20, 0xA1, 0x07, 0x00]).unwrap();
        assert_eq!(cmd(SlcanCommand::Transmit(sdo)), "t605823F45F0020A10700\r");
        let ext = CanFrame::new_extended(0x1ABC_DEF0, &[0xDE, 0xAD]).unwrap();
        assert_eq!(cmd(SlcanCommand::Transmit(ext)), "T1ABCDEF02DEAD\r");
        let rtr = CanFrame::new_remote(0x7FF, 8).unwrap();
        assert_eq!(cmd(SlcanCommand::Transmit(rtr)), "r7FF8\r");
        let rtr_ext = CanFrame::new_remote_extended(0x1FFF_FFFF, 0).unwrap();
        assert_eq!(cmd(SlcanCommand::Transmit(rtr_ext)), "R1FFFFFFF0\r");
        let empty = CanFrame::new(0, &[]).unwrap();
        assert_eq!(cmd(SlcanCommand::Transmit(empty)), "t0000\r");
        assert_eq!(
            resp(SlcanResponse::Received {
                frame: CanFrame::new(0x585, &[0x60, 0xF4, 0x5F, 0, 0, 0, 0, 0]).unwrap(),
                timestamp: Some(0xEA5F)
            }),
            "t585860F45F0000000000EA5F\r"
        );
    }

    #[test]
    fn commands_exact_strings() {
        let all: Vec<String> = Bitrate::ALL
            .into_iter()
            .map(|b| cmd(SlcanCommand::SetBitrate(b)))
            .collect();
        assert_eq!(
            all,
            [
                "S0\r", "S1\r", "S2\r", "S3\r", "S4\r", "S5\r", "S6\r", "S7\r", "S8\r"
            ]
        );
        let bps: Vec<u32> = Bitrate::ALL.iter().map(|b| b.bits_per_second()).collect();
        assert_eq!(
            bps,
            [
                10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000
            ]
        );
        assert_eq!(Bitrate::from_bits_per_second(125_000), Some(Bitrate::K125));
        assert_eq!(Bitrate::from_bits_per_second(750_000), None);
        assert_eq!(Bitrate::from_code(9), None);
        assert_eq!(
            cmd(SlcanCommand::SetBtr {
                btr0: 0x03,
                btr1: 0x1C
            }),
            "s031C\r"
        );
        assert_eq!(cmd(SlcanCommand::Open), "O\r");
        assert_eq!(cmd(SlcanCommand::ListenOnly), "L\r");
        assert_eq!(cmd(SlcanCommand::Close), "C\r");
        assert_eq!(cmd(SlcanCommand::Version), "V\r");
        assert_eq!(cmd(SlcanCommand::SerialNumber), "N\r");
        assert_eq!(cmd(SlcanCommand::StatusFlags), "F\r");
        assert_eq!(cmd(SlcanCommand::Timestamps(true)), "Z1\r");
        assert_eq!(cmd(SlcanCommand::Timestamps(false)), "Z0\r");
        assert_eq!(cmd(SlcanCommand::Empty), "\r");
    }

    #[test]
    fn responses_exact_strings() {
        assert_eq!(resp(SlcanResponse::Ok), "\r");
        assert_eq!(resp(SlcanResponse::Error), "\x07");
        assert_eq!(resp(SlcanResponse::TransmitAck { extended: false }), "z\r");
        assert_eq!(resp(SlcanResponse::TransmitAck { extended: true }), "Z\r");
        assert_eq!(resp(SlcanResponse::Version(*b"1013")), "V1013\r");
        assert_eq!(resp(SlcanResponse::SerialNumber(*b"A123")), "NA123\r");
        assert_eq!(resp(SlcanResponse::StatusFlags(0x08)), "F08\r");
    }

    #[test]
    fn python_can_open_sequence() {
        // what python-can's slcanBus(bitrate=500000) writes
        let mut d = CommandDecoder::new();
        let got = d.feed(b"C\rS6\r\rO\rt605840F45F0000000000\r");
        let frame = CanFrame::new(0x605, &[0x40, 0xF4, 0x5F, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            got,
            vec![
                Ok(SlcanCommand::Close),
                Ok(SlcanCommand::SetBitrate(Bitrate::K500)),
                Ok(SlcanCommand::Empty),
                Ok(SlcanCommand::Open),
                Ok(SlcanCommand::Transmit(frame)),
            ]
        );
    }

    #[test]
    fn response_stream_with_garbage_and_bell() {
        let mut d = ResponseDecoder::new();
        let got = d.feed(b"\r\x07z\rZ\rt58544f45f000\r\nt12\rgarbage\x07V1013\rF0a\r");
        assert_eq!(
            got,
            vec![
                Ok(SlcanResponse::Ok),
                Ok(SlcanResponse::Error),
                Ok(SlcanResponse::TransmitAck { extended: false }),
                Ok(SlcanResponse::TransmitAck { extended: true }),
                Ok(SlcanResponse::Received {
                    frame: CanFrame::new(0x585, &[0x4F, 0x45, 0xF0, 0x00]).unwrap(),
                    timestamp: None
                }),
                Err(SlcanError::BadLength(b't', 3)),
                Ok(SlcanResponse::Error),
                Ok(SlcanResponse::Version(*b"1013")),
                Ok(SlcanResponse::StatusFlags(0x0A)),
            ]
        );
        assert_eq!(d.discarded(), 7);
    }

    #[test]
    fn overlong_line_resyncs() {
        let mut d = ResponseDecoder::new();
        let mut input = vec![b'x'; 100];
        input.extend_from_slice(b"\rz\r");
        assert_eq!(
            d.feed(&input),
            vec![
                Err(SlcanError::LineTooLong),
                Ok(SlcanResponse::TransmitAck { extended: false })
            ]
        );
        assert_eq!(d.discarded(), 100);
        assert_eq!(d.pending(), 0);
    }

    #[test]
    fn decode_errors() {
        use SlcanCommand as C;
        assert_eq!(C::decode(b"S9"), Err(SlcanError::BadBitrate('9')));
        assert_eq!(C::decode(b"S"), Err(SlcanError::BadLength(b'S', 1)));
        assert_eq!(C::decode(b"t8000"), Err(SlcanError::IdOutOfRange(0x800)));
        assert_eq!(
            C::decode(b"T200000000"),
            Err(SlcanError::IdOutOfRange(0x2000_0000))
        );
        assert_eq!(C::decode(b"t1239"), Err(SlcanError::BadDlc('9')));
        assert_eq!(C::decode(b"t1231G0"), Err(SlcanError::BadHex));
        assert_eq!(C::decode(b"t12310011"), Err(SlcanError::BadLength(b't', 9)));
        assert_eq!(C::decode(b"OO"), Err(SlcanError::BadLength(b'O', 2)));
        assert_eq!(C::decode(b"Z2"), Err(SlcanError::BadArgument(b'Z')));
        assert_eq!(C::decode(b"Y2"), Err(SlcanError::Unsupported(b'Y')));
        assert_eq!(C::decode(b"?"), Err(SlcanError::UnknownCommand(b'?')));
        assert_eq!(
            SlcanResponse::decode(b"t12310"),
            Err(SlcanError::BadLength(b't', 6))
        );
        assert_eq!(
            SlcanResponse::decode(b"x123456780"),
            Ok(SlcanResponse::Received {
                frame: CanFrame::new_extended(0x1234_5678, &[]).unwrap(),
                timestamp: None
            })
        );
        assert_eq!(
            SlcanResponse::decode(b"x12345678000"),
            Err(SlcanError::BadLength(b'x', 12))
        );
        let bad = CanFrame {
            id: 0x800,
            ..CanFrame::default()
        };
        assert_eq!(
            SlcanCommand::Transmit(bad).to_bytes(),
            Err(SlcanError::Frame(FrameError::IdOutOfRange {
                id: 0x800,
                bits: 11
            }))
        );
    }
}
