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
