//! Owns recovering a cut `driveset address`: telling its journal from an
//! upload's, finding the drive (at the new and the old address, at the
//! recorded rates and then every rate of its family), checking it is the
//! journal's drive, and finishing every step not in effect yet (each
//! idempotent, so a cut at any telegram ends fully switched).

use std::path::Path;
use std::time::Duration;

use driveset_link::Link;
use driveset_schema::{BusProtocol, CodeKey, Family, RawValue};

use super::codes::{address_of_raw, address_raw, bus_codes, rate_raw};
use super::drive_on;
use super::plan::{lecom_write, lust_write};
use super::probe::{bus_of, now, port_of, set_rate};
use super::record::set_step;
use super::refusal::{refuse, target};
use super::report::{Step, list, pairs};
use super::run::finish;
use super::{AssignPlan, AssignRecovered, AssignRefusal, AssignStep, RateEffect, Schemas};
use crate::client::Target;
use crate::error::{EngineError, LinkFailure, Refusal};
use crate::journal::{Journal, JournalFile, JournalIdentity, TxnState};
use crate::scan::ScanOptions;

/// Whether `journal` records a `driveset address` change.
pub fn is_assign_journal(journal: &Journal) -> bool {
    journal.assign.is_some()
}

/// The refusal the upload's recover gives for an address journal.
pub(crate) fn not_for_upload_recover(target: Target, journal: &Path) -> EngineError {
    EngineError::refused(
        target,
        Refusal::from(AssignRefusal::AssignJournal {
            journal: journal.display().to_string(),
        }),
    )
}

/// Finish the address change the journal at `journal_path` records, on
/// `link` (the journal's bus): find the drive at the new and the old
/// address, at the recorded rates and then every rate of its family;
/// refuse another bus or another drive (TYPE / identity); then every step
/// not in effect yet is done and verified, and the journal marked
/// complete.
pub fn recover(
    link: &mut Link,
    journal_path: &Path,
    schemas: &Schemas,
) -> Result<AssignRecovered, EngineError> {
    let mut jf = JournalFile::open(journal_path)?;
    let name = journal_path.display().to_string();
    let port = port_of(link);
    let Some(rec) = jf.journal.assign.clone() else {
        return Err(EngineError::journal(
            name,
            "it records no `driveset address` change".to_string(),
        ));
    };
    let bus = bus_of(link);
    if jf.journal.target.bus.as_deref() != Some(bus.as_str()) {
        return Err(EngineError::not_journal_drive(
            target(&port, rec.to),
            name.clone(),
            crate::journal::Mismatch::Bus,
            format!(
                "it belongs to bus `{}`, but this port reaches bus `{bus}`; nothing was sent. Recover through a port to that bus",
                jf.journal.target.bus.clone().unwrap_or_default()
            ),
        ));
    }
    if jf.journal.is_finished() {
        return Ok(AssignRecovered {
            journal: name,
            found_step: rec.step,
            found_at: (rec.to, rec.rate.unwrap_or(rec.old_rate)),
            written: Vec::new(),
            state: format!("the journal is already {}", jf.journal.state.as_str()),
        });
    }
    let protocol = rec.protocol;
    let family = Family::parse(&rec.family).map_err(|_| {
        EngineError::journal(name.clone(), format!("unknown family `{}`", rec.family))
    })?;
    let schema = schemas.get(family).ok_or_else(|| {
        refuse(
            &port,
            rec.to,
            AssignRefusal::NoSchema {
                family: family.descriptor().title.into(),
            },
        )
    })?;
    let (addr_key, rate_key) = bus_codes(family, &schema, &port)?;
    // search: addresses N then the old one; rates: new, old, then all
    let mut rates = Vec::new();
    for r in rec
        .rate
        .into_iter()
        .chain([rec.old_rate])
        .chain(family.descriptor().line_rates.rates.iter().copied())
    {
        if !rates.contains(&r) {
            rates.push(r);
        }
    }
    let addresses: Vec<u8> = if rec.from == rec.to {
        vec![rec.to]
    } else {
        vec![rec.to, rec.from]
    };
    let mut found_at = None;
    'search: for r in &rates {
        if !set_rate(link, *r)? {
            continue;
        }
        for a in &addresses {
            let mut c = drive_on(link, schema.clone(), *a)?;
            let got = c.read(addr_key);
            let _ = c.finish();
            match got {
                Ok(v) => {
                    found_at = Some((*a, *r, v));
                    break 'search;
                }
                Err(e) => match e.link_failure() {
                    Some(LinkFailure::NoAnswer { .. } | LinkFailure::Protocol { .. }) => {}
                    _ => return Err(e),
                },
            }
        }
    }
    let Some((at, rate, addr_now)) = found_at else {
        return Err(EngineError::no_answer(
            target(&port, rec.to),
            format!(
                "the search for the drive of journal {name} at address {} at {} baud",
                addresses
                    .iter()
                    .map(u8::to_string)
                    .collect::<Vec<_>>()
                    .join(" and "),
                list(&rates)
            ),
            1,
        ));
    };
    // the bus codes' types from the drive's own descriptions when the
    // schema lacks them, as the change's plan learned them
    let mut needed = vec![addr_key, rate_key];
    needed.extend(super::learn::online_command(family));
    let schema = super::learn::typed_bus_codes(link, &port, schema, at, &needed)?;
    // the same drive?
    let identity = {
        let mut c = drive_on(link, schema.clone(), at)?;
        let id = c.identify()?;
        c.finish()?;
        id
    };
    let jid = JournalIdentity::from(&identity);
    if jid.codes != jf.journal.identity.codes {
        return Err(EngineError::not_journal_drive(
            target(&port, at),
            name.clone(),
            crate::journal::Mismatch::Identity,
            AssignRefusal::NotTheDrive {
                detail: format!(
                    "the drive at address {at} identifies as {} but the journal was written for {}",
                    pairs(&identity),
                    jf.journal
                        .identity
                        .codes
                        .iter()
                        .map(|(n, v)| format!("{n} = {v}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }
            .to_string(),
        ));
    }
    // rebuild the plan from where the drive is
    let old_address = address_of_raw(&schema, addr_key, &addr_now);
    let mut writes = Vec::new();
    let write = |addr: u8, key: CodeKey, raw: RawValue, step: Step| match protocol {
        BusProtocol::Lecom => lecom_write(&schema, addr, rate, key, raw, step),
        _ => lust_write(&schema, addr, rate, key, raw, step),
    };
    if old_address != Some(i64::from(rec.to)) {
        let raw =
            address_raw(&schema, addr_key, rec.to).unwrap_or(RawValue::Int(i64::from(rec.to)));
        writes.push(write(at, addr_key, raw, Step::Address));
    }
    let mut rate_effect = None;
    if let Some(b) = rec.rate {
        let want = rate_raw(&schema, rate_key, b).unwrap_or(RawValue::Int(i64::from(b)));
        let holds = {
            let mut c = drive_on(link, schema.clone(), at)?;
            let v = c.read(rate_key)?;
            c.finish()?;
            v
        };
        if holds != want {
            writes.push(write(rec.to, rate_key, want, Step::Rate));
        }
        rate_effect = Some(RateEffect::AtRestart);
        if let Some(o) = family.descriptor().line_rates.online {
            rate_effect = Some(RateEffect::Online);
            if rate != b {
                writes.push(write(
                    rec.to,
                    CodeKey::new(o.command),
                    RawValue::Int(o.activate),
                    Step::Activate,
                ));
            }
        }
    }
    let p = AssignPlan {
        port: port.clone(),
        bus,
        protocol,
        family,
        schema_id: schema.id.clone(),
        schema: schema.clone(),
        identity,
        type_value: rec.type_value,
        reached_at: at,
        old_address,
        to: rec.to,
        rate,
        baud: rec.rate,
        rate_effect,
        scan: Vec::new(),
        scan_time: Duration::ZERO,
        elapsed: Duration::ZERO,
        writes,
        scan_opts: ScanOptions::default(),
        // recover has no overrides: a running drive is refused
        overrides: crate::overrides::Overrides::none(),
    };
    let (written, verified, rate_now, note) = finish(link, &p, &mut jf)?;
    set_step(&mut jf, AssignStep::Done)?;
    let t = now(link).as_nanos();
    jf.journal.written.extend(written.iter().cloned());
    jf.journal.transition(
        TxnState::Complete,
        t,
        Some("recover: address change finished and verified".into()),
    );
    jf.persist()?;
    let mut state = format!(
        "the drive answers at address {} at {rate_now} baud; {}",
        rec.to,
        verified.join("; ")
    );
    if let Some(n) = note {
        state.push_str("; ");
        state.push_str(&n);
    }
    Ok(AssignRecovered {
        journal: name,
        found_step: rec.step,
        found_at: (at, rate),
        written,
        state,
    })
}
