//! Property tests of the CAN side: SDO frames, FIX32, slcan round trips,
//! decoders that never panic, and segmented transfers end to end.

use std::collections::BTreeMap;

use driveset_proto::can::slcan::{CommandDecoder, MAX_LINE, ResponseDecoder};
use driveset_proto::can::*;
use proptest::prelude::*;

fn index() -> impl Strategy<Value = Index> {
    any::<u16>().prop_map(Index)
}

fn subindex() -> impl Strategy<Value = Subindex> {
    any::<u8>().prop_map(Subindex)
}

fn expedited() -> impl Strategy<Value = ExpeditedData> {
    prop::collection::vec(any::<u8>(), 1..=4).prop_map(|v| ExpeditedData::new(&v).unwrap())
}

fn segment() -> impl Strategy<Value = SegmentData> {
    prop::collection::vec(any::<u8>(), 0..=7).prop_map(|v| SegmentData::new(&v).unwrap())
}

fn abort() -> impl Strategy<Value = SdoAbort> {
    (index(), subindex(), any::<u32>()).prop_map(|(i, s, c)| SdoAbort::new(i, s, AbortCode(c)))
}

fn request() -> impl Strategy<Value = SdoRequest> {
    prop_oneof![
        (index(), subindex(), expedited()).prop_map(|(index, subindex, data)| SdoRequest::Write {
            index,
            subindex,
            data
        }),
        (index(), subindex(), any::<Option<u32>>()).prop_map(|(index, subindex, size)| {
            SdoRequest::InitiateWrite {
                index,
                subindex,
                size,
            }
        }),
        (any::<bool>(), segment(), any::<bool>())
            .prop_map(|(toggle, data, last)| SdoRequest::WriteSegment { toggle, data, last }),
        (index(), subindex()).prop_map(|(index, subindex)| SdoRequest::Read { index, subindex }),
        any::<bool>().prop_map(|toggle| SdoRequest::ReadSegment { toggle }),
        abort().prop_map(SdoRequest::Abort),
    ]
}

fn response() -> impl Strategy<Value = SdoResponse> {
    prop_oneof![
        (index(), subindex())
            .prop_map(|(index, subindex)| SdoResponse::WriteAck { index, subindex }),
        any::<bool>().prop_map(|toggle| SdoResponse::WriteSegmentAck { toggle }),
        (index(), subindex(), expedited()).prop_map(|(index, subindex, data)| {
            SdoResponse::ReadValue {
                index,
                subindex,
                data,
            }
        }),
        (index(), subindex(), any::<Option<u32>>()).prop_map(|(index, subindex, size)| {
            SdoResponse::InitiateRead {
                index,
                subindex,
                size,
            }
        }),
        (any::<bool>(), segment(), any::<bool>())
            .prop_map(|(toggle, data, last)| SdoResponse::ReadSegment { toggle, data, last }),
        abort().prop_map(SdoResponse::Abort),
    ]
}

fn can_frame() -> impl Strategy<Value = CanFrame> {
    prop_oneof![
        (0u32..=0x7FF, prop::collection::vec(any::<u8>(), 0..=8))
            .prop_map(|(id, d)| CanFrame::new(id, &d).unwrap()),
        (
            0u32..=0x1FFF_FFFF,
            prop::collection::vec(any::<u8>(), 0..=8)
        )
            .prop_map(|(id, d)| CanFrame::new_extended(id, &d).unwrap()),
        (0u32..=0x7FF, 0u8..=8).prop_map(|(id, l)| CanFrame::new_remote(id, l).unwrap()),
        (0u32..=0x1FFF_FFFF, 0u8..=8)
            .prop_map(|(id, l)| CanFrame::new_remote_extended(id, l).unwrap()),
    ]
}

#[derive(Default)]
struct Od(BTreeMap<(u16, u8), Vec<u8>>);

impl ObjectDictionary for Od {
    fn read(&mut self, index: Index, subindex: Subindex) -> Result<Vec<u8>, AbortCode> {
        self.0
            .get(&(index.0, subindex.0))
            .cloned()
            .ok_or(AbortCode::NO_SUCH_OBJECT)
    }
    fn write(&mut self, index: Index, subindex: Subindex, data: &[u8]) -> Result<(), AbortCode> {
        self.0.insert((index.0, subindex.0), data.to_vec());
        Ok(())
    }
}

/// Client against server over CAN frames and slcan lines, both directions
/// through the streaming decoders, until the client finishes.
fn exchange(
    client: &mut SdoClient,
    server: &mut SdoServer,
    od: &mut Od,
    first: SdoRequest,
) -> ClientEvent {
    let node = NodeId::new(1).unwrap();
    let mut adapter = CommandDecoder::new();
    let mut host = ResponseDecoder::new();
    let mut q = first;
    loop {
        let line = SlcanCommand::Transmit(q.to_can(node)).to_bytes().unwrap();
        let [Ok(SlcanCommand::Transmit(f))] = adapter.feed(&line)[..] else {
            panic!("adapter did not decode {line:?}");
        };
        let req = SdoRequest::from_can(&f, node).unwrap();
        let resp = server.on_request(req, od).expect("server answers");
        let line = SlcanResponse::Received {
            frame: resp.to_can(node),
            timestamp: None,
        }
        .to_bytes()
        .unwrap();
        let [Ok(SlcanResponse::Received { frame, .. })] = host.feed(&line)[..] else {
            panic!("host did not decode {line:?}");
        };
        match client.on_response(SdoResponse::from_can(&frame, node).unwrap()) {
            ClientEvent::Send(next) => q = next,
            other => return other,
        }
    }
}

proptest! {
    #[test]
    fn sdo_request_round_trip(q in request()) {
        prop_assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
    }

    #[test]
    fn sdo_response_round_trip(r in response()) {
        prop_assert_eq!(SdoResponse::decode(&r.encode()), Ok(r));
    }

    #[test]
    fn sdo_decode_arbitrary_bytes(b in prop::collection::vec(any::<u8>(), 0..12)) {
        if let Ok(q) = SdoRequest::decode(&b) {
            prop_assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
        }
        if let Ok(r) = SdoResponse::decode(&b) {
            prop_assert_eq!(SdoResponse::decode(&r.encode()), Ok(r));
        }
    }

    #[test]
    fn fix32_text_round_trip(raw in any::<i32>()) {
        let f = Fix32(raw);
        prop_assert_eq!(Fix32::from_decimal_str(&f.to_string()), Ok(f));
        prop_assert_eq!(Fix32::from_le_bytes(f.to_le_bytes()), f);
    }

    #[test]
    fn fix32_parse_matches_integer_math(
        int in -214_747i64..=214_747,
        frac in 0u32..10_000,
        digits in 0usize..=4,
        frac5 in 0u32..100_000,
    ) {
        // `frac` cut to `digits` decimals, written with exactly that many
        let scale = 10u32.pow(4 - digits as u32);
        let frac = frac / scale;
        let text = if digits == 0 { format!("{int}") } else { format!("{int}.{frac:0digits$}") };
        let mag = int.abs() * 10_000 + i64::from(frac * scale);
        let expected = if int < 0 { -mag } else { mag };
        prop_assert_eq!(Fix32::from_decimal_str(&text), Ok(Fix32(expected as i32)));
        let five = format!("{int}.{frac5:05}");
        prop_assert_eq!(Fix32::from_decimal_str(&five), Err(Fix32Error::TooManyDecimals));
    }

    #[test]
    fn code_index_round_trip(code in 0u32..=24575) {
        let c = CodeNumber::new(code).unwrap();
        prop_assert_eq!(u32::from(c.index().0), 24575 - code);
        prop_assert_eq!(CodeNumber::from_index(c.index()), Ok(c));
    }

    #[test]
    fn slcan_command_round_trip(f in can_frame()) {
        let c = SlcanCommand::Transmit(f);
        let bytes = c.to_bytes().unwrap();
        prop_assert!(bytes.len() <= MAX_LINE + 1);
        prop_assert_eq!(CommandDecoder::new().feed(&bytes), vec![Ok(c)]);
    }

    #[test]
    fn slcan_response_round_trip(f in can_frame(), ts in any::<Option<u16>>()) {
        let r = SlcanResponse::Received { frame: f, timestamp: ts };
        let bytes = r.to_bytes().unwrap();
        prop_assert!(bytes.len() <= MAX_LINE + 1);
        prop_assert_eq!(ResponseDecoder::new().feed(&bytes), vec![Ok(r)]);
    }

    #[test]
    fn slcan_decoders_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let mut host = ResponseDecoder::new();
        let mut adapter = CommandDecoder::new();
        for &b in &bytes {
            let _ = host.push(b);
            let _ = adapter.push(b);
            prop_assert!(host.pending() <= MAX_LINE && adapter.pending() <= MAX_LINE);
        }
        // after any garbage, a CR resynchronises and a valid line decodes
        let last = host.feed(b"\rt1232ABCD\r").pop();
        prop_assert_eq!(
            last,
            Some(Ok(SlcanResponse::Received {
                frame: CanFrame::new(0x123, &[0xAB, 0xCD]).unwrap(),
                timestamp: None
            }))
        );
    }

    #[test]
    fn segmented_transfer_end_to_end(value in prop::collection::vec(any::<u8>(), 0..300), sub in subindex()) {
        let (mut c, mut s, mut od) = (SdoClient::new(), SdoServer::new(), Od::default());
        let ix = Index(0x2000);
        let q = c.start_write(ix, sub, &value).unwrap();
        prop_assert_eq!(
            exchange(&mut c, &mut s, &mut od, q),
            ClientEvent::Done(Completed::Written { index: ix, subindex: sub })
        );
        let q = c.start_read(ix, sub).unwrap();
        prop_assert_eq!(
            exchange(&mut c, &mut s, &mut od, q),
            ClientEvent::Done(Completed::Read { index: ix, subindex: sub, data: value })
        );
        prop_assert!(c.is_idle() && s.is_idle());
    }
}

#[test]
fn lenze_write_read_over_slcan() {
    // C0011 = 50.0 written and read back through client, slcan and server.
    let (mut c, mut s, mut od) = (SdoClient::new(), SdoServer::new(), Od::default());
    let code = CodeNumber::new(11).unwrap();
    let v: Fix32 = "50.0".parse().unwrap();
    let q = c
        .start_write(code.index(), Subindex(0), &v.to_le_bytes())
        .unwrap();
    assert_eq!(q.encode(), [0x23, 0xF4, 0x5F, 0x00, 0x20, 0xA1, 0x07, 0x00]);
    assert_eq!(
        SlcanCommand::Transmit(q.to_can(NodeId::new(1).unwrap()))
            .to_bytes()
            .unwrap(),
        b"t601823F45F0020A10700\r"
    );
    assert!(matches!(
        exchange(&mut c, &mut s, &mut od, q),
        ClientEvent::Done(_)
    ));
    let q = c.start_read(code.index(), Subindex(0)).unwrap();
    match exchange(&mut c, &mut s, &mut od, q) {
        ClientEvent::Done(Completed::Read { data, .. }) => {
            assert_eq!(data, [0x20, 0xA1, 0x07, 0x00]);
            let raw: [u8; 4] = data.try_into().unwrap();
            assert_eq!(Fix32::from_le_bytes(raw).to_string(), "50");
        }
        other => panic!("{other:?}"),
    }
}

/// One line of a fuzz-like stream: a valid SDO frame line in either
/// direction, or garbage.
fn stream_piece() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        request().prop_map(|q| {
            SlcanCommand::Transmit(q.to_can(NodeId::new(1).unwrap()))
                .to_bytes()
                .unwrap()
        }),
        (response(), any::<Option<u16>>()).prop_map(|(r, timestamp)| {
            SlcanResponse::Received {
                frame: r.to_can(NodeId::new(1).unwrap()),
                timestamp,
            }
            .to_bytes()
            .unwrap()
        }),
        prop::collection::vec(any::<u8>(), 0..40),
    ]
}

proptest! {
    #[test]
    fn fuzz_body_on_structured_streams(pieces in prop::collection::vec(stream_piece(), 0..40)) {
        driveset_proto::can::fuzzing::slcan_sdo_stream(&pieces.concat());
    }

    #[test]
    fn fuzz_body_on_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        driveset_proto::can::fuzzing::slcan_sdo_stream(&bytes);
    }
}
