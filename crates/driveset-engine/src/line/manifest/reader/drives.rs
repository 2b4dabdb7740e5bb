//! The manifest reader's drives (module docs of [`super`]): each
//! `[[drive]]` checked against its bus (named, an address the protocol
//! allows, not used twice on the bus), its name (not used twice) and its
//! set (there, readable, fitting its schema, or a schema to learn), then
//! the drive built.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_schema::{CodeKey, Finding, Location, Registry, ResolvedSet, Schema, load_set};

use super::{RawBus, RawDrive, Reader};
use crate::learn::needs_learning;
use crate::line::manifest::{BusProtocol, Drive, ManifestFinding};

/// A drive's set as loaded: its schema, the set resolved, its file, the
/// schema to learn first (if any) and where the set gives its bus codes.
type LoadedSet = (
    Arc<Schema>,
    ResolvedSet,
    PathBuf,
    Option<Arc<Schema>>,
    Vec<(CodeKey, Location)>,
);

/// What the drives' checks found so far.
#[derive(Default)]
pub(super) struct Found {
    /// The drives that hold.
    pub(super) drives: Vec<Drive>,
    /// Where each (bus, address) is first given.
    seen_addr: BTreeMap<(usize, i64), Range<usize>>,
    /// Where each drive name is first given.
    seen_name: BTreeMap<String, Range<usize>>,
    /// The sets' own findings.
    pub(super) set_findings: Vec<ManifestFinding>,
    /// The findings of sets whose schema is learned from the drive.
    pub(super) learnable: Vec<ManifestFinding>,
}

impl Reader<'_> {
    /// Every drive checked (bus, address, name, set); those that hold are
    /// built.
    pub(super) fn drives(
        &mut self,
        raw_drives: &[RawDrive],
        raw_buses: &[RawBus],
        bus_by_name: &BTreeMap<String, usize>,
        dir: &Path,
        registry: &mut Registry,
    ) -> Found {
        let mut found = Found::default();
        for r in raw_drives {
            self.drive(r, raw_buses, bus_by_name, dir, registry, &mut found);
        }
        found
    }

    /// One drive: its bus, address, name and set checked; built into
    /// `found` when they hold.
    fn drive(
        &mut self,
        r: &RawDrive,
        raw_buses: &[RawBus],
        bus_by_name: &BTreeMap<String, usize>,
        dir: &Path,
        registry: &mut Registry,
        found: &mut Found,
    ) {
        let mut ok = true;
        let bus_index = self.drive_bus(r, bus_by_name);
        let protocol = bus_index.and_then(|i| raw_buses[i].protocol);
        let address = self.drive_address(r, bus_index, protocol, raw_buses, found, &mut ok);
        let name = self.drive_name(r, found, &mut ok);
        let loaded = self.drive_set(r, protocol, dir, registry, found, &mut ok);
        if let (
            true,
            Some(n),
            Some(bi),
            Some(a),
            Some((schema, set, set_path, learn_from, bus_codes)),
        ) = (ok, name, bus_index, address, loaded)
        {
            let addr_loc = r.address.as_ref().map_or(0..0, |x| x.1.clone());
            found.drives.push(Drive {
                name: n,
                bus: raw_buses[bi]
                    .name
                    .as_ref()
                    .map_or(String::new(), |x| x.0.clone()),
                bus_index: bi,
                address: a,
                set_text: r.set.as_ref().map_or(String::new(), |x| x.0.clone()),
                set_path,
                position: r.position.clone(),
                schema,
                set,
                learn_from,
                location: self.loc(&r.span),
                address_location: self.loc(&addr_loc),
                set_bus_codes: bus_codes,
            });
        }
    }

    /// The index of the bus the drive names (an unknown name is a finding).
    fn drive_bus(&mut self, r: &RawDrive, bus_by_name: &BTreeMap<String, usize>) -> Option<usize> {
        match &r.bus {
            Some((bn, span)) => match bus_by_name.get(bn) {
                Some(&i) => Some(i),
                None => {
                    let known: Vec<&str> = bus_by_name.keys().map(String::as_str).collect();
                    self.push(
                        "unknown-bus",
                        span,
                        format!("no bus is named `{bn}`"),
                        &format!(
                            "use one of the [[bus]] names: {}",
                            if known.is_empty() {
                                "(none)".into()
                            } else {
                                known.join(", ")
                            }
                        ),
                    );
                    None
                }
            },
            None => None,
        }
    }

    /// The drive's address, where its bus's protocol allows it and no
    /// other drive of the bus has it.
    fn drive_address(
        &mut self,
        r: &RawDrive,
        bus_index: Option<usize>,
        protocol: Option<BusProtocol>,
        raw_buses: &[RawBus],
        found: &mut Found,
        ok: &mut bool,
    ) -> Option<u8> {
        let mut address = None;
        if let Some((a, span)) = &r.address {
            if let Some(p) = protocol {
                match p.check_address(*a) {
                    Ok(()) => address = Some(*a as u8),
                    Err(refusal) => {
                        let (kind, rule) = (refusal.kind(), refusal.rule);
                        *ok = false;
                        self.push(
                            kind,
                            span,
                            format!(
                                "address {a} on {p} bus `{}`: {rule}",
                                r.bus.as_ref().map_or("", |b| &b.0)
                            ),
                            "give the drive its own address",
                        );
                    }
                }
            }
            if let Some(bi) = bus_index {
                if let Some(first) = found.seen_addr.get(&(bi, *a)) {
                    *ok = false;
                    let f = ManifestFinding::new(
                        "duplicate-address",
                        self.loc(span),
                        format!(
                            "address {a} is used twice on bus `{}`",
                            raw_buses[bi].name.as_ref().map_or("", |x| &x.0)
                        ),
                        "every drive on a bus needs its own address",
                    )
                    .related("first used here", self.loc(first));
                    self.findings.push(f);
                } else {
                    found.seen_addr.insert((bi, *a), span.clone());
                }
            }
        }
        address
    }

    /// The drive's name (`BUS/ADDRESS` without one), where no other drive
    /// has it.
    fn drive_name(&mut self, r: &RawDrive, found: &mut Found, ok: &mut bool) -> Option<String> {
        let name = match (&r.name, &r.bus, &r.address) {
            (Some((n, _)), _, _) => Some(n.clone()),
            (None, Some((b, _)), Some((a, _))) => Some(format!("{b}/{a}")),
            _ => None,
        };
        if let Some(n) = &name {
            let span = r.name.as_ref().map_or(r.span.clone(), |x| x.1.clone());
            if let Some(first) = found.seen_name.get(n) {
                *ok = false;
                let f = ManifestFinding::new(
                    "duplicate-name",
                    self.loc(&span),
                    format!("drive name `{n}` is used twice"),
                    "give every drive its own name (--only / --skip select by name)",
                )
                .related("first used here", self.loc(first));
                self.findings.push(f);
            } else {
                found.seen_name.insert(n.clone(), span);
            }
        }
        name
    }

    /// The drive's set: there, readable, its findings (or, for a schema
    /// learned from the drive, the learnable ones), its family on the
    /// bus's protocol.
    fn drive_set(
        &mut self,
        r: &RawDrive,
        protocol: Option<BusProtocol>,
        dir: &Path,
        registry: &mut Registry,
        found: &mut Found,
        ok: &mut bool,
    ) -> Option<LoadedSet> {
        // the set
        let mut loaded = None;
        if let Some((s, span)) = &r.set {
            let set_path = dir.join(s);
            // missing, not "there but unreadable" (a FIFO, a directory,
            // a device or a symlink loop is named by the reader below)
            if !driveset_schema::input::exists(&set_path) {
                *ok = false;
                self.push(
                    "missing-set",
                    span,
                    format!("set file `{s}` does not exist ({})", set_path.display()),
                    "set paths are relative to the manifest's directory",
                );
            } else {
                match load_set(&set_path, registry) {
                    Err(e) => {
                        *ok = false;
                        let mut f = ManifestFinding::new(
                            "missing-set",
                            self.loc(span),
                            format!("set file `{s}` cannot be read: {}", e.message),
                            &e.help,
                        );
                        f.related.push(("in the set".into(), (*e.location).clone()));
                        self.findings.push(f);
                    }
                    Ok(l) => {
                        let learn_from = l.schema.clone().filter(|s| needs_learning(s));
                        if !l.findings.is_empty() {
                            match &learn_from {
                                Some(base) => found
                                    .learnable
                                    .extend(l.findings.iter().map(|f| learnable_finding(f, base))),
                                None => {
                                    *ok = false;
                                    found
                                        .set_findings
                                        .extend(l.findings.iter().map(ManifestFinding::from_set));
                                }
                            }
                        }
                        let resolved = match (&l.schema, l.resolved, &learn_from) {
                            (_, Some(set), _) if l.findings.is_empty() => Some(set),
                            (Some(schema), _, Some(_)) => Some(ResolvedSet::new(schema)),
                            (_, set, _) => set,
                        };
                        if let (Some(schema), Some(set)) = (l.schema, resolved) {
                            if let Some(p) = protocol
                                && !p.carries(schema.family)
                            {
                                *ok = false;
                                self.push(
                                    "set-family",
                                    span,
                                    format!(
                                        "set `{s}` is for schema `{}` ({} drives, protocol {}), which does not run on {p} bus `{}`",
                                        schema.id,
                                        schema.family,
                                        schema.family.bus(),
                                        r.bus.as_ref().map_or("", |b| &b.0)
                                    ),
                                    "put the drive on a bus of its family's protocol, or name the right set",
                                );
                            }
                            loaded = Some((schema, set, set_path, learn_from, l.bus_codes));
                        }
                    }
                }
            }
        }
        loaded
    }
}

/// A set's finding against a built-in schema that lacks facts, its help
/// naming the remedy.
fn learnable_finding(f: &Finding, base: &Schema) -> ManifestFinding {
    let mut m = ManifestFinding::from_set(f);
    let remedy = format!(
        "the set names `{}`, which lacks facts (types, kinds, ranges) the drive's own descriptions give: `driveset commission` and `driveset status` learn the schema from the drive first and check the set then; to check it offline, name a learned schema in the set (`driveset schema pull`, or the learned-*.toml a commission run writes into its report directory)",
        base.id
    );
    m.help = if m.help.is_empty() {
        remedy
    } else {
        format!("{}; {remedy}", m.help)
    };
    m
}
