//! `driveset`: the command-line tool. A thin layer over the libraries: it
//! parses arguments (clap), calls into `driveset-schema`, `driveset-proto`
//! and friends, prints human or machine output and maps results to exit codes.
//!
//! Exit codes (README.md, "A short tour"): 0 ok, 1 validation findings or
//! differences, 2 usage or input error, 3 bus or device failure.

// Every byte for stdout goes through `output::emit`, which handles a
// closed stdout (EPIPE) in one place; `print!` would panic on it.
#![deny(clippy::print_stdout)]

/// `println!` through [`output::emit`] (closed-stdout safe).
macro_rules! outln {
    ($($t:tt)*) => {
        $crate::output::emit(&format!("{}\n", format_args!($($t)*)))
    };
}

/// `print!` through [`output::emit`] (closed-stdout safe).
macro_rules! out {
    ($($t:tt)*) => {
        $crate::output::emit(&format!($($t)*))
    };
}

mod allow;
mod args;
mod cmd;
mod editor;
mod env;
mod fail;
mod files;
mod git;
mod history;
mod line;
mod offline;
mod output;
mod port;
mod port_args;
mod progress;
mod prompt;
mod report;

use std::process::ExitCode;

// `driveset validate` over a repository of sets allocates many small nodes;
// mimalloc makes that ~10 % faster than the system allocator
// (crates/driveset-schema/benches/validate_many.rs uses the same).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use clap::{Parser, Subcommand};

/// Exit code: everything fine.
pub const EXIT_OK: u8 = 0;
/// Exit code: validation findings, or the compared sets differ.
pub const EXIT_FINDINGS: u8 = 1;
/// Exit code: usage error or unreadable / malformed input.
pub const EXIT_INPUT: u8 = 2;
/// Exit code: bus or device failure.
pub const EXIT_BUS: u8 = 3;

#[derive(Parser)]
#[command(
    name = "driveset",
    version,
    about = "Parameter sets of industrial drives (Lenze Tmd, Lust VF1000 / MC6000, Lenze ECS) as reviewed files",
    propagate_version = true
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Where the run is recorded (docs/history.md).
    #[command(flatten)]
    history: history::HistoryArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Check parameter sets against the schema of their drive family (no hardware).
    Validate(cmd::validate::Args),
    /// Work with schema files.
    #[command(subcommand)]
    Schema(cmd::schema::SchemaCommand),
    /// Semantic diff of two parameter sets (or a set against factory defaults).
    Diff(cmd::diff::Args),
    /// Print the sha256 fingerprint of a set's canonical form.
    Fingerprint(cmd::fingerprint::Args),
    /// Print a set in canonical form or convert it to TOML / YAML / JSON.
    Show(cmd::show::Args),
    /// Annotate a captured bus byte stream telegram by telegram.
    Decode(cmd::decode::Args),
    /// Build a telegram from a readable description.
    Encode(cmd::encode::Args),
    /// Serve simulated drives on a pseudo terminal or a TCP port.
    Sim(cmd::sim::Args),
    /// Identify the drive at a port and address: family, type codes, fitting schema.
    Identify(cmd::identify::Args),
    /// Check a new line, read-only: rates that answer, round trips, echo, parity, USB latency timer, advice.
    Doctor(cmd::doctor::Args),
    /// Find the drives on a bus (LUSTBUS 1..30, LECOM 1..99, CAN node ids).
    Scan(cmd::scan::Args),
    /// Read a drive's parameters into a set file.
    Pull(cmd::pull::Args),
    /// Download a set to a drive as one transaction (or print the plan).
    Upload(cmd::upload::Args),
    /// Finish or roll back an interrupted upload from its journal.
    Recover(cmd::recover::Args),
    /// Give one drive, alone on its line, its bus address (and line rate).
    Address(cmd::address::Args),
    /// Commission a machine line: every drive of a line manifest to its set.
    Commission(cmd::commission::Args),
    /// Make a spare, alone on a service port, the line's drive NAME: address, rate, then its set.
    Replace(cmd::replace::Args),
    /// Twins: capture drives read-only into files that answer as they did.
    #[command(subcommand)]
    Twin(cmd::twin::TwinCommand),
    /// Read-only drift check of a machine line against its sets.
    Status(cmd::status::Args),
    /// The plant history: who wrote what to which drive, when and why (log, blame, as-built, diff, verify).
    #[command(subcommand)]
    History(history::cmd::HistoryCommand),
    /// Make `git diff` show semantic diffs of set files (.gitattributes + diff driver).
    GitSetup(cmd::git_setup::Args),
    /// The textconv filter of the `driveset` git diff driver (one line per code).
    #[command(hide = true)]
    Textconv(cmd::git_setup::TextconvArgs),
    /// Render a saved commissioning report (report.json) to report.html again.
    #[command(hide = true)]
    Report(report::Args),
    /// Language server of set files and line manifests over stdio (for editors).
    Lsp(cmd::lsp::Args),
    /// Write a shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(cmd::completions::Args),
    /// Write the man page (roff) on stdout.
    Man(cmd::completions::ManArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { EXIT_INPUT } else { EXIT_OK };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    history::set_args(cli.history);
    let result = match cli.command {
        Command::Validate(a) => cmd::validate::run(a),
        Command::Schema(c) => cmd::schema::run(c),
        Command::Diff(a) => cmd::diff::run(a),
        Command::Fingerprint(a) => cmd::fingerprint::run(a),
        Command::Show(a) => cmd::show::run(a),
        Command::Decode(a) => cmd::decode::run(a),
        Command::Encode(a) => cmd::encode::run(a),
        Command::Sim(a) => cmd::sim::run(a),
        Command::Identify(a) => cmd::identify::run(a),
        Command::Doctor(a) => cmd::doctor::run(a),
        Command::Scan(a) => cmd::scan::run(a),
        Command::Pull(a) => cmd::pull::run(a),
        Command::Upload(a) => cmd::upload::run(a),
        Command::Recover(a) => cmd::recover::run(a),
        Command::Address(a) => cmd::address::run(a),
        Command::Commission(a) => cmd::commission::run(a),
        Command::Status(a) => cmd::status::run(a),
        Command::Replace(a) => cmd::replace::run(a),
        Command::Twin(c) => cmd::twin::run(c),
        Command::History(c) => history::cmd::run(c),
        Command::GitSetup(a) => cmd::git_setup::run(a),
        Command::Textconv(a) => cmd::git_setup::run_textconv(a),
        Command::Report(a) => report::run(a),
        Command::Lsp(a) => cmd::lsp::run(a),
        Command::Completions(a) => cmd::completions::run(a),
        Command::Man(a) => cmd::completions::run_man(a),
    };
    // the run's session (if a command opened one) closes with its outcome
    let code = match result {
        Ok(code) => {
            history::end(code, None);
            code
        }
        Err(f) => {
            history::end(f.code, Some(&f.msg));
            f.report()
        }
    };
    // output that did not arrive (`> /dev/full`) is an input/usage error
    if output::stdout_failed() && code < EXIT_INPUT {
        return ExitCode::from(EXIT_INPUT);
    }
    ExitCode::from(code)
}
