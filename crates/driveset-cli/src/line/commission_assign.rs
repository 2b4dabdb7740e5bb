//! `driveset commission LINE --assign`: the line's first contact (the
//! engine's `line::commission_assign`): every drive of the line's LUSTBUS and LECOM
//! buses gets its manifest address and its bus's rate, one drive at a time
//! ("connect NAME alone to PORT, then press Enter"), then each bus is
//! scanned and the table printed; then the normal commission runs.

use std::path::PathBuf;

use driveset_engine::line::commission_assign::{
    CommissionAssignOptions, CommissionAssignReport, Stopped, commission_assign, on_service_port,
};
use driveset_engine::line::manifest::{Bus, Drive, Manifest};

use crate::fail::Fail;
use crate::prompt::{ask, confirm_allowed};

/// What `--assign` was given.
pub struct AssignArgs {
    /// `--port`: the port the drives are connected to one at a time
    /// (default: each bus's own port).
    pub port: Option<String>,
    /// `--yes`: no prompts (the order is the manifest's).
    pub yes: bool,
    /// Test hook: read the prompts' answers from stdin even when it is not
    /// a terminal.
    pub prompt_stdin: bool,
    /// `--only`.
    pub only: Vec<String>,
    /// The named overrides (`--allow-running` ...: the running rule of the
    /// address and rate writes).
    pub overrides: driveset_engine::overrides::Overrides,
}

/// Print the first contact's table (one per bus) and its verdict.
pub fn table(a: &CommissionAssignReport) -> String {
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

/// Run the first contact; `Ok(true)` when every bus holds.
pub fn run(manifest: &Manifest, args: &AssignArgs, journal_dir: PathBuf) -> Result<bool, Fail> {
    if !args.yes && !args.prompt_stdin {
        confirm_allowed("commission --assign")?;
    }
    let m = match &args.port {
        Some(p) => on_service_port(manifest.clone(), p, &crate::port::openers())
            .map_err(|e| Fail::input(e.to_string()))?,
        None => manifest.clone(),
    };
    let opts = CommissionAssignOptions {
        journal_dir,
        scan: Default::default(),
        only: args.only.clone(),
        overrides: args.overrides,
    };
    let yes = args.yes;
    let mut connect = |bus: &Bus, d: &Drive| -> Result<(), Stopped> {
        if yes {
            eprintln!(
                "{}: assigning address {} on {} (--yes: the manifest's order, no prompt)",
                d.name, d.address, bus.port_name
            );
            return Ok(());
        }
        let prompt = format!(
            "connect {} alone to {}, then press Enter ",
            d.name, bus.port_name
        );
        match ask(&prompt) {
            Ok(_) => Ok(()),
            Err(f) => Err(Stopped(f.msg)),
        }
    };
    let a = commission_assign(&m, &opts, &super::open_bus, &mut connect);
    out!("{}", table(&a));
    Ok(a.ok)
}
