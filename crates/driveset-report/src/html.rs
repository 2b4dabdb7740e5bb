//! The commissioning report as one self-contained HTML page: inline CSS,
//! inline SVG for the bus timelines, no scripts and no external assets, so
//! the file can be mailed, archived and opened offline. Every text taken
//! from the report (drive names, set paths, values, errors) is
//! HTML-escaped. Results are colour-coded and also spelled out with a
//! symbol, so the page reads the same in black and white.

use std::collections::BTreeMap;
use std::fmt::Write;

use driveset_engine::line::report::{
    BusReport, DiffLine, DriveReport, DriveResult, LineReport, LineResult, TimelineEntry,
};

use crate::Run;

/// Escape text for HTML element content and quoted attribute values.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            // control characters other than tab / newline have no place in a page
            c if c.is_control() && c != '\n' && c != '\t' => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out
}

/// `(css class, symbol, text)` of a line result.
fn line_result(r: LineResult) -> (&'static str, &'static str, &'static str) {
    match r {
        LineResult::Ok => ("ok", "\u{2714}", "OK"),
        LineResult::Drift => ("warn", "\u{2260}", "DRIFT"),
        LineResult::Failed => ("bad", "\u{2716}", "FAILED"),
    }
}

/// `(css class, symbol, text)` of a drive result.
fn drive_result(r: DriveResult) -> (&'static str, &'static str, &'static str) {
    match r {
        DriveResult::Verified => ("ok", "\u{2714}", "verified"),
        DriveResult::Unchanged => ("ok", "=", "unchanged"),
        DriveResult::AlreadyVerified => ("ok", "\u{21bb}", "already verified"),
        DriveResult::NotSelected => ("skip", "\u{2013}", "not selected"),
        DriveResult::Drift => ("warn", "\u{2260}", "drift"),
        DriveResult::RolledBack => ("bad", "\u{21b6}", "rolled back"),
        DriveResult::Failed => ("bad", "\u{2716}", "failed"),
    }
}

/// Sort key of drive results: failures first.
fn result_rank(r: DriveResult) -> u8 {
    match r {
        DriveResult::Failed => 0,
        DriveResult::RolledBack => 1,
        DriveResult::Drift => 2,
        DriveResult::Verified => 3,
        DriveResult::Unchanged => 4,
        DriveResult::AlreadyVerified => 5,
        DriveResult::NotSelected => 6,
    }
}

fn badge((class, symbol, text): (&str, &str, &str)) -> String {
    format!(
        "<span class=\"badge {class}\"><span aria-hidden=\"true\">{symbol}</span> {text}</span>"
    )
}

/// Milliseconds as `850 ms`, `12.5 ms`, `1.84 s`, `2 min 05 s`.
pub fn fmt_ms(ms: f64) -> String {
    if !ms.is_finite() || ms < 0.0 {
        return "-".into();
    }
    if ms < 10.0 {
        format!("{ms:.1} ms")
    } else if ms < 1000.0 {
        format!("{ms:.0} ms")
    } else if ms < 60_000.0 {
        format!("{:.2} s", ms / 1000.0)
    } else {
        let s = (ms / 1000.0).round() as u64;
        format!("{} min {:02} s", s / 60, s % 60)
    }
}

/// `sha256:0123456789ab…` (the full value goes into a `title`).
fn short_fp(fp: &str) -> String {
    let cut = fp.find(':').map_or(0, |i| i + 1) + 10;
    match fp.char_indices().nth(cut) {
        Some((i, _)) => format!("{}\u{2026}", &fp[..i]),
        None => fp.to_string(),
    }
}

const CSS: &str = r#"
:root{--ok:#1a7f37;--ok-bg:#dafbe1;--warn:#9a6700;--warn-bg:#fff8c5;--bad:#cf222e;--bad-bg:#ffebe9;--skip:#57606a;--skip-bg:#eaeef2;--line:#d0d7de;--muted:#57606a}
*{box-sizing:border-box}
body{margin:0;font:14px/1.45 system-ui,-apple-system,"Segoe UI","DejaVu Sans",sans-serif;color:#1f2328;background:#f6f8fa}
main{max-width:1180px;margin:0 auto;padding:24px}
h1{font-size:24px;margin:0 0 4px}
h2{font-size:18px;margin:28px 0 10px;padding-bottom:4px;border-bottom:1px solid var(--line)}
h3{font-size:15px;margin:0}
code,.mono{font:12.5px/1.4 "DejaVu Sans Mono",ui-monospace,Menlo,Consolas,monospace}
.sub{color:var(--muted);margin:0 0 16px}
.kicker{color:var(--muted);margin:0 0 2px;font-size:12.5px;text-transform:uppercase;letter-spacing:.04em}
.nowrap,td.num{white-space:nowrap}
#drives td:first-child a{font-weight:600;color:inherit}
header.top{display:flex;gap:24px;align-items:flex-start;justify-content:space-between;background:#fff;border:1px solid var(--line);border-radius:8px;padding:18px 20px}
.overall{font-size:22px;font-weight:700;padding:10px 18px;border-radius:8px;border:2px solid;white-space:nowrap}
.overall.ok{color:var(--ok);background:var(--ok-bg)}.overall.warn{color:var(--warn);background:var(--warn-bg)}.overall.bad{color:var(--bad);background:var(--bad-bg)}
dl.meta{display:grid;grid-template-columns:max-content 1fr;gap:3px 14px;margin:10px 0 0}
dl.meta dt{color:var(--muted)}dl.meta dd{margin:0;word-break:break-all}
.counts{display:flex;flex-wrap:wrap;gap:8px;margin-top:14px}
.badge{display:inline-block;padding:1px 9px;border-radius:999px;border:1px solid;font-weight:600;font-size:12.5px;white-space:nowrap}
.badge.ok{color:var(--ok);background:var(--ok-bg)}.badge.warn{color:var(--warn);background:var(--warn-bg)}
.badge.bad{color:var(--bad);background:var(--bad-bg)}.badge.skip{color:var(--skip);background:var(--skip-bg)}
.badge.dirty{color:var(--warn);background:var(--warn-bg)}
table{border-collapse:collapse;width:100%;background:#fff;border:1px solid var(--line)}
th,td{text-align:left;padding:6px 9px;border-bottom:1px solid var(--line);vertical-align:top}
th{background:#f0f3f6;font-weight:600;font-size:12.5px}
td.num,th.num{text-align:right;font-variant-numeric:tabular-nums}
tr.bad td:first-child{box-shadow:inset 4px 0 var(--bad)}tr.warn td:first-child{box-shadow:inset 4px 0 var(--warn)}
tr.ok td:first-child{box-shadow:inset 4px 0 var(--ok)}tr.skip td:first-child{box-shadow:inset 4px 0 var(--skip)}
.timeline{background:#fff;border:1px solid var(--line);border-radius:8px;padding:10px 12px;margin-bottom:14px}
.timeline h3 .mono{color:var(--muted);font-weight:400}
.legend{display:flex;flex-wrap:wrap;gap:12px;margin:6px 0 12px;font-size:12.5px}
.legend i{display:inline-block;width:12px;height:12px;border-radius:2px;margin-right:5px;vertical-align:-1px}
svg{display:block;max-width:100%;height:auto}
svg text{font:11px "DejaVu Sans",sans-serif;fill:#1f2328}
svg .axis{stroke:#8c959f;stroke-width:1}svg .grid{stroke:#eaeef2;stroke-width:1}
svg .tick{fill:#57606a}
.drive{background:#fff;border:1px solid var(--line);border-left:6px solid var(--line);border-radius:8px;padding:12px 16px;margin-bottom:12px}
.drive.ok{border-left-color:var(--ok)}.drive.warn{border-left-color:var(--warn)}.drive.bad{border-left-color:var(--bad)}.drive.skip{border-left-color:var(--skip)}
.drive .head{display:flex;gap:10px;align-items:center;flex-wrap:wrap}
.drive .where{color:var(--muted)}
.drive dl.meta{grid-template-columns:max-content 1fr max-content 1fr}
.fp-same{color:var(--ok)}.fp-diff{color:var(--warn)}
.error{margin:10px 0 0;padding:8px 12px;background:var(--bad-bg);border:1px solid var(--bad);border-radius:6px;white-space:pre-wrap;word-break:break-word;font:12.5px/1.4 "DejaVu Sans Mono",ui-monospace,monospace}
table.diff{margin-top:10px}
table.diff td.old{color:var(--bad)}table.diff td.new{color:var(--ok)}
.arrow{color:var(--muted)}
footer{color:var(--muted);margin-top:28px;font-size:12px}
@media print{body{background:#fff}main{padding:0}.drive,.timeline,header.top{break-inside:avoid}}
"#;

/// Phases in legend order with their fill colour; unknown phases are grey.
/// The names are the engine's `observe::Phase` names (`journal` spans take
/// no time on a virtual clock and are left out of timelines).
const PHASES: [(&str, &str); 11] = [
    ("learn", "#0550ae"),
    ("recover", "#a40e26"),
    ("identify", "#6e7781"),
    ("read", "#54aeff"),
    ("plan", "#bf8700"),
    ("dataset", "#e16f24"),
    ("write", "#fb8f44"),
    ("commit", "#9a6700"),
    ("verify", "#2da44e"),
    ("broadcast", "#8250df"),
    ("rollback", "#cf222e"),
];
const OTHER_PHASE: &str = "#afb8c1";

fn phase_colour(phase: &str) -> &'static str {
    PHASES
        .iter()
        .find(|(p, _)| *p == phase)
        .map_or(OTHER_PHASE, |(_, c)| c)
}

/// A CSS-class-safe version of a phase name.
fn class_token(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// Render the whole page of a report of `run`.
pub fn render(r: &LineReport, run: Run) -> String {
    let mut o = String::with_capacity(16 * 1024);
    let (class, _, text) = line_result(r.result);
    let kind = match run {
        Run::Rehearsal => "rehearsal report (against twins)",
        Run::Commissioning => "commissioning report",
    };
    let title = format!("{text}: {kind} of {}", r.line);
    let _ = write!(
        o,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"driveset {}\">\n\
         <title>{}</title>\n<style>{CSS}</style>\n</head>\n<body>\n<main>\n",
        esc(env!("CARGO_PKG_VERSION")),
        esc(&title)
    );
    header(&mut o, r, class);
    buses(&mut o, r);
    drives_table(&mut o, r);
    timelines(&mut o, r);
    drive_details(&mut o, r);
    let _ = write!(
        o,
        "<footer>Written by driveset {} (report format {}). The machine-readable form of this \
         report is <code>report.json</code> beside this file.</footer>\n</main>\n</body>\n</html>\n",
        esc(env!("CARGO_PKG_VERSION")),
        r.report_version
    );
    o
}

fn header(o: &mut String, r: &LineReport, class: &str) {
    let (_, symbol, text) = line_result(r.result);
    let _ = write!(
        o,
        "<header class=\"top\">\n<div>\n<p class=\"kicker\">Commissioning report \u{b7} <code>driveset {}</code></p>\n\
         <h1 id=\"line\">{}</h1>\n<dl class=\"meta\">\n",
        esc(&r.command),
        esc(&r.line)
    );
    let mut meta = |k: &str, v: String| {
        let _ = writeln!(o, "<dt>{k}</dt><dd>{v}</dd>");
    };
    if let Some(label) = &r.label {
        meta(
            "Label",
            format!("<strong id=\"label\">{}</strong>", esc(label)),
        );
    }
    meta("Manifest", format!("<code>{}</code>", esc(&r.manifest)));
    meta(
        "Time",
        format!(
            "<span id=\"started\">{}</span> \u{2192} <span id=\"finished\">{}</span>",
            esc(&r.started),
            esc(&r.finished)
        ),
    );
    match &r.git {
        Some(g) => meta(
            "Git commit",
            format!(
                "<code id=\"git-commit\">{}</code>{}",
                esc(&g.commit),
                if g.dirty {
                    " <span class=\"badge dirty\">\u{26a0} uncommitted changes</span>"
                } else {
                    " <span class=\"badge ok\">clean</span>"
                }
            ),
        ),
        None => meta("Git commit", "<em>not in a git work tree</em>".into()),
    }
    if let Some(h) = &r.history {
        meta(
            "History",
            format!(
                "session <code id=\"history-session\">{}</code> in <code id=\"history-store\">{}</code>; \
                 the line as built: <code id=\"history-as-built\">{}</code>",
                esc(&h.session),
                esc(&h.store),
                esc(&h.as_built)
            ),
        );
    }
    let _ = writeln!(o, "</dl>");
    // counts per drive result, in the order of the result kinds
    let mut counts: BTreeMap<u8, (usize, (&str, &str, &str))> = BTreeMap::new();
    for d in &r.drives {
        counts
            .entry(result_rank(d.result))
            .or_insert((0, drive_result(d.result)))
            .0 += 1;
    }
    let _ = write!(
        o,
        "<div class=\"counts\"><span class=\"badge skip\">{} drive{} on {} bus{}</span>",
        r.drives.len(),
        if r.drives.len() == 1 { "" } else { "s" },
        r.buses.len(),
        if r.buses.len() == 1 { "" } else { "es" }
    );
    for (n, (class, symbol, text)) in counts.values() {
        let _ = write!(
            o,
            " <span class=\"badge {class}\"><span aria-hidden=\"true\">{symbol}</span> {n} {text}</span>"
        );
    }
    let _ = write!(
        o,
        "</div>\n</div>\n<div class=\"overall {class}\" id=\"result\" role=\"status\">\
         <span aria-hidden=\"true\">{symbol}</span> {text}</div>\n</header>\n"
    );
}

fn buses(o: &mut String, r: &LineReport) {
    let _ = write!(
        o,
        "<h2>Buses</h2>\n<table id=\"buses\">\n<thead><tr><th>Bus</th><th>Port</th><th>Protocol</th>\
         <th class=\"num\">Rate</th><th class=\"num\">Drives</th><th class=\"num\">Busy</th></tr></thead>\n<tbody>\n"
    );
    for b in &r.buses {
        let n = r.drives.iter().filter(|d| d.bus == b.name).count();
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td><code>{}</code></td><td>{}</td><td class=\"num\">{}</td>\
             <td class=\"num\">{n}</td><td class=\"num\">{}</td></tr>",
            esc(&b.name),
            esc(&b.port),
            esc(b.protocol.name()),
            if b.protocol == driveset_schema::BusProtocol::CanSdo {
                format!("{} bit/s", b.rate)
            } else {
                format!("{} Bd", b.rate)
            },
            fmt_ms(b.elapsed_ms)
        );
    }
    o.push_str("</tbody>\n</table>\n");
}

fn fp_cell(fp: Option<&str>, set_fp: &str) -> String {
    match fp {
        None => "<span class=\"where\">-</span>".into(),
        Some(fp) => {
            let (class, mark) = if fp == set_fp {
                ("fp-same", "= set")
            } else {
                ("fp-diff", "\u{2260} set")
            };
            format!(
                "<code title=\"{}\">{}</code> <span class=\"{class}\">{mark}</span>",
                esc(fp),
                esc(&short_fp(fp))
            )
        }
    }
}

fn drives_table(o: &mut String, r: &LineReport) {
    let _ = write!(
        o,
        "<h2>Drives</h2>\n<table id=\"drives\">\n<thead><tr><th>Drive</th><th>Bus / address</th>\
         <th>Set</th><th>Fingerprint before</th><th>Fingerprint after</th>\
         <th class=\"num\">Written</th><th class=\"num\">Retries</th><th class=\"num\">Time</th>\
         <th>Result</th></tr></thead>\n<tbody>\n"
    );
    for (i, d) in r.drives.iter().enumerate() {
        let res = drive_result(d.result);
        let _ = writeln!(
            o,
            "<tr class=\"{}\" data-drive=\"{}\"><td class=\"nowrap\"><a href=\"#drive-{i}\">{}</a></td>\
             <td class=\"nowrap\">{} / {}</td><td><code>{}</code></td><td class=\"nowrap\">{}</td><td class=\"nowrap\">{}</td>\
             <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>",
            res.0,
            esc(&d.name),
            esc(&d.name),
            esc(&d.bus),
            d.address,
            esc(&d.set),
            fp_cell(d.fingerprint_before.as_deref(), &d.set_fingerprint),
            fp_cell(d.fingerprint_after.as_deref(), &d.set_fingerprint),
            d.codes_written,
            d.retries,
            fmt_ms(d.elapsed_ms),
            badge(res)
        );
    }
    o.push_str("</tbody>\n</table>\n");
}

/// A tick step (1, 2 or 5 x 10^n ms) giving about `want` ticks over `span`.
fn tick_step(span: f64, want: f64) -> f64 {
    let raw = (span / want).max(1e-9);
    let mag = 10f64.powf(raw.log10().floor());
    for m in [1.0, 2.0, 5.0, 10.0] {
        if m * mag >= raw {
            return m * mag;
        }
    }
    10.0 * mag
}

fn timelines(o: &mut String, r: &LineReport) {
    let _ = writeln!(o, "<h2>Bus timelines</h2>");
    let _ = write!(o, "<div class=\"legend\">");
    for (p, c) in PHASES {
        let _ = write!(o, "<span><i style=\"background:{c}\"></i>{p}</span>");
    }
    let _ = writeln!(o, "</div>");
    for (i, b) in r.buses.iter().enumerate() {
        timeline(o, b, i);
    }
}

/// One bus: a Gantt chart of its timeline, one row per drive (in order of
/// first activity), one `rect` per timeline entry.
fn timeline(o: &mut String, b: &BusReport, index: usize) {
    let _ = writeln!(
        o,
        "<section class=\"timeline\" id=\"timeline-{index}\" data-bus=\"{}\">\n\
         <h3>{} <span class=\"mono\">{} \u{b7} {} \u{b7} {} entries \u{b7} busy {}</span></h3>",
        esc(&b.name),
        esc(&b.name),
        esc(&b.port),
        esc(b.protocol.name()),
        b.timeline.len(),
        fmt_ms(b.elapsed_ms)
    );
    if b.timeline.is_empty() {
        let _ = writeln!(
            o,
            "<p class=\"sub\">No bus activity recorded.</p>\n</section>"
        );
        return;
    }
    let mut rows: Vec<&str> = Vec::new();
    for e in &b.timeline {
        if !rows.contains(&e.drive.as_str()) {
            rows.push(&e.drive);
        }
    }
    let finite = |v: f64| if v.is_finite() { v.max(0.0) } else { 0.0 };
    let end = b
        .timeline
        .iter()
        .map(|e| finite(e.end_ms).max(finite(e.start_ms)))
        .fold(finite(b.elapsed_ms), f64::max)
        .max(1e-3);
    const W: f64 = 1100.0;
    const LABEL: f64 = 170.0;
    const RIGHT: f64 = 16.0;
    const ROW: f64 = 26.0;
    const TOP: f64 = 8.0;
    let plot = W - LABEL - RIGHT;
    let h = TOP + ROW * rows.len() as f64 + 30.0;
    let x = |ms: f64| LABEL + finite(ms) / end * plot;
    let _ = writeln!(
        o,
        "<svg class=\"gantt\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {W} {h}\" \
         width=\"{W}\" height=\"{h}\" role=\"img\" aria-label=\"Timeline of bus {}\">",
        esc(&b.name)
    );
    // grid and ticks
    let step = tick_step(end, 8.0);
    let axis_y = TOP + ROW * rows.len() as f64 + 4.0;
    let mut t = 0.0;
    while t <= end * 1.0001 {
        let xx = x(t);
        let _ = writeln!(
            o,
            "<line class=\"grid\" x1=\"{xx:.1}\" y1=\"{TOP}\" x2=\"{xx:.1}\" y2=\"{axis_y}\"/>\
             <text class=\"tick\" x=\"{xx:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            axis_y + 16.0,
            esc(&fmt_ms(t))
        );
        t += step;
    }
    let _ = writeln!(
        o,
        "<line class=\"axis\" x1=\"{LABEL}\" y1=\"{axis_y}\" x2=\"{:.1}\" y2=\"{axis_y}\"/>",
        LABEL + plot
    );
    for (ri, name) in rows.iter().enumerate() {
        let y = TOP + ROW * ri as f64;
        let shown: String = if name.chars().count() > 24 {
            name.chars().take(23).chain(['\u{2026}']).collect()
        } else {
            name.to_string()
        };
        let _ = writeln!(
            o,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            LABEL - 8.0,
            y + ROW / 2.0 + 4.0,
            esc(&shown)
        );
    }
    for e in &b.timeline {
        span(o, e, &rows, &x);
    }
    o.push_str("</svg>\n</section>\n");
}

fn span(o: &mut String, e: &TimelineEntry, rows: &[&str], x: &dyn Fn(f64) -> f64) {
    let ri = rows.iter().position(|r| *r == e.drive).unwrap_or(0);
    let y = 8.0 + 26.0 * ri as f64 + 4.0;
    let x0 = x(e.start_ms);
    let w = (x(e.end_ms) - x0).max(1.5);
    let _ = writeln!(
        o,
        "<rect class=\"span phase-{}\" data-drive=\"{}\" data-phase=\"{}\" x=\"{x0:.2}\" y=\"{y:.1}\" \
         width=\"{w:.2}\" height=\"18\" rx=\"2\" fill=\"{}\"><title>{}: {} {} \u{2192} {} ({})</title></rect>",
        class_token(e.phase.as_str()),
        esc(&e.drive),
        esc(e.phase.as_str()),
        phase_colour(e.phase.as_str()),
        esc(&e.drive),
        esc(e.phase.as_str()),
        esc(&fmt_ms(e.start_ms)),
        esc(&fmt_ms(e.end_ms)),
        esc(&fmt_ms(e.end_ms - e.start_ms))
    );
}

fn drive_details(o: &mut String, r: &LineReport) {
    let _ = writeln!(o, "<h2>Drive details</h2>");
    for (i, d) in r.drives.iter().enumerate() {
        drive_card(o, d, i);
    }
}

fn drive_card(o: &mut String, d: &DriveReport, i: usize) {
    let res = drive_result(d.result);
    let _ = write!(
        o,
        "<section class=\"drive {}\" id=\"drive-{i}\" data-drive=\"{}\">\n<div class=\"head\">\
         <h3 class=\"drive-name\">{}</h3>{}<span class=\"where\">{}bus {} address {}</span></div>\n\
         <dl class=\"meta\">\n",
        res.0,
        esc(&d.name),
        esc(&d.name),
        badge(res),
        d.position
            .as_deref()
            .map(|p| format!("{} \u{b7} ", esc(p)))
            .unwrap_or_default(),
        esc(&d.bus),
        d.address
    );
    let identity = if d.identity.is_empty() {
        "<em>not identified</em>".to_string()
    } else {
        d.identity
            .iter()
            .map(|(k, v)| format!("{} = <code>{}</code>", esc(k), esc(v)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let opt_fp = |fp: &Option<String>| match fp {
        Some(f) => format!("<code class=\"fp\">{}</code>", esc(f)),
        None => "<em>not read</em>".into(),
    };
    let rows: [(&str, String); 10] = [
        ("Set file", format!("<code>{}</code>", esc(&d.set))),
        ("Schema", format!("<code>{}</code>", esc(&d.schema))),
        ("Identity", identity),
        (
            "Set fingerprint",
            format!("<code class=\"fp\">{}</code>", esc(&d.set_fingerprint)),
        ),
        ("Before", opt_fp(&d.fingerprint_before)),
        ("After", opt_fp(&d.fingerprint_after)),
        ("Codes written", d.codes_written.to_string()),
        ("Telegrams", d.telegrams.to_string()),
        ("Retries", d.retries.to_string()),
        ("Time", fmt_ms(d.elapsed_ms)),
    ];
    for (k, v) in rows {
        let _ = writeln!(o, "<dt>{k}</dt><dd>{v}</dd>");
    }
    if let Some(stored) = &d.stored {
        // over a power cycle (docs/file-formats.md, `[schema.store]`)
        let _ = writeln!(o, "<dt>Kept at power off</dt><dd>{}</dd>", esc(stored));
    }
    if let Some(l) = &d.learned_schema {
        let _ = writeln!(
            o,
            "<dt>Learned schema</dt><dd><code>{}</code> from the drive's descriptions (extends <code>{}</code>; {} codes{}){}</dd>",
            esc(&l.id),
            esc(&l.base),
            l.codes,
            if l.texts {
                ""
            } else {
                ", without substitution texts"
            },
            l.file
                .as_deref()
                .map(|f| format!(", file <code>{}</code>", esc(f)))
                .unwrap_or_default()
        );
    }
    if let Some(h) = &d.history {
        let _ = writeln!(
            o,
            "<dt>History</dt><dd class=\"history\">record {} \u{b7} <code>{}</code></dd>",
            h.record,
            esc(&h.log)
        );
    }
    o.push_str("</dl>\n");
    if let Some(rep) = &d.replacement {
        let _ = writeln!(
            o,
            "<div class=\"replacement\" role=\"note\"><strong>Replacement unit:</strong> a spare on service port <code>{}</code> (found at address {}, {} baud) was given address {} and {} baud{}, then this drive's set.{}</div>",
            esc(&rep.service_port),
            rep.found_address,
            rep.found_rate,
            rep.address,
            rep.rate,
            rep.old_address
                .map(|a| format!(" (its own address was {a})"))
                .unwrap_or_default(),
            rep.rate_note
                .as_deref()
                .map(|n| format!(" {}", esc(n)))
                .unwrap_or_default()
        );
    }
    if d.factory_settings {
        let _ = writeln!(
            o,
            "<div class=\"factory\" role=\"note\"><strong>{}:</strong> where it differed from its set, the drive held its schema's defaults.</div>",
            if d.result == DriveResult::Drift {
                "At factory settings (a new or exchanged unit?)"
            } else {
                "Was at factory settings (a new or exchanged unit?)"
            }
        );
    }
    if let Some(e) = &d.error {
        let _ = writeln!(
            o,
            "<div class=\"error\" role=\"alert\"><strong>Error:</strong> {}</div>",
            esc(e)
        );
    }
    if !d.diff.is_empty() {
        diff_table(o, &d.diff);
    }
    o.push_str("</section>\n");
}

fn diff_table(o: &mut String, diff: &[DiffLine]) {
    let _ = write!(
        o,
        "<table class=\"diff\">\n<thead><tr><th>Code</th><th>Name</th><th>Change</th><th>Old (drive)</th>\
         <th></th><th>New (set)</th></tr></thead>\n<tbody>\n"
    );
    for l in diff {
        let unset = "<em>(unset)</em>".to_string();
        let _ = writeln!(
            o,
            "<tr class=\"diff-line\"><td><code>{}</code></td><td>{}</td><td>{}</td>\
             <td class=\"old\"><code>{}</code></td><td class=\"arrow\">\u{2192}</td><td class=\"new\"><code>{}</code></td></tr>",
            esc(&l.code),
            esc(&l.name),
            esc(l.kind.as_str()),
            l.old.as_deref().map_or(unset.clone(), esc),
            l.new.as_deref().map_or(unset, esc)
        );
    }
    o.push_str("</tbody>\n</table>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_and_quotes() {
        assert_eq!(
            esc("<script>alert('x') & \"y\"</script>"),
            "&lt;script&gt;alert(&#39;x&#39;) &amp; &quot;y&quot;&lt;/script&gt;"
        );
        assert_eq!(esc("a\u{0}b\u{1b}c\n"), "a\u{fffd}b\u{fffd}c\n");
    }

    #[test]
    fn formats_times_and_fingerprints() {
        assert_eq!(fmt_ms(2.25), "2.2 ms");
        assert_eq!(fmt_ms(850.0), "850 ms");
        assert_eq!(fmt_ms(1840.0), "1.84 s");
        assert_eq!(fmt_ms(125_000.0), "2 min 05 s");
        assert_eq!(fmt_ms(f64::NAN), "-");
        assert_eq!(
            short_fp("sha256:0123456789abcdef"),
            "sha256:0123456789\u{2026}"
        );
        assert_eq!(short_fp("short"), "short");
        assert_eq!(tick_step(1000.0, 8.0), 200.0);
        assert_eq!(tick_step(95.0, 8.0), 20.0);
    }
}
