//! The manifest reader: walks the spanned document, checks keys, types,
//! ports, rates, names, addresses and the sets each drive names, and
//! builds the [`Manifest`] or the findings. One step per function, in the
//! order [`Reader::read`] takes them: the `[line]` table, the buses and
//! drives as written (keys and types), the bus names, the drives (bus,
//! address, name, set: `drives`), the buses (port, simulated drives,
//! rate: `ports`), then what spans both (same device, bus codes).

mod drives;
mod ports;

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use driveset_link::Openers;
use driveset_schema::doc::{Document, Entry, Node, NodeKind};
use driveset_schema::{Location, Registry};

use super::bus_codes::bus_code_finding;
use super::{Bus, BusProtocol, LoadedManifest, Manifest, ManifestFinding};
use drives::Found;

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

/// The `[line]` table's values.
#[derive(Default)]
struct LineTable {
    name: Option<String>,
    label: Option<String>,
    report_dir: Option<PathBuf>,
    journal_dir: Option<PathBuf>,
}

impl<'a> Reader<'a> {
    fn loc(&self, span: &Range<usize>) -> Location {
        self.d.loc(span)
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

    /// Read the manifest at `path` (its sets through `registry`): the
    /// manifest, or the findings that keep it from being one.
    pub(super) fn read(&mut self, path: &Path, registry: &mut Registry) -> LoadedManifest {
        let d = self.d;
        let root = &d.root;
        self.check_keys(root, TOP_KEYS, "a line manifest");
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        let line = self.line_table(&dir);
        let raw_buses: Vec<RawBus> = self
            .items(["bus", "buses"], "bus")
            .into_iter()
            .map(|node| self.raw_bus(node))
            .collect();
        let raw_drives: Vec<RawDrive> = self
            .items(["drive", "drives"], "drive")
            .into_iter()
            .map(|node| self.raw_drive(node))
            .collect();
        if raw_drives.is_empty() && self.findings.is_empty() {
            self.push(
                "no-drives",
                &root.span,
                "the manifest lists no drives".into(),
                "add [[drive]] entries with bus, address and set",
            );
        }
        let bus_by_name = self.bus_names(&raw_buses);
        let found = self.drives(&raw_drives, &raw_buses, &bus_by_name, &dir, registry);
        // ports (after drives: a sim port without addresses takes the drives')
        let buses = self.buses(&raw_buses, &found.drives);
        self.finish(path, line, buses, found)
    }

    /// The `[line]` table: name, label and the directories (relative to
    /// the manifest's `dir`).
    fn line_table(&mut self, dir: &Path) -> LineTable {
        let mut t = LineTable::default();
        if let Some(line) = self.d.root.get("line") {
            if matches!(line.value.kind, NodeKind::Table(_)) {
                self.check_keys(&line.value, LINE_KEYS, "[line]");
                for e in line.value.entries() {
                    let v = match e.key.as_str() {
                        "name" | "label" | "report_dir" | "journal_dir" => self.string(e, "[line]"),
                        _ => None,
                    };
                    let Some((v, _)) = v else { continue };
                    match e.key.as_str() {
                        "name" => t.name = Some(v),
                        "label" => t.label = Some(v),
                        "report_dir" => t.report_dir = Some(dir.join(v)),
                        "journal_dir" => t.journal_dir = Some(dir.join(v)),
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
        t
    }

    /// A `[[bus]]` as written: its keys and their types checked.
    fn raw_bus(&mut self, node: &Node) -> RawBus {
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
        b
    }

    /// A `[[drive]]` as written: its keys and their types checked.
    fn raw_drive(&mut self, node: &Node) -> RawDrive {
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
        r
    }

    /// The buses by name (a name used twice is a finding).
    fn bus_names(&mut self, raw_buses: &[RawBus]) -> BTreeMap<String, usize> {
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
        bus_by_name
    }

    /// What spans buses and drives (the same device named twice, the
    /// families of each bus, the sets' bus codes against their bus), then
    /// the manifest when no finding but a per-drive one stands.
    fn finish(
        &mut self,
        path: &Path,
        line: LineTable,
        mut buses: Vec<Bus>,
        found: Found,
    ) -> LoadedManifest {
        let Found {
            drives,
            set_findings,
            learnable,
            ..
        } = found;
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
                name: line.name.unwrap_or_else(|| {
                    path.file_stem()
                        .map_or_else(|| "line".into(), |s| s.to_string_lossy().into_owned())
                }),
                label: line.label,
                report_dir: line.report_dir,
                journal_dir: line.journal_dir,
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
