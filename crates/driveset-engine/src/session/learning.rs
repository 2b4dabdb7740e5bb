//! Owns learning within a session: a LUSTBUS schema that lacks facts is
//! learned from the drive's own descriptions (identify, read the
//! descriptions and MC texts: [`crate::learn::pull_descriptions`]; render
//! and check: [`crate::learn::PulledDescriptions::render`]), and the
//! learned schema file `<id>.toml` is written through the
//! [`crate::env::Environment`], the engine's one way to the file system
//! besides its journals (`lustbus-protocol.txt` §5.3, the parameter
//! descriptions; docs/file-formats.md, "Learned schemas"). Two steps
//! ([`LearnStep`]): render (and write), or `status`'s read-only reuse of an
//! earlier learned file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_link::ByteLink;
use driveset_proto::lustbus::description::McTypeChars;
use driveset_schema::error::SourceFile;
use driveset_schema::{Family, Schema};

use super::{LearnPolicy, SessionError};
use crate::client::{DriveClient, LustbusClient};
use crate::env::Environment;
use crate::learn::{
    LearnOptions, Learned, PullSchemaError, PulledDescriptions, PulledSchema, pull_descriptions,
};

/// What learning did, for reports.
#[derive(Debug, Clone)]
pub struct LearnedReport {
    /// The learned schema's id (as the drive's descriptions give it:
    /// [`crate::learn::learned_id`]).
    pub id: String,
    /// The learned schema.
    pub schema: Arc<Schema>,
    /// The file written (or, [`LearnStep::ReuseEarlier`], used), if any.
    pub file: Option<PathBuf>,
    /// The base schema's id.
    pub base: String,
    /// Codes learned (in the file).
    pub codes: usize,
    /// What was read and how it was interpreted.
    pub learned: Learned,
}

impl LearnedReport {
    /// What [`LearnSummary::lines`] and [`LearnSummary::doc`] render of it.
    pub fn summary(&self) -> LearnSummary {
        LearnSummary {
            id: self.id.clone(),
            file: self.file.clone(),
            base: self.base.clone(),
            codes: self.codes,
            learned: self.learned.clone(),
        }
    }

    /// [`LearnSummary::lines`] of this report.
    pub fn lines(&self) -> Vec<String> {
        self.summary().lines()
    }

    /// [`LearnSummary::doc`] of this report.
    pub fn doc(&self) -> LearnDoc<'_> {
        LearnDoc::of(
            &self.id,
            self.file.as_deref(),
            &self.base,
            self.codes,
            &self.learned,
        )
    }
}

/// What learning did, as reports show it (a session's learning, or
/// `schema pull`'s file).
#[derive(Debug, Clone)]
pub struct LearnSummary {
    /// The learned schema's id.
    pub id: String,
    /// The file written, if any.
    pub file: Option<PathBuf>,
    /// The base schema's id.
    pub base: String,
    /// Codes learned (in the file).
    pub codes: usize,
    /// What was read and how it was interpreted.
    pub learned: Learned,
}

impl LearnSummary {
    /// One line per finding, for stderr / human output: what was learned
    /// (codes, the file, the description layout and type characters),
    /// then each place the drive disagrees with the base schema.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        let layouts: Vec<&str> = self.learned.layouts.iter().map(|l| l.name()).collect();
        out.push(format!(
            "learned schema {} from the drive's descriptions: {} codes{}{}{}",
            self.id,
            self.codes,
            self.file
                .as_ref()
                .map_or_else(String::new, |f| format!(", written to {}", f.display())),
            if layouts.is_empty() {
                String::new()
            } else {
                format!(", description layout {}", layouts.join("/"))
            },
            self.learned
                .type_chars
                .as_ref()
                .map_or_else(String::new, |t| format!(
                    ", type characters {}{}",
                    t.name(),
                    if self.learned.type_chars_guessed {
                        " (guessed)"
                    } else {
                        ""
                    }
                ))
        ));
        for f in &self.learned.findings {
            if f.action == crate::learn::KEPT_SPEC {
                // the reason names the code, both facts and the spec
                out.push(f.reason.clone());
            } else {
                out.push(format!("{}: {}: {}", f.code, f.action, f.reason));
            }
        }
        out
    }

    /// The report as the commands' `--format json` carries it.
    pub fn doc(&self) -> LearnDoc<'_> {
        LearnDoc::of(
            &self.id,
            self.file.as_deref(),
            &self.base,
            self.codes,
            &self.learned,
        )
    }
}

/// What learning did as the commands' `--format json` carries it
/// ([`LearnSummary::doc`], [`LearnedReport::doc`]); `schema pull`'s report
/// names the drive too ([`LearnDoc::at`]). The fields are in the
/// alphabetical order of their keys, as the JSON documents of the CLI have
/// always had them (serde_json sorts a `json!` object's keys), and so are
/// [`crate::learn::LearnFinding`]'s.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LearnDoc<'a> {
    /// Parameters the drive NAKed.
    pub absent: usize,
    /// `schema pull`: the drive's address.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub address: Option<u8>,
    /// Parameters asked for.
    pub asked: usize,
    /// The base schema's id.
    pub base: &'a str,
    /// Codes learned.
    pub codes: usize,
    /// `schema pull`: the drive's family.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub family: Option<&'static str>,
    /// The file written, if any.
    pub file: Option<String>,
    /// Parameters left out or downgraded, and why.
    pub findings: &'a [crate::learn::LearnFinding],
    /// The learned schema's id.
    pub id: &'a str,
    /// MC: the description layouts met.
    pub layouts: Vec<&'static str>,
    /// `schema pull`: the port.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub port: Option<&'a str>,
    /// Substitution texts read.
    pub substitution_texts: usize,
    /// MC: the type-character reading used.
    pub type_chars: Option<String>,
    /// MC: whether that reading was guessed.
    pub type_chars_guessed: bool,
}

impl<'a> LearnDoc<'a> {
    fn of(
        id: &'a str,
        file: Option<&Path>,
        base: &'a str,
        codes: usize,
        learned: &'a Learned,
    ) -> Self {
        LearnDoc {
            absent: learned.absent,
            address: None,
            asked: learned.asked,
            base,
            codes,
            family: None,
            file: file.map(|f| f.display().to_string()),
            findings: &learned.findings,
            id,
            layouts: learned.layouts.iter().map(|l| l.name()).collect(),
            port: None,
            substitution_texts: learned.texts_read,
            type_chars: learned.type_chars.as_ref().map(McTypeChars::name),
            type_chars_guessed: learned.type_chars_guessed,
        }
    }

    /// The document naming the drive it was learned from (`schema pull`).
    pub fn at(self, port: &'a str, address: u8, family: Family) -> Self {
        LearnDoc {
            port: Some(port),
            address: Some(address),
            family: Some(family.name()),
            ..self
        }
    }
}

/// Which learning a session does ([`LearnPolicy::step`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LearnStep {
    /// Read the descriptions (and the MC texts unless
    /// [`LearnOptions::no_texts`]), render the schema, and write it to
    /// `<dir>/<id>.toml` when [`LearnPolicy::dir`] is given: the one-drive
    /// commands and `commission`.
    #[default]
    Render,
    /// `status`'s read-only learning: the descriptions only (no texts:
    /// reading them selects them through 108-STEXT), then the file an
    /// earlier run wrote to `<dir>/<id>.toml` for these very descriptions
    /// (the id holds their hash), used as it is (not rendered), when there
    /// is one; else the schema rendered. Nothing is written.
    ReuseEarlier,
}

/// Learn the schema of the drive `client` talks to, extending `base`
/// (which `client` speaks), with `policy` and its step ([`LearnStep`]);
/// `port` names the drive in the file (`<port> address <a>`). Nothing but
/// the RAM selector 108-STEXT is written to the drive, and it is set back.
/// The client goes on speaking `base`: the caller connects again with the
/// learned schema.
pub fn learn_on<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    port: &str,
    policy: &LearnPolicy<'_>,
) -> Result<LearnedReport, SessionError> {
    match policy.step {
        LearnStep::Render => render_on(client, base, port, policy),
        LearnStep::ReuseEarlier => reuse_on(client, base, port, policy),
    }
}

/// [`LearnStep::Render`].
fn render_on<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    port: &str,
    policy: &LearnPolicy<'_>,
) -> Result<LearnedReport, SessionError> {
    let address = client.target().address;
    let read = pull_descriptions(client, base, &policy.options)?;
    let id = read.id(base);
    let pulled = render(read, base, &id, port, address, policy)?;
    let file = match &policy.dir {
        Some(dir) => Some(write(policy.env, dir, &id, &pulled.rendered.text)?),
        None => None,
    };
    Ok(rendered_report(pulled, base, file))
}

/// [`LearnStep::ReuseEarlier`].
fn reuse_on<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    port: &str,
    policy: &LearnPolicy<'_>,
) -> Result<LearnedReport, SessionError> {
    let address = client.target().address;
    let options = LearnOptions {
        no_texts: true,
        ..policy.options.clone()
    };
    let read = pull_descriptions(client, base, &options)?;
    let id = read.id(base);
    if let Some(dir) = &policy.dir {
        let path = dir.join(format!("{id}.toml"));
        if let Some(schema) = earlier(policy, &path)? {
            return Ok(LearnedReport {
                id,
                schema,
                file: Some(path),
                base: base.id.clone(),
                codes: read.learned.codes.len(),
                learned: read.learned,
            });
        }
    }
    let pulled = render(read, base, &id, port, address, policy)?;
    Ok(rendered_report(pulled, base, None))
}

/// The schema rendered from what was read ([`PulledDescriptions::render`]).
fn render(
    read: PulledDescriptions,
    base: &Schema,
    id: &str,
    port: &str,
    address: u8,
    policy: &LearnPolicy<'_>,
) -> Result<PulledSchema, SessionError> {
    read.render(
        base,
        id,
        format!("{port} address {address}"),
        policy.registry,
    )
    .map_err(|e| match e {
        PullSchemaError::Engine(e) => SessionError::Engine(e),
        PullSchemaError::Render(detail) => SessionError::Render {
            port: port.to_string(),
            address,
            detail,
        },
    })
}

/// The report of a rendered schema, its file `file` if written.
fn rendered_report(pulled: PulledSchema, base: &Schema, file: Option<PathBuf>) -> LearnedReport {
    let rendered = pulled.rendered;
    LearnedReport {
        id: rendered.id,
        schema: rendered.schema,
        file,
        base: base.id.clone(),
        codes: rendered.codes,
        learned: pulled.learned,
    }
}

/// `text` written to `<dir>/<id>.toml` through `env` (the directory
/// created first); the path.
fn write(env: &dyn Environment, dir: &Path, id: &str, text: &str) -> Result<PathBuf, SessionError> {
    env.create_dir(dir).map_err(|e| SessionError::File {
        action: "create",
        path: dir.to_path_buf(),
        detail: e.to_string(),
    })?;
    let path = dir.join(format!("{id}.toml"));
    env.write_file(&path, text)
        .map_err(|e| SessionError::File {
            action: "write",
            path: path.clone(),
            detail: e.to_string(),
        })?;
    Ok(path)
}

/// The learned schema in the file at `path` an earlier run wrote, if there
/// is one, loaded against (a copy of) the policy's registry.
fn earlier(policy: &LearnPolicy<'_>, path: &Path) -> Result<Option<Arc<Schema>>, SessionError> {
    let text = policy.env.read_file(path).map_err(|e| SessionError::File {
        action: "read",
        path: path.to_path_buf(),
        detail: e.to_string(),
    })?;
    let Some(text) = text else {
        return Ok(None);
    };
    let mut registry = policy.registry.clone();
    registry
        .add_source(SourceFile::new(path.display().to_string(), text))
        .map(Some)
        .map_err(|e| SessionError::Earlier {
            path: path.to_path_buf(),
            detail: e.message,
        })
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, BTreeSet};

    use driveset_proto::lustbus::description::McLayout;

    use super::*;
    use crate::learn::{KEPT_SPEC, LearnFinding};

    fn summary(file: Option<&str>) -> LearnSummary {
        let finding = |code: &str, number, action, reason: &str| LearnFinding {
            action,
            code: code.into(),
            number,
            reason: reason.into(),
        };
        LearnSummary {
            id: "learned-mc6000-type6000-x".into(),
            file: file.map(PathBuf::from),
            base: "lust-mc6000".into(),
            codes: 3,
            learned: Learned {
                protocol: Family::Mc6000,
                layouts: BTreeSet::from([McLayout::Table43, McLayout::Hex52]),
                type_chars: Some(McTypeChars::Table),
                type_chars_guessed: true,
                codes: Vec::new(),
                findings: vec![
                    finding("11-STAT", 11, "left out", "no \"description\""),
                    finding("428-X", 428, KEPT_SPEC, "the spec's"),
                ],
                asked: 999,
                asked_params: BTreeSet::new(),
                absent: 990,
                texts_read: 4,
                descriptions_hash: 0,
                raw: Vec::new(),
                raw_texts: BTreeMap::new(),
            },
        }
    }

    fn pretty(doc: &impl serde::Serialize) -> String {
        serde_json::to_string_pretty(doc).expect("serializes")
    }

    /// The `json!` document `LearnSummary::json` built before `LearnDoc`
    /// (serde_json sorting its keys), and `schema pull`'s three keys added
    /// to its `Value`: the derived documents give the same bytes.
    #[test]
    fn the_document_is_the_bytes_the_json_value_gave() {
        let old = |s: &LearnSummary| {
            serde_json::json!({
                "id": s.id,
                "file": s.file.as_ref().map(|f| f.display().to_string()),
                "base": s.base,
                "codes": s.codes,
                "layouts": s.learned.layouts.iter().map(|l| l.name()).collect::<Vec<_>>(),
                "type_chars": s.learned.type_chars.as_ref().map(McTypeChars::name),
                "type_chars_guessed": s.learned.type_chars_guessed,
                "asked": s.learned.asked,
                "absent": s.learned.absent,
                "substitution_texts": s.learned.texts_read,
                "findings": s.learned.findings,
            })
        };
        for s in [summary(Some("dir/learned.toml")), summary(None)] {
            assert_eq!(pretty(&s.doc()), pretty(&old(&s)));
            let mut pulled = old(&s);
            pulled["port"] = serde_json::Value::from("sim:mc6000");
            pulled["address"] = serde_json::Value::from(1u8);
            pulled["family"] = serde_json::Value::from(Family::Mc6000.name());
            assert_eq!(
                pretty(&s.doc().at("sim:mc6000", 1, Family::Mc6000)),
                pretty(&pulled)
            );
        }
    }
}
