//! Owns `schema pull`'s one call and its two halves: reading a drive's
//! descriptions (identify, learn, end the exchange: [`pull_descriptions`])
//! and rendering the learned schema from them ([`PulledDescriptions::render`]);
//! a session's learning step that reuses an earlier learned file reads
//! without rendering (`session::learning`).

use driveset_link::ByteLink;
use driveset_schema::{Registry, Schema};

use super::LearnOptions;
use super::file::{LearnSource, LearnedSchema, learned_id, render_schema};
use super::model::Learned;
use super::read::learn;
use super::scope::options_for;
use crate::client::{DriveClient as _, Identity, LustbusClient};
use crate::error::EngineError;

/// A schema learned from one drive ([`pull_schema`]).
#[derive(Debug, Clone)]
pub struct PulledSchema {
    /// The drive's identity.
    pub identity: Identity,
    /// What was read and how it was interpreted.
    pub learned: Learned,
    /// The rendered, checked schema.
    pub rendered: LearnedSchema,
}

/// A drive's descriptions read, not yet rendered ([`pull_descriptions`]).
#[derive(Debug, Clone)]
pub struct PulledDescriptions {
    /// The drive's identity.
    pub identity: Identity,
    /// What was read and how it was interpreted.
    pub learned: Learned,
}

/// Why [`pull_schema`] failed.
#[derive(Debug, thiserror::Error)]
pub enum PullSchemaError {
    /// The bus or the drive failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The learned schema does not render into a file that checks.
    #[error("{0}")]
    Render(String),
}

/// Identify the drive, read and interpret its descriptions (and MC texts
/// unless `opts.no_texts`) with `opts` as [`options_for`] fits them to
/// `base`, and end the exchange. Nothing but the RAM selector 108-STEXT is
/// written, and it is set back.
pub fn pull_descriptions<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    opts: &LearnOptions,
) -> Result<PulledDescriptions, EngineError> {
    let identity = client.identify()?;
    let learned = learn(client, base.family, &options_for(base, opts))?;
    client.finish()?;
    Ok(PulledDescriptions { identity, learned })
}

impl PulledDescriptions {
    /// The learned schema's id for these descriptions ([`learned_id`]: the
    /// family, the drive's type and the descriptions' hash).
    pub fn id(&self, base: &Schema) -> String {
        learned_id(base.family, &self.identity, &self.learned)
    }

    /// The schema extending `base` with `id`, rendered and checked
    /// ([`render_schema`]); `drive` names it in the file (`<port> address
    /// <a>`). `registry` must hold `base`.
    pub fn render(
        self,
        base: &Schema,
        id: &str,
        drive: String,
        registry: &Registry,
    ) -> Result<PulledSchema, PullSchemaError> {
        let PulledDescriptions {
            identity,
            mut learned,
        } = self;
        let source = LearnSource {
            drive,
            identity: identity.clone(),
        };
        let rendered = render_schema(&mut learned, base, id, &source, registry)
            .map_err(PullSchemaError::Render)?;
        Ok(PulledSchema {
            identity,
            learned,
            rendered,
        })
    }
}

/// `schema pull` and the learning commands: [`pull_descriptions`], then
/// the schema extending `base` with `id` (default: [`learned_id`])
/// rendered ([`PulledDescriptions::render`]); `drive` names it in the file
/// (`<port> address <a>`). `registry` must hold `base`. Nothing but the
/// RAM selector 108-STEXT is written, and it is set back.
pub fn pull_schema<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    opts: &LearnOptions,
    id: Option<&str>,
    drive: String,
    registry: &Registry,
) -> Result<PulledSchema, PullSchemaError> {
    let pulled = pull_descriptions(client, base, opts)?;
    let id = id.map_or_else(|| pulled.id(base), str::to_string);
    pulled.render(base, &id, drive, registry)
}
