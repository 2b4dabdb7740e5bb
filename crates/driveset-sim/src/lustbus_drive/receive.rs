//! The LUSTBUS slave side: one character from the line into a model
//! (section 3 receiver, addressing 4.2 / 9.1, BCC and parity), the reply
//! it sends (section 6), and the [`ByteDrive`] impl both families share.

use super::*;

/// One character from the line into a model (section 3: the receiver is a
/// state machine reset by EOT, without timeouts).
///
/// - Off or booting: nothing is heard (section 8.1).
/// - Address (sections 4.2, 9.1): the own address and 0 ('@') are executed
///   and answered (the reply carries the address the host used); 31 (`_`,
///   broadcast) SELECTs are executed without a reply, broadcast ENQUIRYs
///   ignored; other addresses ignored.
/// - A SELECT with a wrong BCC is refused with NAK and SIOF/SERR 0x08
///   (sections 3, 9.2); so is a SELECT with an empty VALUE (0x80). A
///   telegram with a character that had a parity error is treated as a
///   transfer error: a SELECT gets NAK + 0x08, an ENQUIRY no answer
///   (section 3: improper telegram). Other malformed telegrams get no
///   answer (section 3).
/// - While any SIOF/SERR bit is set, every SELECT is refused with NAK
///   (sections 6, 9.2), without new bits.
fn hear<M: LustModel>(m: &mut M, now: Instant, byte: u8, parity_ok: bool) -> Heard {
    let b = mask7(byte);
    if m.core().booting(now) {
        let c = m.core();
        c.decoder.reset();
        c.telegram_adr = None;
        c.prev_byte = 0;
        return Heard::Nothing;
    }
    let (events, bad, adr) = {
        let c = m.core();
        if c.prev_byte == EOT
            && let Some(a) = Address::from_byte(b)
        {
            c.telegram_adr = Some(a);
        }
        c.prev_byte = b;
        let bad = c.parity_bad || !parity_ok;
        let events: Vec<_> = c.decoder.push(b).collect();
        c.parity_bad = if b == EOT {
            !parity_ok
        } else if events.is_empty() {
            bad
        } else {
            false
        };
        (events, bad, c.telegram_adr)
    };
    let mut heard = Heard::Nothing;
    for ev in events {
        let h = match ev.result {
            Ok(Request::Eot) => Heard::Nothing,
            Ok(Request::Enquiry(e)) => {
                let reply = if !answers(m.core(), e.address) || bad {
                    None
                } else {
                    m.tick(now);
                    let a = m.enquiry(now, e.code);
                    finish(m, now, e.address, e.code, a)
                };
                Heard::Telegram { reply }
            }
            Ok(Request::Select(s)) => {
                let reply = if !executes(m.core(), s.address) {
                    None
                } else {
                    m.tick(now);
                    let a = if bad {
                        Answer::Refuse(Siof::CHECKSUM)
                    } else if m.core().siof().0 != 0 {
                        Answer::Nak
                    } else {
                        m.select(now, s.code, &s.value)
                    };
                    if s.code.number() == ADDRESS
                        && matches!(a, Answer::Ack { .. } | Answer::AckThenReboot { .. })
                    {
                        m.core().address_assigned = true;
                    }
                    finish(m, now, s.address, s.code, a)
                };
                Heard::Telegram { reply }
            }
            Err(FrameError::Garbage { .. }) => Heard::Nothing,
            Err(e @ (FrameError::BadBcc { .. } | FrameError::EmptyValue { .. })) => {
                let reply = match adr {
                    Some(a) if executes(m.core(), a) => {
                        let bits = if matches!(e, FrameError::BadBcc { .. }) || bad {
                            Siof::CHECKSUM
                        } else {
                            Siof::INVALID_VALUE
                        };
                        finish(m, now, a, ParameterCode::POSMOD, Answer::Refuse(bits))
                    }
                    _ => None,
                };
                Heard::Telegram { reply }
            }
            Err(_) => Heard::Telegram { reply: None },
        };
        if !matches!(h, Heard::Nothing) {
            heard = h;
        }
    }
    heard
}

/// Whether a telegram to `adr` is executed (own, 0, broadcast).
fn executes(c: &LustCore, adr: Address) -> bool {
    adr == Address::ALL || adr == Address::BROADCAST || adr.number() == c.address()
}

/// Whether a telegram to `adr` is answered (own or 0).
fn answers(c: &LustCore, adr: Address) -> bool {
    adr != Address::BROADCAST && executes(c, adr)
}

/// Builds the reply bytes for an answer and applies its side effects.
fn finish<M: LustModel>(
    m: &mut M,
    now: Instant,
    adr: Address,
    code: ParameterCode,
    a: Answer,
) -> Option<LineReply> {
    let (reply, extra, reboot) = match a {
        Answer::Value(value) => (
            Reply::Value(ValueReply {
                address: adr,
                code,
                value,
            })
            .encode()
            .to_vec(),
            Duration::ZERO,
            false,
        ),
        Answer::Ack { extra } => (Reply::Ack(adr).encode().to_vec(), extra, false),
        Answer::AckThenReboot { cut } => {
            let mut b = Reply::Ack(adr).encode().to_vec();
            if cut {
                b.truncate(1);
            }
            (b, Duration::ZERO, true)
        }
        Answer::Refuse(bits) => {
            m.core().latch(bits);
            (Reply::Nak(adr).encode().to_vec(), Duration::ZERO, false)
        }
        Answer::Nak => (Reply::Nak(adr).encode().to_vec(), Duration::ZERO, false),
    };
    let reaction = m.core().draw().saturating_add(extra);
    let wanted = adr != Address::BROADCAST;
    if reboot {
        // The reset happens right after the (possibly cut) ACK has gone out;
        // the bus sends the reply, then the drive is deaf while it boots.
        let boot = m.core().boot_time;
        m.power_cycle(now.saturating_add(reaction), boot);
    }
    if !wanted {
        return None;
    }
    Some(LineReply {
        bytes: reply,
        reaction,
    })
}

/// Both LUSTBUS families are [`ByteDrive`]s through their shared core; what
/// differs (telegram handling, the running bit) comes from `LustModel`.
impl<M: LustModel + Send + std::fmt::Debug> ByteDrive for M {
    fn family(&self) -> &'static str {
        M::FAMILY
    }

    fn address(&self) -> u8 {
        self.core_ref().address()
    }

    fn secret_codes(&self) -> Vec<u32> {
        self.core_ref().table.secret_codes()
    }

    fn hear(&mut self, now: Instant, byte: u8, parity_ok: bool) -> Heard {
        hear(self, now, byte, parity_ok)
    }

    fn power_cycle(&mut self, now: Instant, off: Duration) {
        LustModel::power_cycle(self, now, off);
    }

    fn state(&self) -> ResolvedSet {
        self.core_ref().state()
    }

    /// An ENQUIRY of `key`'s value is answered `ADR NAK`, with the bits
    /// of [`ReadRefusal::NakSiof`] latched in SIOF/SERR (LUSTBUS 9.2).
    fn refuse_read(&mut self, key: CodeKey, answer: ReadRefusal) -> Result<(), String> {
        let core = self.core();
        let bits = match answer {
            ReadRefusal::Nak => None,
            ReadRefusal::NakSiof(b) => Some(Siof::from_bits_retain(b)),
            other => {
                return Err(format!(
                    "{}: a LUSTBUS drive refuses an ENQUIRY with NAK only, not `{}`",
                    key.number,
                    other.text()
                ));
            }
        };
        if key.subcode.is_some() || core.param(key.number).is_none() {
            return Err(format!(
                "{}: no such parameter on a {}",
                key.number,
                M::FAMILY
            ));
        }
        core.refused_reads.insert(key.number, bits);
        Ok(())
    }

    fn forget(&mut self, key: CodeKey) -> Result<(), String> {
        let core = self.core();
        if key.subcode.is_some() || core.param(key.number).is_none() {
            return Err(format!(
                "{}: no such parameter on a {}",
                key.number,
                M::FAMILY
            ));
        }
        core.hidden.insert(key.number);
        Ok(())
    }

    fn describe_as(
        &mut self,
        descriptions: &BTreeMap<u32, Vec<u8>>,
        texts: &BTreeMap<(u32, u8), Vec<u8>>,
    ) -> Result<(), String> {
        let value = |what: String, v: &[u8]| ValueText::new(v).map_err(|e| format!("{what}: {e}"));
        let mut recorded = super::Recorded::default();
        for (n, v) in descriptions {
            recorded
                .descriptions
                .insert(*n, value(format!("the description of {n}"), v)?);
            // a parameter the table does not have: as the drive describes it
            if self.core_ref().param(*n).is_none() {
                let p = self.core_ref().param_described(*n, v)?;
                let core = self.core();
                core.values.insert(p.key, p.factory.clone());
                core.table.adopt(p);
            }
        }
        for ((n, i), v) in texts {
            recorded
                .texts
                .insert((*n, *i), value(format!("substitution text {i} of {n}"), v)?);
        }
        self.core().recorded = Some(recorded);
        Ok(())
    }

    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        let (word, bit) = M::RUN_BIT;
        let core = self.core();
        core.poke(key, raw)?;
        if key == CodeKey::new(word) {
            core.running = core.int(word).is_some_and(|v| v & bit != 0);
        }
        Ok(())
    }

    fn running(&self) -> bool {
        self.core_ref().running
    }

    fn set_running(&mut self, running: bool) {
        let (word, bit) = M::RUN_BIT;
        let core = self.core();
        core.running = running;
        let w = core.int(word).unwrap_or(0);
        core.set(CodeKey::new(word), if running { w | bit } else { w & !bit });
    }

    fn take_baud_change(&mut self) -> Option<u32> {
        // The MC activates a new baud rate at 4-PROG = 111 (section 11.5);
        // both families at a restart (power cycle, STAT / error reset).
        self.core().baud_change.take()
    }

    fn active_rate(&self) -> Option<u32> {
        // only a rate 81 does not say (activated online, 81 changed since)
        let core = self.core_ref();
        if core.active_baud == core.int(BAUD) {
            return None;
        }
        core.active_baud.and_then(|b| u32::try_from(b).ok())
    }

    fn address_assigned(&self) -> bool {
        self.core_ref().address_assigned
    }

    fn restore_address_assigned(&mut self) {
        self.core().address_assigned = true;
    }

    fn coded_rate(&self) -> Option<u32> {
        self.core_ref()
            .int(BAUD)
            .and_then(|b| u32::try_from(b).ok())
    }

    fn restore_rate(&mut self, baud: u32) {
        let core = self.core();
        if core.active_baud != Some(i64::from(baud)) {
            core.active_baud = Some(i64::from(baud));
            core.baud_change = Some(baud);
        }
    }
}
