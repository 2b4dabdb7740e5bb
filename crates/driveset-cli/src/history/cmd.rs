//! `driveset history`: the queries (`log`, `blame`, `as-built`, `diff`),
//! `verify` (walk the chain), `sync` (forward the sessions kept locally to
//! the shared store) and `export` (JSON Lines). docs/history.md.

use std::path::PathBuf;

use driveset_history::query::{At, LogFilter};
use driveset_history::{Store, Target, Verdict};

use crate::fail::Fail;
use crate::output::OutputFormat;
use crate::{EXIT_FINDINGS, EXIT_OK};
use driveset_history::render;

/// `driveset history ...`.
#[derive(clap::Subcommand)]
pub enum HistoryCommand {
    /// The records of drives, filtered (newest last).
    Log(LogArgs),
    /// Who last changed a code of a drive: when, from what, to what, why, with which commit.
    Blame(BlameArgs),
    /// What every drive of a line held at a label or a time, and the run that put it there.
    AsBuilt(AsBuiltArgs),
    /// What changed on a line between two labels or times (FAT vs SAT).
    Diff(DiffArgs),
    /// Walk the hash chain; name the first broken record (exit 1).
    Verify,
    /// Forward the sessions recorded locally while the shared store was down (each once).
    Sync,
    /// Write every record as JSON Lines on stdout (an archive outside any database).
    Export,
}

/// `history log`.
#[derive(clap::Args)]
pub struct LogArgs {
    /// Only this line.
    #[arg(long, value_name = "LINE")]
    pub line: Option<String>,
    /// Only this drive (its manifest name).
    #[arg(long, value_name = "NAME")]
    pub drive: Option<String>,
    /// Only this unit: its family, TYPE, software or an identity value.
    #[arg(long, value_name = "UNIT")]
    pub unit: Option<String>,
    /// Only records that wrote this code (or found it drifted).
    #[arg(long, value_name = "CODE")]
    pub code: Option<String>,
    /// From this time on (RFC 3339 or a date).
    #[arg(long, value_name = "TIME")]
    pub since: Option<String>,
    /// Before this time (RFC 3339 or a date).
    #[arg(long, value_name = "TIME")]
    pub until: Option<String>,
    /// Only sessions with this label.
    #[arg(long, value_name = "LABEL")]
    pub label: Option<String>,
    /// At most this many records (the newest).
    #[arg(long, value_name = "N", default_value_t = 1000)]
    pub limit: u32,
    /// Output format.
    #[arg(long, value_parser = crate::output::formats(crate::output::LOG_FORMATS), default_value = "table")]
    pub format: OutputFormat,
}

/// `history blame`.
#[derive(clap::Args)]
pub struct BlameArgs {
    /// The drive (its manifest name).
    #[arg(long, value_name = "NAME")]
    pub drive: String,
    /// Its line, where several lines have a drive of that name.
    #[arg(long, value_name = "LINE")]
    pub line: Option<String>,
    /// The code as the schema spells it (C0011, 428-RSIO).
    #[arg(value_name = "CODE")]
    pub code: String,
    /// JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `history as-built`.
#[derive(clap::Args)]
pub struct AsBuiltArgs {
    /// The line manifest.
    #[arg(value_name = "MANIFEST")]
    pub manifest: PathBuf,
    /// A label or a time (RFC 3339 or a date); default: everything recorded.
    #[arg(long, value_name = "LABEL|TIME")]
    pub at: Option<String>,
    /// Output format.
    #[arg(long, value_parser = crate::output::formats(crate::output::BUILT_FORMATS), default_value = "table")]
    pub format: OutputFormat,
}

/// `history diff`.
#[derive(clap::Args)]
pub struct DiffArgs {
    /// A and B: labels or times (give --at twice).
    #[arg(long, value_name = "LABEL|TIME", num_args = 1, required = true)]
    pub at: Vec<String>,
    /// The line manifest.
    #[arg(value_name = "MANIFEST")]
    pub manifest: PathBuf,
    /// JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

fn open() -> Result<Store, Fail> {
    let target = super::target()?;
    match target.open() {
        Ok(Some(s)) => Ok(s),
        Ok(None) => Err(Fail::input(
            "history is off (--history off / DRIVESET_HISTORY=off): nothing to ask",
        )),
        Err(e) => Err(Fail::input(e.to_string())),
    }
}

fn db(e: driveset_history::HistoryError) -> Fail {
    Fail::input(e.to_string())
}

fn time(what: &str, s: &Option<String>) -> Result<Option<String>, Fail> {
    match s.as_deref().map(At::parse) {
        None => Ok(None),
        Some(At::Time(t)) => Ok(Some(t)),
        Some(_) => Err(Fail::input(format!(
            "{what} `{}`: not a time; give RFC 3339 (2026-12-03T10:00:00Z) or a date (2026-12-03)",
            s.as_deref().unwrap_or_default()
        ))),
    }
}

/// Run `driveset history ...`.
pub fn run(c: HistoryCommand) -> Result<u8, Fail> {
    match c {
        HistoryCommand::Log(a) => {
            let f = LogFilter {
                line: a.line,
                drive: a.drive,
                unit: a.unit,
                code: a.code,
                since: time("--since", &a.since)?,
                until: time("--until", &a.until)?,
                label: a.label,
                limit: a.limit,
            };
            let rows = open()?.log(&f).map_err(db)?;
            out!(
                "{}",
                match a.format {
                    OutputFormat::Json => render::json(&rows),
                    OutputFormat::Csv => render::log_csv(&rows),
                    // `table`, the only other value `log` takes
                    _ => render::log_table(&rows),
                }
            );
            Ok(EXIT_OK)
        }
        HistoryCommand::Blame(a) => {
            let b = open()?
                .blame(a.line.as_deref(), &a.drive, &a.code)
                .map_err(db)?;
            match b {
                None => Err(Fail::input(format!(
                    "history: no record of {} written on drive {}",
                    a.code, a.drive
                ))),
                Some(b) => {
                    out!(
                        "{}",
                        if a.json {
                            render::json(&b)
                        } else {
                            render::blame(&b)
                        }
                    );
                    Ok(EXIT_OK)
                }
            }
        }
        HistoryCommand::AsBuilt(a) => {
            let (line, drives) = manifest_drives(&a.manifest)?;
            let at = a.at.as_deref().map_or(At::Latest, At::parse);
            let built = open()?.as_built(&line, &drives, &at).map_err(db)?;
            out!(
                "{}",
                match a.format {
                    OutputFormat::Json => render::json(&built),
                    OutputFormat::Html => render::as_built_html(&built),
                    // `table`, the only other value `as-built` takes
                    _ => render::as_built_text(&built),
                }
            );
            Ok(EXIT_OK)
        }
        HistoryCommand::Diff(a) => {
            let [x, y] = a.at.as_slice() else {
                return Err(Fail::input(format!(
                    "history diff: give --at twice (A and B), not {} time(s)",
                    a.at.len()
                )));
            };
            let (line, drives) = manifest_drives(&a.manifest)?;
            let d = open()?
                .changes(&line, &drives, &At::parse(x), &At::parse(y))
                .map_err(db)?;
            out!(
                "{}",
                if a.json {
                    render::json(&d)
                } else {
                    render::diff(x, y, &d)
                }
            );
            Ok(if d.is_empty() { EXIT_OK } else { EXIT_FINDINGS })
        }
        HistoryCommand::Verify => {
            let mut store = open()?;
            let verdict = store.verify().map_err(db)?;
            out!("{}", render::verify(&store.shown, &verdict));
            Ok(match verdict {
                Verdict::Intact { .. } => EXIT_OK,
                Verdict::Broken { .. } => EXIT_FINDINGS,
            })
        }
        HistoryCommand::Sync => {
            let target = super::target()?;
            let Target::Postgres(_) = target else {
                return Err(Fail::input(format!(
                    "history sync forwards to a shared store: give --history postgresql://... (not {})",
                    target.shown()
                )));
            };
            let mut shared = open()?;
            let ids = driveset_history::run::forward_owed(&mut shared, |l| eprintln!("{l}"));
            outln!("{} session(s) forwarded to {}", ids.len(), shared.shown);
            Ok(EXIT_OK)
        }
        HistoryCommand::Export => {
            let mut out = Vec::new();
            open()?.export(&mut out).map_err(db)?;
            crate::output::emit(&String::from_utf8_lossy(&out));
            Ok(EXIT_OK)
        }
    }
}

/// The line's name and its drives' names, from its manifest.
fn manifest_drives(path: &std::path::Path) -> Result<(String, Vec<String>), Fail> {
    let m = crate::line::load(path, crate::line::LearnedSets::Excused).map_err(Fail::reported)?;
    Ok((
        m.name.clone(),
        m.drives.iter().map(|d| d.name.clone()).collect(),
    ))
}
