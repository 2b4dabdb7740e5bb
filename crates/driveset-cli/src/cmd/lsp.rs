//! `driveset lsp`: the language server of set files and line manifests
//! over stdio (`editor::lsp`; editor set-up in docs/editors.md).

use std::path::PathBuf;

/// Arguments of `driveset lsp`.
#[derive(clap::Args)]
#[command(after_help = "\
Speaks the Language Server Protocol on stdin / stdout; an editor starts it
(VS Code, Neovim, Helix: docs/editors.md). Diagnostics are the findings of
`driveset validate` for the open file, after every change; hover shows a
code's facts, completion offers code keys and selection texts, go to
definition opens the code's entry in its schema file, and code actions fix
the findings that have a mechanical fix.

Exit codes: 0 after the client's shutdown and exit, 2 a protocol error.")]
pub struct Args {
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
    /// Accepted for editors that pass it (the server always speaks on stdio).
    #[arg(long, hide = true)]
    pub stdio: bool,
}

/// Run `driveset lsp`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    crate::editor::lsp::serve(crate::editor::lsp::Config {
        schemas: args.schemas,
        cache_dir: None,
    })?;
    Ok(crate::EXIT_OK)
}
