//! The core of a [`super::LustbusClient`]: one ENQUIRY or SELECT with its
//! retries, the SIOF / SERR bookkeeping and the MC EEPROM pacing around
//! every SELECT, and a read of a schema code.
//!
//! # Answer timeout and retries
//!
//! From the end of the request: the longest reaction time of section 10
//! (MC 30 ms / VF1000 60 ms with KEYPAD, 25 / 30 ms without:
//! [`super::LustbusOptions::keypad`], default with) + the reply's wire time at 10
//! bits a character + the link's allowance ([`crate::client::timing`]: measured
//! from the session's round trips, at least 10 ms, at most 1 s, 200 ms
//! before the first reply; at least the port's `?latency=` plus 10 ms,
//! [`super::LustbusOptions::latency`]). A VF1000 SELECT to an EEPROM parameter
//! (kind `eeprom`, `fsel-isel` or unknown) adds the ACK delay of section 10
//! exception 4: 60 ms for a one-byte, 120 ms for a wider parameter.
//! [`super::LustbusOptions::answer_timeout`] replaces the computed figure. No
//! answer or a garbled one: the client listens as long again for a late
//! reply (counted and dropped, [`crate::client::ClientStats::late`]), then the telegram is
//! sent again (input discarded first), [`super::LustbusOptions::tries`] times in
//! all (default 3), then [`crate::EngineError::NoAnswer`]. A value reply from
//! another address or for another CODE is a late reply too and never taken
//! for the answer.
//!
//! # SIOF / SERR (85)
//!
//! Read before the first SELECT of a session: that read clears the power-on
//! bit every start sets (section 6) and whatever else is latched. After
//! that, SIOF is read after every NAK to a SELECT (6.2 note, 9.2) and
//! decoded with the codec's [`Siof`]:
//!
//! - 0x04 EEPROM busy: wait (MC: the rest of the store time the client
//!   tracks, at least [`super::LustbusOptions::eeprom_busy_wait`], default 61 ms,
//!   since 9.2 says "> 60 ms") and repeat, at most
//!   [`super::LustbusOptions::busy_repeats`] times;
//! - 0x08 checksum: repeat (counts against `tries`);
//! - 0x01 power on: [`crate::EngineError::Restarted`] (the drive restarted since
//!   the session began; what was written is void);
//! - 0x02, 0x20, 0x40, 0x80 and undocumented bits: [`crate::EngineError::Device`]
//!   with the 9.2 cause, the raw word and the remedy;
//! - a NAK with nothing latched: repeated like a checksum error, then
//!   `Device`.
//!
//! A NAK to an ENQUIRY means "no such parameter or read-protected in the
//! current operating state" (6.1 note) and is a `Device` error; it latches
//! nothing. A public [`crate::client::DriveClient::read`] of 85 goes through the same
//! bookkeeping (the read clears the word, so the client must interpret it).
//!
//! # MC6000/7000 EEPROM pacing (sections 3, 10.2.2)
//!
//! After an ACKed SELECT to an EEPROM parameter the servo stores it in the
//! background for width x 3 x 5 ms from the ACK. [`crate::client::DriveClient::ready_for_write`]
//! reports that instant for the next EEPROM write; reads and RAM writes are
//! never held back. [`crate::client::DriveClient::write`] of an EEPROM parameter waits on
//! the link's clock only for what is left of it, so a caller that used the
//! gap for reads waits nothing. (An unknown width counts as 4 bytes.)

use std::sync::Arc;
use std::time::Duration;

use driveset_link::ByteLink;
use driveset_proto::lustbus::{
    Dialect, Enquiry, ParameterCode, ParameterType, ParameterValue, Reply, Siof, SiofAction,
    ValueText,
};
use driveset_schema::schema::StorageKind;
use driveset_schema::{Code, CodeKey, RawValue};

use super::LustbusRefusal;
use super::encoding::{parse_hex, raw_of, value_of, wire_type};
use super::line::Outcome;
use super::{LustbusClient, SIOF};
use crate::client::{code_name, device, link_error, schema_code, shown_value};
use crate::error::{DeviceCause, EngineError, SiofRegister, SiofVerdict};
use crate::guard::{self, Permit};

impl<L: ByteLink> LustbusClient<L> {
    /// One ENQUIRY with retries: `Ok(Some(text))` for a value, `Ok(None)`
    /// for NAK.
    pub(super) fn enquire(
        &mut self,
        code: ParameterCode,
        value_len: usize,
        what: &str,
    ) -> Result<Option<ValueText>, EngineError> {
        let bytes = Enquiry::new(self.address, code).encode();
        let mut last = String::new();
        for attempt in 0..self.tries() {
            if attempt > 0 {
                self.drive.line.stats.retries += 1;
            }
            // ADR STX CODE(5) '=' VALUE ETX BCC
            let timeout = self.timeout(10 + value_len);
            let out = self
                .drive
                .line
                .exchange(&bytes, self.address, Some(code), timeout, Duration::ZERO)
                .map_err(|e| link_error(&self.drive.target, e))?;
            match out {
                Outcome::Reply(Reply::Value(v)) => return Ok(Some(v.value)),
                Outcome::Reply(Reply::Nak(_)) => return Ok(None),
                Outcome::Reply(Reply::Ack(_)) => last = "ACK to an ENQUIRY".into(),
                Outcome::Garbled(g) => last = g,
                Outcome::NoAnswer => last.clear(),
            }
        }
        Err(self.no_answer(what, &last))
    }

    pub(super) fn no_answer(&self, what: &str, last: &str) -> EngineError {
        let what = if last.is_empty() {
            what.to_string()
        } else {
            format!("{what} (last answer: {last})")
        };
        EngineError::no_answer(self.drive.target.clone(), what, self.tries())
    }

    /// One SELECT with retries on no answer: `Ok(true)` ACK, `Ok(false)`
    /// NAK. `known_delay`: the drive's known extra reaction (VF1000 EEPROM
    /// ACK delay), added to the timeout.
    pub(super) fn select_once(
        &mut self,
        bytes: &[u8],
        known_delay: Duration,
        what: &str,
    ) -> Result<bool, EngineError> {
        let mut last = String::new();
        for attempt in 0..self.tries() {
            if attempt > 0 {
                self.drive.line.stats.retries += 1;
            }
            // ADR ACK / ADR NAK
            let timeout = self.timeout(2).saturating_add(known_delay);
            let out = self
                .drive
                .line
                .exchange(bytes, self.address, None, timeout, known_delay)
                .map_err(|e| link_error(&self.drive.target, e))?;
            match out {
                Outcome::Reply(Reply::Ack(_)) => return Ok(true),
                Outcome::Reply(Reply::Nak(_)) => return Ok(false),
                Outcome::Reply(Reply::Value(v)) => {
                    last = format!("a value reply ({}) to a SELECT", v.code);
                }
                Outcome::Garbled(g) => last = g,
                Outcome::NoAnswer => last.clear(),
            }
        }
        Err(self.no_answer(what, &last))
    }

    pub(super) fn siof_name(&self) -> &'static str {
        match self.family {
            Dialect::Vf1000 => "SIOF",
            Dialect::Mc => "SERR",
        }
    }

    /// [`DeviceCause::Siof`] of this family's register.
    pub(super) fn siof_cause(&self, what: &str, bits: Siof, verdict: SiofVerdict) -> EngineError {
        let register = match self.family {
            Dialect::Vf1000 => SiofRegister::Siof,
            Dialect::Mc => SiofRegister::Serr,
        };
        device(
            &self.drive.target,
            what,
            DeviceCause::Siof {
                register,
                bits,
                verdict,
            },
        )
    }

    /// Reads (and so clears) SIOF/SERR. A power-on bit after the first
    /// read of the session is [`EngineError::Restarted`].
    pub(super) fn read_siof(&mut self, during: &str) -> Result<Siof, EngineError> {
        let what = format!("read 85-{} after {during}", self.siof_name());
        let code = ParameterCode::new(SIOF).unwrap_or(ParameterCode::POSMOD);
        let text = self
            .enquire(code, 4, &what)?
            .ok_or_else(|| device(&self.drive.target, &what, DeviceCause::SiofUnreadable))?;
        let v = ParameterValue::decode(ParameterType::Usign16, self.family, text.as_bytes())
            .ok()
            .and_then(|v| u8::try_from(v.raw()).ok())
            .ok_or_else(|| {
                EngineError::protocol(
                    self.drive.target.clone(),
                    what.clone(),
                    format!("SIOF/SERR value `{text}` is not an 8-bit hex word"),
                )
            })?;
        let siof = Siof(v);
        let first = !self.siof_checked;
        self.siof_checked = true;
        if !first && siof.contains(Siof::POWER_ON) {
            self.drive.line.stats.restarts += 1;
            self.eeprom_busy_until = None;
            self.dataset_open = false;
            return Err(EngineError::restarted(
                self.drive.target.clone(),
                during.to_string(),
            ));
        }
        Ok(siof)
    }

    pub(super) fn ensure_session(&mut self, during: &str) -> Result<(), EngineError> {
        if !self.siof_checked {
            // The start-of-session read: whatever was latched (power on
            // after every start, section 6) is cleared by it.
            self.read_siof(during)?;
        }
        Ok(())
    }

    /// Whether `code` is stored in EEPROM (MC pacing, VF1000 ACK delay).
    /// Unknown kinds count as EEPROM on the VF1000 (a longer timeout only)
    /// and as RAM on the MC pacing unless the code is typed as EEPROM.
    pub(super) fn is_eeprom(code: &Code) -> bool {
        matches!(code.kind, Some(StorageKind::Eeprom))
    }

    pub(super) fn store_time(code: &Code) -> Duration {
        let w = code.width.map_or(4, |w| u32::from(w).clamp(1, 4));
        Duration::from_millis(u64::from(
            driveset_proto::lustbus::timing::mc_eeprom_store_ms(w),
        ))
    }

    /// Whether the MC pacing applies to a write of `code` now.
    pub(super) fn paced(&self, code: &Code) -> bool {
        self.family == Dialect::Mc && Self::is_eeprom(code) && !self.dataset_open
    }

    /// The SELECT path: the write guard ([`guard::check`] under
    /// `permit`), encode, pace, send, handle NAK via SIOF.
    pub(super) fn select(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        what: &str,
        nak_40_cause: Option<SiofVerdict>,
        permit: Permit,
    ) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        let cleared = guard::check(&schema, &self.drive.target, key, raw, permit)?;
        let pcode = self.code_for(key, Some(code))?;
        let ty = if is_dataset_code(&schema, key) && schema.type_of(code).is_none() {
            // 11.4 writes -1 / -2: a signed type, whatever the schema gives.
            Some(ParameterType::Integer16)
        } else {
            wire_type(&schema, code, self.family)
        };
        let Some(ty) = ty else {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::NoWireType {
                    code: code_name(&schema, key),
                    schema: schema.id.clone(),
                    family: self.family.to_string(),
                },
            ));
        };
        let RawValue::Int(n) = raw else {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::NotInteger {
                    code: code_name(&schema, key),
                    value: shown_value(&schema, key, raw),
                },
            ));
        };
        let value = value_of(ty, *n)
            .and_then(|v| v.encode(self.family).ok())
            .ok_or_else(|| {
                EngineError::refused(
                    self.drive.target.clone(),
                    LustbusRefusal::DoesNotFit {
                        code: code_name(&schema, key),
                        value: shown_value(&schema, key, raw),
                        ty: ty.name().to_string(),
                    },
                )
            })?;
        let bytes = guard::lustbus_select(&cleared, self.address, pcode, value);
        // Section 10 exception 4 (VF1000: 60 ms one-byte, 120 ms two-byte
        // when the value changes): the family descriptor's one rule, the
        // planner's too. Whether the value changes is not known here, so
        // the answer timeout allows for it.
        let known_delay = schema
            .family
            .descriptor()
            .ack_delay(code, driveset_schema::family::ValueChange::Differs);
        self.ensure_session(what)?;
        let paced = self.paced(code);
        let mut checksum_repeats = 0u32;
        let mut busy_repeats = 0u32;
        loop {
            if paced
                && let Some(until) = self.eeprom_busy_until
                && until > self.now()
            {
                self.drive.line.link.clock().sleep_until(until);
            }
            if self.select_once(&bytes, known_delay, what)? {
                if paced {
                    self.eeprom_busy_until = Some(self.now() + Self::store_time(code));
                }
                return Ok(());
            }
            let siof = self.read_siof(what)?;
            match siof.action() {
                SiofAction::RepeatAfter { wait_ms } => {
                    busy_repeats += 1;
                    if busy_repeats > self.opts.busy_repeats {
                        return Err(self.siof_cause(
                            what,
                            siof,
                            SiofVerdict::EepromBusy {
                                repeats: self.opts.busy_repeats,
                            },
                        ));
                    }
                    let now = self.now();
                    let rest = self
                        .eeprom_busy_until
                        .map_or(Duration::ZERO, |u| u.saturating_duration_since(now));
                    // The rest of the store time this client tracks; if
                    // it knows of none (another session wrote), the
                    // section 9.2 "> 60 ms".
                    let wait = if rest.is_zero() {
                        self.opts
                            .eeprom_busy_wait
                            .max(Duration::from_millis(u64::from(wait_ms)))
                    } else {
                        rest
                    };
                    self.drive.line.link.clock().sleep(wait);
                    self.drive.line.stats.retries += 1;
                }
                SiofAction::Repeat | SiofAction::None => {
                    checksum_repeats += 1;
                    if checksum_repeats >= self.tries() {
                        let verdict = if siof.is_empty() {
                            SiofVerdict::Unrecorded
                        } else {
                            SiofVerdict::Checksum
                        };
                        return Err(self.siof_cause(what, siof, verdict));
                    }
                    self.drive.line.stats.retries += 1;
                }
                SiofAction::RestartTransaction => {
                    // read_siof reports a power-on bit itself; kept for
                    // completeness.
                    return Err(EngineError::restarted(
                        self.drive.target.clone(),
                        what.to_string(),
                    ));
                }
                SiofAction::Fail => {
                    let verdict = match nak_40_cause {
                        Some(v) if siof.contains(Siof::NO_CHANGE) => v,
                        _ => SiofVerdict::Failed,
                    };
                    return Err(self.siof_cause(what, siof, verdict));
                }
            }
        }
    }

    /// Reads a code; `what` names the operation.
    pub(super) fn read_code(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        if key.number == SIOF && key.subcode.is_none() {
            let s = self.read_siof("a read of SIOF/SERR")?;
            return Ok(RawValue::Int(i64::from(s.0)));
        }
        let pcode = self.code_for(key, Some(code))?;
        let len = self.value_len(Some(code), true);
        let text = self.enquire(pcode, len, what)?.ok_or_else(|| {
            device(
                &self.drive.target,
                what,
                DeviceCause::NoSuchParameter {
                    parameter: pcode.to_string(),
                },
            )
        })?;
        let ty = if is_dataset_code(&schema, key) && schema.type_of(code).is_none() {
            Some(ParameterType::Integer16)
        } else {
            wire_type(&schema, code, self.family)
        };
        let raw = match ty {
            Some(ty) => ParameterValue::decode(ty, self.family, text.as_bytes())
                .map(|v| raw_of(&v))
                .map_err(|e| e.to_string()),
            None => parse_hex(text.as_bytes()).ok_or_else(|| "not a hex number".to_string()),
        }
        .map_err(|e| {
            EngineError::protocol(
                self.drive.target.clone(),
                what.to_string(),
                if schema.is_password(code) {
                    format!("the VALUE (password, not shown) does not decode: {e}")
                } else {
                    format!("VALUE `{text}` does not decode: {e}")
                },
            )
        })?;
        Ok(RawValue::Int(raw))
    }
}

/// Whether `key` is the family's dataset handshake code (MC 80-SLOAD,
/// section 11.4: [`driveset_schema::family::Descriptor::dataset_code`]).
pub(super) fn is_dataset_code(schema: &driveset_schema::Schema, key: CodeKey) -> bool {
    key.subcode.is_none() && schema.family.descriptor().dataset_code() == Some(key.number)
}

#[cfg(test)]
mod tests {
    use driveset_schema::{CodeKey, Registry};

    use super::is_dataset_code;

    /// The handshake code is the descriptor's: MC 80-SLOAD, no code of a
    /// VF1000 (which has no handshake), never a subcode.
    #[test]
    fn the_dataset_code_is_the_descriptors() {
        let reg = Registry::builtin().expect("built-in schemas");
        let mc = reg.get("lust-mc6000").expect("mc6000");
        let vf = reg.get("lust-vf1000").expect("vf1000");
        assert!(is_dataset_code(&mc, CodeKey::new(80)));
        assert!(!is_dataset_code(&mc, CodeKey::new(81)));
        assert!(!is_dataset_code(
            &mc,
            CodeKey {
                number: 80,
                subcode: Some(1)
            }
        ));
        assert!(!is_dataset_code(&vf, CodeKey::new(80)));
    }
}
