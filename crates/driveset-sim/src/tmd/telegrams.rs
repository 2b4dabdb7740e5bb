//! The Tmd's LECOM slave side (manual section 8): addressing (8.A-8.D),
//! RECEIVE (8.H), SEND / BROADCAST (8.I, 8.J) and the line's bytes.

use super::*;

impl TmdDrive {
    // ----------------------------------------------------------------------
    // Addressing (8.A-8.D)

    /// The addressing state of C0249 / C0248 (8.B, 8.C).
    pub(super) fn addressing(&self) -> StandardAddressing {
        StandardAddressing {
            bank: u8::try_from(self.vd(C0249))
                .ok()
                .and_then(|b| CodeBank::new(b).ok())
                .unwrap_or_default(),
            input_selection: u8::try_from(self.vd(C0248)).unwrap_or(0),
        }
    }

    /// The table key a code field names: [`StandardAddressing::resolve`]
    /// under the drive's C0249 / C0248 (the one mapping `driveset decode`
    /// uses as well).
    pub(super) fn resolve(&self, code: CodeAddress) -> Result<CodeKey, Nak> {
        let (number, sub) = self.addressing().resolve(code);
        let (number, sub) = (u32::from(number), u32::from(sub));
        let key = if sub == 0 {
            CodeKey::new(number)
        } else {
            CodeKey::sub(number, sub)
        };
        let seen = |k: &CodeKey| !self.hidden.contains(k);
        if self.table.get(key).is_some() && seen(&key) {
            Ok(key)
        } else if sub != 0
            && self
                .table
                .iter()
                .any(|p| p.key.number == number && seen(&p.key))
        {
            Err(Nak::NO_SUBCODE)
        } else {
            Err(Nak::NO_CODE)
        }
    }

    pub(super) fn own_address(&self) -> Option<ControllerAddress> {
        u8::try_from(self.vd(C0009))
            .ok()
            .and_then(ControllerAddress::new)
            .filter(|a| !a.is_broadcast())
    }

    // ----------------------------------------------------------------------
    // RECEIVE (8.H)

    /// The answer to a RECEIVE of `code` (8.H a): the value, or "no such
    /// code".
    pub(super) fn read(&mut self, code: CodeAddress) -> Response {
        let value = self.resolve(code).and_then(|key| {
            if self.refused_reads.contains(&key) {
                return Err(Nak::NO_CODE);
            }
            self.wire_value(key).ok_or(Nak::NO_CODE)
        });
        match value {
            Ok(value) => Response::Value { code, value },
            Err(nak) => {
                self.record(Some(nak));
                Response::NoSuchCode { code }
            }
        }
    }

    /// A held value in the code's LECOM format: VD shortest form, VH with
    /// the code's width (8.E), VS text.
    pub(super) fn wire_value(&self, key: CodeKey) -> Option<Value> {
        let p = self.table.get(key)?;
        let raw = self.values.get(&key)?;
        to_wire(p.ty.unwrap_or(ValueType::VD), p.width, raw)
    }

    // ----------------------------------------------------------------------
    // SEND / BROADCAST (8.I, 8.J)

    /// Carries out a SEND or BROADCAST of `value` to `code`: `Ok` = ACK.
    /// Checks in order: the code exists (cause 4), is writable (6: read-only,
    /// program source of C0001, running), the value has the code's format
    /// and range (5), the cross-code rules hold (5).
    pub(super) fn write(&mut self, code: CodeAddress, value: &Value) -> Result<(), Nak> {
        let key = self.resolve(code)?;
        let p = self.table.get(key).ok_or(Nak::NO_CODE)?;
        if !p.writable() {
            return Err(Nak::READ_ONLY);
        }
        if !self.lecom_may_write(key.number) {
            return Err(Nak::NO_ACCESS);
        }
        if self.running && (key.number == C0002 || p.access == Access::Standstill) {
            return Err(Nak::NO_ACCESS);
        }
        let ty = p.ty.unwrap_or(ValueType::VD);
        let raw = from_wire(ty, value)?;
        self.table.check_write(key, &raw).map_err(|r| match r {
            Refusal::NoSuchCode => Nak::NO_CODE,
            Refusal::ReadOnly => Nak::READ_ONLY,
            Refusal::NotNow => Nak::NO_ACCESS,
            Refusal::WrongType => Nak::DATA_TYPE,
            Refusal::OutOfRange { .. } => Nak::INVALID,
        })?;
        if let (RawValue::Int(v), Some(c)) = (&raw, self.table.schema().code(key.number))
            && c.values.is_some()
            && self.table.schema().enum_label(c, *v).is_none()
        {
            return Err(Nak::INVALID);
        }
        // Numbers the protocol uses as integers (address, subcode, bank).
        if matches!(key.number, C0009 | C0248 | C0249)
            && let RawValue::Int(v) = raw
            && (v % VD != 0 || (key.number == C0009 && !is_station(v / VD)))
        {
            return Err(Nak::INVALID);
        }
        let mut tentative = self.values.clone();
        tentative.insert(key, raw.clone());
        let mut trip_cfg = false;
        for v in self.rule_violations(&tentative) {
            match (v, self.options.cfg_reaction) {
                (Violation::Distinct, CfgReaction::Trip) => trip_cfg = true,
                _ => return Err(Nak::INVALID),
            }
        }
        self.apply(key, raw)?;
        if trip_cfg {
            self.trip(FAULT_CFG);
        }
        Ok(())
    }

    /// §4e / §4f / §5: which codes LECOM may write under the current C0001.
    pub(super) fn lecom_may_write(&self, number: u32) -> bool {
        let source = self.control_source();
        match number {
            C0248 | C0249 => true,
            C0040 | C0043 => (0..=3).contains(&source),
            C0135 => source == 3,
            _ => source == 2 || source == 3,
        }
    }

    /// Stores a checked value and carries out its effect.
    pub(super) fn apply(&mut self, key: CodeKey, raw: RawValue) -> Result<(), Nak> {
        let old = self.values.get(&key).and_then(as_int).unwrap_or(0);
        let new = as_int(&raw).unwrap_or(0);
        match key.number {
            C0002 => match new / VD {
                0 => {}
                1 => {
                    self.load_lenze_setting();
                    return Ok(());
                }
                // The manual gives neither the 60 Hz nor an OEM setting.
                _ => return Err(Nak::GENERAL),
            },
            C0043 if old == 0 && new != 0 => {
                self.values.insert(key, raw);
                self.fault_reset();
                self.refresh();
                return Ok(());
            }
            C0135 if old & CW_TRIP_RESET == 0 && new & CW_TRIP_RESET != 0 => {
                self.values.insert(key, raw);
                self.fault_reset();
                self.refresh();
                return Ok(());
            }
            _ => {}
        }
        self.values.insert(key, raw);
        self.refresh();
        Ok(())
    }

    /// C0002 = 1: Table 1's factory values, keeping the communication
    /// settings C0001, C0009, C0125 and the read-only codes.
    pub(super) fn load_lenze_setting(&mut self) {
        let factory = self.table.factory_state();
        for p in self.table.iter() {
            if !p.writable() || matches!(p.key.number, C0001 | C0009 | C0125) {
                continue;
            }
            if let Some(v) = factory.get(&p.key) {
                self.values.insert(p.key, v.clone());
            }
        }
        self.set_int(C0002, 0);
        self.refresh();
    }

    // ----------------------------------------------------------------------
    // The line

    pub(super) fn remember(&mut self, byte: u8, parity_ok: bool) {
        if self.history.is_empty() {
            self.history_start = self.decoder.position();
        }
        if self.history.len() == HISTORY {
            self.history.pop_front();
            self.history_start += 1;
        }
        self.history.push_back((ascii::mask7(byte), parity_ok));
    }

    /// The bytes of `range` still in the history.
    pub(super) fn frame_bytes(&self, range: &std::ops::Range<u64>) -> Vec<(u8, bool)> {
        let from = range.start.max(self.history_start);
        let skip = usize::try_from(from - self.history_start).unwrap_or(usize::MAX);
        let take = usize::try_from(range.end.saturating_sub(from)).unwrap_or(0);
        self.history.iter().skip(skip).take(take).copied().collect()
    }

    /// What a finished frame means for this drive; `None` = no answer.
    pub(super) fn on_frame(
        &mut self,
        bytes: &[(u8, bool)],
        result: Result<HostFrame, StreamError>,
    ) -> Option<Response> {
        let me = self.own_address();
        let parity_bad = bytes.iter().any(|&(_, ok)| !ok);
        let address = match bytes {
            [(EOT, _), (a1, _), (a2, _), ..] => ControllerAddress::from_ascii([*a1, *a2]).ok(),
            _ => None,
        }?;
        // Who the frame is for (8.F, 8.J): this station, or a broadcast
        // reaching it. A drive above 99 is reached by 00 only.
        let station = me.is_some_and(|m| address == m);
        let reached = station
            || address == ControllerAddress::ALL
            || me.is_some_and(|m| address.is_broadcast() && address.reaches(m));
        if !reached {
            return None;
        }
        let send_shaped = matches!(bytes.get(3), Some((STX, _)));
        match result {
            Ok(HostFrame::EndOfTransmission) => None,
            Ok(HostFrame::Telegram(Telegram::Receive(r))) => {
                if !station {
                    return None;
                }
                if parity_bad {
                    // 8.J b: a parity fault on ENQ itself gets no answer.
                    if matches!(bytes.last(), Some((ENQ, false))) {
                        self.record(Some(Nak::PARITY));
                        return None;
                    }
                    self.record(Some(Nak::PARITY));
                    return Some(Response::ChecksumFault { code: r.code });
                }
                Some(self.read(r.code))
            }
            Ok(HostFrame::Telegram(Telegram::Send(s))) => {
                let outcome = if parity_bad {
                    Err(Nak::PARITY)
                } else {
                    self.write(s.code, &s.value)
                };
                if outcome.is_ok() && self.resolve(s.code).is_ok_and(|k| k.number == C0009) {
                    self.address_assigned = true;
                }
                self.record(outcome.err());
                station.then_some(if outcome.is_ok() {
                    Response::Ack
                } else {
                    Response::Nak
                })
            }
            Ok(HostFrame::Telegram(Telegram::Broadcast(b))) => {
                let outcome = if parity_bad {
                    Err(Nak::PARITY)
                } else {
                    self.write(b.code, &b.value)
                };
                self.record(outcome.err());
                None
            }
            Err(e) => {
                let (nak, answer) = match e {
                    StreamError::Frame(FrameError::BadBcc { .. }) => (
                        if parity_bad {
                            Nak::PARITY
                        } else {
                            Nak::CHECKSUM
                        },
                        true,
                    ),
                    StreamError::Frame(FrameError::ReceiveToBroadcast { .. }) => return None,
                    _ if parity_bad => (Nak::PARITY, true),
                    StreamError::Frame(FrameError::Code(_)) => (Nak::NO_CODE, true),
                    StreamError::Frame(FrameError::CodeLength { .. }) => (Nak::FRAME, true),
                    StreamError::Frame(FrameError::Value(v)) => (Nak::of_value_error(v), true),
                    StreamError::Interrupted { found: EOT, .. } => (Nak::INTERRUPTED, false),
                    StreamError::Overlong { .. } => (Nak::TOO_LONG, false),
                    StreamError::Garbage { .. } => return None,
                    _ => (Nak::FRAME, false),
                };
                self.record(Some(nak));
                // Only a complete SEND-shaped frame (ETX and BCC received)
                // to this station gets a NAK (8.I a); everything else goes
                // unanswered (8.J b).
                (answer && send_shaped && station).then_some(Response::Nak)
            }
        }
    }
}
