//! Streaming decoders, fed with bytes as they arrive (section 8 framing):
//!
//! - [`ResponseDecoder`], the master's side: controller answers (value
//!   reply, `?` reply, `STX C1 C2 EOT`, ACK, NAK).
//! - [`TelegramDecoder`], a slave's side: host telegrams (RECEIVE, SEND,
//!   BROADCAST) and lone EOTs.
//! - [`BusSniffer`]: a captured half-duplex stream holding both directions.
//!
//! Every byte is parity-masked ([`ascii::mask7`]). EOT always resets a host
//! telegram; garbage is skipped and reported; buffers are bounded
//! ([`MAX_TEXT`]); no input makes a decoder panic.
//!
//! Two rules of the wire need care:
//! - The byte after ETX is always the BCC (8.G: 00..FF hex), even if it is
//!   EOT. If the BCC is wrong and that byte is one that starts a frame (EOT,
//!   STX, ACK, NAK), the decoder reports the bad BCC and then also tries the
//!   byte as the start of the next frame, so a garbage ETX cannot swallow
//!   the next telegram's EOT unless the BCC happens to match.
//! - `STX C1 C2 EOT` (no such code) ends with EOT, which is also the first
//!   byte of the host's next telegram. The sniffer reports the response over
//!   the range that includes the EOT and starts the next host telegram at
//!   the same EOT, so those two events share one byte.

use core::ops::Range;

use thiserror::Error;

use crate::ascii::{self, ACK, ENQ, EOT, ETX, NAK, STX};

use super::address::ControllerAddress;
use super::code::{CodeAddress, ExtendedAddress};
use super::codec::{
    MAX_TEXT, TextBuf, check_bcc, parse_receive, parse_reply_text, parse_send_text,
};
use super::error::FrameError;
use super::frame::{Response, Telegram};

/// Who sent the bytes of an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Host (master) to controller (slave).
    HostToController,
    /// Controller to host.
    ControllerToHost,
    /// Not known: garbage in a sniffed stream.
    Unknown,
}

/// What a host puts on the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HostFrame {
    /// A RECEIVE, SEND or BROADCAST.
    Telegram(Telegram),
    /// An EOT not followed by an address: the end of a transmission.
    EndOfTransmission,
}

/// Anything seen on a LECOM line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Frame {
    Host(HostFrame),
    Controller(Response),
}

/// What went wrong with a stretch of the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum StreamError {
    /// Bytes that start no frame were skipped.
    #[error("{len} bytes of garbage skipped")]
    Garbage { len: u64 },
    /// A frame was cut off by a byte that cannot continue it.
    #[error("frame interrupted by {found:#04x} where {expected} was expected")]
    Interrupted { expected: &'static str, found: u8 },
    /// More text than any frame can hold: the frame was dropped.
    #[error("more than {limit} bytes of text: frame dropped")]
    Overlong { limit: usize },
    /// The stream ended inside a frame ([`finish`](ResponseDecoder::finish)).
    #[error("stream ended inside a frame")]
    Truncated,
    /// A complete frame that does not decode (bad BCC, bad code, bad value).
    #[error(transparent)]
    Frame(#[from] FrameError),
}

/// One decoded frame or one error, with where it was in the stream.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Event<T> {
    pub direction: Direction,
    /// Offsets of the bytes, counted from the first byte fed to the decoder.
    pub range: Range<u64>,
    pub result: Result<T, StreamError>,
}

/// Longest run of garbage reported as one event.
const MAX_GARBAGE_RUN: u64 = 256;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Idle,
    /// After EOT: AD1 (`None`) or AD2 (`Some(ad1)`) next.
    Address(Option<u8>),
    /// After AD2: STX or the first code character next.
    AfterAddress,
    /// Code field of a RECEIVE, until ENQ.
    ReceiveCode,
    /// Text of a SEND / BROADCAST, until ETX.
    HostText,
    /// Text of a controller answer, until ETX or EOT.
    ReplyText,
    /// The byte after ETX.
    Bcc(Direction),
}

/// The state machine behind all three decoders.
#[derive(Clone)]
struct Machine {
    host: bool,
    controller: bool,
    garbage_direction: Direction,
    state: State,
    pos: u64,
    start: u64,
    address: ControllerAddress,
    text: TextBuf,
    garbage: Option<u64>,
    /// The EOT that began the current host telegram also ended a "no such
    /// code" answer: if no address follows, it is not a lone EOT.
    shared_eot: bool,
}

type Emit<'a> = &'a mut dyn FnMut(Direction, Range<u64>, Result<Frame, StreamError>);

impl Machine {
    const fn new(host: bool, controller: bool, garbage_direction: Direction) -> Self {
        Self {
            host,
            controller,
            garbage_direction,
            state: State::Idle,
            pos: 0,
            start: 0,
            address: ControllerAddress::ALL,
            text: TextBuf::new(),
            garbage: None,
            shared_eot: false,
        }
    }

    fn feed(&mut self, bytes: &[u8], emit: Emit<'_>) {
        for &raw in bytes {
            self.step(raw, emit);
            self.pos += 1;
        }
    }

    fn flush_garbage(&mut self, emit: Emit<'_>) {
        if let Some(start) = self.garbage.take() {
            let len = self.pos - start;
            emit(
                self.garbage_direction,
                start..self.pos,
                Err(StreamError::Garbage { len }),
            );
        }
    }

    fn finish(&mut self, emit: Emit<'_>) {
        self.flush_garbage(emit);
        match self.state {
            State::Idle => {}
            State::Address(None) if self.shared_eot => {}
            State::Address(None) => emit(
                Direction::HostToController,
                self.start..self.pos,
                Ok(Frame::Host(HostFrame::EndOfTransmission)),
            ),
            State::Bcc(d) => emit(d, self.start..self.pos, Err(StreamError::Truncated)),
            State::ReplyText => {
                emit(
                    Direction::ControllerToHost,
                    self.start..self.pos,
                    Err(StreamError::Truncated),
                );
            }
            _ => emit(
                Direction::HostToController,
                self.start..self.pos,
                Err(StreamError::Truncated),
            ),
        }
        self.state = State::Idle;
    }

    /// Starts a frame at the current byte.
    fn begin(&mut self, state: State, emit: Emit<'_>) {
        self.flush_garbage(emit);
        self.shared_eot = false;
        self.start = self.pos;
        self.text.clear();
        self.state = state;
    }

    /// Reports the frame so far (excluding the current byte) as cut off and
    /// gives the current byte to the idle state.
    fn interrupt(&mut self, direction: Direction, expected: &'static str, b: u8, emit: Emit<'_>) {
        emit(
            direction,
            self.start..self.pos,
            Err(StreamError::Interrupted { expected, found: b }),
        );
        self.state = State::Idle;
        self.idle(b, emit);
    }

    /// Ends the current frame with the current byte.
    fn complete(
        &mut self,
        direction: Direction,
        result: Result<Frame, StreamError>,
        emit: Emit<'_>,
    ) {
        emit(direction, self.start..self.pos + 1, result);
        self.state = State::Idle;
    }

    fn push_text(&mut self, direction: Direction, b: u8, emit: Emit<'_>) {
        if !self.text.push(b) {
            self.complete(
                direction,
                Err(StreamError::Overlong { limit: MAX_TEXT }),
                emit,
            );
        }
    }

    fn idle(&mut self, b: u8, emit: Emit<'_>) {
        match b {
            EOT if self.host => self.begin(State::Address(None), emit),
            STX if self.controller => self.begin(State::ReplyText, emit),
            ACK | NAK if self.controller => {
                self.begin(State::Idle, emit);
                let r = if b == ACK {
                    Response::Ack
                } else {
                    Response::Nak
                };
                self.complete(Direction::ControllerToHost, Ok(Frame::Controller(r)), emit);
            }
            _ => {
                let start = *self.garbage.get_or_insert(self.pos);
                if self.pos + 1 - start >= MAX_GARBAGE_RUN {
                    emit(
                        self.garbage_direction,
                        start..self.pos + 1,
                        Err(StreamError::Garbage {
                            len: self.pos + 1 - start,
                        }),
                    );
                    self.garbage = None;
                }
            }
        }
    }

    fn step(&mut self, raw: u8, emit: Emit<'_>) {
        const HOST: Direction = Direction::HostToController;
        const CTRL: Direction = Direction::ControllerToHost;
        let b = ascii::mask7(raw);
        match self.state {
            State::Idle => self.idle(b, emit),
            State::Address(None) if b.is_ascii_digit() => self.state = State::Address(Some(b)),
            State::Address(None) => {
                // A lone EOT: the end of a transmission.
                if !self.shared_eot {
                    emit(
                        HOST,
                        self.start..self.pos,
                        Ok(Frame::Host(HostFrame::EndOfTransmission)),
                    );
                }
                self.state = State::Idle;
                self.idle(b, emit);
            }
            State::Address(Some(ad1)) => match ControllerAddress::from_ascii([ad1, b]) {
                Ok(a) => {
                    self.address = a;
                    self.state = State::AfterAddress;
                }
                Err(_) => self.interrupt(HOST, "AD2 (a digit)", b, emit),
            },
            State::AfterAddress => match b {
                STX => self.state = State::HostText,
                ENQ => self.complete(HOST, Err(FrameError::CodeLength { len: 0 }.into()), emit),
                0..0x20 => self.interrupt(HOST, "STX or a code character", b, emit),
                _ => {
                    self.text.push(b);
                    self.state = State::ReceiveCode;
                }
            },
            State::ReceiveCode => match b {
                ENQ => {
                    let r = parse_receive(self.address, self.text.as_slice())
                        .map(|t| Frame::Host(HostFrame::Telegram(t)))
                        .map_err(StreamError::from);
                    self.complete(HOST, r, emit);
                }
                0..0x20 => self.interrupt(HOST, "ENQ or a code character", b, emit),
                _ if self.text.as_slice().len() >= ExtendedAddress::LEN => {
                    self.complete(
                        HOST,
                        Err(FrameError::CodeLength {
                            len: ExtendedAddress::LEN + 1,
                        }
                        .into()),
                        emit,
                    );
                }
                _ => {
                    self.text.push(b);
                }
            },
            State::HostText => match b {
                ETX => self.state = State::Bcc(HOST),
                0..0x20 => self.interrupt(HOST, "ETX or text", b, emit),
                _ => self.push_text(HOST, b, emit),
            },
            State::ReplyText => match b {
                ETX => self.state = State::Bcc(CTRL),
                EOT => {
                    let r = CodeAddress::parse(self.text.as_slice())
                        .map(|code| Frame::Controller(Response::NoSuchCode { code }))
                        .map_err(StreamError::from);
                    self.complete(CTRL, r, emit);
                    // The same EOT begins the host's next telegram.
                    if self.host {
                        self.begin(State::Address(None), emit);
                        self.shared_eot = true;
                    }
                }
                0..0x20 => self.interrupt(CTRL, "ETX, EOT or text", b, emit),
                _ => self.push_text(CTRL, b, emit),
            },
            State::Bcc(direction) => {
                let text = self.text.as_slice();
                let checked = check_bcc(text, b);
                let bad_bcc = checked.is_err();
                let r = checked
                    .and_then(|()| {
                        if direction == HOST {
                            parse_send_text(self.address, text)
                                .map(|t| Frame::Host(HostFrame::Telegram(t)))
                        } else {
                            parse_reply_text(text).map(Frame::Controller)
                        }
                    })
                    .map_err(StreamError::from);
                self.complete(direction, r, emit);
                let starts_frame =
                    (b == EOT && self.host) || (matches!(b, STX | ACK | NAK) && self.controller);
                if bad_bcc && starts_frame {
                    self.idle(b, emit);
                }
            }
        }
    }
}

macro_rules! decoder {
    ($(#[$doc:meta])* $name:ident, $item:ty, $host:expr, $ctrl:expr, $dir:expr, $map:expr) => {
        $(#[$doc])*
        #[derive(Clone)]
        pub struct $name(Machine);

        impl Default for $name {
            fn default() -> Self {
                Self::new()
            }
        }

        impl $name {
            /// A decoder at stream offset 0, between frames.
            pub const fn new() -> Self {
                Self(Machine::new($host, $ctrl, $dir))
            }

            /// Feeds bytes as they arrive; `on_event` gets every frame and
            /// every error they complete, in stream order.
            pub fn feed(&mut self, bytes: &[u8], mut on_event: impl FnMut(Event<$item>)) {
                self.0.feed(bytes, &mut |direction, range, result| {
                    let map: fn(Frame) -> Option<$item> = $map;
                    let result = match result {
                        Ok(frame) => match map(frame) {
                            Some(item) => Ok(item),
                            // Not produced with this decoder's settings.
                            None => return,
                        },
                        Err(e) => Err(e),
                    };
                    on_event(Event { direction, range, result });
                });
            }

            /// Ends the stream: reports pending garbage and a frame cut off
            /// by the end ([`StreamError::Truncated`]), and returns to idle.
            pub fn finish(&mut self, mut on_event: impl FnMut(Event<$item>)) {
                let map: fn(Frame) -> Option<$item> = $map;
                self.0.finish(&mut |direction, range, result| {
                    let result = match result {
                        Ok(frame) => match map(frame) {
                            Some(item) => Ok(item),
                            None => return,
                        },
                        Err(e) => Err(e),
                    };
                    on_event(Event { direction, range, result });
                });
            }

            /// Decodes a whole capture: [`feed`](Self::feed) then
            /// [`finish`](Self::finish).
            pub fn decode_all(bytes: &[u8]) -> Vec<Event<$item>> {
                let mut d = Self::new();
                let mut events = Vec::new();
                d.feed(bytes, |e| events.push(e));
                d.finish(|e| events.push(e));
                events
            }

            /// Offset of the next byte to be fed.
            pub const fn position(&self) -> u64 {
                self.0.pos
            }

            /// `true` between frames: nothing is half received.
            pub fn is_idle(&self) -> bool {
                self.0.state == State::Idle
            }
        }
    };
}

decoder!(
    /// The master's decoder for controller answers (8.H a, 8.I a). Bytes
    /// that start no answer (including EOT) are garbage.
    ResponseDecoder,
    Response,
    false,
    true,
    Direction::ControllerToHost,
    |f| match f {
        Frame::Controller(r) => Some(r),
        Frame::Host(_) => None,
    }
);

decoder!(
    /// A slave's decoder for host telegrams (8.H, 8.I, 8.J). Everything
    /// outside `EOT ...` (other slaves' answers included) is garbage.
    TelegramDecoder,
    HostFrame,
    true,
    false,
    Direction::HostToController,
    |f| match f {
        Frame::Host(h) => Some(h),
        Frame::Controller(_) => None,
    }
);

decoder!(
    /// A bus sniffer for a half-duplex capture of both directions: host
    /// telegrams begin with EOT, answers with STX, ACK or NAK.
    BusSniffer,
    Frame,
    true,
    true,
    Direction::Unknown,
    Some
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lecom::code::CodeNumber;
    use crate::lecom::codec::tests::{any_response, any_telegram};
    use crate::lecom::error::CodeError;
    use crate::lecom::frame::{Broadcast, Receive, Send};
    use crate::lecom::value::{Decimal, Hex, Value};
    use proptest::prelude::*;

    fn code(n: u16) -> CodeAddress {
        CodeAddress::Standard(CodeNumber::new(n).unwrap())
    }

    fn addr(n: u8) -> ControllerAddress {
        ControllerAddress::new(n).unwrap()
    }

    fn ok<T>(direction: Direction, range: Range<u64>, item: T) -> Event<T> {
        Event {
            direction,
            range,
            result: Ok(item),
        }
    }

    fn err<T>(direction: Direction, range: Range<u64>, e: StreamError) -> Event<T> {
        Event {
            direction,
            range,
            result: Err(e),
        }
    }

    const C2H: Direction = Direction::ControllerToHost;
    const H2C: Direction = Direction::HostToController;

    #[test]
    fn master_decodes_the_three_answers_and_ack_nak() {
        let mut stream = Vec::new();
        stream.extend_from_slice(&[0x02, b'4', b'6', b'3', b'5', b'.', b'4', 0x03, 0x1D]);
        stream.extend_from_slice(&[0x02, b'4', b'6', b'?', 0x03, 0x3E]);
        stream.extend_from_slice(&[0x02, b'4', b'6', 0x04]);
        stream.extend_from_slice(&[0x06, 0x15]);
        let events = ResponseDecoder::decode_all(&stream);
        assert_eq!(
            events,
            [
                ok(
                    C2H,
                    0..9,
                    Response::Value {
                        code: code(46),
                        value: Value::Decimal(Decimal::from_raw(354_000).unwrap())
                    }
                ),
                ok(C2H, 9..15, Response::ChecksumFault { code: code(46) }),
                ok(C2H, 15..19, Response::NoSuchCode { code: code(46) }),
                ok(C2H, 19..20, Response::Ack),
                ok(C2H, 20..21, Response::Nak),
            ]
        );
    }

    #[test]
    fn master_byte_by_byte_with_parity_bits() {
        let reply = [0x02, b'6', b'8', b'H', b'0', b'9', b'0', b'0', 0x03, 0x4C];
        let mut d = ResponseDecoder::new();
        let mut events = Vec::new();
        for &b in &reply {
            assert!(events.is_empty());
            d.feed(&[b | 0x80], |e| events.push(e));
        }
        assert_eq!(
            events,
            [ok(
                C2H,
                0..10,
                Response::Value {
                    code: code(68),
                    value: Value::Hex(Hex::Word(0x0900))
                }
            )]
        );
        assert!(d.is_idle());
        assert_eq!(d.position(), 10);
    }

    #[test]
    fn master_reports_bad_bcc_garbage_and_truncation() {
        let events = ResponseDecoder::decode_all(b"xy\x0246?\x03\x00\x06\x0246");
        assert_eq!(
            events,
            [
                err(C2H, 0..2, StreamError::Garbage { len: 2 }),
                err(
                    C2H,
                    2..8,
                    FrameError::BadBcc {
                        expected: 0x3E,
                        found: 0
                    }
                    .into()
                ),
                ok(C2H, 8..9, Response::Ack),
                err(C2H, 9..12, StreamError::Truncated),
            ]
        );
        // An EOT is no answer for a master.
        assert_eq!(
            ResponseDecoder::decode_all(b"\x040146\x05"),
            [err(C2H, 0..6, StreamError::Garbage { len: 6 })]
        );
    }

    #[test]
    fn master_interrupted_reply_resynchronises() {
        let events = ResponseDecoder::decode_all(b"\x0246\x15");
        assert_eq!(
            events,
            [
                err(
                    C2H,
                    0..3,
                    StreamError::Interrupted {
                        expected: "ETX, EOT or text",
                        found: 0x15
                    }
                ),
                ok(C2H, 3..4, Response::Nak),
            ]
        );
    }

    #[test]
    fn slave_decodes_the_spec_telegrams() {
        let mut stream = Vec::new();
        stream.extend_from_slice(&[0x04, b'0', b'1', b'4', b'6', 0x05]);
        stream.extend_from_slice(&[
            0x04, b'3', b'4', 0x02, b'1', b'1', b'9', b'5', b'.', b'2', 0x03, 0x13,
        ]);
        stream.extend_from_slice(&[0x04, b'0', b'0', 0x02, b'4', b'0', b'0', 0x03, 0x37]);
        stream.push(0x04);
        let events = TelegramDecoder::decode_all(&stream);
        let vd = |raw| Value::Decimal(Decimal::from_raw(raw).unwrap());
        assert_eq!(
            events,
            [
                ok(
                    H2C,
                    0..6,
                    HostFrame::Telegram(Telegram::Receive(Receive {
                        address: addr(1),
                        code: code(46)
                    }))
                ),
                ok(
                    H2C,
                    6..18,
                    HostFrame::Telegram(Telegram::Send(Send {
                        address: addr(34),
                        code: code(11),
                        value: vd(952_000)
                    }))
                ),
                ok(
                    H2C,
                    18..27,
                    HostFrame::Telegram(Telegram::Broadcast(Broadcast {
                        address: ControllerAddress::ALL,
                        code: code(40),
                        value: vd(0)
                    }))
                ),
                ok(H2C, 27..28, HostFrame::EndOfTransmission),
            ]
        );
    }

    #[test]
    fn slave_eot_resets_a_half_telegram() {
        let events = TelegramDecoder::decode_all(b"\x0401\x0211\x040146\x05");
        assert_eq!(events.len(), 2);
        assert_eq!(
            events[0],
            err(
                H2C,
                0..6,
                StreamError::Interrupted {
                    expected: "ETX or text",
                    found: 0x04
                }
            )
        );
        assert_eq!(events[1].range, 6..12);
        assert!(events[1].result.is_ok());
        // A lone EOT before a telegram.
        let events = TelegramDecoder::decode_all(b"\x04\x040146\x05");
        assert_eq!(events[0], ok(H2C, 0..1, HostFrame::EndOfTransmission));
        assert_eq!(events[1].range, 1..7);
    }

    #[test]
    fn slave_errors() {
        assert_eq!(
            TelegramDecoder::decode_all(b"\x04\x30A"),
            [
                err(
                    H2C,
                    0..2,
                    StreamError::Interrupted {
                        expected: "AD2 (a digit)",
                        found: b'A'
                    }
                ),
                err(H2C, 2..3, StreamError::Garbage { len: 1 })
            ]
        );
        assert_eq!(
            TelegramDecoder::decode_all(b"\x0401\x7F0\x05"),
            [err(
                H2C,
                0..6,
                FrameError::Code(CodeError::NotFromFormula { c1: 0x7F, c2: b'0' }).into()
            )]
        );
        assert_eq!(
            TelegramDecoder::decode_all(b"\x041046\x05"),
            [err(
                H2C,
                0..6,
                FrameError::ReceiveToBroadcast { address: addr(10) }.into()
            )]
        );
        assert_eq!(
            TelegramDecoder::decode_all(b"\x0401\x05"),
            [err(H2C, 0..4, FrameError::CodeLength { len: 0 }.into())]
        );
        assert_eq!(
            TelegramDecoder::decode_all(b"\x0401!03EA000\x05"),
            [
                err(H2C, 0..11, FrameError::CodeLength { len: 8 }.into()),
                err(H2C, 11..12, StreamError::Garbage { len: 1 })
            ]
        );
        // A text longer than any frame.
        let mut long = b"\x0401\x0211O".to_vec();
        long.extend(core::iter::repeat_n(b'0', 300));
        let events = TelegramDecoder::decode_all(&long);
        assert_eq!(
            events[0],
            err(
                H2C,
                0..(4 + MAX_TEXT as u64 + 1),
                StreamError::Overlong { limit: MAX_TEXT }
            )
        );
    }

    #[test]
    fn sniffer_splits_no_such_code_eot() {
        // RECEIVE C46, "no such code", then the next RECEIVE starting at the
        // answer's EOT.
        let stream = b"\x040146\x05\x0246\x040168\x05";
        let events = BusSniffer::decode_all(stream);
        assert_eq!(
            events,
            [
                ok(
                    H2C,
                    0..6,
                    Frame::Host(HostFrame::Telegram(Telegram::Receive(Receive {
                        address: addr(1),
                        code: code(46)
                    })))
                ),
                ok(
                    C2H,
                    6..10,
                    Frame::Controller(Response::NoSuchCode { code: code(46) })
                ),
                ok(
                    H2C,
                    9..15,
                    Frame::Host(HostFrame::Telegram(Telegram::Receive(Receive {
                        address: addr(1),
                        code: code(68)
                    })))
                ),
            ]
        );
    }

    #[test]
    fn bcc_equal_to_eot_is_the_bcc() {
        // C11 = 16: BCC = '1'^'1'^'1'^'6'^ETX = 0x04.
        let stream = b"\x0401\x021116\x03\x04\x06\x040111\x05\x021116\x03\x04";
        let events = BusSniffer::decode_all(stream);
        let vd7 = Value::Decimal(Decimal::from_int(16).unwrap());
        assert_eq!(
            events,
            [
                ok(
                    H2C,
                    0..10,
                    Frame::Host(HostFrame::Telegram(Telegram::Send(Send {
                        address: addr(1),
                        code: code(11),
                        value: vd7
                    })))
                ),
                ok(C2H, 10..11, Frame::Controller(Response::Ack)),
                ok(
                    H2C,
                    11..17,
                    Frame::Host(HostFrame::Telegram(Telegram::Receive(Receive {
                        address: addr(1),
                        code: code(11)
                    })))
                ),
                ok(
                    C2H,
                    17..24,
                    Frame::Controller(Response::Value {
                        code: code(11),
                        value: vd7
                    })
                ),
            ]
        );
    }

    #[test]
    fn a_garbage_etx_does_not_swallow_the_next_eot() {
        // Garbage STX 'x' ETX, then a RECEIVE: the EOT is a bad BCC for the
        // garbage and also the start of the RECEIVE.
        let events = BusSniffer::decode_all(b"\x02x\x03\x040146\x05");
        assert_eq!(events.len(), 2);
        assert_eq!(
            events[0],
            err(
                C2H,
                0..4,
                FrameError::BadBcc {
                    expected: b'x' ^ 3,
                    found: 4
                }
                .into()
            )
        );
        assert_eq!(events[1].range, 3..9);
        assert!(events[1].result.is_ok());
    }

    #[test]
    fn long_garbage_is_reported_in_bounded_runs() {
        let events = BusSniffer::decode_all(&[b'x'; 600]);
        assert_eq!(
            events,
            [
                err(
                    Direction::Unknown,
                    0..256,
                    StreamError::Garbage { len: 256 }
                ),
                err(
                    Direction::Unknown,
                    256..512,
                    StreamError::Garbage { len: 256 }
                ),
                err(
                    Direction::Unknown,
                    512..600,
                    StreamError::Garbage { len: 88 }
                ),
            ]
        );
    }

    fn host_bytes(t: &Telegram) -> Vec<u8> {
        t.to_bytes().unwrap()
    }

    /// Garbage that cannot leave a decoder right after an ETX (where the
    /// next byte would be taken as a BCC, by the rule of 8.G).
    fn garbage() -> impl Strategy<Value = Vec<u8>> {
        proptest::collection::vec(any::<u8>(), 0..64).prop_filter("ends in ETX", |g| {
            g.last().map(|&b| ascii::mask7(b)) != Some(ETX)
        })
    }

    proptest! {
        #[test]
        fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            let n = bytes.len() as u64;
            for e in ResponseDecoder::decode_all(&bytes) {
                prop_assert!(e.range.start <= e.range.end && e.range.end <= n);
            }
            for e in TelegramDecoder::decode_all(&bytes) {
                prop_assert!(e.range.start <= e.range.end && e.range.end <= n);
            }
            for e in BusSniffer::decode_all(&bytes) {
                prop_assert!(e.range.start <= e.range.end && e.range.end <= n);
            }
        }

        #[test]
        fn every_telegram_round_trips_through_the_slave_decoder(t in any_telegram()) {
            let bytes = host_bytes(&t);
            let events = TelegramDecoder::decode_all(&bytes);
            prop_assert_eq!(events, vec![ok(H2C, 0..bytes.len() as u64, HostFrame::Telegram(t))]);
        }

        #[test]
        fn every_response_round_trips_through_the_master_decoder(r in any_response()) {
            let bytes = r.to_bytes();
            let events = ResponseDecoder::decode_all(&bytes);
            prop_assert_eq!(events, vec![ok(C2H, 0..bytes.len() as u64, r)]);
        }

        #[test]
        fn a_telegram_in_garbage_is_found(g in garbage(), t in any_telegram(), tail in garbage()) {
            let mut bytes = g.clone();
            bytes.extend(host_bytes(&t));
            let end = bytes.len() as u64;
            bytes.extend(&tail);
            let found = TelegramDecoder::decode_all(&bytes).into_iter().any(|e| {
                e.result == Ok(HostFrame::Telegram(t)) && e.range == (g.len() as u64..end)
            });
            prop_assert!(found);
            let found = BusSniffer::decode_all(&bytes).into_iter().any(|e| {
                e.result == Ok(Frame::Host(HostFrame::Telegram(t))) && e.range == (g.len() as u64..end)
            });
            prop_assert!(found);
        }

        #[test]
        fn a_response_in_garbage_is_found(g in garbage(), r in any_response()) {
            let mut bytes = g.clone();
            bytes.extend(r.to_bytes());
            let found = ResponseDecoder::decode_all(&bytes).into_iter().any(|e| {
                e.result == Ok(r) && e.range == (g.len() as u64..bytes.len() as u64)
            });
            prop_assert!(found);
        }

        #[test]
        fn a_conversation_is_sniffed_in_order(ts in proptest::collection::vec((any_telegram(), any_response()), 1..8)) {
            let mut bytes = Vec::new();
            let mut expected = Vec::new();
            for (t, r) in &ts {
                bytes.extend(host_bytes(t));
                expected.push(Frame::Host(HostFrame::Telegram(*t)));
                if t.expects_response() {
                    bytes.extend(r.to_bytes());
                    expected.push(Frame::Controller(*r));
                }
            }
            let got: Vec<Frame> = BusSniffer::decode_all(&bytes)
                .into_iter()
                .map(|e| e.result)
                .collect::<Result<_, _>>()
                .unwrap();
            prop_assert_eq!(got, expected);
        }
    }
}
