//! Property tests for the LUSTBUS codec: encode -> decode round trips for
//! every telegram kind, every PT_* type, descriptions and PosMOD1 data; the
//! streaming decoders never panic, account for every byte, and find a valid
//! telegram embedded in garbage.

use driveset_proto::ascii::EOT;
use driveset_proto::lustbus::description::{
    ActivityArea, Attributes, HardwareFilter, McExtended, McExtension, McKind, ShortText,
    StructureFilter, UserLevel, VfKind,
};
use driveset_proto::lustbus::frame::{MAX_VALUE_LEN, is_value_byte};
use driveset_proto::lustbus::fuzzing::lustbus_stream;
use driveset_proto::lustbus::posmod::{PosModData, PosModStatus};
use driveset_proto::lustbus::value::{Fixpoint16, FloatIeee, Int32Q16, McError, VfError};
use driveset_proto::lustbus::{
    Address, Dialect, Enquiry, McDescription, ParameterCode, ParameterType, ParameterValue, Reply,
    Request, Select, Sniffer, Telegram, ValueReply, ValueText, VfDescription, decode_reply,
    decode_request,
};
use proptest::prelude::*;

fn address() -> impl Strategy<Value = Address> {
    (0u8..=31).prop_map(|n| Address::new(n).unwrap())
}

fn code() -> impl Strategy<Value = ParameterCode> {
    (0u32..=99_999).prop_map(|n| ParameterCode::new(n).unwrap())
}

fn value_text() -> impl Strategy<Value = ValueText> {
    proptest::collection::vec(
        (0u8..=0x7F).prop_filter("value byte", |b| is_value_byte(*b)),
        1..=MAX_VALUE_LEN,
    )
    .prop_map(|v| ValueText::new(&v).unwrap())
}

fn request() -> impl Strategy<Value = Request> {
    prop_oneof![
        Just(Request::Eot),
        (address(), code()).prop_map(|(a, c)| Request::Enquiry(Enquiry::new(a, c))),
        (address(), code(), value_text())
            .prop_map(|(a, c, v)| Request::Select(Select::new(a, c, v))),
    ]
}

fn reply() -> impl Strategy<Value = Reply> {
    prop_oneof![
        address().prop_map(Reply::Ack),
        address().prop_map(Reply::Nak),
        (address(), code(), value_text()).prop_map(|(address, code, value)| Reply::Value(
            ValueReply {
                address,
                code,
                value
            }
        )),
    ]
}

fn parameter_value() -> impl Strategy<Value = ParameterValue> {
    prop_oneof![
        any::<u8>().prop_map(ParameterValue::Binary8),
        any::<u16>().prop_map(|v| ParameterValue::Fixpoint16(Fixpoint16(v))),
        any::<u16>().prop_map(ParameterValue::Usign16),
        any::<u8>().prop_map(ParameterValue::Usign8),
        any::<u16>().prop_map(|v| ParameterValue::VfError(VfError::from_raw(v))),
        any::<u16>().prop_map(ParameterValue::Password),
        any::<i16>().prop_map(ParameterValue::Integer16),
        any::<i32>().prop_map(|v| ParameterValue::Int32Q16(Int32Q16(v))),
        any::<u32>().prop_map(|v| ParameterValue::FloatIeee(FloatIeee(v))),
        any::<u32>().prop_map(|v| ParameterValue::McError(McError::from_raw(v))),
    ]
}

fn short_text(max: usize, upper: bool) -> impl Strategy<Value = ShortText> {
    let re = if upper {
        format!("[A-Z0-9_-]{{0,{max}}}")
    } else {
        format!("[!-~]([ -~]{{0,{}}}[!-~])?", max.saturating_sub(2))
    };
    proptest::string::string_regex(&re)
        .unwrap()
        .prop_filter_map("fits", move |s| {
            ShortText::new(&s).filter(|t| t.as_str().len() <= max)
        })
}

fn garbage() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(any::<u8>(), 0..64)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn request_round_trip(r in request()) {
        let bytes = r.encode();
        prop_assert_eq!(decode_request(&bytes), Ok(r));
        // With the parity bit set on every byte, too.
        let high: Vec<u8> = bytes.iter().map(|b| b | 0x80).collect();
        prop_assert_eq!(decode_request(&high), Ok(r));
    }

    #[test]
    fn reply_round_trip(r in reply()) {
        let bytes = r.encode();
        prop_assert_eq!(decode_reply(&bytes), Ok(r));
    }

    #[test]
    fn value_round_trip(v in parameter_value()) {
        for family in [Dialect::Vf1000, Dialect::Mc] {
            if !v.ty().in_family(family) {
                prop_assert!(v.encode(family).is_err());
                continue;
            }
            let text = v.encode(family).unwrap();
            match family {
                Dialect::Vf1000 => prop_assert_eq!(text.len(), 4),
                Dialect::Mc => {
                    prop_assert!((1..=8).contains(&text.len()));
                    prop_assert!(text.len() == 1 || text.as_bytes()[0] != b'0');
                    // Leading zeros are accepted on decode.
                    let mut padded = vec![b'0'; 8 - text.len()];
                    padded.extend_from_slice(text.as_bytes());
                    prop_assert_eq!(ParameterValue::decode(v.ty(), family, &padded), Ok(v));
                }
            }
            prop_assert!(text.as_bytes().iter().all(|b| b.is_ascii_digit() || b.is_ascii_uppercase()));
            prop_assert_eq!(ParameterValue::decode(v.ty(), family, text.as_bytes()), Ok(v));
        }
    }

    #[test]
    fn value_decode_never_panics(ty in 0usize..10, text in proptest::collection::vec(any::<u8>(), 0..12)) {
        for family in [Dialect::Vf1000, Dialect::Mc] {
            let _ = ParameterValue::decode(ParameterType::ALL[ty], family, &text);
        }
    }

    #[test]
    fn int32q16_decimal_round_trip(raw in any::<i32>()) {
        let q = Int32Q16(raw);
        prop_assert_eq!(Int32Q16::from_decimal_exact(&q.to_string()), Ok(q));
    }

    #[test]
    fn fixpoint16_decimal_round_trip(raw in any::<u16>()) {
        let f = Fixpoint16(raw);
        prop_assert_eq!(Fixpoint16::from_decimal(&f.to_string()), Ok(f));
    }

    #[test]
    fn vf_description_round_trip(
        name in short_text(6, true),
        unit in short_text(6, false),
        kind in (b'0'..=b'7'),
        ty in 0usize..6,
        min in any::<u16>(), max in any::<u16>(), default in any::<u16>(),
    ) {
        let d = VfDescription {
            name, unit,
            kind: VfKind::from_code(kind).unwrap(),
            ty: ParameterType::ALL[ty],
            min, max, default,
        };
        let v = d.encode().unwrap();
        prop_assert_eq!(v.len(), VfDescription::LEN);
        prop_assert_eq!(VfDescription::decode(v.as_bytes()), Ok(d));
    }

    #[test]
    fn mc_description_round_trip(
        name in short_text(5, true),
        unit in any::<u8>(),
        kind in (b'0'..=b'2'),
        ty in prop::sample::select(vec![
            ParameterType::Usign8, ParameterType::Usign16, ParameterType::Fixpoint16,
            ParameterType::Integer16, ParameterType::Int32Q16, ParameterType::FloatIeee,
            ParameterType::McError, ParameterType::Password,
        ]),
        min in any::<u32>(), max in any::<u32>(), default in any::<u32>(),
        level in any::<u8>(), attributes in any::<u16>(), hardware in any::<u16>(),
        structure in any::<u16>(), subject in any::<u8>(), activity in any::<u8>(),
        basic in any::<bool>(),
    ) {
        let d = McDescription {
            name, unit,
            kind: McKind::from_code(kind).unwrap(),
            ty, min, max, default,
            extended: if basic { McExtended::Absent } else {
                McExtended::Decoded(McExtension {
                    level: UserLevel::from_byte(level),
                    attributes: Attributes(attributes),
                    hardware: HardwareFilter(hardware),
                    structure: StructureFilter(structure),
                    subject, activity,
                })
            },
        };
        let v = d.encode().unwrap();
        prop_assert_eq!(v.len(), if basic { 34 } else { 52 });
        prop_assert_eq!(McDescription::decode(v.as_bytes()), Ok(d));
        if let McExtended::Decoded(e) = d.extended {
            prop_assert_eq!(e.activity_area().is_some(), ActivityArea::new(activity).is_some());
        }
    }

    #[test]
    fn description_decode_never_panics(v in proptest::collection::vec(any::<u8>(), 0..60)) {
        let _ = VfDescription::decode(&v);
        let _ = McDescription::decode(&v);
    }

    #[test]
    fn posmod_round_trip(
        request in any::<bool>(), multiblock in any::<bool>(), bit3 in any::<bool>(),
        data in proptest::collection::vec(
            (0u8..=0x7F).prop_filter("value byte", |b| is_value_byte(*b)), 0..=80),
    ) {
        let mut status = if request { PosModStatus::request() } else { PosModStatus::data() };
        if multiblock { status = status.multiblock(); }
        if bit3 { status |= PosModStatus::BIT3; }
        let d = PosModData::new(status, &data).unwrap();
        let v = d.encode();
        prop_assert_eq!(v.len(), data.len() + 1);
        let s = Select::new(Address::ALL, ParameterCode::POSMOD, v);
        let Ok(Request::Select(back)) = decode_request(&s.encode()) else {
            return Err(TestCaseError::fail("select must decode"));
        };
        prop_assert_eq!(PosModData::decode(back.value.as_bytes()), Ok(d));
    }

    /// Arbitrary bytes: no panic, spans partition the input, telegrams
    /// re-encode to their bytes, all decoders agree (see `lustbus_stream`).
    #[test]
    fn streams_never_panic(data in proptest::collection::vec(any::<u8>(), 0..400)) {
        lustbus_stream(&data);
    }

    /// Same, from bytes that look like LUSTBUS (control characters, digits,
    /// addresses) so the deeper states are reached.
    #[test]
    fn streams_never_panic_on_lustbus_alphabet(
        data in proptest::collection::vec(
            prop::sample::select(vec![2u8, 3, 4, 5, 6, 0x15, b'@', b'A', b'_', b'0', b'1', b'9', b'=', b'F', 0x84, 0x82]),
            0..300)
    ) {
        lustbus_stream(&data);
    }

    #[test]
    fn host_telegram_found_in_garbage(pre in garbage(), r in request(), post in garbage()) {
        prop_assume!(r != Request::Eot);
        let mut data = pre.clone();
        data.push(EOT); // resynchronise (may be eaten as a BCC)
        let start = data.len() as u64;
        data.extend_from_slice(&r.encode());
        let end = data.len() as u64;
        data.extend_from_slice(&post);
        let mut s = Sniffer::new();
        let mut ev: Vec<_> = s.feed(&data).collect();
        ev.extend(s.finish());
        prop_assert!(ev.iter().any(|e| e.span == (start..end) && e.result == Ok(Telegram::Request(r))),
            "not found: {:?}", ev);
        lustbus_stream(&data);
    }

    #[test]
    fn reply_found_after_enquiry_in_garbage(pre in garbage(), a in address(), c in code(), r in reply(), post in garbage()) {
        let mut data = pre.clone();
        data.push(EOT);
        data.extend_from_slice(&Enquiry::new(a, c).encode());
        let start = data.len() as u64;
        data.extend_from_slice(&r.encode());
        let end = data.len() as u64;
        data.extend_from_slice(&post);
        let mut m = driveset_proto::lustbus::ReplyDecoder::new();
        let mut ev: Vec<_> = m.feed(&data).collect();
        ev.extend(m.finish());
        prop_assert!(ev.iter().any(|e| e.span == (start..end) && e.result == Ok(r)),
            "not found: {:?}", ev);
    }
}
