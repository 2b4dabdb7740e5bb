use super::*;

fn vf_example() -> VfDescription {
    VfDescription {
        name: ShortText::new("FSSIO").unwrap(),
        unit: ShortText::new("Hz").unwrap(),
        kind: VfKind::from_code(b'3').unwrap(),
        ty: ParameterType::Fixpoint16,
        min: 0,
        max: 8000,
        default: 0,
    }
}

#[test]
fn vf_layout_exact() {
    let d = vf_example();
    let v = d.encode().unwrap();
    assert_eq!(v.as_bytes(), b" FSSIO    Hz3200001F400000");
    assert_eq!(v.len(), 26);
    assert_eq!(VfDescription::decode(v.as_bytes()), Ok(d));
    assert_eq!(d.kind.storage, VfStorage::FselIsel);
    assert!(!d.kind.inverter_specific);
}

#[test]
fn vf_errors() {
    assert!(matches!(
        VfDescription::decode(b"short"),
        Err(DescriptionError::Length { found: 5, .. })
    ));
    assert_eq!(
        VfDescription::decode(b" FSSIO    Hz8200001F400000"),
        Err(DescriptionError::Kind {
            offset: 12,
            found: b'8',
            expected: "'0'..='7'"
        })
    );
    assert_eq!(
        VfDescription::decode(b" FSSIO    Hz3700001F400000"),
        Err(DescriptionError::Type {
            offset: 13,
            found: b'7',
            family: Dialect::Vf1000
        })
    );
    assert_eq!(
        VfDescription::decode(b" FSSIO    Hz32000g1F400000"),
        Err(DescriptionError::Field {
            field: "minimum",
            offset: 14,
            error: ValueError::NotHex {
                offset: 17,
                found: b'g'
            }
        })
    );
}

#[test]
fn vf_kinds() {
    for c in b'0'..=b'7' {
        assert_eq!(VfKind::from_code(c).unwrap().code(), c);
    }
    assert!(VfKind::from_code(b'6').unwrap().inverter_specific);
    assert_eq!(VfKind::from_code(b'6').unwrap().storage, VfStorage::Eeprom);
}

fn mc_example() -> McDescription {
    McDescription {
        name: ShortText::new("RSIO").unwrap(),
        unit: 3,
        kind: McKind::RamControl,
        ty: ParameterType::Int32Q16,
        min: 0xE000_0000,
        max: 0x2000_0000,
        default: 0,
        extended: McExtended::Decoded(McExtension {
            level: UserLevel { read: 1, write: 2 },
            attributes: Attributes::SHOW_TEXT | Attributes::PASSWORD,
            hardware: HardwareFilter::MPTC | HardwareFilter::BRAKE,
            structure: StructureFilter::SPEED_CTRL,
            subject: 15,
            activity: 6,
        }),
    }
}

#[test]
fn mc_layout_exact() {
    let d = mc_example();
    let v = d.encode().unwrap();
    assert_eq!(
        v.as_bytes(),
        concat!(
            "RSIO\0\0", "03", "1", "8", "E0000000", "20000000", "00000000", "21", "0220", "C000",
            "0002", "0F", "06"
        )
        .as_bytes()
    );
    assert_eq!(v.len(), 52);
    assert_eq!(McDescription::decode(v.as_bytes()), Ok(d));
    let McExtended::Decoded(e) = d.extended else {
        panic!()
    };
    assert_eq!(e.subject_area().unwrap().abbreviation(), "REF");
    assert_eq!(e.activity_area().unwrap().name(), "SC_REF");
    assert_eq!(e.hardware.labels().collect::<Vec<_>>(), ["MPTC", "Brake"]);
    // Basic part only.
    let basic = McDescription::decode(&v.as_bytes()[..34]).unwrap();
    assert_eq!(basic.extended, McExtended::Absent);
    assert_eq!(basic.encode().unwrap().as_bytes(), &v.as_bytes()[..34]);
    assert_eq!(
        d.min_value(),
        Some(ParameterValue::Int32Q16(super::super::value::Int32Q16(
            -0x2000_0000
        )))
    );
}

#[test]
fn mc_literal_layout_tolerated() {
    let mut v = b"SPEED\0".to_vec();
    v.push(b'#'); // unit as one raw character
    v.extend(b"17"); // kind, type INTEGER16
    v.extend(b"FFFF800000007FFF00000000");
    v.extend(b"ABCDEFGHI\0"); // 10 uninterpreted characters
    assert_eq!(v.len(), 43);
    let d = McDescription::decode(&v).unwrap();
    assert_eq!(d.name.as_str(), "SPEED");
    assert_eq!(d.unit, b'#');
    assert_eq!(d.ty, ParameterType::Integer16);
    assert_eq!(d.min_value(), Some(ParameterValue::Integer16(-32768)));
    assert!(matches!(d.extended, McExtended::Literal { len: 10, .. }));
}

#[test]
fn mc_errors() {
    let mut v = mc_example().encode().unwrap().as_bytes().to_vec();
    v[8] = b'3';
    assert_eq!(
        McDescription::decode(&v),
        Err(DescriptionError::Kind {
            offset: 8,
            found: b'3',
            expected: "'0', '1', '2'"
        })
    );
    v[8] = b'1';
    v[9] = b'1'; // PT_BINARY8 is VF1000 only
    assert!(matches!(
        McDescription::decode(&v),
        Err(DescriptionError::Type { offset: 9, .. })
    ));
    v[0] = 0x03;
    assert!(matches!(
        McDescription::decode(&v),
        Err(DescriptionError::Text { offset: 0, .. })
    ));
    let mut long = mc_example();
    long.name = ShortText::new("SPEEDX").unwrap();
    assert!(matches!(
        long.encode(),
        Err(DescriptionError::TooLong { max: 5, .. })
    ));
    assert!(McDescription::decode(&[b'0'; 40]).is_err());
}

#[test]
fn layouts_round_trip_and_are_told_apart() {
    let d = mc_example();
    let mut d = d;
    // Printable layouts need bytes <= 78: ShowText (0x20) and Password
    // (0x0200) fit, MPTC/Brake (0xC000) do not.
    if let McExtended::Decoded(e) = &mut d.extended {
        e.hardware = HardwareFilter(0);
    }
    for layout in McLayout::ALL {
        for types in [McTypeChars::Driveset, McTypeChars::Table] {
            let v = d.encode_as(layout, &types).unwrap();
            assert_eq!(v.len(), layout.value_len());
            assert_eq!(McLayout::candidates(v.as_bytes()), vec![layout]);
            let r = McRawDescription::decode(v.as_bytes(), layout).unwrap();
            assert_eq!(types.type_of(r.type_char), Some(ParameterType::Int32Q16));
            assert_eq!((r.min, r.max, r.default), (0xE000_0000, 0x2000_0000, 0));
            assert_eq!(r.unit, 3);
            assert_eq!(r.kind, McKind::RamControl);
            match layout {
                McLayout::Basic34 => assert_eq!(r.extension, None),
                _ => {
                    let e = r.extension.unwrap();
                    assert_eq!(e.attributes, Attributes::SHOW_TEXT | Attributes::PASSWORD);
                    assert_eq!((e.subject, e.activity), (15, 6));
                    assert_eq!((e.level.read, e.level.write), (1, 2));
                }
            }
        }
    }
    assert_eq!(
        d.encode_as(McLayout::Table43, &McTypeChars::Table)
            .unwrap()
            .as_bytes(),
        b"RSIO\0\x00315E00000002000000000000000Q2P0002?6\0"
    );
    // Table order: '1' PT_USIGN8 .. '8' PT_PASSWORD; driveset: '8' INT32Q16.
    assert_eq!(
        McTypeChars::Table.type_of(b'8'),
        Some(ParameterType::Password)
    );
    assert_eq!(
        McTypeChars::Driveset.type_of(b'8'),
        Some(ParameterType::Int32Q16)
    );
    assert_eq!(McTypeChars::Driveset.type_of(b'1'), None);
    assert_eq!(
        McTypeChars::parse("1=usign8, Z=PT_INTEGER16").unwrap(),
        McTypeChars::Map(vec![
            (b'1', ParameterType::Usign8),
            (b'Z', ParameterType::Integer16)
        ])
    );
    assert!(
        McTypeChars::parse("1=PT_BINARY8")
            .unwrap_err()
            .contains("not an MC6000/7000 type")
    );
    assert!(McTypeChars::parse("12=PT_USIGN8").is_err());
    assert!(McLayout::candidates(b"short").is_empty());
}

#[test]
fn substitution_texts() {
    let (sel, enq) = substitution_text_request(Address::ALL, 300, 2).unwrap();
    assert_eq!(sel.encode().as_bytes(), b"\x04@\x0220108=2\x03\x37");
    assert_eq!(enq.encode().as_bytes(), b"\x04@61300\x05");
    assert_eq!(decode_substitution_text(b"SCON\0\0"), Ok("SCON"));
    assert_eq!(decode_substitution_text(b"1/min  "), Ok("1/min"));
    assert!(decode_substitution_text(b"A\x01B").is_err());
}

#[test]
fn user_level_nibbles() {
    let l = UserLevel::from_byte(0x21);
    assert_eq!((l.read, l.write), (1, 2));
    assert_eq!(l.to_byte(), 0x21);
}
