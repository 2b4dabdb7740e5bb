//! The manifest reader: walks the spanned document, checks keys, types,
//! ports, rates, names, addresses and the sets each drive names, and
//! builds the [`Manifest`] or the findings.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

use crate::learn::needs_learning;
use driveset_link::{Openers, PortShape, PortSpec};
use driveset_schema::doc::{Document, Entry, Node, NodeKind};
use driveset_schema::{Family, Finding, Location, Registry, ResolvedSet, Schema, load_set};

use super::bus_codes::bus_code_finding;
use super::{Bus, BusProtocol, Drive, LoadedManifest, Manifest, ManifestFinding};

pub(super) struct Reader<'a> {
    pub(super) d: &'a Document,
    pub(super) findings: Vec<ManifestFinding>,
    pub(super) openers: &'a Openers,
}

const LINE_KEYS: &[&str] = &["name", "label", "report_dir", "journal_dir"];
const BUS_KEYS: &[&str] = &[
    "name",
    "port",
    "protocol",
    "baud",
    "bitrate",
    "transfer_baud",
];
const DRIVE_KEYS: &[&str] = &["name", "bus", "address", "set", "position"];
const TOP_KEYS: &[&str] = &["line", "bus", "buses", "drive", "drives"];

struct RawBus {
    name: Option<(String, Range<usize>)>,
    port: Option<(String, Range<usize>)>,
    protocol: Option<BusProtocol>,
    baud: Option<(u32, Range<usize>)>,
    bitrate: Option<(u32, Range<usize>)>,
    transfer_baud: Option<(u32, Range<usize>)>,
    span: Range<usize>,
}

struct RawDrive {
    name: Option<(String, Range<usize>)>,
    bus: Option<(String, Range<usize>)>,
    address: Option<(i64, Range<usize>)>,
    set: Option<(String, Range<usize>)>,
    position: Option<String>,
    span: Range<usize>,
}

impl<'a> Reader<'a> {
    fn loc(&self, span: &Range<usize>) -> Location {
        self.d.loc(span)
    }

    /// `spec` running at `rate` (an opener's port through its opener).
    fn set_rate(&self, mut spec: PortSpec, rate: u32) -> PortSpec {
        match &mut spec {
            PortSpec::Serial { baud, .. }
            | PortSpec::Tcp { baud, .. }
            | PortSpec::Rfc2217 { baud, .. } => *baud = Some(rate),
            PortSpec::Slcan { bitrate, .. } => *bitrate = Some(rate),
            PortSpec::Sim(o) => {
                if let Some(opener) = self.openers.get(&o.scheme) {
                    *o = opener.with_rate(o, rate);
                }
            }
            PortSpec::SocketCan { .. } => {}
        }
        spec
    }

    /// A `sim://` port with `factory=` drives: every family the manifest
    /// puts on bus `bname` (index `bi`) has at least as many drives on it.
    fn check_factory_port(
        &mut self,
        sim: &driveset_link::PortShape,
        drives: &[Drive],
        bi: usize,
        bname: &str,
        pspan: &Range<usize>,
    ) {
        let mut want: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for d in drives.iter().filter(|d| d.bus_index == bi) {
            want.entry(d.schema.family.name())
                .or_default()
                .push(d.name.as_str());
        }
        for (family, names) in want {
            let have = sim
                .drives
                .iter()
                .filter(|(f, _)| {
                    driveset_schema::Family::parse(&f.to_ascii_lowercase())
                        .is_ok_and(|x| x.name() == family)
                })
                .count();
            if names.len() > have {
                self.push(
                    "set-family",
                    pspan,
                    format!(
                        "simulated bus `{bname}` holds {have} factory-fresh {family} drive(s), but the manifest puts {} on it ({})",
                        names.len(),
                        names.join(", ")
                    ),
                    "give factory= one drive per manifest drive of the family, e.g. factory=mc6000*4,vf1000*3",
                );
            }
        }
    }

    fn push(&mut self, kind: &str, span: &Range<usize>, message: String, help: &str) {
        let loc = self.loc(span);
        self.findings
            .push(ManifestFinding::new(kind, loc, message, help));
    }

    fn check_keys(&mut self, node: &Node, allowed: &[&str], what: &str) {
        for e in node.entries() {
            if !allowed.contains(&e.key.as_str()) {
                self.push(
                    "unknown-key",
                    &e.key_span,
                    format!("unknown key `{}` in {what}", e.key),
                    &format!("the keys of {what} are: {}", allowed.join(", ")),
                );
            }
        }
    }

    fn string(&mut self, e: &Entry, what: &str) -> Option<(String, Range<usize>)> {
        match &e.value.kind {
            NodeKind::Str(s) if !s.trim().is_empty() => Some((s.clone(), e.value.span.clone())),
            NodeKind::Str(_) => {
                self.push(
                    "wrong-type",
                    &e.value.span,
                    format!("`{}` of {what} is empty", e.key),
                    "give a non-empty text",
                );
                None
            }
            k => {
                self.push(
                    "wrong-type",
                    &e.value.span,
                    format!("`{}` of {what} is {}, not a string", e.key, k.describe()),
                    "write the value in quotes",
                );
                None
            }
        }
    }

    fn integer(&mut self, e: &Entry, what: &str) -> Option<(i64, Range<usize>)> {
        if let NodeKind::Num(lit) = &e.value.kind {
            let t = lit.replace('_', "");
            let parsed = if let Some(h) = t.strip_prefix("0x") {
                i64::from_str_radix(h, 16).ok()
            } else {
                t.parse::<i64>().ok()
            };
            if let Some(v) = parsed {
                return Some((v, e.value.span.clone()));
            }
        }
        self.push(
            "wrong-type",
            &e.value.span,
            format!(
                "`{}` of {what} is {}, not a whole number",
                e.key,
                e.value.kind.describe()
            ),
            "give a whole number",
        );
        None
    }

    fn items(&mut self, names: [&str; 2], what: &str) -> Vec<&'a Node> {
        let root: &'a Node = &self.d.root;
        let mut out = Vec::new();
        for name in names {
            let Some(e) = root.get(name) else { continue };
            match &e.value.kind {
                NodeKind::Array(items) => {
                    for it in items {
                        if matches!(it.kind, NodeKind::Table(_)) {
                            out.push(it);
                        } else {
                            self.push(
                                "wrong-type",
                                &it.span,
                                format!(
                                    "an entry of `{name}` is {}, not a table",
                                    it.kind.describe()
                                ),
                                &format!("write each {what} as a table (TOML `[[{}]]`)", names[0]),
                            );
                        }
                    }
                }
                k => self.push(
                    "wrong-type",
                    &e.value.span,
                    format!("`{name}` is {}, not a list of tables", k.describe()),
                    &format!("write each {what} as `[[{}]]`", names[0]),
                ),
            }
        }
        if root.get(names[0]).is_some()
            && let Some(e) = root.get(names[1])
        {
            self.push(
                "unknown-key",
                &e.key_span,
                format!("both `{}` and `{}` are given", names[0], names[1]),
                "use one of them",
            );
        }
        out
    }

    pub(super) fn read(&mut self, path: &Path, registry: &mut Registry) -> LoadedManifest {
        let d = self.d;
        let root = &d.root;
        self.check_keys(root, TOP_KEYS, "a line manifest");
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut name = None;
        let mut label = None;
        let mut report_dir = None;
        let mut journal_dir = None;
        if let Some(line) = root.get("line") {
            if matches!(line.value.kind, NodeKind::Table(_)) {
                self.check_keys(&line.value, LINE_KEYS, "[line]");
                for e in line.value.entries() {
                    let v = match e.key.as_str() {
                        "name" | "label" | "report_dir" | "journal_dir" => self.string(e, "[line]"),
                        _ => None,
                    };
                    let Some((v, _)) = v else { continue };
                    match e.key.as_str() {
                        "name" => name = Some(v),
                        "label" => label = Some(v),
                        "report_dir" => report_dir = Some(dir.join(v)),
                        "journal_dir" => journal_dir = Some(dir.join(v)),
                        _ => {}
                    }
                }
            } else {
                self.push(
                    "wrong-type",
                    &line.value.span,
                    format!("`line` is {}, not a table", line.value.kind.describe()),
                    "write `[line]` with name = \"...\"",
                );
            }
        }

        // buses
        let bus_nodes = self.items(["bus", "buses"], "bus");
        let mut raw_buses = Vec::new();
        for node in bus_nodes {
            self.check_keys(node, BUS_KEYS, "a bus");
            let mut b = RawBus {
                name: None,
                port: None,
                protocol: None,
                baud: None,
                bitrate: None,
                transfer_baud: None,
                span: node.span.clone(),
            };
            for e in node.entries() {
                match e.key.as_str() {
                    "name" => b.name = self.string(e, "a bus"),
                    "port" => b.port = self.string(e, "a bus"),
                    "protocol" => {
                        if let Some((p, span)) = self.string(e, "a bus") {
                            b.protocol = BusProtocol::parse(&p);
                            if b.protocol.is_none() {
                                self.push(
                                    "bad-protocol",
                                    &span,
                                    format!("unknown bus protocol `{p}`"),
                                    "use lustbus, lecom or can",
                                );
                            }
                        }
                    }
                    "transfer_baud" => {
                        if let Some((v, span)) = self.integer(e, "a bus") {
                            let ok = u32::try_from(v)
                                .ok()
                                .filter(|r| driveset_schema::family::SERVO_RATES.contains(r));
                            match ok {
                                Some(r) => b.transfer_baud = Some((r, span)),
                                None => self.push(
                                    "bad-transfer-baud",
                                    &span,
                                    format!("`transfer_baud` = {v} is not a rate MC6000/7000 servos run at"),
                                    "use 2400, 4800, 9600, 19200, 38400 or 57600 (lustbus-protocol.txt §4)",
                                ),
                            }
                        }
                    }
                    "baud" | "bitrate" => {
                        if let Some((v, span)) = self.integer(e, "a bus") {
                            match u32::try_from(v) {
                                Ok(v) if e.key == "baud" => b.baud = Some((v, span)),
                                Ok(v) => b.bitrate = Some((v, span)),
                                Err(_) => self.push(
                                    "wrong-type",
                                    &span,
                                    format!("`{}` = {v} is not a line rate", e.key),
                                    "give a positive rate",
                                ),
                            }
                        }
                    }
                    _ => {}
                }
            }
            for (key, have) in [
                ("name", b.name.is_some()),
                ("port", b.port.is_some()),
                ("protocol", b.protocol.is_some()),
            ] {
                if !have && node.get(key).is_none() {
                    self.push(
                        "missing-key",
                        &node.span,
                        format!("this bus has no `{key}`"),
                        "every bus needs name, port and protocol",
                    );
                }
            }
            raw_buses.push(b);
        }

        // drives
        let drive_nodes = self.items(["drive", "drives"], "drive");
        let mut raw_drives = Vec::new();
        for node in drive_nodes {
            self.check_keys(node, DRIVE_KEYS, "a drive");
            let mut r = RawDrive {
                name: None,
                bus: None,
                address: None,
                set: None,
                position: None,
                span: node.span.clone(),
            };
            for e in node.entries() {
                match e.key.as_str() {
                    "name" => r.name = self.string(e, "a drive"),
                    "bus" => r.bus = self.string(e, "a drive"),
                    "set" => r.set = self.string(e, "a drive"),
                    "position" => r.position = self.string(e, "a drive").map(|x| x.0),
                    "address" => r.address = self.integer(e, "a drive"),
                    _ => {}
                }
            }
            for (key, have) in [
                ("bus", r.bus.is_some()),
                ("address", r.address.is_some()),
                ("set", r.set.is_some()),
            ] {
                if !have && node.get(key).is_none() {
                    self.push(
                        "missing-key",
                        &node.span,
                        format!("this drive has no `{key}`"),
                        "every drive needs bus, address and set",
                    );
                }
            }
            raw_drives.push(r);
        }
        if raw_drives.is_empty() && self.findings.is_empty() {
            self.push(
                "no-drives",
                &root.span,
                "the manifest lists no drives".into(),
                "add [[drive]] entries with bus, address and set",
            );
        }

        // bus names
        let mut bus_by_name: BTreeMap<String, usize> = BTreeMap::new();
        for (i, b) in raw_buses.iter().enumerate() {
            let Some((n, span)) = &b.name else { continue };
            if let Some(&first) = bus_by_name.get(n) {
                let first_loc =
                    self.loc(&raw_buses[first].name.as_ref().map_or(0..0, |x| x.1.clone()));
                let f = ManifestFinding::new(
                    "duplicate-bus",
                    self.loc(span),
                    format!("bus name `{n}` is used twice"),
                    "give every bus its own name",
                )
                .related("first used here", first_loc);
                self.findings.push(f);
            } else {
                bus_by_name.insert(n.clone(), i);
            }
        }

        // drives: bus, address, names, sets
        let mut drives = Vec::new();
        // per drive of `drives`: where the set gives its bus codes, and
        // where the manifest gives the drive's address
        let mut seen_addr: BTreeMap<(usize, i64), Range<usize>> = BTreeMap::new();
        let mut seen_name: BTreeMap<String, Range<usize>> = BTreeMap::new();
        let mut set_findings = Vec::new();
        let mut learnable = Vec::new();
        for r in &raw_drives {
            let mut ok = true;
            let bus_index = match &r.bus {
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
            };
            let protocol = bus_index.and_then(|i| raw_buses[i].protocol);
            let mut address = None;
            if let Some((a, span)) = &r.address {
                if let Some(p) = protocol {
                    match p.check_address(*a) {
                        Ok(()) => address = Some(*a as u8),
                        Err(refusal) => {
                            let (kind, rule) = (refusal.kind(), refusal.rule);
                            ok = false;
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
                    if let Some(first) = seen_addr.get(&(bi, *a)) {
                        ok = false;
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
                        seen_addr.insert((bi, *a), span.clone());
                    }
                }
            }
            let name = match (&r.name, &r.bus, &r.address) {
                (Some((n, _)), _, _) => Some(n.clone()),
                (None, Some((b, _)), Some((a, _))) => Some(format!("{b}/{a}")),
                _ => None,
            };
            if let Some(n) = &name {
                let span = r.name.as_ref().map_or(r.span.clone(), |x| x.1.clone());
                if let Some(first) = seen_name.get(n) {
                    ok = false;
                    let f = ManifestFinding::new(
                        "duplicate-name",
                        self.loc(&span),
                        format!("drive name `{n}` is used twice"),
                        "give every drive its own name (--only / --skip select by name)",
                    )
                    .related("first used here", self.loc(first));
                    self.findings.push(f);
                } else {
                    seen_name.insert(n.clone(), span);
                }
            }
            // the set
            let mut loaded = None;
            if let Some((s, span)) = &r.set {
                let set_path = dir.join(s);
                // missing, not "there but unreadable" (a FIFO, a directory,
                // a device or a symlink loop is named by the reader below)
                if !driveset_schema::input::exists(&set_path) {
                    ok = false;
                    self.push(
                        "missing-set",
                        span,
                        format!("set file `{s}` does not exist ({})", set_path.display()),
                        "set paths are relative to the manifest's directory",
                    );
                } else {
                    match load_set(&set_path, registry) {
                        Err(e) => {
                            ok = false;
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
                                    Some(base) => learnable.extend(
                                        l.findings.iter().map(|f| learnable_finding(f, base)),
                                    ),
                                    None => {
                                        ok = false;
                                        set_findings.extend(
                                            l.findings.iter().map(ManifestFinding::from_set),
                                        );
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
                                    ok = false;
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
            if let (
                true,
                Some(n),
                Some(bi),
                Some(a),
                Some((schema, set, set_path, learn_from, bus_codes)),
            ) = (ok, name, bus_index, address, loaded)
            {
                let addr_loc = r.address.as_ref().map_or(0..0, |x| x.1.clone());
                drives.push(Drive {
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

        // ports (after drives: a sim port without addresses takes the drives')
        let mut buses = Vec::new();
        for (i, b) in raw_buses.iter().enumerate() {
            let (Some((bname, _)), Some((port_text, pspan)), Some(protocol)) =
                (&b.name, &b.port, b.protocol)
            else {
                continue;
            };
            let mut spec = match PortSpec::parse(port_text) {
                Ok(s) => s,
                Err(e) => {
                    self.push(
                        "bad-port",
                        pspan,
                        format!("port `{port_text}`: {e}"),
                        "use the common port syntax: /dev/ttyUSB0?baud=19200, tcp://host:4001, slcan:///dev/ttyACM0, can://can0, sim://FAMILY",
                    );
                    continue;
                }
            };
            // A port of an opener (`sim://`): the opener checks it and says
            // what it holds; without drives it takes the manifest's.
            let mut shape: Option<PortShape> = None;
            if let PortSpec::Sim(o) = &spec {
                let checked = match self.openers.get(&o.scheme) {
                    None => Err(format!(
                        "no opener for {}:// ports is registered; this program cannot open simulated buses",
                        o.scheme
                    )),
                    Some(opener) => {
                        let here: Vec<(&str, u8)> = drives
                            .iter()
                            .filter(|d| d.bus_index == i)
                            .map(|d| (d.schema.family.name(), d.address))
                            .collect();
                        let filled = opener.with_drives(o, &here);
                        opener
                            .check(&filled)
                            .map(|sh| (sh, filled))
                            .map_err(|e| e.to_string())
                    }
                };
                match checked {
                    Ok((sh, filled)) => {
                        spec = PortSpec::Sim(filled);
                        shape = Some(sh);
                    }
                    Err(e) => {
                        self.push(
                            "bad-port",
                            pspan,
                            format!("port `{port_text}`: {e}"),
                            "use the common port syntax: /dev/ttyUSB0?baud=19200, tcp://host:4001, slcan:///dev/ttyACM0, can://can0, sim://FAMILY",
                        );
                        continue;
                    }
                }
            }
            let port_can = shape.as_ref().map_or_else(|| spec.is_can(), |sh| sh.frames);
            if port_can != (protocol == BusProtocol::CanSdo) {
                self.push(
                    "bad-port",
                    pspan,
                    format!(
                        "port `{port_text}` is a {} port, but the bus protocol is {protocol}",
                        if port_can { "CAN" } else { "character line" }
                    ),
                    "CAN buses need a CAN port (slcan://, can://, sim://ecs); LUSTBUS and LECOM need a serial or TCP port",
                );
                continue;
            }
            if let Some(sim) = &shape
                && port_has_rate(port_text, "factory")
            {
                // factory-fresh drives share the factory address until
                // `commission --assign` / `replace` give them theirs: the
                // port must hold enough drives of each family
                self.check_factory_port(sim, &drives, i, bname, pspan);
            } else if let Some(sim) = &shape {
                let on_bus = &sim.drives;
                for d in drives.iter().filter(|d| d.bus_index == i) {
                    // The family the simulated bus has at the drive's address.
                    let at = on_bus.iter().find(|(_, a)| *a == d.address);
                    if let Some((fam, _)) = at
                        && !sim_family_matches(&fam.to_ascii_lowercase(), &d.schema)
                    {
                        let (what, fix) = if sim.mixed {
                            (
                                format!("has a `{fam}` drive at address {}", d.address),
                                "on sim://lustbus give the address under the set's family (mc6000= or vf1000=)",
                            )
                        } else {
                            (
                                format!("holds `{fam}` drives"),
                                "a simulated bus holds one family (sim://lustbus?mc6000=..&vf1000=.. mixes LUSTBUS families); put the drive on a bus of its family",
                            )
                        };
                        let f = ManifestFinding::new(
                            "set-family",
                            d.location.clone(),
                            format!(
                                "drive `{}` has a `{}` set, but simulated bus `{bname}` {what}",
                                d.name, d.schema.id
                            ),
                            fix,
                        );
                        self.findings.push(f);
                    }
                    if at.is_none() {
                        self.push(
                            "unknown-bus",
                            pspan,
                            format!(
                                "drive `{}` is at address {}, which simulated bus `{bname}` does not have",
                                d.name, d.address
                            ),
                            if sim.mixed {
                                "add the address under its family (mc6000= / vf1000=), or write sim://lustbus without them to simulate the manifest's drives"
                            } else {
                                "add the address to addresses=, or leave addresses= out to simulate the manifest's drives"
                            },
                        );
                    }
                }
            }
            // rate
            let (given, key) = if protocol == BusProtocol::CanSdo {
                (b.bitrate.clone(), "bitrate")
            } else {
                (b.baud.clone(), "baud")
            };
            let wrong = if protocol == BusProtocol::CanSdo {
                &b.baud
            } else {
                &b.bitrate
            };
            if let Some((_, span)) = wrong {
                self.push(
                    "unknown-key",
                    span,
                    format!(
                        "a {protocol} bus has no `{}`",
                        if key == "baud" { "bitrate" } else { "baud" }
                    ),
                    &format!("use `{key}`"),
                );
            }
            let port_rate = if protocol == BusProtocol::CanSdo {
                spec.can_bitrate()
            } else {
                spec.line_baud()
            };
            let rate = match (given, port_rate) {
                (Some((g, span)), Some(p)) if g != p && port_has_rate(port_text, key) => {
                    self.push(
                        "rate-mismatch",
                        &span,
                        format!("{key} = {g}, but port `{port_text}` says {p}"),
                        "give the rate in one place",
                    );
                    continue;
                }
                (Some((g, _)), _) => {
                    spec = self.set_rate(spec, g);
                    g
                }
                (None, Some(p)) => p,
                (None, None) => 0,
            };
            if let Some((_, span)) = &b.transfer_baud
                && protocol != BusProtocol::Lustbus
            {
                self.push(
                    "unknown-key",
                    span,
                    format!("a {protocol} bus has no `transfer_baud`"),
                    "only MC6000/7000 servos on a LUSTBUS bus switch their rate online (lustbus-protocol.txt §11.5); remove it",
                );
            }
            let port_name = match (&spec, &shape) {
                (PortSpec::Sim(o), Some(_)) => self
                    .openers
                    .get(&o.scheme)
                    .and_then(|op| op.check(o).ok())
                    .map_or_else(|| spec.to_string(), |sh| sh.name),
                _ => spec.to_string(),
            };
            buses.push(Bus {
                name: bname.clone(),
                port_text: port_text.clone(),
                port: spec,
                port_name,
                protocol,
                rate,
                transfer_baud: b.transfer_baud.as_ref().map(|t| t.0),
                families: Vec::new(),
                location: self.loc(&b.span),
                rate_location: b
                    .baud
                    .as_ref()
                    .map(|x| x.1.clone())
                    .or_else(|| b.port.as_ref().map(|x| x.1.clone()))
                    .map(|span| self.loc(&span)),
            });
        }
        self.findings.extend(super::same_device::findings(&buses));
        for d in &drives {
            if let Some(b) = buses.iter_mut().find(|b| b.name == d.bus) {
                b.families.push(d.schema.family);
            }
        }
        for d in &drives {
            let bus = buses.iter().find(|b| b.name == d.bus);
            for (key, set_loc) in &d.set_bus_codes {
                if let Some(f) = bus_code_finding(
                    d,
                    *key,
                    set_loc,
                    &d.address_location,
                    bus,
                    bus.and_then(|b| b.rate_location.as_ref()),
                ) {
                    self.findings.push(f);
                }
            }
        }
        let mut findings = std::mem::take(&mut self.findings);
        findings.extend(set_findings);
        let manifest = findings
            .iter()
            .all(ManifestFinding::is_per_drive)
            .then(|| Manifest {
                path: path.to_path_buf(),
                name: name.unwrap_or_else(|| {
                    path.file_stem()
                        .map_or_else(|| "line".into(), |s| s.to_string_lossy().into_owned())
                }),
                label,
                report_dir,
                journal_dir,
                buses,
                drives,
            });
        LoadedManifest {
            manifest,
            findings,
            learnable,
        }
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

fn port_has_rate(port: &str, key: &str) -> bool {
    port.contains(&format!("{key}="))
}

/// Whether the family a simulated port names at an address (`fam`, as the
/// port spells it) is `schema`'s: the descriptor reads the name
/// ([`Family::from_port_name`]).
fn sim_family_matches(fam: &str, schema: &Schema) -> bool {
    Family::from_port_name(fam) == Some(schema.family)
}
