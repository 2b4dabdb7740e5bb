//! Every example telegram and worked number of `lustbus-protocol.txt`, with
//! exact bytes. The BCCs the spec prints as "?" are computed once (XOR of
//! CODE..ETX) and asserted as literals here. Where an example's byte row
//! contradicts its text, the test follows the normative text and says so
//! (see docs/errata/lustbus.md).

use driveset_proto::ascii::{ACK, ENQ, EOT, ETX, NAK, STX};
use driveset_proto::lustbus::description::substitution_text_request;
use driveset_proto::lustbus::posmod::{PosModData, PosModStatus};
use driveset_proto::lustbus::value::{Fixpoint16, Int32Q16};
use driveset_proto::lustbus::{
    Address, CodeMeaning, CompatibleParameter, Dialect, Direction, Enquiry, ParameterCode,
    ParameterType, ParameterValue, Reply, Request, Select, Siof, SiofAction, Sniffer, Telegram,
    ValueReply, ValueText, decode_reply, decode_request,
};

fn code(n: u32) -> ParameterCode {
    ParameterCode::new(n).unwrap()
}

fn sel(adr: Address, c: u32, v: &[u8]) -> Select {
    Select::new(adr, code(c), ValueText::new(v).unwrap())
}

/// `EOT ADR STX text ETX bcc`
fn select_bytes(adr: u8, text: &[u8], bcc: u8) -> Vec<u8> {
    let mut v = vec![EOT, adr, STX];
    v.extend_from_slice(text);
    v.extend([ETX, bcc]);
    v
}

/// `ADR STX text ETX bcc`
fn reply_bytes(adr: u8, text: &[u8], bcc: u8) -> Vec<u8> {
    let mut v = vec![adr, STX];
    v.extend_from_slice(text);
    v.extend([ETX, bcc]);
    v
}

#[test]
fn section_2_2_control_characters() {
    assert_eq!((STX, ETX, EOT, ENQ, ACK), (2, 3, 4, 5, 6));
    // The table prints NAK as "15" in the decimal column too: 0x15 = 21.
    assert_eq!(NAK, 0x15);
    assert_eq!(NAK, 21);
    assert_eq!(b'=', 0x3D);
}

#[test]
fn section_4_2_address_space() {
    assert_eq!(Address::ALL.to_byte(), b'@');
    assert_eq!(Address::new(1).unwrap().to_byte(), b'A');
    assert_eq!(Address::new(30).unwrap().to_byte(), b'^');
    // Printed as a blank in 4.2; section 9.1 says 5Fh, which is '_'.
    assert_eq!(Address::BROADCAST.to_byte(), 0x5F);
    assert_eq!(Address::BROADCAST.to_byte(), b'_');
    assert!(!Address::BROADCAST.expects_reply());
}

#[test]
fn section_2_4_code_strings() {
    // 2.4.1 sprintf("000%02u", 1) -> "00001"; 2.4.2 sprintf("20%03u", 1) -> "20001".
    assert_eq!(&ParameterCode::vf_value(0, 1).unwrap().digits(), b"00001");
    assert_eq!(&ParameterCode::mc_value(1).unwrap().digits(), b"20001");
    // 5.2: the compatible parameters under 000xx.
    for (p, d) in [
        (CompatibleParameter::Baud, b"00081"),
        (CompatibleParameter::Address, b"00082"),
        (CompatibleParameter::Dummy, b"00083"),
        (CompatibleParameter::Watchdog, b"00084"),
        (CompatibleParameter::Siof, b"00085"),
        (CompatibleParameter::Type, b"00091"),
    ] {
        assert_eq!(&ParameterCode::compatible(p).digits(), d);
    }
}

/// 6.1.1.1: requesting the rotary-field frequency (parameter 12) via address 0.
#[test]
fn section_6_1_1_1_vf1000_enquiry() {
    let enq = Enquiry::new(Address::ALL, ParameterCode::vf_value(1, 12).unwrap());
    let bytes = enq.encode();
    assert_eq!(bytes.as_bytes(), &[4, 64, 48, 48, 49, 49, 50, 5]);
    assert_eq!(decode_request(&bytes), Ok(Request::Enquiry(enq)));

    // Reply; the spec prints ADR as 0 in the number row, it is '@' = 64.
    let reply_wire = [64, 2, 48, 48, 49, 49, 50, 61, 48, 51, 69, 56, 3, 0x72];
    let Ok(Reply::Value(r)) = decode_reply(&reply_wire) else {
        panic!("reply must decode")
    };
    assert_eq!(r.address, Address::ALL);
    assert_eq!(&r.code.digits(), b"00112");
    assert_eq!(r.value.as_bytes(), b"03E8");
    assert_eq!(
        r.typed(ParameterType::Fixpoint16, Dialect::Vf1000),
        Ok(ParameterValue::Fixpoint16(Fixpoint16(1000)))
    );
    assert_eq!(Fixpoint16(1000).to_string(), "50.00");
    assert_eq!(Reply::Value(r).encode().as_bytes(), &reply_wire);

    // The number rows spell CODE "00012" (device number 0 = basis
    // parameter, 11.1); equally valid.
    let alt = decode_request(&[4, 64, 48, 48, 48, 49, 50, 5]).unwrap();
    let Request::Enquiry(alt) = alt else { panic!() };
    assert_eq!(
        alt.code.meaning(),
        CodeMeaning::VfValue {
            device: 0,
            parameter: 12
        }
    );
    assert_eq!(
        decode_reply(&reply_bytes(b'@', b"00012=03E8", 0x73)).map(|r| r.address()),
        Ok(Address::ALL)
    );

    assert_eq!(decode_request(&[4]), Ok(Request::Eot));
}

/// 6.1.1.2: requesting the current motor speed 77-SPEED via address 0.
#[test]
fn section_6_1_1_2_mc_enquiry() {
    let enq = Enquiry::new(Address::ALL, ParameterCode::mc_value(77).unwrap());
    assert_eq!(enq.encode().as_bytes(), &[4, 64, 50, 48, 48, 55, 55, 5]);

    // The spec prints ETX as 2 and the first VALUE digit as 52 ('4'); the
    // character row ("04FA4000") and the worked number are right.
    let wire = reply_bytes(b'@', b"20077=04FA4000", 0x0B);
    assert_eq!(
        wire,
        [
            64, 2, 50, 48, 48, 55, 55, 61, 48, 52, 70, 65, 52, 48, 48, 48, 3, 0x0B
        ]
    );
    let r = decode_reply(&wire).unwrap();
    let Reply::Value(r) = r else { panic!() };
    let v = r.typed(ParameterType::Int32Q16, Dialect::Mc).unwrap();
    assert_eq!(v, ParameterValue::Int32Q16(Int32Q16(83_509_248)));
    assert_eq!(0x04FA_4000, 83_509_248);
    assert_eq!(Int32Q16(83_509_248).to_string(), "1274.25");
    // Our encoder writes no leading zero: "4FA4000" as in the worked number.
    assert_eq!(v.encode(Dialect::Mc).unwrap().as_bytes(), b"4FA4000");
}

/// 6.2.2: setting 05-FSSIO to 50.00 Hz via address 0.
#[test]
fn section_6_2_2_vf1000_select() {
    let raw = Fixpoint16::from_decimal("50.00").unwrap();
    assert_eq!(raw, Fixpoint16(1000));
    let s = Select::with_value(
        Address::ALL,
        ParameterCode::vf_value(1, 5).unwrap(),
        &ParameterValue::Fixpoint16(raw),
        Dialect::Vf1000,
    )
    .unwrap();
    let bytes = s.encode();
    assert_eq!(
        bytes.as_bytes(),
        &[4, 64, 2, 48, 48, 49, 48, 53, 61, 48, 51, 69, 56, 3, 0x74]
    );
    assert_eq!(decode_request(&bytes), Ok(Request::Select(s)));
    assert_eq!(decode_reply(&[64, 6]), Ok(Reply::Ack(Address::ALL)));
    // Number-row variant, CODE "00005" (device 0).
    assert_eq!(
        select_bytes(b'@', b"00005=03E8", 0x75),
        sel(Address::ALL, 5, b"03E8").encode().as_bytes()
    );
}

/// 6.2.3: the MC reference value of the serial interface, 333.254 1/min.
/// The text says 14D4106H; the parameter is 428-RSIO (CODE 20428); the
/// printed CODE 00005 and byte row are copied from 6.2.2.
#[test]
fn section_6_2_3_mc_select() {
    let raw = Int32Q16::from_decimal_rounded("333.254").unwrap();
    assert_eq!(raw, Int32Q16(21_840_134));
    assert_eq!(raw.0, 0x14D4106);
    let s = Select::with_value(
        Address::ALL,
        ParameterCode::mc_value(428).unwrap(),
        &ParameterValue::Int32Q16(raw),
        Dialect::Mc,
    )
    .unwrap();
    assert_eq!(
        s.encode().as_bytes(),
        select_bytes(b'@', b"20428=14D4106", 0x40)
    );
    // The literal CODE of the example is syntactically valid too (a VF1000
    // code; an MC would answer NAK).
    let lit = decode_request(&select_bytes(b'@', b"00005=14D4106", 0x49)).unwrap();
    let Request::Select(lit) = lit else { panic!() };
    assert_eq!(
        lit.code.meaning(),
        CodeMeaning::VfValue {
            device: 0,
            parameter: 5
        }
    );
}

/// 7.1.1: start with 23.15 Hz, clockwise. The normative order per 7.1
/// (3-CNTL, 4-FSSEL, 5-FSSIO); the printed table shifts codes 3..5.
#[test]
fn section_7_1_1_vf1000_control_sequence() {
    assert_eq!(Fixpoint16::from_decimal("23.15"), Ok(Fixpoint16(463)));
    let steps: [(u8, ParameterValue, &[u8], u8); 5] = [
        (1, ParameterValue::Usign8(0), b"00001=0000", 0x0F),
        (2, ParameterValue::Usign8(3), b"00002=0003", 0x0F),
        (4, ParameterValue::Usign8(8), b"00004=0008", 0x02),
        (
            5,
            ParameterValue::Fixpoint16(Fixpoint16(463)),
            b"00005=01CF",
            0x0F,
        ),
        (3, ParameterValue::Binary8(128), b"00003=0080", 0x05),
    ];
    for (p, v, text, bcc) in steps {
        let s = Select::with_value(
            Address::ALL,
            ParameterCode::vf_value(0, p).unwrap(),
            &v,
            Dialect::Vf1000,
        )
        .unwrap();
        assert_eq!(s.encode().as_bytes(), select_bytes(b'@', text, bcc));
        assert_eq!(decode_request(&s.encode()), Ok(Request::Select(s)));
    }
    // As printed (codes 3..5 shifted), for the record: BCCs 0x05, 0x0E, 0x03.
    assert_eq!(
        sel(Address::ALL, 3, b"0008").encode().as_bytes(),
        select_bytes(b'@', b"00003=0008", 0x05)
    );
    assert_eq!(
        sel(Address::ALL, 4, b"01CF").encode().as_bytes(),
        select_bytes(b'@', b"00004=01CF", 0x0E)
    );
    // Its BCC is ETX: the decoder must take the byte after ETX as BCC.
    let printed = select_bytes(b'@', b"00005=0080", 0x03);
    assert_eq!(sel(Address::ALL, 5, b"0080").encode().as_bytes(), printed);
    assert!(decode_request(&printed).is_ok());
}

/// 7.2.1: MC speed control via SIO, start with 132.15 rpm. 842666 is hex:
/// 132.15 x 65536 = 8660582.4, rounded (and truncated) 8660582 = 0x842666.
#[test]
fn section_7_2_1_mc_control_sequence() {
    let rsio = Int32Q16::from_decimal_rounded("132.15").unwrap();
    assert_eq!(rsio, Int32Q16(8_660_582));
    assert_eq!(rsio.0, 0x842666);
    let steps: [(u16, ParameterValue, &[u8], u8); 9] = [
        (300, ParameterValue::Usign8(2), b"20300=2", 0x3D),
        (416, ParameterValue::Usign16(0), b"20416=0", 0x3F),
        (402, ParameterValue::Usign8(2), b"20402=2", 0x38),
        (418, ParameterValue::Usign8(0), b"20418=0", 0x31),
        (419, ParameterValue::Usign8(0), b"20419=0", 0x30),
        (420, ParameterValue::Usign8(0), b"20420=0", 0x3A),
        (417, ParameterValue::Usign8(3), b"20417=3", 0x3D),
        (428, ParameterValue::Int32Q16(rsio), b"20428=842666", 0x0A),
        (416, ParameterValue::Usign16(1), b"20416=1", 0x3E),
    ];
    let mut capture = Vec::new();
    for (p, v, text, bcc) in steps {
        let s = Select::with_value(
            Address::ALL,
            ParameterCode::mc_value(p).unwrap(),
            &v,
            Dialect::Mc,
        )
        .unwrap();
        assert_eq!(s.encode().as_bytes(), select_bytes(b'@', text, bcc));
        capture.extend_from_slice(&s.encode());
        capture.extend_from_slice(&Reply::Ack(Address::ALL).encode());
        capture.push(EOT);
    }
    // The whole sequence through the sniffer: 9 x (SELECT, ACK, EOT).
    let mut sn = Sniffer::new();
    let mut ev: Vec<_> = sn.feed(&capture).collect();
    ev.extend(sn.finish());
    assert_eq!(ev.len(), 27);
    assert!(ev.iter().all(|e| e.result.is_ok()));
    assert_eq!(ev[1].direction, Some(Direction::Device));
    assert_eq!(ev[26].result, Ok(Telegram::Request(Request::Eot)));
    // 8.1.2: error reset by bit 7 of 416-SCTL1.
    assert_eq!(
        sel(Address::ALL, 20416, b"80").encode().as_bytes(),
        select_bytes(b'@', b"20416=80", 0x07)
    );
}

/// 9.2: SIOF/SERR read back with CODE 00085 on both families.
#[test]
fn section_9_2_siof() {
    let vf = decode_reply(&reply_bytes(b'@', b"00085=0081", 0x0A)).unwrap();
    let Reply::Value(vf) = vf else { panic!() };
    let ParameterValue::Usign8(bits) = vf.typed(ParameterType::Usign8, Dialect::Vf1000).unwrap()
    else {
        panic!()
    };
    let s = Siof(bits);
    assert!(s.contains(Siof::POWER_ON) && s.contains(Siof::INVALID_VALUE));
    assert_eq!(s.action(), SiofAction::Fail);
    let mc = decode_reply(&reply_bytes(b'@', b"00085=81", 0x0A)).unwrap();
    let Reply::Value(mc) = mc else { panic!() };
    assert_eq!(
        mc.typed(ParameterType::Usign8, Dialect::Mc),
        Ok(ParameterValue::Usign8(0x81))
    );
    for (bits, descriptor, action) in [
        (0x01, "Power on", SiofAction::RestartTransaction),
        (0x02, "Watchdog", SiofAction::Fail),
        (0x04, "EEPROM busy", SiofAction::RepeatAfter { wait_ms: 60 }),
        (0x08, "Checksum error", SiofAction::Repeat),
        (0x20, "No parameter", SiofAction::Fail),
        (0x40, "No change", SiofAction::Fail),
        (0x80, "Invalid value", SiofAction::Fail),
    ] {
        let s = Siof(bits);
        assert_eq!(s.causes().next().unwrap().descriptor, descriptor);
        assert_eq!(s.causes().count(), 1);
        assert_eq!(s.action(), action);
    }
}

/// 11.3: value substitution text via 108-STEXT and 61xxx.
#[test]
fn section_11_3_substitution_text() {
    let (s, e) = substitution_text_request(Address::ALL, 300, 2).unwrap();
    assert_eq!(s.encode().as_bytes(), select_bytes(b'@', b"20108=2", 0x37));
    assert_eq!(e.encode().as_bytes(), b"\x04@61300\x05");
}

/// 11.6.4: the PosMOD1 example telegrams (ADR '@' as in 11.6.1).
#[test]
fn section_11_6_posmod_examples() {
    let host: [(u8, &[u8], u8); 6] = [
        (0x38, b"GOA0V1000", 0x1C),
        (0x3C, b"%P10 (RPF)", 0x27),
        (0x3C, b"N10 GO 0", 0x41),
        (0x38, b"END", 0x7D),
        (0x31, b"?", 0x04), // BCC = EOT
        (0x31, b"%RDP10", 0x59),
    ];
    for (status, data, bcc) in host {
        let d = PosModData::new(PosModStatus::from_byte(status).unwrap(), data).unwrap();
        let s = Select::new(Address::ALL, ParameterCode::POSMOD, d.encode());
        let mut text = b"49999=".to_vec();
        text.push(status);
        text.extend_from_slice(data);
        assert_eq!(s.encode().as_bytes(), select_bytes(b'@', &text, bcc));
        let Ok(Request::Select(back)) = decode_request(&s.encode()) else {
            panic!()
        };
        assert_eq!(back.code.meaning(), CodeMeaning::PosMod);
        assert_eq!(PosModData::decode(back.value.as_bytes()), Ok(d));
    }
    // 38H and 3CH set the undocumented bit 3.
    assert!(PosModStatus(0x38).contains(PosModStatus::BIT3));
    assert!(!PosModStatus(0x31).contains(PosModStatus::BIT3));

    assert_eq!(
        Enquiry::new(Address::ALL, ParameterCode::POSMOD)
            .encode()
            .as_bytes(),
        b"\x04@49999\x05"
    );
    let device: [(u8, &[u8], u8); 4] = [
        (0x30, b"G10H10", 0x35),
        (0x34, b"%P10 (RPF)", 0x2F),
        (0x34, b"N10 GO 0", 0x49),
        (0x30, b"END", 0x75),
    ];
    for (status, data, bcc) in device {
        let mut text = b"49999=".to_vec();
        text.push(status);
        text.extend_from_slice(data);
        let Ok(Reply::Value(r)) = decode_reply(&reply_bytes(b'@', &text, bcc)) else {
            panic!()
        };
        let d = PosModData::decode(r.value.as_bytes()).unwrap();
        assert_eq!(d.status.bits(), status);
        assert_eq!(d.data(), data);
        assert_eq!(d.status.is_multiblock(), status == 0x34);
        let again = ValueReply {
            address: Address::ALL,
            code: ParameterCode::POSMOD,
            value: d.encode(),
        };
        assert_eq!(again.encode().as_bytes(), reply_bytes(b'@', &text, bcc));
    }
}

/// 10.1: telegram lengths of the timing examples, and their real wire time.
#[test]
fn section_10_telegram_lengths() {
    use driveset_proto::lustbus::timing::wire_time_us;
    let enq = Enquiry::new(Address::ALL, code(112)).encode();
    assert_eq!(enq.len(), 8);
    let vf_reply = decode_reply(&reply_bytes(b'@', b"00112=03E8", 0x72)).unwrap();
    assert_eq!(vf_reply.encode().len(), 14);
    assert_eq!(sel(Address::ALL, 105, b"03E8").encode().len(), 15);
    assert_eq!(sel(Address::ALL, 20428, b"14D4106F").encode().len(), 19);
    let mc_reply = ValueReply {
        address: Address::ALL,
        code: code(20077),
        value: ValueText::new(b"04FA4000").unwrap(),
    };
    assert_eq!(mc_reply.encode().len(), 18);
    assert_eq!(Reply::Ack(Address::ALL).encode().len(), 2);
    // 8 characters at 9600 Bd: the spec says 7 ms (8 bits); 10 bits: 8.33 ms.
    assert_eq!(wire_time_us(8, 9600), 8334);
}
