//! Owns `schema pull`'s one call: identify the drive, learn, end the
//! exchange, and render the learned schema.

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

/// `schema pull` and the learning commands: identify the drive, read and
/// interpret its descriptions (and MC texts) with `opts`, end the
/// exchange, and render the schema extending `base` with `id` (default:
/// [`learned_id`]); `drive` names it in the file (`<port> address <a>`).
/// `registry` must hold `base`. Nothing but the RAM selector 108-STEXT is
/// written, and it is set back.
pub fn pull_schema<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    opts: &LearnOptions,
    id: Option<&str>,
    drive: String,
    registry: &Registry,
) -> Result<PulledSchema, PullSchemaError> {
    let identity = client.identify()?;
    let mut learned = learn(client, base.family, &options_for(base, opts))?;
    client.finish()?;
    let id = id.map_or_else(
        || learned_id(base.family, &identity, &learned),
        str::to_string,
    );
    let source = LearnSource {
        drive,
        identity: identity.clone(),
    };
    let rendered = render_schema(&mut learned, base, &id, &source, registry)
        .map_err(PullSchemaError::Render)?;
    Ok(PulledSchema {
        identity,
        learned,
        rendered,
    })
}
