//! `driveset address --port P --protocol lustbus|lecom --to N [--from M]
//! [--baud B] [--dry-run]`: give one drive, alone on its line, its bus
//! address (and line rate) in stand-alone operation (driveset-engine's
//! `assign`; `lustbus-protocol.txt` §4.1, §4.2, §5.1, §5.2, §11.5,
//! `lecom-ab-tmd-manual.txt` §4c-§4e). The journal of an address change cut
//! short is `driveset recover`'s (cmd/recover.rs).

use std::fmt::Write as _;
use std::path::PathBuf;

use driveset_engine::assign::{self, AssignPlan, AssignReport, AssignRequest};
use driveset_engine::journal::JournalAt;
use driveset_engine::overrides::Override;

use crate::EXIT_OK;
use crate::output;
use crate::output::OutputFormat;
use crate::port::{self, Fail};
use crate::port_args::{Need, Port, PortCommand, SchemaCount, Takes};

/// Arguments of `driveset address`.
#[derive(clap::Args)]
#[command(after_help = "\
Connect the drive alone to the port (stand-alone operation), then:

LUSTBUS: finds the drive at address 0 (every device answers there,
lustbus-protocol.txt 4.2), at 9600 baud first, then at every other rate
(5.1); reads its TYPE (91) and tells an MC6000/7000 from a VF1000; scans
1..30 (5.2). Refused (exit 2, nothing written) when the line holds more than
one device (more than one answer in 1..30, or answers at address 0 that do
not decode), when N is taken by another device, or N is not 1..30. Writes
82-SIOA/SADDR = N at address 0 and verifies at N (82 = N, 91 = the same
TYPE, nothing answering at the drive's old address any more).

LECOM: the drive at --from M (default 1, the factory C0009); refused when
another device answers at N, when N is not a station address, or when C0001
does not let LECOM write (2 or 3, lecom-ab-tmd-manual.txt 4e: set it at the
keypad). Writes C0009 = N at M and verifies at N.

--baud B also sets the line rate, after the address: an MC6000/7000
activates it at once (81-SBAUD = B, then 4-PROG = 111, 11.5) and is verified
at B; a VF1000 (81-SIOC) and a Tmd (C0125) store it and take it at their
next restart (the report says so; verified by reading it back).

The drive must be at standstill: it is asked whether its motor runs before
anything is sent (and again before the first write); a running drive is
refused (exit 2) unless --allow-running, one whose running state cannot be
read unless --allow-running-unknown, as upload refuses.

The journal (--journal FILE, or DIR/<bus>-<N>.journal.json with
--journal-dir DIR; default .driveset/journal) is written before the first
write; a change cut short is finished by `driveset recover JOURNAL`, which
finds the drive at its old or new address and rate. --dry-run prints every
probe's result and each telegram it would write; it writes nothing and
makes no journal. The bus is locked for the whole command.

Exit codes: 0 done (verified), 2 refused before anything was written or a
usage error, 3 bus or device failure (the journal says how far it got).

Examples:
  driveset address --port /dev/ttyUSB0 --protocol lustbus --to 5
  driveset address --port /dev/ttyUSB0 --protocol lustbus --to 5 --baud 38400 --dry-run
  driveset address --port /dev/ttyUSB0 --protocol lecom --from 1 --to 12")]
pub struct Args {
    /// The port the drive is alone on, its bus protocol and the schemas of
    /// its family.
    #[command(flatten)]
    pub at: Port<Args>,
    /// The address to give the drive.
    #[arg(long, value_name = "N")]
    pub to: u8,
    /// LECOM: the address the drive answers at now (default 1, the factory C0009).
    #[arg(long, value_name = "M")]
    pub from: Option<u8>,
    /// Also set the line rate (baud).
    #[arg(long, value_name = "B")]
    pub baud: Option<u32>,
    /// Print what would be written; write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// The journal file.
    #[arg(long, value_name = "FILE", conflicts_with = "journal_dir")]
    pub journal: Option<PathBuf>,
    /// Directory for the journal (file name from the bus and N).
    #[arg(long, value_name = "DIR")]
    pub journal_dir: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::BUS_FORMATS), default_value = "human")]
    pub format: OutputFormat,
    /// Write the address and rate to a drive that reports a running motor.
    #[arg(long)]
    pub allow_running: bool,
    /// Write the address and rate to a drive whose running state cannot
    /// be known (its schema names no running bit).
    #[arg(long)]
    pub allow_running_unknown: bool,
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The port the drive is alone on.",
        schema: SchemaCount::Many,
        schema_help: "Schema id or file for the drive's family (repeatable), e.g. one learned by `driveset schema pull` that types 81 / 82.",
        schemas: true,
        protocol: Need::Required,
        protocol_help: "The bus protocol (lustbus or lecom).",
        ..Takes::NONE
    };
}

/// Run `driveset address`.
pub fn run(args: Args) -> Result<u8, Fail> {
    address(&args)
}

fn address(args: &Args) -> Result<u8, Fail> {
    let protocol = args
        .at
        .protocol
        .ok_or_else(|| Fail::input("give the bus protocol: --protocol lustbus|lecom"))?
        .0;
    let mut req = AssignRequest::checked(protocol, args.to, args.from, args.baud)
        .map_err(|e| Fail::input(e.to_string()))?;
    if let Some(j) = &args.journal {
        driveset_schema::input::refuse_special_file(j, driveset_schema::input::InputKind::JOURNAL)
            .map_err(|e| Fail::input(format!("--journal {}: {}", j.display(), e.detail())))?;
    }
    let schemas = port::family_schemas(&args.at.schemas, &args.at.schema)?;
    req.overrides = [
        (args.allow_running, Override::AllowRunning),
        (args.allow_running_unknown, Override::AllowRunningUnknown),
    ]
    .into_iter()
    .filter(|(on, _)| *on)
    .map(|(_, o)| o)
    .collect();
    let opened = port::open_port(args.at.port()?)?;
    let name = opened.name.clone();
    // the bus lock: open_port takes it, for the rest of the command
    let mut link = opened.link;
    let json = args.format == OutputFormat::Json;
    let plan = assign::plan(&mut link, &req, &schemas)?;
    if args.dry_run {
        emit_plan(&name, &plan, json);
        return Ok(EXIT_OK);
    }
    let journal = JournalAt::new(args.journal.as_deref(), args.journal_dir.as_deref())
        .path(&plan.bus, plan.to);
    crate::history::begin_writing("address", crate::history::Context::default())?;
    let report = assign::run(&mut link, &plan, &journal)?;
    crate::history::drive(&driveset_engine::history::DriveRecord::of_assign(&report));
    emit_report(&name, &report, json);
    Ok(EXIT_OK)
}

fn writes_json(plan: &AssignPlan) -> serde_json::Value {
    serde_json::to_value(&plan.writes).unwrap_or_default()
}

/// `address`'s JSON document: the plan (`--dry-run`: `dry_run`, `to`,
/// `rate_effect`, `writes`) or the report of the change made (`address`,
/// `rate_note`, `written`, `verified`, `journal`), with the keys both
/// share. Keys in alphabetical order, as the document always had them
/// (serde_json's maps are sorted); a key one of the two lacks is left out,
/// a key it has may be `null`.
#[derive(serde::Serialize)]
struct AddressDoc<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    address: Option<u8>,
    baud: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    dry_run: Option<bool>,
    elapsed_ms: f64,
    family: &'a str,
    found_at: FoundAt,
    #[serde(skip_serializing_if = "Option::is_none")]
    journal: Option<&'a str>,
    old_address: Option<i64>,
    port: &'a str,
    /// The engine's rate effect (its keys sorted, as they were).
    #[serde(skip_serializing_if = "Option::is_none")]
    rate_effect: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rate_note: Option<Option<&'a str>>,
    /// The scan's devices (their keys sorted, as they were).
    scan: serde_json::Value,
    scan_ms: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    to: Option<u8>,
    #[serde(rename = "type")]
    type_value: Option<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    verified: Option<&'a [String]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    writes: Option<serde_json::Value>,
    #[serde(skip_serializing_if = "Option::is_none")]
    written: Option<&'a [String]>,
}

/// Where the drive answered: address and line rate.
#[derive(serde::Serialize)]
struct FoundAt {
    address: u8,
    baud: u32,
}

impl<'a> AddressDoc<'a> {
    /// The keys the plan and the report share, of `plan` on port `name`.
    fn of(name: &'a str, plan: &'a AssignPlan) -> Self {
        AddressDoc {
            address: None,
            baud: None,
            dry_run: None,
            elapsed_ms: 0.0,
            family: plan.family.name(),
            found_at: FoundAt {
                address: plan.reached_at,
                baud: plan.rate,
            },
            journal: None,
            old_address: plan.old_address,
            port: name,
            rate_effect: None,
            rate_note: None,
            scan: serde_json::to_value(&plan.scan).unwrap_or_default(),
            scan_ms: plan.scan_time.as_secs_f64() * 1000.0,
            to: None,
            type_value: plan.type_value,
            verified: None,
            writes: None,
            written: None,
        }
    }
}

/// Print `doc` as the one JSON object of the command.
fn emit_doc(doc: &AddressDoc) {
    output::emit(&format!(
        "{}\n",
        serde_json::to_string_pretty(doc).unwrap_or_default()
    ));
}

/// The human text's first lines, the plan's and the report's alike: where
/// the drive was found (on port `name`) and what the scan saw.
fn head(name: &str, plan: &AssignPlan) -> String {
    format!("{name}: {}\n{}\n", plan.found_line(), plan.scan_line())
}

fn emit_plan(name: &str, plan: &AssignPlan, json: bool) {
    if json {
        let doc = AddressDoc {
            baud: plan.baud,
            dry_run: Some(true),
            rate_effect: Some(serde_json::to_value(plan.rate_effect).unwrap_or_default()),
            to: Some(plan.to),
            writes: Some(writes_json(plan)),
            elapsed_ms: plan.elapsed.as_secs_f64() * 1000.0,
            ..AddressDoc::of(name, plan)
        };
        emit_doc(&doc);
        return;
    }
    let mut out = head(name, plan);
    if plan.writes.is_empty() {
        let _ = writeln!(
            out,
            "nothing to write: the drive is at address {} already",
            plan.to
        );
    } else {
        let _ = writeln!(out, "would write (dry run: nothing was written):");
        for w in &plan.writes {
            let _ = writeln!(
                out,
                "  {}: {} = {} at {} baud",
                w.telegram, w.code, w.value, w.baud
            );
        }
    }
    output::emit(&out);
}

fn emit_report(name: &str, r: &AssignReport, json: bool) {
    let plan = &r.plan;
    if json {
        let doc = AddressDoc {
            address: Some(plan.to),
            baud: Some(r.rate_now),
            rate_note: Some(r.rate_note.as_deref()),
            written: Some(&r.written),
            verified: Some(&r.verified),
            journal: Some(&r.journal),
            elapsed_ms: r.elapsed.as_secs_f64() * 1000.0,
            ..AddressDoc::of(name, plan)
        };
        emit_doc(&doc);
        return;
    }
    let mut out = head(name, plan);
    for w in &r.written {
        let _ = writeln!(out, "wrote {w}");
    }
    for v in &r.verified {
        let _ = writeln!(out, "verified {v}");
    }
    if let Some(n) = &r.rate_note {
        let _ = writeln!(out, "note: {n}");
    }
    let ty = plan
        .type_value
        .map_or_else(String::new, |t| format!(", 91-TYPE {t}"));
    let _ = writeln!(
        out,
        "done: {} ({}{ty}) at address {}, {} baud ({} ms)",
        plan.family.descriptor().title,
        plan.family.name(),
        plan.to,
        r.rate_now,
        r.elapsed.as_millis()
    );
    let _ = writeln!(out, "journal: {}", r.journal);
    output::emit(&out);
}
