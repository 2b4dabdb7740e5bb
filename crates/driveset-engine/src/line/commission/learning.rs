//! Owns learning the schema of a drive whose set names a built-in LUSTBUS
//! schema that lacks facts (module docs of [`super`], "Learning the
//! schema"): the drive's descriptions read over the bus's link, the
//! learned schema rendered and written (`commission`) or an earlier file
//! used (`status`), and the set resolved again against it.

use std::path::Path;
use std::sync::Arc;

use driveset_link::Link;
use driveset_schema::error::SourceFile;
use driveset_schema::{CodeKey, Location, Registry, ResolvedSet, Schema, load_set};

use super::drive::{Failure, failure_of};
use super::options::{LineLearn, Mode};
use super::run::Ctx;
use crate::client::{DriveClient, Identity};
use crate::error::EngineError;
use crate::learn::{LearnOptions, LearnSource, Learned, learn, learned_id, render_schema};
use crate::line::manifest::{Bus, Drive};
use crate::line::report::LearnedSchemaReport;

/// Why learning failed: the message, and what kind of failure it was.
type LearnError = (String, Option<Failure>);

/// Learns the schema of drive `d` (whose set names `base`, a built-in
/// schema that lacks facts) over the bus's link and resolves its set
/// against it (module docs of [`super`], "Learning the schema"). Returns
/// the drive as the run then treats it, or the error text and what kind
/// of failure it was.
pub(super) fn learn_drive(
    bus: &Bus,
    d: &Drive,
    base: &Arc<Schema>,
    link: &mut Link,
    ctx: &Ctx<'_>,
) -> Result<(Drive, LearnedSchemaReport), LearnError> {
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
    let mut opts = cfg.options.clone();
    if ctx.mode == Mode::Status {
        // descriptions only: reading texts selects them through 108-STEXT
        opts.no_texts = true;
    }
    let (identity, mut learned) = read_drive(d, base, link, &opts).map_err(|e| match e {
        Read::Can => (
            format!(
                "{what}: `{}` is a LUSTBUS schema, but bus `{}` is a CAN bus",
                base.id, bus.name
            ),
            None,
        ),
        Read::Engine(e) => {
            let f = failure_of(&e);
            (
                format!("{what}: learning the schema from the drive's descriptions: {e}"),
                f,
            )
        }
    })?;
    let input = |e: String| (format!("{what}: {e}"), None);
    let id = learned_id(base.family, &identity, &learned);
    let source = LearnSource {
        drive: format!("{} address {}", bus.port_name, d.address),
        identity,
    };
    let path = cfg.schema_dir.join(format!("{id}.toml"));
    let mut registry = cfg.registry.clone();
    let (schema, file, codes) = learned_schema(
        &mut learned,
        Rendering {
            base,
            id: &id,
            source: &source,
            path: &path,
            cfg,
        },
        &mut registry,
        ctx,
    )
    .map_err(input)?;
    registry.insert_as(&base.id, schema.clone());
    let (set, set_bus_codes) =
        resolve_set(d, &id, &path, file.is_none(), &mut registry, ctx).map_err(input)?;
    let report = LearnedSchemaReport {
        id: schema.id.clone(),
        base: base.id.clone(),
        file,
        codes,
        texts: !opts.no_texts,
        findings: learned.findings.len(),
    };
    let drive = Drive {
        schema,
        set,
        set_bus_codes,
        ..d.clone()
    };
    Ok((drive, report))
}

/// Why the drive's descriptions could not be read.
enum Read {
    /// The bus is a CAN bus.
    Can,
    /// The bus or the drive failed.
    Engine(EngineError),
}

/// Identify the drive and read and interpret its descriptions (and MC
/// texts unless `opts.no_texts`), ending the exchange.
fn read_drive(
    d: &Drive,
    base: &Arc<Schema>,
    link: &mut Link,
    opts: &LearnOptions,
) -> Result<(Identity, Learned), Read> {
    if !matches!(link, Link::Bytes(_)) {
        return Err(Read::Can);
    }
    let mut client =
        crate::connect::lustbus_on(link, base.clone(), d.address).map_err(Read::Engine)?;
    let identity = client.identify().map_err(Read::Engine)?;
    let opts = crate::learn::options_for(base, opts);
    let learned = learn(&mut client, base.family, &opts).map_err(Read::Engine)?;
    client.finish().map_err(Read::Engine)?;
    Ok((identity, learned))
}

/// What a learned schema is rendered from and where its file goes.
struct Rendering<'a> {
    base: &'a Arc<Schema>,
    id: &'a str,
    source: &'a LearnSource,
    path: &'a Path,
    cfg: &'a LineLearn,
}

/// The learned schema, its file and how many codes it has: in `status`
/// the file an earlier `commission` wrote for these very descriptions
/// when there is one, else rendered from `learned` (and written to its
/// file in `commission`).
fn learned_schema(
    learned: &mut Learned,
    how: Rendering<'_>,
    registry: &mut Registry,
    ctx: &Ctx<'_>,
) -> Result<(Arc<Schema>, Option<String>, usize), String> {
    let env = &*ctx.opts.env;
    let path = how.path;
    let earlier = if ctx.mode == Mode::Status {
        env.read_file(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?
    } else {
        None
    };
    if let Some(text) = earlier {
        let schema = registry
            .add_source(SourceFile::new(path.display().to_string(), text))
            .map_err(|e| format!("learned schema {}: {}", path.display(), e.message))?;
        let codes = learned.codes.len();
        return Ok((schema, Some(path.display().to_string()), codes));
    }
    let rendered = render_schema(learned, how.base, how.id, how.source, registry)?;
    let file = if ctx.mode == Mode::Commission {
        let dir = &how.cfg.schema_dir;
        env.create_dir(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        env.write_file(path, &rendered.text)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Some(path.display().to_string())
    } else {
        None
    };
    Ok((rendered.schema, file, rendered.codes))
}

/// Drive `d`'s set resolved against `registry` (which now holds the
/// learned schema `id` under the base's id), with its bus codes; a set
/// that does not fit fails the drive. `unwritten`: `status` found no
/// learned file at `path` (the hint says so).
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
            let hint = if ctx.mode == Mode::Status && unwritten {
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
