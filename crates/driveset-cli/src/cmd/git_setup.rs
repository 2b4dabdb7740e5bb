//! `driveset git-setup [--global]`: make `git diff` show semantic diffs of
//! set files. Writes `.gitattributes` lines (`parameter-sets/**/*.toml
//! diff=driveset`, `.yaml`, `.yml`) at the top of the work tree, keeping
//! what is there and adding only missing lines, and configures the diff
//! driver `diff.driveset.textconv = driveset textconv` in the repository's
//! config (or with `--global` in the user's, for every clone).
//!
//! Also the hidden `driveset textconv FILE` the driver runs (see
//! `driveset_report::textconv`).

use std::path::{Path, PathBuf};
use std::process::Command;

use driveset_report::driver::{self, Attributes, attribute_lines};
use driveset_report::textconv;

use crate::output;

/// Arguments of `driveset git-setup`.
#[derive(clap::Args)]
#[command(after_help = "\
Run once per clone (or once with --global). Afterwards `git diff`, `git log
-p` and `git show` print set files as one line per code with its name and
the value in engineering units:

  -C0011 maximum_output_frequency = 50 Hz
  +C0011 maximum_output_frequency = 60 Hz

The .gitattributes lines are meant to be committed; the driver itself is git
configuration, which git never takes from a repository: every clone (or
user, with --global) runs git-setup once. Without the driver git falls back
to the plain text diff.

Exit codes: 0 ok, 2 not in a git work tree (without --global) or git failed.

Examples:
  driveset git-setup
  driveset git-setup --global
  driveset git-setup --sets line-2/sets
  driveset git-setup --json-schemas .driveset/json-schema")]
pub struct Args {
    /// Configure the diff driver in the user's global git config instead of
    /// the repository's (`.gitattributes` is still written when run inside a
    /// work tree).
    #[arg(long)]
    pub global: bool,
    /// Folder of the set files, relative to the top of the work tree (repeatable).
    #[arg(long = "sets", value_name = "DIR", default_value = "parameter-sets")]
    pub sets: Vec<String>,
    /// Also write the JSON Schema of every schema the sets name into DIR
    /// (relative to the top of the work tree) and associate the sets with
    /// them for the editors: `.taplo.toml` (TOML) and
    /// `.vscode/settings.json` `yaml.schemas` (YAML); docs/editors.md.
    #[arg(long = "json-schemas", value_name = "DIR")]
    pub json_schemas: Option<String>,
    /// Command git runs as the textconv driver [default: `driveset textconv`
    /// when `driveset` is on PATH, else this binary's absolute path].
    #[arg(long, value_name = "CMD")]
    pub command: Option<String>,
}

/// Arguments of the hidden `driveset textconv`.
#[derive(clap::Args)]
pub struct TextconvArgs {
    /// Set file (git passes a temporary copy).
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Load every *.toml schema of DIR in addition to the built-in schemas (repeatable).
    #[arg(long = "schemas", value_name = "DIR")]
    pub schemas: Vec<PathBuf>,
}

/// Run the hidden `driveset textconv FILE`.
pub fn run_textconv(args: TextconvArgs) -> Result<u8, crate::fail::Fail> {
    let registry = match output::registry(&args.schemas) {
        Ok(r) => r,
        Err(e) => return Err(crate::fail::Fail::from(&e)),
    };
    match textconv::render(&args.file, &registry, crate::git::tracked_files) {
        Ok(text) => {
            output::emit(&text);
            Ok(crate::EXIT_OK)
        }
        Err(e) => Err(crate::fail::Fail::input(format!(
            "cannot read {}: {e}",
            args.file.display()
        ))),
    }
}

fn default_command() -> String {
    let on_path = std::env::var_os("PATH").is_some_and(|p| {
        std::env::split_paths(&p).any(|d| {
            let f = d.join("driveset");
            f.is_file()
        })
    });
    let exe = (!on_path).then(std::env::current_exe).and_then(Result::ok);
    driver::command(exe.as_ref().map(|e| e.to_string_lossy()).as_deref())
}

fn git(args: &[&str]) -> anyhow::Result<()> {
    let status = Command::new("git").args(args).status()?;
    anyhow::ensure!(status.success(), "`git {}` failed", args.join(" "));
    Ok(())
}

/// Run `driveset git-setup`.
pub fn run(args: Args) -> Result<u8, crate::fail::Fail> {
    let top = crate::git::output(Path::new("."), &["rev-parse", "--show-toplevel"])
        .map(|s| PathBuf::from(s.trim_end_matches('\n')));
    if top.is_none() && !args.global {
        return Err(crate::fail::Fail::input(
            "not inside a git work tree\n  = help: run it in your repository, or use --global to configure the driver for every repository",
        ));
    }
    let command = args.command.clone().unwrap_or_else(default_command);
    let scope = if args.global { "--global" } else { "--local" };
    if let Err(e) = git(&["config", scope, driver::TEXTCONV_KEY, &command]) {
        return Err(crate::fail::Fail::input(format!("{e}")));
    }
    outln!(
        "git config {scope} {} \"{}\"",
        driver::TEXTCONV_KEY,
        command.replace('"', "\\\"")
    );
    match top {
        Some(top) => {
            let path = top.join(".gitattributes");
            match driver::update_attributes(&path, &args.sets) {
                Err(e) => return Err(crate::fail::Fail::input(e.to_string())),
                Ok(Attributes::UpToDate) => outln!("{}: up to date", path.display()),
                Ok(Attributes::Written) => outln!(
                    "{}: set files use the driveset diff driver (commit this file)",
                    path.display()
                ),
            }
            if let Some(dir) = &args.json_schemas {
                let mut registry = crate::output::registry(&[])
                    .map_err(|e| crate::fail::Fail::input(e.message.clone()))?;
                let said = driveset_ide::associate::associate(&top, &args.sets, dir, &mut registry)
                    .map_err(crate::fail::Fail::input)?;
                for line in said {
                    outln!("{line}");
                }
            }
        }
        None if args.json_schemas.is_some() => {
            return Err(crate::fail::Fail::input(
                "--json-schemas needs a git work tree (the associations are written at its top)",
            ));
        }
        None => outln!(
            "not in a git work tree: add `{}` to each repository's .gitattributes",
            attribute_lines("parameter-sets")[0]
        ),
    }
    Ok(crate::EXIT_OK)
}
