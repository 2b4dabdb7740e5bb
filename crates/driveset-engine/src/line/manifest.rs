//! The line manifest: which drives (bus, address) a machine line has and
//! which set each one gets. TOML or YAML, read through the schema crate's
//! spanned document tree so every finding has file:line:column.
//!
//! ```toml
//! [line]
//! name = "demo-line"                  # optional; default: the file stem
//! label = "FAT build 7"               # optional default for --label
//! report_dir = "reports"              # optional, relative to this file
//! journal_dir = "journals"            # optional, relative to this file
//!
//! [[bus]]
//! name = "press"
//! port = "sim://mc6000"               # the common port syntax (sim:// without
//!                                     # addresses= simulates this bus' drives)
//! protocol = "lustbus"                # lustbus | lecom | can
//! baud = 19200                        # lustbus / lecom; `bitrate` for can
//!
//! [[drive]]
//! bus = "press"
//! address = 1
//! set = "sets/press-axis-1.toml"      # relative to this file
//! name = "press-axis-1"               # optional; default BUS/ADDRESS
//! position = "press, X axis"          # optional, free text
//! ```
//!
//! YAML manifests use the same keys (`line:`, `bus:` or `buses:`, `drive:`
//! or `drives:` as sequences).
//!
//! Findings ([`ManifestFinding`], kind in brackets): `unknown-key`,
//! `missing-key`, `wrong-type`, `bad-port`, `bad-protocol`,
//! `rate-mismatch`, `duplicate-bus`, `unknown-bus`, `duplicate-name`,
//! `duplicate-address`, `group-address`, `address-out-of-range`,
//! `missing-set`, `set-family`, `no-drives`, `set-address`, `set-rate`,
//! and the findings of each set file (their own kinds, at their own
//! locations).
//!
//! **The manifest's address is the truth.** A set that gives its drive's
//! bus address code (role `bus-address`: LUSTBUS 82-SIOA/SADDR, Tmd C0009)
//! with a value other than the drive's `address`, or its line rate code
//! (role `baud-rate`: 81-SIOC/SBAUD, C0125) with a rate other than its
//! bus's `baud`, is a finding (`set-address`, `set-rate`) at the set's
//! line, naming the manifest's place: a set copied from another drive is
//! caught before the plant.
//!
//! **Sets whose schema lacks facts.** A set naming a built-in LUSTBUS schema
//! that lacks codes' types, kinds or ranges (`lust-mc6000`, `lust-vf1000`;
//! [`crate::learn::needs_learning`]) gets its facts from the drive:
//! `commission` and `status` learn the schema from each such drive's own
//! descriptions before planning it (see `commission`'s module docs). Such a
//! drive loads with [`Drive::learn_from`] set, and the findings its set has
//! against the built-in schema do not stop the line: they are kept apart in
//! [`LoadedManifest::learnable`]. Offline (`validate LINE`,
//! [`validate_manifest`]) they are findings like any other, their help
//! naming the remedy (commission learns the schema; or name a learned
//! schema in the set).

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::learn::needs_learning;
use driveset_link::{Openers, PortShape, PortSpec};
use driveset_schema::doc::{self, Document, Entry, Node, NodeKind, Syntax};
use driveset_schema::error::read_text_file;
use driveset_schema::{
    CodeKey, Family, Finding, FindingKind, InputError, Location, RawValue, Registry, ResolvedSet,
    Role, Schema, load_set,
};

/// The bus protocols a manifest names (`lustbus | lecom | can`): the
/// schema crate's family descriptor owns them, their addresses included.
pub use driveset_schema::BusProtocol;

/// One finding in a manifest (or in a set it names).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ManifestFinding {
    /// Kebab-case kind (`duplicate-address`, ...; a set's findings keep their kind).
    pub kind: String,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
    /// Where.
    pub location: Location,
    /// Other places involved (the first use of a duplicate address, ...).
    pub related: Vec<(String, Location)>,
}

impl ManifestFinding {
    fn new(
        kind: &str,
        location: Location,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> Self {
        ManifestFinding {
            kind: kind.to_string(),
            message: message.into(),
            help: help.into(),
            location,
            related: Vec::new(),
        }
    }

    fn related(mut self, label: &str, loc: Location) -> Self {
        self.related.push((label.to_string(), loc));
        self
    }

    /// rustc-style text, like the schema crate's findings.
    pub fn render_human(&self) -> String {
        let mut f = self.to_finding();
        f.message = self.message.clone();
        let mut out = f.render_human();
        // the schema crate's renderer names its own kind; put ours back
        if let Some(rest) = out.split_once("]: ").map(|x| x.1.to_string()) {
            out = format!("error[{}]: {rest}", self.kind);
        }
        out
    }

    /// The nearest schema-crate [`Finding`] (for `driveset validate`, whose
    /// output model has a closed set of kinds): the kind maps to the
    /// closest one; the message is kept word for word.
    pub fn to_finding(&self) -> Finding {
        let kind = match self.kind.as_str() {
            "duplicate-address" | "duplicate-name" | "duplicate-bus" => FindingKind::DuplicateCode,
            "group-address" | "address-out-of-range" => FindingKind::OutOfRange,
            "unknown-key" | "unknown-bus" => FindingKind::UnknownCode,
            "missing-set" => FindingKind::BadExtends,
            "set-family" => FindingKind::UnknownSchema,
            "rate-mismatch" | "no-drives" => FindingKind::RuleViolation,
            "missing-key" | "wrong-type" | "bad-port" | "bad-protocol" => FindingKind::WrongType,
            other => set_kind(other).unwrap_or(FindingKind::RuleViolation),
        };
        Finding {
            kind,
            message: self.message.clone(),
            help: self.help.clone(),
            location: self.location.clone(),
            related: self.related.clone(),
        }
    }

    fn from_set(f: &Finding) -> Self {
        ManifestFinding {
            kind: f.kind.as_str().to_string(),
            message: f.message.clone(),
            help: f.help.clone(),
            location: f.location.clone(),
            related: f.related.clone(),
        }
    }
}

fn set_kind(s: &str) -> Option<FindingKind> {
    use FindingKind as K;
    [
        K::UnknownCode,
        K::DuplicateCode,
        K::WrongType,
        K::OutOfRange,
        K::Unrepresentable,
        K::UnknownEnumLabel,
        K::UnknownBitField,
        K::ReadOnly,
        K::RuleViolation,
        K::UnknownSchema,
        K::BadExtends,
        K::UnknownType,
        K::UnitMismatch,
        K::SchemaError,
    ]
    .into_iter()
    .find(|k| k.as_str() == s)
}

impl fmt::Display for ManifestFinding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: error[{}]: {}",
            self.location, self.kind, self.message
        )?;
        if !self.help.is_empty() {
            write!(f, " (help: {})", self.help)?;
        }
        Ok(())
    }
}

/// One bus of a line.
#[derive(Debug, Clone)]
pub struct Bus {
    /// Name.
    pub name: String,
    /// Port as written in the manifest.
    pub port_text: String,
    /// The parsed port, with the manifest's rate applied and (for a
    /// `sim://` port without drives) the manifest's drives put on it by
    /// the port's opener ([`driveset_link::PortOpener::with_drives`]).
    pub port: PortSpec,
    /// The port as reports, journals and messages name it: the canonical
    /// form (for an opener's port, the opener's name of it: `sim://` leaves
    /// out `state=`).
    pub port_name: String,
    /// Family.
    pub protocol: BusProtocol,
    /// Line rate (baud, or CAN bit/s).
    pub rate: u32,
    /// `transfer_baud = RATE`: the MC6000/7000 drives of the bus are
    /// commissioned at this rate (`crate::transfer`).
    pub transfer_baud: Option<u32>,
    /// The families of the bus's drives, one entry per drive (for the
    /// transfer rate's shared-bus refusal).
    pub families: Vec<driveset_schema::Family>,
    /// Where the bus is declared.
    pub location: Location,
}

/// One drive of a line.
#[derive(Debug, Clone)]
pub struct Drive {
    /// Name (given, else `BUS/ADDRESS`).
    pub name: String,
    /// Bus name.
    pub bus: String,
    /// Index into [`Manifest::buses`].
    pub bus_index: usize,
    /// Address / node id.
    pub address: u8,
    /// Set path as written.
    pub set_text: String,
    /// Set path (relative to the manifest's directory resolved).
    pub set_path: PathBuf,
    /// Position text.
    pub position: Option<String>,
    /// The set's schema.
    pub schema: Arc<Schema>,
    /// The set's values. For a drive with [`Drive::learn_from`] whose set
    /// does not resolve against the built-in schema: empty until the run
    /// learns the schema and resolves the set again.
    pub set: ResolvedSet,
    /// The built-in schema the set names when it lacks facts a drive's
    /// descriptions fill ([`crate::learn::needs_learning`]): line runs learn
    /// the schema from the drive first and resolve the set against it.
    pub learn_from: Option<Arc<Schema>>,
    /// Where the drive is declared.
    pub location: Location,
}

/// A manifest without findings.
#[derive(Debug, Clone)]
pub struct Manifest {
    /// The manifest path as given.
    pub path: PathBuf,
    /// Line name.
    pub name: String,
    /// Default label.
    pub label: Option<String>,
    /// Report directory (resolved against the manifest's directory), if given.
    pub report_dir: Option<PathBuf>,
    /// Journal directory (resolved), if given.
    pub journal_dir: Option<PathBuf>,
    /// Buses, in manifest order.
    pub buses: Vec<Bus>,
    /// Drives, in manifest order.
    pub drives: Vec<Drive>,
}

/// The result of loading a manifest: the manifest when it has no findings.
#[derive(Debug, Clone)]
pub struct LoadedManifest {
    /// The manifest (`None` when there are findings).
    pub manifest: Option<Manifest>,
    /// Every finding, manifest ones first, then the sets'.
    pub findings: Vec<ManifestFinding>,
    /// The findings of sets whose schema lacks facts against that built-in
    /// schema: a line run clears them by learning the schema from the
    /// drive (module docs); they do not stop the manifest from loading.
    pub learnable: Vec<ManifestFinding>,
}

/// Whether `path` holds a line manifest (a top-level `line` table, or a
/// `bus` / `buses` key). Unreadable or malformed files are not manifests.
pub fn is_manifest(path: &Path) -> bool {
    let Ok(source) = read_text_file(path) else {
        return false;
    };
    let Ok(d) = doc::parse(source, Syntax::from_path(path)) else {
        return false;
    };
    is_manifest_doc(&d)
}

/// [`is_manifest`] on a parsed document.
pub fn is_manifest_doc(d: &Document) -> bool {
    d.root
        .get("line")
        .is_some_and(|e| matches!(e.value.kind, NodeKind::Table(_)))
        || d.root.get("bus").is_some()
        || d.root.get("buses").is_some()
}

/// Validate a manifest and every set it names (the `driveset validate`
/// entry point). `Err` when the file cannot be read or parsed at all.
/// `openers` check the ports of the schemes `driveset-link` does not open
/// itself (`sim://`: the simulator's opener).
///
/// Offline the sets whose schema lacks facts cannot be checked: their
/// findings ([`LoadedManifest::learnable`]) are reported with a help that
/// names the remedy.
pub fn validate_manifest(
    path: &Path,
    openers: &Openers,
) -> Result<Vec<ManifestFinding>, InputError> {
    let mut registry = Registry::builtin()?;
    let loaded = load_manifest(path, &mut registry, openers)?;
    let mut out = loaded.findings;
    out.extend(loaded.learnable);
    Ok(out)
}

/// [`validate_manifest`] of a manifest given as text (an editor's unsaved
/// buffer); `path` names it in findings and anchors its relative paths.
pub fn validate_manifest_str(
    path: &Path,
    text: &str,
    openers: &Openers,
) -> Result<Vec<ManifestFinding>, InputError> {
    let mut registry = Registry::builtin()?;
    let source = driveset_schema::error::source_from_str(&path.display().to_string(), text)?;
    let d = doc::parse(source, Syntax::from_path(path))?;
    let mut r = Reader {
        d: &d,
        findings: Vec::new(),
        openers,
    };
    let loaded = r.read(path, &mut registry);
    let mut out = loaded.findings;
    out.extend(loaded.learnable);
    Ok(out)
}

/// Load and check a manifest and its sets; `openers` check the ports of
/// the schemes `driveset-link` does not open itself (as for
/// [`validate_manifest`]).
pub fn load_manifest(
    path: &Path,
    registry: &mut Registry,
    openers: &Openers,
) -> Result<LoadedManifest, InputError> {
    let source = read_text_file(path)?;
    let d = doc::parse(source, Syntax::from_path(path))?;
    let mut r = Reader {
        d: &d,
        findings: Vec::new(),
        openers,
    };
    Ok(r.read(path, registry))
}

struct Reader<'a> {
    d: &'a Document,
    findings: Vec<ManifestFinding>,
    openers: &'a Openers,
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

    fn read(&mut self, path: &Path, registry: &mut Registry) -> LoadedManifest {
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
        let mut bus_code_places: Vec<(Vec<(CodeKey, Location)>, Location)> = Vec::new();
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
                if !set_path.is_file() {
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
                bus_code_places.push((bus_codes, self.loc(&addr_loc)));
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
            if let Some(sim) = &shape {
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
            });
        }
        for d in &drives {
            if let Some(b) = buses.iter_mut().find(|b| b.name == d.bus) {
                b.families.push(d.schema.family);
            }
        }
        for (d, (codes, addr_loc)) in drives.iter().zip(&bus_code_places) {
            let bus = buses.iter().find(|b| b.name == d.bus);
            let rate_loc = raw_buses[d.bus_index]
                .baud
                .as_ref()
                .map(|x| x.1.clone())
                .or_else(|| raw_buses[d.bus_index].port.as_ref().map(|x| x.1.clone()))
                .map(|span| self.loc(&span));
            for (key, set_loc) in codes {
                if let Some(f) =
                    bus_code_finding(d, *key, set_loc, addr_loc, bus, rate_loc.as_ref())
                {
                    self.findings.push(f);
                }
            }
        }
        let mut findings = std::mem::take(&mut self.findings);
        findings.extend(set_findings);
        let manifest = findings.is_empty().then(|| Manifest {
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

/// The engineering whole number a bus code's value stands for: the number
/// its label starts with (Tmd C0125 `1 = "4800 bps ..."`), else its
/// engineering value (a VD C0009 = 2.0000 is 2).
fn bus_code_number(schema: &Schema, code: &driveset_schema::Code, raw: &RawValue) -> Option<i64> {
    let RawValue::Int(r) = raw else { return None };
    if let Some(label) = schema.enum_label(code, *r) {
        let digits: String = label.chars().take_while(char::is_ascii_digit).collect();
        return digits.parse().ok();
    }
    match schema.type_of(code) {
        Some(ty) => match driveset_schema::value::raw_to_decimal(ty, *r) {
            Some(d) => d.to_integer().and_then(|v| i64::try_from(v).ok()),
            None => Some(*r),
        },
        None => Some(*r),
    }
}

/// `set-address` / `set-rate`: the drive's set gives its bus address code
/// (or its line rate code) a value other than the manifest's address of the
/// drive (or its bus's rate). `None` where they agree, or where the bus has
/// no rate to compare with.
fn bus_code_finding(
    d: &Drive,
    key: CodeKey,
    set_loc: &Location,
    addr_loc: &Location,
    bus: Option<&Bus>,
    rate_loc: Option<&Location>,
) -> Option<ManifestFinding> {
    let schema = &d.schema;
    let code = schema.code(key.number)?;
    let raw = d.set.values.get(&key)?;
    let got = bus_code_number(schema, code, raw);
    let label = schema.display_code(key.number, key.subcode);
    let shown = driveset_schema::validate::display_value(schema, code, raw);
    match code.role()? {
        Role::BusAddress => {
            if got == Some(i64::from(d.address)) {
                return None;
            }
            let f = ManifestFinding::new(
                "set-address",
                set_loc.clone(),
                format!(
                    "set `{}` gives {label} = {shown}, but the manifest puts drive `{}` at address {} on bus `{}`",
                    d.set_text, d.name, d.address, d.bus
                ),
                format!(
                    "the manifest's address is the truth: remove {label} from the set, or give drive `{}` address {shown} in the manifest",
                    d.name
                ),
            );
            Some(f.related("the drive's address in the manifest", addr_loc.clone()))
        }
        Role::BaudRate => {
            let bus = bus?;
            if bus.rate == 0 || got == Some(i64::from(bus.rate)) {
                return None;
            }
            let f = ManifestFinding::new(
                "set-rate",
                set_loc.clone(),
                format!(
                    "set `{}` gives {label} = {shown}, but bus `{}` of drive `{}` runs at {} baud",
                    d.set_text, d.bus, d.name, bus.rate
                ),
                format!(
                    "the manifest's rate is the truth: remove {label} from the set, or give bus `{}` the set's rate in the manifest",
                    d.bus
                ),
            );
            Some(match rate_loc {
                Some(l) => f.related("the bus's rate in the manifest", l.clone()),
                None => f,
            })
        }
        _ => None,
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

fn sim_family_matches(fam: &str, schema: &Schema) -> bool {
    let fam = fam.replace('_', "-");
    let short = fam
        .trim_start_matches("fictional-")
        .trim_start_matches("lust-")
        .trim_start_matches("lenze-")
        .trim_end_matches("-demo")
        .to_string();
    match schema.family {
        Family::Mc6000 => short == "mc6000" || short == "mc7000",
        Family::Vf1000 => short == "vf1000",
        Family::Tmd => short == "tmd",
        Family::Ecs => short == "ecs",
    }
}
