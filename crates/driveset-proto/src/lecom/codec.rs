//! Bytes in, bytes out for complete frames: encoding and decoding of host
//! telegrams (8.H, 8.I, 8.J) and controller responses (8.H a, 8.I a), the
//! BCC check (8.G), and the text parsers the streaming decoders in
//! [`super::stream`] share. Every received byte is parity-masked
//! ([`ascii::mask7`]) before it is looked at.

use crate::ascii::{self, ACK, ENQ, EOT, ETX, NAK, STX};

use super::address::ControllerAddress;
use super::code::{CodeAddress, ExtendedAddress};
use super::error::{EncodeError, FrameError};
use super::frame::{Broadcast, Receive, Response, Send, Telegram};
use super::value::Value;

/// The longest text between STX and ETX: a 7-byte extended code field and
/// the longest value ('O' + 240 nibbles).
pub const MAX_TEXT: usize = 7 + Value::MAX_WIRE_LEN;

/// Appends `STX`, what `body` writes, `ETX` and the BCC over both (8.G).
fn write_text_block(out: &mut Vec<u8>, body: impl FnOnce(&mut Vec<u8>)) {
    out.push(STX);
    let start = out.len();
    body(out);
    out.push(ETX);
    let bcc = ascii::bcc(&out[start..]);
    out.push(bcc);
}

impl Telegram {
    /// Appends the telegram's bytes to `out` (8.H, 8.I, 8.J).
    ///
    /// # Errors
    /// [`EncodeError`] when the address does not fit the telegram kind
    /// (RECEIVE / SEND need a station, BROADCAST needs 00 or x0). Nothing is
    /// appended then.
    pub fn encode(&self, out: &mut Vec<u8>) -> Result<(), EncodeError> {
        let address = self.address();
        match (self, address.is_broadcast()) {
            (Self::Receive(_), true) => return Err(EncodeError::ReceiveFromBroadcast { address }),
            (Self::Send(_), true) => return Err(EncodeError::SendToBroadcast { address }),
            (Self::Broadcast(_), false) => {
                return Err(EncodeError::BroadcastToStation { address });
            }
            _ => {}
        }
        out.push(EOT);
        out.extend_from_slice(&address.to_ascii());
        match self {
            Self::Receive(t) => {
                t.code.write(out);
                out.push(ENQ);
            }
            Self::Send(Send { code, value, .. })
            | Self::Broadcast(Broadcast { code, value, .. }) => {
                write_text_block(out, |out| {
                    code.write(out);
                    value.write(out);
                });
            }
        }
        Ok(())
    }

    /// The telegram's bytes in a new buffer.
    ///
    /// # Errors
    /// As [`encode`](Self::encode).
    pub fn to_bytes(&self) -> Result<Vec<u8>, EncodeError> {
        let mut out = Vec::with_capacity(12);
        self.encode(&mut out)?;
        Ok(out)
    }

    /// Decodes exactly one telegram, `frame` holding nothing else.
    ///
    /// # Errors
    /// [`FrameError`] naming the offending byte.
    pub fn decode(frame: &[u8]) -> Result<Self, FrameError> {
        let masked = |i: usize| frame.get(i).map(|&b| ascii::mask7(b));
        let truncated = FrameError::Truncated { len: frame.len() };
        match masked(0) {
            None => return Err(truncated),
            Some(EOT) => {}
            Some(found) => {
                return Err(FrameError::Expected {
                    expected: "EOT",
                    at: 0,
                    found,
                });
            }
        }
        let (Some(ad1), Some(ad2)) = (masked(1), masked(2)) else {
            return Err(truncated);
        };
        let address = ControllerAddress::from_ascii([ad1, ad2])?;
        match masked(3) {
            None => Err(truncated),
            Some(STX) => {
                let (text, bcc, end) = split_text_block(frame, 4)?;
                check_end(frame, end)?;
                check_bcc(text.as_slice(), bcc)?;
                parse_send_text(address, text.as_slice())
            }
            Some(_) => {
                let mut field = TextBuf::new();
                for (i, &b) in frame.iter().enumerate().skip(3) {
                    let b = ascii::mask7(b);
                    if b == ENQ {
                        check_end(frame, i + 1)?;
                        return parse_receive(address, field.as_slice());
                    }
                    if field.as_slice().len() == ExtendedAddress::LEN {
                        return Err(FrameError::Expected {
                            expected: "ENQ",
                            at: i,
                            found: b,
                        });
                    }
                    field.push(b);
                }
                Err(truncated)
            }
        }
    }
}

impl Response {
    /// Appends the response's bytes to `out` (8.H a, 8.I a).
    pub fn encode(&self, out: &mut Vec<u8>) {
        match self {
            Self::Value { code, value } => write_text_block(out, |out| {
                code.write(out);
                value.write(out);
            }),
            Self::ChecksumFault { code } => write_text_block(out, |out| {
                code.write(out);
                out.push(b'?');
            }),
            Self::NoSuchCode { code } => {
                out.push(STX);
                code.write(out);
                out.push(EOT);
            }
            Self::Ack => out.push(ACK),
            Self::Nak => out.push(NAK),
        }
    }

    /// The response's bytes in a new buffer.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(12);
        self.encode(&mut out);
        out
    }

    /// Decodes exactly one response, `frame` holding nothing else.
    ///
    /// # Errors
    /// [`FrameError`] naming the offending byte.
    pub fn decode(frame: &[u8]) -> Result<Self, FrameError> {
        let Some(&first) = frame.first() else {
            return Err(FrameError::Truncated { len: 0 });
        };
        match ascii::mask7(first) {
            ACK => check_end(frame, 1).map(|()| Self::Ack),
            NAK => check_end(frame, 1).map(|()| Self::Nak),
            STX => {
                // STX C1 C2 EOT: the EOT comes where the text would go on.
                if let Some(i) = frame.iter().skip(1).position(|&b| {
                    let b = ascii::mask7(b);
                    b == EOT || b == ETX
                }) {
                    let i = i + 1;
                    if ascii::mask7(frame[i]) == EOT {
                        check_end(frame, i + 1)?;
                        let text = TextBuf::masked(&frame[1..i])?;
                        return Ok(Self::NoSuchCode {
                            code: CodeAddress::parse(text.as_slice())?,
                        });
                    }
                }
                let (text, bcc, end) = split_text_block(frame, 1)?;
                check_end(frame, end)?;
                check_bcc(text.as_slice(), bcc)?;
                parse_reply_text(text.as_slice())
            }
            found => Err(FrameError::Expected {
                expected: "STX, ACK or NAK",
                at: 0,
                found,
            }),
        }
    }
}

/// A bounded, inline buffer for the masked text between STX and ETX.
#[derive(Clone)]
pub(crate) struct TextBuf {
    len: usize,
    bytes: [u8; MAX_TEXT],
}

impl TextBuf {
    pub(crate) const fn new() -> Self {
        Self {
            len: 0,
            bytes: [0; MAX_TEXT],
        }
    }

    /// `frame`, parity-masked; `Err(TextTooLong)` beyond [`MAX_TEXT`].
    fn masked(frame: &[u8]) -> Result<Self, FrameError> {
        let mut t = Self::new();
        for &b in frame {
            if !t.push(ascii::mask7(b)) {
                return Err(FrameError::TextTooLong { limit: MAX_TEXT });
            }
        }
        Ok(t)
    }

    /// Appends `b`; `false` when full.
    pub(crate) fn push(&mut self, b: u8) -> bool {
        if self.len == MAX_TEXT {
            return false;
        }
        self.bytes[self.len] = b;
        self.len += 1;
        true
    }

    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    pub(crate) fn as_slice(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

/// From `frame[start..]`: the masked text before ETX, the BCC byte after ETX
/// (masked) and the offset after the BCC.
fn split_text_block(frame: &[u8], start: usize) -> Result<(TextBuf, u8, usize), FrameError> {
    let mut text = TextBuf::new();
    for (i, &b) in frame.iter().enumerate().skip(start) {
        let b = ascii::mask7(b);
        if b == ETX {
            return match frame.get(i + 1) {
                Some(&bcc) => Ok((text, ascii::mask7(bcc), i + 2)),
                None => Err(FrameError::Truncated { len: frame.len() }),
            };
        }
        if !text.push(b) {
            return Err(FrameError::TextTooLong { limit: MAX_TEXT });
        }
    }
    Err(FrameError::Truncated { len: frame.len() })
}

fn check_end(frame: &[u8], end: usize) -> Result<(), FrameError> {
    if frame.len() > end {
        Err(FrameError::Trailing {
            at: end,
            extra: frame.len() - end,
        })
    } else {
        Ok(())
    }
}

/// Checks the BCC of a text block (8.G): `text` is what lies between STX and
/// ETX (both exclusive), `bcc` the received BCC, parity-masked. A 7E1 line
/// carries 7 bits, so only the low 7 bits are compared (the computed BCC of
/// 7-bit text is 7-bit anyway).
///
/// # Errors
/// [`FrameError::BadBcc`].
pub fn check_bcc(text: &[u8], bcc: u8) -> Result<(), FrameError> {
    let expected = ascii::bcc(text) ^ ETX;
    if ascii::mask7(expected) == ascii::mask7(bcc) {
        Ok(())
    } else {
        Err(FrameError::BadBcc {
            expected,
            found: bcc,
        })
    }
}

/// The telegram a SEND-shaped text (code field + value, between STX and
/// ETX) to `address` is: SEND to a station, BROADCAST to 00 / x0.
///
/// # Errors
/// [`FrameError`] for the code field or the value.
pub fn parse_send_text(address: ControllerAddress, text: &[u8]) -> Result<Telegram, FrameError> {
    let (code, value) = CodeAddress::split(text)?;
    let value = Value::parse(value)?;
    Ok(if address.is_broadcast() {
        Telegram::Broadcast(Broadcast {
            address,
            code,
            value,
        })
    } else {
        Telegram::Send(Send {
            address,
            code,
            value,
        })
    })
}

/// The RECEIVE with the code field `field` (between AD2 and ENQ).
///
/// # Errors
/// [`FrameError`] for the code field; [`FrameError::ReceiveToBroadcast`].
pub fn parse_receive(address: ControllerAddress, field: &[u8]) -> Result<Telegram, FrameError> {
    let code = CodeAddress::parse(field)?;
    if address.is_broadcast() {
        return Err(FrameError::ReceiveToBroadcast { address });
    }
    Ok(Telegram::Receive(Receive { address, code }))
}

/// The response a reply text (between STX and ETX) is: `C1 C2 ?` a
/// checksum fault, else `C1 C2 V1..Vn` a value.
///
/// # Errors
/// [`FrameError`] for the code field or the value.
pub fn parse_reply_text(text: &[u8]) -> Result<Response, FrameError> {
    let (code, rest) = CodeAddress::split(text)?;
    if rest == b"?" {
        return Ok(Response::ChecksumFault { code });
    }
    Ok(Response::Value {
        code,
        value: Value::parse(rest)?,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::lecom::code::CodeNumber;
    use crate::lecom::error::{CodeError, ValueError};
    use crate::lecom::value::{Decimal, Hex};
    use proptest::prelude::*;

    fn addr(n: u8) -> ControllerAddress {
        ControllerAddress::new(n).unwrap()
    }

    fn std_code(n: u16) -> CodeAddress {
        CodeAddress::Standard(CodeNumber::new(n).unwrap())
    }

    fn vd(raw: i64) -> Value {
        Value::Decimal(Decimal::from_raw(raw).unwrap())
    }

    #[test]
    fn spec_8h_example_1_receive_c46_at_01() {
        let t = Telegram::Receive(Receive::new(addr(1), std_code(46)).unwrap());
        let bytes = t.to_bytes().unwrap();
        assert_eq!(bytes, [0x04, b'0', b'1', b'4', b'6', 0x05]);
        assert_eq!(Telegram::decode(&bytes).unwrap(), t);
    }

    #[test]
    fn spec_8h_example_1_the_three_answers() {
        // Valid request: C46 = 35.4 (Hz). BCC = '4'^'6'^'3'^'5'^'.'^'4'^ETX = 0x1D.
        let value = [0x02, b'4', b'6', b'3', b'5', b'.', b'4', 0x03, 0x1D];
        let r = Response::Value {
            code: std_code(46),
            value: vd(354_000),
        };
        assert_eq!(r.to_bytes(), value);
        assert_eq!(Response::decode(&value).unwrap(), r);
        let Response::Value {
            value: Value::Decimal(d),
            ..
        } = Response::decode(&value).unwrap()
        else {
            panic!("not a value reply");
        };
        assert_eq!(d.raw(), 354_000);

        // Checksum (parity) fault: BCC = '4'^'6'^'?'^ETX = 0x3E.
        let fault = [0x02, b'4', b'6', b'?', 0x03, 0x3E];
        let r = Response::ChecksumFault { code: std_code(46) };
        assert_eq!(r.to_bytes(), fault);
        assert_eq!(Response::decode(&fault).unwrap(), r);

        // No such code: no ETX, no BCC.
        let none = [0x02, b'4', b'6', 0x04];
        let r = Response::NoSuchCode { code: std_code(46) };
        assert_eq!(r.to_bytes(), none);
        assert_eq!(Response::decode(&none).unwrap(), r);
    }

    #[test]
    fn spec_8h_example_2_receive_c68_at_25() {
        let t = Telegram::Receive(Receive::new(addr(25), std_code(68)).unwrap());
        assert_eq!(t.to_bytes().unwrap(), [0x04, b'2', b'5', b'6', b'8', 0x05]);
        // BCC = '6'^'8'^'H'^'0'^'9'^'0'^'0'^ETX = 0x4C ('L').
        let reply = [0x02, b'6', b'8', b'H', b'0', b'9', b'0', b'0', 0x03, 0x4C];
        let r = Response::Value {
            code: std_code(68),
            value: Value::Hex(Hex::Word(0x0900)),
        };
        assert_eq!(r.to_bytes(), reply);
        assert_eq!(Response::decode(&reply).unwrap(), r);
    }

    #[test]
    fn spec_8i_example_send_c11_95_2_at_34() {
        let t = Telegram::Send(Send::new(addr(34), std_code(11), vd(952_000)).unwrap());
        // BCC = '1'^'1'^'9'^'5'^'.'^'2'^ETX = 0x13.
        let bytes = [
            0x04, b'3', b'4', 0x02, b'1', b'1', b'9', b'5', b'.', b'2', 0x03, 0x13,
        ];
        assert_eq!(t.to_bytes().unwrap(), bytes);
        assert_eq!(Telegram::decode(&bytes).unwrap(), t);
        assert_eq!(Response::decode(&[0x06]).unwrap(), Response::Ack);
        assert_eq!(Response::decode(&[0x15]).unwrap(), Response::Nak);
        assert_eq!(Response::Ack.to_bytes(), [0x06]);
        assert_eq!(Response::Nak.to_bytes(), [0x15]);
    }

    #[test]
    fn spec_8j_example_broadcast_c40_0_at_00() {
        let t = Telegram::Broadcast(
            Broadcast::new(ControllerAddress::ALL, std_code(40), vd(0)).unwrap(),
        );
        // BCC = '4'^'0'^'0'^ETX = 0x37 ('7').
        let bytes = [0x04, b'0', b'0', 0x02, b'4', b'0', b'0', 0x03, 0x37];
        assert_eq!(t.to_bytes().unwrap(), bytes);
        assert_eq!(Telegram::decode(&bytes).unwrap(), t);
        assert!(!t.expects_response());
        // The same text to a group address x0 is a multicast.
        let group = [0x04, b'3', b'0', 0x02, b'4', b'0', b'0', 0x03, 0x37];
        assert!(
            matches!(Telegram::decode(&group).unwrap(), Telegram::Broadcast(b) if b.address.get() == 30)
        );
    }

    #[test]
    fn extended_addressing_in_telegrams() {
        let code = CodeAddress::Extended(ExtendedAddress {
            code: 1002,
            subcode: 0,
        });
        let t = Telegram::Receive(Receive::new(addr(1), code).unwrap());
        let bytes = t.to_bytes().unwrap();
        assert_eq!(bytes, b"\x0401!03EA00\x05");
        assert_eq!(Telegram::decode(&bytes).unwrap(), t);
        let r = Response::NoSuchCode { code };
        assert_eq!(r.to_bytes(), b"\x02!03EA00\x04");
        assert_eq!(Response::decode(&r.to_bytes()).unwrap(), r);
        let r = Response::Value {
            code,
            value: vd(10_000),
        };
        let bytes = r.to_bytes();
        assert_eq!(&bytes[..10], b"\x02!03EA001\x03");
        assert_eq!(bytes[10], ascii::bcc(b"!03EA001\x03"));
        assert_eq!(Response::decode(&bytes).unwrap(), r);
    }

    #[test]
    fn parity_bit_is_masked() {
        let bytes: Vec<u8> = [
            0x04, b'3', b'4', 0x02, b'1', b'1', b'9', b'5', b'.', b'2', 0x03, 0x13,
        ]
        .iter()
        .map(|b| b | 0x80)
        .collect();
        assert!(Telegram::decode(&bytes).is_ok());
    }

    #[test]
    fn encode_refuses_wrong_address_kinds() {
        let t = Telegram::Send(Send {
            address: addr(20),
            code: std_code(11),
            value: vd(0),
        });
        assert_eq!(
            t.to_bytes(),
            Err(EncodeError::SendToBroadcast { address: addr(20) })
        );
        let t = Telegram::Broadcast(Broadcast {
            address: addr(21),
            code: std_code(11),
            value: vd(0),
        });
        assert_eq!(
            t.to_bytes(),
            Err(EncodeError::BroadcastToStation { address: addr(21) })
        );
        let t = Telegram::Receive(Receive {
            address: addr(0),
            code: std_code(11),
        });
        assert_eq!(
            t.to_bytes(),
            Err(EncodeError::ReceiveFromBroadcast { address: addr(0) })
        );
        assert!(Send::new(addr(10), std_code(1), vd(0)).is_err());
        assert!(Broadcast::new(addr(11), std_code(1), vd(0)).is_err());
        assert!(Receive::new(addr(90), std_code(1)).is_err());
    }

    #[test]
    fn decode_errors_name_the_bytes() {
        let mut bad = vec![
            0x04, b'3', b'4', 0x02, b'1', b'1', b'9', b'5', b'.', b'2', 0x03, 0x14,
        ];
        assert_eq!(
            Telegram::decode(&bad),
            Err(FrameError::BadBcc {
                expected: 0x13,
                found: 0x14
            })
        );
        bad[11] = 0x13;
        bad.push(0);
        assert_eq!(
            Telegram::decode(&bad),
            Err(FrameError::Trailing { at: 12, extra: 1 })
        );
        assert_eq!(
            Telegram::decode(b"X01"),
            Err(FrameError::Expected {
                expected: "EOT",
                at: 0,
                found: b'X'
            })
        );
        assert_eq!(
            Telegram::decode(b"\x04A1"),
            Err(FrameError::BadAddress {
                ad1: b'A',
                ad2: b'1'
            })
        );
        assert_eq!(
            Telegram::decode(b"\x040146"),
            Err(FrameError::Truncated { len: 5 })
        );
        assert_eq!(
            Telegram::decode(b"\x0401123\x05"),
            Err(FrameError::CodeLength { len: 3 })
        );
        assert_eq!(
            Telegram::decode(b"\x041046\x05"),
            Err(FrameError::ReceiveToBroadcast { address: addr(10) })
        );
        assert_eq!(
            Telegram::decode(b"\x0401\x7F0\x05"),
            Err(FrameError::Code(CodeError::NotFromFormula {
                c1: 0x7F,
                c2: b'0'
            }))
        );
        let text = b"46X";
        let mut frame = vec![0x02];
        frame.extend_from_slice(text);
        frame.push(0x03);
        frame.push(ascii::bcc(b"46X\x03"));
        assert_eq!(
            Response::decode(&frame),
            Err(FrameError::Value(ValueError::UnknownFormat { byte: b'X' }))
        );
        assert_eq!(Response::decode(b""), Err(FrameError::Truncated { len: 0 }));
        assert_eq!(
            Response::decode(b"\x06\x06"),
            Err(FrameError::Trailing { at: 1, extra: 1 })
        );
        assert_eq!(
            Response::decode(b"A"),
            Err(FrameError::Expected {
                expected: "STX, ACK or NAK",
                at: 0,
                found: b'A'
            })
        );
    }

    #[test]
    fn bcc_may_be_any_byte_even_eot() {
        // C11 = 16: BCC = '1'^'1'^'1'^'6'^ETX = 0x04 = EOT.
        let r = Response::Value {
            code: std_code(11),
            value: vd(160_000),
        };
        assert_eq!(r.to_bytes(), [0x02, b'1', b'1', b'1', b'6', 0x03, 0x04]);
        assert_eq!(Response::decode(&r.to_bytes()).unwrap(), r);
    }

    pub(crate) fn any_code() -> impl Strategy<Value = CodeAddress> {
        prop_oneof![
            (0u16..=6229).prop_map(|c| CodeAddress::Standard(CodeNumber::new(c).unwrap())),
            (any::<u16>(), any::<u8>()).prop_map(|(code, subcode)| CodeAddress::Extended(
                ExtendedAddress { code, subcode }
            )),
        ]
    }

    pub(crate) fn any_station() -> impl Strategy<Value = ControllerAddress> {
        (0u8..=99).prop_filter_map("station", |n| {
            ControllerAddress::new(n).filter(|a| !a.is_broadcast())
        })
    }

    pub(crate) fn any_group() -> impl Strategy<Value = ControllerAddress> {
        (0u8..=9).prop_map(|n| ControllerAddress::new(n * 10).unwrap())
    }

    pub(crate) fn any_telegram() -> impl Strategy<Value = Telegram> {
        use crate::lecom::value::tests::any_value;
        prop_oneof![
            (any_station(), any_code())
                .prop_map(|(address, code)| Telegram::Receive(Receive { address, code })),
            (any_station(), any_code(), any_value()).prop_map(|(address, code, value)| {
                Telegram::Send(Send {
                    address,
                    code,
                    value,
                })
            }),
            (any_group(), any_code(), any_value()).prop_map(|(address, code, value)| {
                Telegram::Broadcast(Broadcast {
                    address,
                    code,
                    value,
                })
            }),
        ]
    }

    pub(crate) fn any_response() -> impl Strategy<Value = Response> {
        use crate::lecom::value::tests::any_value;
        prop_oneof![
            (any_code(), any_value()).prop_map(|(code, value)| Response::Value { code, value }),
            any_code().prop_map(|code| Response::ChecksumFault { code }),
            any_code().prop_map(|code| Response::NoSuchCode { code }),
            Just(Response::Ack),
            Just(Response::Nak),
        ]
    }

    proptest! {
        #[test]
        fn telegrams_round_trip(t in any_telegram()) {
            let bytes = t.to_bytes().unwrap();
            prop_assert!(bytes.len() <= 3 + 1 + MAX_TEXT + 2);
            prop_assert_eq!(Telegram::decode(&bytes).unwrap(), t);
        }

        #[test]
        fn responses_round_trip(r in any_response()) {
            prop_assert_eq!(Response::decode(&r.to_bytes()).unwrap(), r);
        }

        #[test]
        fn frame_decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            let _ = Telegram::decode(&bytes);
            let _ = Response::decode(&bytes);
        }
    }
}
