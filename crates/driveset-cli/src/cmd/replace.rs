//! `driveset replace LINE --drive NAME --port SERVICE_PORT`: a spare, alone
//! on a service port, becomes drive NAME of the line (the engine's
//! `line::replace`): its manifest address and its bus's rate, then its set
//! as one verified transaction.

use std::path::PathBuf;

use driveset_engine::error::EngineError;
use driveset_engine::history::DriveRecord;
use driveset_engine::line::replace::{
    Prepared, ReplaceError, ReplaceOptions, ReplaceOutcome, finish, prepare,
};
use driveset_link::{Link, PortSpec};

use crate::fail::Fail;
use crate::output::OutputFormat;
use crate::port_args::{Need, Port, PortCommand, Takes};
use crate::prompt::{ask, confirm_allowed};
use crate::{EXIT_FINDINGS, EXIT_OK, port, report};

/// Arguments of `driveset replace`.
#[derive(clap::Args)]
#[command(after_help = "\
The spare must be alone on the service port, and replace proves it before
anything is written: a service port that reaches a bus of the line (the same
bus id: the same serial device, device server or simulated bus) is refused
before anything is sent, naming the bus; the spare is found as `driveset
address` finds a drive (LUSTBUS: at address 0, every rate tried, section
5.1; LECOM: at the factory address 1), and any other device that answers is
refused, named (LUSTBUS: the network list 1..30 of section 5.2 and the
answers at address 0; LECOM: a scan of every station 01..99 at the rate the
spare answered). The spare must be of the family (and, where
the set's schema names them, the TYPE) of the drive's set, and then gets
the drive's manifest address and its bus's rate (journalled, verified),
then the drive's set as one upload transaction (read back, journal, write,
verify). Nothing is written before you confirm (or give --yes).

The report (one drive, marked as a replacement) goes to
REPORT_DIR/replace-NAME/report.json and report.html (REPORT_DIR: --report-dir,
else the manifest's report_dir, else target/driveset-report).

Exit codes: 0 replaced and verified; 1 the set's upload failed (rolled back)
or you declined; 2 usage error, a manifest with findings, a spare that does
not fit, more than one unit on the port, no --yes on a non-interactive
stdin, a service port that reaches a bus of the line; 3 the port could not
be opened or the spare did not answer.

Examples:
  driveset replace line.toml --drive press-axis-3 --port /dev/ttyUSB1
  driveset replace line.toml --drive press-axis-3 --port /dev/ttyUSB1 --yes --format json")]
pub struct Args {
    /// The line manifest (TOML or YAML).
    #[arg(value_name = "LINE")]
    pub manifest: PathBuf,
    /// The drive of the line the spare becomes.
    #[arg(long, value_name = "NAME")]
    pub drive: String,
    /// The service port the spare is alone on.
    #[command(flatten)]
    pub at: Port<Args>,
    /// Do not ask before writing.
    #[arg(long)]
    pub yes: bool,
    /// Output: text, or one JSON object on stdout.
    #[arg(long, value_parser = crate::output::formats(crate::output::REPLACE_FORMATS), default_value = "text")]
    pub format: OutputFormat,
    /// Where the report goes (REPORT_DIR/replace-NAME/).
    #[arg(long, value_name = "DIR")]
    pub report_dir: Option<PathBuf>,
    /// Named overrides passed to the set's upload.
    #[command(flatten)]
    pub allow: crate::allow::AllowArgs,
    /// Test hook: read the answer from stdin even when it is not a terminal.
    #[arg(long, hide = true)]
    pub prompt_stdin: bool,
}

/// Open a port string and lock its bus, as every command does (the
/// engine's [`driveset_engine::session::open_port`] over
/// [`port::CliPorts`]: `sim://` in-process); the port as its parsed form
/// spells it.
fn open_service_port(
    port_text: &str,
) -> Result<(Link, String, driveset_engine::connect::ConnectOptions), Fail> {
    let spec = PortSpec::parse(port_text).map_err(|e| {
        Fail::input(format!(
            "{e}; ports look like /dev/ttyUSB0?baud=9600, tcp://host:4001 or sim://mc6000?factory=1"
        ))
    })?;
    let opened = driveset_engine::session::open_port(&port::CliPorts, port_text, None)?;
    Ok((opened.link, spec.to_string(), opened.connect))
}

fn question(p: &Prepared, port: &str) -> String {
    format!(
        "replace {}: write address {}, {} baud and {} codes to the unit on {port}? [y/N] ",
        p.drive.name,
        p.drive.address,
        p.bus.rate,
        p.codes()
    )
}

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Required,
        port_help: "The service port the spare is alone on.",
        ..Takes::NONE
    };
}

/// Run `driveset replace`.
pub fn run(args: Args) -> Result<u8, Fail> {
    let overrides = args.allow.overrides()?;
    let manifest = match crate::line::load(&args.manifest, crate::line::LearnedSets::Counted) {
        Ok(m) => m,
        Err(code) => return Err(Fail::reported(code)),
    };
    // a known drive with a fitting set, before the port is touched
    driveset_engine::line::replace::drive_of(&manifest, &args.drive).map_err(|e| Fail::from(&e))?;
    if !args.yes && !args.prompt_stdin {
        confirm_allowed("replace")?;
    }
    let report_dir = manifest
        .report_dir_or(args.report_dir.clone())
        .join(format!("replace-{}", args.drive));
    let opts = ReplaceOptions::for_line(&manifest, overrides, &port::CliPorts);
    let (mut link, port_name, connect) = open_service_port(args.at.port()?)?;
    let opts = ReplaceOptions { connect, ..opts };
    let prep = prepare(&manifest, &args.drive, &mut link, &opts).map_err(|e| Fail::from(&e))?;
    if args.format == OutputFormat::Text {
        outln!("{}", spare_line(&prep, &port_name));
    }
    if !args.yes {
        let answer = ask(&question(&prep, &port_name))?;
        if !matches!(answer.to_ascii_lowercase().as_str(), "y" | "yes") {
            eprintln!("not replaced: nothing was written");
            return Ok(EXIT_FINDINGS);
        }
    }
    crate::history::begin_writing(
        "replace",
        crate::history::Context {
            manifest: Some(args.manifest.display().to_string()),
            sets: Some(args.manifest.clone()),
            label: manifest.label.clone(),
        },
    )?;
    let env = crate::env::SystemEnv;
    let outcome = finish(&manifest, &prep, &mut link, &port_name, &opts, &env);
    let (mut report, done) = match outcome {
        Ok(o) => (o.report.clone(), Ok(o)),
        Err(ReplaceError::Upload { report, error }) => (*report, Err(error)),
        Err(e) => return Err(Fail::from(&e)),
    };
    // the slot's new unit, on record with what was written to it
    for d in report.drives.iter().filter(|d| d.name == args.drive) {
        let family = prep.plan.family.to_string();
        crate::history::drive(&DriveRecord::of_replacement(&report.line, d, &family));
    }
    crate::history::link_report(&mut report);
    let written = report::write_reports(&report, &report_dir).map_err(|e| {
        Fail::input(format!(
            "cannot write the report into {}: {e}",
            report_dir.display()
        ))
    })?;
    let status_cmd = format!(
        "driveset status {} --only {}",
        args.manifest.display(),
        prep.drive.name
    );
    let shown = Shown {
        prep: &prep,
        port_name: &port_name,
        written: &written,
        status_cmd: &status_cmd,
    };
    match done {
        Ok(o) => {
            shown.replaced(&o, args.format);
            Ok(EXIT_OK)
        }
        Err(e) => Ok(shown.upload_failed(&e)),
    }
}

/// The spare as found on the service port `port_name`: its family,
/// address, rate and identify codes.
fn spare_line(prep: &Prepared, port_name: &str) -> String {
    let id = prep
        .plan
        .identity
        .pairs()
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "spare on {port_name}: {} at address {}, {} baud{}",
        prep.plan.family,
        prep.plan.reached_at,
        prep.plan.rate,
        if id.is_empty() {
            String::new()
        } else {
            format!(" ({id})")
        }
    )
}

/// What the end of a replacement shows: the spare, the service port, the
/// report files written and the command that checks the drive on the line.
struct Shown<'a> {
    prep: &'a Prepared,
    port_name: &'a str,
    written: &'a (PathBuf, PathBuf),
    status_cmd: &'a str,
}

impl Shown<'_> {
    /// The spare replaced and verified: the JSON document or the text.
    fn replaced(&self, o: &ReplaceOutcome, format: OutputFormat) {
        let (d, prep, written) = (&self.prep.drive, self.prep, self.written);
        let r = &o.report.drives[0];
        if format == OutputFormat::Json {
            let v = Replaced {
                address: d.address,
                codes: prep.codes(),
                codes_written: r.codes_written,
                drive: &d.name,
                factory_settings: r.factory_settings,
                next: self.status_cmd,
                rate: o.assign.rate_now,
                rate_note: &o.assign.rate_note,
                report: written.0.display().to_string(),
                result: "replaced",
                service_port: self.port_name,
                virtual_ms: VirtualMs {
                    assign: o.assign_time.as_secs_f64() * 1000.0,
                    total: o.total().as_secs_f64() * 1000.0,
                    upload: o.upload_time.as_secs_f64() * 1000.0,
                },
            };
            outln!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
            return;
        }
        for w in &o.assign.written {
            outln!("wrote {w}");
        }
        outln!(
            "{}: address {}, {} baud, {} codes written and verified ({} codes in the set){} ({:.3} s on the bus)",
            d.name,
            d.address,
            o.assign.rate_now,
            r.codes_written,
            prep.codes(),
            if r.factory_settings {
                "; the spare was at factory settings"
            } else {
                ""
            },
            o.total().as_secs_f64()
        );
        if let Some(n) = &o.assign.rate_note {
            outln!("note: {n}");
        }
        outln!("report: {} {}", written.0.display(), written.1.display());
        outln!(
            "next: plug it into the line (bus `{}`, {}) and run `{}`",
            prep.bus.name,
            prep.bus.port_name,
            self.status_cmd
        );
    }

    /// The spare has its address and rate but the set's upload failed
    /// (`e`): said on stderr, the report named; the exit code (3 when the
    /// link failed or the spare did not answer, else 1).
    fn upload_failed(&self, e: &EngineError) -> u8 {
        let (d, written) = (&self.prep.drive, self.written);
        eprintln!(
            "error: {}: given address {} and {} baud, but the set's upload failed: {e}",
            d.name, d.address, self.prep.bus.rate
        );
        outln!("report: {} {}", written.0.display(), written.1.display());
        crate::fail::set_after_address_exit(e)
    }
}

/// `replace --format json`'s document (keys in alphabetical order, as it
/// always had them).
#[derive(serde::Serialize)]
struct Replaced<'a> {
    address: u8,
    codes: usize,
    codes_written: u32,
    drive: &'a str,
    factory_settings: bool,
    next: &'a str,
    rate: u32,
    rate_note: &'a Option<String>,
    report: String,
    result: &'static str,
    service_port: &'a str,
    virtual_ms: VirtualMs,
}

/// The virtual time of a replacement's steps, in milliseconds.
#[derive(serde::Serialize)]
struct VirtualMs {
    assign: f64,
    total: f64,
    upload: f64,
}
