//! The CLI's commands never import each other (docs/architecture.md,
//! "Crates and their arrows"): what two commands share lives where it
//! belongs (the engine, a crate of its own, or the CLI's shared modules
//! beside `cmd/`), so each command module is parse, resolve, call, render.

use std::collections::BTreeMap;

use super::{report, sources_under};

const CMD: &str = "crates/driveset-cli/src/cmd/";

/// Command modules that still name another command, with how many lines
/// do (a count may only go down; never add an entry).
const COMMANDS_STILL_NAMING_COMMANDS: &[(&str, usize)] = &[];

/// The command a file under `cmd/` belongs to (`cmd/decode/input.rs`:
/// `decode`), and `None` for `cmd/mod.rs`, the dispatcher.
fn command_of(path: &str) -> Option<&str> {
    let rest = path.strip_prefix(CMD)?;
    let first = rest.split('/').next()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "mod").then_some(name)
}

/// The lines of code of `source` that name a command module other than
/// its own (`super::upload`, `crate::cmd::identify`).
fn naming_lines(own: Option<&str>, commands: &[&str], code: &[(usize, &str)]) -> Vec<usize> {
    let mut out = Vec::new();
    for &(n, line) in code {
        let names_one = commands.iter().filter(|c| Some(**c) != own).any(|c| {
            ["super::", "crate::cmd::", "cmd::"].iter().any(|p| {
                let needle = format!("{p}{c}");
                line.match_indices(&needle).any(|(at, m)| {
                    let after = line[at + m.len()..].chars().next();
                    let before = line[..at].chars().next_back();
                    !after.is_some_and(|ch| ch.is_alphanumeric() || ch == '_')
                        && !before.is_some_and(|ch| ch.is_alphanumeric() || ch == '_')
                })
            })
        });
        if names_one {
            out.push(n);
        }
    }
    out
}

#[test]
fn tidy_commands_never_import_each_other() {
    let sources: Vec<_> = sources_under("crates/driveset-cli/src/").collect();
    let mut commands: Vec<&str> = sources.iter().filter_map(|s| command_of(&s.path)).collect();
    commands.sort_unstable();
    commands.dedup();
    let mut found: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for source in &sources {
        let path = source.path.as_str();
        // the dispatchers name every command
        if path == "crates/driveset-cli/src/main.rs" || path == "crates/driveset-cli/src/cmd/mod.rs"
        {
            continue;
        }
        let code: Vec<(usize, &str)> = source.code().collect();
        let lines = naming_lines(command_of(path), &commands, &code);
        if !lines.is_empty() {
            found.insert(path, lines);
        }
    }
    let mut problems = Vec::new();
    for (path, lines) in &found {
        let allowed = COMMANDS_STILL_NAMING_COMMANDS
            .iter()
            .find(|(f, _)| f == path)
            .map_or(0, |(_, n)| *n);
        if lines.len() > allowed {
            problems.push(format!(
                "{path}:{}: names another command module ({} line(s), {allowed} allowed): move what the commands share where it belongs (the engine, its own crate, or a shared module of the CLI beside cmd/) and import it from there",
                lines[0],
                lines.len()
            ));
        } else if lines.len() < allowed {
            problems.push(format!(
                "{path}:1: {} line(s) name another command, COMMANDS_STILL_NAMING_COMMANDS (tests/integration/tidy/commands.rs) says {allowed}: lower its entry",
                lines.len()
            ));
        }
    }
    for (f, n) in COMMANDS_STILL_NAMING_COMMANDS {
        if !found.contains_key(f) {
            problems.push(format!(
                "{f}:1: listed in COMMANDS_STILL_NAMING_COMMANDS with {n} but names no other command any more: remove its entry"
            ));
        }
    }
    report("commands importing commands", &problems);
}

/// The reader: a `super::` or `crate::cmd::` path to another command is
/// found; the command's own, a longer name and `super::*` are not.
#[test]
fn tidy_the_command_reader_sees_an_import() {
    let code = [
        (1, "use super::identify::BusFormat;"),
        (2, "use crate::cmd::upload::DEFAULT_JOURNAL_DIR;"),
        (3, "use super::diff_live;"),
        (4, "use super::*;"),
        (5, "let x = super::diff::render(a);"),
        (6, "use super::identify_more::X;"),
    ];
    assert_eq!(
        naming_lines(
            Some("diff"),
            &["diff", "diff_live", "identify", "upload"],
            &code
        ),
        [1, 2, 3]
    );
    assert_eq!(
        command_of("crates/driveset-cli/src/cmd/decode/input.rs"),
        Some("decode")
    );
    assert_eq!(command_of("crates/driveset-cli/src/cmd/mod.rs"), None);
}
