//! Owns the plan of `driveset address` (the dry run, and the first half of
//! [`assign()`](super::assign())): finding the lone drive, every check
//! before a write and the list of writes, for a LUSTBUS line
//! (`lustbus-protocol.txt` §4.2, §5.1, §5.2, §11.5) and a LECOM line
//! (`lecom-ab-tmd-manual.txt` §4c, §4d, §4e, Table 1). Nothing is written
//! here.

use std::sync::Arc;
use std::time::Duration;

use driveset_link::{Instant, Link};
use driveset_proto::lustbus::{Address, Dialect, ParameterCode};
use driveset_schema::family::{BusWriteSource, TYPE};
use driveset_schema::{BusProtocol, CodeKey, Family, RawValue, Schema};

use super::codes::{address_of_raw, address_raw, bus_codes, rate_raw, shown};
use super::drive_on;
use super::probe::{baud_of, bus_of, bytes, lecom_probe, lust_probe, now, port_of, set_rate};
use super::refusal::{check_address, check_family_rate, link_err, need_type, refuse, target};
use super::report::{PlannedWrite, Step, found_text, list};
use super::{
    AssignPlan, AssignRefusal, AssignRequest, LECOM_SEARCH, LUSTBUS_SEARCH, RateEffect, Schemas,
};
use crate::client::Identity;
use crate::client::lustbus::Heard;
use crate::error::EngineError;
use crate::plan::code_label;
use crate::scan::{Found, lecom_addresses, lustbus_addresses, scan_lecom, scan_lustbus};

/// Find the drive, run every check and list the writes; nothing is
/// written (the dry run, and the first half of [`assign()`](super::assign())).
pub fn plan(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
) -> Result<AssignPlan, EngineError> {
    match req.protocol {
        BusProtocol::Lustbus => plan_lustbus(link, req, schemas),
        BusProtocol::Lecom => plan_lecom(link, req, schemas),
        BusProtocol::CanSdo => Err(refuse(
            &port_of(link),
            req.to,
            AssignRefusal::NotSerial {
                protocol: "CAN SDO node ids".into(),
            },
        )),
    }
}

pub(super) fn plan_lustbus(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
) -> Result<AssignPlan, EngineError> {
    let port = port_of(link);
    let protocol = BusProtocol::Lustbus;
    check_address(protocol, &port, "--to", req.to)?;
    if let Some(b) = req.baud
        && !LUSTBUS_SEARCH.contains(&b)
    {
        return Err(refuse(
            &port,
            0,
            AssignRefusal::InvalidRate {
                baud: b,
                who: "a LUSTBUS device".into(),
                rates: list(&LUSTBUS_SEARCH),
            },
        ));
    }
    bytes(link, protocol)?;
    let start = now(link);
    let opts = &req.scan;
    let type_code = ParameterCode::new(TYPE).unwrap_or(ParameterCode::POSMOD);
    // §5.1: address 0 at 9600, then every rate
    let mut garbled: Option<(u32, String)> = None;
    let mut hit: Option<(u32, Option<i64>)> = None;
    let first_rate = baud_of(link);
    for r in LUSTBUS_SEARCH {
        if !set_rate(link, r)? {
            continue;
        }
        let b = bytes(link, protocol)?;
        match lust_probe(b, Address::ALL, type_code, opts).map_err(|e| link_err(&port, 0, e))? {
            Heard::Value(v) => {
                hit = Some((r, v));
                break;
            }
            Heard::Nak => {
                hit = Some((r, None));
                break;
            }
            Heard::Garbled(g) => {
                if garbled.is_none() {
                    garbled = Some((r, g));
                }
            }
            Heard::Nothing => {}
        }
    }
    let Some((rate, type_value)) = hit else {
        if let Some((baud, heard)) = garbled {
            let e = collision(link, &port, baud, heard, opts);
            let _ = set_rate(link, first_rate);
            return Err(e);
        }
        let _ = set_rate(link, first_rate);
        return Err(EngineError::no_answer(
            target(&port, 0),
            format!(
                "an ENQUIRY of 91-TYPE at address 0 at every LUSTBUS rate ({}; lustbus-protocol.txt §5.1)",
                list(&LUSTBUS_SEARCH)
            ),
            opts.tries.max(2),
        ));
    };
    // a collision heard at the rate that answered (the other devices at
    // another rate would not answer there)
    if let Some((baud, heard)) = garbled.filter(|(b, _)| *b == rate) {
        return Err(collision(link, &port, baud, heard, opts));
    }
    // the family: the MC CODE 20091 (§5.2: the numerically compatible
    // parameters are the same; MC codes above them are not): a drive that
    // answers it speaks the MC dialect, one that does not the VF1000's
    let mc_code = ParameterCode::mc_value(91).unwrap_or(ParameterCode::POSMOD);
    let b = bytes(link, protocol)?;
    let family =
        match lust_probe(b, Address::ALL, mc_code, opts).map_err(|e| link_err(&port, 0, e))? {
            Heard::Value(_) => Family::from_dialect(Dialect::Mc),
            Heard::Garbled(g) => return Err(collision(link, &port, rate, g, opts)),
            _ => Family::from_dialect(Dialect::Vf1000),
        };
    if let Some(b) = req.baud {
        check_family_rate(&port, family, b)?;
    }
    // §5.2: the network list
    let scan_start = now(link);
    let b = bytes(link, protocol)?;
    let found = scan_lustbus(b, &lustbus_addresses(), opts)?;
    let scan_time = now(link) - scan_start;
    let schema = schemas.get(family).ok_or_else(|| {
        refuse(
            &port,
            0,
            AssignRefusal::NoSchema {
                family: family.descriptor().title.into(),
            },
        )
    })?;
    if found.len() > 1 {
        if let Some(at) = found.iter().find(|f| f.address == req.to) {
            return Err(refuse(
                &port,
                0,
                AssignRefusal::Taken {
                    address: req.to,
                    answer: format!(
                        "{}; and the line holds {} devices",
                        found_text(std::slice::from_ref(at)),
                        found.len()
                    ),
                },
            ));
        }
        return Err(refuse(
            &port,
            0,
            AssignRefusal::MoreThanOne {
                found: found_text(&found),
            },
        ));
    }
    let (addr_key, rate_key) = bus_codes(family, &schema, &port)?;
    need_type(&schema, &port, addr_key)?;
    if req.baud.is_some_and(|b| b != rate) {
        need_type(&schema, &port, rate_key)?;
    }
    // read at address 0
    let (identity, old_raw, rate_raw_now) = {
        let mut c = drive_on(link, schema.clone(), 0)?;
        let identity = c.identify()?;
        crate::guard::standstill(c.as_mut(), req.overrides)?;
        let old = c.read(addr_key)?;
        let r = if req.baud.is_some() {
            Some(c.read(rate_key)?)
        } else {
            None
        };
        c.finish()?;
        (identity, old, r)
    };
    let old_address = address_of_raw(&schema, addr_key, &old_raw);
    // the one device of the list is at N, but 82 says otherwise: another
    // device (a lone device answers at 0 and at its own address only)
    if let Some(f) = found.first()
        && f.address == req.to
        && old_address != Some(i64::from(req.to))
    {
        return Err(refuse(
            &port,
            0,
            AssignRefusal::Taken {
                address: req.to,
                answer: found_text(&found),
            },
        ));
    }
    let mut writes = Vec::new();
    if old_address != Some(i64::from(req.to)) || req.always_write_address {
        let raw =
            address_raw(&schema, addr_key, req.to).unwrap_or(RawValue::Int(i64::from(req.to)));
        writes.push(lust_write(&schema, 0, rate, addr_key, raw, Step::Address));
    }
    let mut rate_effect = None;
    if let Some(b) = req.baud {
        let want = rate_raw(&schema, rate_key, b).unwrap_or(RawValue::Int(i64::from(b)));
        let online = family.descriptor().line_rates.online;
        if b != rate || rate_raw_now.as_ref() != Some(&want) {
            writes.push(lust_write(
                &schema,
                req.to,
                rate,
                rate_key,
                want,
                Step::Rate,
            ));
            rate_effect = Some(RateEffect::AtRestart);
        }
        if let Some(o) = online
            && b != rate
        {
            writes.push(lust_write(
                &schema,
                req.to,
                rate,
                CodeKey::new(o.command),
                RawValue::Int(o.activate),
                Step::Activate,
            ));
            rate_effect = Some(RateEffect::Online);
        }
    }
    Ok(Reached {
        family,
        schema,
        identity,
        type_value,
        reached_at: 0,
        old_address,
        rate,
        rate_effect,
        scan: found,
        scan_time,
        writes,
    }
    .plan(link, req, protocol, start))
}

/// The refusal of answers at address 0 that do not decode at `baud`
/// (several devices answer, §4.2), naming who the network list (§5.2) at
/// that rate finds.
fn collision(
    link: &mut Link,
    port: &str,
    baud: u32,
    heard: String,
    opts: &crate::scan::ScanOptions,
) -> EngineError {
    let found = match set_rate(link, baud) {
        Ok(true) => bytes(link, BusProtocol::Lustbus)
            .ok()
            .and_then(|b| scan_lustbus(b, &lustbus_addresses(), opts).ok())
            .map(|f| found_text(&f))
            .unwrap_or_default(),
        _ => String::new(),
    };
    refuse(port, 0, AssignRefusal::Collision { baud, heard, found })
}

/// What a plan found at its drive; [`Reached::plan`] adds the request's
/// side of the [`AssignPlan`] (the port, the bus, the address and rate
/// asked for, the discovery's time), the same for both protocols.
struct Reached {
    family: Family,
    schema: Arc<Schema>,
    identity: Identity,
    type_value: Option<i64>,
    reached_at: u8,
    old_address: Option<i64>,
    rate: u32,
    rate_effect: Option<RateEffect>,
    scan: Vec<Found>,
    scan_time: Duration,
    writes: Vec<PlannedWrite>,
}

impl Reached {
    /// The plan of `req` on `link` for the drive reached, its discovery
    /// begun at `start` (link clock).
    fn plan(
        self,
        link: &Link,
        req: &AssignRequest,
        protocol: BusProtocol,
        start: Instant,
    ) -> AssignPlan {
        AssignPlan {
            port: port_of(link),
            bus: bus_of(link),
            protocol,
            family: self.family,
            schema_id: self.schema.id.clone(),
            schema: self.schema,
            identity: self.identity,
            type_value: self.type_value,
            reached_at: self.reached_at,
            old_address: self.old_address,
            to: req.to,
            rate: self.rate,
            baud: req.baud,
            rate_effect: self.rate_effect,
            scan: self.scan,
            scan_time: self.scan_time,
            elapsed: now(link) - start,
            writes: self.writes,
            scan_opts: req.scan.clone(),
            overrides: req.overrides,
        }
    }
}

pub(super) fn lust_write(
    schema: &Schema,
    address: u8,
    baud: u32,
    key: CodeKey,
    raw: RawValue,
    step: Step,
) -> PlannedWrite {
    let at = if address == 0 {
        "0 (@)".to_string()
    } else {
        address.to_string()
    };
    let code = crate::client::lustbus::wire_code_text(schema, key);
    let telegram = format!("LUSTBUS SELECT to address {at}, CODE {code}");
    planned(telegram, schema, address, baud, key, raw, step)
}

pub(super) fn lecom_write(
    schema: &Schema,
    address: u8,
    baud: u32,
    key: CodeKey,
    raw: RawValue,
    step: Step,
) -> PlannedWrite {
    let telegram = format!("LECOM SEND to controller {address:02}, C{:04}", key.number);
    planned(telegram, schema, address, baud, key, raw, step)
}

/// A write of `raw` to `key` at `address` and `baud` as the report shows
/// it (the code's label, the value in the schema's terms) by `telegram`,
/// which the protocol's [`lust_write`] / [`lecom_write`] name.
fn planned(
    telegram: String,
    schema: &Schema,
    address: u8,
    baud: u32,
    key: CodeKey,
    raw: RawValue,
    step: Step,
) -> PlannedWrite {
    PlannedWrite {
        telegram,
        code: code_label(schema, key),
        value: shown(schema, key, &raw),
        address,
        baud,
        key,
        raw,
        step,
    }
}

/// The family a LECOM line carries (its descriptor's only one, the Tmd):
/// checked when the crate is built, so a second LECOM family in the
/// descriptor stops the build here instead of being taken for a Tmd.
const LECOM_FAMILY: Family = match BusProtocol::Lecom.only_family() {
    Some(f) => f,
    None => panic!("the descriptor names one family on LECOM"),
};

/// The code that must let LECOM write before an address is written (the
/// LECOM family's [`BusWriteSource`], C0001 2 or 3, §4e): checked when
/// the crate is built, like [`LECOM_FAMILY`].
const LECOM_WRITE: BusWriteSource = match LECOM_FAMILY.descriptor().bus_write {
    Some(w) => w,
    None => panic!("the LECOM family's descriptor names its write source"),
};

pub(super) fn plan_lecom(
    link: &mut Link,
    req: &AssignRequest,
    schemas: &Schemas,
) -> Result<AssignPlan, EngineError> {
    let port = port_of(link);
    let protocol = BusProtocol::Lecom;
    let family = LECOM_FAMILY;
    let from = req.from.unwrap_or(1);
    check_address(protocol, &port, "--to", req.to)?;
    check_address(protocol, &port, "--from", from)?;
    if let Some(b) = req.baud {
        check_family_rate(&port, family, b)?;
    }
    bytes(link, protocol)?;
    let schema = schemas.get(family).ok_or_else(|| {
        refuse(
            &port,
            from,
            AssignRefusal::NoSchema {
                family: family.descriptor().title.into(),
            },
        )
    })?;
    let (addr_key, rate_key) = bus_codes(family, &schema, &port)?;
    need_type(&schema, &port, addr_key)?;
    let start = now(link);
    let opts = &req.scan;
    let probe_key = CodeKey::new(
        schema
            .identify
            .as_ref()
            .and_then(|i| i.codes.first().copied())
            .unwrap_or(crate::client::lecom::C0093),
    );
    // the drive at M: the port's rate first, then every Tmd rate
    let first_rate = baud_of(link);
    let mut order = vec![first_rate];
    order.extend(LECOM_SEARCH.iter().copied().filter(|r| *r != first_rate));
    let mut rate = None;
    for r in order {
        if !set_rate(link, r)? {
            continue;
        }
        let b = bytes(link, protocol)?;
        if lecom_probe(b, from, probe_key, opts)
            .map_err(|e| link_err(&port, from, e))?
            .is_some()
        {
            rate = Some(r);
            break;
        }
    }
    let Some(rate) = rate else {
        let _ = set_rate(link, first_rate);
        return Err(EngineError::no_answer(
            target(&port, from),
            format!(
                "a RECEIVE of C{:04} at controller {from:02} at every LECOM rate ({})",
                probe_key.number,
                list(&LECOM_SEARCH)
            ),
            opts.tries.max(1),
        ));
    };
    // another device on the port at all (`alone`), or at N?
    let scan_start = now(link);
    let mut found = Vec::new();
    if req.alone {
        let b = bytes(link, protocol)?;
        found = scan_lecom(b, Some(&schema), &lecom_addresses(), opts)?;
        if found.iter().any(|f| f.address != from) {
            return Err(refuse(
                &port,
                from,
                AssignRefusal::NotAlone {
                    scanned: "the LECOM stations 01..99".into(),
                    found: found_text(&found),
                },
            ));
        }
    } else if req.to != from {
        let b = bytes(link, protocol)?;
        found = scan_lecom(b, Some(&schema), &[req.to], opts)?;
        if !found.is_empty() {
            return Err(refuse(
                &port,
                from,
                AssignRefusal::Taken {
                    address: req.to,
                    answer: found_text(&found),
                },
            ));
        }
    }
    let scan_time = now(link) - scan_start;
    let (identity, c0001, old_raw, rate_now) = {
        let mut c = drive_on(link, schema.clone(), from)?;
        let identity = c.identify()?;
        crate::guard::standstill(c.as_mut(), req.overrides)?;
        let c0001 = c.read(CodeKey::new(LECOM_WRITE.code))?;
        let old = c.read(addr_key)?;
        let r = if req.baud.is_some() {
            Some(c.read(rate_key)?)
        } else {
            None
        };
        c.finish()?;
        (identity, c0001, old, r)
    };
    // §4e: 0 and 1 read only; 2 and 3 write
    let write_key = CodeKey::new(LECOM_WRITE.code);
    let program = address_of_raw(&schema, write_key, &c0001);
    if !program.is_some_and(|p| LECOM_WRITE.allows(p)) {
        return Err(refuse(
            &port,
            from,
            AssignRefusal::LecomReadOnly {
                c0001: shown(&schema, write_key, &c0001),
            },
        ));
    }
    let old_address = address_of_raw(&schema, addr_key, &old_raw);
    let mut writes = Vec::new();
    if req.to != from || old_address != Some(i64::from(req.to)) || req.always_write_address {
        let raw =
            address_raw(&schema, addr_key, req.to).unwrap_or(RawValue::Int(i64::from(req.to)));
        writes.push(lecom_write(
            &schema,
            from,
            rate,
            addr_key,
            raw,
            Step::Address,
        ));
    }
    let mut rate_effect = None;
    if let Some(b) = req.baud {
        need_type(&schema, &port, rate_key)?;
        let want = rate_raw(&schema, rate_key, b).ok_or_else(|| {
            refuse(
                &port,
                from,
                AssignRefusal::InvalidRate {
                    baud: b,
                    who: format!("schema `{}`'s C0125", schema.id),
                    rates: list(family.descriptor().line_rates.rates),
                },
            )
        })?;
        if rate_now.as_ref() != Some(&want) {
            writes.push(lecom_write(
                &schema,
                req.to,
                rate,
                rate_key,
                want,
                Step::Rate,
            ));
            rate_effect = Some(RateEffect::AtRestart);
        }
    }
    Ok(Reached {
        family,
        schema,
        identity,
        type_value: None,
        reached_at: from,
        old_address,
        rate,
        rate_effect,
        scan: found,
        scan_time,
        writes,
    }
    .plan(link, req, protocol, start))
}
