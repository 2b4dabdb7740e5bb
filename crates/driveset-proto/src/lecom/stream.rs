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

/// A decoder's event for what the machine completed: the frame as the
/// decoder's item (`map`), or the error. `None` for a frame `map` does not
/// take (one this decoder's settings do not produce): no event.
fn event_of<T>(
    map: fn(Frame) -> Option<T>,
    direction: Direction,
    range: Range<u64>,
    result: Result<Frame, StreamError>,
) -> Option<Event<T>> {
    let result = match result {
        Ok(frame) => Ok(map(frame)?),
        Err(e) => Err(e),
    };
    Some(Event {
        direction,
        range,
        result,
    })
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
                let map: fn(Frame) -> Option<$item> = $map;
                self.0.feed(bytes, &mut |direction, range, result| {
                    if let Some(event) = event_of(map, direction, range, result) {
                        on_event(event);
                    }
                });
            }

            /// Ends the stream: reports pending garbage and a frame cut off
            /// by the end ([`StreamError::Truncated`]), and returns to idle.
            pub fn finish(&mut self, mut on_event: impl FnMut(Event<$item>)) {
                let map: fn(Frame) -> Option<$item> = $map;
                self.0.finish(&mut |direction, range, result| {
                    if let Some(event) = event_of(map, direction, range, result) {
                        on_event(event);
                    }
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
mod tests;
