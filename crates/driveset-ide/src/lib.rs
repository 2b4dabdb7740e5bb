//! The editor's analysis of driveset files (docs/editors.md), as plain data
//! in byte offsets and line / column positions: what rust-analyzer keeps in
//! its `ide` crate, apart from its server. The language server (`driveset
//! lsp`: the loop, LSP types) is the CLI's, its frames
//! `driveset-lsp-base`'s; it converts what this crate computes.
//!
//! - [`document`]: one document open in an editor (its text, its file,
//!   the schema its last analysis found) and what it answers at a
//!   position; [`text`]: its text, edited in place, positions in UTF-16
//!   code units to byte offsets and back;
//! - [`analysis`]: a document's diagnostics (the findings `driveset
//!   validate` gives the same file) and the mechanical fix a finding has;
//! - [`navigate`]: hover (a code's facts), go to a code's entry in its
//!   schema file, completion of keys, selection texts and schema ids;
//! - [`facts`]: what an editor shows about one code;
//! - [`json_schema`]: the JSON Schema of a schema's set files;
//! - [`associate`]: the JSON Schemas of a repository's sets and their
//!   association with the editors (`git-setup --json-schemas`).

pub mod analysis;
pub mod associate;
pub mod document;
pub mod facts;
pub mod json_schema;
pub mod navigate;
pub mod text;
