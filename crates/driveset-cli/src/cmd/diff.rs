//! `driveset diff A B`: semantic diff of two parameter sets of one drive
//! family (engineering units and labels), or of one set against the schema's
//! factory defaults (`--defaults`), or a unified text diff of the canonical
//! forms (`--unified`). A set against a live drive (`--port`) is `live`.

pub mod live;

use std::fmt::Write;
use std::path::PathBuf;

use driveset_schema::diff::defaults_for;
use driveset_schema::validate::display_value;
use driveset_schema::{
    CodeKey, DiffKind, RawValue, ResolvedSet, Schema, diff, diff_defaults, unified_diff,
};

use crate::output::{self, OutputFormat, Style, plural};
use crate::port_args::{LearnFlags, Need, Port, PortCommand, Takes};

/// Arguments of `driveset diff`.
#[derive(clap::Args)]
#[command(after_help = "\
Lines start with `+` (only in B), `-` (only in A) or `~` (in both, changed)
and show values in engineering units with labels; a password never shows
its value: a differing one is `differs (secret)` (--unified: `<secret: old
value>` / `<secret: new value>`). With --defaults, old values are the
schema's factory defaults (`(no factory default known)` where the schema
gives none).

Exit codes: 0 same, 1 different, 2 error (unreadable or invalid set, sets of
different schemas, usage); with --port also 3 (bus or device failure).

Examples:
  driveset diff parameter-sets/tmd/base.toml parameter-sets/tmd/conveyor-3.toml
  driveset diff --defaults parameter-sets/tmd/conveyor-3.toml
  driveset diff --unified A.toml B.yaml
  driveset diff parameter-sets/mc6000/axis-1.toml --port sim://mc6000?addresses=1 --address 1")]
pub struct Args {
    /// The old set (with --defaults: the set to compare with factory defaults).
    #[arg(value_name = "A")]
    pub a: PathBuf,
    /// The new set.
    #[arg(
        value_name = "B",
        required_unless_present_any = ["defaults", "port"],
        conflicts_with_all = ["defaults", "port"]
    )]
    pub b: Option<PathBuf>,
    /// The live drive to compare A with (`--port` and `--address`; see
    /// `live`), the schema directories and, with --port, learning the
    /// schema from the drive where the set's lacks facts.
    #[command(flatten)]
    pub at: Port<Args>,
    /// Compare A with the factory defaults of its schema.
    #[arg(long, conflicts_with = "port")]
    pub defaults: bool,
    /// Unified text diff of the canonical forms (raw values) instead.
    #[arg(long, conflicts_with_all = ["format", "port"])]
    pub unified: bool,
    /// Output format.
    #[arg(long, value_parser = output::formats(output::DIFF_FORMATS), default_value = "human")]
    pub format: OutputFormat,
    /// With --port: the transfer rate (the switch is journaled in
    /// .driveset/journal/<bus>-<address>.journal.json).
    #[allow(rustdoc::invalid_html_tags)] // clap's help text, printed as written
    #[command(flatten)]
    pub transfer: crate::allow::TransferArgs,
}

fn code_name(schema: &Schema, key: CodeKey) -> String {
    schema
        .code(key.number)
        .map(|c| driveset_schema::error::escape_controls(&c.name).into_owned())
        .unwrap_or_default()
}

fn shown(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => display_value(schema, c, raw),
        None => format!("{raw:?}"),
    }
}

/// A raw value in `diff`'s JSON: a number, or text (octets as hex, a
/// password as the secret marker).
#[derive(serde::Serialize)]
#[serde(untagged)]
enum RawShown {
    Int(i64),
    Text(String),
}

fn raw_json(schema: &Schema, key: CodeKey, raw: Option<&RawValue>) -> Option<RawShown> {
    let redact = schema
        .code(key.number)
        .is_some_and(|c| schema.is_password(c));
    match raw? {
        _ if redact => Some(RawShown::Text(driveset_schema::canonical::SECRET.into())),
        RawValue::Int(i) => Some(RawShown::Int(*i)),
        RawValue::Text(t) => Some(RawShown::Text(t.clone())),
        RawValue::Octets(o) => Some(RawShown::Text(
            o.iter().map(|b| format!("{b:02x}")).collect::<String>(),
        )),
    }
}

/// `diff --format json`'s document (keys in alphabetical order, as it
/// always had them).
#[derive(serde::Serialize)]
struct DiffDoc<'a> {
    added: usize,
    changed: usize,
    entries: Vec<EntryDoc<'a>>,
    equal: bool,
    new: &'a str,
    old: &'a str,
    removed: usize,
    schema: &'a str,
}

/// One difference.
#[derive(serde::Serialize)]
struct EntryDoc<'a> {
    code: String,
    key: String,
    kind: &'static str,
    name: String,
    new: Option<String>,
    new_raw: Option<RawShown>,
    old: Option<String>,
    old_raw: Option<RawShown>,
    text: &'a str,
}

/// `diff`'s port arguments (for `live`).
pub type DiffPort = Port<Args>;

impl PortCommand for Args {
    const TAKES: Takes = Takes {
        port: Need::Optional,
        port_help: "Compare A with the live drive at this port (needs --address; see `diff_live`).",
        address: Need::Optional,
        address_help: "Bus address of the drive for --port.",
        together: true,
        schemas: true,
        allow_family: true,
        learn: LearnFlags::All,
        ..Takes::NONE
    };
}

/// Run `driveset diff`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    if let (Some(_), Some(address)) = (&args.at.port, args.at.address) {
        return live::run(live::LiveArgs {
            set: &args.a,
            at: &args.at,
            address,
            format: args.format,
            transfer: args.transfer,
        });
    }
    let mut registry = match output::registry(&args.at.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    let a = match output::load_valid_set(&args.a, &mut registry) {
        Ok(l) => l,
        Err(code) => return Err(crate::fail::Fail::reported(code)),
    };
    let (Some(schema), Some(set_a)) = (a.schema.clone(), a.resolved.as_ref()) else {
        return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
    };
    let a_name = args.a.display().to_string();
    let (old, new, old_name, new_name): (ResolvedSet, ResolvedSet, String, String) = match &args.b {
        None => (
            defaults_for(set_a, &schema),
            set_a.clone(),
            format!("factory defaults ({})", schema.id),
            a_name,
        ),
        Some(bp) => {
            let b = match output::load_valid_set(bp, &mut registry) {
                Ok(l) => l,
                Err(code) => return Err(crate::fail::Fail::reported(code)),
            };
            let Some(set_b) = b.resolved else {
                return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
            };
            if set_b.schema != set_a.schema {
                eprintln!(
                        "{}",
                        Style::stderr().error(&format!(
                            "error: cannot diff sets of different schemas: {a_name} is `{}`, {} is `{}`",
                            set_a.schema,
                            bp.display(),
                            set_b.schema
                        ))
                    );
                eprintln!("  = help: compare sets of one drive family");
                return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
            }
            (set_a.clone(), set_b, a_name, bp.display().to_string())
        }
    };

    if args.unified {
        let text = unified_diff(&old, &new, &schema, &old_name, &new_name);
        let style = Style::stdout();
        for line in text.lines() {
            let l = if line.starts_with("+++") || line.starts_with("---") {
                style.bold(line)
            } else if line.starts_with('+') {
                style.added(line)
            } else if line.starts_with('-') {
                style.removed(line)
            } else {
                line.to_string()
            };
            output::emit(&format!("{l}\n"));
        }
        return Ok(if text.is_empty() {
            crate::EXIT_OK
        } else {
            crate::EXIT_FINDINGS
        });
    }

    let d = if args.defaults {
        diff_defaults(&new, &schema)
    } else {
        diff(&old, &new, &schema)
    };
    let d = match d {
        Ok(d) => d,
        Err(e) => {
            eprintln!("{}", Style::stderr().error(&format!("error: {e}")));
            return Err(crate::fail::Fail::reported(crate::EXIT_INPUT));
        }
    };
    Ok(render(
        &d,
        &schema,
        &old_name,
        &new_name,
        args.format == OutputFormat::Json,
    ))
}

/// Print a semantic diff, as human lines (`~`/`+`/`-` and a summary) or one
/// JSON document, and return the exit code: 0 same, 1 different. The offline
/// diff and `diff SET --port` (cmd/diff/live.rs) share it, so both print the
/// same thing.
pub(crate) fn render(
    d: &driveset_schema::Diff,
    schema: &Schema,
    old_name: &str,
    new_name: &str,
    json_out: bool,
) -> u8 {
    let count = |k: DiffKind| d.entries.iter().filter(|e| e.kind == k).count();
    let summary = format!(
        "{} changed, {} added, {} removed",
        count(DiffKind::Changed),
        count(DiffKind::Added),
        count(DiffKind::Removed)
    );
    if json_out {
        {
            let entries: Vec<EntryDoc> = d
                .entries
                .iter()
                .map(|e| EntryDoc {
                    code: schema.display_code(e.key.number, e.key.subcode),
                    key: e.key.canonical(schema.code_style),
                    kind: match e.kind {
                        DiffKind::Added => "added",
                        DiffKind::Removed => "removed",
                        DiffKind::Changed => "changed",
                    },
                    name: code_name(schema, e.key),
                    new: e.new.as_ref().map(|r| shown(schema, e.key, r)),
                    new_raw: raw_json(schema, e.key, e.new.as_ref()),
                    old: e.old.as_ref().map(|r| shown(schema, e.key, r)),
                    old_raw: raw_json(schema, e.key, e.old.as_ref()),
                    text: &e.text,
                })
                .collect();
            let doc = DiffDoc {
                added: count(DiffKind::Added),
                changed: count(DiffKind::Changed),
                entries,
                equal: d.is_empty(),
                new: new_name,
                old: old_name,
                removed: count(DiffKind::Removed),
                schema: &schema.id,
            };
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&doc).unwrap_or_default()
            ));
        }
    } else {
        {
            let style = Style::stdout();
            let mut out = String::new();
            let _ = writeln!(out, "{}", style.bold(&format!("--- {old_name}")));
            let _ = writeln!(out, "{}", style.bold(&format!("+++ {new_name}")));
            for e in &d.entries {
                let line = match e.kind {
                    DiffKind::Added => style.added(&format!("+ {}", e.text)),
                    DiffKind::Removed => style.removed(&format!("- {}", e.text)),
                    DiffKind::Changed => style.changed(&format!("~ {}", e.text)),
                };
                let _ = writeln!(out, "{line}");
            }
            if d.is_empty() {
                let _ = writeln!(out, "no differences");
            } else {
                let _ = writeln!(
                    out,
                    "{} ({summary})",
                    plural(d.entries.len(), "difference", "differences")
                );
            }
            output::emit(&out);
        }
    }
    if d.is_empty() {
        crate::EXIT_OK
    } else {
        crate::EXIT_FINDINGS
    }
}
