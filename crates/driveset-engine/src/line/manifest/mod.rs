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
//!
//! Files: this one holds the model (buses, drives, the manifest) and the
//! entry points; `finding.rs` the finding type, `reader.rs` the reader of
//! the document, `bus_codes.rs` the set-address / set-rate check.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_link::{Openers, PortSpec};
use driveset_schema::doc::{self, Document, NodeKind, Syntax};
use driveset_schema::error::read_text_file;
use driveset_schema::{CodeKey, InputError, Location, Registry, ResolvedSet, Schema};

mod bus_codes;
mod finding;
mod reader;
mod same_device;

pub(crate) use bus_codes::bus_code_finding;
pub use finding::ManifestFinding;
use reader::Reader;

/// The bus protocols a manifest names (`lustbus | lecom | can`): the
/// schema crate's family descriptor owns them, their addresses included.
pub use driveset_schema::BusProtocol;

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
    /// Where the bus's rate is given (`baud` / `bitrate`, else the port).
    pub rate_location: Option<Location>,
}

impl Bus {
    /// What the bus's port says about talking to its drives (its
    /// `latency=`): every client of a line run on the bus is connected with
    /// it, as a one-drive command's client is with its port's.
    pub fn connect(&self) -> crate::connect::ConnectOptions {
        crate::connect::ConnectOptions::of(&self.port)
    }
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
    /// Where the drive's `address` is given.
    pub address_location: Location,
    /// Where the set gives its bus address and line rate codes (roles
    /// `bus-address`, `baud-rate`; [`driveset_schema::LoadedSet::bus_codes`]):
    /// the manifest's address and rate are the truth (module docs).
    pub set_bus_codes: Vec<(CodeKey, Location)>,
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

/// The result of loading a manifest: the manifest when it has no findings
/// but per-drive ones ([`ManifestFinding::is_per_drive`]: a line run
/// refuses such a drive, the others run).
#[derive(Debug, Clone)]
pub struct LoadedManifest {
    /// The manifest (`None` when there are findings other than per-drive ones).
    pub manifest: Option<Manifest>,
    /// Every finding, manifest ones first, then the sets'.
    pub findings: Vec<ManifestFinding>,
    /// The findings of sets whose schema lacks facts against that built-in
    /// schema: a line run clears them by learning the schema from the
    /// drive (module docs); they do not stop the manifest from loading.
    pub learnable: Vec<ManifestFinding>,
}

/// The report directory of a line command when neither its `--report-dir`
/// nor the manifest's `report_dir` gives one (relative to the current
/// directory; README.md).
pub const DEFAULT_REPORT_DIR: &str = "target/driveset-report";

/// Whether the findings of sets whose schema is learned from the drive
/// ([`LoadedManifest::learnable`]) stop a line command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LearnedSets {
    /// They do not count: the run learns the drive's schema and checks the
    /// set against it then.
    Excused,
    /// They count (`--no-learn`, or a command that learns nothing).
    Counted,
}

impl LoadedManifest {
    /// The manifest a line command runs, or the findings that stop it:
    /// every finding but the per-drive ones (`set-address`, `set-rate`:
    /// the line run refuses that drive, not the line), and the learnable
    /// ones when `learned` counts them.
    ///
    /// # Errors
    /// The findings that stop the command (possibly none, when the
    /// manifest did not load for per-drive findings alone: it always
    /// loads then).
    pub fn runnable(self, learned: LearnedSets) -> Result<Manifest, Vec<ManifestFinding>> {
        let mut findings: Vec<_> = self
            .findings
            .into_iter()
            .filter(|f| !f.is_per_drive())
            .collect();
        if learned == LearnedSets::Counted {
            findings.extend(self.learnable);
        }
        match self.manifest {
            Some(m) if findings.is_empty() => Ok(m),
            _ => Err(findings),
        }
    }
}

impl Manifest {
    /// Where a line command's reports go: `given` (`--report-dir`), else
    /// the manifest's `report_dir`, else [`DEFAULT_REPORT_DIR`].
    pub fn report_dir_or(&self, given: Option<PathBuf>) -> PathBuf {
        given
            .or_else(|| self.report_dir.clone())
            .unwrap_or_else(|| PathBuf::from(DEFAULT_REPORT_DIR))
    }

    /// Where a line command's journals go: the manifest's `journal_dir`,
    /// else the one `upload` uses ([`crate::journal::journal_dir_or_default`]),
    /// so each sees the other's journals.
    pub fn journal_dir(&self) -> PathBuf {
        crate::journal::journal_dir_or_default(self.journal_dir.as_deref())
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn finding(kind: &str) -> ManifestFinding {
        ManifestFinding::new(kind, Location::file_only("line.toml"), kind, "")
    }

    fn manifest() -> Manifest {
        Manifest {
            path: PathBuf::from("line.toml"),
            name: "line".into(),
            label: None,
            report_dir: None,
            journal_dir: None,
            buses: Vec::new(),
            drives: Vec::new(),
        }
    }

    #[test]
    fn per_drive_findings_never_stop_a_line_and_learnable_ones_as_told() {
        let loaded = LoadedManifest {
            manifest: Some(manifest()),
            findings: vec![finding("set-address"), finding("set-rate")],
            learnable: vec![finding("wrong-type")],
        };
        assert!(loaded.clone().runnable(LearnedSets::Excused).is_ok());
        let stopped = loaded.runnable(LearnedSets::Counted).unwrap_err();
        assert_eq!(stopped.len(), 1);
        assert_eq!(stopped[0].kind, "wrong-type");
        let loaded = LoadedManifest {
            manifest: None,
            findings: vec![finding("set-rate"), finding("unknown-bus")],
            learnable: Vec::new(),
        };
        let stopped = loaded.runnable(LearnedSets::Excused).unwrap_err();
        assert_eq!(stopped.len(), 1);
        assert_eq!(stopped[0].kind, "unknown-bus");
    }

    #[test]
    fn report_and_journal_dirs_given_else_the_manifests_else_the_defaults() {
        let mut m = manifest();
        assert_eq!(m.report_dir_or(None), PathBuf::from(DEFAULT_REPORT_DIR));
        assert_eq!(
            m.journal_dir(),
            PathBuf::from(crate::journal::DEFAULT_JOURNAL_DIR)
        );
        m.report_dir = Some(PathBuf::from("r"));
        m.journal_dir = Some(PathBuf::from("j"));
        assert_eq!(m.report_dir_or(None), PathBuf::from("r"));
        assert_eq!(
            m.report_dir_or(Some("given".into())),
            PathBuf::from("given")
        );
        assert_eq!(m.journal_dir(), PathBuf::from("j"));
    }
}
