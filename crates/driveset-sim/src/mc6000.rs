//! Simulated Lust MASTERCONTROL MC6000/7000 servocontroller on LUSTBUS
//! (enhanced protocol, `lustbus-protocol.txt`).
//!
//! Table: `fictional-mc6000-demo` (the real `lust-mc6000` schema extended
//! by a FICTIONAL fixture; 250 parameters with types, kinds, widths and
//! CardWriteable flags).
//!
//! Behaviour, with the section it implements:
//!
//! - CODEs (2.4.2, 5.2): `20ppp` values, `30ppp` descriptions, `61ppp`
//!   substitution texts, `000xx` for the compatible parameters 81..85 and
//!   91. Any other CODE: SELECT NAK + SERR 0x20, ENQUIRY `ADR NAK`.
//!   PosMOD1 (49999, 11.6) is not fitted: treated as any unknown CODE.
//! - Values (2.3.2): 1..8 hex digits accepted; replies padded to two digits
//!   per byte of the parameter width (the 6.1.1.2 reply `04FA4000`).
//! - SERR (6, 9.2): power-on bit at start and after every power cycle;
//!   every SELECT NAKed while a bit is set; reading 85 returns and clears
//!   it; ENQUIRYs never set bits. Causes: 0x04 EEPROM busy, 0x08 bad BCC
//!   (or a parity error in the telegram), 0x20 no such parameter, 0x40
//!   change not permitted (read-only / RAM actual value, a standstill-only
//!   parameter while running), 0x80 invalid value (malformed, out of
//!   min/max).
//! - EEPROM parameters (3, 10.2.2, 11.2.1 kind '2'): the value is taken
//!   and ACKed at once; the EEPROM is then busy for width x 3 x 5 ms from
//!   the end of the SELECT; a further EEPROM SELECT meanwhile is NAKed with
//!   SERR 0x04 (every EEPROM write burns, changed or not).
//! - 80-SLOAD dataset download (11.4): see [`Mc6000`].
//! - 4-PROG (10 exception 1, 11.5): 1 reloads the factory settings and
//!   ACKs when done (the store time of every EEPROM parameter, width x 15
//!   ms, capped at 10 s; 81/82 are kept so the drive stays reachable;
//!   refused with 0x40 while running); 111 activates a changed 81-SBAUD
//!   (reported by `take_baud_change`). PROG itself keeps its factory value.
//! - 416-SCTL1 (7.2, 8.1.2): bit 0 set = running, clear = standstill; bit 7
//!   (error reset) is stored, the simulator has no error states.
//! - 107-UNIT / 108-STEXT / 61xxx (11.2.1, 11.3): see
//!   `LustCore::substitution_text`.
//! - Reaction times (10): 1..25 ms without KEYPAD, 1..30 ms with, drawn from
//!   the seeded generator.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::lustbus::timing::mc_eeprom_store_ms;
use driveset_proto::lustbus::{CodeMeaning, ParameterCode, Siof, ValueText};
use driveset_schema::canonical::CodeKey;
use driveset_schema::schema::{Access, Rule, StorageKind};

use crate::catalog::Family;
use crate::drive::ReactionTime;
use crate::lustbus_drive::{Answer, LustCore, LustModel, LustOptions, SIOF};

/// 80-SLOAD (section 11.4).
pub const SLOAD: u32 = 80;
/// 4-PROG (section 10 exception 1, section 11.5).
pub const PROG: u32 = 4;
/// 416-SCTL1, the LUSTBUS control word (sections 7.2, 8.1.2).
pub const SCTL1: u32 = 416;
/// 108-STEXT, the substitution text selector (section 11.3).
pub const STEXT: u32 = 108;
/// FICTIONAL cross-parameter plausibility rule of the SLOAD check: the
/// undervoltage trip level 102-UVLIM must not exceed the mains voltage
/// 101-MAINV (both invented parameters of the fixture). A violation
/// rejects the set with SLOAD = 102.
pub const FICTIONAL_RULE: (u32, u32) = (102, 101);

/// FICTIONAL time the plausibility check of a dataset takes before the
/// store starts (section 11.4 gives none, only the 10 s the host polls):
/// a fixed 20 ms plus 1 ms per staged parameter. Also the time a rejected
/// set reads -1 before SLOAD shows the parameter number.
pub fn dataset_check_time(staged: usize) -> Duration {
    Duration::from_millis(20 + staged as u64)
}

/// How long SLOAD reads -1 after `SLOAD = -2` (section 11.4: "still busy
/// testing and saving") for an accepted set: [`dataset_check_time`], then
/// the EEPROM store of every staged parameter, width x 3 x 5 ms each
/// (sections 3, 10.2.2; `mc_eeprom_store_ms`; errata L33). `widths` are
/// the staged parameters' byte widths. The engine's upload benchmark takes
/// its bound's non-overlapping store time from here.
pub fn dataset_busy_time(widths: &[u32]) -> Duration {
    let store: u64 = widths
        .iter()
        .map(|w| u64::from(mc_eeprom_store_ms(*w)))
        .sum();
    rejected_dataset_busy_time(widths) + Duration::from_millis(store)
}

/// How long SLOAD reads -1 after `SLOAD = -2` for a set the check rejects:
/// [`dataset_check_time`] only, nothing is stored.
pub fn rejected_dataset_busy_time(widths: &[u32]) -> Duration {
    dataset_check_time(widths.len())
}

/// Where the SLOAD handshake stands.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Sload {
    /// No download; SLOAD holds the last result (0 or a parameter number).
    Idle,
    /// SLOAD = -1 registered: CardWriteable values are staged.
    Staging(BTreeMap<u32, i64>),
    /// SLOAD = -2 received: checking and storing until `until`.
    Checking {
        until: Instant,
        result: Result<BTreeMap<u32, i64>, u32>,
    },
}

/// A simulated MC6000/7000.
///
/// SLOAD (section 11.4): `80 = -1` is taken only at standstill (else NAK
/// 0x40); SLOAD then reads -1 and every SELECT to a CardWriteable parameter
/// is decoded (malformed: NAK 0x80) and staged without plausibility check
/// (ACK); SELECTs to other parameters are ACKed and ignored (so the drive
/// cannot be started). `80 = -2` ends the transfer (without a download:
/// NAK 0x40) and starts the check of the complete staged set: every value
/// within its min/max, plus [`FICTIONAL_RULE`]; the first invalid parameter
/// is the lowest-numbered one. SLOAD reads -1 while checking and storing
/// ([`dataset_busy_time`]): the check ([`dataset_check_time`], FICTIONAL:
/// 20 ms + 1 ms per staged parameter), then for an accepted set the EEPROM
/// store of the staged values (width x 3 x 5 ms each, sections 3, 10.2.2),
/// after which the values are in RAM and EEPROM and SLOAD reads 0; a
/// rejected set reads -1 for the check time only (nothing is stored), then
/// the parameter number, and the old set stays active. Every SELECT during checking/storing is NAKed with SERR
/// 0x04 (EEPROM busy). A power cycle loses a staged or unstored set.
#[derive(Debug)]
pub struct Mc6000 {
    core: LustCore,
    eeprom_busy_until: Option<Instant>,
    /// The EEPROM value being saved in the background and the value its
    /// EEPROM held before (§3, §11.2.1: RAM first, the EEPROM "only as a
    /// backup"): a power cycle before `eeprom_busy_until` comes back with
    /// the old one, as the start copies EEPROM into RAM.
    saving: Option<(CodeKey, Option<i64>)>,
    sload: Sload,
}

impl Mc6000 {
    /// A drive with these options.
    pub fn new(opts: LustOptions) -> Result<Self, String> {
        let default = ReactionTime::of(Family::Mc6000, opts.keypad);
        Ok(Mc6000 {
            core: LustCore::new(Family::Mc6000, &opts, default)?,
            eeprom_busy_until: None,
            saving: None,
            sload: Sload::Idle,
        })
    }

    /// A drive at `address` with default options (seed 0, no KEYPAD).
    pub fn at(address: u8) -> Result<Self, String> {
        Mc6000::new(LustOptions::new(address))
    }

    /// The latched SERR bits (without clearing them).
    pub fn serr(&self) -> Siof {
        self.core.siof()
    }

    /// Until when the EEPROM is busy storing, if it is.
    pub fn eeprom_busy_until(&self) -> Option<Instant> {
        self.eeprom_busy_until
    }

    fn value_number(code: ParameterCode) -> Option<u32> {
        match code.meaning() {
            CodeMeaning::McValue { parameter } => Some(u32::from(parameter)),
            CodeMeaning::VfValue { .. } => {
                code.compatible_parameter().map(|c| u32::from(c.number()))
            }
            _ => None,
        }
    }

    fn sload_value(&mut self, v: i64) {
        self.core.set(CodeKey::new(SLOAD), v);
    }

    /// The plausibility check of section 11.4 (see [`Mc6000`]).
    fn check(&self, staged: &BTreeMap<u32, i64>) -> Result<(), u32> {
        let mut bad = BTreeSet::new();
        for (&n, &raw) in staged {
            match self.core.param(n) {
                Some(p) if self.core.in_range(p, raw) => {}
                _ => {
                    bad.insert(n);
                }
            }
        }
        let get = |n: u32| staged.get(&n).copied().or_else(|| self.core.int(n));
        let mut le = vec![FICTIONAL_RULE];
        for r in &self.core.table.schema().rules {
            if let Rule::LessOrEqual { left, right, .. } = r {
                le.push((*left, *right));
            }
        }
        for (left, right) in le {
            if let (Some(l), Some(r)) = (get(left), get(right))
                && l > r
            {
                bad.insert(left);
            }
        }
        match bad.first() {
            Some(&n) => Err(n),
            None => Ok(()),
        }
    }

    fn sload_select(&mut self, now: Instant, raw: i64) -> Answer {
        match raw {
            -1 => {
                if self.core.running {
                    return Answer::Refuse(Siof::NO_CHANGE);
                }
                self.sload = Sload::Staging(BTreeMap::new());
                self.sload_value(-1);
                Answer::Ack {
                    extra: Duration::ZERO,
                }
            }
            -2 => {
                let Sload::Staging(staged) = std::mem::replace(&mut self.sload, Sload::Idle) else {
                    return Answer::Refuse(Siof::NO_CHANGE);
                };
                let widths: Vec<u32> = staged
                    .keys()
                    .filter_map(|n| self.core.param(*n))
                    .map(|p| u32::from(p.byte_width()))
                    .collect();
                let result = self.check(&staged).map(|()| staged);
                let busy = if result.is_ok() {
                    dataset_busy_time(&widths)
                } else {
                    rejected_dataset_busy_time(&widths)
                };
                let until = now.saturating_add(busy);
                self.sload = Sload::Checking { until, result };
                self.sload_value(-1);
                Answer::Ack {
                    extra: Duration::ZERO,
                }
            }
            _ => Answer::Refuse(Siof::INVALID_VALUE),
        }
    }

    fn read(&mut self, number: u32) -> Answer {
        if let Some(refusal) = self.core.refused_read(number) {
            return refusal;
        }
        let Some(p) = self.core.wire_param(number).cloned() else {
            return Answer::Nak;
        };
        let Some(raw) = self.core.int(number) else {
            return Answer::Nak;
        };
        let Some(text) = self.core.encode_value(&p, raw) else {
            return Answer::Nak;
        };
        if number == SIOF {
            self.core.take_siof();
        }
        Answer::Value(text)
    }
}

impl LustModel for Mc6000 {
    const FAMILY: &'static str = "mc6000";
    const RUN_BIT: (u32, i64) = (SCTL1, 1);

    fn core(&mut self) -> &mut LustCore {
        &mut self.core
    }

    fn core_ref(&self) -> &LustCore {
        &self.core
    }

    fn tick(&mut self, now: Instant) {
        if let Sload::Checking { until, .. } = &self.sload
            && now >= *until
            && let Sload::Checking { result, .. } = std::mem::replace(&mut self.sload, Sload::Idle)
        {
            match result {
                Ok(staged) => {
                    for (n, raw) in staged {
                        self.core.set(CodeKey::new(n), raw);
                    }
                    self.sload_value(0);
                }
                Err(n) => self.sload_value(i64::from(n)),
            }
        }
    }

    fn enquiry(&mut self, _now: Instant, code: ParameterCode) -> Answer {
        if let Some(n) = Mc6000::value_number(code) {
            return self.read(n);
        }
        let text = match (code.meaning(), &self.core.recorded) {
            // a twin: what its drive sent, nothing else
            (CodeMeaning::McDescription { parameter }, Some(r)) => {
                r.descriptions.get(&u32::from(parameter)).cloned()
            }
            (CodeMeaning::SubstitutionText { parameter }, Some(r)) => {
                let index = self.core.int(STEXT).unwrap_or(0);
                u8::try_from(index)
                    .ok()
                    .and_then(|i| r.texts.get(&(u32::from(parameter), i)).cloned())
            }
            (CodeMeaning::McDescription { parameter }, None) => self
                .core
                .param(u32::from(parameter))
                .and_then(|p| self.core.mc_description(p)),
            (CodeMeaning::SubstitutionText { parameter }, None) => {
                let index = self.core.int(STEXT).unwrap_or(0);
                self.core.substitution_text(u32::from(parameter), index)
            }
            _ => None,
        };
        text.map_or(Answer::Nak, Answer::Value)
    }

    fn select(&mut self, now: Instant, code: ParameterCode, value: &ValueText) -> Answer {
        let ack = Answer::Ack {
            extra: Duration::ZERO,
        };
        let Some(number) = Mc6000::value_number(code) else {
            return Answer::Refuse(Siof::NO_PARAMETER);
        };
        let Some(p) = self.core.wire_param(number).cloned() else {
            return Answer::Refuse(Siof::NO_PARAMETER);
        };
        if matches!(self.sload, Sload::Checking { .. }) {
            return Answer::Refuse(Siof::EEPROM_BUSY);
        }
        if number != SLOAD && matches!(self.sload, Sload::Staging(_)) {
            if !p.card_writeable {
                return ack;
            }
            let Some(raw) = self.core.decode_value(&p, value) else {
                return Answer::Refuse(Siof::INVALID_VALUE);
            };
            if let Sload::Staging(staged) = &mut self.sload {
                staged.insert(number, raw);
            }
            return ack;
        }
        if !p.writable() {
            return Answer::Refuse(Siof::NO_CHANGE);
        }
        let Some(raw) = self.core.decode_value(&p, value) else {
            return Answer::Refuse(Siof::INVALID_VALUE);
        };
        if !self.core.in_range(&p, raw) {
            return Answer::Refuse(Siof::INVALID_VALUE);
        }
        if p.access == Access::Standstill && self.core.running {
            return Answer::Refuse(Siof::NO_CHANGE);
        }
        match (number, raw) {
            (SLOAD, _) => return self.sload_select(now, raw),
            (PROG, 1) => {
                if self.core.running {
                    return Answer::Refuse(Siof::NO_CHANGE);
                }
                self.core.load_factory();
                self.sload = Sload::Idle;
                self.eeprom_busy_until = None;
                self.saving = None;
                return Answer::Ack {
                    extra: self.core.factory_reload_time(15),
                };
            }
            (PROG, 111) => {
                self.core.activate_baud();
                return ack;
            }
            _ => {}
        }
        if p.kind == Some(StorageKind::Eeprom) {
            if self.eeprom_busy_until.is_some_and(|t| now < t) {
                return Answer::Refuse(Siof::EEPROM_BUSY);
            }
            let store = Duration::from_millis(u64::from(p.byte_width()) * 15);
            self.eeprom_busy_until = Some(now.saturating_add(store));
            self.saving = Some((CodeKey::new(number), self.core.int(number)));
        }
        self.core.set(CodeKey::new(number), raw);
        if number == SCTL1 {
            self.core.running = raw & 1 != 0;
        }
        ack
    }

    fn power_cycle(&mut self, now: Instant, off: Duration) {
        // a background EEPROM save cut by the power: the EEPROM still
        // holds the value before it, which the start copies into RAM
        if let Some((key, before)) = self.saving.take()
            && self.eeprom_busy_until.is_some_and(|t| now < t)
            && let Some(before) = before
        {
            self.core.set(key, before);
        }
        self.core.power_cycle(now, off);
        self.sload = Sload::Idle;
        self.eeprom_busy_until = None;
    }
}
