//! Streaming LUSTBUS decoders: bytes in as they arrive, [`StreamEvent`]s out.
//!
//! - [`Sniffer`]: a captured half-duplex stream of both directions. Host
//!   telegrams begin with EOT (section 3: "the Host computer sends the EOT
//!   character before and after each data sequence"), device replies with
//!   ADR followed by STX, ACK or NAK (sections 6.1, 6.2).
//! - [`ReplyDecoder`] (master side): the sniffer's device telegrams and
//!   skipped garbage; host telegrams (an echo of our own) are dropped.
//! - [`RequestDecoder`] (slave side): the sniffer's host telegrams and
//!   garbage; other devices' replies on the bus are dropped.
//!
//! Rules, all from the spec's state-machine model (section 3):
//!
//! - every byte is parity-masked first ([`crate::ascii::mask7`]);
//! - EOT resets: inside a telegram it aborts it (reported as an error) and
//!   starts a new host telegram, except in the BCC position, where whatever
//!   byte follows ETX is the BCC (it may equal EOT or STX);
//! - a lone EOT becomes [`Request::Eot`] once the next byte shows it does not
//!   start a telegram (or at [`Sniffer::finish`]), so each event's span is
//!   exactly the bytes [`Telegram::encode`] produces;
//! - `EOT ADR` followed by ACK/NAK is a lone EOT and a late device reply
//!   (a VF1000 delays its ACK up to ~120 ms for EEPROM writes, section 10);
//! - bytes that start no telegram are collected into one
//!   [`FrameError::Garbage`] event per run;
//! - memory is fixed: a 5-digit CODE, a 100-character VALUE and a small event
//!   queue; nothing allocates and nothing panics, whatever the input.
//!
//! A capture that begins mid-telegram, or a host whose leading EOT was lost,
//! may classify a SELECT as a value reply (the two differ only by that EOT).

use core::ops::Range;

use crate::ascii::{ACK, ENQ, EOT, ETX, NAK, STX, mask7};

use super::codec::{Expected, FrameError};
use super::frame::{
    Address, Direction, Enquiry, ParameterCode, Reply, Request, Select, Telegram, ValueReply,
    ValueText, is_value_byte,
};

/// One decoder output: a telegram or an error, with the absolute byte range
/// (counted from the first byte ever pushed) it covers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StreamEvent<T = Telegram> {
    /// Bytes `span.start..span.end` of the stream.
    pub span: Range<u64>,
    /// Who sent it; `None` for skipped garbage.
    pub direction: Option<Direction>,
    /// The telegram, or what was wrong with those bytes.
    pub result: Result<T, FrameError>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Idle,
    /// EOT seen.
    HostEot,
    /// EOT ADR seen.
    HostAdr,
    /// EOT ADR digits: ENQUIRY CODE (then ENQ).
    EnqCode,
    /// ... STX digits: CODE of a SELECT or a value reply.
    TextCode,
    /// Five digits seen, `=` next.
    Equals,
    /// VALUE characters until ETX.
    Value,
    /// The byte after ETX.
    Bcc,
    /// ADR seen (device reply?).
    DevAdr,
}

#[derive(Clone, Copy, Debug)]
struct Partial {
    dir: Direction,
    start: u64,
    len: usize,
    adr: Address,
    code: [u8; 5],
    code_len: usize,
    value: ValueText,
    bcc: u8,
    empty_value_at: Option<usize>,
}

impl Partial {
    const fn new() -> Self {
        Self {
            dir: Direction::Host,
            start: 0,
            len: 0,
            adr: Address::ALL,
            code: [b'0'; 5],
            code_len: 0,
            value: ValueText::empty(),
            bcc: 0,
            empty_value_at: None,
        }
    }
}

const QUEUE: usize = 8;

/// Bus sniffer for both directions (see the module docs).
#[derive(Clone, Debug)]
pub struct Sniffer {
    stage: Stage,
    p: Partial,
    pos: u64,
    /// Pending garbage run: start, length, first byte.
    garbage: Option<(u64, u64, u8)>,
    queue: [Option<StreamEvent>; QUEUE],
    head: usize,
    count: usize,
}

impl Default for Sniffer {
    fn default() -> Self {
        Self::new()
    }
}

impl Sniffer {
    /// A sniffer at stream position 0.
    pub const fn new() -> Self {
        Self {
            stage: Stage::Idle,
            p: Partial::new(),
            pos: 0,
            garbage: None,
            queue: [None, None, None, None, None, None, None, None],
            head: 0,
            count: 0,
        }
    }

    /// Position of the next byte (bytes pushed so far).
    pub const fn position(&self) -> u64 {
        self.pos
    }

    /// Pushes one byte; returns the events it completed (usually none).
    pub fn push(&mut self, byte: u8) -> Drain<'_> {
        let at = self.pos;
        self.pos = self.pos.saturating_add(1);
        self.step(mask7(byte), at);
        Drain { s: self }
    }

    /// Pushes bytes lazily as the returned iterator is advanced.
    pub fn feed<'a>(&'a mut self, bytes: &'a [u8]) -> Feed<'a> {
        Feed {
            s: self,
            bytes,
            i: 0,
        }
    }

    /// End of input: reports a pending lone EOT, a cut-off telegram and
    /// pending garbage, then starts over (the position keeps counting).
    pub fn finish(&mut self) -> Drain<'_> {
        let p = self.p;
        let expected = match self.stage {
            Stage::Idle => None,
            Stage::HostEot => {
                self.emit_lone_eot();
                None
            }
            Stage::DevAdr => {
                self.add_garbage(p.adr.to_byte(), p.start);
                None
            }
            Stage::HostAdr => Some(Expected::StxOrDigit),
            Stage::EnqCode if p.code_len < 5 => Some(Expected::Digit),
            Stage::EnqCode => Some(Expected::Enq),
            Stage::TextCode => Some(Expected::Digit),
            Stage::Equals => Some(Expected::Equals),
            Stage::Value => Some(Expected::ValueOrEtx),
            Stage::Bcc => Some(Expected::Bcc),
        };
        if let Some(expected) = expected {
            self.emit(
                p.start..p.start + p.len as u64,
                Some(p.dir),
                Err(FrameError::Truncated {
                    direction: p.dir,
                    len: p.len,
                    expected,
                }),
            );
        }
        self.stage = Stage::Idle;
        self.flush_garbage();
        Drain { s: self }
    }

    /// Drops any partial telegram and pending events (e.g. after the link
    /// was reopened); the position keeps counting.
    pub fn reset(&mut self) {
        self.stage = Stage::Idle;
        self.garbage = None;
        self.queue = Default::default();
        self.head = 0;
        self.count = 0;
    }

    fn pop(&mut self) -> Option<StreamEvent> {
        if self.count == 0 {
            return None;
        }
        let ev = self.queue[self.head].take();
        self.head = (self.head + 1) % QUEUE;
        self.count -= 1;
        ev
    }

    fn enqueue(&mut self, ev: StreamEvent) {
        // At most three events follow from one byte (garbage run, lone EOT,
        // a reply); the queue holds eight, so this never drops in practice.
        if self.count < QUEUE {
            let i = (self.head + self.count) % QUEUE;
            self.queue[i] = Some(ev);
            self.count += 1;
        }
    }

    fn flush_garbage(&mut self) {
        if let Some((start, len, first)) = self.garbage.take() {
            self.enqueue(StreamEvent {
                span: start..start + len,
                direction: None,
                result: Err(FrameError::Garbage { len, first }),
            });
        }
    }

    fn emit(
        &mut self,
        span: Range<u64>,
        direction: Option<Direction>,
        result: Result<Telegram, FrameError>,
    ) {
        self.flush_garbage();
        self.enqueue(StreamEvent {
            span,
            direction,
            result,
        });
    }

    fn add_garbage(&mut self, b: u8, at: u64) {
        match &mut self.garbage {
            Some((start, len, _)) if *start + *len == at => *len += 1,
            _ => {
                self.flush_garbage();
                self.garbage = Some((at, 1, b));
            }
        }
    }

    fn emit_lone_eot(&mut self) {
        let s = self.p.start;
        self.emit(
            s..s + 1,
            Some(Direction::Host),
            Ok(Telegram::Request(Request::Eot)),
        );
        self.stage = Stage::Idle;
    }

    fn begin(&mut self, dir: Direction, at: u64, stage: Stage) {
        self.p = Partial {
            dir,
            start: at,
            len: 1,
            ..Partial::new()
        };
        self.stage = stage;
    }

    /// Reports the partial telegram as broken at byte `b` (which is not part
    /// of it) and reprocesses `b` from idle.
    fn fail(&mut self, b: u8, at: u64, expected: Expected) {
        let p = self.p;
        self.emit(
            p.start..at,
            Some(p.dir),
            Err(FrameError::Unexpected {
                direction: p.dir,
                offset: p.len,
                found: b,
                expected,
            }),
        );
        self.stage = Stage::Idle;
        self.step(b, at);
    }

    fn complete(&mut self, at: u64, t: Telegram) {
        let p = self.p;
        self.emit(p.start..at + 1, Some(p.dir), Ok(t));
        self.stage = Stage::Idle;
    }

    fn step(&mut self, b: u8, at: u64) {
        match self.stage {
            Stage::Idle => {
                if b == EOT {
                    self.begin(Direction::Host, at, Stage::HostEot);
                } else if let Some(a) = Address::from_byte(b) {
                    self.begin(Direction::Device, at, Stage::DevAdr);
                    self.p.adr = a;
                } else {
                    self.add_garbage(b, at);
                }
            }
            Stage::HostEot => {
                if let Some(a) = Address::from_byte(b) {
                    self.p.adr = a;
                    self.p.len += 1;
                    self.stage = Stage::HostAdr;
                } else {
                    self.emit_lone_eot();
                    self.step(b, at);
                }
            }
            Stage::HostAdr => {
                if b.is_ascii_digit() {
                    self.p.code[0] = b;
                    self.p.code_len = 1;
                    self.p.len += 1;
                    self.stage = Stage::EnqCode;
                } else if b == STX {
                    self.p.len += 1;
                    self.stage = Stage::TextCode;
                } else if b == ACK || b == NAK {
                    // A lone EOT, then a late `ADR ACK|NAK` from a device.
                    let adr = self.p.adr;
                    let adr_at = self.p.start + 1;
                    self.emit_lone_eot();
                    self.step(adr.to_byte(), adr_at);
                    self.step(b, at);
                } else {
                    self.fail(b, at, Expected::StxOrDigit);
                }
            }
            Stage::EnqCode => {
                if self.p.code_len < 5 {
                    if b.is_ascii_digit() {
                        self.p.code[self.p.code_len] = b;
                        self.p.code_len += 1;
                        self.p.len += 1;
                    } else {
                        self.fail(b, at, Expected::Digit);
                    }
                } else if b == ENQ {
                    match ParameterCode::from_digits(self.p.code) {
                        Some(code) => {
                            let e = Enquiry::new(self.p.adr, code);
                            self.complete(at, Telegram::Request(Request::Enquiry(e)));
                        }
                        None => self.fail(b, at, Expected::Digit),
                    }
                } else {
                    self.fail(b, at, Expected::Enq);
                }
            }
            Stage::TextCode => {
                if b.is_ascii_digit() && self.p.code_len < 5 {
                    self.p.code[self.p.code_len] = b;
                    self.p.code_len += 1;
                    self.p.len += 1;
                    self.p.bcc ^= b;
                    if self.p.code_len == 5 {
                        self.stage = Stage::Equals;
                    }
                } else {
                    self.fail(b, at, Expected::Digit);
                }
            }
            Stage::Equals => {
                if b == b'=' {
                    self.p.len += 1;
                    self.p.bcc ^= b;
                    self.stage = Stage::Value;
                } else {
                    self.fail(b, at, Expected::Equals);
                }
            }
            Stage::Value => {
                if b == ETX {
                    if self.p.value.is_empty() {
                        self.p.empty_value_at = Some(self.p.len);
                    }
                    self.p.len += 1;
                    self.p.bcc ^= b;
                    self.stage = Stage::Bcc;
                } else if is_value_byte(b) {
                    if self.p.value.push(b) {
                        self.p.len += 1;
                        self.p.bcc ^= b;
                    } else {
                        let p = self.p;
                        self.emit(
                            p.start..at,
                            Some(p.dir),
                            Err(FrameError::ValueTooLong {
                                direction: p.dir,
                                offset: p.len,
                            }),
                        );
                        self.stage = Stage::Idle;
                        self.step(b, at);
                    }
                } else {
                    self.fail(b, at, Expected::ValueOrEtx);
                }
            }
            Stage::Bcc => {
                let p = self.p;
                self.p.len += 1;
                let result = if let Some(offset) = p.empty_value_at {
                    Err(FrameError::EmptyValue {
                        direction: p.dir,
                        offset,
                    })
                } else if b != p.bcc {
                    Err(FrameError::BadBcc {
                        direction: p.dir,
                        received: b,
                        computed: p.bcc,
                    })
                } else {
                    match ParameterCode::from_digits(p.code) {
                        Some(code) => Ok(match p.dir {
                            Direction::Host => Telegram::Request(Request::Select(Select::new(
                                p.adr, code, p.value,
                            ))),
                            Direction::Device => Telegram::Reply(Reply::Value(ValueReply {
                                address: p.adr,
                                code,
                                value: p.value,
                            })),
                        }),
                        None => Err(FrameError::Unexpected {
                            direction: p.dir,
                            offset: 0,
                            found: b,
                            expected: Expected::Digit,
                        }),
                    }
                };
                self.emit(p.start..at + 1, Some(p.dir), result);
                self.stage = Stage::Idle;
            }
            Stage::DevAdr => {
                let a = self.p.adr;
                match b {
                    ACK => self.complete(at, Telegram::Reply(Reply::Ack(a))),
                    NAK => self.complete(at, Telegram::Reply(Reply::Nak(a))),
                    STX => {
                        self.p.len += 1;
                        self.stage = Stage::TextCode;
                    }
                    _ => {
                        // Not a reply after all: the ADR-like byte is garbage.
                        let start = self.p.start;
                        self.stage = Stage::Idle;
                        self.add_garbage(a.to_byte(), start);
                        self.step(b, at);
                    }
                }
            }
        }
    }
}

/// The events completed by one [`Sniffer::push`] or [`Sniffer::finish`].
#[derive(Debug)]
pub struct Drain<'a> {
    s: &'a mut Sniffer,
}

impl Iterator for Drain<'_> {
    type Item = StreamEvent;
    fn next(&mut self) -> Option<StreamEvent> {
        self.s.pop()
    }
}

/// Lazily feeds a byte slice to a [`Sniffer`]; see [`Sniffer::feed`].
#[derive(Debug)]
pub struct Feed<'a> {
    s: &'a mut Sniffer,
    bytes: &'a [u8],
    i: usize,
}

impl Iterator for Feed<'_> {
    type Item = StreamEvent;
    fn next(&mut self) -> Option<StreamEvent> {
        loop {
            if let Some(ev) = self.s.pop() {
                return Some(ev);
            }
            let &b = self.bytes.get(self.i)?;
            self.i += 1;
            let at = self.s.pos;
            self.s.pos = self.s.pos.saturating_add(1);
            self.s.step(mask7(b), at);
        }
    }
}

fn as_reply(ev: StreamEvent) -> Option<StreamEvent<Reply>> {
    let result = match ev.result {
        Ok(Telegram::Reply(r)) => Ok(r),
        Ok(Telegram::Request(_)) => return None,
        Err(_) if ev.direction == Some(Direction::Host) => return None,
        Err(e) => Err(e),
    };
    Some(StreamEvent {
        span: ev.span,
        direction: ev.direction,
        result,
    })
}

fn as_request(ev: StreamEvent) -> Option<StreamEvent<Request>> {
    let result = match ev.result {
        Ok(Telegram::Request(r)) => Ok(r),
        Ok(Telegram::Reply(_)) => return None,
        Err(_) if ev.direction == Some(Direction::Device) => return None,
        Err(e) => Err(e),
    };
    Some(StreamEvent {
        span: ev.span,
        direction: ev.direction,
        result,
    })
}

macro_rules! filtered_decoder {
    ($(#[$m:meta])* $name:ident, $item:ty, $conv:ident) => {
        $(#[$m])*
        #[derive(Clone, Debug, Default)]
        pub struct $name {
            inner: Sniffer,
        }

        impl $name {
            /// A decoder at stream position 0.
            pub const fn new() -> Self {
                Self { inner: Sniffer::new() }
            }

            /// Pushes one byte; returns the events it completed.
            pub fn push(&mut self, byte: u8) -> impl Iterator<Item = StreamEvent<$item>> + '_ {
                self.inner.push(byte).filter_map($conv)
            }

            /// Pushes bytes lazily as the returned iterator is advanced.
            pub fn feed<'a>(
                &'a mut self,
                bytes: &'a [u8],
            ) -> impl Iterator<Item = StreamEvent<$item>> + 'a {
                self.inner.feed(bytes).filter_map($conv)
            }

            /// End of input (see [`Sniffer::finish`]).
            pub fn finish(&mut self) -> impl Iterator<Item = StreamEvent<$item>> + '_ {
                self.inner.finish().filter_map($conv)
            }

            /// Drops any partial telegram (see [`Sniffer::reset`]).
            pub fn reset(&mut self) {
                self.inner.reset();
            }

            /// Position of the next byte.
            pub const fn position(&self) -> u64 {
                self.inner.position()
            }
        }
    };
}

filtered_decoder!(
    /// Master-side decoder of device replies (value reply, ACK, NAK) and
    /// garbage; host telegrams on the line (echoes) are skipped silently.
    ReplyDecoder,
    Reply,
    as_reply
);

filtered_decoder!(
    /// Slave-side decoder of host telegrams (ENQUIRY, SELECT, EOT) and
    /// garbage; other devices' replies on the bus are skipped silently.
    RequestDecoder,
    Request,
    as_request
);

#[cfg(test)]
mod tests {
    use super::*;

    fn all(bytes: &[u8]) -> Vec<StreamEvent> {
        let mut s = Sniffer::new();
        let mut v: Vec<_> = s.feed(bytes).collect();
        v.extend(s.finish());
        v
    }

    #[test]
    fn transaction_in_both_directions() {
        let bytes = b"\x04@00112\x05@\x0200112=03E8\x03\x72\x04";
        let ev = all(bytes);
        assert_eq!(ev.len(), 3);
        assert_eq!(ev[0].span, 0..8);
        assert_eq!(ev[0].direction, Some(Direction::Host));
        assert!(matches!(
            ev[0].result,
            Ok(Telegram::Request(Request::Enquiry(_)))
        ));
        assert_eq!(ev[1].span, 8..22);
        assert_eq!(ev[1].direction, Some(Direction::Device));
        assert!(matches!(ev[1].result, Ok(Telegram::Reply(Reply::Value(_)))));
        assert_eq!(ev[2].span, 22..23);
        assert_eq!(ev[2].result, Ok(Telegram::Request(Request::Eot)));
    }

    #[test]
    fn garbage_is_one_event_per_run() {
        let ev = all(b"xyz\x04@00085\x05");
        assert_eq!(ev.len(), 2);
        assert_eq!(ev[0].span, 0..3);
        assert_eq!(
            ev[0].result,
            Err(FrameError::Garbage {
                len: 3,
                first: b'x'
            })
        );
        assert_eq!(ev[1].span, 3..11);
    }

    #[test]
    fn eot_aborts_and_restarts() {
        let ev = all(b"\x04@001\x04@00112\x05");
        assert_eq!(ev.len(), 2);
        assert_eq!(ev[0].span, 0..5);
        assert_eq!(
            ev[0].result,
            Err(FrameError::Unexpected {
                direction: Direction::Host,
                offset: 5,
                found: EOT,
                expected: Expected::Digit
            })
        );
        assert_eq!(ev[1].span, 5..13);
        assert!(ev[1].result.is_ok());
    }

    #[test]
    fn late_ack_after_lone_eot() {
        let ev = all(b"\x04A\x06");
        assert_eq!(ev.len(), 2);
        assert_eq!(ev[0].result, Ok(Telegram::Request(Request::Eot)));
        assert_eq!(
            ev[1].result,
            Ok(Telegram::Reply(Reply::Ack(Address::new(1).unwrap())))
        );
        assert_eq!(ev[1].span, 1..3);
    }

    #[test]
    fn adr_like_letters_are_garbage() {
        let ev = all(b"HELLO@\x06");
        assert_eq!(ev.len(), 2);
        assert_eq!(
            ev[0].result,
            Err(FrameError::Garbage {
                len: 5,
                first: b'H'
            })
        );
        assert_eq!(ev[1].span, 5..7);
    }

    #[test]
    fn filtered_decoders() {
        let bytes = b"\x04@00112\x05@\x0200112=03E8\x03\x72\x04";
        let mut m = ReplyDecoder::new();
        let replies: Vec<_> = m.feed(bytes).chain(Vec::new()).collect();
        let mut replies = replies;
        replies.extend(m.finish());
        assert_eq!(replies.len(), 1);
        assert!(matches!(replies[0].result, Ok(Reply::Value(_))));

        let mut d = RequestDecoder::new();
        let mut reqs: Vec<_> = d.feed(bytes).collect();
        reqs.extend(d.finish());
        assert_eq!(reqs.len(), 2);
        assert_eq!(reqs[1].result, Ok(Request::Eot));
    }

    #[test]
    fn push_one_by_one_matches_feed() {
        let bytes = b"junk\x04@\x0200105=03E8\x03\x74@\x06\x04";
        let mut s = Sniffer::new();
        let mut a = Vec::new();
        for &b in bytes {
            a.extend(s.push(b));
        }
        a.extend(s.finish());
        assert_eq!(a, all(bytes));
        assert_eq!(a.len(), 4);
    }
}
