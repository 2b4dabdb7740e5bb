//! `driveset completions SHELL` and `driveset man`: shell completion
//! scripts (clap_complete) and the roff man page (clap_mangen), generated
//! from the same clap definitions the commands parse with, so they never
//! drift from `--help`.

use clap::CommandFactory;

use crate::EXIT_OK;

/// Arguments of `driveset completions`.
#[derive(clap::Args)]
#[command(after_help = "\
Examples:
  driveset completions bash > /etc/bash_completion.d/driveset
  driveset completions zsh > \"${fpath[1]}/_driveset\"
  driveset completions fish > ~/.config/fish/completions/driveset.fish")]
pub struct Args {
    /// The shell to write completions for.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// Arguments of `driveset man`.
#[derive(clap::Args)]
#[command(after_help = "\
Examples:
  driveset man > driveset.1 && man ./driveset.1")]
pub struct ManArgs {}

/// Write the completion script on stdout.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let mut cmd = crate::Cli::command();
    let mut buf = Vec::new();
    clap_complete::generate(args.shell, &mut cmd, "driveset", &mut buf);
    crate::output::emit(&String::from_utf8_lossy(&buf));
    Ok(EXIT_OK)
}

/// Write the man page (roff) on stdout.
pub fn run_man(_args: ManArgs) -> Result<u8, crate::fail::Fail> {
    let cmd = crate::Cli::command();
    let mut buf = Vec::new();
    if let Err(e) = clap_mangen::Man::new(cmd).render(&mut buf) {
        return Err(crate::fail::Fail::input(format!(
            "cannot render the man page: {e}"
        )));
    }
    crate::output::emit(&String::from_utf8_lossy(&buf));
    Ok(EXIT_OK)
}
