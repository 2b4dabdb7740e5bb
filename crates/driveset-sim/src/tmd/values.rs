//! The Tmd's values (Table 1): reading and setting codes, the status
//! words C0068 / C0150 derived from them, the cross-code rules, the
//! fault words C0161..C0164.

use super::*;

impl TmdDrive {
    // ----------------------------------------------------------------------
    // Values

    pub(super) fn int(&self, code: u32) -> i64 {
        self.values
            .get(&CodeKey::new(code))
            .and_then(as_int)
            .unwrap_or(0)
    }

    /// A VD code's integer part.
    pub(super) fn vd(&self, code: u32) -> i64 {
        self.int(code) / VD
    }

    pub(super) fn set_int(&mut self, code: u32, raw: i64) {
        self.values.insert(CodeKey::new(code), RawValue::Int(raw));
    }

    pub(super) fn control_source(&self) -> i64 {
        self.vd(C0001)
    }

    pub(super) fn lecom_control(&self) -> bool {
        self.control_source() == 3
    }

    pub(super) fn fault(&self) -> i64 {
        self.vd(C0161)
    }

    /// Control word bits count only with C0001 = 3 (§4f).
    pub(super) fn control_word(&self) -> i64 {
        if self.lecom_control() {
            self.int(C0135)
        } else {
            0
        }
    }

    pub(super) fn quick_stop(&self) -> bool {
        self.control_word() & CW_QUICK_STOP != 0
    }

    pub(super) fn inhibited(&self) -> bool {
        self.int(C0040) == 0 || self.control_word() & CW_INHIBIT != 0
    }

    pub(super) fn ccw(&self) -> bool {
        self.control_word() & CW_ROTATION_CCW != 0
    }

    pub(super) fn above_threshold(&self) -> bool {
        self.int(C0050) > self.int(C0017)
    }

    /// C0068 (Table 1): bits 0..3 tens digit of the fault (erratum E4),
    /// 4..7 last communication error, 8 control via LECOM (C0001 = 3),
    /// 9 above threshold, 10 CCW, 11 power stage energized (running),
    /// 12 quick stop, 13 / 14 not simulated, 15 fault.
    pub(super) fn c0068(&self) -> u16 {
        let fault = self.fault();
        let mut w = u16::try_from((fault / 10).clamp(0, 15)).unwrap_or(0);
        w |= u16::from(self.comm_error.nibble() & 0xF) << 4;
        let bits = [
            (8, self.lecom_control()),
            (9, self.above_threshold()),
            (10, self.ccw()),
            (11, self.running),
            (12, self.quick_stop()),
            (15, fault != 0),
        ];
        for (bit, on) in bits {
            if on {
                w |= 1 << bit;
            }
        }
        w
    }

    /// C0150 (Table 1): 1 power stage energized, 5 above threshold C17,
    /// 6 frequency 0 Hz, 7 controller inhibit, 8..11 error (1), 12
    /// overtemperature (fault 50 "OH"), 13 DC bus overvoltage (fault 20
    /// "OU"), 14 CCW, 15 ready (no fault); 2 and 4 not simulated.
    pub(super) fn c0150(&self) -> u16 {
        let fault = self.fault();
        let mut w = 0u16;
        let bits = [
            (1, self.running),
            (5, self.above_threshold()),
            (6, self.int(C0050) == 0),
            (7, self.inhibited()),
            (8, fault != 0),
            (12, fault == 50),
            (13, fault == 20),
            (14, self.ccw()),
            (15, fault == 0),
        ];
        for (bit, on) in bits {
            if on {
                w |= 1 << bit;
            }
        }
        w
    }

    /// Brings the derived codes (C0068, C0150, C1962) up to date and stops
    /// the motor where the state forbids running.
    pub(super) fn refresh(&mut self) {
        if self.inhibited() || self.quick_stop() || self.fault() != 0 {
            self.running = false;
        }
        let s68 = i64::from(self.c0068());
        let s150 = i64::from(self.c0150());
        self.set_int(C0068, s68);
        self.set_int(C0150, s150);
        self.set_int(C1962, i64::from(self.ext_error.code()) * VD);
    }

    pub(super) fn record(&mut self, nak: Option<Nak>) {
        match nak {
            Some(n) => {
                self.comm_error = n.cause;
                self.ext_error = n.ext;
            }
            None => {
                self.comm_error = CommunicationError::NoFault;
                self.ext_error = ExtendedError::NoFault;
            }
        }
        self.refresh();
    }

    /// §5 power-up state, Table 1 C0248 / C0249 "always set to 0 when
    /// switching on"; a trip is reset by mains switching (Table 1 C0170).
    pub(super) fn power_up(&mut self) {
        self.set_int(C0248, 0);
        self.set_int(C0249, 0);
        self.set_int(C0043, 0);
        self.set_int(C0161, 0);
        self.running = false;
        self.comm_error = CommunicationError::NoFault;
        self.ext_error = ExtendedError::NoFault;
        if self.lecom_control() {
            let cw = self.int(C0135);
            if self.vd(C1920) == 0 {
                self.set_int(C0135, cw | CW_QUICK_STOP);
            } else {
                self.set_int(C0040, 0);
            }
        }
        if self.cfg_violated() {
            self.set_int(C0161, i64::from(FAULT_CFG) * VD);
        }
        let baud = self.int(C0125);
        if baud != self.active_baud {
            self.active_baud = baud;
            self.baud_change = baud_rate(baud);
        }
        self.decoder = TelegramDecoder::new();
        self.history.clear();
        self.history_start = 0;
        self.refresh();
    }

    /// Whether C0007 breaks the schema's distinct-fields rule.
    pub(super) fn cfg_violated(&self) -> bool {
        self.rule_violations(&self.values)
            .iter()
            .any(|r| matches!(r, Violation::Distinct))
    }

    /// The cross-code rules of the schema (`distinct-fields`,
    /// `less-or-equal`) that `values` break.
    pub(super) fn rule_violations(&self, values: &BTreeMap<CodeKey, RawValue>) -> Vec<Violation> {
        let schema = self.table.schema();
        let get = |n: u32| values.get(&CodeKey::new(n)).and_then(as_int);
        let mut out = Vec::new();
        for rule in &schema.rules {
            match rule {
                Rule::DistinctFields { code, fields, .. } => {
                    let (Some(c), Some(raw)) = (schema.code(*code), get(*code)) else {
                        continue;
                    };
                    let members: Vec<i64> = fields
                        .iter()
                        .filter_map(|f| c.bits.iter().find(|b| &b.name == f))
                        .map(|b| b.extract(raw))
                        .collect();
                    let distinct = members
                        .iter()
                        .enumerate()
                        .all(|(i, a)| members[i + 1..].iter().all(|b| a != b));
                    if !distinct {
                        out.push(Violation::Distinct);
                    }
                }
                Rule::LessOrEqual { left, right, .. } => {
                    if let (Some(l), Some(r)) = (get(*left), get(*right))
                        && l > r
                    {
                        out.push(Violation::LessOrEqual);
                    }
                }
            }
        }
        out
    }

    pub(super) fn fault_reset(&mut self) {
        let f = self.int(C0161);
        if f == 0 {
            return;
        }
        let h1 = self.int(C0162);
        let h2 = self.int(C0163);
        self.set_int(C0164, h2);
        self.set_int(C0163, h1);
        self.set_int(C0162, f);
        self.set_int(C0161, 0);
        if self.cfg_violated() {
            self.set_int(C0161, i64::from(FAULT_CFG) * VD);
        }
    }
}
