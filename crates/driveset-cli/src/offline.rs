//! What the commands that read no drive share (`decode`, `encode`, `twin
//! from-capture`): the built-in schemas ([`builtin_registry`]), the schema
//! `--schema ID|PATH` names ([`load_schema`]) and the capture format of a
//! recorded session (`--protocol`, [`DecodeProtocol`]).

use std::sync::Arc;

use driveset_engine::decode::Capture;
use driveset_schema::{Registry, Schema};

/// Format of a capture (`--protocol`); [`DecodeProtocol::capture`] gives
/// the engine's [`Capture`], whose `bus()` is the descriptor's protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DecodeProtocol {
    /// LUSTBUS (Lust VF1000, MC6000/7000).
    Lustbus,
    /// LECOM-A/B (Lenze Tmd).
    Lecom,
    /// slcan (Lawicel) lines carrying CAN SDO frames (Lenze ECS).
    Slcan,
}

impl DecodeProtocol {
    /// The engine's capture format.
    pub fn capture(self) -> Capture {
        match self {
            DecodeProtocol::Lustbus => Capture::Lustbus,
            DecodeProtocol::Lecom => Capture::Lecom,
            DecodeProtocol::Slcan => Capture::Slcan,
        }
    }
}

/// Loads `--schema` (an id of `registry` or a file:
/// [`Registry::id_or_file`]).
pub fn load_schema(registry: &mut Registry, arg: &str) -> anyhow::Result<Arc<Schema>> {
    Ok(registry.id_or_file(arg)?)
}

/// The built-in schemas (the user commands' registry without `--schemas`).
pub fn builtin_registry() -> anyhow::Result<Registry> {
    crate::output::registry(&[])
        .map_err(|e| anyhow::anyhow!("built-in schemas: {}", e.render_human()))
}
