//! Owns the selection of a line run: the drives `--only` / `--skip` name
//! (by drive or by bus), a name the manifest does not have refused.

use std::collections::BTreeSet;

use super::options::{LineError, LineOptions};
use crate::line::manifest::{Drive, Manifest};

/// The drive names `--only` / `--skip` select (names of drives or buses);
/// a rehearsal asks it which drives need a twin.
pub fn select(manifest: &Manifest, opts: &LineOptions) -> Result<BTreeSet<String>, LineError> {
    let known = |n: &str| {
        manifest.drives.iter().any(|d| d.name == n) || manifest.buses.iter().any(|b| b.name == n)
    };
    for n in opts.only.iter().chain(&opts.skip) {
        if !known(n) {
            let names: Vec<&str> = manifest.drives.iter().map(|d| d.name.as_str()).collect();
            return Err(LineError::Selection(format!(
                "no drive or bus is named `{n}` in {}; drives: {}",
                manifest.path.display(),
                names.join(", ")
            )));
        }
    }
    let hit = |list: &[String], d: &Drive| list.iter().any(|n| *n == d.name || *n == d.bus);
    Ok(manifest
        .drives
        .iter()
        .filter(|d| (opts.only.is_empty() || hit(&opts.only, d)) && !hit(&opts.skip, d))
        .map(|d| d.name.clone())
        .collect())
}
