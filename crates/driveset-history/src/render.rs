//! The plant history's reports (docs/history.md), as `driveset history`
//! prints them: the log as a table or CSV, a blame, an as-built line as
//! text or an HTML page, a diff, any of them as JSON, and what `verify`
//! found. Pure: the store's query results in, text out.

use std::fmt::Write as _;

use crate::Verdict;
use crate::query::{AsBuilt, Blame, Difference, LogRow, Who};

fn slot(r: &LogRow) -> String {
    match (&r.line, &r.drive) {
        (Some(l), Some(d)) => format!("{l}/{d}"),
        _ => format!("{}/{}", r.bus, r.address),
    }
}

fn or_dash(s: &Option<String>) -> &str {
    s.as_deref().unwrap_or("-")
}

/// The log as aligned columns.
pub fn log_table(rows: &[LogRow]) -> String {
    let with_change = rows.iter().any(|r| r.change.is_some());
    let mut table: Vec<Vec<String>> = vec![
        [
            "AT", "DRIVE", "COMMAND", "OPERATOR", "RESULT", "WRITTEN", "REASON",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect(),
    ];
    if with_change {
        table[0].push("CHANGE".into());
    }
    for r in rows {
        let mut row = vec![
            r.at.clone(),
            slot(r),
            r.who.command.clone(),
            or_dash(&r.who.operator).to_string(),
            r.result.clone(),
            r.codes_written.to_string(),
            or_dash(&r.who.reason).to_string(),
        ];
        if with_change {
            row.push(match &r.change {
                Some((o, n)) => format!("{} -> {}", or_dash(o), or_dash(n)),
                None => "-".into(),
            });
        }
        table.push(row);
    }
    let widths: Vec<usize> = (0..table[0].len())
        .map(|i| {
            table
                .iter()
                .map(|r| r[i].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for r in &table {
        let mut line = String::new();
        for (i, c) in r.iter().enumerate() {
            if i + 1 == r.len() {
                line.push_str(c);
            } else {
                let _ = write!(line, "{c:w$}  ", w = widths[i]);
            }
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    let _ = writeln!(out, "{} record(s)", rows.len());
    out
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The log as CSV (RFC 4180 quoting).
pub fn log_csv(rows: &[LogRow]) -> String {
    let mut out = String::from(
        "seq,at,session,command,station,os_user,operator,reason,label,git_commit,line,drive,bus,address,family,device_type,software,result,codes_written,fingerprint_after,old,new\n",
    );
    for r in rows {
        let (old, new) = r.change.clone().unwrap_or_default();
        let fields = [
            r.seq.to_string(),
            r.at.clone(),
            r.who.session.clone(),
            r.who.command.clone(),
            r.who.station.clone(),
            r.who.os_user.clone(),
            r.who.operator.clone().unwrap_or_default(),
            r.who.reason.clone().unwrap_or_default(),
            r.who.label.clone().unwrap_or_default(),
            r.who.git_commit.clone().unwrap_or_default(),
            r.line.clone().unwrap_or_default(),
            r.drive.clone().unwrap_or_default(),
            r.bus.clone(),
            r.address.to_string(),
            r.family.clone(),
            r.device_type.clone().unwrap_or_default(),
            r.software.clone().unwrap_or_default(),
            r.result.clone(),
            r.codes_written.to_string(),
            r.fingerprint_after.clone().unwrap_or_default(),
            old.unwrap_or_default(),
            new.unwrap_or_default(),
        ];
        let line: Vec<String> = fields.iter().map(|f| csv_field(f)).collect();
        out.push_str(&line.join(","));
        out.push('\n');
    }
    out
}

fn who_text(w: &Who) -> String {
    let commit = match (&w.git_commit, w.git_dirty) {
        (Some(c), Some(true)) => format!("{c} (dirty)"),
        (Some(c), _) => c.clone(),
        (None, _) => "-".into(),
    };
    format!(
        "by:      {} (OS user {} on {})\nreason:  {}\nlabel:   {}\ncommit:  {commit}\nsession: {} (`driveset {}`)\n",
        or_dash(&w.operator),
        w.os_user,
        w.station,
        or_dash(&w.reason),
        or_dash(&w.label),
        w.session,
        w.command
    )
}

/// A blame.
pub fn blame(b: &Blame) -> String {
    format!(
        "{} {}: {} -> {} (read back {})\nwhen:    {}\n{}",
        b.drive,
        b.code,
        or_dash(&b.old),
        or_dash(&b.new),
        or_dash(&b.verified),
        b.at,
        who_text(&b.who)
    )
}

/// An as-built line as text.
pub fn as_built_text(a: &AsBuilt) -> String {
    let mut out = format!("line {} as built ({})\n", a.line, a.at);
    for h in &a.drives {
        let _ = writeln!(
            out,
            "\n{} ({}/{}): {}\n  unit: {} TYPE {} software {}",
            h.drive,
            h.bus,
            h.address,
            h.fingerprint,
            h.family,
            or_dash(&h.device_type),
            or_dash(&h.software)
        );
        match (&h.put_by, &h.put_at) {
            (Some(w), Some(at)) => {
                let _ = writeln!(
                    out,
                    "  put there: {at} by {} (`driveset {}`, session {}, label {})",
                    or_dash(&w.operator),
                    w.command,
                    w.session,
                    or_dash(&w.label)
                );
            }
            _ => {
                let _ = writeln!(out, "  put there: before the history (no recorded write)");
            }
        }
        for (c, v) in &h.values {
            let _ = writeln!(out, "  {c} = {v}");
        }
    }
    for u in &a.unknown {
        let _ = writeln!(out, "\n{u}: no record");
    }
    out
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An as-built line as an HTML page.
pub fn as_built_html(a: &AsBuilt) -> String {
    let mut out = format!(
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>{} as built</title></head><body>\n<h1>Line {} as built ({})</h1>\n",
        esc(&a.line),
        esc(&a.line),
        esc(&a.at)
    );
    for h in &a.drives {
        let _ = writeln!(
            out,
            "<h2 id=\"{}\">{} ({}/{})</h2>\n<p>fingerprint <code>{}</code>; unit {} TYPE {} software {}</p>",
            esc(&h.drive),
            esc(&h.drive),
            esc(&h.bus),
            h.address,
            esc(&h.fingerprint),
            esc(&h.family),
            esc(or_dash(&h.device_type)),
            esc(or_dash(&h.software))
        );
        if let (Some(w), Some(at)) = (&h.put_by, &h.put_at) {
            let _ = writeln!(
                out,
                "<p>put there {} by {} (<code>driveset {}</code>, session <code>{}</code>, label {}, commit {})</p>",
                esc(at),
                esc(or_dash(&w.operator)),
                esc(&w.command),
                esc(&w.session),
                esc(or_dash(&w.label)),
                esc(or_dash(&w.git_commit))
            );
        }
        out.push_str("<table>\n<tr><th>code</th><th>value</th></tr>\n");
        for (c, v) in &h.values {
            let _ = writeln!(out, "<tr><td>{}</td><td>{}</td></tr>", esc(c), esc(v));
        }
        out.push_str("</table>\n");
    }
    for u in &a.unknown {
        let _ = writeln!(out, "<h2>{}</h2>\n<p>no record</p>", esc(u));
    }
    out.push_str("</body></html>\n");
    out
}

/// A diff between two as-built states.
pub fn diff(a: &str, b: &str, d: &[Difference]) -> String {
    let mut out = format!("--- {a}\n+++ {b}\n");
    for x in d {
        let _ = writeln!(
            out,
            "{} {}: {} -> {}",
            x.drive,
            x.what,
            or_dash(&x.a),
            or_dash(&x.b)
        );
    }
    let _ = writeln!(out, "{} difference(s)", d.len());
    out
}

/// A query's result as `--format json` / `--json` prints it: pretty JSON
/// and a newline (the log's rows, a blame, an as-built line, a diff).
pub fn json<T: serde::Serialize + ?Sized>(value: &T) -> String {
    format!(
        "{}\n",
        serde_json::to_string_pretty(value).unwrap_or_default()
    )
}

/// What `verify` found, one line: the chain intact with its record count
/// and head, or the first broken record; `store` is the store as shown.
pub fn verify(store: &str, v: &Verdict) -> String {
    match v {
        Verdict::Intact { records, head } => {
            format!("{store}: {records} records, chain intact; head {head}\n")
        }
        Verdict::Broken {
            seq,
            kind,
            session_id,
            why,
        } => format!(
            "{store}: chain broken at record {seq} ({kind} of session {session_id}): {why}\n"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verify_lines() {
        let ok = Verdict::Intact {
            records: 3,
            head: "ab12".into(),
        };
        assert_eq!(
            verify("h.db", &ok),
            "h.db: 3 records, chain intact; head ab12\n"
        );
        let broken = Verdict::Broken {
            seq: 2,
            kind: "drive".into(),
            session_id: "s1".into(),
            why: "hash differs".into(),
        };
        assert_eq!(
            verify("h.db", &broken),
            "h.db: chain broken at record 2 (drive of session s1): hash differs\n"
        );
    }

    #[test]
    fn json_is_pretty_with_a_newline() {
        assert_eq!(json(&[1, 2]), "[\n  1,\n  2\n]\n");
    }
}
