//! Owns learning within a session: a LUSTBUS schema that lacks facts is
//! learned from the drive's own descriptions ([`crate::learn::pull_schema`]:
//! identify, read the descriptions and MC texts, render and check), and the
//! learned schema file `<id>.toml` is written through the
//! [`crate::env::Environment`], the engine's one way to the file system
//! besides its journals (`lustbus-protocol.txt` §5.3, the parameter
//! descriptions; docs/file-formats.md, "Learned schemas").

use std::path::PathBuf;
use std::sync::Arc;

use driveset_link::ByteLink;
use driveset_schema::Schema;

use super::{LearnPolicy, SessionError};
use crate::client::{DriveClient, LustbusClient};
use crate::learn::{Learned, PullSchemaError, pull_schema};

/// What learning did, for reports.
#[derive(Debug, Clone)]
pub struct LearnedReport {
    /// The learned schema's id.
    pub id: String,
    /// The learned schema.
    pub schema: Arc<Schema>,
    /// The file written, if any.
    pub file: Option<PathBuf>,
    /// The base schema's id.
    pub base: String,
    /// Codes learned (in the file).
    pub codes: usize,
    /// What was read and how it was interpreted.
    pub learned: Learned,
}

/// Learn the schema of the drive `client` talks to, extending `base`
/// (which `client` speaks), with `policy`; `port` names the drive in the
/// file (`<port> address <a>`). Nothing but the RAM selector 108-STEXT is
/// written to the drive, and it is set back. The client goes on speaking
/// `base`: the caller connects again with the learned schema.
pub fn learn_on<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    port: &str,
    policy: &LearnPolicy<'_>,
) -> Result<LearnedReport, SessionError> {
    let address = client.target().address;
    let pulled = pull_schema(
        client,
        base,
        &policy.options,
        None,
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
    })?;
    let rendered = pulled.rendered;
    let id = rendered.id.clone();
    let file = match &policy.dir {
        Some(dir) => {
            policy.env.create_dir(dir).map_err(|e| SessionError::File {
                action: "create",
                path: dir.clone(),
                detail: e.to_string(),
            })?;
            let path = dir.join(format!("{id}.toml"));
            policy
                .env
                .write_file(&path, &rendered.text)
                .map_err(|e| SessionError::File {
                    action: "write",
                    path: path.clone(),
                    detail: e.to_string(),
                })?;
            Some(path)
        }
        None => None,
    };
    Ok(LearnedReport {
        id,
        schema: rendered.schema,
        file,
        base: base.id.clone(),
        codes: rendered.codes,
        learned: pulled.learned,
    })
}
