//! Owns carrying out a plan of `driveset address`: the journal first, then
//! the address written and verified at the new address (and that nothing
//! answers at the old one), then the rate written, activated where the
//! family activates it online (MC6000/7000 4-PROG = 111,
//! `lustbus-protocol.txt` §11.5) and read back. [`finish`] is also how
//! [`recover()`](super::recover()) completes a change.

use std::path::Path;

use driveset_link::Link;
use driveset_schema::{BusProtocol, RawValue};

use super::codes::{address_of_raw, bus_codes, rate_raw, shown};
use super::drive_on;
use super::probe::{bytes, now, set_rate};
use super::record::{new_journal, record_of, set_step};
use super::refusal::target;
use super::report::{Step, found_text, pairs};
use super::{AssignPlan, AssignReport, AssignStep, RateEffect};
use crate::error::{DeviceFailure, EngineError, ErrorKind, LinkFailure};
use crate::guard::{self, Permit};
use crate::journal::{JournalFile, TxnState};
use crate::plan::code_label;
use crate::scan::scan_lustbus;

/// Carry out `p` (from [`plan()`](super::plan()) on the same link):
/// journal at `journal` first, then the writes, each verified (module
/// docs).
pub fn run(link: &mut Link, p: &AssignPlan, journal: &Path) -> Result<AssignReport, EngineError> {
    let start = now(link);
    if let Some(dir) = journal.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::journal::ensure_dir(dir)?;
    }
    // an unfinished transaction of this drive (at its new address or the
    // one it is reached at) is settled first
    let dir = match journal.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    for a in [p.to, p.reached_at] {
        let found = crate::journal::unfinished_for(dir, &p.bus, &p.port, a)?;
        if !found.is_empty() {
            return Err(crate::journal::unfinished_error(
                &target(&p.port, a),
                &found,
            ));
        }
    }
    let at_ns = now(link).as_nanos();
    let mut jf = JournalFile::create(journal, new_journal(p, at_ns, record_of(p)))?;
    let result = finish(link, p, &mut jf);
    match result {
        Ok((written, verified, rate_now, rate_note)) => {
            set_step(&mut jf, AssignStep::Done)?;
            let t = now(link).as_nanos();
            jf.journal.written = written.clone();
            jf.journal.transition(
                TxnState::Complete,
                t,
                Some("address set and verified".into()),
            );
            jf.persist()?;
            Ok(AssignReport {
                plan: p.clone(),
                written,
                verified,
                rate_now,
                rate_note,
                journal: journal.display().to_string(),
                elapsed: p.elapsed + (now(link) - start),
            })
        }
        Err(e) => {
            let t = now(link).as_nanos();
            let msg = format!(
                "{e}; journal {j}: run `driveset recover {j}` (it finds the drive and finishes the change)",
                j = journal.display()
            );
            jf.journal.failure = Some(msg.clone());
            jf.journal.failure_cause = Some(crate::journal::FailureCause::of(&e));
            jf.journal.transition(TxnState::Failed, t, Some(msg));
            let _ = jf.persist();
            Err(with_journal(e, journal))
        }
    }
}

pub(super) fn with_journal(mut e: EngineError, journal: &Path) -> EngineError {
    let note = format!(
        "journal {j}: run `driveset recover {j}`",
        j = journal.display()
    );
    match &mut *e.kind {
        ErrorKind::Link(LinkFailure::NoAnswer { what, .. })
        | ErrorKind::Device(DeviceFailure::Refused { what, .. }) => {
            what.push_str(&format!(" ({note})"));
            e
        }
        ErrorKind::Link(LinkFailure::Protocol { detail, .. }) => {
            detail.push_str(&format!("; {note}"));
            e
        }
        _ => {
            let t = e.target.clone().unwrap_or_else(|| target("", 0));
            EngineError::protocol(t, "the address change", format!("{e}; {note}"))
        }
    }
}

pub(super) type Done = (Vec<String>, Vec<String>, u32, Option<String>);

/// The writes of `p` and their verification; also
/// [`recover()`](super::recover())'s way to finish (every write is
/// skipped when its value is in place already).
pub(super) fn finish(
    link: &mut Link,
    p: &AssignPlan,
    jf: &mut JournalFile,
) -> Result<Done, EngineError> {
    let schema = p.schema.clone();
    let port = p.port.clone();
    let mut written = Vec::new();
    let mut verified = Vec::new();
    let (addr_key, rate_key) = bus_codes(p.family, &schema, &port)?;
    let lustbus = p.protocol == BusProtocol::Lustbus;
    // 0. at standstill, asked where the first write goes, before it
    // (the plan asked too; a prompt may have passed since)
    let still = match p.writes.first() {
        Some(w) => {
            let mut c = drive_on(link, schema.clone(), w.address)?;
            let still = guard::standstill(c.as_mut(), p.overrides)?;
            c.finish()?;
            Some(still)
        }
        None => None,
    };
    // 1. the address
    if let (Some(w), Some(still)) = (p.writes.iter().find(|w| w.step == Step::Address), &still) {
        set_step(jf, AssignStep::Address)?;
        let mut c = drive_on(link, schema.clone(), w.address)?;
        c.write_named(w.key, &w.raw, Permit::bus_address(still))?;
        c.finish()?;
        written.push(format!("{} = {} at address {}", w.code, w.value, w.address));
    }
    // verify at N
    {
        let mut c = drive_on(link, schema.clone(), p.to)?;
        let got = c.read(addr_key)?;
        if address_of_raw(&schema, addr_key, &got) != Some(i64::from(p.to)) {
            return Err(EngineError::protocol(
                target(&port, p.to),
                format!("verify {}", code_label(&schema, addr_key)),
                format!(
                    "reads {} instead of {}",
                    shown(&schema, addr_key, &got),
                    p.to
                ),
            ));
        }
        let id = c.identify()?;
        if id.codes != p.identity.codes {
            return Err(EngineError::protocol(
                target(&port, p.to),
                "verify the identity at the new address",
                format!(
                    "the drive at {} identifies as {} instead of {}",
                    p.to,
                    pairs(&id),
                    pairs(&p.identity)
                ),
            ));
        }
        c.finish()?;
        verified.push(format!(
            "address {}: {} = {}, {}",
            p.to,
            code_label(&schema, addr_key),
            p.to,
            pairs(&id)
        ));
    }
    // nothing at the old own address any more
    if lustbus
        && let Some(old) = p.old_address.and_then(|a| u8::try_from(a).ok())
        && old != p.to
        && BusProtocol::Lustbus.drive_addresses().contains(&old)
    {
        let b = bytes(link, p.protocol)?;
        let found = scan_lustbus(b, &[old], &p.scan_opts())?;
        if !found.is_empty() {
            return Err(EngineError::protocol(
                target(&port, old),
                "verify the old address is free",
                format!(
                    "a device still answers at address {old}: {}",
                    found_text(&found)
                ),
            ));
        }
        verified.push(format!("nothing answers at the old address {old}"));
    }
    set_step(jf, AssignStep::AddressVerified)?;
    // 2. the rate
    let mut rate_now = p.rate;
    let mut rate_note = None;
    if let (Some(w), Some(still)) = (p.writes.iter().find(|w| w.step == Step::Rate), &still) {
        set_step(jf, AssignStep::Rate)?;
        let mut c = drive_on(link, schema.clone(), p.to)?;
        c.write_named(w.key, &w.raw, Permit::line_rate(still))?;
        written.push(format!("{} = {} at address {}", w.code, w.value, w.address));
        c.finish()?;
    }
    if let (Some(a), Some(still)) = (p.writes.iter().find(|w| w.step == Step::Activate), &still) {
        let target_rate = p.baud.unwrap_or(p.rate);
        {
            let mut c = drive_on(link, schema.clone(), p.to)?;
            c.write_named(a.key, &a.raw, Permit::activate_rate(still))?;
            c.finish()?;
        }
        written.push(format!("{} = {} at address {}", a.code, a.value, a.address));
        set_rate(link, target_rate)?;
        rate_now = target_rate;
    }
    if let (Some(b), Some(effect)) = (p.baud, p.rate_effect) {
        let want = rate_raw(&schema, rate_key, b).unwrap_or(RawValue::Int(i64::from(b)));
        let mut c = drive_on(link, schema.clone(), p.to)?;
        let got = c.read(rate_key)?;
        if got != want {
            return Err(EngineError::protocol(
                target(&port, p.to),
                format!("verify {}", code_label(&schema, rate_key)),
                format!(
                    "reads {} at {} baud instead of {}",
                    shown(&schema, rate_key, &got),
                    rate_now,
                    shown(&schema, rate_key, &want)
                ),
            ));
        }
        match effect {
            RateEffect::Online => {
                let a = c.read(addr_key)?;
                let id = c.identify()?;
                if address_of_raw(&schema, addr_key, &a) != Some(i64::from(p.to))
                    || id.codes != p.identity.codes
                {
                    return Err(EngineError::protocol(
                        target(&port, p.to),
                        format!("verify at {b} baud"),
                        format!(
                            "{} reads {}, {}",
                            code_label(&schema, addr_key),
                            shown(&schema, addr_key, &a),
                            pairs(&id)
                        ),
                    ));
                }
                verified.push(format!(
                    "at {b} baud: {} = {}, {} = {}, {}",
                    code_label(&schema, rate_key),
                    shown(&schema, rate_key, &got),
                    code_label(&schema, addr_key),
                    p.to,
                    pairs(&id)
                ));
            }
            RateEffect::AtRestart => {
                verified.push(format!(
                    "{} = {} (read back at {} baud)",
                    code_label(&schema, rate_key),
                    shown(&schema, rate_key, &got),
                    rate_now
                ));
                rate_note = Some(format!(
                    "the {} takes the new rate {b} baud at its next restart ({}); until then it answers at {} baud",
                    p.family.descriptor().title,
                    if lustbus {
                        "lustbus-protocol.txt §11.5: only a servocontroller activates a rate online"
                    } else {
                        "lecom-ab-tmd-manual.txt C0125, §4d"
                    },
                    rate_now
                ));
            }
        }
        c.finish()?;
    }
    Ok((written, verified, rate_now, rate_note))
}
