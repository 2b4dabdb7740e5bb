//! Editor support (docs/editors.md): the `driveset lsp` language server
//! (`lsp`) over the analysis of the `driveset-ide` crate (diagnostics,
//! hover, completion, definition, fixes, the JSON Schema of a schema's
//! sets, associations).

pub mod lsp;
