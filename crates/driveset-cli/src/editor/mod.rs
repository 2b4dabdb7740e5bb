//! Editor support (docs/editors.md): what an editor shows about a code
//! (`facts`), the JSON Schema of a schema's set files for the editors'
//! TOML and YAML servers (`json_schema`), and the `driveset lsp` language
//! server (`lsp`).

pub mod associate;
pub mod facts;
pub mod json_schema;
pub mod lsp;
