//! `driveset replace LINE --drive NAME --port SERVICE_PORT` (issue 20): a
//! spare for a drive of the line, alone on a service port, becomes that
//! drive. Owns [`prepare`] (find the spare and check it fits, nothing
//! written), [`finish`] (address and rate, then the set), the spare check
//! [`check_spare`] that `commission --assign` shares, and the errors
//! [`ReplaceError`].
//!
//! 1. The drive's set is checked as a line run checks it (the manifest's
//!    address is the truth: [`super::address_truth::check_drive`]); a set
//!    whose schema is learned from the drive is refused (replace needs the
//!    schema's facts before it talks to the spare).
//! 2. [`prepare`]: **`replace` never takes a live drive.** A service port
//!    that reaches a bus of the line (the same bus id,
//!    [`ReplaceOptions::line_buses`]) is refused before anything is sent
//!    ([`ReplaceError::LineBus`]). The spare is found as `driveset address`
//!    finds a drive ([`crate::assign::plan`]: LUSTBUS at address 0 at every
//!    rate, section 5.1; LECOM at the factory address 1) and must be alone
//!    on the port ([`AssignRequest::alone`]): LUSTBUS by the network list
//!    of section 5.2 and the answers at address 0 (several devices garble
//!    them, section 4.2), LECOM by a scan of every station 01..99 at the
//!    rate the spare answered; any other answer is refused, naming who
//!    answered, nothing written. (A CAN bus is refused as a whole: an ECS
//!    node id is set at the unit.) The spare must fit the set's schema: its
//!    family, and its TYPE where the schema names the types it allows
//!    ([`check_spare`], the same rule as `upload`'s identify check).
//! 3. The caller asks the engineer (the CLI's prompt), then [`finish`]:
//!    the drive's manifest address and its bus's rate are given through
//!    [`crate::assign::run`] (journalled, verified; the address is written
//!    even when the spare holds it already), then the drive's set as one
//!    upload transaction at the new address ([`crate::upload::upload`]:
//!    read back, plan, journal, write, verify). Its report is a line
//!    report of one drive (command `replace`) whose drive entry carries
//!    [`ReplacementReport`].

use std::path::PathBuf;
use std::time::Duration;

use driveset_link::Link;
use driveset_schema::{BusProtocol, Family};

use super::address_truth::{SetBusCodes, check_drive};
use super::manifest::{Bus, Drive, Manifest};
use super::report::{
    BusReport, DriveResult, LineReport, LineResult, REPORT_VERSION, ReplacementReport,
};
use crate::assign::{AssignPlan, AssignReport, AssignRequest, Schemas};
use crate::env::{Environment, rfc3339};
use crate::error::EngineError;
use crate::overrides::Overrides;
use crate::scan::ScanOptions;
use crate::session::Ports;
use crate::upload::{UploadOptions, default_journal_path, upload};

/// A spare that does not fit the drive's set.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Misfit {
    /// The drive's name.
    pub drive: String,
    /// The drive's set file as the manifest gives it.
    pub set: String,
    /// The set's schema.
    pub schema: String,
    /// What the schema wants (`mc6000`, `mc6000 with 91-TYPE 6000 or 6001`).
    pub expected: String,
    /// What answered.
    pub found: String,
}

impl std::fmt::Display for Misfit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the unit on the port is {}, but drive `{}`'s set `{}` (schema `{}`) is for {}; nothing was written. Connect a spare of the drive's family and type",
            self.found, self.drive, self.set, self.schema, self.expected
        )
    }
}

/// Why `replace` did not replace.
#[derive(Debug, thiserror::Error)]
pub enum ReplaceError {
    /// `--drive` names no drive of the manifest.
    #[error(
        "the line manifest has no drive `{name}`; its drives: {known}. Give one of them with --drive"
    )]
    UnknownDrive {
        /// The name given.
        name: String,
        /// The manifest's drive names.
        known: String,
    },
    /// The drive is on a CAN bus.
    #[error(
        "drive `{0}` is on a CAN bus: an ECS node id is set at the unit, not over the bus; give the spare its node id there, then run `driveset commission LINE --only {0}`"
    )]
    CanBus(String),
    /// The drive's set names a schema the run learns from the drive.
    #[error(
        "drive `{drive}`'s set names `{schema}`, whose facts are learned from the drive: name a learned schema in the set (the learned-*.toml `driveset commission` wrote), then run `replace` again"
    )]
    Learned {
        /// The drive.
        drive: String,
        /// The built-in schema the set names.
        schema: String,
    },
    /// The set disagrees with the manifest's address or rate.
    #[error("drive `{}`: {}", .0.drive, .0)]
    SetBusCodes(SetBusCodes),
    /// The spare does not fit the set.
    #[error("{0}")]
    Misfit(Misfit),
    /// The spare has its address and rate, but the set's upload failed
    /// (rolled back, or left as the journal says); the report says which.
    #[error("the spare was given its address and rate, but the set's upload failed: {error}")]
    Upload {
        /// The report of the run (one drive, failed or rolled back).
        report: Box<LineReport>,
        /// The upload's failure.
        error: EngineError,
    },
    /// The service port reaches a bus of the line (the same bus id): the
    /// line's drives are on it. Nothing was sent.
    #[error(
        "the service port {port} reaches bus `{bus}` of the line ({bus_port}; bus id {id}): the line's drives are on it, and a spare must be alone on its port; nothing was sent. Connect the spare alone to a service port and run again"
    )]
    LineBus {
        /// The service port as given.
        port: String,
        /// The line's bus it reaches.
        bus: String,
        /// That bus's port as the manifest names it.
        bus_port: String,
        /// The bus id both reach.
        id: String,
    },
    /// The engine refused or failed (the assignment's refusals: more than
    /// one unit on the port, the address taken ...; transport failures).
    #[error("{0}")]
    Engine(#[from] EngineError),
}

/// A bus of the line and the bus id its port reaches, as the front end
/// knows it before opening the port (a serial device, a simulated bus's
/// state file, a TCP device server's resolved addresses): `replace` refuses
/// a service port that reaches it ([`ReplaceError::LineBus`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineBusId {
    /// The bus's name.
    pub bus: String,
    /// Its port as the manifest names it.
    pub port: String,
    /// A bus id its port reaches (one entry per id: a host name may
    /// resolve to several addresses).
    pub id: String,
}

impl ReplaceError {
    /// The layer this failure comes from ([`crate::error::Layer`]): a rule
    /// refused and nothing was written (the manifest, the set, the spare,
    /// the engine's refusals), or the replacement failed on the way (the
    /// engine's other failures, the journal's included, and the set's
    /// upload: the report says what the spare holds).
    pub fn layer(&self) -> crate::error::Layer {
        use crate::error::Layer;
        match self {
            ReplaceError::Engine(e) if e.is_refused() => Layer::Refusal,
            ReplaceError::Engine(_) | ReplaceError::Upload { .. } => Layer::Transaction,
            ReplaceError::UnknownDrive { .. }
            | ReplaceError::CanBus(_)
            | ReplaceError::Learned { .. }
            | ReplaceError::SetBusCodes(_)
            | ReplaceError::Misfit(_)
            | ReplaceError::LineBus { .. } => Layer::Refusal,
        }
    }
}

/// The spare fits drive `d`'s set (module docs, step 2).
pub fn check_spare(d: &Drive, p: &AssignPlan) -> Result<(), Misfit> {
    let schema = &d.schema;
    let types: Vec<i64> = schema
        .identify
        .as_ref()
        .map(|i| i.type_values.clone())
        .unwrap_or_default();
    let type_label = schema.display_code(91, None);
    let expected = if types.is_empty() || schema.family.bus() != BusProtocol::Lustbus {
        schema.family.name().to_string()
    } else {
        let list: Vec<String> = types.iter().map(i64::to_string).collect();
        format!(
            "{} with {type_label} {}",
            schema.family.name(),
            list.join(" or ")
        )
    };
    let found = match p.type_value {
        Some(t) => format!("{} with {type_label} {t}", p.family.name()),
        None => p.family.name().to_string(),
    };
    let type_fits = types.is_empty()
        || schema.family.bus() != BusProtocol::Lustbus
        || p.type_value.is_some_and(|t| types.contains(&t));
    if p.family == schema.family && type_fits {
        Ok(())
    } else {
        Err(Misfit {
            drive: d.name.clone(),
            set: d.set_text.clone(),
            schema: schema.id.clone(),
            expected,
            found,
        })
    }
}

/// What `replace` does.
#[derive(Debug, Clone)]
pub struct ReplaceOptions {
    /// Where the assignment and upload journals go.
    pub journal_dir: PathBuf,
    /// Probe timeouts of the search.
    pub scan: ScanOptions,
    /// Passed to the upload (each lifts one refusal).
    pub overrides: Overrides,
    /// The line's buses and the bus ids their ports reach: a service port
    /// that reaches one of them is refused before anything is sent.
    pub line_buses: Vec<LineBusId>,
    /// The service port's options (its `latency=`), for the set's upload.
    pub connect: crate::connect::ConnectOptions,
}

impl ReplaceOptions {
    /// The options of replacing a drive of `manifest`: its journal
    /// directory (else [`crate::journal::DEFAULT_JOURNAL_DIR`]), the named
    /// `overrides` for the set's upload, the bus ids the line's buses
    /// reach as `ports` tells them before opening ([`line_bus_ids`]), the
    /// default probes and connect options (the caller puts the service
    /// port's in once it is open).
    pub fn for_line(manifest: &Manifest, overrides: Overrides, ports: &dyn Ports) -> Self {
        ReplaceOptions {
            journal_dir: crate::journal::journal_dir_or_default(manifest.journal_dir.as_deref()),
            scan: ScanOptions::default(),
            overrides,
            line_buses: line_bus_ids(manifest, ports),
            connect: crate::connect::ConnectOptions::default(),
        }
    }
}

/// The bus ids the line's buses reach, as far as their ports say before
/// they are opened (a serial device, an slcan adapter, a simulated bus's
/// state file: [`Ports::bus_before_open`]; a TCP or RFC 2217 device server:
/// every address its host resolves to,
/// [`driveset_link::bus_id::tcp_candidates`]), so that `replace` refuses a
/// service port that reaches the line's own bus ([`ReplaceError::LineBus`]).
pub fn line_bus_ids(manifest: &Manifest, ports: &dyn Ports) -> Vec<LineBusId> {
    let mut out = Vec::new();
    for bus in &manifest.buses {
        let text = bus.port.to_string();
        let mut ids: Vec<String> = ports
            .bus_before_open(&text, &bus.port)
            .into_iter()
            .collect();
        ids.extend(driveset_link::bus_id::tcp_candidates(&bus.port));
        out.extend(ids.into_iter().map(|id| LineBusId {
            bus: bus.name.clone(),
            port: bus.port_name.clone(),
            id,
        }));
    }
    out
}

/// The spare found and checked: what [`finish`] will write.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The drive of the line the spare becomes.
    pub drive: Drive,
    /// Its bus.
    pub bus: Bus,
    /// The assignment's plan (the spare as found, the writes).
    pub plan: AssignPlan,
}

impl Prepared {
    /// Codes in the drive's set.
    pub fn codes(&self) -> usize {
        self.drive.set.values.len()
    }
}

/// What [`finish`] did.
#[derive(Debug, Clone)]
pub struct ReplaceOutcome {
    /// The line report of one drive (command `replace`).
    pub report: LineReport,
    /// The assignment.
    pub assign: AssignReport,
    /// Link clock time of finding the spare, giving it its address and
    /// rate, and of the set's upload.
    pub assign_time: Duration,
    /// Link clock time of the set's upload.
    pub upload_time: Duration,
}

impl ReplaceOutcome {
    /// The whole command's time on the service port's clock.
    pub fn total(&self) -> Duration {
        self.assign_time + self.upload_time
    }
}

/// The drive `name` of `manifest`, checked (module docs, step 1).
pub fn drive_of<'m>(manifest: &'m Manifest, name: &str) -> Result<&'m Drive, ReplaceError> {
    let Some(d) = manifest.drives.iter().find(|d| d.name == name) else {
        return Err(ReplaceError::UnknownDrive {
            name: name.to_string(),
            known: manifest
                .drives
                .iter()
                .map(|d| d.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        });
    };
    let bus = &manifest.buses[d.bus_index];
    if bus.protocol == BusProtocol::CanSdo {
        return Err(ReplaceError::CanBus(d.name.clone()));
    }
    if let Some(base) = &d.learn_from {
        return Err(ReplaceError::Learned {
            drive: d.name.clone(),
            schema: base.id.clone(),
        });
    }
    check_drive(bus, d).map_err(ReplaceError::SetBusCodes)?;
    Ok(d)
}

/// A refused search on a LUSTBUS port whose unit is of another family
/// than the set's (its built-in schema may lack what the search needs):
/// the misfit, said as such; otherwise the search's own error.
fn misfit_or(d: &Drive, link: &mut Link, opts: &ReplaceOptions, e: EngineError) -> ReplaceError {
    if d.schema.family.bus() != BusProtocol::Lustbus || !e.is_refused() {
        return e.into();
    }
    let Link::Bytes(b) = link else {
        return e.into();
    };
    match lone_family(&mut **b, opts) {
        Some(found) if found != d.schema.family => ReplaceError::Misfit(Misfit {
            drive: d.name.clone(),
            set: d.set_text.clone(),
            schema: d.schema.id.clone(),
            expected: d.schema.family.name().to_string(),
            found: found.name().to_string(),
        }),
        _ => e.into(),
    }
}

/// The family of the lone LUSTBUS unit at address 0 (section 4.2: every
/// device answers there) at the link's present rate: it answers the
/// ENQUIRY of 91-TYPE; an MC6000/7000 also the MC CODE 20091, a VF1000
/// NAKs it (as `crate::scan::detect_protocol` tells them apart): the
/// family is the one that speaks the dialect it answered in
/// ([`Family::from_dialect`]).
fn lone_family(b: &mut dyn driveset_link::ByteLink, opts: &ReplaceOptions) -> Option<Family> {
    use crate::client::lustbus::{LustLine, probe_code, probe_type};
    use driveset_proto::lustbus::{Address, Dialect, ParameterCode};
    let timeout = opts
        .scan
        .timeout
        .unwrap_or_else(|| Duration::from_millis(65) + driveset_link::mem::wire_time(14, b.baud()));
    let zero = Address::new(0)?;
    let mut line = LustLine::new(crate::client::BorrowedByteLink(b));
    let ty = probe_type(&mut line, zero, timeout, opts.scan.tries).ok()?;
    ty?;
    let code = ParameterCode::mc_value(91)?;
    let mc = probe_code(&mut line, zero, code, timeout, 1).ok()?;
    let _ = line.finish();
    Some(match mc {
        Some(Some(_)) => Family::from_dialect(Dialect::Mc),
        _ => Family::from_dialect(Dialect::Vf1000),
    })
}

/// Every family's built-in schema, so that a spare of another family is
/// identified (and refused as a misfit by [`check_spare`]).
pub(super) fn known_schemas() -> Schemas {
    driveset_schema::Registry::builtin()
        .map(|r| Schemas::from_registry(&r))
        .unwrap_or_default()
}

fn link_now(link: &Link) -> driveset_link::Instant {
    match link {
        Link::Bytes(b) => b.clock().now(),
        Link::Frames(f) => f.clock().now(),
    }
}

/// Find the spare on `link` and check it (module docs, step 2): nothing
/// is written.
pub fn prepare(
    manifest: &Manifest,
    name: &str,
    link: &mut Link,
    opts: &ReplaceOptions,
) -> Result<Prepared, ReplaceError> {
    let d = drive_of(manifest, name)?;
    let bus = &manifest.buses[d.bus_index];
    let reached = link.bus_id();
    if let Some(b) = opts.line_buses.iter().find(|b| b.id == reached) {
        return Err(ReplaceError::LineBus {
            port: link.port().to_string(),
            bus: b.bus.clone(),
            bus_port: b.port.clone(),
            id: b.id.clone(),
        });
    }
    let mut req = AssignRequest::new(bus.protocol, d.address)
        .always_write_address()
        .alone();
    if bus.rate != 0 {
        req = req.baud(bus.rate);
    }
    req.scan = opts.scan.clone();
    req.overrides = opts.overrides;
    let schemas = known_schemas().with(d.schema.clone());
    let plan = match crate::assign::plan(link, &req, &schemas) {
        Ok(p) => p,
        Err(e) => return Err(misfit_or(d, link, opts, e)),
    };
    check_spare(d, &plan).map_err(ReplaceError::Misfit)?;
    Ok(Prepared {
        drive: d.clone(),
        bus: bus.clone(),
        plan,
    })
}

/// Give the spare its address and rate, then its set (module docs, step
/// 3). `service_port` names the port in the report.
pub fn finish(
    manifest: &Manifest,
    prep: &Prepared,
    link: &mut Link,
    service_port: &str,
    opts: &ReplaceOptions,
    env: &dyn Environment,
) -> Result<ReplaceOutcome, ReplaceError> {
    let started = rfc3339(env.now_utc());
    let t0 = link_now(link);
    let p = &prep.plan;
    let journal = crate::journal::journal_path(&opts.journal_dir, &p.bus, p.to);
    let assign = crate::assign::run(link, p, &journal)?;
    let t1 = link_now(link);
    let d = &prep.drive;
    let mut client = crate::session::BusSession::connect_using(
        link,
        service_port,
        d.schema.clone(),
        d.address,
        opts.connect,
    )?
    .client;
    let stats0 = client.stats();
    let mut uo = UploadOptions::new(default_journal_path(&opts.journal_dir, &*client));
    uo.overrides = opts.overrides;
    let result = upload(&mut *client, &d.set, &uo);
    let stats = client.stats();
    let _ = client.finish();
    drop(client);
    let t2 = link_now(link);
    let mut r = super::commission::blank_report(d, &prep.bus, DriveResult::Failed);
    r.telegrams = stats.telegrams.saturating_sub(stats0.telegrams);
    r.retries = stats.retries.saturating_sub(stats0.retries);
    r.elapsed_ms = t2.saturating_duration_since(t0).as_secs_f64() * 1000.0;
    r.replacement = Some(ReplacementReport {
        service_port: service_port.to_string(),
        found_address: p.reached_at,
        found_rate: p.rate,
        old_address: p.old_address,
        address: p.to,
        rate: assign.rate_now,
        rate_note: assign.rate_note.clone(),
        assigned: assign.written.clone(),
    });
    let failure = match result {
        Ok(rep) => {
            super::commission::fill_from_upload(&mut r, &d.schema, &rep.identity, &rep.codes);
            r.fingerprint_before = Some(rep.fingerprint_before.clone());
            r.fingerprint_after = rep.fingerprint_after.clone();
            r.codes_written = rep.codes_written as u32;
            r.result = DriveResult::Verified;
            None
        }
        Err(f) => {
            if let Some(rep) = &f.report {
                super::commission::fill_from_upload(&mut r, &d.schema, &rep.identity, &rep.codes);
                r.fingerprint_before = Some(rep.fingerprint_before.clone());
                r.fingerprint_after = rep.fingerprint_after.clone();
                r.codes_written = rep.codes_written as u32;
            }
            let e = *f.error;
            if e.is_rolled_back() {
                r.result = DriveResult::RolledBack;
            }
            r.error = Some(e.to_string());
            Some(e)
        }
    };
    let result = if failure.is_none() {
        LineResult::Ok
    } else {
        LineResult::Failed
    };
    let bus_report = BusReport {
        name: prep.bus.name.clone(),
        port: service_port.to_string(),
        protocol: prep.bus.protocol,
        rate: assign.rate_now,
        elapsed_ms: r.elapsed_ms,
        timeline: Vec::new(),
    };
    let dir = manifest.path.parent().unwrap_or(std::path::Path::new("."));
    let report = LineReport {
        report_version: REPORT_VERSION,
        command: "replace".into(),
        line: manifest.name.clone(),
        manifest: manifest.path.display().to_string(),
        label: manifest.label.clone(),
        started,
        finished: rfc3339(env.now_utc()),
        git: env.git_info(dir),
        result,
        buses: vec![bus_report],
        drives: vec![r],
        history: None,
    };
    if let Some(e) = failure {
        return Err(ReplaceError::Upload {
            report: Box::new(report),
            error: e,
        });
    }
    Ok(ReplaceOutcome {
        report,
        assign,
        assign_time: t1.saturating_duration_since(t0),
        upload_time: t2.saturating_duration_since(t1),
    })
}
