//! Simulated MC6000/7000 and VF1000 on LUSTBUS, driven byte by byte through
//! `ByteDrive::hear` at 9600 Bd wire timing (10 bits a character).

use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::ascii::bcc;
use driveset_proto::lustbus::description::{McKind, VfStorage, decode_substitution_text};
use driveset_proto::lustbus::{McDescription, ParameterType, VfDescription};
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_schema::family::Keypad;
use driveset_sim::drive::{ByteDrive, Heard, ReactionTime, Reply};
use driveset_sim::lustbus_drive::LustOptions;
use driveset_sim::mc6000::Mc6000;
use driveset_sim::rng::SimRng;
use driveset_sim::vf1000::Vf1000;

const CHAR: Duration = Duration::from_nanos(1_041_667);
const ONE_MS: ReactionTime = ReactionTime::ms(1, 1);

/// A host on a private line to one drive, with a virtual clock.
struct Host<D> {
    d: D,
    t: Instant,
}

impl<D: ByteDrive> Host<D> {
    fn new(d: D) -> Self {
        Host {
            d,
            t: Instant::from_nanos(1_000_000_000),
        }
    }

    /// Sends a telegram character by character; returns the drive's reply
    /// (and advances the clock past it).
    fn send(&mut self, bytes: &[u8]) -> Option<Reply> {
        self.send_with(bytes, &[])
    }

    /// Like `send`; the characters at the `bad_parity` indexes arrive with a
    /// parity error.
    fn send_with(&mut self, bytes: &[u8], bad_parity: &[usize]) -> Option<Reply> {
        let mut reply = None;
        for (i, &b) in bytes.iter().enumerate() {
            self.t += CHAR;
            if let Heard::Telegram { reply: r } = self.d.hear(self.t, b, !bad_parity.contains(&i)) {
                reply = r;
            }
        }
        if let Some(r) = &reply {
            self.t += r.reaction + CHAR * r.bytes.len() as u32;
        }
        reply
    }

    fn bytes(&mut self, bytes: &[u8]) -> Option<Vec<u8>> {
        self.send(bytes).map(|r| r.bytes)
    }

    fn wait(&mut self, d: Duration) {
        self.t += d;
    }
}

use crate::lust_support::{enq, sel, val};

fn ack(a: u8) -> Option<Vec<u8>> {
    Some(vec![0x40 + a, 0x06])
}

fn nak(a: u8) -> Option<Vec<u8>> {
    Some(vec![0x40 + a, 0x15])
}

fn mc() -> Host<Mc6000> {
    Host::new(Mc6000::new(LustOptions::new(1).reaction(ONE_MS)).unwrap())
}

fn vf() -> Host<Vf1000> {
    Host::new(Vf1000::new(LustOptions::new(1).reaction(ONE_MS)).unwrap())
}

fn raw<D: ByteDrive>(h: &Host<D>, n: u32) -> i64 {
    match h.d.state().values.get(&CodeKey::new(n)) {
        Some(RawValue::Int(v)) => *v,
        other => panic!("{n}: {other:?}"),
    }
}

/// Reads and clears SERR (MC, 2 digits).
fn mc_serr(h: &mut Host<Mc6000>) -> Vec<u8> {
    h.bytes(&enq(0, 85)).unwrap()
}

fn with_bcc(text: &[u8]) -> Vec<u8> {
    let mut v = text.to_vec();
    v.push(bcc(
        &text[text.iter().position(|&b| b == 0x02).unwrap() + 1..]
    ));
    v
}

// ---------------------------------------------------------------- spec examples

#[test]
fn spec_6_1_1_1_vf_enquiry_of_parameter_12_via_address_0() {
    let mut h = vf();
    h.d.poke(CodeKey::new(12), RawValue::Int(0x03E8)).unwrap();
    let r = h.bytes(&[4, 64, 48, 48, 49, 49, 50, 5]).unwrap();
    assert_eq!(r, [64, 2, 48, 48, 49, 49, 50, 61, 48, 51, 69, 56, 3, 0x72]);
    // The same parameter with the basis device number 0 (section 11.1).
    assert_eq!(
        h.bytes(b"\x04@00012\x05").unwrap(),
        b"@\x0200012=03E8\x03\x73"
    );
}

#[test]
fn spec_6_1_1_2_mc_enquiry_of_77_speed_via_address_0() {
    let mut h = mc();
    h.d.poke(CodeKey::new(77), RawValue::Int(0x04FA_4000))
        .unwrap();
    let r = h.bytes(&[4, 64, 50, 48, 48, 55, 55, 5]).unwrap();
    assert_eq!(
        r,
        [
            64, 2, 50, 48, 48, 55, 55, 61, 48, 52, 70, 65, 52, 48, 48, 48, 3, 0x0B
        ]
    );
}

#[test]
fn spec_6_2_2_vf_select_fssio_50_hz() {
    let mut h = vf();
    // Power-on bit first (section 6): read SIOF, then the example.
    assert_eq!(h.bytes(&enq(0, 85)).unwrap(), val(0, 85, "0001"));
    let t = [4, 64, 2, 48, 48, 49, 48, 53, 61, 48, 51, 69, 56, 3, 0x74];
    assert_eq!(with_bcc(&t[..14]), t);
    assert_eq!(h.bytes(&t), ack(0));
    assert_eq!(raw(&h, 5), 1000);
    assert!(!h.d.running());
}

#[test]
fn spec_7_1_1_vf_control_sequence() {
    let mut h = vf();
    h.bytes(&enq(0, 85));
    for (c, v) in [(1, "0000"), (2, "0003"), (4, "0008"), (5, "01CF")] {
        assert_eq!(h.bytes(&sel(0, c, v)), ack(0), "{c}");
        assert!(!h.d.running());
    }
    assert_eq!(h.bytes(&sel(0, 3, "0080")), ack(0));
    assert!(h.d.running());
    assert_eq!((raw(&h, 5), raw(&h, 3)), (463, 128));
}

#[test]
fn spec_7_2_1_mc_control_sequence() {
    let mut h = mc();
    h.bytes(&enq(0, 85));
    let seq = [
        (20300, "2"),
        (20416, "0"),
        (20402, "2"),
        (20418, "0"),
        (20419, "0"),
        (20420, "0"),
        (20417, "3"),
        (20428, "842666"),
    ];
    for (c, v) in seq {
        assert_eq!(h.bytes(&sel(0, c, v)), ack(0), "{c}={v}");
        assert!(!h.d.running());
    }
    assert_eq!(
        sel(0, 20428, "842666"),
        b"\x04@\x0220428=842666\x03\x0A".to_vec()
    );
    assert_eq!(h.bytes(&sel(0, 20416, "1")), ack(0));
    assert!(h.d.running());
    assert_eq!(raw(&h, 428), 0x842666);
    assert_eq!(raw(&h, 417), 3);
}

// ---------------------------------------------------------------- SERR/SIOF

#[test]
fn serr_power_on_latches_until_read() {
    let mut h = mc();
    assert_eq!(h.bytes(&sel(0, 20416, "0")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "01"));
    assert_eq!(h.bytes(&sel(0, 20416, "0")), ack(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "00"));
    // Compatible CODE and the MC CODE of 85 read the same word.
    assert_eq!(h.bytes(&enq(0, 20085)).unwrap(), val(0, 20085, "00"));
}

#[test]
fn enquiry_of_unknown_code_is_nak_and_never_sets_serr() {
    let mut h = mc();
    mc_serr(&mut h);
    for c in [20999, 5, 30999, 61077, 12345, 49999] {
        assert_eq!(h.bytes(&enq(0, c)), nak(0), "{c}");
    }
    assert_eq!(mc_serr(&mut h), val(0, 85, "00"));
    let mut v = vf();
    v.bytes(&enq(0, 85));
    for c in [99, 20077, 10199, 212] {
        assert_eq!(v.bytes(&enq(0, c)), nak(0), "{c}");
    }
    assert_eq!(v.bytes(&enq(0, 85)).unwrap(), val(0, 85, "0000"));
}

#[test]
fn nak_causes_are_latched() {
    let mut h = mc();
    mc_serr(&mut h);
    let cases: [(u32, &str, &str); 7] = [
        (20999, "1", "20"),         // no such parameter
        (5, "3E8", "20"),           // VF-style CODE on an MC (errata L7)
        (20077, "0", "40"),         // RAM actual value, read-only
        (20085, "0", "40"),         // SERR itself is read-only
        (20300, "8", "80"),         // CFCON max 7
        (20300, "g", "80"),         // not hex
        (20300, "123456789", "80"), // 9 digits
    ];
    for (c, v, bits) in cases {
        assert_eq!(h.bytes(&sel(0, c, v)), nak(0), "{c}={v}");
        // Latched: the next SELECT is refused even if valid.
        assert_eq!(h.bytes(&sel(0, 20416, "0")), nak(0));
        assert_eq!(mc_serr(&mut h), val(0, 85, bits), "{c}={v}");
    }
    // Standstill-only while running: 80-SLOAD.
    h.d.set_running(true);
    assert_eq!(h.bytes(&sel(0, 20080, "FFFF")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "40"));
}

#[test]
fn bad_bcc_and_parity_errors() {
    let mut h = mc();
    mc_serr(&mut h);
    let mut t = sel(0, 20416, "0");
    *t.last_mut().unwrap() ^= 1;
    assert_eq!(h.bytes(&t), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "08"));
    // A parity error inside a SELECT: transfer error.
    let t = sel(0, 20416, "0");
    assert_eq!(h.send_with(&t, &[5]).map(|r| r.bytes), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "08"));
    // A parity error inside an ENQUIRY: no answer, nothing latched.
    assert_eq!(h.send_with(&enq(0, 20416), &[3]), None);
    assert_eq!(mc_serr(&mut h), val(0, 85, "00"));
    // Empty VALUE: invalid value.
    assert_eq!(h.bytes(b"\x04@\x0220416=\x03\x37"), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "80"));
}

// ---------------------------------------------------------------- EEPROM

#[test]
fn mc_eeprom_busy_for_width_times_15_ms() {
    let mut h = mc();
    mc_serr(&mut h);
    // 105-BRRES, PT_FLOAT_IEEE, 4 bytes: busy 60 ms after the SELECT.
    assert_eq!(h.bytes(&sel(0, 20105, "42480000")), ack(0));
    let first_end = h.t;
    assert_eq!(
        h.d.eeprom_busy_until(),
        Some(first_end - Duration::from_millis(1) - CHAR * 2 + Duration::from_millis(60))
    );
    assert_eq!(h.bytes(&sel(0, 20106, "43C80000")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "04"));
    // RAM parameters are not paced.
    assert_eq!(h.bytes(&sel(0, 20416, "0")), ack(0));
    h.wait(Duration::from_millis(60));
    assert_eq!(h.bytes(&sel(0, 20106, "43C80000")), ack(0));
    assert_eq!(raw(&h, 105), 0x4248_0000);
    assert_eq!(raw(&h, 106), 0x43C8_0000);
    // One-byte parameters: 15 ms, shorter than a SELECT at 9600 Bd.
    h.wait(Duration::from_millis(60));
    assert_eq!(h.bytes(&sel(0, 20300, "3")), ack(0));
    assert_eq!(h.bytes(&sel(0, 20402, "1")), ack(0));
}

#[test]
fn mc_float_range_is_numeric() {
    let mut h = mc();
    mc_serr(&mut h);
    // BRRES 10..1000 Ohm: 5.0 and -50.0 are below, NaN is never valid.
    for v in ["40A00000", "C2480000", "7FC00000"] {
        assert_eq!(h.bytes(&sel(0, 20105, v)), nak(0), "{v}");
        assert_eq!(mc_serr(&mut h), val(0, 85, "80"));
    }
}

#[test]
fn vf_eeprom_write_delays_the_ack() {
    let opts = LustOptions::new(1).reaction(ReactionTime::fixed(Duration::from_millis(5)));
    let mut h = Host::new(Vf1000::new(opts).unwrap());
    h.bytes(&enq(0, 85));
    let reaction = |h: &mut Host<Vf1000>, t: Vec<u8>| {
        let r = h.send(&t).unwrap();
        assert_eq!(r.bytes, ack(0).unwrap());
        r.reaction
    };
    // 6-FMIN: two bytes, changed -> +120 ms; unchanged -> none.
    assert_eq!(
        reaction(&mut h, sel(0, 6, "0064")),
        Duration::from_millis(125)
    );
    assert_eq!(
        reaction(&mut h, sel(0, 6, "0064")),
        Duration::from_millis(5)
    );
    // 1-MODE: one byte -> +60 ms.
    assert_eq!(
        reaction(&mut h, sel(0, 1, "0001")),
        Duration::from_millis(65)
    );
    // 5-FSSIO is RAM while CSEL = 3 ...
    assert_eq!(
        reaction(&mut h, sel(0, 5, "0100")),
        Duration::from_millis(5)
    );
    // ... and EEPROM when CSEL < 3 (section 11.1).
    assert_eq!(
        reaction(&mut h, sel(0, 2, "0002")),
        Duration::from_millis(65)
    );
    assert_eq!(
        reaction(&mut h, sel(0, 5, "0200")),
        Duration::from_millis(125)
    );
    // RAM control: 3-CNTL.
    assert_eq!(
        reaction(&mut h, sel(0, 3, "0000")),
        Duration::from_millis(5)
    );
}

#[test]
fn vf_eeprom_refused_while_running() {
    let mut h = vf();
    h.bytes(&enq(0, 85));
    assert_eq!(h.bytes(&sel(0, 3, "0080")), ack(0));
    assert!(h.d.running());
    assert_eq!(h.bytes(&sel(0, 6, "0064")), nak(0));
    assert_eq!(h.bytes(&enq(0, 85)).unwrap(), val(0, 85, "0040"));
    // RAM parameters still go: FSSIO (CSEL = 3) and the stop.
    assert_eq!(h.bytes(&sel(0, 5, "0100")), ack(0));
    assert_eq!(h.bytes(&sel(0, 3, "0000")), ack(0));
    assert!(!h.d.running());
    assert_eq!(h.bytes(&sel(0, 6, "0064")), ack(0));
    // VF values are exactly four digits.
    assert_eq!(h.bytes(&sel(0, 6, "64")), nak(0));
    assert_eq!(h.bytes(&enq(0, 85)).unwrap(), val(0, 85, "0080"));
}

#[test]
fn vf_stat_reset_reboots() {
    let mut cut_seen = [false; 2];
    for seed in 0..16 {
        let opts = LustOptions::new(1)
            .seed(seed)
            .reaction(ONE_MS)
            .boot_time(Duration::from_millis(500));
        let mut h = Host::new(Vf1000::new(opts).unwrap());
        h.bytes(&enq(0, 85));
        h.bytes(&sel(0, 5, "0100"));
        let r = h.bytes(&sel(0, 11, "000F")).unwrap();
        assert!(r == b"@\x06" || r == b"@", "{r:?}");
        cut_seen[usize::from(r.len() == 1)] = true;
        // Deaf while booting.
        assert_eq!(h.bytes(&enq(0, 85)), None);
        h.wait(Duration::from_millis(500));
        assert_eq!(h.bytes(&enq(0, 85)).unwrap(), val(0, 85, "0001"));
        assert_eq!(raw(&h, 5), 0, "RAM value back to factory");
    }
    assert_eq!(cut_seen, [true, true]);
}

// ---------------------------------------------------------------- SLOAD

fn sload_session(h: &mut Host<Mc6000>, values: &[(u32, &str)]) {
    mc_serr(h);
    assert_eq!(h.bytes(&sel(0, 20080, "FFFF")), ack(0));
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "FFFF"));
    for (c, v) in values {
        assert_eq!(h.bytes(&sel(0, *c, v)), ack(0), "{c}={v}");
    }
    assert_eq!(h.bytes(&sel(0, 20080, "FFFE")), ack(0));
}

#[test]
fn sload_accepted_set_lands_after_the_store_time() {
    let mut h = mc();
    sload_session(
        &mut h,
        &[
            (20100, "2"),   // PWMF, card writeable, 1 byte
            (20101, "1C2"), // MAINV = 450 V, 2 bytes
            (20103, "2BC"), // OVLIM, not card writeable: ACKed, ignored
            (20416, "1"),   // SCTL1 start: ignored during the download
        ],
    );
    assert!(!h.d.running());
    // Checking (FICTIONAL 20 ms + 1 ms per staged parameter: 22 ms) and
    // storing (1 and 2 bytes x 3 x 5 ms = 15 + 30 ms): SLOAD reads -1, old
    // values active, SELECTs refused as EEPROM busy.
    let busy = driveset_sim::mc6000::dataset_busy_time(&[1, 2]);
    assert_eq!(busy, Duration::from_millis(67));
    assert_eq!(
        driveset_sim::mc6000::rejected_dataset_busy_time(&[1, 2]),
        Duration::from_millis(22)
    );
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "FFFF"));
    assert_eq!(raw(&h, 100), 1);
    assert_eq!(h.bytes(&sel(0, 20416, "0")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "04"));
    h.wait(busy);
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "0000"));
    assert_eq!((raw(&h, 100), raw(&h, 101), raw(&h, 103)), (2, 450, 790));
    assert_eq!(h.bytes(&sel(0, 20416, "1")), ack(0));
    assert!(h.d.running());
}

#[test]
fn sload_rejected_set_reports_first_invalid_parameter() {
    let mut h = mc();
    // Out of range: 300-CFCON = 9 (max 7) and 417-RSSL1 = 8.
    sload_session(&mut h, &[(20100, "2"), (20417, "8"), (20300, "9")]);
    // -1 while it checks (20 ms + 3 x 1 ms), then the first invalid number
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "FFFF"));
    h.wait(Duration::from_millis(23));
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "012C"));
    assert_eq!((raw(&h, 100), raw(&h, 300), raw(&h, 417)), (1, 2, 3));
    // The FICTIONAL cross rule: UVLIM (320) above MAINV (230).
    sload_session(&mut h, &[(20100, "2"), (20101, "E6")]);
    h.wait(Duration::from_millis(22));
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "0066"));
    assert_eq!((raw(&h, 100), raw(&h, 101)), (1, 400));
    // Nothing of the rejected sets survives: an empty download is accepted.
    sload_session(&mut h, &[]);
    h.wait(Duration::from_millis(20));
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "0000"));
    assert_eq!((raw(&h, 100), raw(&h, 101), raw(&h, 300)), (1, 400, 2));
}

#[test]
fn sload_handshake_refusals() {
    let mut h = mc();
    mc_serr(&mut h);
    // -2 without a registered download.
    assert_eq!(h.bytes(&sel(0, 20080, "FFFE")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "40"));
    // Other SLOAD values.
    assert_eq!(h.bytes(&sel(0, 20080, "5")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "80"));
    // -1 while running.
    h.d.set_running(true);
    assert_eq!(h.bytes(&sel(0, 20080, "FFFF")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "40"));
    // A malformed staged value is refused even without a plausibility check.
    h.d.set_running(false);
    assert_eq!(h.bytes(&sel(0, 20080, "FFFF")), ack(0));
    assert_eq!(h.bytes(&sel(0, 20100, "1FF")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "80"));
    // Power cycle loses the staged set.
    assert_eq!(h.bytes(&sel(0, 20100, "2")), ack(0));
    let now = h.t;
    h.d.power_cycle(now, Duration::from_millis(10));
    h.wait(Duration::from_millis(10));
    mc_serr(&mut h);
    assert_eq!(h.bytes(&sel(0, 20080, "FFFE")), nak(0));
    assert_eq!(h.bytes(&enq(0, 20080)).unwrap(), val(0, 20080, "0000"));
    assert_eq!(raw(&h, 100), 1);
}

// ---------------------------------------------------------------- descriptions, texts

#[test]
fn mc_descriptions_and_substitution_texts() {
    let mut h = mc();
    mc_serr(&mut h);
    let r = h.bytes(&enq(0, 30077)).unwrap();
    let v = &r[8..r.len() - 2];
    assert_eq!(v.len(), McDescription::LEN);
    let d = McDescription::decode(v).unwrap();
    assert_eq!(d.name.as_str(), "SPEED");
    assert_eq!(d.kind, McKind::RamActual);
    assert_eq!(d.ty, ParameterType::Int32Q16);
    // Unit index -> 107-UNIT text via STEXT and 61107 (sections 11.2.1, 11.3).
    let stext = format!("{:X}", d.unit);
    assert_eq!(h.bytes(&sel(0, 20108, &stext)), ack(0));
    let r = h.bytes(&enq(0, 61107)).unwrap();
    assert_eq!(decode_substitution_text(&r[8..r.len() - 2]), Ok("1/min"));
    // 100-PWMF: texts of values 0..2; 3 is above its maximum.
    let d = h.bytes(&enq(0, 30100)).unwrap();
    let d = McDescription::decode(&d[8..d.len() - 2]).unwrap();
    assert_eq!((d.kind, d.min, d.max, d.default), (McKind::Eeprom, 0, 2, 1));
    assert_eq!(h.bytes(&sel(0, 20108, "2")), ack(0));
    assert_eq!(h.bytes(&enq(0, 61100)).unwrap(), val(0, 61100, "16 kHz"));
    assert_eq!(h.bytes(&sel(0, 20108, "3")), ack(0));
    assert_eq!(h.bytes(&enq(0, 61100)), nak(0));
    // No texts / no parameter.
    assert_eq!(h.bytes(&sel(0, 20108, "0")), ack(0));
    assert_eq!(h.bytes(&enq(0, 61077)), nak(0));
    assert_eq!(h.bytes(&enq(0, 61999)), nak(0));
    // SLOAD (PT_INTEGER16, -2..999) describes its signed range.
    let d = h.bytes(&enq(0, 30080)).unwrap();
    let d = McDescription::decode(&d[8..d.len() - 2]).unwrap();
    assert_eq!(
        (d.ty, d.min, d.max),
        (ParameterType::Integer16, 0xFFFE, 999)
    );
    // Every parameter has a description.
    let numbers: Vec<u32> = h.d.state().values.keys().map(|k| k.number).collect();
    assert!(numbers.len() >= 240, "{}", numbers.len());
    for n in numbers {
        let r = h.bytes(&enq(0, 30000 + n)).unwrap();
        assert!(McDescription::decode(&r[8..r.len() - 2]).is_ok(), "{n}");
    }
    assert_eq!(mc_serr(&mut h), val(0, 85, "00"));
}

#[test]
fn vf_descriptions() {
    let mut h = vf();
    let r = h.bytes(&enq(0, 10105)).unwrap();
    assert_eq!(r, val(0, 10105, " FSSIO    Hz3200001F400000"));
    let d = VfDescription::decode(&r[8..r.len() - 2]).unwrap();
    assert_eq!(d.kind.storage, VfStorage::FselIsel);
    let r = h.bytes(&enq(0, 10112)).unwrap();
    let d = VfDescription::decode(&r[8..r.len() - 2]).unwrap();
    assert_eq!((d.name.as_str(), d.unit.as_str()), ("ROTARY", "Hz"));
    assert_eq!(d.kind.storage, VfStorage::RamActual);
    let numbers: Vec<u32> = h.d.state().values.keys().map(|k| k.number).collect();
    for n in numbers {
        let r = h.bytes(&enq(0, 10100 + n)).unwrap();
        assert_eq!(r.len(), 8 + 26 + 2, "{n}");
    }
    assert_eq!(h.bytes(&enq(0, 10199)), nak(0));
}

// ---------------------------------------------------------------- power, PROG, addresses

#[test]
fn power_cycle_keeps_eeprom_and_resets_ram() {
    let mut h = mc();
    mc_serr(&mut h);
    assert_eq!(h.bytes(&sel(0, 20300, "3")), ack(0)); // EEPROM
    assert_eq!(h.bytes(&sel(0, 20428, "10000")), ack(0)); // RAM control
    assert_eq!(h.bytes(&sel(0, 20416, "1")), ack(0));
    h.d.poke(CodeKey::new(77), RawValue::Int(5)).unwrap(); // RAM actual
    assert!(h.d.running());
    let now = h.t;
    h.d.power_cycle(now, Duration::from_millis(200));
    assert_eq!(h.bytes(&enq(0, 85)), None);
    h.wait(Duration::from_millis(200));
    assert_eq!(h.bytes(&sel(0, 20416, "0")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "01"));
    assert!(!h.d.running());
    assert_eq!(
        (raw(&h, 300), raw(&h, 428), raw(&h, 416), raw(&h, 77)),
        (3, 0, 0, 0)
    );
}

#[test]
fn prog_factory_reload_and_baud_activation() {
    let mut h = mc();
    mc_serr(&mut h);
    assert_eq!(h.bytes(&sel(0, 20300, "3")), ack(0));
    h.wait(Duration::from_millis(20));
    assert_eq!(h.bytes(&sel(0, 81, "4B00")), ack(0));
    assert_eq!(h.d.take_baud_change(), None);
    assert_eq!(h.bytes(&sel(0, 20004, "6F")), ack(0));
    assert_eq!(h.d.take_baud_change(), Some(19200));
    assert_eq!(h.d.take_baud_change(), None);
    let r = h.send(&sel(0, 20004, "1")).unwrap();
    assert_eq!(r.bytes, ack(0).unwrap());
    assert!(r.reaction > Duration::from_secs(1) && r.reaction <= Duration::from_secs(10));
    assert_eq!(raw(&h, 300), 2);
    assert_eq!(raw(&h, 81), 19200);
    // Refused while running.
    h.d.set_running(true);
    assert_eq!(h.bytes(&sel(0, 20004, "1")), nak(0));
    assert_eq!(mc_serr(&mut h), val(0, 85, "40"));
}

#[test]
fn addressing_own_zero_broadcast_and_others() {
    let mut h = Host::new(Mc6000::new(LustOptions::new(5).reaction(ONE_MS)).unwrap());
    assert_eq!(h.d.address(), 5);
    assert_eq!(h.bytes(&enq(5, 85)).unwrap(), val(5, 85, "01"));
    assert_eq!(h.bytes(&enq(6, 85)), None);
    assert_eq!(h.bytes(&sel(6, 20416, "0")), None);
    assert_eq!(h.bytes(&enq(0, 91)).unwrap()[0], b'@');
    // Broadcast: executed, never answered.
    assert_eq!(h.bytes(&enq(31, 85)), None);
    assert_eq!(h.bytes(&sel(31, 20428, "20000")), None);
    assert_eq!(raw(&h, 428), 0x20000);
    assert_eq!(h.bytes(&sel(31, 20999, "1")), None);
    assert_eq!(h.bytes(&sel(5, 20416, "0")), nak(5));
    assert_eq!(h.bytes(&enq(5, 85)).unwrap(), val(5, 85, "20"));
    // A new 82-SADDR takes effect at once; the reply carries the old ADR.
    assert_eq!(h.bytes(&sel(5, 82, "7")), ack(5));
    assert_eq!(h.d.address(), 7);
    assert_eq!(h.bytes(&enq(5, 85)), None);
    assert_eq!(h.bytes(&enq(7, 85)).unwrap(), val(7, 85, "00"));
    let mut v = Host::new(Vf1000::new(LustOptions::new(30).reaction(ONE_MS)).unwrap());
    assert_eq!(v.bytes(&enq(30, 85)).unwrap(), val(30, 85, "0001"));
    assert_eq!(v.bytes(&sel(31, 5, "0010")), None);
    assert_eq!(raw(&v, 5), 16);
    assert!(Mc6000::at(31).is_err());
}

#[test]
fn reactions_follow_the_seed_and_the_keypad_setting() {
    let run = |keypad: Keypad, seed: u64| {
        let mut h = Host::new(Vf1000::new(LustOptions::new(1).seed(seed).keypad(keypad)).unwrap());
        (0..50)
            .map(|_| h.send(&enq(0, 91)).unwrap().reaction)
            .collect::<Vec<_>>()
    };
    assert_eq!(run(Keypad::Fitted, 9), run(Keypad::Fitted, 9));
    assert_ne!(run(Keypad::Fitted, 9), run(Keypad::Fitted, 10));
    let with = run(Keypad::Fitted, 3);
    assert!(
        with.iter()
            .all(|d| *d >= Duration::from_millis(1) && *d <= Duration::from_millis(60))
    );
    assert!(with.iter().any(|d| *d > Duration::from_millis(30)));
    let without = run(Keypad::Absent, 3);
    assert!(without.iter().all(|d| *d <= Duration::from_millis(30)));
    let mut m = Host::new(Mc6000::at(1).unwrap());
    for _ in 0..50 {
        let r = m.send(&enq(0, 91)).unwrap().reaction;
        assert!(r >= Duration::from_millis(1) && r <= Duration::from_millis(25));
    }
}

#[test]
fn noise_never_panics_and_the_drive_recovers() {
    let mut rng = SimRng::new(77);
    let mut h = mc();
    let mut v = vf();
    for _ in 0..20_000 {
        let b = (rng.next_u64() & 0xFF) as u8;
        let ok = rng.chance(0.95);
        h.t += CHAR;
        v.t += CHAR;
        let _ = h.d.hear(h.t, b, ok);
        let _ = v.d.hear(v.t, b, ok);
    }
    h.wait(Duration::from_secs(20));
    v.wait(Duration::from_secs(20));
    // EOT resets the receiver; reading 85 unlatches whatever noise set.
    assert!(h.bytes(&enq(0, 85)).is_some());
    assert!(v.bytes(&enq(0, 85)).is_some());
    h.d.set_running(false);
    assert_eq!(h.bytes(&sel(0, 20083, "1234")), ack(0));
}
