//! A line run as the terminal shows it (`driveset commission`, `driveset
//! status`; docs/architecture.md, "The walk of one commission"): the line
//! each drive prints when it is done, and the summary table after the run
//! with its differences, errors, counts and times; the table of
//! `commission --assign`'s first contact ([`assign_table`]). The report
//! files are written by [`crate::write_reports`]; printing is the caller's.

use std::time::Duration;

use driveset_engine::line::commission::{DriveDone, LineOutcome};
use driveset_engine::line::commission_assign::{BusAssign, CommissionAssignReport};
use driveset_engine::line::factory::FACTORY_WORDS;
use driveset_engine::line::report::{DriveReport, DriveResult, LineResult};

/// A drive's result as the progress lines and the summary table name it
/// (`verified`, `DRIFT`, ...).
pub fn result_name(r: DriveResult) -> &'static str {
    match r {
        DriveResult::Verified => "verified",
        DriveResult::Unchanged => "unchanged",
        DriveResult::AlreadyVerified => "already-verified",
        DriveResult::NotSelected => "not-selected",
        DriveResult::Drift => "DRIFT",
        DriveResult::RolledBack => "ROLLED-BACK",
        DriveResult::Failed => "FAILED",
    }
}

/// The line a drive done prints while the line runs: `[BUS] done/total
/// DRIVE: RESULT`, what it learned, wrote and stored, its drift, its time,
/// a factory-settings note and its error; `width` pads the bus name.
pub fn progress_line(p: &DriveDone<'_>, width: usize) -> String {
    let d = p.drive;
    let mut s = format!(
        "[{:width$}] {}/{} {}: {}",
        p.bus,
        p.done,
        p.total,
        d.name,
        result_name(d.result)
    );
    if let Some(l) = &d.learned_schema {
        s.push_str(&format!(", schema {} learned", l.id));
    }
    if d.codes_written > 0 {
        s.push_str(&format!(", {} codes written", d.codes_written));
    }
    if let Some(stored) = d.store_worth_saying() {
        s.push_str(&format!(", {stored}"));
    }
    if d.result == DriveResult::Drift {
        s.push_str(&format!(", {} code(s) differ", d.diff.len()));
    }
    s.push_str(&format!(" ({:.3} s)", d.elapsed_ms / 1000.0));
    if d.factory_settings {
        s.push_str(&factory_note(d.result));
    }
    if let Some(e) = &d.error {
        s.push_str(&format!(": {e}"));
    }
    s
}

/// ", at factory settings (a new or exchanged unit?)" for `status`, ", was at
/// ..." once commission wrote the set (the engine's `line::factory` rule).
fn factory_note(result: DriveResult) -> String {
    let was = match result {
        DriveResult::Drift | DriveResult::Failed => "",
        _ => "was ",
    };
    format!(", {was}{FACTORY_WORDS}")
}

fn short_fp(fp: Option<&str>) -> String {
    match fp {
        Some(f) => f.chars().take(19).collect(),
        None => "-".into(),
    }
}

/// The summary after a line run: the table of drives, each drifted drive's
/// differences, each drive's error, the counts (`N of M drives VERB: ...`,
/// `verb` the command's: `commissioned`, `checked`) and the bus and wall
/// times (`wall` measured by the caller: this crate reads no clock).
pub fn summary(o: &LineOutcome, verb: &str, wall: Duration) -> String {
    let r = &o.report;
    let rows: Vec<[String; 5]> = r
        .drives
        .iter()
        .map(|d| {
            [
                d.name.clone(),
                format!("{}/{}", d.bus, d.address),
                result_name(d.result).to_string(),
                d.codes_written.to_string(),
                short_fp(d.fingerprint_after.as_deref()),
            ]
        })
        .collect();
    let head = ["DRIVE", "BUS/ADDRESS", "RESULT", "WRITTEN", "FINGERPRINT"];
    let mut w = head.map(str::len);
    for row in &rows {
        for (i, c) in row.iter().enumerate() {
            w[i] = w[i].max(c.len());
        }
    }
    let line = |c: &[String; 5]| {
        format!(
            "{:<w0$}  {:<w1$}  {:<w2$}  {:>w3$}  {}\n",
            c[0],
            c[1],
            c[2],
            c[3],
            c[4],
            w0 = w[0],
            w1 = w[1],
            w2 = w[2],
            w3 = w[3]
        )
    };
    let mut out = line(&head.map(String::from));
    for row in &rows {
        out.push_str(&line(row));
    }
    let drifted: Vec<&DriveReport> = r
        .drives
        .iter()
        .filter(|d| !d.diff.is_empty() && d.result == DriveResult::Drift)
        .collect();
    for d in &drifted {
        let factory = if d.factory_settings {
            format!(" is {FACTORY_WORDS}: it")
        } else {
            String::new()
        };
        out.push_str(&format!(
            "\n{} ({}/{}){factory} differs from {}:\n",
            d.name, d.bus, d.address, d.set
        ));
        for l in &d.diff {
            out.push_str(&format!(
                "  {} {}: {} -> {}\n",
                l.code,
                l.name,
                l.old.as_deref().unwrap_or("(none)"),
                l.new.as_deref().unwrap_or("(none)")
            ));
        }
    }
    for d in r.drives.iter().filter(|d| d.error.is_some()) {
        out.push_str(&format!(
            "\n{}: {}\n",
            d.name,
            d.error.as_deref().unwrap_or_default()
        ));
    }
    let count = |k: DriveResult| r.drives.iter().filter(|d| d.result == k).count();
    let selected = r.drives.len() - count(DriveResult::NotSelected);
    let slowest = r
        .buses
        .iter()
        .max_by(|a, b| a.elapsed_ms.total_cmp(&b.elapsed_ms))
        .map_or("-", |b| b.name.as_str());
    out.push_str(&format!(
        "\n{} of {} drives {verb}: {} verified, {} unchanged, {} already verified, {} drift, {} rolled back, {} failed; line {}: {}\n",
        selected,
        r.drives.len(),
        count(DriveResult::Verified),
        count(DriveResult::Unchanged),
        count(DriveResult::AlreadyVerified),
        count(DriveResult::Drift),
        count(DriveResult::RolledBack),
        count(DriveResult::Failed),
        r.line,
        match r.result {
            LineResult::Ok => "ok",
            LineResult::Drift => "DRIFT",
            LineResult::Failed => "FAILED",
        },
    ));
    out.push_str(&format!(
        "bus time {:.3} s (buses in parallel; slowest: {slowest}), wall time {:.3} s\n",
        o.line_ms() / 1000.0,
        wall.as_secs_f64()
    ));
    out
}

/// `commission --assign`'s first contact as the terminal shows it
/// (docs/factory-fresh.md): per bus, each drive given its address and rate
/// (or why not), the final scan as a table (`ADDRESS DRIVE EXPECTED
/// ANSWERED CHECK`) and the bus's verdict; a skipped bus in one line.
pub fn assign_table(a: &CommissionAssignReport) -> String {
    let mut out = String::new();
    for b in &a.buses {
        if let Some(why) = &b.skipped {
            out.push_str(&format!("bus `{}`: skipped: {why}\n", b.bus));
            continue;
        }
        for d in &b.drives {
            match &d.error {
                None => out.push_str(&format!(
                    "{}: address {}, {} baud ({}{}, found at {} baud{})\n",
                    d.drive,
                    d.address,
                    d.rate,
                    d.family.as_deref().unwrap_or("?"),
                    d.type_value
                        .map_or_else(String::new, |t| format!(" TYPE {t}")),
                    d.found_at.unwrap_or(0),
                    d.rate_note
                        .as_deref()
                        .map_or_else(String::new, |n| format!("; {n}"))
                )),
                Some(e) => out.push_str(&format!("{}: FAILED: {e}\n", d.drive)),
            }
        }
        if let Some(e) = &b.scan_error {
            out.push_str(&format!("bus `{}`: {e}\n", b.bus));
            continue;
        }
        out.push_str(&format!("\nbus `{}` ({}), scanned:\n", b.bus, b.port));
        scan_table(&mut out, b);
        out.push_str(&format!(
            "bus `{}`: {} drive(s) assigned, {}; {:.3} s on the bus\n",
            b.bus,
            b.drives.len(),
            if b.holds() {
                "every manifest address answers as its set's family, nothing else answers"
            } else {
                "the bus does NOT match the manifest"
            },
            b.elapsed_ms / 1000.0
        ));
    }
    out
}

/// The final scan of bus `b` as a table, its columns as wide as their
/// widest cell.
fn scan_table(out: &mut String, b: &BusAssign) {
    let rows: Vec<[String; 5]> = b
        .scan
        .iter()
        .map(|r| {
            [
                r.address.to_string(),
                r.drive.clone().unwrap_or_else(|| "-".into()),
                r.expected.clone().unwrap_or_else(|| "-".into()),
                match (&r.found, &r.type_value) {
                    (Some(f), Some(t)) => format!("{f} TYPE {t}"),
                    (Some(f), None) => f.clone(),
                    (None, _) => "no answer".into(),
                },
                if r.ok { "ok" } else { "WRONG" }.into(),
            ]
        })
        .collect();
    let head = ["ADDRESS", "DRIVE", "EXPECTED", "ANSWERED", "CHECK"].map(String::from);
    let mut w = head.clone().map(|h| h.len());
    for row in &rows {
        for (i, c) in row.iter().enumerate() {
            w[i] = w[i].max(c.len());
        }
    }
    for row in std::iter::once(&head).chain(rows.iter()) {
        out.push_str(&format!(
            "{:>w0$}  {:<w1$}  {:<w2$}  {:<w3$}  {}\n",
            row[0],
            row[1],
            row[2],
            row[3],
            row[4],
            w0 = w[0],
            w1 = w[1],
            w2 = w[2],
            w3 = w[3]
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn result_names() {
        assert_eq!(result_name(DriveResult::Verified), "verified");
        assert_eq!(
            result_name(DriveResult::AlreadyVerified),
            "already-verified"
        );
        assert_eq!(result_name(DriveResult::Drift), "DRIFT");
        assert_eq!(result_name(DriveResult::RolledBack), "ROLLED-BACK");
    }

    #[test]
    fn factory_notes_and_short_fingerprints() {
        assert_eq!(
            factory_note(DriveResult::Drift),
            format!(", {FACTORY_WORDS}")
        );
        assert_eq!(
            factory_note(DriveResult::Verified),
            format!(", was {FACTORY_WORDS}")
        );
        assert_eq!(short_fp(None), "-");
        assert_eq!(
            short_fp(Some("sha256:0123456789abcdef0123")),
            "sha256:0123456789ab"
        );
    }

    #[test]
    fn assign_table_shows_drives_scan_and_verdict() {
        use driveset_engine::line::commission_assign::{DriveAssigned, ScanRow};
        let bus = BusAssign {
            bus: "press".into(),
            port: "/dev/ttyUSB0".into(),
            skipped: None,
            drives: vec![DriveAssigned {
                drive: "axis-1".into(),
                address: 3,
                rate: 19200,
                family: Some("mc6000".into()),
                type_value: Some(17),
                found_at: Some(9600),
                written: vec![],
                rate_note: None,
                elapsed_ms: 10.0,
                error: None,
            }],
            scan: vec![ScanRow {
                address: 3,
                drive: Some("axis-1".into()),
                expected: Some("mc6000".into()),
                found: Some("mc6000".into()),
                type_value: Some("17".into()),
                ok: true,
            }],
            scan_error: None,
            scan_ms: 5.0,
            elapsed_ms: 1500.0,
        };
        let skipped = BusAssign {
            bus: "can".into(),
            skipped: Some("a CAN bus".into()),
            ..bus.clone()
        };
        let a = CommissionAssignReport {
            line: "l".into(),
            buses: vec![bus, skipped],
            ok: true,
        };
        assert_eq!(
            assign_table(&a),
            "axis-1: address 3, 19200 baud (mc6000 TYPE 17, found at 9600 baud)\n\
             \nbus `press` (/dev/ttyUSB0), scanned:\n\
             ADDRESS  DRIVE   EXPECTED  ANSWERED        CHECK\n\
             \x20     3  axis-1  mc6000    mc6000 TYPE 17  ok\n\
             bus `press`: 1 drive(s) assigned, every manifest address answers as its set's family, nothing else answers; 1.500 s on the bus\n\
             bus `can`: skipped: a CAN bus\n"
        );
    }
}
