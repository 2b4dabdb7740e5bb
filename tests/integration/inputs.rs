//! Inputs that must never hang or run away (issue 10, item 5): FIFOs and
//! device files, symlink loops in a directory walk, a 1 MB hex line, an
//! endless stdin, a closed stdout. Every command runs with a timeout in
//! the harness, so a regression fails instead of hanging the test run
//! (the timeout is a hang guard, not a speed assertion: the outcomes are
//! what the tests check).

use std::io::Read as _;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use driveset_test_support::{driveset, mkfifo};

/// Generous: only a hang reaches it.
const HANG_GUARD: Duration = Duration::from_secs(120);

const TMD_SET: &str = "schema = \"lenze-tmd\"\n[values]\nC0011 = \"60 Hz\"\n";

#[test]
fn a_fifo_as_set_file_is_an_input_error_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("set.toml");
    mkfifo(&fifo);
    let out = driveset()
        .current_dir(dir.path())
        .args(["validate", "set.toml"])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .get_output()
        .clone();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "error: set.toml is a FIFO (named pipe), not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only\n = note: in set.toml\n = help: give the path of a regular file (save a pipe's or device's data into a file first)\n\n0 findings in 0 of 1 file; 1 file could not be read\n"
    );
    // the same through the other readers of set files
    for args in [
        &["fingerprint", "set.toml"][..],
        &["show", "set.toml"][..],
        &["diff", "set.toml", "set.toml"][..],
    ] {
        let out = driveset()
            .current_dir(dir.path())
            .args(args)
            .timeout(HANG_GUARD)
            .assert()
            .code(2)
            .get_output()
            .clone();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            text.contains("set.toml is a FIFO (named pipe), not a regular file"),
            "{args:?}: {text}"
        );
    }
}

#[test]
fn a_fifo_named_by_extends_or_as_schema_path_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("base.toml"));
    mkfifo(&dir.path().join("schema.toml"));
    std::fs::write(
        dir.path().join("over.toml"),
        "schema = \"lenze-tmd\"\nextends = \"base.toml\"\n[values]\nC0011 = \"60 Hz\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("own.toml"),
        "schema = \"schema.toml\"\n[values]\nC0011 = \"60 Hz\"\n",
    )
    .unwrap();
    for (file, fifo) in [("over.toml", "base.toml"), ("own.toml", "schema.toml")] {
        let out = driveset()
            .current_dir(dir.path())
            .args(["validate", file])
            .timeout(HANG_GUARD)
            .assert()
            .code(2)
            .get_output()
            .clone();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.starts_with(&format!(
                "error: ./{fifo} is a FIFO (named pipe), not a regular file; "
            )) || text.starts_with(&format!(
                "error: {fifo} is a FIFO (named pipe), not a regular file; "
            )),
            "{file}: {text}"
        );
    }
}

#[test]
fn a_fifo_inside_a_directory_is_reported_and_the_rest_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.toml"), TMD_SET).unwrap();
    mkfifo(&dir.path().join("b.toml"));
    let out = driveset()
        .current_dir(dir.path())
        .args(["validate", "."])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .get_output()
        .clone();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "error: ./b.toml is a FIFO (named pipe), not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only\n = note: in ./b.toml\n = help: give the path of a regular file (save a pipe's or device's data into a file first)\n\n0 findings in 0 of 2 files; 1 file could not be read\n"
    );
    // a schema directory with a FIFO in it
    let out = driveset()
        .current_dir(dir.path())
        .args(["validate", "--schemas", ".", "a.toml"])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .get_output()
        .clone();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("b.toml is a FIFO (named pipe), not a regular file"),
        "{text}"
    );
}

#[test]
fn a_device_file_is_refused_by_name() {
    let out = driveset()
        .args(["validate", "/dev/null"])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .get_output()
        .clone();
    assert!(
        String::from_utf8_lossy(&out.stdout).starts_with(
            "error: /dev/null is a character device, not a regular file; driveset reads parameter sets, schemas and line manifests from regular files only\n"
        ),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn symlink_loops_and_links_back_to_a_parent_are_walked_once() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("sets");
    let sub = root.join("line/a/b");
    std::fs::create_dir_all(&sub).unwrap();
    std::fs::write(root.join("line/t.toml"), TMD_SET).unwrap();
    std::fs::write(sub.join("u.toml"), TMD_SET).unwrap();
    // a loop, two links back to the parents (exponential without a
    // visited set), and a second link to a file
    std::os::unix::fs::symlink("..", sub.join("up")).unwrap();
    std::os::unix::fs::symlink("../..", sub.join("up2")).unwrap();
    std::os::unix::fs::symlink(".", sub.join("self")).unwrap();
    std::os::unix::fs::symlink("../../..", root.join("line/a/top")).unwrap();
    std::os::unix::fs::symlink("u.toml", sub.join("u-again.toml")).unwrap();
    driveset()
        .current_dir(dir.path())
        .args(["validate", "sets"])
        .timeout(HANG_GUARD)
        .assert()
        .code(0)
        .stdout("0 findings in 0 of 2 files\n");
}

/// A 1 MB hex capture on one line: the hex parser is linear (the column of
/// an error was recomputed from the line start for every token before).
#[test]
fn decode_of_a_1_mb_hex_line() {
    let dir = tempfile::tempdir().unwrap();
    let telegram = "04 40 30 30 31 31 32 05";
    let n = 1_048_576 / (telegram.len() + 1) + 1;
    let line = vec![telegram; n].join(" ");
    assert!(line.len() >= 1_048_576);
    std::fs::write(dir.path().join("big.hex"), format!("{line}\n")).unwrap();
    let out = driveset()
        .current_dir(dir.path())
        .args(["decode", "--protocol", "lustbus", "big.hex"])
        .timeout(HANG_GUARD)
        .assert()
        .code(0)
        .get_output()
        .clone();
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), n);
    let last = (n - 1) * 8;
    assert_eq!(
        text.lines().last().unwrap(),
        format!(
            "{:<11} host -> drive   ENQUIRY   address 0 '@' (all devices), code 00112 (12-rotary_field_frequency)",
            format!("{last}..{}", last + 8)
        )
    );
}

#[test]
fn decode_raw_dev_zero_and_an_endless_stdin_are_capped() {
    driveset()
        .args(["decode", "--protocol", "lustbus", "--raw", "/dev/zero"])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            "error: /dev/zero is a character device, not a regular file; driveset reads bus captures from regular files only; give the path of a regular file (save a pipe's or device's data into a file first)\n",
        );
    let bin = driveset_test_support::driveset_bin();
    let zero = std::fs::File::open("/dev/zero").unwrap();
    let mut child = Command::new(bin)
        .args(["decode", "--protocol", "lustbus", "--raw", "-"])
        .stdin(Stdio::from(zero))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = String::new();
    let mut stderr = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(2));
    assert_eq!(stdout, "");
    assert_eq!(
        stderr,
        "error: <stdin>: the capture is larger than 16777216 bytes, the most `driveset decode` reads; split it (e.g. with `split -b`) and decode the parts\n"
    );
}

#[test]
fn a_capture_file_that_is_a_fifo_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("cap.hex"));
    driveset()
        .current_dir(dir.path())
        .args(["decode", "--protocol", "lecom", "cap.hex"])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            "error: cap.hex is a FIFO (named pipe), not a regular file; driveset reads bus captures from regular files only; give the path of a regular file (save a pipe's or device's data into a file first)\n",
        );
}

/// `driveset decode ... | head -c1`: the reader goes away after one byte;
/// the rest of the output is dropped, no panic, no message, exit 0.
#[test]
fn decode_into_a_closed_pipe_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    // a few MB of output: far more than a pipe buffer holds
    let line = vec!["04 40 30 30 31 31 32 05"; 20_000].join(" ");
    std::fs::write(dir.path().join("cap.hex"), format!("{line}\n")).unwrap();
    let bin = driveset_test_support::driveset_bin();
    let mut child = Command::new(bin)
        .current_dir(dir.path())
        .args(["decode", "--protocol", "lustbus", "cap.hex"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut one = [0u8; 1];
    let mut out = child.stdout.take().unwrap();
    out.read_exact(&mut one).unwrap();
    assert_eq!(&one, b"0");
    drop(out);
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    let status = child.wait().unwrap();
    assert_eq!(stderr, "");
    assert_eq!(status.code(), Some(0));
}

/// The same for a command whose output goes through the shared renderer
/// (validate of many files), via a real `| head -c1`.
#[test]
fn validate_and_show_into_head_end_quietly() {
    let dir = tempfile::tempdir().unwrap();
    for i in 0..400 {
        std::fs::write(
            dir.path().join(format!("s{i:03}.toml")),
            "schema = \"lenze-tmd\"\n[values]\nC0011 = \"999 Hz\"\n",
        )
        .unwrap();
    }
    std::fs::write(dir.path().join("ok.toml"), TMD_SET).unwrap();
    let bin = driveset_test_support::driveset_bin();
    for cmd in ["validate .", "show --to json ok.toml"] {
        let out = Command::new("bash")
            .current_dir(dir.path())
            .arg("-c")
            .arg(format!(
                "set -o pipefail; '{}' {cmd} | head -c1 >/dev/null; echo \"rc=${{PIPESTATUS[0]}}\"",
                bin.display()
            ))
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr, "", "{cmd}");
        // validate: 400 findings -> 1; show: 0
        let want = if cmd.starts_with("validate") {
            "rc=1\n"
        } else {
            "rc=0\n"
        };
        assert_eq!(stdout, want, "{cmd}");
    }
}

/// Stdout and stderr of a finished command, as text.
fn outputs(out: &std::process::Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `driveset ARGS` in `dir` under the hang guard, ending with `code`.
fn run_in<const N: usize>(dir: &Path, args: [&str; N], code: i32) -> std::process::Output {
    driveset()
        .current_dir(dir)
        .args(args)
        .timeout(HANG_GUARD)
        .assert()
        .code(code)
        .get_output()
        .clone()
}

const REFUSED_HELP: &str =
    "give the path of a regular file (save a pipe's or device's data into a file first)";

#[test]
fn schema_import_refuses_a_fifo_a_device_and_a_directory_at_once() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("axis.eds"));
    std::fs::create_dir(dir.path().join("adir.eds")).unwrap();
    for (file, is) in [
        ("axis.eds", "a FIFO (named pipe)"),
        ("/dev/zero", "a character device"),
        ("adir.eds", "a directory"),
    ] {
        let out = run_in(dir.path(), ["schema", "import", file], 2);
        let (stdout, stderr) = outputs(&out);
        assert_eq!(stdout, "", "{file}");
        assert_eq!(
            stderr,
            format!(
                "error: {file} is {is}, not a regular file; driveset reads EDS / DCF files from regular files only\n  = help: {REFUSED_HELP}\n"
            ),
            "{file}"
        );
    }
}

#[test]
fn an_eds_or_journal_over_its_cap_is_refused_from_its_size_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    // sparse files: 300 MB of EDS and 17 MiB of journal cost no disk
    let eds = dir.path().join("big.eds");
    std::fs::File::create(&eds)
        .unwrap()
        .set_len(300_000_000)
        .unwrap();
    let journal = dir.path().join("big.journal.json");
    std::fs::File::create(&journal)
        .unwrap()
        .set_len(17 * 1024 * 1024)
        .unwrap();
    let out = run_in(dir.path(), ["schema", "import", "big.eds"], 2);
    assert_eq!(
        outputs(&out).1,
        "error: big.eds is larger than 16777216 bytes\n  = help: EDS / DCF files are at most 16777216 bytes; check that this is the right file\n"
    );
    let out = run_in(dir.path(), ["recover", "big.journal.json"], 2);
    assert_eq!(
        outputs(&out).1,
        "error: journal big.journal.json: is larger than 16777216 bytes; journals are at most 16777216 bytes; check that this is the right file\n"
    );
}

#[test]
fn recover_refuses_a_fifo_dev_zero_and_a_directory_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("j.json"));
    for (file, is) in [
        ("j.json", "a FIFO (named pipe)"),
        ("/dev/zero", "a character device"),
        (".", "a directory"),
    ] {
        let out = run_in(dir.path(), ["recover", file], 2);
        assert_eq!(
            outputs(&out).1,
            format!(
                "error: journal {file}: is {is}, not a regular file; driveset reads journals from regular files only; {REFUSED_HELP}\n"
            ),
            "{file}"
        );
    }
}

#[test]
fn upload_with_a_fifo_as_journal_is_refused_before_the_port_is_opened() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("j.json"));
    std::fs::write(dir.path().join("set.toml"), TMD_SET).unwrap();
    let out = driveset()
        .current_dir(dir.path())
        .args([
            "upload",
            "set.toml",
            "--port",
            "sim://tmd?c0001=3&state=drive.json",
            "--address",
            "1",
            "--journal",
            "j.json",
        ])
        .timeout(HANG_GUARD)
        .assert()
        .code(2)
        .get_output()
        .clone();
    assert_eq!(
        outputs(&out).1,
        format!(
            "error: --journal j.json: is a FIFO (named pipe), not a regular file; driveset reads journals from regular files only; {REFUSED_HELP}\n"
        )
    );
    // the simulated bus was never opened: no state file, no byte sent
    assert!(!dir.path().join("drive.json").exists());
}

#[test]
fn a_failed_write_to_stdout_exits_2_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("set.toml"), TMD_SET).unwrap();
    for args in [
        &["show", "set.toml"][..],
        &["validate", "set.toml"][..],
        &["fingerprint", "set.toml"][..],
        &[
            "decode",
            "--protocol",
            "lecom",
            "--ascii",
            "<EOT>01<STX>11600<ETX>6",
        ][..],
    ] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .expect("/dev/full");
        let out = Command::new(driveset_test_support::driveset_bin())
            .current_dir(dir.path())
            .args(args)
            .stdout(full)
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            "error: cannot write to stdout: No space left on device (os error 28); the output is incomplete\n",
            "{args:?}"
        );
    }
}

#[test]
fn show_into_head_exits_quietly_with_its_own_code() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("set.toml"), TMD_SET).unwrap();
    let mut child = Command::new(driveset_test_support::driveset_bin())
        .current_dir(dir.path())
        .args(["show", "--to", "yaml", "set.toml"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // read one byte, then close the pipe (as `head -c1` does)
    let mut stdout = child.stdout.take().unwrap();
    let mut one = [0u8; 1];
    stdout.read_exact(&mut one).unwrap();
    drop(stdout);
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(String::from_utf8_lossy(&out.stderr), "");
}

#[test]
fn control_characters_in_keys_never_reach_the_terminal_raw() {
    let dir = tempfile::tempdir().unwrap();
    // a key holding ESC [ 2 J (clear screen) and a newline (a forged line)
    std::fs::write(
        dir.path().join("set.toml"),
        "schema = \"lenze-tmd\"\n[values]\n\"C\\u001b[2J11\\nerror: forged\" = \"60 Hz\"\n",
    )
    .unwrap();
    let run = |format: &str| {
        let out = run_in(dir.path(), ["validate", "--format", format, "set.toml"], 1);
        assert!(
            !out.stdout.contains(&0x1B),
            "{format}: raw ESC in {}",
            String::from_utf8_lossy(&out.stdout)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    assert_eq!(
        run("human"),
        "error[unknown-code]: `C\\u{1b}[2J11\\nerror: forged` is not a code name of lenze-tmd\n --> set.toml:3:1\n  |\n3 | \"C\\u001b[2J11\\nerror: forged\" = \"60 Hz\"\n  | ^^^^^^^^^^^^^^^^^^^^^^^^^^^^^ here\n  |\n  = help: use a code number or a name from the schema (schemas/lenze-tmd.toml)\n\n1 finding in 1 of 1 file\n"
    );
    assert_eq!(
        run("github"),
        "::error file=set.toml,line=3,col=1,title=unknown-code::`C\\u{1b}[2J11\\nerror: forged` is not a code name of lenze-tmd%0Ahelp: use a code number or a name from the schema (schemas/lenze-tmd.toml)\n1 finding in 1 of 1 file\n"
    );
    assert!(run("junit").contains("`C\\u{1b}[2J11\\nerror: forged` is not a code name"));
    assert!(!run("human").lines().any(|l| l.starts_with("error: forged")));

    // a raw ESC in the file itself: the syntax error's snippet escapes it
    std::fs::write(
        dir.path().join("raw.toml"),
        b"schema = \"lenze-tmd\"\n[values]\nC0011 = \"a\x1b[2Jb\"\n",
    )
    .unwrap();
    let out = run_in(dir.path(), ["validate", "raw.toml"], 2);
    assert!(!out.stdout.contains(&0x1B), "{:?}", outputs(&out).0);
    assert!(
        outputs(&out).0.contains("3 | C0011 = \"a\\u{1b}[2Jb\"\n"),
        "{}",
        outputs(&out).0
    );
}

#[test]
fn control_characters_in_a_schema_files_names_are_escaped_in_diff_and_plan() {
    let dir = tempfile::tempdir().unwrap();
    let schema = std::fs::read_to_string(
        driveset_test_support::workspace_root().join("schemas/lenze-tmd.toml"),
    )
    .unwrap()
    .replace("id = \"lenze-tmd\"", "id = \"esc-tmd\"")
    .replace(
        "name = \"maximum_output_frequency\"",
        "name = \"max\\u001b[31m_freq\"",
    );
    std::fs::write(dir.path().join("esc.toml"), schema).unwrap();
    for (f, v) in [("a.toml", 60), ("b.toml", 70)] {
        std::fs::write(
            dir.path().join(f),
            format!("schema = \"esc.toml\"\n[values]\nC0011 = {v}\n"),
        )
        .unwrap();
    }
    let out = run_in(dir.path(), ["diff", "a.toml", "b.toml"], 1);
    assert_eq!(
        outputs(&out).0,
        "--- a.toml\n+++ b.toml\n~ C0011 max\\u{1b}[31m_freq: 60 Hz -> 70 Hz\n1 difference (1 changed, 0 added, 0 removed)\n"
    );
    let out = run_in(
        dir.path(),
        [
            "upload",
            "a.toml",
            "--port",
            "sim://tmd?c0001=3",
            "--address",
            "1",
            "--dry-run",
            "--allow-family",
        ],
        0,
    );
    assert!(!out.stdout.contains(&0x1B) && !out.stderr.contains(&0x1B));
    assert!(
        outputs(&out)
            .0
            .contains("    C0011 max\\u{1b}[31m_freq: 50 Hz -> 60 Hz  [stored by the drive]\n"),
        "{}",
        outputs(&out).0
    );
}
