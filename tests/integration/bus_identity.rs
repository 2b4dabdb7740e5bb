//! The bus, not its spelling (issue 17): journals and the bus lock follow
//! the bus a port reaches, whatever the port string says. Through the
//! built binary over real OS objects: a pty served by `driveset sim
//! --pty` and a symlink to it, a TCP simulator reached as `localhost` and
//! as `127.0.0.1`, uploads killed with SIGKILL while they write, and
//! `sim://` ports with a state file, faults and a schema given by path
//! (recover needs no flags). What each drive holds is read from the
//! simulator's dump or state file.
//!
//! Timeouts are hang guards only; nothing here asserts how long anything
//! took.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::e2e_pty::{Sim, dump_subset, load, one_at_a_time};
use driveset_test_support::{
    driveset, driveset_in_with_locks, outcome, send_signal, workspace_root,
};

/// Hang guard of one command, and of waiting for a journal to appear.
const GUARD: Duration = Duration::from_secs(300);

const SET: &str = "parameter-sets/tmd/conveyor-3.toml";

/// `driveset ARGS` from the workspace root with the test's lock directory.
fn cmd(locks: &Path, args: &[&str]) -> assert_cmd::Command {
    let mut c = driveset();
    c.env("DRIVESET_LOCK_DIR", locks).args(args).timeout(GUARD);
    c
}

/// `driveset upload SET --port PORT --address 11 --journal-dir DIR`,
/// started in the background.
fn spawn_upload(locks: &Path, port: &str, journals: &Path, stderr: &Path) -> Child {
    Command::new(driveset_test_support::driveset_bin())
        .current_dir(workspace_root())
        .env("DRIVESET_LOCK_DIR", locks)
        .args([
            "upload",
            SET,
            "--port",
            port,
            "--address",
            "11",
            "--journal-dir",
        ])
        .arg(journals)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(stderr).expect("stderr file"))
        .spawn()
        .expect("start driveset upload")
}

/// The one journal in `dir`, once it exists and records writing (the
/// upload is past its plan; the drive may hold some new values).
fn wait_for_writing_journal(dir: &Path, child: &mut Child, stderr: &Path) -> PathBuf {
    let give_up = Instant::now() + GUARD;
    loop {
        if let Some(p) = journals(dir).into_iter().next()
            && let Ok(text) = std::fs::read_to_string(&p)
            && let Ok(j) = serde_json::from_str::<serde_json::Value>(&text)
            && j["state"] == "writing"
        {
            return p;
        }
        if let Some(s) = child.try_wait().expect("wait") {
            panic!(
                "the upload ended ({s}) before its journal recorded writing: {}",
                std::fs::read_to_string(stderr).unwrap_or_default()
            );
        }
        assert!(Instant::now() < give_up, "no journal in {}", dir.display());
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn journals(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".journal.json"))
        .collect();
    v.sort();
    v
}

fn kill9(child: &mut Child) {
    assert!(
        send_signal(child.id(), "-KILL"),
        "kill -KILL {}",
        child.id()
    );
    let _ = child.wait();
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("JSON")
}

/// The refusal of a bus another process holds, up to the holder's `since`.
fn held_prefix(bus: &str, pid: u32) -> String {
    format!("error: bus `{bus}` is in use by another process: pid {pid} (`driveset upload`, since ")
}

fn held_suffix(lock: &Path) -> String {
    format!(
        "); nothing was sent. Wait until that command ends (or stop it), then run this one again (lock {})\n",
        lock.display()
    )
}

fn stem(bus: &str) -> String {
    bus.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

#[test]
fn a_pty_upload_killed_mid_write_is_seen_locked_recovered_and_redone_through_a_symlink() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let locks = dir.path().join("locks");
    let journal_dir = dir.path().join("journal");
    let mut sim = Sim::start(dir.path(), "tmd", 11, &["--c0001", "3"]);
    let pts = std::fs::canonicalize(&sim.path)
        .unwrap()
        .display()
        .to_string();
    // what a udev rule or /dev/serial/by-id makes: a symlink to the device
    let link = dir.path().join("usb-FTDI_FT232R_A1B2C3-if00-port0");
    std::os::unix::fs::symlink(&sim.path, &link).unwrap();
    let link = link.display().to_string();
    let bus = format!("serial:{pts}");

    // 1. upload A through the pty's own name; while it writes, upload B
    //    through the symlink is refused by the bus lock, naming A
    let a_err = dir.path().join("a.stderr");
    let mut a = spawn_upload(&locks, &sim.path, &journal_dir, &a_err);
    let journal = wait_for_writing_journal(&journal_dir, &mut a, &a_err);
    assert_eq!(
        journal.file_name().unwrap().to_string_lossy(),
        format!("{}-11.journal.json", stem(&bus))
    );
    let jarg = journal.display().to_string();
    let (code, stdout, stderr) = outcome(
        cmd(
            &locks,
            &[
                "upload",
                SET,
                "--port",
                &link,
                "--address",
                "11",
                "--journal-dir",
            ],
        )
        .arg(&journal_dir),
    );
    assert_eq!(code, Some(3), "{stderr}");
    assert_eq!(stdout, "");
    let lock = locks.join(format!("{}.lock", stem(&bus)));
    assert!(stderr.starts_with(&held_prefix(&bus, a.id())), "{stderr}");
    assert!(stderr.ends_with(&held_suffix(&lock)), "{stderr}");

    // 2. kill -9 A mid-write: the kernel drops its lock, its journal stays
    //    unfinished; the upload through the symlink is refused by it
    kill9(&mut a);
    let j = json(&journal);
    let cut_in = j["state"].as_str().unwrap().to_string();
    assert!(cut_in == "writing" || cut_in == "verifying", "{j}");
    assert_eq!(j["target"]["bus"], bus.as_str(), "{j}");
    assert_eq!(j["target"]["port"], sim.path.as_str(), "{j}");
    let (code, stdout, stderr) = outcome(
        cmd(
            &locks,
            &[
                "upload",
                SET,
                "--port",
                &link,
                "--address",
                "11",
                "--journal-dir",
            ],
        )
        .arg(&journal_dir),
    );
    assert_eq!(code, Some(2), "{stderr}");
    assert_eq!(stdout, "");
    assert_eq!(
        stderr,
        format!(
            "error: journal {jarg}: the drive at {link} address 11 has an unfinished transaction ({jarg} (state {cut_in})); nothing was sent. Run `driveset recover {jarg}` first\n"
        )
    );

    // 3. recover through the symlink: the same bus, so it settles the drive
    let (code, stdout, stderr) = outcome(&mut cmd(&locks, &["recover", &jarg, "--port", &link]));
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(
        stdout.contains(&format!(
            "note: the journal was written through {} address 11; {link} address 11 reaches the same drive (bus `{bus}`)\n",
            sim.path
        )),
        "{stdout}"
    );
    let state = json(&journal)["state"].clone();
    assert!(state == "rolled-back" || state == "complete", "{state}");

    // 4. the upload through the symlink now runs, and the drive holds the set
    let (code, stdout, stderr) = outcome(
        cmd(
            &locks,
            &[
                "upload",
                SET,
                "--port",
                &link,
                "--address",
                "11",
                "--journal-dir",
            ],
        )
        .arg(&journal_dir),
    );
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(
        stdout.starts_with(&format!("{link} address 11: complete (")),
        "{stdout}"
    );
    let status = sim.terminate();
    assert!(status.success(), "{}", sim.stderr());
    let dump = json(&dir.path().join("tmd.dump.json"));
    let set = load(SET);
    assert_eq!(dump_subset(&dump, 11, &set), set.canonical());
}

/// One direction of the TCP test: an upload through `cut` killed while it
/// writes (a second one through `other` refused by the lock meanwhile),
/// then the guard and recover through `other`.
fn tcp_cut_then_other_spelling(dir: &Path, sim: &Sim, cut: &str, other: &str, bus: &str) {
    let locks = dir.join("locks");
    let journal_dir = dir.join(format!("journal-{}", stem(cut)));
    let a_err = dir.join(format!("{}.stderr", stem(cut)));
    let mut a = spawn_upload(&locks, cut, &journal_dir, &a_err);
    let journal = wait_for_writing_journal(&journal_dir, &mut a, &a_err);
    assert_eq!(
        journal.file_name().unwrap().to_string_lossy(),
        format!("{}-11.journal.json", stem(bus))
    );
    let jarg = journal.display().to_string();
    let upload_other = || {
        let mut c = cmd(
            &locks,
            &[
                "upload",
                SET,
                "--port",
                other,
                "--address",
                "11",
                "--journal-dir",
            ],
        );
        c.arg(&journal_dir);
        c
    };
    let (code, _, stderr) = outcome(&mut upload_other());
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stderr.starts_with(&held_prefix(bus, a.id())), "{stderr}");
    assert!(
        stderr.ends_with(&held_suffix(&locks.join(format!("{}.lock", stem(bus))))),
        "{stderr}"
    );
    kill9(&mut a);
    assert_eq!(json(&journal)["target"]["bus"], bus, "{}", json(&journal));
    let (code, stdout, stderr) = outcome(&mut upload_other());
    assert_eq!(code, Some(2), "{stderr}");
    assert_eq!(stdout, "");
    let state = json(&journal)["state"].as_str().unwrap().to_string();
    assert_eq!(
        stderr,
        format!(
            "error: journal {jarg}: the drive at {other} address 11 has an unfinished transaction ({jarg} (state {state})); nothing was sent. Run `driveset recover {jarg}` first\n"
        )
    );
    let (code, stdout, stderr) = outcome(&mut cmd(&locks, &["recover", &jarg, "--port", other]));
    assert_eq!(code, Some(0), "{stdout}{stderr}\n{}", sim.stderr());
    assert!(
        stdout.contains(&format!(
            "note: the journal was written through {cut} address 11; {other} address 11 reaches the same drive (bus `{bus}`)\n"
        )),
        "{stdout}"
    );
    let settled = json(&journal)["state"].clone();
    assert!(
        settled == "rolled-back" || settled == "complete",
        "{settled}"
    );
}

#[test]
fn tcp_by_name_and_by_address_are_one_bus_both_ways_and_another_port_is_refused() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let mut sim = Sim::start_tcp(dir.path(), "tmd", 11, &["--c0001", "3"]);
    let port = sim.path.rsplit(':').next().unwrap().to_string();
    let by_addr = format!("tcp://127.0.0.1:{port}");
    let by_name = format!("tcp://localhost:{port}");
    let bus = format!("tcp:127.0.0.1:{port}");
    tcp_cut_then_other_spelling(dir.path(), &sim, &by_addr, &by_name, &bus);
    tcp_cut_then_other_spelling(dir.path(), &sim, &by_name, &by_addr, &bus);

    // a journal of this bus through a port to another one: refused before
    // a telegram, naming both buses (the listener is never read from)
    let locks = dir.path().join("locks");
    let elsewhere = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let q = elsewhere.local_addr().unwrap().port();
    let journal = journals(&dir.path().join(format!("journal-{}", stem(&by_name))))
        .pop()
        .unwrap();
    let jarg = journal.display().to_string();
    let before = std::fs::read(&journal).unwrap();
    let far = format!("tcp://localhost:{q}");
    let (code, stdout, stderr) = outcome(&mut cmd(&locks, &["recover", &jarg, "--port", &far]));
    assert_eq!(code, Some(0), "a settled journal needs nothing: {stderr}");
    assert!(stdout.contains("nothing to do"), "{stdout}");
    // an unfinished one of the same bus: written back to `writing`
    let mut j = json(&journal);
    j["state"] = "writing".into();
    std::fs::write(&journal, serde_json::to_vec_pretty(&j).unwrap()).unwrap();
    let (code, stdout, stderr) = outcome(&mut cmd(&locks, &["recover", &jarg, "--port", &far]));
    assert_eq!(code, Some(2), "{stderr}");
    assert_eq!(stdout, "");
    assert_eq!(
        stderr,
        format!(
            "error: {far} address 11: refused to recover journal {jarg}: it belongs to the drive at address 11 on bus `{bus}` (port {by_name}), but this port reaches bus `tcp:127.0.0.1:{q}`; nothing was sent. Recover through a port to that bus\n"
        )
    );
    std::fs::write(&journal, before).unwrap();
    drop(elsewhere);

    // the drive holds its old values or the set, never a mix: the last
    // recover settled it; an upload by name completes it
    let (code, stdout, stderr) = outcome(
        cmd(
            &locks,
            &[
                "upload",
                SET,
                "--port",
                &by_name,
                "--address",
                "11",
                "--journal-dir",
            ],
        )
        .arg(dir.path().join("journal-final")),
    );
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let status = sim.terminate();
    assert!(status.success(), "{}", sim.stderr());
    let dump = json(&dir.path().join("tmd.dump.json"));
    let set = load(SET);
    assert_eq!(dump_subset(&dump, 11, &set), set.canonical());
}

/// The IPv4-mapped IPv6 spelling of an address is its bus (issue 29):
/// with an unfinished journal of `tcp://127.0.0.1:P`, an upload through
/// `tcp://[::ffff:127.0.0.1]:P` is refused by the lock while the first
/// runs and by the journal after it was killed, and recover finishes it.
#[test]
fn an_ipv4_mapped_spelling_is_the_bus_of_its_ipv4_journal() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let mut sim = Sim::start_tcp(dir.path(), "tmd", 11, &["--c0001", "3"]);
    let port = sim.path.rsplit(':').next().unwrap().to_string();
    let by_addr = format!("tcp://127.0.0.1:{port}");
    let mapped = format!("tcp://[::ffff:127.0.0.1]:{port}");
    let bus = format!("tcp:127.0.0.1:{port}");
    tcp_cut_then_other_spelling(dir.path(), &sim, &by_addr, &mapped, &bus);
    let status = sim.terminate();
    assert!(status.success(), "{}", sim.stderr());
}

/// `driveset` in `dir` (the simulator's state and the journals there).
fn guarded_in(dir: &Path) -> assert_cmd::Command {
    let mut c = driveset_in_with_locks(dir);
    c.timeout(GUARD);
    c
}

#[test]
fn a_journal_written_through_a_sim_port_with_state_and_faults_recovers_without_flags() {
    let dir = tempfile::tempdir().unwrap();
    let set = workspace_root().join(SET);
    let port = "sim://tmd?addresses=11&c0001=3&state=drives.json&faults=cable@30+600s&seed=7";
    let (code, _, stderr) = outcome(guarded_in(dir.path()).arg("upload").arg(&set).args([
        "--port",
        port,
        "--address",
        "11",
    ]));
    assert_eq!(code, Some(3), "{stderr}");
    let state = std::fs::canonicalize(dir.path())
        .unwrap()
        .join("drives.json");
    let bus = format!("sim:tmd@{}", state.display());
    let jarg = format!(".driveset/journal/{}-11.journal.json", stem(&bus));
    let j = json(&dir.path().join(&jarg));
    assert_eq!(j["state"], "failed", "{j}");
    assert_eq!(j["target"]["bus"], bus.as_str(), "{j}");
    // the port as journals name it: canonical, its state file absolute
    let recorded = format!(
        "sim://tmd?addresses=11&c0001=3&faults=cable@30+600s&seed=7&state={}",
        state.display()
    );
    assert_eq!(j["target"]["port"], recorded.as_str(), "{j}");
    assert_eq!(j["schema"], "lenze-tmd", "{j}");
    assert!(j.get("schema_path").is_none(), "a built-in: {j}");
    let before = j["fingerprint_before"].as_str().unwrap().to_string();

    // another spelling (other key order, no faults, the state file by
    // another relative path) is the same bus: the guard refuses it
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let respelled = "sim://tmd?c0001=3&state=sub/../drives.json&addresses=11";
    let (code, _, stderr) = outcome(guarded_in(dir.path()).arg("upload").arg(&set).args([
        "--port",
        respelled,
        "--address",
        "11",
    ]));
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "has an unfinished transaction ({jarg} (state failed))"
        )),
        "{stderr}"
    );

    // recover with nothing but the journal, from another directory: the
    // recorded port without the run's faults, the state file absolute
    let elsewhere = tempfile::tempdir().unwrap();
    let journal = dir.path().join(&jarg);
    let (code, stdout, stderr) = outcome(guarded_in(elsewhere.path()).arg("recover").arg(&journal));
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let reopened = format!("sim://tmd?addresses=11&c0001=3&state={}", state.display());
    assert!(
        stdout.starts_with(&format!(
            "{reopened} address 11: journal was failed; rolled back: the drive holds its old values again (verified); journal marked rolled-back\n"
        )),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!("drive holds: {before}\n")),
        "{stdout}"
    );
    assert_eq!(json(&journal)["state"], "rolled-back");
    // the state file holds the drive as it was before the upload
    let sim_state = json(&state);
    assert!(sim_state["telegrams"].as_u64().unwrap() > 0, "{sim_state}");
}

#[test]
fn a_journal_of_a_schema_given_by_path_recovers_without_flags_and_refuses_an_edited_schema() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(workspace_root().join("schemas/lenze-tmd.toml"))
        .unwrap()
        .replace("id = \"lenze-tmd\"", "id = \"plant-tmd\"");
    std::fs::create_dir(dir.path().join("sets")).unwrap();
    let schema = dir.path().join("sets/plant-tmd.toml");
    std::fs::write(&schema, &text).unwrap();
    std::fs::write(
        dir.path().join("sets/axis.toml"),
        "schema = \"plant-tmd.toml\"\ntitle = \"t\"\n\n[values]\nC0010 = \"5.0 Hz\"\nC0011 = \"60.0 Hz\"\nC0012 = \"8.0 s\"\nC0013 = \"6.0 s\"\nC0086 = \"4.0 kW\"\nC0087 = \"1450 rpm\"\nC0088 = \"8.2 A\"\nC0090 = \"400 V\"\nC0091 = \"0.84\"\n",
    )
    .unwrap();
    let port = "sim://tmd?addresses=11&c0001=3&state=drives.json&faults=cable@17+600s";
    let (code, _, stderr) = outcome(guarded_in(dir.path()).args([
        "upload",
        "sets/axis.toml",
        "--port",
        port,
        "--address",
        "11",
    ]));
    assert_eq!(code, Some(3), "{stderr}");
    let state = std::fs::canonicalize(dir.path())
        .unwrap()
        .join("drives.json");
    let jarg = format!(
        ".driveset/journal/{}-11.journal.json",
        stem(&format!("sim:tmd@{}", state.display()))
    );
    let journal = dir.path().join(&jarg);
    let j = json(&journal);
    assert_eq!(j["schema"], "plant-tmd", "{j}");
    let canon = std::fs::canonicalize(&schema)
        .unwrap()
        .display()
        .to_string();
    assert_eq!(j["schema_path"], canon.as_str(), "{j}");
    let fp = driveset_schema::schema::schema_fingerprint(None, &text);
    assert_eq!(j["schema_fingerprint"], fp.as_str(), "{j}");
    assert!(j["state"] == "failed" || j["state"] == "writing", "{j}");

    // the schema file edited since: refused, nothing sent, both named
    std::fs::write(&schema, format!("{text}\n# edited\n")).unwrap();
    let edited = driveset_schema::schema::schema_fingerprint(None, &format!("{text}\n# edited\n"));
    let (code, stdout, stderr) = outcome(guarded_in(dir.path()).arg("recover").arg(&jarg));
    assert_eq!(code, Some(2), "{stdout}{stderr}");
    let reopened = format!("sim://tmd?addresses=11&c0001=3&state={}", state.display());
    assert_eq!(
        stderr,
        format!(
            "error: {reopened} address 11: refused to recover journal {jarg}: it was written with schema `plant-tmd` from {canon} ({fp}), this client's `plant-tmd` is another version of it ({edited}); nothing was sent. Recover with the schema file the upload used (restore it from version control)\n"
        )
    );
    assert_eq!(json(&state)["telegrams"], 0, "nothing was sent");

    // restored: recover with nothing but the journal, from another directory
    std::fs::write(&schema, &text).unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = outcome(guarded_in(elsewhere.path()).arg("recover").arg(&journal));
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(
        stdout.starts_with(&format!("{reopened} address 11: journal was ")),
        "{stdout}"
    );
    let settled = json(&journal)["state"].clone();
    assert!(
        settled == "rolled-back" || settled == "complete",
        "{settled}"
    );
}

/// A `sim://` bus with a state file, held by another process, is refused
/// by every command before it is opened, through a symlink to the state
/// file too: the state file is not read and written back (its bytes stay),
/// the symlink stays a symlink, and once the lock is free the link reaches
/// the same bus.
#[test]
fn a_held_sim_state_bus_is_refused_before_it_is_opened_through_a_symlink_too() {
    let dir = tempfile::tempdir().unwrap();
    let locks = dir.path().join("locks");
    let state = dir.path().join("state.json");
    let link = dir.path().join("link.json");
    let port = |file: &Path, addresses: &str| {
        format!(
            "sim://mc6000?addresses={addresses}&state={}",
            file.display()
        )
    };
    cmd(&locks, &["scan", "--port", &port(&state, "1,2")])
        .assert()
        .code(0);
    std::os::unix::fs::symlink(&state, &link).unwrap();
    let before = std::fs::read(&state).unwrap();
    let canonical = std::fs::canonicalize(&state).unwrap();
    let bus = format!("sim:mc6000@{}", canonical.display());
    let holder = driveset_link::lock::Holder {
        pid: 1,
        command: "driveset upload".into(),
        since: "2026-12-03T13:00:00.000Z".into(),
    };
    let held = driveset_link::BusLock::acquire(&locks, &bus, &holder).unwrap();
    let refused = format!(
        "error: bus `{bus}` is in use by another process: pid 1 (`driveset upload`, since 2026-12-03T13:00:00.000Z); nothing was sent."
    );
    for args in [
        vec!["scan", "--port", &*port(&link, "1,2")],
        vec!["identify", "--port", &*port(&link, "1"), "--address", "1"],
        vec!["doctor", "--port", &*port(&link, "1")],
        vec![
            "address",
            "--port",
            &*port(&link, "1"),
            "--protocol",
            "lustbus",
            "--to",
            "5",
            "--dry-run",
        ],
    ] {
        let out = cmd(&locks, &args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{args:?}: {err}");
        assert!(err.starts_with(&refused), "{args:?}: {err}");
    }
    assert_eq!(
        std::fs::read(&state).unwrap(),
        before,
        "the state file was written"
    );
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink(),
        "the symlink was replaced by a file"
    );
    drop(held);
    cmd(
        &locks,
        &["identify", "--port", &port(&link, "1"), "--address", "1"],
    )
    .assert()
    .code(0);
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
}
