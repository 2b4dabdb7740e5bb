//! Owns the learned file as a whole: its id (the learned-file name
//! scheme), where it comes from, and rendering it until it checks: the
//! contradiction findings, then render, parse and `schema check`, leaving
//! out each code the check objects to (module docs of [`super`]).

use std::collections::BTreeSet;
use std::sync::Arc;

use driveset_proto::lustbus::Dialect;
use driveset_schema::error::SourceFile;
use driveset_schema::family::TYPE;
use driveset_schema::{Family, Location, Registry, Schema, check_schema};

use super::contradict::{contradiction_message, contradictions};
use super::model::{KEPT_SPEC, LearnFinding, Learned};
use super::render::render_text;
use crate::client::Identity;

/// The file (and schema id) a learned schema is stored under:
/// `learned-<family>-type<TYPE>-<software>.toml`, the software being the
/// identity's software version where the drive reports one, else
/// `d<8 hex>`, the hash of the descriptions the drive sent. The scheme is
/// the descriptor's ([`driveset_schema::Learning::file_id`]), the TYPE the
/// value of its [`driveset_schema::Descriptor::type_code`] (LUSTBUS
/// 91-TYPE, section 5.2).
pub fn learned_id(protocol: Family, identity: &Identity, learned: &Learned) -> String {
    // A family without descriptions (none learns: only LUSTBUS clients do)
    // is named as before the descriptor held the scheme: like an MC file.
    let d = Some(protocol.descriptor())
        .filter(|d| d.learning.is_some())
        .unwrap_or_else(|| Family::from_dialect(Dialect::Mc).descriptor());
    let ty = identity
        .value_of(d.type_code.unwrap_or(TYPE))
        .map(ToString::to_string);
    d.learned_id(
        ty.as_deref(),
        identity.software.as_deref(),
        learned.descriptions_hash,
    )
    .unwrap_or_default()
}

/// Where a learned schema comes from, for its file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LearnSource {
    /// `<port> address <a>`.
    pub drive: String,
    /// The drive's identity (for the header and `[schema.identify]`).
    pub identity: Identity,
}

/// A rendered, checked learned schema.
#[derive(Debug, Clone)]
pub struct LearnedSchema {
    /// Its id (also the file stem).
    pub id: String,
    /// The file text.
    pub text: String,
    /// The schema, parsed and checked.
    pub schema: Arc<Schema>,
    /// Codes in the file that came from the drive.
    pub codes: usize,
}

/// How reports name learned parameter `number`: the base schema's display
/// code, else `<number>-<the description's name>`.
fn code_name(learned: &Learned, base: &Schema, number: u32) -> String {
    if base.code(number).is_some() {
        return base.display_code(number, None);
    }
    match learned.codes.iter().find(|c| c.number == number) {
        Some(c) if !c.name.trim().is_empty() => format!("{number}-{}", c.name.trim()),
        _ => number.to_string(),
    }
}

/// Renders `learned` as a schema file extending `base` (merge rule in the
/// module docs), parses and checks it, and leaves out any code the check
/// objects to (recorded in `learned.findings`, naming the code and the
/// check). Where the drive contradicts a fact of `base`, the base's fact
/// stands, the drive's is recorded in the file (`# drive says:`) and a
/// `kept the spec's` finding names the code, both facts and the spec
/// section. `registry` must hold `base`. Fails only when the file's own
/// head (not a code) does not check.
pub fn render_schema(
    learned: &mut Learned,
    base: &Schema,
    id: &str,
    source: &LearnSource,
    registry: &Registry,
) -> Result<LearnedSchema, String> {
    for c in &learned.codes {
        if let Some(b) = base.code(c.number) {
            let x = contradictions(c, b, base);
            if !x.is_empty() {
                learned.findings.push(LearnFinding {
                    code: String::new(),
                    number: c.number,
                    action: KEPT_SPEC,
                    reason: contradiction_message(c, b, base, &x),
                });
            }
        }
    }
    // A type the learner downgraded or dropped does not matter where the
    // spec gives the type: say so rather than "not read".
    for f in &mut learned.findings {
        if let Some(bt) = base.code(f.number).and_then(|b| base.type_of(b))
            && f.action == "downgraded"
            && f.reason.contains("type")
        {
            let head = f
                .reason
                .rsplit_once("; ")
                .map_or(f.reason.as_str(), |(h, _)| h);
            f.reason = format!("{head}; the spec's type {} stands", bt.name());
        }
    }
    let file = format!("{id}.toml");
    let mut dropped: BTreeSet<u32> = BTreeSet::new();
    let result = loop {
        let (text, spans) = render_text(learned, base, id, source, &dropped);
        let mut reg = registry.clone();
        let parsed = reg.add_source(SourceFile::new(file.clone(), text.clone()));
        let objections: Vec<(Location, String)> = match &parsed {
            Ok(schema) => check_schema(schema)
                .into_iter()
                .map(|f| (f.location, f.message))
                .collect(),
            Err(e) => vec![((*e.location).clone(), e.message.clone())],
        };
        if objections.is_empty() {
            let schema = reg
                .get(id)
                .ok_or_else(|| format!("learned schema {id} vanished"))?;
            let codes = learned.codes.len() - dropped.len();
            break Ok(LearnedSchema {
                id: id.to_string(),
                text,
                schema,
                codes,
            });
        }
        // The code an objection is about: the learned entry holding its
        // line, or (a fact merged into a base code) the base code whose
        // entry holds it.
        let owner = |loc: &Location| -> Option<u32> {
            if loc.file == file {
                return spans
                    .iter()
                    .find(|(_, r)| r.contains(&loc.line))
                    .map(|(n, _)| *n);
            }
            let codes = parsed.as_ref().map_or(&base.codes, |s| &s.codes);
            codes
                .iter()
                .filter(|c| c.loc.file == loc.file && c.loc.line <= loc.line)
                .max_by_key(|c| c.loc.line)
                .map(|c| c.number)
                .filter(|n| learned.codes.iter().any(|c| c.number == *n))
        };
        let mut progress = false;
        let mut unowned = Vec::new();
        for (loc, msg) in objections {
            match owner(&loc) {
                Some(n) if !dropped.contains(&n) => {
                    dropped.insert(n);
                    learned.findings.push(LearnFinding {
                        code: String::new(),
                        number: n,
                        action: "left out",
                        reason: format!(
                            "the learned entry fails `schema check` ({}:{}): {msg}",
                            loc.file, loc.line
                        ),
                    });
                    progress = true;
                }
                Some(_) => {}
                None => unowned.push(format!("{}:{}: {msg}", loc.file, loc.line)),
            }
        }
        if !progress {
            break Err(format!(
                "the learned schema {id} fails `schema check` outside any learned code: {}",
                unowned.join("; ")
            ));
        }
    };
    let names: Vec<String> = learned
        .findings
        .iter()
        .map(|f| code_name(learned, base, f.number))
        .collect();
    for (f, name) in learned.findings.iter_mut().zip(names) {
        f.code = name;
    }
    result
}
