//! Owns the LUSTBUS broadcast of a line run (module docs of [`super`],
//! "Broadcast"; LUSTBUS 2.1, 4.2, 9.1, 11.4): which values may go to
//! address 31 and why a bus gets none, and the run of such a bus: every
//! drive to "dataset open", the common values once to address 31 (each
//! journal recording them first), then every drive to its end.

use driveset_link::Link;
use driveset_schema::{CodeKey, RawValue};

use super::bus::OnBus;
use super::drive::blank_report;
use super::parked::{FirstHalf, Parked, first_half, next_half};
use super::recovery::unfinished_at;
use super::resume::Resume;
use super::run::Ctx;
use super::timeline::{link_now, push_broadcast, push_spans};
use crate::client::DriveClient;
use crate::line::manifest::Drive;
use crate::line::report::{BusReport, DriveReport, DriveResult};

/// The values a LUSTBUS broadcast may carry for `drives` ([`super`] module docs): the
/// codes every drive's set gives the same value, CardWriteable (staged by
/// the SLOAD dataset), never a numerically compatible code (81..85, 91),
/// never a code with a role, never the handshake code itself.
pub fn lustbus_common_values(drives: &[&Drive]) -> Vec<(CodeKey, RawValue)> {
    let Some(first) = drives.first() else {
        return Vec::new();
    };
    let schema = &first.schema;
    first
        .set
        .values
        .iter()
        .filter(|(k, _)| k.subcode.is_none())
        .filter(|(k, _)| {
            schema
                .code(k.number)
                .is_some_and(|c| crate::client::lustbus::not_broadcast(schema, c).is_none())
        })
        .filter(|(k, v)| drives[1..].iter().all(|m| m.set.values.get(k) == Some(*v)))
        .map(|(k, v)| (*k, v.clone()))
        .collect()
}

/// Why a LUSTBUS bus gets no broadcast, checked before anything is sent;
/// `None`: it may (the values are then chosen per drive after the datasets
/// are open). `listed`: every drive the manifest puts on the bus.
pub(super) fn lustbus_broadcast_refusal(
    drives: &[&Drive],
    listed: &[&Drive],
    link: &Link,
    ctx: &Ctx<'_>,
) -> Option<String> {
    if let Some(why) = bus_refusal(drives, listed) {
        return Some(why);
    }
    let Link::Bytes(b) = link else {
        return Some("not a character line".into());
    };
    // Every address, listed or not: a drive with an unfinished transaction
    // must not take values outside its recovery.
    let (bus_id, port) = (b.bus_id(), b.port().to_string());
    let open = unfinished_at(ctx, &bus_id, &port, 0..=30);
    if !open.is_empty() {
        return Some(format!(
            "the bus has unfinished journals ({}); they are recovered drive by drive first",
            open.join(", ")
        ));
    }
    if lustbus_common_values(drives).is_empty() {
        return Some("the drives share no CardWriteable value".into());
    }
    None
}

/// Why the drives of a bus rule a broadcast out: a drive that executes
/// every broadcast as its own write, a drive left out of the run, fewer
/// than two drives, a schema learned first or not shared, a family without
/// dataset downloads.
fn bus_refusal(drives: &[&Drive], listed: &[&Drive]) -> Option<String> {
    let vf: Vec<&str> = listed
        .iter()
        // a drive that executes every SELECT to address 31 as its own write
        .filter(|d| d.schema.family.descriptor().broadcast_as_own)
        .map(|d| d.name.as_str())
        .collect();
    if !vf.is_empty() {
        return Some(format!(
            "refused: the bus also has VF1000 drives ({}), which would execute every SELECT to address 31 as a write of their own parameter of that number (LUSTBUS 4.2)",
            vf.join(", ")
        ));
    }
    let left_out: Vec<&str> = listed
        .iter()
        .filter(|d| !drives.iter().any(|s| s.name == d.name))
        .map(|d| d.name.as_str())
        .collect();
    if !left_out.is_empty() {
        return Some(format!(
            "address 31 reaches every device on the bus, and {} are not part of this run (--only / --skip): they would take the values outside any transaction",
            left_out.join(", ")
        ));
    }
    if drives.len() < 2 {
        return Some("fewer than two drives: nothing to share".into());
    }
    if let Some(d) = drives.iter().find(|d| d.learn_from.is_some()) {
        return Some(format!(
            "drive `{}` has its schema learned first; the broadcast needs every drive's schema up front",
            d.name
        ));
    }
    if let Some(d) = drives.iter().find(|d| d.schema.id != drives[0].schema.id) {
        return Some(format!(
            "the drives do not share one schema (`{}` has `{}`, `{}` has `{}`)",
            drives[0].name, drives[0].schema.id, d.name, d.schema.id
        ));
    }
    // the family's dataset handshake (MC6000/7000 80-SLOAD) carries the broadcast
    if drives[0].schema.family.descriptor().dataset.is_none() {
        return Some("broadcasts go into MC6000/7000 dataset downloads only".into());
    }
    None
}

/// A LUSTBUS bus with `--broadcast-common` (module docs of [`super`],
/// "Broadcast"): every drive to "dataset open", the common values once to
/// address 31, then every drive to its end. Gives the drives' reports and
/// whether the bus failed.
pub(super) fn run_lustbus_broadcast(
    on: &OnBus<'_>,
    resume: &Resume,
    drives: &[&Drive],
    link: &mut Link,
    report: &mut BusReport,
) -> (Vec<DriveReport>, bool) {
    let mut tally = Tally {
        done: vec![None; drives.len()],
        count: 0,
        failed: false,
    };
    let (mut parked, mut why_not) = open_datasets(on, resume, drives, link, report, &mut tally);
    // the codes every waiting drive stages, with the common value
    let codes: Vec<(CodeKey, RawValue)> = lustbus_common_values(drives)
        .into_iter()
        .filter(|(k, _)| parked.iter().all(|(_, p)| p.tx.staged().contains(k)))
        .collect();
    if why_not.is_none() && codes.is_empty() {
        why_not = Some("no common value is to be written on every drive".into());
    }
    if why_not.is_none() {
        match record_broadcast(&mut parked, &codes) {
            Ok(()) => send(on, parked[0].1.d, &codes, link, report),
            Err(why) => why_not = Some(why),
        }
    }
    let bus = on.bus;
    match &why_not {
        Some(w) => on.ctx.warn(format!(
            "bus `{}`: no broadcast (address 31): {w}; values were written drive by drive",
            bus.name
        )),
        None => on.ctx.warn(format!(
            "bus `{}`: {} value(s) common to its {} drives sent once to address 31 (broadcast, no receipt) inside each drive's dataset download; every value verified drive by drive",
            bus.name,
            codes.len(),
            parked.len()
        )),
    }
    // every drive's own dataset writes and SLOAD = -2, then every drive's
    // poll, writes and verification: each drive checks and stores its
    // dataset while the bus serves the others
    for last in [false, true] {
        let mut again = Vec::new();
        for (i, p) in parked {
            let name = p.d.name.clone();
            match next_half(bus, p, link, on.ctx, resume, last) {
                FirstHalf::Parked(p) => again.push((i, *p)),
                FirstHalf::Done(r, spans, f) => {
                    push_spans(report, on.start, &name, spans);
                    tally.done(on, i, *r, f.is_some());
                }
            }
        }
        parked = again;
    }
    let out = tally
        .done
        .into_iter()
        .zip(drives)
        .map(|(r, d)| r.unwrap_or_else(|| blank_report(d, bus, DriveResult::Failed)))
        .collect();
    (out, tally.failed)
}

/// The drives of a broadcast bus as they end: their reports by position,
/// how many ended, whether one failed the bus.
struct Tally {
    done: Vec<Option<DriveReport>>,
    count: usize,
    failed: bool,
}

impl Tally {
    /// Drive `i` ended with `r`; `fails_bus`: its failure bears on the bus.
    fn done(&mut self, on: &OnBus<'_>, i: usize, r: DriveReport, fails_bus: bool) {
        self.failed |= fails_bus;
        self.count += 1;
        on.drive_done(self.count, &r);
        self.done[i] = Some(r);
    }
}

/// Every drive's first half: the drives parked at "dataset open" (with
/// their positions), the others done; and the first reason found why the
/// bus then gets no broadcast.
fn open_datasets<'d>(
    on: &OnBus<'_>,
    resume: &Resume,
    drives: &[&'d Drive],
    link: &mut Link,
    report: &mut BusReport,
    tally: &mut Tally,
) -> (Vec<(usize, Parked<'d>)>, Option<String>) {
    let mut parked: Vec<(usize, Parked<'_>)> = Vec::new();
    let mut why_not: Option<String> = None;
    for (i, d) in drives.iter().enumerate() {
        match first_half(on.bus, d, link, on.ctx, resume) {
            FirstHalf::Done(r, spans, f) => {
                push_spans(report, on.start, &d.name, spans);
                why_not.get_or_insert_with(|| match r.result {
                    DriveResult::AlreadyVerified | DriveResult::Unchanged => format!(
                        "`{}` already holds its set and opens no dataset download",
                        d.name
                    ),
                    _ => format!("`{}` did not reach its dataset download", d.name),
                });
                tally.done(on, i, *r, f.is_some());
            }
            FirstHalf::Parked(p) => {
                if !p.dataset {
                    why_not.get_or_insert_with(|| {
                        format!("`{}` stages no value in a dataset download", d.name)
                    });
                }
                parked.push((i, *p));
            }
        }
    }
    (parked, why_not)
}

/// Every waiting drive's journal records the codes the broadcast sends,
/// made durable before it goes out; when one cannot, none keeps them and
/// the reason is given.
fn record_broadcast(
    parked: &mut [(usize, Parked<'_>)],
    codes: &[(CodeKey, RawValue)],
) -> Result<(), String> {
    let keys: Vec<CodeKey> = codes.iter().map(|(k, _)| *k).collect();
    for (_, p) in parked.iter_mut() {
        if let Err(e) = p.tx.expect_broadcast(&keys) {
            let why = format!(
                "`{}`: the journal could not record the broadcast: {}",
                p.d.name,
                e.error()
            );
            for (_, p) in parked.iter_mut() {
                p.tx.cancel_broadcast();
            }
            return Err(why);
        }
    }
    Ok(())
}

/// One SELECT per value to address 31 (client of drive `first`), nothing
/// awaited but the longest reaction time; the bus timeline shows it under
/// `address 31`. What did not go out is found missing and written drive by
/// drive.
fn send(
    on: &OnBus<'_>,
    first: &Drive,
    codes: &[(CodeKey, RawValue)],
    link: &mut Link,
    report: &mut BusReport,
) {
    let t0 = link_now(link);
    let res =
        crate::connect::lustbus_on(link, first.schema.clone(), first.address, &on.bus.connect())
            .and_then(|mut c| {
                for (k, v) in codes {
                    c.broadcast(*k, v)?;
                }
                c.finish()
            });
    let t1 = link_now(link);
    push_broadcast(report, on.start, "address 31".into(), (t0, t1));
    if let Err(e) = res {
        on.ctx.warn(format!(
            "bus `{}`: the broadcast stopped: {e}; each drive writes what did not land",
            on.bus.name
        ));
    }
}
