//! Simulated Lust SMARTDRIVE VF1000 frequency inverter on LUSTBUS
//! (standard protocol, `lustbus-protocol.txt`).
//!
//! Table: `fictional-vf1000-demo` (the real `lust-vf1000` schema extended
//! by a FICTIONAL fixture).
//!
//! Behaviour, with the section it implements:
//!
//! - CODEs (2.4.1, 11.1): `0 0 d pp` values, `1 0 d pp` descriptions (26
//!   characters). Device number 1 (VF1000) reaches every parameter; 0
//!   reaches the basis parameters (every parameter the schema does not mark
//!   `basis = false`; the compatible 81..85, 91 always). Other CODEs:
//!   SELECT NAK + SIOF 0x20, ENQUIRY `ADR NAK`.
//! - Values (2.3.1): exactly 4 uppercase hex digits in and out.
//! - SIOF (6, 9.2): as the MC's SERR (power-on bit, SELECTs NAKed while a
//!   bit is set, reading 85 clears, ENQUIRYs never set bits; causes 0x08,
//!   0x20, 0x40, 0x80).
//! - EEPROM parameters (3, 11.1, 10 exception 4): refused while the motor
//!   runs (NAK, SIOF 0x40); a changed value delays the ACK by 60 ms (one
//!   byte) or 120 ms (two bytes) on top of the reaction time; an unchanged
//!   value adds nothing. 5-FSSIO (kind FSEL/ISEL) is RAM while 2-CSEL = 3
//!   and EEPROM below (11.1, errata schemas-lust E6). Standstill-only
//!   parameters are refused with 0x40 while running.
//! - 3-CNTL (7.1, 7.1.1): bit 7 (start clockwise) set = running, clear =
//!   standstill.
//! - 11-STAT = 000F (8.1.1): error reset. The drive reboots at once: the
//!   ACK is sent in full or cut after the ADR (even odds from the seeded
//!   generator), then nothing is answered for the boot time
//!   ([`LustOptions::boot_time`], FICTIONAL 1 s) and SIOF holds the
//!   power-on bit, as after a power cycle. The simulator has no error
//!   states, so the reset is executed whatever STAT holds.
//! - 71-PROG = 1 (10 exception 1): factory settings, ACK when done (60 ms a
//!   byte of every EEPROM parameter, capped at 10 s; 81/82 kept; refused
//!   with 0x40 while running).
//! - Reaction times (10): 1..30 ms without KEYPAD, 1..60 ms with.

use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::lustbus::{CodeMeaning, ParameterCode, Siof, ValueText};
use driveset_schema::canonical::CodeKey;
use driveset_schema::schema::{Access, StorageKind};

use crate::catalog::Family;
use crate::drive::ReactionTime;
use crate::lustbus_drive::{Answer, LustCore, LustModel, LustOptions, SIOF};

/// 3-CNTL, the control word (section 7.1).
pub const CNTL: u32 = 3;
/// 11-STAT, status / error reset (section 8.1.1).
pub const STAT: u32 = 11;
/// 71-PROG (section 10 exception 1).
pub const PROG: u32 = 71;

/// A simulated VF1000 (behaviour in the module docs).
#[derive(Debug)]
pub struct Vf1000 {
    core: LustCore,
}

impl Vf1000 {
    /// A drive with these options.
    pub fn new(opts: LustOptions) -> Result<Self, String> {
        let default = ReactionTime::of(Family::Vf1000, opts.keypad);
        Ok(Vf1000 {
            core: LustCore::new(Family::Vf1000, &opts, default)?,
        })
    }

    /// A drive at `address` with default options (seed 0, no KEYPAD).
    pub fn at(address: u8) -> Result<Self, String> {
        Vf1000::new(LustOptions::new(address))
    }

    /// The latched SIOF bits (without clearing them).
    pub fn siof(&self) -> Siof {
        self.core.siof()
    }

    /// The parameter a value or description CODE addresses, if the device
    /// number allows it (section 11.1).
    fn number(&self, device: u8, parameter: u8) -> Option<u32> {
        let n = u32::from(parameter);
        let p = self.core.param(n)?;
        let basis = self
            .core
            .table
            .schema()
            .code(n)
            .and_then(|c| c.basis)
            .unwrap_or(true);
        match device {
            1 => Some(p.key.number),
            0 if basis || Family::Vf1000.descriptor().is_compatible(n) => Some(p.key.number),
            _ => None,
        }
    }
}

impl LustModel for Vf1000 {
    const FAMILY: &'static str = "vf1000";
    const RUN_BIT: (u32, i64) = (CNTL, 0x80);

    fn core(&mut self) -> &mut LustCore {
        &mut self.core
    }

    fn core_ref(&self) -> &LustCore {
        &self.core
    }

    fn tick(&mut self, _now: Instant) {}

    fn enquiry(&mut self, _now: Instant, code: ParameterCode) -> Answer {
        match code.meaning() {
            CodeMeaning::VfValue { device, parameter } => {
                let Some(n) = self.number(device, parameter) else {
                    return Answer::Nak;
                };
                if let Some(refusal) = self.core.refused_read(n) {
                    return refusal;
                }
                let Some(p) = self.core.wire_param(n).cloned() else {
                    return Answer::Nak;
                };
                let Some(text) = self
                    .core
                    .int(n)
                    .and_then(|raw| self.core.encode_value(&p, raw))
                else {
                    return Answer::Nak;
                };
                if n == SIOF {
                    self.core.take_siof();
                }
                Answer::Value(text)
            }
            CodeMeaning::VfDescription { device, parameter } => {
                let n = self.number(device, parameter);
                match &self.core.recorded {
                    // a twin: what its drive sent, nothing else
                    Some(r) => n.and_then(|n| r.descriptions.get(&n).cloned()),
                    None => n
                        .and_then(|n| self.core.param(n))
                        .and_then(|p| self.core.vf_description(p)),
                }
                .map_or(Answer::Nak, Answer::Value)
            }
            _ => Answer::Nak,
        }
    }

    fn select(&mut self, _now: Instant, code: ParameterCode, value: &ValueText) -> Answer {
        let CodeMeaning::VfValue { device, parameter } = code.meaning() else {
            return Answer::Refuse(Siof::NO_PARAMETER);
        };
        let Some(number) = self.number(device, parameter) else {
            return Answer::Refuse(Siof::NO_PARAMETER);
        };
        let Some(p) = self.core.wire_param(number).cloned() else {
            return Answer::Refuse(Siof::NO_PARAMETER);
        };
        if !p.writable() {
            return Answer::Refuse(Siof::NO_CHANGE);
        }
        let Some(raw) = self.core.decode_value(&p, value) else {
            return Answer::Refuse(Siof::INVALID_VALUE);
        };
        if !self.core.in_range(&p, raw) {
            return Answer::Refuse(Siof::INVALID_VALUE);
        }
        let eeprom = self.core.effective_kind(&p) == Some(StorageKind::Eeprom);
        if self.core.running && (eeprom || p.access == Access::Standstill) {
            return Answer::Refuse(Siof::NO_CHANGE);
        }
        match (number, raw) {
            (STAT, 0x0F) => {
                let cut = self.core.chance(0.5);
                return Answer::AckThenReboot { cut };
            }
            (PROG, 1) => {
                if self.core.running {
                    return Answer::Refuse(Siof::NO_CHANGE);
                }
                self.core.load_factory();
                self.core.running = false;
                return Answer::Ack {
                    extra: self.core.factory_reload_time(60),
                };
            }
            _ => {}
        }
        let changed = self.core.int(number) != Some(raw);
        self.core.set(CodeKey::new(number), raw);
        if number == CNTL {
            self.core.running = raw & 0x80 != 0;
        }
        let extra = match (eeprom && changed, p.byte_width()) {
            (false, _) => Duration::ZERO,
            (true, 1) => Duration::from_millis(60),
            (true, _) => Duration::from_millis(120),
        };
        Answer::Ack { extra }
    }

    fn power_cycle(&mut self, now: Instant, off: Duration) {
        self.core.power_cycle(now, off);
    }
}
