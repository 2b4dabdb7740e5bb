//! Owns the LECOM broadcast of a line run (module docs of [`super`],
//! "Broadcast"): the values every selected drive of a group (addresses
//! x1..x9) sets identically, sent once per group with MULTICAST to x0
//! before the drives are done one by one. A CAN bus gets none, with a
//! warning.

use std::collections::BTreeMap;

use driveset_link::Link;
use driveset_schema::{CodeKey, RawValue, Role};

use super::bus::OnBus;
use super::recovery::unfinished_at;
use super::timeline::{link_now, push_broadcast};
use crate::client::DriveClient;
use crate::connect;
use crate::line::manifest::{BusProtocol, Drive};
use crate::line::report::BusReport;
use crate::overrides::Override;

/// LECOM MULTICAST of the values common to every selected drive of a group.
pub(super) fn broadcast_common(
    on: &OnBus<'_>,
    drives: &[&Drive],
    link: &mut Link,
    report: &mut BusReport,
) {
    let (bus, ctx) = (on.bus, on.ctx);
    if bus.protocol != BusProtocol::Lecom {
        ctx.warn(format!(
            "bus `{}` ({}): --broadcast-common is done on LECOM and LUSTBUS buses only (the engine's {} client has no broadcast); values were written drive by drive",
            bus.name, bus.protocol, bus.protocol
        ));
        return;
    }
    for (tens, members) in groups(drives) {
        if members.len() < 2 || members.iter().any(|m| m.schema.id != members[0].schema.id) {
            continue;
        }
        let common = group_common(&members);
        if common.is_empty() {
            continue;
        }
        let t0 = link_now(link);
        if !matches!(link, Link::Bytes(_)) {
            return;
        }
        if !may_multicast(on, tens, &members, link) {
            continue;
        }
        if !multicast(on, tens, &members, &common, link) {
            continue;
        }
        let t1 = link_now(link);
        push_broadcast(report, on.start, format!("group {tens}0"), (t0, t1));
    }
}

/// The selected drives of each LECOM group (by the tens of their address;
/// addresses 0..9 are in none).
fn groups<'d>(drives: &[&'d Drive]) -> BTreeMap<u8, Vec<&'d Drive>> {
    let mut groups: BTreeMap<u8, Vec<&Drive>> = BTreeMap::new();
    for d in drives {
        if d.address >= 10 {
            groups.entry(d.address / 10).or_default().push(d);
        }
    }
    groups
}

/// The values every member's set gives the same value; never the station
/// address or the baud rate.
fn group_common(members: &[&Drive]) -> Vec<(CodeKey, RawValue)> {
    members[0]
        .set
        .values
        .iter()
        .filter(|(k, _)| {
            !matches!(
                members[0].schema.role_of(k.number),
                Some(Role::BusAddress | Role::BaudRate)
            )
        })
        .filter(|(k, v)| members[1..].iter().all(|m| m.set.values.get(k) == Some(v)))
        .map(|(k, v)| (*k, v.clone()))
        .collect()
}

/// Whether group `tens` may take a MULTICAST: no address of the group has
/// an unfinished journal (each is recovered first, drive by drive), and
/// no member runs (the per-drive upload would refuse too) unless running
/// drives are allowed; when not, a warning says why.
fn may_multicast(on: &OnBus<'_>, tens: u8, members: &[&Drive], link: &mut Link) -> bool {
    let (bus, ctx) = (on.bus, on.ctx);
    let Link::Bytes(b) = link else { return false };
    let (bus_id, port) = (b.bus_id(), b.port().to_string());
    let open = unfinished_at(ctx, &bus_id, &port, tens * 10..=tens * 10 + 9);
    if !open.is_empty() {
        ctx.warn(format!(
            "bus `{}` group {tens}0: no MULTICAST while the group has unfinished journals ({}); values were written drive by drive after recovery",
            bus.name,
            open.join(", ")
        ));
        return false;
    }
    let schema = members[0].schema.clone();
    let mut running = Vec::new();
    for m in members {
        if let Ok(mut c) = connect::lecom_on(link, schema.clone(), m.address, &bus.connect())
            && let Ok(Some(true)) = c.running()
        {
            running.push(m.name.clone());
        }
    }
    if !running.is_empty() && !ctx.opts.overrides.allows(Override::AllowRunning) {
        ctx.warn(format!(
            "bus `{}` group {tens}0: not broadcast, running: {}",
            bus.name,
            running.join(", ")
        ));
        return false;
    }
    true
}

/// One MULTICAST per common value to group `tens`; a failure stops the
/// group's (its drives then get the values one by one). `false`: no client
/// to send with (nothing sent, a warning says why).
fn multicast(
    on: &OnBus<'_>,
    tens: u8,
    members: &[&Drive],
    common: &[(CodeKey, RawValue)],
    link: &mut Link,
) -> bool {
    let schema = members[0].schema.clone();
    let mut c = match connect::lecom_on(link, schema.clone(), members[0].address, &on.bus.connect())
    {
        Ok(c) => c,
        Err(e) => {
            on.ctx.warn(e.to_string());
            return false;
        }
    };
    for (k, v) in common {
        if let Err(e) = c.multicast(tens, *k, v) {
            on.ctx.warn(format!(
                "bus `{}` group {tens}0: MULTICAST of {} failed: {e}; the drives get it one by one",
                on.bus.name,
                schema.display_code(k.number, k.subcode)
            ));
            break;
        }
    }
    let _ = c.finish();
    true
}
