//! `driveset diff SET --port P --address A`: a set against what the drive
//! at the address holds for the set's codes (driveset-engine's `live_diff`),
//! with the offline diff's output and exit codes: old (`---`) is the drive,
//! new (`+++`) the set, so the lines read as what an upload would change.

// EngineError is large by design; it is built on the failure path only.
#![allow(clippy::result_large_err)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use driveset_schema::validate::display_value;
use driveset_schema::{CodeKey, DiffKind, RawValue, Schema};
use serde_json::{Value, json};

use crate::output::{self, Style, plural};
use crate::port::{self, Fail};
use crate::{EXIT_FINDINGS, EXIT_OK};

/// Whether the output is JSON (the offline diff's `--format json`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LiveFormat {
    /// Lines.
    Human,
    /// One JSON document.
    Json,
}

/// What `diff --port` needs.
#[derive(Debug, Clone)]
pub struct LiveArgs<'a> {
    /// The set file.
    pub set: &'a Path,
    /// The port.
    pub port: &'a str,
    /// The address.
    pub address: u8,
    /// Output.
    pub format: LiveFormat,
    /// Extra schema directories.
    pub schemas: &'a [PathBuf],
    /// Compare even if the drive's identity does not fit the set's schema.
    pub force: bool,
}

fn shown(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => display_value(schema, c, raw),
        None => format!("{raw:?}"),
    }
}

fn raw_json(schema: &Schema, key: CodeKey, raw: Option<&RawValue>) -> Value {
    let redact = schema
        .code(key.number)
        .is_some_and(|c| schema.is_password(c));
    match raw {
        None => Value::Null,
        Some(_) if redact => json!("<redacted>"),
        Some(RawValue::Int(i)) => json!(i),
        Some(RawValue::Text(t)) => json!(t),
        Some(RawValue::Octets(o)) => {
            json!(o.iter().map(|b| format!("{b:02x}")).collect::<String>())
        }
    }
}

/// Run `driveset diff SET --port P --address A`.
pub fn run(args: LiveArgs<'_>) -> anyhow::Result<u8> {
    port::finish(live(&args))
}

fn live(args: &LiveArgs<'_>) -> Result<u8, Fail> {
    let (schema, set) = match super::upload::load_set(args.set, args.schemas) {
        Ok(x) => x,
        Err(code) => {
            return Err(Fail {
                code,
                msg: format!("{}: not compared", args.set.display()),
            });
        }
    };
    let opened = port::open_port(args.port)?;
    let port_name = opened.name.clone();
    let mut client = port::into_client(opened, schema.clone(), args.address, args.force)?;
    if !args.force {
        driveset_engine::identify::check_family(client.as_mut())?;
    }
    let d = driveset_engine::live::live_diff(client.as_mut(), &set);
    let _ = client.finish();
    let d = d?;
    let old_name = format!("{port_name} address {}", args.address);
    let new_name = args.set.display().to_string();
    let count = |k: DiffKind| d.entries.iter().filter(|e| e.kind == k).count();
    let summary = format!(
        "{} changed, {} added, {} removed",
        count(DiffKind::Changed),
        count(DiffKind::Added),
        count(DiffKind::Removed)
    );
    match args.format {
        LiveFormat::Json => {
            let entries: Vec<Value> = d
                .entries
                .iter()
                .map(|e| {
                    json!({
                        "code": schema.display_code(e.key.number, e.key.subcode),
                        "key": e.key.canonical(schema.code_style),
                        "name": schema.code(e.key.number).map(|c| c.name.clone()).unwrap_or_default(),
                        "kind": match e.kind {
                            DiffKind::Added => "added",
                            DiffKind::Removed => "removed",
                            DiffKind::Changed => "changed",
                        },
                        "old": e.old.as_ref().map(|r| shown(&schema, e.key, r)),
                        "new": e.new.as_ref().map(|r| shown(&schema, e.key, r)),
                        "old_raw": raw_json(&schema, e.key, e.old.as_ref()),
                        "new_raw": raw_json(&schema, e.key, e.new.as_ref()),
                        "text": e.text,
                    })
                })
                .collect();
            let doc = json!({
                "old": old_name,
                "new": new_name,
                "schema": schema.id,
                "equal": d.is_empty(),
                "changed": count(DiffKind::Changed),
                "added": count(DiffKind::Added),
                "removed": count(DiffKind::Removed),
                "entries": entries,
            });
            output::emit(&format!(
                "{}\n",
                serde_json::to_string_pretty(&doc).unwrap_or_default()
            ));
        }
        LiveFormat::Human => {
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
    Ok(if d.is_empty() { EXIT_OK } else { EXIT_FINDINGS })
}
