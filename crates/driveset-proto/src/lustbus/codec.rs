//! LUSTBUS codec for one complete telegram: exact bytes out
//! ([`TelegramBytes`] from `encode()` on every telegram type), checked
//! telegrams in ([`decode_request`], [`decode_reply`], [`decode_telegram`])
//! with [`FrameError`] saying what is wrong with which byte.
//!
//! Frames (sections 2.2, 6.1, 6.2):
//!
//! ```text
//! ENQUIRY      EOT ADR C C C C C ENQ
//! SELECT       EOT ADR STX C C C C C = VALUE ETX BCC
//! value reply      ADR STX C C C C C = VALUE ETX BCC
//! ACK / NAK        ADR ACK | ADR NAK
//! end          EOT
//! ```
//!
//! BCC = XOR of every byte after STX up to and including ETX
//! ([`crate::ascii::bcc`]). The decoders mask the parity bit of every byte
//! ([`crate::ascii::mask7`]) and always take the byte after ETX as the BCC,
//! whatever its value (it may equal EOT or STX).

use core::fmt;
use core::ops::Deref;

use thiserror::Error;

use crate::ascii::{ACK, ENQ, EOT, ETX, NAK, STX, bcc};

use super::frame::Address;
use super::frame::{
    Direction, Enquiry, MAX_VALUE_LEN, ParameterCode, Reply, Request, Select, Shown, Telegram,
    ValueReply, ValueText,
};
use super::stream::Sniffer;

/// Longest telegram: `EOT ADR STX CODE(5) = VALUE(100) ETX BCC`.
pub const MAX_TELEGRAM_LEN: usize = 3 + 5 + 1 + MAX_VALUE_LEN + 2;

/// What the decoder expected at the byte it did not like.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Expected {
    /// An address character 0x40..=0x5F.
    Address,
    /// STX (SELECT) or the first CODE digit (ENQUIRY) after `EOT ADR`.
    StxOrDigit,
    /// A CODE digit `0`..`9`.
    Digit,
    /// ENQ after the five CODE digits of an ENQUIRY.
    Enq,
    /// `=` after the five CODE digits.
    Equals,
    /// A VALUE character or ETX.
    ValueOrEtx,
    /// The BCC after ETX.
    Bcc,
    /// STX, ACK or NAK after a device's ADR.
    StxAckNak,
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Expected::Address => "an address character 0x40..=0x5F",
            Expected::StxOrDigit => "STX (SELECT) or a CODE digit (ENQUIRY)",
            Expected::Digit => "a CODE digit 0-9",
            Expected::Enq => "ENQ",
            Expected::Equals => "'=' after the CODE",
            Expected::ValueOrEtx => "a VALUE character or ETX",
            Expected::Bcc => "the BCC after ETX",
            Expected::StxAckNak => "STX, ACK or NAK after the address",
        })
    }
}

/// What is wrong with a telegram. Offsets count from the telegram's first
/// byte (its EOT for host telegrams, its ADR for replies).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Error)]
pub enum FrameError {
    /// No bytes at all.
    #[error("no bytes")]
    Empty,
    /// Bytes that start no telegram; a stream decoder skipped them.
    #[error("{len} byte(s) starting with {first:#04x} ({shown}) belong to no telegram; skipped", shown = Shown(*first))]
    Garbage {
        /// How many bytes were skipped.
        len: u64,
        /// The first of them (parity masked).
        first: u8,
    },
    /// A byte that does not fit the telegram syntax at that place.
    #[error("{direction} telegram byte {offset} is {found:#04x} ({shown}); expected {expected}", shown = Shown(*found))]
    Unexpected {
        /// Who was sending (from the telegram's first byte).
        direction: Direction,
        /// Offset of the byte in the telegram.
        offset: usize,
        /// The byte (parity masked).
        found: u8,
        /// What would have been valid there.
        expected: Expected,
    },
    /// VALUE exceeded 100 characters (section 2.3).
    #[error("{direction} telegram VALUE is longer than 100 characters (byte {offset})")]
    ValueTooLong {
        /// Who was sending.
        direction: Direction,
        /// Offset of the 101st VALUE character.
        offset: usize,
    },
    /// ETX right after `=` (section 2.3: VALUE has 1..100 characters).
    #[error("{direction} telegram has an empty VALUE (ETX at byte {offset})")]
    EmptyValue {
        /// Who was sending.
        direction: Direction,
        /// Offset of the ETX.
        offset: usize,
    },
    /// The BCC does not match CODE..ETX.
    #[error("{direction} telegram BCC is {received:#04x} but CODE..ETX XOR to {computed:#04x}")]
    BadBcc {
        /// Who was sending.
        direction: Direction,
        /// BCC byte received (parity masked).
        received: u8,
        /// BCC computed over the received CODE, '=', VALUE and ETX.
        computed: u8,
    },
    /// Input ended inside a telegram.
    #[error("{direction} telegram cut off after {len} byte(s); expected {expected} next")]
    Truncated {
        /// Who was sending.
        direction: Direction,
        /// Bytes received.
        len: usize,
        /// What the next byte should have been.
        expected: Expected,
    },
    /// Bytes after a complete telegram (whole-telegram decoders only).
    #[error("{extra} byte(s) after the end of the telegram at byte {offset}")]
    Trailing {
        /// Offset of the first extra byte.
        offset: usize,
        /// How many extra bytes.
        extra: usize,
    },
    /// A valid telegram of the other direction (e.g. a reply given to
    /// [`decode_request`]).
    #[error("a valid {found} telegram where a {wanted} telegram was expected")]
    WrongDirection {
        /// Direction of the telegram found.
        found: Direction,
        /// Direction wanted.
        wanted: Direction,
    },
}

/// Encoded telegram bytes, inline (at most [`MAX_TELEGRAM_LEN`]).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct TelegramBytes {
    len: u8,
    buf: [u8; MAX_TELEGRAM_LEN],
}

impl TelegramBytes {
    const fn new() -> Self {
        Self {
            len: 0,
            buf: [0; MAX_TELEGRAM_LEN],
        }
    }

    fn extend(&mut self, bytes: &[u8]) {
        let start = self.len as usize;
        let n = bytes.len().min(MAX_TELEGRAM_LEN - start);
        self.buf[start..start + n].copy_from_slice(&bytes[..n]);
        self.len += n as u8;
    }

    /// The bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len as usize]
    }

    /// Appends `CODE = VALUE ETX BCC` (the part after STX).
    fn text(&mut self, code: ParameterCode, value: &ValueText) {
        let from = self.len as usize;
        self.extend(&code.digits());
        self.extend(b"=");
        self.extend(value.as_bytes());
        self.extend(&[ETX]);
        let b = bcc(&self.buf[from..self.len as usize]);
        self.extend(&[b]);
    }
}

impl Deref for TelegramBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_bytes()
    }
}

impl AsRef<[u8]> for TelegramBytes {
    fn as_ref(&self) -> &[u8] {
        self.as_bytes()
    }
}

impl fmt::Debug for TelegramBytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "TelegramBytes(\"{}\")", self.as_bytes().escape_ascii())
    }
}

impl Enquiry {
    /// `EOT ADR CODE ENQ` (section 6.1).
    pub fn encode(&self) -> TelegramBytes {
        let mut t = TelegramBytes::new();
        t.extend(&[EOT, self.address.to_byte()]);
        t.extend(&self.code.digits());
        t.extend(&[ENQ]);
        t
    }
}

impl Select {
    /// `EOT ADR STX CODE = VALUE ETX BCC` (section 6.2).
    pub fn encode(&self) -> TelegramBytes {
        let mut t = TelegramBytes::new();
        t.extend(&[EOT, self.address.to_byte(), STX]);
        t.text(self.code, &self.value);
        t
    }
}

impl ValueReply {
    /// `ADR STX CODE = VALUE ETX BCC` (section 6.1).
    pub fn encode(&self) -> TelegramBytes {
        let mut t = TelegramBytes::new();
        t.extend(&[self.address.to_byte(), STX]);
        t.text(self.code, &self.value);
        t
    }
}

impl Request {
    /// The host telegram's bytes (a lone EOT is the single byte 0x04).
    pub fn encode(&self) -> TelegramBytes {
        match self {
            Request::Eot => {
                let mut t = TelegramBytes::new();
                t.extend(&[EOT]);
                t
            }
            Request::Enquiry(e) => e.encode(),
            Request::Select(s) => s.encode(),
        }
    }
}

impl Reply {
    /// The device telegram's bytes: `ADR ACK`, `ADR NAK` or a value reply.
    pub fn encode(&self) -> TelegramBytes {
        let short = |a: Address, c: u8| {
            let mut t = TelegramBytes::new();
            t.extend(&[a.to_byte(), c]);
            t
        };
        match self {
            Reply::Value(v) => v.encode(),
            Reply::Ack(a) => short(*a, ACK),
            Reply::Nak(a) => short(*a, NAK),
        }
    }
}

impl Telegram {
    /// The telegram's bytes.
    pub fn encode(&self) -> TelegramBytes {
        match self {
            Telegram::Request(r) => r.encode(),
            Telegram::Reply(r) => r.encode(),
        }
    }
}

/// Decodes exactly one telegram of either direction: all of `bytes`, no
/// more, no less. A leading EOT makes it a host telegram; `EOT` alone is
/// [`Request::Eot`].
pub fn decode_telegram(bytes: &[u8]) -> Result<Telegram, FrameError> {
    if bytes.is_empty() {
        return Err(FrameError::Empty);
    }
    let mut s = Sniffer::new();
    let first = {
        let mut it = s.feed(bytes);
        it.next()
    };
    let first = match first {
        Some(ev) => ev,
        None => match s.finish().next() {
            Some(ev) => ev,
            // Unreachable in practice: finish() reports whatever is pending.
            None => return Err(FrameError::Empty),
        },
    };
    let telegram = first.result?;
    let end = first.span.end as usize;
    if end < bytes.len() {
        return Err(FrameError::Trailing {
            offset: end,
            extra: bytes.len() - end,
        });
    }
    Ok(telegram)
}

/// Decodes exactly one host telegram (ENQUIRY, SELECT or a lone EOT), as
/// a device receives it.
pub fn decode_request(bytes: &[u8]) -> Result<Request, FrameError> {
    match decode_telegram(bytes)? {
        Telegram::Request(r) => Ok(r),
        Telegram::Reply(_) => Err(FrameError::WrongDirection {
            found: Direction::Device,
            wanted: Direction::Host,
        }),
    }
}

/// Decodes exactly one device telegram (value reply, ACK, NAK), as the host
/// receives it.
pub fn decode_reply(bytes: &[u8]) -> Result<Reply, FrameError> {
    match decode_telegram(bytes)? {
        Telegram::Reply(r) => Ok(r),
        Telegram::Request(_) => Err(FrameError::WrongDirection {
            found: Direction::Host,
            wanted: Direction::Device,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ascii::mask7;

    fn code(n: u32) -> ParameterCode {
        ParameterCode::new(n).unwrap()
    }
    fn val(s: &[u8]) -> ValueText {
        ValueText::new(s).unwrap()
    }

    #[test]
    fn encode_enquiry_exact() {
        let e = Enquiry::new(Address::ALL, code(112));
        assert_eq!(e.encode().as_bytes(), b"\x04@00112\x05");
    }

    #[test]
    fn encode_select_exact() {
        let s = Select::new(Address::ALL, code(105), val(b"03E8"));
        // BCC of "00105=03E8" ETX = 0x74.
        assert_eq!(s.encode().as_bytes(), b"\x04@\x0200105=03E8\x03\x74");
    }

    #[test]
    fn encode_replies_exact() {
        let a = Address::new(1).unwrap();
        assert_eq!(Reply::Ack(a).encode().as_bytes(), b"A\x06");
        assert_eq!(Reply::Nak(a).encode().as_bytes(), b"A\x15");
        assert_eq!(Request::Eot.encode().as_bytes(), b"\x04");
        let r = ValueReply {
            address: Address::ALL,
            code: code(112),
            value: val(b"03E8"),
        };
        assert_eq!(r.encode().as_bytes(), b"@\x0200112=03E8\x03\x72");
    }

    #[test]
    fn decode_checks_bcc() {
        let err = decode_reply(b"@\x0200112=03E8\x03\x0B").unwrap_err();
        assert_eq!(
            err,
            FrameError::BadBcc {
                direction: Direction::Device,
                received: 0x0B,
                computed: 0x72
            }
        );
    }

    #[test]
    fn decode_masks_parity() {
        let bytes: Vec<u8> = b"\x04@00112\x05".iter().map(|b| b | 0x80).collect();
        assert_eq!(
            decode_request(&bytes),
            Ok(Request::Enquiry(Enquiry::new(Address::ALL, code(112))))
        );
        assert_eq!(mask7(bytes[0]), EOT);
    }

    #[test]
    fn decode_errors_name_the_byte() {
        assert_eq!(decode_request(b""), Err(FrameError::Empty));
        assert_eq!(
            decode_request(b"\x04@001x2\x05"),
            Err(FrameError::Unexpected {
                direction: Direction::Host,
                offset: 5,
                found: b'x',
                expected: Expected::Digit
            })
        );
        assert_eq!(
            decode_request(b"\x04@00112"),
            Err(FrameError::Truncated {
                direction: Direction::Host,
                len: 7,
                expected: Expected::Enq
            })
        );
        assert_eq!(
            decode_request(b"\x04@00112\x05\x04"),
            Err(FrameError::Trailing {
                offset: 8,
                extra: 1
            })
        );
        assert_eq!(
            decode_request(b"@\x06"),
            Err(FrameError::WrongDirection {
                found: Direction::Device,
                wanted: Direction::Host
            })
        );
        assert_eq!(
            decode_reply(b"\x04"),
            Err(FrameError::WrongDirection {
                found: Direction::Host,
                wanted: Direction::Device
            })
        );
        assert_eq!(
            decode_reply(b"@\x02=\x03\x3E"),
            Err(FrameError::Unexpected {
                direction: Direction::Device,
                offset: 2,
                found: b'=',
                expected: Expected::Digit
            })
        );
        // ETX right after '=': the BCC is still consumed, then reported.
        assert_eq!(
            decode_reply(b"@\x0200112=\x03\x3E"),
            Err(FrameError::EmptyValue {
                direction: Direction::Device,
                offset: 8
            })
        );
        assert_eq!(
            decode_reply(b"x"),
            Err(FrameError::Garbage {
                len: 1,
                first: b'x'
            })
        );
    }

    #[test]
    fn bcc_may_be_a_control_character() {
        // The PosMOD1 status request "49999=1?" (11.6.4) has BCC 0x04 = EOT.
        let s = Select::new(Address::ALL, ParameterCode::POSMOD, val(b"1?"));
        let bytes = s.encode();
        assert_eq!(bytes.as_bytes(), b"\x04@\x0249999=1?\x03\x04");
        assert_eq!(decode_request(&bytes), Ok(Request::Select(s)));
        // "00005=0080" has BCC 0x03 = ETX.
        let s = Select::new(Address::ALL, code(5), val(b"0080"));
        assert_eq!(*s.encode().last().unwrap(), ETX);
        assert_eq!(decode_request(&s.encode()), Ok(Request::Select(s)));
    }

    #[test]
    fn overlong_value_is_refused() {
        let mut bytes = b"@\x0220001=".to_vec();
        bytes.extend([b'0'; 101]);
        bytes.extend([ETX, 0]);
        assert_eq!(
            decode_reply(&bytes),
            Err(FrameError::ValueTooLong {
                direction: Direction::Device,
                offset: 108
            })
        );
    }
}
