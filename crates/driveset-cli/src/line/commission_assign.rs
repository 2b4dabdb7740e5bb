//! `driveset commission LINE --assign`: the line's first contact (the
//! engine's `line::commission_assign`): every drive of the line's LUSTBUS and LECOM
//! buses gets its manifest address and its bus's rate, one drive at a time
//! ("connect NAME alone to PORT, then press Enter"), then each bus is
//! scanned and the table printed (`driveset_report::line::assign_table`);
//! then the normal commission runs.

use std::path::PathBuf;

use driveset_engine::line::commission_assign::{
    CommissionAssignOptions, Stopped, commission_assign, on_service_port,
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
    out!("{}", driveset_report::line::assign_table(&a));
    Ok(a.ok)
}
