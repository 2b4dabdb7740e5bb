//! `driveset commission LINE`: bring every drive of a machine line to its
//! set (buses in parallel, drives on one bus in turn), write the
//! commissioning report. The run itself, which `driveset status` shares, is
//! [`crate::line`]'s; `--assign` is [`crate::line::commission_assign`]'s.

use std::path::PathBuf;

use crate::EXIT_FINDINGS;
use crate::line::{COMMISSION, Common, load, run_mode};

/// Arguments of `driveset commission`.
#[derive(clap::Args)]
#[command(after_help = "\
For every selected drive: identify, read back, diff, upload what differs as
one transaction, verify. Buses run in
parallel, the drives of one bus in turn. One progress line per drive on
stderr (on a terminal, with CI unset, above one progress bar per bus showing
the drive and the phase its transaction is in), a summary table on stdout,
report.json + report.html in the report directory (default
target/driveset-report, or the manifest's report_dir).

Resume: drives that end holding their set are recorded in
REPORT_DIR/.commission-state.json. A rerun confirms each recorded drive with
one read of its set's codes (no writes) and reports it `already-verified`;
drives whose set changed, that drifted, or that were not reached are
commissioned. --fresh ignores the file.

Journals: in the manifest's journal_dir, default .driveset/journal (the
directory `driveset upload` uses; same naming: <bus>-<address>.journal.json).
A drive with an unfinished journal (of an upload or of a killed commission
run, found by bus and address, not by file name) is never `unchanged`: it is
recovered first (`driveset recover`'s rules, a warning says what was done),
then commissioned; if recovery refuses (the journal is stale or does not fit
the drive) or fails, the drive is `failed`.

Sets naming a built-in LUSTBUS schema that lacks facts (lust-mc6000,
lust-vf1000: most codes have no type or range in the spec): before the drive
is planned, its own descriptions (VF1000 specifier 1, MC specifier 3) and MC
substitution texts are read, the schema is learned as `driveset pull` learns
it (the built-in schema's spec facts stand), written to
--schema-dir/learned-<family>-type<TYPE>-<software>.toml (default: the
report directory) and named in the report (`learned_schema`); the set is
then checked against it. --no-learn refuses such sets at load instead.

--assign (a line fresh from the factory): first, per LUSTBUS / LECOM bus in
manifest order, \"connect NAME alone to PORT, then press Enter\" for every
drive; each gets its manifest address and its bus's rate (as `driveset
address`); then the bus is scanned: every manifest address must answer with
its set's family, nothing else may answer (a table is printed). CAN buses are
skipped (ECS node ids are set at the unit). Only when every bus holds does
the normal commission follow. --yes: no prompts (manifest order); without
--yes stdin must be a terminal (exit 2 otherwise).

Exit codes: 0 every selected drive holds its set; 1 a drive does not
(refused, rolled back, failed; or --assign found the line not as its manifest); 2 usage error or a manifest with findings;
3 a bus could not be opened, a link failed or a drive did not answer (3 wins
over 1).

Examples:
  driveset commission parameter-sets/demo-line/line.toml
  driveset commission line.toml --only press,conveyor-5 --label \"FAT 7\"
  driveset commission line.toml --skip handling --report-dir out/")]
pub struct Args {
    /// The line manifest (TOML or YAML).
    #[arg(value_name = "LINE")]
    pub manifest: PathBuf,
    /// Only these drives (names; a bus name selects its drives).
    #[arg(long, value_name = "NAME,..", value_delimiter = ',')]
    pub only: Vec<String>,
    /// Leave these drives (or buses) out.
    #[arg(long, value_name = "NAME,..", value_delimiter = ',')]
    pub skip: Vec<String>,
    /// Label written into the report (default: the manifest's `label`).
    #[arg(long, value_name = "TEXT")]
    pub label: Option<String>,
    /// Where report.json, report.html, the state file and the journals go.
    #[arg(long, value_name = "DIR")]
    pub report_dir: Option<PathBuf>,
    /// Named overrides passed to every upload, one per refusal.
    #[command(flatten)]
    pub allow: crate::allow::AllowArgs,
    /// Send values the drives share once. LECOM: by MULTICAST to each
    /// group (x1..x9; unacknowledged, no journal backup). LUSTBUS (MC6000/
    /// 7000 only): CardWriteable values as one SELECT to address 31, which
    /// every device on the bus executes without a receipt, inside every
    /// drive's SLOAD dataset download (journalled); never 81..85, 91 or a
    /// code with a role; refused on a bus with VF1000s, with unselected or
    /// running drives, or with unfinished journals. Every drive is then
    /// verified code by code. CAN: per-drive writes.
    #[arg(long)]
    pub broadcast_common: bool,
    /// Ignore the resume state: commission every selected drive.
    #[arg(long)]
    pub fresh: bool,
    /// Test hook: every bus stops after N drives, as if the run were killed.
    #[arg(long, value_name = "N", hide = true)]
    pub stop_after: Option<usize>,
    /// Learning the schema of drives whose set's schema lacks facts.
    #[command(flatten)]
    pub learn: crate::port_args::LearnArgs,
    /// Rehearse against the twins in DIR (DIR/<drive name>.twin.toml), in
    /// virtual time: same plan, refusals, report and exit codes. A missing
    /// or empty DIR, or no twin of any selected drive, is an error (exit
    /// 2); a selected drive without a twin is not rehearsed and fails the
    /// run (exit 1) unless --allow-missing-twins (docs/twins.md).
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    #[arg(long, value_name = "DIR")]
    pub rehearse: Option<PathBuf>,
    /// With --rehearse: a selected drive without a twin is not rehearsed
    /// and the run still exits 0 when every rehearsed drive holds its set
    /// (without it such a run exits 1).
    #[arg(long, requires = "rehearse")]
    pub allow_missing_twins: bool,
    /// The line's first contact: give every drive of the LUSTBUS / LECOM
    /// buses its manifest address and its bus's rate, one drive at a time
    /// (connect each alone when asked), scan every bus, then commission
    /// (docs/factory-fresh.md).
    #[arg(long)]
    pub assign: bool,
    /// With --assign: the port the drives are connected to one at a time
    /// (default: the bus's own port; a line with one LUSTBUS/LECOM bus).
    #[arg(long, value_name = "PORT", requires = "assign")]
    pub port: Option<String>,
    /// With --assign: do not prompt; the drives are taken in manifest order.
    #[arg(long, requires = "assign")]
    pub yes: bool,
    /// Test hook: read the prompts' answers from stdin even when it is not a terminal.
    #[arg(long, hide = true)]
    pub prompt_stdin: bool,
}

/// Run `driveset commission`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let overrides = args.allow.overrides()?;
    if args.assign && !first_contact(&args, overrides)? {
        eprintln!(
            "error: the line does not match its manifest after the address assignment; not commissioned (fix what the table shows, then run `driveset commission {}`)",
            args.manifest.display()
        );
        return Ok(EXIT_FINDINGS);
    }
    let opts = Common {
        manifest: args.manifest,
        only: args.only,
        skip: args.skip,
        label: args.label,
        report_dir: args.report_dir,
        learn: args.learn,
        rehearse: args.rehearse,
        allow_missing_twins: args.allow_missing_twins,
        stop_after: args.stop_after,
    };
    run_mode(opts, COMMISSION, |o| {
        o.overrides = overrides;
        o.broadcast_common = args.broadcast_common;
        o.fresh = args.fresh;
    })
}

/// `--assign`: the line's first contact before the commission
/// ([`crate::line::commission_assign::run`]); `Ok(true)` when every bus holds.
fn first_contact(
    args: &Args,
    overrides: driveset_engine::overrides::Overrides,
) -> Result<bool, crate::fail::Fail> {
    let manifest = match load(&args.manifest, crate::line::learned_sets(&args.learn)) {
        Ok(m) => m,
        Err(code) => return Err(crate::fail::Fail::reported(code)),
    };
    let journal_dir = manifest.journal_dir();
    let a = crate::line::commission_assign::AssignArgs {
        port: args.port.clone(),
        yes: args.yes,
        prompt_stdin: args.prompt_stdin,
        only: args.only.clone(),
        overrides,
    };
    crate::line::commission_assign::run(&manifest, &a, journal_dir)
}
