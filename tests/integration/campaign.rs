//! A campaign that keeps looking (issue 29): every command that takes a
//! file argument or writes a file ([`COMMANDS`], one table: a new command
//! joins by being listed) against every kind of file that is not a good
//! regular file ([`InputKind`] for inputs, [`OutputKind`] for outputs):
//! exit 2, no bus ever taken (the test's lock directory stays empty: the
//! refusal comes before the port is opened), and nothing at the path
//! replaced (a FIFO stays a FIFO, a symlink a symlink, a directory keeps
//! its entries), and the message names the file. Each run has a watchdog that kills the child: a hang fails
//! the test (the watchdog is a hang guard, not a speed assertion).
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::time::Duration;

use driveset_test_support::{driveset, mkfifo, workspace_root};

/// Kills a run that hangs (a blocking open of a FIFO, a read of
/// `/dev/zero`); generous for a loaded machine.
const WATCHDOG: Duration = Duration::from_secs(20);

/// How a command is given the file under test: `{F}` in its arguments is
/// the file, `{P}` a `sim://` port of one drive at address 1.
struct Command {
    /// The command as the table shows it.
    name: &'static str,
    args: &'static [&'static str],
    role: Role,
    /// Kinds that are good input for this command, and why (a directory
    /// of sets; a capture or data sheet cut short is still one).
    fine: &'static [(InputKind, &'static str)],
}

/// `validate` and `schema check` walk a directory.
const DIRS: &[(InputKind, &str)] = &[(InputKind::Directory, "a directory of files is walked")];
/// A capture cut short is a capture (its last telegram shown incomplete);
/// an EDS has no end marker (a shorter data sheet is imported, linted).
const CUT: &[(InputKind, &str)] = &[(
    InputKind::Truncated,
    "a file cut short is still one of its kind",
)];

#[derive(Clone, Copy)]
enum Role {
    /// `{F}` is read; the good file of this kind is the workspace file
    /// named (truncated and binary kinds are cut from it).
    Input(&'static str),
    /// `{F}` is written.
    Output,
}

const SET: &str = "parameter-sets/tmd/conveyor-3.toml";
const P: &str = "sim://tmd?addresses=1";

/// Every command that reads or writes a file argument.
#[rustfmt::skip]
const COMMANDS: &[Command] = &[
    Command { name: "validate", args: &["validate", "{F}"], role: Role::Input(SET), fine: DIRS },
    Command { name: "fingerprint", args: &["fingerprint", "{F}"], role: Role::Input(SET), fine: &[] },
    Command { name: "show", args: &["show", "{F}"], role: Role::Input(SET), fine: &[] },
    Command { name: "diff", args: &["diff", "{F}", SET], role: Role::Input(SET), fine: &[] },
    Command { name: "schema check", args: &["schema", "check", "{F}"], role: Role::Input("schemas/lenze-tmd.toml"), fine: DIRS },
    Command { name: "schema import", args: &["schema", "import", "{F}"], role: Role::Input("tests/data/eds/fictional-ecs-axis.eds"), fine: CUT },
    Command { name: "schema json-schema", args: &["schema", "json-schema", "{F}"], role: Role::Input("schemas/lenze-tmd.toml"), fine: &[] },
    Command { name: "decode", args: &["decode", "--protocol", "lustbus", "--family", "mc6000", "{F}"], role: Role::Input("tests/data/captures/mc6000-eeprom-busy.hex"), fine: CUT },
    Command { name: "twin from-capture", args: &["twin", "from-capture", "--protocol", "lustbus", "--schema", "lust-mc6000", "{F}", "-o", "out"], role: Role::Input("tests/data/captures/mc6000-eeprom-busy.hex"), fine: CUT },
    Command { name: "upload", args: &["upload", "{F}", "--port", P, "--address", "1"], role: Role::Input(SET), fine: &[] },
    Command { name: "commission", args: &["commission", "{F}"], role: Role::Input("parameter-sets/demo-line/line.toml"), fine: &[] },
    Command { name: "status", args: &["status", "{F}"], role: Role::Input("parameter-sets/demo-line/line.toml"), fine: &[] },
    Command { name: "twin capture-line", args: &["twin", "capture-line", "{F}", "-o", "out"], role: Role::Input("parameter-sets/demo-line/line.toml"), fine: &[] },
    Command { name: "recover", args: &["recover", "{F}"], role: Role::Input("crates/driveset-engine/tests/data/journals/v1-upload.journal.json"), fine: &[] },
    Command { name: "sim --twin", args: &["sim", "--twin", "{F}"], role: Role::Input("examples/ci/twins/conveyor-5.twin.toml"), fine: &[] },
    Command { name: "pull --port sim://twin?file=", args: &["pull", "--port", "sim://twin?file={F}", "--address", "5", "-o", "x.toml"], role: Role::Input("examples/ci/twins/conveyor-5.twin.toml"), fine: &[] },
    Command { name: "pull -o", args: &["pull", "--port", P, "--address", "1", "-o", "{F}"], role: Role::Output, fine: &[] },
    Command { name: "schema pull -o", args: &["schema", "pull", "--port", "sim://mc6000?addresses=1", "--address", "1", "-o", "{F}"], role: Role::Output, fine: &[] },
    Command { name: "schema import -o", args: &["schema", "import", "tests/data/eds/fictional-ecs-axis.eds", "-o", "{F}"], role: Role::Output, fine: &[] },
    Command { name: "schema json-schema -o", args: &["schema", "json-schema", "lenze-tmd", "-o", "{F}"], role: Role::Output, fine: &[] },
    Command { name: "twin capture -o", args: &["twin", "capture", "--port", P, "--address", "1", "-o", "{F}"], role: Role::Output, fine: &[] },
    Command { name: "upload --journal", args: &["upload", SET, "--port", P, "--address", "1", "--journal", "{F}"], role: Role::Output, fine: &[] },
    Command { name: "sim --log", args: &["sim", "--family", "tmd", "--address", "1", "--log", "{F}"], role: Role::Output, fine: &[] },
];

/// Kinds of bad input file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum InputKind {
    Fifo,
    DevZeroLink,
    Directory,
    SymlinkLoop,
    Oversize,
    Truncated,
    Binary,
}

const INPUT_KINDS: [InputKind; 7] = [
    InputKind::Fifo,
    InputKind::DevZeroLink,
    InputKind::Directory,
    InputKind::SymlinkLoop,
    InputKind::Oversize,
    InputKind::Truncated,
    InputKind::Binary,
];

/// Kinds of output target that exist and are no regular file.
const OUTPUT_KINDS: [InputKind; 4] = [
    InputKind::Fifo,
    InputKind::DevZeroLink,
    InputKind::Directory,
    InputKind::SymlinkLoop,
];

/// Makes `kind` at `dir/NAME` (cut from `good` for the truncated and
/// binary kinds); the path.
fn make(dir: &Path, kind: InputKind, good: Option<&str>) -> PathBuf {
    let ext = good
        .and_then(|g| g.rsplit_once('.'))
        .map_or("toml", |(_, e)| e);
    let name = match good {
        Some(g) if g.ends_with(".twin.toml") => "f.twin.toml".to_string(),
        Some(g) if g.ends_with(".journal.json") => "f.journal.json".to_string(),
        _ => format!("f.{ext}"),
    };
    let p = dir.join(name);
    match kind {
        InputKind::Fifo => mkfifo(&p),
        InputKind::DevZeroLink => std::os::unix::fs::symlink("/dev/zero", &p).unwrap(),
        InputKind::Directory => {
            std::fs::create_dir(&p).unwrap();
            std::fs::write(p.join("keep"), "x").unwrap();
        }
        InputKind::SymlinkLoop => {
            std::os::unix::fs::symlink("loop-b", &p).unwrap();
            std::os::unix::fs::symlink(p.file_name().unwrap(), dir.join("loop-b")).unwrap();
        }
        InputKind::Oversize => {
            // sparse: larger than every input cap (64 MiB for reports)
            std::fs::File::create(&p)
                .unwrap()
                .set_len(200 * 1024 * 1024)
                .unwrap();
        }
        InputKind::Truncated => {
            // cut a third of the way in, just after an `=` or `:` (a key
            // without its value), as a copy cut short is
            let bytes = std::fs::read(workspace_root().join(good.unwrap())).unwrap();
            let third = bytes.len() / 3;
            let cut = bytes[third..]
                .iter()
                .position(|&b| b == b'=' || b == b':')
                .map_or(third, |i| third + i + 1);
            std::fs::write(&p, &bytes[..cut]).unwrap();
        }
        InputKind::Binary => {
            let mut bytes = b"\x00\xff\xfe binary \x00\x80".to_vec();
            bytes.extend((0..4096u32).map(|i| (i * 7919 % 251) as u8));
            std::fs::write(&p, bytes).unwrap();
        }
    }
    p
}

/// What is at `p`, to compare before and after (type, link target,
/// directory entries, size).
fn fingerprint(p: &Path) -> String {
    let Ok(m) = std::fs::symlink_metadata(p) else {
        return "absent".into();
    };
    if m.file_type().is_symlink() {
        return format!("symlink to {}", std::fs::read_link(p).unwrap().display());
    }
    if m.is_dir() {
        let mut names: Vec<String> = std::fs::read_dir(p)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        return format!("dir {names:?}");
    }
    format!("{:?} {} bytes", m.file_type(), m.len())
}

/// Runs one command against one kind: the problems found.
fn run(cmd: &Command, kind: InputKind) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let good = match cmd.role {
        Role::Input(g) => Some(g),
        Role::Output => None,
    };
    let f = make(dir.path(), kind, good);
    let before = fingerprint(&f);
    let locks = dir.path().join("locks");
    let args: Vec<String> = cmd
        .args
        .iter()
        .map(|a| a.replace("{F}", &f.display().to_string()))
        .collect();
    let at = format!("{} x {kind:?}", cmd.name);
    let out = driveset()
        .current_dir(dir.path())
        // the good files the table names are from the workspace
        .env("DRIVESET_LOCK_DIR", &locks)
        .env("DRIVESET_SIM_STATE_DIR", dir.path().join("sim"))
        .args(args.iter().map(|a| {
            let p = workspace_root().join(a);
            if !a.starts_with('/') && !a.contains("://") && p.exists() && a.contains('/') {
                p.display().to_string()
            } else {
                a.clone()
            }
        }))
        .timeout(WATCHDOG)
        .output();
    let mut problems = Vec::new();
    match out {
        Err(e) => problems.push(format!("{at}: did not end within the watchdog: {e}")),
        Ok(o) => {
            let text = format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            );
            // the refusal names the file (an exit 2 for another reason,
            // a usage error, would pass unseen)
            let name = f.file_name().unwrap().to_string_lossy().into_owned();
            if o.status.code() == Some(2) && !text.contains(&name) {
                problems.push(format!("{at}: exit 2 without naming {name}: {text}"));
            }
            if o.status.code() != Some(2) {
                problems.push(format!(
                    "{at}: exit {:?}, not 2\n  stdout: {}\n  stderr: {}",
                    o.status.code(),
                    String::from_utf8_lossy(&o.stdout).trim_end(),
                    String::from_utf8_lossy(&o.stderr).trim_end()
                ));
            }
        }
    }
    let taken: Vec<_> = std::fs::read_dir(&locks)
        .map(|rd| rd.flatten().map(|e| e.file_name()).collect())
        .unwrap_or_default();
    if !taken.is_empty() {
        problems.push(format!("{at}: a bus lock was taken: {taken:?}"));
    }
    let after = fingerprint(&f);
    if after != before {
        problems.push(format!(
            "{at}: {} was replaced: {before} -> {after}",
            f.display()
        ));
    }
    problems
}

/// The table: every command x every kind that applies to its role.
#[test]
fn every_command_refuses_every_kind_of_bad_file_with_exit_2() {
    let mut problems = Vec::new();
    let mut table = String::from(
        "command | fifo | /dev/zero link | directory | symlink loop | oversize | truncated | binary\n",
    );
    for cmd in COMMANDS {
        let cells: Vec<&str> = INPUT_KINDS
            .iter()
            .map(|k| match cmd.role {
                _ if cmd.fine.iter().any(|(f, _)| f == k) => "good input",
                Role::Output if !OUTPUT_KINDS.contains(k) => "-",
                _ => "exit 2",
            })
            .collect();
        table.push_str(&format!("{} | {}\n", cmd.name, cells.join(" | ")));
    }
    println!("{table}");
    for cmd in COMMANDS {
        let kinds: &[InputKind] = match cmd.role {
            Role::Input(_) => &INPUT_KINDS,
            Role::Output => &OUTPUT_KINDS,
        };
        for &kind in kinds {
            if cmd.fine.iter().any(|(k, _)| *k == kind) {
                continue;
            }
            problems.extend(run(cmd, kind));
        }
    }
    assert!(
        problems.is_empty(),
        "{} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}
