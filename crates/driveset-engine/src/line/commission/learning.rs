//! Owns learning the schema of a drive whose set names a built-in LUSTBUS
//! schema that lacks facts (module docs of [`super`], "Learning the
//! schema"): the drive's session over the bus's link learns it
//! ([`crate::session::BusSession`]: rendered and written by `commission`,
//! an earlier file reused by `status`, [`LearnStep`]), and the set is
//! resolved again against it. What is read, rendered and written is the
//! session's ([`crate::session::learning`]); this module words its
//! failures for the line report.

use std::path::Path;
use std::sync::Arc;

use driveset_link::Link;
use driveset_schema::{CodeKey, Location, Registry, ResolvedSet, Schema, load_set};

use super::drive::{Failure, failure_of};
use super::run::Ctx;
use crate::line::manifest::{Bus, Drive};
use crate::line::report::LearnedSchemaReport;
use crate::session::{BusSession, LearnPolicy, LearnStep, SessionError, SessionPolicy};

/// Why learning failed: the message, and what kind of failure it was.
type LearnError = (String, Option<Failure>);

/// Learns the schema of drive `d` (whose set names `base`, a built-in
/// schema that lacks facts) over the bus's link and resolves its set
/// against it (module docs of [`super`], "Learning the schema"). Returns
/// the drive as the run then treats it, its report's learned schema and
/// its session (whose client speaks the learned schema), or the error text
/// and what kind of failure it was.
pub(super) fn learn_drive<'l>(
    bus: &Bus,
    d: &Drive,
    base: &Arc<Schema>,
    link: &'l mut Link,
    ctx: &Ctx<'_>,
) -> Result<(Drive, LearnedSchemaReport, BusSession<'l>), LearnError> {
    let what = format!(
        "drive `{}` ({} address {})",
        d.name, bus.port_name, d.address
    );
    let Some(cfg) = &ctx.opts.learn else {
        return Err((
            format!(
                "{what}: set `{}` names `{}`, which lacks facts (types, kinds, ranges) the drive's descriptions give, and learning is off (--no-learn); name a learned schema in the set (`driveset schema pull`)",
                d.set_text, base.id
            ),
            None,
        ));
    };
    if !matches!(link, Link::Bytes(_)) {
        return Err((
            format!(
                "{what}: `{}` is a LUSTBUS schema, but bus `{}` is a CAN bus",
                base.id, bus.name
            ),
            None,
        ));
    }
    let policy = SessionPolicy {
        learn: Some(LearnPolicy {
            options: cfg.options.clone(),
            registry: &cfg.registry,
            dir: Some(cfg.schema_dir.clone()),
            env: &*ctx.opts.env,
            // status: descriptions only (reading texts selects them
            // through 108-STEXT)
            step: ctx.walk.learn_step(),
        }),
    };
    let session = BusSession::open_using(
        link,
        &bus.port_name,
        base.clone(),
        d.address,
        &policy,
        bus.connect(),
    )
    .map_err(|e| worded(&what, e))?;
    let Some(learned) = &session.learned else {
        // the manifest sets `learn_from` only for a schema that needs learning
        return Err((format!("{what}: `{}` needs no learning", base.id), None));
    };
    let schema = learned.schema.clone();
    let path = cfg.schema_dir.join(format!("{}.toml", learned.id));
    let mut registry = cfg.registry.clone();
    registry.insert_as(&base.id, schema.clone());
    let (set, set_bus_codes) = resolve_set(
        d,
        &learned.id,
        &path,
        learned.file.is_none(),
        &mut registry,
        ctx,
    )
    .map_err(|e| (format!("{what}: {e}"), None))?;
    let report = LearnedSchemaReport {
        id: schema.id.clone(),
        base: base.id.clone(),
        file: learned.file.as_ref().map(|f| f.display().to_string()),
        codes: learned.codes,
        // status's `ReuseEarlier` reads no texts
        texts: ctx.walk.learn_step() == LearnStep::Render && !cfg.options.no_texts,
        findings: learned.learned.findings.len(),
    };
    let drive = Drive {
        schema,
        set,
        set_bus_codes,
        ..d.clone()
    };
    Ok((drive, report, session))
}

/// A session's failure to learn as the line report words it, and what
/// kind of failure it was.
fn worded(what: &str, e: SessionError) -> LearnError {
    match e {
        SessionError::Engine(e) => {
            let f = failure_of(&e);
            (
                format!("{what}: learning the schema from the drive's descriptions: {e}"),
                f,
            )
        }
        SessionError::Render { detail, .. } => (format!("{what}: {detail}"), None),
        e => (format!("{what}: {e}"), None),
    }
}

/// Drive `d`'s set resolved against `registry` (which now holds the
/// learned schema `id` under the base's id), with its bus codes; a set
/// that does not fit fails the drive. `unwritten`: no learned file at
/// `path`, which a read-only learning (`status`) then says.
fn resolve_set(
    d: &Drive,
    id: &str,
    path: &Path,
    unwritten: bool,
    registry: &mut Registry,
    ctx: &Ctx<'_>,
) -> Result<(ResolvedSet, Vec<(CodeKey, Location)>), String> {
    let loaded = load_set(&d.set_path, registry)
        .map_err(|e| format!("set {}: {}", d.set_path.display(), e.message))?;
    match (loaded.findings.is_empty(), loaded.resolved) {
        (true, Some(set)) => Ok((set, loaded.bus_codes)),
        _ => {
            let list: Vec<String> = loaded.findings.iter().map(|f| f.to_string()).collect();
            let hint = if ctx.walk.learn_step() == LearnStep::ReuseEarlier && unwritten {
                format!(
                    "; status reads no substitution texts and found no learned file {} (run `driveset commission` first, whose file status then uses, or give --schema-dir where it is)",
                    path.display()
                )
            } else {
                String::new()
            };
            Err(format!(
                "set `{}` does not fit the schema learned from the drive ({id}): {}; fix the set (`driveset validate {}` after naming the learned schema){hint}",
                d.set_text,
                list.join("; "),
                d.set_path.display()
            ))
        }
    }
}
