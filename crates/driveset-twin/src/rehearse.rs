//! The buses of a rehearsal (`driveset commission MANIFEST --rehearse
//! DIR`, docs/twins.md): the twins of a manifest's drives found in `DIR`
//! and checked ([`twins`]), each bus opened as a simulated bus of its
//! drives' twins in virtual time ([`opener`]; they live in this process
//! only, so there is no bus to lock), and the label its report carries
//! ([`label`]); [`prepare`] gives all three for the selected drives, and
//! [`for_run`] for the drives a line run's options select, those options
//! made a rehearsal's. A rehearsal that would rehearse nothing is refused.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

use driveset_engine::line::commission::LineOptions;
use driveset_engine::line::manifest::{Bus, Manifest};
use driveset_link::{Link, VirtualClock};
use driveset_sim::log::EventLog;
use driveset_sim::open::{SimConfig, open_sim_with};
use driveset_sim::twin::{TWIN_SUFFIX, Twin, load_file};

/// Why a rehearsal is refused before it starts (an input error: the
/// directory, its twins, the drives they are of); the message says what
/// to do.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refused(pub String);

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refused {}

/// The twins of a rehearsal: per drive of `manifest`, its twin in `dir`
/// (`None`: not rehearsed). A rehearsal that would rehearse nothing is
/// refused: `dir` missing or not a directory, holding no twin, or no twin
/// of any drive of `selected`; so is a twin of another address than its
/// drive's.
pub fn twins(
    manifest: &Manifest,
    dir: &Path,
    selected: &BTreeSet<String>,
) -> Result<BTreeMap<String, Option<Twin>>, Refused> {
    let capture = format!(
        "capture the line's twins into it with `driveset twin capture-line {} -o {}`",
        manifest.path.display(),
        dir.display()
    );
    if !dir.is_dir() {
        let what = if dir.exists() {
            "is not a directory"
        } else {
            "no such directory"
        };
        return Err(Refused(format!(
            "--rehearse {}: {what}; {capture}",
            dir.display()
        )));
    }
    let any_twin = std::fs::read_dir(dir)
        .map_err(|e| Refused(format!("--rehearse {}: cannot read: {e}", dir.display())))?
        .filter_map(Result::ok)
        .any(|e| e.file_name().to_string_lossy().ends_with(TWIN_SUFFIX));
    if !any_twin {
        return Err(Refused(format!(
            "--rehearse {}: the directory holds no twin (*{TWIN_SUFFIX}); {capture}",
            dir.display()
        )));
    }
    let mut out = BTreeMap::new();
    for d in &manifest.drives {
        let file = dir.join(format!("{}{TWIN_SUFFIX}", d.name));
        // a file that is there but is no regular file is an error naming
        // it (the reader says what it is), not a drive without a twin
        let twin = if std::fs::symlink_metadata(&file).is_ok() {
            let t = load_file(&file).map_err(|e| Refused(e.to_string()))?;
            if t.address != d.address {
                return Err(Refused(format!(
                    "{}: the twin is of address {}, the manifest puts {} at address {}; capture it again (driveset twin capture-line)",
                    file.display(),
                    t.address,
                    d.name,
                    d.address
                )));
            }
            Some(t)
        } else {
            None
        };
        out.insert(d.name.clone(), twin);
    }
    if !selected
        .iter()
        .any(|n| out.get(n).is_some_and(Option::is_some))
    {
        let names: Vec<String> = selected
            .iter()
            .map(|n| format!("{n}{TWIN_SUFFIX}"))
            .collect();
        return Err(Refused(format!(
            "--rehearse {}: no twin of any selected drive (looked for {}); {capture}",
            dir.display(),
            names.join(", ")
        )));
    }
    Ok(out)
}

/// A rehearsal ready to run ([`prepare`]).
#[derive(Debug)]
pub struct Rehearsal<O> {
    /// Its buses' opener ([`opener`]).
    pub opener: O,
    /// The selected drives without a twin, in the manifest's order: not
    /// rehearsed (the line run skips them; the report names them).
    pub missing: Vec<String>,
    /// Its report's label ([`label`]).
    pub label: String,
}

/// The rehearsal of the `selected` drives of `manifest` against the twins
/// in `dir`: the twins found and checked ([`twins`]), the selected drives
/// without one, the label and the buses' opener.
///
/// # Errors
/// [`Refused`] when it would rehearse nothing (see [`twins`]).
pub fn prepare(
    manifest: &Manifest,
    dir: &Path,
    selected: &BTreeSet<String>,
) -> Result<Rehearsal<impl Fn(&Bus) -> Result<Link, String> + Sync + use<>>, Refused> {
    let twins = twins(manifest, dir, selected)?;
    let missing: Vec<String> = twins
        .iter()
        .filter(|(n, t)| t.is_none() && selected.contains(*n))
        .map(|(n, _)| n.clone())
        .collect();
    let label = label(dir, &twins, &missing);
    Ok(Rehearsal {
        opener: opener(manifest, &twins),
        missing,
        label,
    })
}

/// The rehearsal of a line run with `opts` (`driveset commission
/// MANIFEST --rehearse DIR`) against the twins in `dir`: the drives `opts`
/// selects ([`driveset_engine::line::commission::select`]) [`prepare`]d,
/// and `opts` made a rehearsal's: the selected drives without a twin
/// skipped, the rehearsal's label, no resume state (`fresh`), its own
/// journals (`rehearsal-journal` in the report directory).
///
/// # Errors
/// [`Refused`] when the selection names what the manifest lacks, or the
/// rehearsal would rehearse nothing (see [`twins`]).
pub fn for_run(
    manifest: &Manifest,
    dir: &Path,
    opts: &mut LineOptions,
) -> Result<Rehearsal<impl Fn(&Bus) -> Result<Link, String> + Sync + use<>>, Refused> {
    let selected = driveset_engine::line::commission::select(manifest, opts)
        .map_err(|e| Refused(e.to_string()))?;
    let r = prepare(manifest, dir, &selected)?;
    opts.skip.extend(r.missing.iter().cloned());
    opts.label = Some(r.label.clone());
    opts.fresh = true;
    opts.journal_dir = opts.report_dir.join("rehearsal-journal");
    Ok(r)
}

/// The opener of a rehearsal: each bus a simulated bus of its drives'
/// twins, in virtual time.
pub fn opener(
    manifest: &Manifest,
    twins: &BTreeMap<String, Option<Twin>>,
) -> impl Fn(&Bus) -> Result<Link, String> + Sync + use<> {
    let mut per_bus: BTreeMap<String, Vec<Twin>> = BTreeMap::new();
    for d in &manifest.drives {
        if let Some(Some(t)) = twins.get(&d.name) {
            per_bus
                .entry(manifest.buses[d.bus_index].name.clone())
                .or_default()
                .push(t.clone());
        }
    }
    move |bus: &Bus| {
        let twins = per_bus
            .get(&bus.name)
            .cloned()
            .ok_or_else(|| format!("no twin for any drive of bus {}", bus.name))?;
        let config = SimConfig::of_twins(twins).map_err(|e| e.to_string())?;
        open_sim_with(
            &config,
            &VirtualClock::new(),
            &bus.port_name,
            EventLog::off(),
        )
        .map(|l| l.link())
        .map_err(|e| e.to_string())
    }
}

/// The label of a rehearsal report: it is a rehearsal, of which twins, and
/// which selected drives were not rehearsed (`missing`: no twin).
pub fn label(dir: &Path, twins: &BTreeMap<String, Option<Twin>>, missing: &[String]) -> String {
    let mut dates: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (name, t) in twins {
        if let Some(t) = t {
            dates.entry(t.captured.as_str()).or_default().push(name);
        }
    }
    let mut s = format!("REHEARSAL against the twins in {}", dir.display());
    let list: Vec<String> = dates
        .iter()
        .map(|(date, names)| format!("captured {date}: {}", names.join(", ")))
        .collect();
    if !list.is_empty() {
        let _ = write!(s, " ({})", list.join("; "));
    }
    if !missing.is_empty() {
        let _ = write!(s, "; not rehearsed (no twin): {}", missing.join(", "));
    }
    s
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use driveset_engine::env::Memory;

    use super::*;

    fn manifest() -> Manifest {
        Manifest {
            path: "line.toml".into(),
            name: "line".into(),
            label: None,
            report_dir: None,
            journal_dir: None,
            buses: Vec::new(),
            drives: Vec::new(),
        }
    }

    fn opts() -> LineOptions {
        LineOptions::new("reports", Arc::new(Memory::at(jiff::Timestamp::UNIX_EPOCH)))
    }

    #[test]
    fn a_run_naming_what_the_manifest_lacks_or_without_twins_is_refused_untouched() {
        let mut o = opts();
        o.only = vec!["nope".into()];
        let Err(e) = for_run(&manifest(), Path::new("twins"), &mut o) else {
            panic!("a selection of nothing known is refused");
        };
        assert!(e.0.contains("no drive or bus is named `nope`"), "{e}");
        let mut o = opts();
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("none");
        let Err(e) = for_run(&manifest(), &missing, &mut o) else {
            panic!("a missing directory is refused");
        };
        assert!(e.0.contains("no such directory"), "{e}");
        assert!(!o.fresh && o.label.is_none() && o.skip.is_empty());
        assert_eq!(o.journal_dir, Path::new("reports").join("journals"));
    }
}
