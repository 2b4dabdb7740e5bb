//! The simulated Lenze Tmd against `lecom-ab-tmd-manual.txt`: the manual's
//! examples byte for byte, every NAK cause, addressing, rules, power cycle.
//! Telegrams are fed byte by byte through `ByteDrive::hear`.

use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::lecom::{CommunicationError, ExtendedError};
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::drive::{ByteDrive, Heard, ReactionTime};
use driveset_sim::tmd::{CfgReaction, TmdDrive, TmdOptions};

const STX: u8 = 0x02;
const ETX: u8 = 0x03;
const EOT: u8 = 0x04;
const ENQ: u8 = 0x05;
const ACK: u8 = 0x06;
const NAK: u8 = 0x15;

/// XOR of the text after STX up to and including ETX (8.G), computed here
/// independently of the codec.
fn bcc(text: &[u8]) -> u8 {
    text.iter().fold(ETX, |a, b| a ^ b)
}

/// `EOT AD1 AD2 C1 C2 ENQ` (8.H).
fn receive(addr: &str, code: &[u8]) -> Vec<u8> {
    let mut v = vec![EOT];
    v.extend_from_slice(addr.as_bytes());
    v.extend_from_slice(code);
    v.push(ENQ);
    v
}

/// `EOT AD1 AD2 STX text ETX BCC` (8.I, 8.J).
fn send(addr: &str, text: &[u8]) -> Vec<u8> {
    let mut v = vec![EOT];
    v.extend_from_slice(addr.as_bytes());
    v.push(STX);
    v.extend_from_slice(text);
    v.push(ETX);
    v.push(bcc(text));
    v
}

/// `STX text ETX BCC`, a value reply (8.H a).
fn value_reply(text: &[u8]) -> Vec<u8> {
    let mut v = vec![STX];
    v.extend_from_slice(text);
    v.push(ETX);
    v.push(bcc(text));
    v
}

struct Line {
    now: u64,
}

impl Line {
    fn new() -> Self {
        Line { now: 0 }
    }

    /// Feeds `bytes` (parity errors at the indices in `bad`); only the last
    /// byte may complete a telegram. Returns what it completed.
    fn feed_bad(&mut self, d: &mut TmdDrive, bytes: &[u8], bad: &[usize]) -> Heard {
        let mut last = Heard::Nothing;
        for (i, &b) in bytes.iter().enumerate() {
            // 9600 bd, 10 bits a character.
            self.now += 1_041_667;
            let h = d.hear(Instant::from_nanos(self.now), b, !bad.contains(&i));
            if i + 1 < bytes.len() {
                assert_eq!(
                    h,
                    Heard::Nothing,
                    "byte {i} of {bytes:02x?} completed a frame"
                );
            }
            last = h;
        }
        self.now += 50_000_000;
        last
    }

    /// The reply to a telegram, `None` for no answer; panics if the last
    /// byte did not complete a telegram.
    fn ask_bad(&mut self, d: &mut TmdDrive, bytes: &[u8], bad: &[usize]) -> Option<Vec<u8>> {
        match self.feed_bad(d, bytes, bad) {
            Heard::Telegram { reply } => reply.map(|r| r.bytes),
            Heard::Nothing => panic!("{bytes:02x?} completed no telegram"),
        }
    }

    fn ask(&mut self, d: &mut TmdDrive, bytes: &[u8]) -> Option<Vec<u8>> {
        self.ask_bad(d, bytes, &[])
    }

    /// RECEIVE C68 at `addr`, the status word as its 4 hex digits.
    fn c68(&mut self, d: &mut TmdDrive, addr: &str) -> String {
        let r = self.ask(d, &receive(addr, b"68")).expect("C68 answered");
        assert_eq!(&r[..4], [STX, b'6', b'8', b'H']);
        String::from_utf8(r[4..8].to_vec()).unwrap()
    }
}

fn drive(address: u8) -> TmdDrive {
    TmdDrive::new(TmdOptions {
        reaction: ReactionTime::fixed(Duration::from_millis(5)),
        ..TmdOptions::at(address).c0001(3)
    })
    .unwrap()
}

fn raw(d: &TmdDrive, code: u32) -> RawValue {
    d.value(CodeKey::new(code)).cloned().unwrap()
}

fn int(d: &TmdDrive, code: u32) -> i64 {
    match raw(d, code) {
        RawValue::Int(i) => i,
        other => panic!("C{code} holds {other:?}"),
    }
}

fn assert_cause(d: &TmdDrive, nibble: u8, ext: u32) {
    assert_eq!(d.last_error().nibble(), nibble, "C0068 bits 4..7");
    assert_eq!(d.extended_error().code(), ext, "C1962");
    assert_eq!(int(d, 1962), i64::from(ext) * 10_000);
    assert_eq!(int(d, 68) >> 4 & 0xF, i64::from(nibble));
}

// ---------------------------------------------------------------------------
// The manual's examples

#[test]
fn spec_8h_b_receive_c46_at_01_is_35_4() {
    let mut d = drive(1);
    let mut l = Line::new();
    d.poke(CodeKey::new(46), RawValue::Int(354_000)).unwrap();
    let r = l.ask(&mut d, &[EOT, b'0', b'1', b'4', b'6', ENQ]);
    assert_eq!(
        r,
        Some(vec![STX, b'4', b'6', b'3', b'5', b'.', b'4', ETX, 0x1D])
    );
}

#[test]
fn spec_8h_b_parity_fault_answers_question_mark() {
    let mut d = drive(1);
    let mut l = Line::new();
    // A parity error on C1 ('4').
    let r = l.ask_bad(&mut d, &[EOT, b'0', b'1', b'4', b'6', ENQ], &[3]);
    assert_eq!(r, Some(vec![STX, b'4', b'6', b'?', ETX, 0x3E]));
    assert_eq!(d.last_error(), CommunicationError::ChecksumError);
    assert_eq!(d.extended_error(), ExtendedError::ParityError);
    // On ENQ itself: no answer (8.J b).
    let r = l.ask_bad(&mut d, &[EOT, b'0', b'1', b'4', b'6', ENQ], &[5]);
    assert_eq!(r, None);
}

#[test]
fn spec_8h_b_no_such_code_answers_stx_c1_c2_eot() {
    let mut d = drive(1);
    let mut l = Line::new();
    // C0045 is not in Table 1.
    assert_eq!(
        l.ask(&mut d, &receive("01", b"45")),
        Some(vec![STX, b'4', b'5', EOT])
    );
    assert_cause(&d, 4, 5);
    // C46 with input selection 1 (8.C): the subcode does not exist, so the
    // answer is exactly the manual's "STX 4 6 EOT".
    assert_eq!(l.ask(&mut d, &send("01", b"H81")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"46")),
        Some(vec![STX, b'4', b'6', EOT])
    );
    assert_cause(&d, 4, 4);
}

#[test]
fn spec_8h_c_c68_at_25_is_h0900() {
    let mut d = drive(25);
    let mut l = Line::new();
    // The example's state: control via LECOM (C0001 = 3), controller
    // enabled, power stage energized, no fault, no communication error.
    d.set_running(true);
    let r = l.ask(&mut d, &[EOT, b'2', b'5', b'6', b'8', ENQ]);
    assert_eq!(
        r,
        Some(vec![
            STX, b'6', b'8', b'H', b'0', b'9', b'0', b'0', ETX, 0x4C
        ])
    );
    assert_eq!(d.operating_status().0, 0x0900);
}

#[test]
fn spec_8i_send_c11_95_2_at_34() {
    let mut d = drive(34);
    let mut l = Line::new();
    let t = [
        EOT, b'3', b'4', STX, b'1', b'1', b'9', b'5', b'.', b'2', ETX, 0x13,
    ];
    assert_eq!(l.ask(&mut d, &t), Some(vec![ACK]));
    assert_eq!(int(&d, 11), 952_000);
    assert_eq!(
        l.ask(&mut d, &receive("34", b"11")),
        Some(value_reply(b"1195.2"))
    );
    assert_cause(&d, 0, 0);
}

#[test]
fn spec_8j_broadcast_c40_0_to_00() {
    let mut d = drive(1);
    let mut l = Line::new();
    d.set_running(true);
    assert_eq!(int(&d, 40), 10_000);
    let t = [EOT, b'0', b'0', STX, b'4', b'0', b'0', ETX, 0x37];
    assert_eq!(l.ask(&mut d, &t), None);
    assert_eq!(int(&d, 40), 0);
    assert!(!d.running(), "controller inhibit stops the motor");
}

// ---------------------------------------------------------------------------
// Formats (8.E)

#[test]
fn values_in_the_codes_formats() {
    let mut d = drive(1);
    let mut l = Line::new();
    // VD shortest form: 50.0 Hz -> "50"; 0.25 -> "0.25".
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(value_reply(b"1150"))
    );
    assert_eq!(
        l.ask(&mut d, &receive("01", b"77")),
        Some(value_reply(b"770.25"))
    );
    // VH, 4 digits: C0007 factory 0x4321 (erratum E1).
    assert_eq!(
        l.ask(&mut d, &receive("01", b"07")),
        Some(value_reply(b"07H4321"))
    );
    // VS: C0200 (code 200 = "D0" by the 8.A formula).
    assert_eq!(
        l.ask(&mut d, &receive("01", b"D0")),
        Some(value_reply(b"D0S33STMD-M_12000"))
    );
    assert_eq!(
        l.ask(&mut d, &receive("01", b"99")),
        Some(value_reply(b"99S1.20"))
    );
    // A VD value written with trailing zeros reads back in shortest form.
    assert_eq!(l.ask(&mut d, &send("01", b"1260.0000")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"12")),
        Some(value_reply(b"1260"))
    );
}

// ---------------------------------------------------------------------------
// NAK causes (C0068 bits 4..7, C1962)

#[test]
fn nak_cause_1_bad_bcc_and_parity() {
    let mut d = drive(1);
    let mut l = Line::new();
    let mut t = send("01", b"1160");
    *t.last_mut().unwrap() ^= 0x40;
    assert_eq!(l.ask(&mut d, &t), Some(vec![NAK]));
    assert_eq!(int(&d, 11), 500_000, "value unchanged");
    assert_cause(&d, 1, 210);
    // Read back through C0068: control via LECOM (8), quick stop after
    // power-up with C1920 = 0 (12), checksum error (1 in bits 4..7).
    assert_eq!(l.c68(&mut d, "01"), "1110");
    // A parity error in a SEND (BCC right) is a checksum error too.
    assert_eq!(
        l.ask_bad(&mut d, &send("01", b"1160"), &[5]),
        Some(vec![NAK])
    );
    assert_cause(&d, 1, 214);
    assert_eq!(int(&d, 11), 500_000);
    // A good SEND clears the error.
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    assert_cause(&d, 0, 0);
    assert_eq!(l.c68(&mut d, "01"), "1100");
}

#[test]
fn nak_cause_2_protocol_frame_error() {
    let mut d = drive(1);
    let mut l = Line::new();
    // A code field of one character.
    assert_eq!(l.ask(&mut d, &send("01", b"1")), Some(vec![NAK]));
    assert_cause(&d, 2, 212);
    // A RECEIVE without a code field gets no answer, but is recorded.
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &[EOT, b'0', b'1', ENQ]), None);
    assert_cause(&d, 2, 212);
}

#[test]
fn nak_cause_4_invalid_code_number() {
    let mut d = drive(1);
    let mut l = Line::new();
    assert_eq!(l.ask(&mut d, &send("01", b"4512")), Some(vec![NAK]));
    assert_cause(&d, 4, 5);
    // Extended addressing of a code that does not exist: C1002.
    assert_eq!(l.ask(&mut d, &send("01", b"!03EA001")), Some(vec![NAK]));
    assert_cause(&d, 4, 5);
    // A subcode that does not exist: C0011/1.
    assert_eq!(l.ask(&mut d, &send("01", b"!000B0160")), Some(vec![NAK]));
    assert_cause(&d, 4, 4);
    // C1 C2 the 8.A formula never produces (C1 = 127).
    assert_eq!(
        l.ask(&mut d, &send("01", &[0x7F, b'0', b'1'])),
        Some(vec![NAK])
    );
    assert_cause(&d, 4, 5);
    assert_eq!(l.ask(&mut d, &receive("01", &[0x7F, b'0'])), None);
}

#[test]
fn nak_cause_5_invalid_variable() {
    let mut d = drive(1);
    let mut l = Line::new();
    // Out of range: C0011 is 7.5 - 240 Hz.
    assert_eq!(l.ask(&mut d, &send("01", b"11240.1")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(l.ask(&mut d, &send("01", b"117.4")), Some(vec![NAK]));
    assert_eq!(l.ask(&mut d, &send("01", b"117.5")), Some(vec![ACK]));
    assert_eq!(int(&d, 11), 75_000);
    // Wrong format: VH for a VD code, VD for a VH code.
    assert_eq!(l.ask(&mut d, &send("01", b"11H0032")), Some(vec![NAK]));
    assert_cause(&d, 5, 3);
    assert_eq!(l.ask(&mut d, &send("01", b"074321")), Some(vec![NAK]));
    assert_cause(&d, 5, 3);
    // A VH value wider than the code: C0007 is a word.
    assert_eq!(l.ask(&mut d, &send("01", b"07H00014321")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    // Unparseable VD (7 integer digits), a value of no format.
    assert_eq!(l.ask(&mut d, &send("01", b"111234567")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(l.ask(&mut d, &send("01", b"11X")), Some(vec![NAK]));
    assert_cause(&d, 5, 3);
    // An enumerated code takes its listed values only.
    assert_eq!(l.ask(&mut d, &send("01", b"142.5")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(int(&d, 14), 20_000);
    // The address must stay a station address (§4c).
    assert_eq!(l.ask(&mut d, &send("01", b"0920")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(l.ask(&mut d, &send("01", b"H90.5")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(l.ask(&mut d, &send("01", b"H916")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
}

#[test]
fn nak_cause_6_no_access_permission() {
    let mut d = drive(1);
    let mut l = Line::new();
    // Read-only: C0050 output frequency, C0068, C0200.
    assert_eq!(l.ask(&mut d, &send("01", b"5010")), Some(vec![NAK]));
    assert_cause(&d, 6, 9);
    assert_eq!(l.ask(&mut d, &send("01", b"68H0000")), Some(vec![NAK]));
    assert_cause(&d, 6, 9);
    // C0001 = 2: parameters yes, control word no (§4f).
    assert_eq!(l.ask(&mut d, &send("01", b"012")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"!008700H0000")), Some(vec![NAK]));
    assert_cause(&d, 6, 8);
    // C0001 = 0: reads only, but C0040 (§5) and the addressing registers.
    assert_eq!(l.ask(&mut d, &send("01", b"010")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"1170")), Some(vec![NAK]));
    assert_cause(&d, 6, 8);
    assert_eq!(int(&d, 11), 600_000);
    assert_eq!(l.ask(&mut d, &send("01", b"011")), Some(vec![NAK]));
    assert_eq!(l.ask(&mut d, &send("01", b"401")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"H91")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"H90")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(value_reply(b"1160"))
    );
}

#[test]
fn nak_cause_6_running_drive_refuses_loading_a_lenze_setting() {
    let mut d = drive(1);
    let mut l = Line::new();
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    d.set_running(true);
    assert!(d.running());
    assert_eq!(l.ask(&mut d, &send("01", b"021")), Some(vec![NAK]));
    assert_cause(&d, 6, 8);
    // Parameters are still writable while running.
    assert_eq!(l.ask(&mut d, &send("01", b"1165")), Some(vec![ACK]));
    d.set_running(false);
    assert_eq!(l.ask(&mut d, &send("01", b"021")), Some(vec![ACK]));
    assert_eq!(int(&d, 11), 500_000, "Table 1 factory value");
    assert_eq!(int(&d, 2), 0, "loading complete");
    assert_eq!(int(&d, 1), 30_000, "C0001 kept");
    // No 60 Hz / OEM setting in the manual: general fault.
    assert_eq!(l.ask(&mut d, &send("01", b"022")), Some(vec![NAK]));
    assert_cause(&d, 15, 17);
}

#[test]
fn nak_cause_7_telegram_interrupted_by_a_new_telegram() {
    let mut d = drive(1);
    let mut l = Line::new();
    // A SEND cut off by the EOT of the next telegram: no answer to it; the
    // RECEIVE that interrupted it reads the cause.
    let mut t = vec![EOT, b'0', b'1', STX, b'1', b'1', b'6'];
    t.extend(receive("01", b"68"));
    let r = l.ask(&mut d, &t[..t.len()]);
    assert_eq!(r, Some(value_reply(b"68H1170")));
    assert_cause(&d, 7, 211);
    assert_eq!(int(&d, 11), 500_000);
}

// ---------------------------------------------------------------------------
// Cross-code rules

#[test]
fn c0007_equal_inputs_are_refused_by_default() {
    let mut d = drive(1);
    let mut l = Line::new();
    assert_eq!(l.ask(&mut d, &send("01", b"07H4311")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(int(&d, 7), 0x4321);
    assert_eq!(l.ask(&mut d, &send("01", b"07HC521")), Some(vec![ACK]));
    assert_eq!(int(&d, 7), 0xC521);
    assert_eq!(int(&d, 161), 0);
}

#[test]
fn c0007_equal_inputs_trip_cfg_when_configured() {
    let mut d = TmdDrive::new(TmdOptions {
        cfg_reaction: CfgReaction::Trip,
        ..TmdOptions::at(1).c0001(3)
    })
    .unwrap();
    let mut l = Line::new();
    d.set_running(true);
    assert_eq!(l.ask(&mut d, &send("01", b"07H1111")), Some(vec![ACK]));
    assert_eq!(int(&d, 7), 0x1111);
    assert_eq!(int(&d, 161), 710_000, "CFG = 71 (Table 2)");
    assert!(!d.running());
    // Fault bit 15, tens digit 7, control via LECOM: H8107.
    assert_eq!(l.c68(&mut d, "01"), "8107");
    // A reset while C0007 is still invalid trips again.
    assert_eq!(l.ask(&mut d, &send("01", b"431")), Some(vec![ACK]));
    assert_eq!(int(&d, 161), 710_000);
    assert_eq!(int(&d, 162), 710_000);
    assert_eq!(l.ask(&mut d, &send("01", b"07H4321")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"430")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"431")), Some(vec![ACK]));
    assert_eq!(int(&d, 161), 0);
    assert_eq!(int(&d, 163), 710_000);
}

#[test]
fn c0010_must_not_exceed_c0011() {
    let mut d = drive(1);
    let mut l = Line::new();
    assert_eq!(l.ask(&mut d, &send("01", b"1050.1")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(l.ask(&mut d, &send("01", b"1050")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"1149.9")), Some(vec![NAK]));
    assert_cause(&d, 5, 14);
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    assert_eq!((int(&d, 10), int(&d, 11)), (500_000, 600_000));
}

// ---------------------------------------------------------------------------
// Addressing (8.A - 8.D)

#[test]
fn code_bank_and_input_selection() {
    let mut d = drive(1);
    let mut l = Line::new();
    // Bank 7 = 1750..2005 (Table 1 C0249): local 173 ("A3") is C1923.
    assert_eq!(l.ask(&mut d, &send("01", b"H97")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"A3")),
        Some(value_reply(b"A350"))
    );
    assert_eq!(l.ask(&mut d, &send("01", b"A3100")), Some(vec![ACK]));
    assert_eq!(int(&d, 1923), 1_000_000);
    // C0249 and C0248 stay reachable as 249 / 248 in any bank.
    assert_eq!(
        l.ask(&mut d, &receive("01", b"H9")),
        Some(value_reply(b"H97"))
    );
    // Local 11 is C1761 in bank 7: does not exist.
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(vec![STX, b'1', b'1', EOT])
    );
    // Extended addressing ignores the bank (8.D).
    assert_eq!(
        l.ask(&mut d, &receive("01", b"!000B00")),
        Some(value_reply(b"!000B0050"))
    );
    assert_eq!(l.ask(&mut d, &send("01", b"H90")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(value_reply(b"1150"))
    );
    // Input selection 1: every standard access goes to subcode 1 (8.C),
    // except C0248 itself.
    assert_eq!(l.ask(&mut d, &send("01", b"H81")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(vec![STX, b'1', b'1', EOT])
    );
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![NAK]));
    assert_cause(&d, 4, 4);
    assert_eq!(
        l.ask(&mut d, &receive("01", b"!000B00")),
        Some(value_reply(b"!000B0050"))
    );
    assert_eq!(
        l.ask(&mut d, &receive("01", b"H8")),
        Some(value_reply(b"H81"))
    );
    assert_eq!(l.ask(&mut d, &send("01", b"H80")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
}

#[test]
fn codes_above_255_by_formula_and_extended_addressing() {
    let mut d = drive(1);
    let mut l = Line::new();
    // C1923 by the 8.A formula: 1923 = 2 x 790 + 343 -> 'R' 'G'.
    assert_eq!(
        l.ask(&mut d, &receive("01", b"RG")),
        Some(value_reply(b"RG50"))
    );
    // Extended: 1923 = 0x0783.
    assert_eq!(l.ask(&mut d, &send("01", b"!078300250")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"!078300")),
        Some(value_reply(b"!078300250"))
    );
    // C1962 read by extended addressing, after a refusal: 9 read-only.
    assert_eq!(l.ask(&mut d, &send("01", b"!07AA001")), Some(vec![NAK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"!07AA00")),
        Some(value_reply(b"!07AA009"))
    );
    // An extended subcode that does not exist.
    assert_eq!(
        l.ask(&mut d, &receive("01", b"!078301")),
        Some([&[STX][..], b"!078301", &[EOT]].concat())
    );
}

#[test]
fn own_address_groups_and_other_addresses() {
    let mut d = drive(25);
    let mut l = Line::new();
    assert_eq!(d.address(), 25);
    // Another station: no answer, nothing done.
    assert_eq!(l.ask(&mut d, &receive("24", b"11")), None);
    assert_eq!(l.ask(&mut d, &send("24", b"1160")), None);
    assert_eq!(int(&d, 11), 500_000);
    // Another group: not for this drive.
    assert_eq!(l.ask(&mut d, &send("30", b"1160")), None);
    assert_eq!(int(&d, 11), 500_000);
    // Its group 20: executed, unanswered.
    assert_eq!(l.ask(&mut d, &send("20", b"1160")), None);
    assert_eq!(int(&d, 11), 600_000);
    // A refused broadcast records the cause.
    assert_eq!(l.ask(&mut d, &send("00", b"11999")), None);
    assert_cause(&d, 5, 14);
    // A RECEIVE to a group address is never answered.
    assert_eq!(l.ask(&mut d, &receive("20", b"11")), None);
    // Changing the address: the ACK comes from 25, then it answers at 26.
    assert_eq!(l.ask(&mut d, &send("25", b"0926")), Some(vec![ACK]));
    assert_eq!(d.address(), 26);
    assert_eq!(l.ask(&mut d, &receive("25", b"09")), None);
    assert_eq!(
        l.ask(&mut d, &receive("26", b"09")),
        Some(value_reply(b"0926"))
    );
    // Group addresses can never be a drive's own address.
    assert!(TmdDrive::at(20).is_err());
    assert!(TmdDrive::at(0).is_err());
    assert!(TmdDrive::at(100).is_err());
    assert!(d.poke(CodeKey::new(9), RawValue::Int(300_000)).is_err());
}

// ---------------------------------------------------------------------------
// Running state, power cycle

#[test]
fn status_words_follow_the_drive_state() {
    let mut d = drive(1);
    let mut l = Line::new();
    // Power-up with C0001 = 3, C1920 = 0: quick stop (§5), inhibited.
    assert_eq!(int(&d, 135), 0x0008);
    assert_eq!(l.c68(&mut d, "01"), "1100");
    // C0150: 0 Hz (6), inhibit (7), ready (15).
    assert_eq!(int(&d, 150), 0x80C0);
    // Enable over LECOM: C0135 = 0, C0040 = 1; not running until started.
    assert_eq!(l.ask(&mut d, &send("01", b"!008700H0000")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"401")), Some(vec![ACK]));
    assert_eq!(l.c68(&mut d, "01"), "0100");
    d.set_running(true);
    assert_eq!(int(&d, 150), 0x8042);
    // CCW and quick stop through the control word: QSP stops the motor.
    assert_eq!(l.ask(&mut d, &send("01", b"!008700H0004")), Some(vec![ACK]));
    assert_eq!(l.c68(&mut d, "01"), "0D00");
    assert_eq!(l.ask(&mut d, &send("01", b"!008700H000C")), Some(vec![ACK]));
    assert!(!d.running());
    assert_eq!(l.c68(&mut d, "01"), "1500");
    // A fault: tens digit, bit 15; overtemperature in C0150 bit 12.
    d.poke(CodeKey::new(161), RawValue::Int(500_000)).unwrap();
    assert_eq!(l.c68(&mut d, "01"), "9505");
    assert_eq!(int(&d, 150) & 0xF000, 0x5000);
    // Reset by the C0135 bit 11 edge.
    assert_eq!(l.ask(&mut d, &send("01", b"!008700H080C")), Some(vec![ACK]));
    assert_eq!(int(&d, 161), 0);
    assert_eq!(int(&d, 162), 500_000);
    assert!(d.poke(CodeKey::new(68), RawValue::Int(0)).is_err());
}

#[test]
fn power_cycle_keeps_values_and_resets_bank_and_selection() {
    let mut d = drive(1);
    let mut l = Line::new();
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"H93")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"H82")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"!007D002")), Some(vec![ACK]));
    assert_eq!(d.take_baud_change(), None, "C0125 waits for power-up");
    d.set_running(true);
    let off_at = l.now;
    d.power_cycle(Instant::from_nanos(off_at), Duration::from_millis(500));
    // Nothing is answered while the power is off.
    assert_eq!(
        l.feed_bad(&mut d, &receive("01", b"11"), &[]),
        Heard::Nothing
    );
    l.now = off_at + 500_000_000;
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(value_reply(b"1160"))
    );
    assert_eq!(int(&d, 249), 0);
    assert_eq!(int(&d, 248), 0);
    assert!(!d.running());
    assert_eq!(
        int(&d, 135) & 0x0008,
        0x0008,
        "§5: quick stop after power-up"
    );
    assert_eq!(d.take_baud_change(), Some(2400));
    assert_eq!(d.take_baud_change(), None);
    // C1920 = 1: inhibit instead.
    assert_eq!(l.ask(&mut d, &send("01", b"!07800001")), Some(vec![ACK]));
    assert_eq!(l.ask(&mut d, &send("01", b"401")), Some(vec![ACK]));
    d.power_cycle(Instant::from_nanos(l.now), Duration::ZERO);
    assert_eq!(int(&d, 40), 0);
}

#[test]
fn state_poke_and_reaction_time() {
    let mut d = TmdDrive::new(TmdOptions {
        seed: 7,
        ..TmdOptions::at(1).c0001(3)
    })
    .unwrap();
    let s = d.state();
    assert_eq!(s.schema, "lenze-tmd");
    assert_eq!(
        s.values.get(&CodeKey::new(11)),
        Some(&RawValue::Int(500_000))
    );
    assert_eq!(
        s.values.get(&CodeKey::new(99)),
        Some(&RawValue::Text("1.20".into()))
    );
    assert!(d.poke(CodeKey::new(45), RawValue::Int(0)).is_err());
    assert!(
        d.poke(CodeKey::new(99), RawValue::Text("x".repeat(21)))
            .is_err()
    );
    d.poke(CodeKey::new(50), RawValue::Int(123_400)).unwrap();
    assert_eq!(int(&d, 50), 123_400);
    // Reaction times: within TMD_ASSUMED, the same for the same seed.
    let mut e = TmdDrive::new(TmdOptions {
        seed: 7,
        ..TmdOptions::at(1).c0001(3)
    })
    .unwrap();
    for _ in 0..20 {
        let mut now = 0;
        let mut rs = Vec::new();
        for dr in [&mut d, &mut e] {
            let mut h = Heard::Nothing;
            for &b in &receive("01", b"11") {
                now += 1;
                h = dr.hear(Instant::from_nanos(now), b, true);
            }
            let Heard::Telegram { reply: Some(r) } = h else {
                panic!("no reply")
            };
            assert!(r.reaction >= Duration::from_millis(1));
            assert!(r.reaction <= Duration::from_millis(20));
            rs.push(r.reaction);
        }
        assert_eq!(rs[0], rs[1]);
    }
}

#[test]
fn a_lone_eot_and_garbage_complete_nothing() {
    let mut d = drive(1);
    let mut l = Line::new();
    assert_eq!(l.feed_bad(&mut d, b"xyz\x06\x15", &[]), Heard::Nothing);
    // Another drive's answer on the line is ignored.
    assert_eq!(
        l.feed_bad(&mut d, &value_reply(b"1150"), &[]),
        Heard::Nothing
    );
    assert_eq!(
        l.ask(&mut d, &receive("01", b"11")),
        Some(value_reply(b"1150"))
    );
}

// ---------------------------------------------------------------------------
// Robustness

mod robustness {
    use super::*;
    use driveset_proto::lecom::{Broadcast, Receive, Send};
    use driveset_proto::lecom::{
        CodeAddress, ControllerAddress, Decimal, Hex, Response, ResponseDecoder, Telegram, Value,
    };
    use proptest::prelude::*;

    /// Codes of Table 1 and a few that do not exist.
    const CODES: [u16; 24] = [
        1, 2, 7, 9, 10, 11, 12, 14, 40, 43, 45, 46, 50, 68, 99, 125, 135, 150, 161, 200, 248, 249,
        1923, 1962,
    ];

    fn any_value() -> impl Strategy<Value = Value> {
        prop_oneof![
            (-3_000_000i64..3_000_000).prop_map(|r| Value::Decimal(Decimal::from_raw(r).unwrap())),
            (0i64..300).prop_map(|n| Value::Decimal(Decimal::from_int(n).unwrap())),
            any::<u16>().prop_map(|w| Value::Hex(Hex::Word(w))),
            any::<u8>().prop_map(|b| Value::Hex(Hex::Byte(b))),
        ]
    }

    fn any_telegram() -> impl Strategy<Value = Telegram> {
        (
            prop::sample::select(&[0u8, 1, 2, 10, 11, 20][..]),
            prop::sample::select(&CODES[..]),
            0u8..3,
            any::<bool>(),
            any_value(),
            any::<bool>(),
        )
            .prop_map(|(addr, code, sub, ext, value, read)| {
                let address = ControllerAddress::new(addr).unwrap();
                let code = if ext {
                    CodeAddress::Extended(driveset_proto::lecom::ExtendedAddress {
                        code,
                        subcode: sub,
                    })
                } else {
                    CodeAddress::select(code, 0)
                };
                if address.is_broadcast() {
                    Telegram::Broadcast(Broadcast {
                        address,
                        code,
                        value,
                    })
                } else if read {
                    Telegram::Receive(Receive { address, code })
                } else {
                    Telegram::Send(Send {
                        address,
                        code,
                        value,
                    })
                }
            })
    }

    fn check_invariants(d: &TmdDrive) {
        let i = |c| int(d, c);
        assert!(i(10) <= i(11), "C0010 <= C0011");
        let e: Vec<i64> = (0..4).map(|k| i(7) >> (4 * k) & 0xF).collect();
        for a in 0..4 {
            for b in a + 1..4 {
                assert_ne!(e[a], e[b], "C0007 inputs distinct");
            }
        }
        let addr = i(9) / 10_000;
        assert!(addr >= 1 && addr % 10 != 0, "C0009 a station address");
        assert!(i(249) % 10_000 == 0 && (0..=15).contains(&(i(249) / 10_000)));
        assert!(i(248) % 10_000 == 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn random_bytes_never_panic(bytes in prop::collection::vec((any::<u8>(), any::<bool>()), 0..600)) {
            let mut d = drive(11);
            let mut now = 0;
            for (b, p) in bytes {
                now += 1_000;
                if let Heard::Telegram { reply: Some(r) } = d.hear(Instant::from_nanos(now), b, p) {
                    let events = ResponseDecoder::decode_all(&r.bytes);
                    prop_assert_eq!(events.len(), 1);
                    prop_assert!(events[0].result.is_ok());
                }
            }
            check_invariants(&d);
        }

        #[test]
        fn telegrams_are_answered_per_section_8(
            ts in prop::collection::vec((any_telegram(), prop::option::of(0usize..12)), 1..40)
        ) {
            let mut d = drive(11);
            d.set_running(true);
            let mut now = 0;
            for (t, bad) in ts {
                let bytes = t.to_bytes().unwrap();
                // A broadcast may have changed the address (C0009).
                let me = d.address();
                let mut heard = Heard::Nothing;
                for (k, &b) in bytes.iter().enumerate() {
                    now += 1_000_000;
                    heard = d.hear(Instant::from_nanos(now), b, bad != Some(k));
                }
                let Heard::Telegram { reply } = heard else {
                    return Err(TestCaseError::fail(format!("{t} completed nothing")));
                };
                let for_me = ControllerAddress::new(me) == Some(t.address());
                match (&t, reply) {
                    (_, None) => prop_assert!(
                        !for_me || !t.expects_response() || bad == Some(bytes.len() - 1),
                        "{} unanswered", t
                    ),
                    (Telegram::Broadcast(_), Some(_)) => prop_assert!(false, "broadcast answered"),
                    (Telegram::Receive(r), Some(reply)) => {
                        prop_assert!(for_me);
                        let resp = Response::decode(&reply.bytes).unwrap();
                        prop_assert_eq!(resp.code(), Some(r.code), "echoes the code field");
                    }
                    (Telegram::Send(_), Some(reply)) => {
                        prop_assert!(for_me);
                        prop_assert!(reply.bytes == [ACK] || reply.bytes == [NAK]);
                        if bad.is_some_and(|k| k < bytes.len()) {
                            prop_assert_eq!(reply.bytes, vec![NAK]);
                        }
                    }
                }
                check_invariants(&d);
            }
        }
    }
}

#[test]
fn factory_c0001_is_0_lecom_reads_and_switches_banks_only() {
    // Table 1: C0001 factory setting 0 (§4e: programmed via keypad,
    // monitored via LECOM).
    let mut d = TmdDrive::new(TmdOptions::at(1)).unwrap();
    let mut l = Line::new();
    assert_eq!(int(&d, 1), 0);
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![NAK]));
    assert_cause(&d, 6, 8);
    assert_eq!(int(&d, 11), 500_000);
    // C0249 = 7 is allowed: standard code 173 ("A3") then names C1923
    // (StandardAddressing, shared with `driveset decode`).
    assert_eq!(l.ask(&mut d, &send("01", b"H97")), Some(vec![ACK]));
    assert_eq!(
        l.ask(&mut d, &receive("01", b"A3")),
        Some(value_reply(b"A350"))
    );
    // The keypad setting 3 lets LECOM program it (§4e).
    let mut d = TmdDrive::new(TmdOptions::at(1).c0001(3)).unwrap();
    assert_eq!(int(&d, 1), 30_000);
    assert_eq!(l.ask(&mut d, &send("01", b"1160")), Some(vec![ACK]));
    assert_eq!(int(&d, 11), 600_000);
}
