//! End to end over a real pseudo terminal, in real time: `driveset sim`
//! serves a simulated drive on a pty, `driveset upload` downloads a set to
//! it through the serial port code (`SerialLink`, 7E1), `driveset diff
//! SET --port` reads it back, and after SIGTERM the simulator's `--dump`
//! holds exactly the set's values (same canonical lines, so the same
//! fingerprint as `driveset fingerprint SET`). LUSTBUS (MC6000, with the
//! SLOAD dataset download) and LECOM (Tmd).
//!
//! Timeouts are hang guards only; nothing here asserts how long anything
//! took.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::ExitStatus;
use std::time::Duration;

use driveset_schema::{Registry, ResolvedSet, load_set};

use driveset_test_support::{
    LinePeer, Spawned, driveset, driveset_bin, driveset_sim, outcome, python, sdo_server,
    workspace_root,
};

/// Hang guard of one `driveset upload` / `diff` run.
const RUN_GUARD: Duration = Duration::from_secs(300);

/// The real-time tests here run one at a time (within one test process):
/// each is a timed exchange with the client's answer timeouts, and they
/// should not load the machine for each other more than needed.
pub(crate) static REAL_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

pub(crate) fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    REAL_TIME
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Hang guard for the simulator to stop after SIGTERM.
const STOP_GUARD: Duration = Duration::from_secs(30);

/// A running `driveset sim --pty` (or `--tcp`); killed if the test fails
/// first.
pub(crate) struct Sim {
    child: Spawned,
    /// The pty's slave path (or the TCP address) from the first stdout line.
    pub(crate) path: String,
    stderr: PathBuf,
}

impl Sim {
    pub(crate) fn start(dir: &Path, family: &str, address: u8, extra: &[&str]) -> Sim {
        Sim::start_on(dir, family, address, &["--pty"], "pty ", extra)
    }

    /// `driveset sim --tcp 127.0.0.1:0`; [`Sim::path`] is `IP:PORT`.
    pub(crate) fn start_tcp(dir: &Path, family: &str, address: u8, extra: &[&str]) -> Sim {
        Sim::start_on(
            dir,
            family,
            address,
            &["--tcp", "127.0.0.1:0"],
            "tcp ",
            extra,
        )
    }

    fn start_on(
        dir: &Path,
        family: &str,
        address: u8,
        endpoint: &[&str],
        announce: &str,
        extra: &[&str],
    ) -> Sim {
        let stderr = dir.join(format!("sim-{family}.stderr"));
        let mut args: Vec<std::ffi::OsString> = ["--family", family, "--address"]
            .iter()
            .map(Into::into)
            .collect();
        args.push(address.to_string().into());
        args.extend(endpoint.iter().map(Into::into));
        args.push("--dump".into());
        args.push(dir.join(format!("{family}.dump.json")).into());
        args.extend(extra.iter().map(Into::into));
        let mut child = driveset_sim(
            &args,
            std::fs::File::create(&stderr)
                .expect("sim stderr file")
                .into(),
        );
        let (first, _) = child.first_line();
        let path = first
            .trim_end()
            .strip_prefix(announce)
            .unwrap_or_else(|| {
                panic!(
                    "first line `{first}` is not `{announce}PATH`; stderr: {}",
                    std::fs::read_to_string(&stderr).unwrap_or_default()
                )
            })
            .to_string();
        Sim {
            child,
            path,
            stderr,
        }
    }

    pub(crate) fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// SIGTERM, then wait (bounded) for the exit.
    pub(crate) fn terminate(&mut self) -> ExitStatus {
        self.child.signal("-TERM", STOP_GUARD)
    }
}

/// Run `driveset ARGS` from the workspace root; (exit code, stdout, stderr).
pub(crate) fn run(args: &[&str]) -> (Option<i32>, String, String) {
    outcome(driveset().args(args).timeout(RUN_GUARD))
}

pub(crate) fn load(rel: &str) -> ResolvedSet {
    let mut registry = Registry::builtin().expect("built-in schemas");
    let loaded = load_set(&workspace_root().join(rel), &mut registry).expect("set loads");
    assert!(loaded.findings.is_empty(), "{:?}", loaded.findings);
    loaded.resolved.expect("resolved")
}

/// `driveset fingerprint SET`'s fingerprint.
fn fingerprint_cli(rel: &str) -> String {
    let (code, stdout, stderr) = run(&["fingerprint", rel]);
    assert_eq!(code, Some(0), "{stderr}");
    stdout
        .split_whitespace()
        .next()
        .expect("a fingerprint")
        .to_string()
}

/// The dump's canonical lines of the set's codes, as a canonical text of
/// the set's schema: equal to the set's canonical form exactly when the
/// drive holds every value of the set.
pub(crate) fn dump_subset(dump: &serde_json::Value, address: u8, set: &ResolvedSet) -> String {
    let drive = dump["drives"]
        .as_array()
        .expect("drives")
        .iter()
        .find(|d| d["address"] == address)
        .unwrap_or_else(|| panic!("no drive {address} in the dump: {dump}"));
    assert_eq!(drive["schema"], set.schema.as_str(), "{dump}");
    let canonical = drive["canonical"].as_str().expect("canonical");
    let mut out = format!("driveset-canonical 1\nschema {}\n", set.schema);
    for key in set.values.keys() {
        let code = key.canonical(set.code_style);
        let line = canonical
            .lines()
            .find(|l| l.split_once(' ').is_some_and(|(c, _)| c == code))
            .unwrap_or_else(|| panic!("{code} is not in the dump:\n{canonical}"));
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Upload `set_rel` to a simulated `family` drive at `address` over a pty,
/// diff it live, stop the simulator and compare its dump with the set.
/// `port_query` is appended to the pty path (`?baud=...`), `sim_args` go
/// to `driveset sim`. Returns the upload's stdout.
fn upload_over_pty(
    family: &str,
    address: u8,
    set_rel: &str,
    sim_args: &[&str],
    port_query: &str,
) -> String {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let set = load(set_rel);
    let fingerprint = fingerprint_cli(set_rel);
    assert_eq!(fingerprint, set.fingerprint());
    let mut sim = Sim::start(dir.path(), family, address, sim_args);
    let port = format!("{}{port_query}", sim.path);
    let addr = address.to_string();
    let journal_dir = dir.path().join("journal");
    let journal_dir_arg = journal_dir.to_string_lossy().into_owned();

    // upload
    let (code, stdout, stderr) = run(&[
        "upload",
        set_rel,
        "--port",
        &port,
        "--address",
        &addr,
        "--journal-dir",
        &journal_dir_arg,
    ]);
    let context = || {
        format!(
            "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- sim stderr\n{}",
            sim.stderr()
        )
    };
    assert_eq!(code, Some(0), "upload failed\n{}", context());
    let n = set.values.len();
    let head = stdout.lines().next().unwrap_or_default();
    assert!(
        head.starts_with(&format!("{} address {address}: complete (", sim.path)),
        "{}",
        context()
    );
    assert!(
        head.contains(&format!(" of {n} codes written, 1 attempt(s), ")),
        "{}",
        context()
    );
    assert!(
        stdout
            .lines()
            .any(|l| l == format!("after:  {fingerprint}")),
        "the drive holds the set's fingerprint\n{}",
        context()
    );
    assert!(!stdout.contains("FAILED"), "{}", context());
    // every written code verified
    let written: usize = head
        .split_once("complete (")
        .and_then(|(_, r)| r.split_once(' '))
        .and_then(|(w, _)| w.parse().ok())
        .expect("codes written");
    let verified = stdout.lines().filter(|l| l.ends_with("  verified")).count();
    assert_eq!(verified, written, "{}", context());
    // the journal says complete
    let journals: Vec<PathBuf> = std::fs::read_dir(&journal_dir)
        .expect("journal dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.to_string_lossy().ends_with(".journal.json"))
        .collect();
    assert_eq!(journals.len(), 1, "{journals:?}");
    // the directory the upload created keeps itself out of git
    assert!(journal_dir.join(".gitignore").exists());
    let journal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&journals[0]).expect("journal"))
            .expect("journal JSON");
    assert_eq!(journal["state"], "complete", "{journal}");

    // live diff: nothing differs
    let (code, diff_out, diff_err) = run(&["diff", set_rel, "--port", &port, "--address", &addr]);
    assert_eq!(
        code,
        Some(0),
        "diff\n--- stdout\n{diff_out}\n--- stderr\n{diff_err}\n--- sim stderr\n{}",
        sim.stderr()
    );
    assert!(diff_out.contains("no differences"), "{diff_out}");

    // stop the simulator; its dump holds the set
    let status = sim.terminate();
    assert!(status.success(), "{status}\n{}", sim.stderr());
    let dump_path = dir.path().join(format!("{family}.dump.json"));
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&dump_path).expect("dump written"))
            .expect("dump JSON");
    assert_eq!(dump["family"], family);
    assert_eq!(
        dump_subset(&dump, address, &set),
        set.canonical(),
        "the drive's values of the set's codes (so the fingerprint {fingerprint})"
    );
    stdout
}

#[test]
fn mc6000_upload_over_a_pty_lands_through_the_dataset_download() {
    let stdout = upload_over_pty(
        "mc6000",
        1,
        "tests/data/sets/e2e/mc6000-small.toml",
        &[],
        "",
    );
    // 9 CardWriteable codes go through the SLOAD dataset, 428-RSIO to RAM.
    assert!(
        stdout.lines().any(|l| l == "dataset: accepted (SLOAD = 0)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("address 1: complete (10 of 10 codes written"),
        "{stdout}"
    );
    for line in [
        "  100-PWMF: \"8 kHz\" -> \"16 kHz\"  verified",
        "  561-USR2: 0 -> -42  verified",
        "  428-RSIO: 0 1/min -> 132.25 1/min  verified",
    ] {
        assert!(stdout.lines().any(|l| l == line), "{line}\n{stdout}");
    }
}

/// The whole axis set (195 codes, 78 written, ~700 telegrams with the
/// diff) at 57600 baud: ~15 s. The clients' answer timeouts carry the
/// link's measured latency (engine `client::timing`), so a loaded machine
/// (the integration binary's other tests alongside) costs time, not
/// answers.
#[test]
fn mc6000_full_axis_set_over_a_pty_at_57600_baud() {
    let stdout = upload_over_pty(
        "mc6000",
        1,
        "parameter-sets/mc6000/axis-1.toml",
        &["--baud", "57600"],
        "?baud=57600",
    );
    assert!(
        stdout.lines().any(|l| l == "dataset: accepted (SLOAD = 0)"),
        "{stdout}"
    );
}

#[test]
fn tmd_upload_over_a_pty_with_lecom() {
    let stdout = upload_over_pty(
        "tmd",
        13,
        "tests/data/sets/e2e/tmd-small.toml",
        // C0001 = 3 at the keypad: LECOM may program the drive (§4e)
        &["--c0001", "3"],
        "",
    );
    // C0089 already holds 50 Hz: read back, not written.
    assert!(
        stdout.contains("address 13: complete (5 of 6 codes written"),
        "{stdout}"
    );
    for line in [
        "  C0010 minimum_output_frequency: 0 Hz -> 5 Hz  verified",
        "  C0088 motor_rated_current: 0 A -> 8.2 A  verified",
    ] {
        assert!(stdout.lines().any(|l| l == line), "{line}\n{stdout}");
    }
    assert!(!stdout.contains("C0089"), "{stdout}");
}

/// `driveset pull --port PTY --address N -o FILE` alone against a drive
/// served on a real pty: the protocol and family come from the read-only
/// probes, the VF1000's schema is learned from its descriptions and written
/// beside the set, which then validates offline.
#[test]
fn pull_alone_over_a_pty_finds_the_family_and_learns_the_schema() {
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let mut sim = Sim::start(dir.path(), "vf1000", 2, &[]);
    let set = dir.path().join("pulled").join("conveyor.toml");
    let set_s = set.to_str().unwrap().to_string();
    let (code, stdout, stderr) =
        run(&["pull", "--port", &sim.path, "--address", "2", "-o", &set_s]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}\n{}", sim.stderr());
    assert!(
        stdout.contains("protocol: lustbus-vf1000 (LUSTBUS ENQUIRY of 91-TYPE answered (1000), the MC6000/7000 CODE 20091 not: a VF1000)\n"),
        "{stdout}"
    );
    assert!(
        stderr.starts_with("learned schema learned-vf1000-type1000-d"),
        "{stderr}"
    );
    let text = std::fs::read_to_string(&set).unwrap();
    assert!(
        text.contains("\nschema = \"learned-vf1000-type1000-d"),
        "{text}"
    );
    let (code, out, err) = run(&["validate", &set_s]);
    assert_eq!(code, Some(0), "{out}\n{err}");
    let (code, out, err) = run(&[
        "identify",
        "--port",
        &sim.path,
        "--address",
        "2",
        "--schema-dir",
        set.parent().unwrap().to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{out}\n{err}");
    assert!(
        out.contains("\nuses:     learned-vf1000-type1000-d"),
        "{out}"
    );
    assert!(out.contains(" (learned, "), "{out}");
    assert!(sim.terminate().success(), "{}", sim.stderr());

    // A Tmd on LECOM: found by RECEIVE of C0093; its schema is complete.
    let mut tmd = Sim::start(dir.path(), "tmd", 13, &[]);
    let tset = dir.path().join("tmd.toml");
    let (code, stdout, stderr) = run(&[
        "pull",
        "--port",
        &tmd.path,
        "--address",
        "13",
        "-o",
        tset.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}\n{}", tmd.stderr());
    assert!(
        stdout.contains("protocol: lecom (LECOM RECEIVE of C0093 answered ("),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&tset).unwrap();
    assert!(text.contains("\nschema = \"lenze-tmd\"\n"), "{text}");
    assert!(tmd.terminate().success(), "{}", tmd.stderr());
}

/// The `canopen` LocalNode of crates/driveset-engine/tests/python/sdo_server.py
/// on python-can's slcan interface (see that crate's interop_canopen.rs):
/// spoken to over stdin / stdout.
struct PySdoServer(LinePeer);

impl PySdoServer {
    fn start(pty: &str) -> PySdoServer {
        PySdoServer::start_with(pty, &[])
    }

    /// `extra`: further arguments of sdo_server.py (an EDS to import).
    fn start_with(pty: &str, extra: &[&str]) -> PySdoServer {
        PySdoServer(sdo_server(pty, 1, extra, RUN_GUARD))
    }

    fn stderr(&self) -> String {
        self.0.stderr()
    }

    fn line(&mut self) -> String {
        self.0.line()
    }

    fn send(&mut self, command: &str) {
        self.0.send(command);
    }

    /// `CODE RAW` lines of the object dictionary (writes left out).
    fn values(&mut self) -> Vec<String> {
        self.send("dump");
        let mut out = Vec::new();
        loop {
            let line = self.line();
            if line == "end" {
                return out;
            }
            if !line.starts_with("wrote ") {
                out.push(line);
            }
        }
    }

    fn quit(self) {
        self.0.quit("quit", "bye");
    }
}

/// `driveset pull` and `driveset upload` on `slcan://` against an SDO
/// server driveset did not write (canopen's LocalNode behind python-can's
/// slcan interface), joined by driveset_sim::slcan_hub.
#[test]
fn pull_and_upload_against_a_canopen_local_node_over_slcan() {
    if driveset_test_support::python_or_skip("canopen interop").is_none() {
        return;
    }
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let hub = driveset_sim::slcan_hub::SlcanHub::spawn(500_000).expect("slcan hub");
    let mut server = PySdoServer::start(hub.path_b());
    let port = format!("slcan://{}?bitrate=500000", hub.path_a());
    let log = |hub: &driveset_sim::slcan_hub::SlcanHub| hub.log().join("\n");

    // pull: every code, exact values
    let pulled = dir.path().join("pulled.toml");
    let pulled_arg = pulled.to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "pull",
        "--port",
        &port,
        "--address",
        "1",
        "--schema",
        "parameter-sets/fixtures/fictional-ecs-demo.toml",
        "-o",
        &pulled_arg,
    ]);
    assert_eq!(
        code,
        Some(0),
        "pull\n{stdout}\n{stderr}\n{}\n{}",
        server.stderr(),
        log(&hub)
    );
    let mut registry = driveset_sim::catalog::registry().expect("registry");
    let loaded = load_set(&pulled, &mut registry).expect("pulled set loads");
    assert!(loaded.findings.is_empty(), "{:?}", loaded.findings);
    let set = loaded.resolved.expect("resolved");
    let got: Vec<String> = set
        .values
        .iter()
        .map(|(k, v)| match v {
            driveset_schema::RawValue::Int(i) => format!("C{:04} {i}", k.number),
            other => panic!("C{:04}: {other:?}", k.number),
        })
        .collect();
    // C0135 is the control word (role `control-word`): pull leaves it out,
    // a set cannot hold it.
    let initial = server.values();
    let settings: Vec<String> = initial
        .iter()
        .filter(|v| !v.starts_with("C0135 "))
        .cloned()
        .collect();
    assert_eq!(
        got,
        settings,
        "{}",
        std::fs::read_to_string(&pulled).unwrap_or_default()
    );

    // upload a changed set
    // The sets name the simulator's fixture schema by path (`driveset
    // fingerprint` loads the built-in schemas only).
    let schema_line = format!(
        "schema = {:?}\n",
        workspace_root()
            .join("parameter-sets/fixtures/fictional-ecs-demo.toml")
            .display()
            .to_string()
    );
    let changed = dir.path().join("changed.toml");
    std::fs::write(
        &changed,
        format!("{schema_line}[values]\nC5001 = \"5200.5 rpm\"\nC5003 = \"0.400 s\"\nC5016 = \"Position control\"\nC5014 = \"80 ms\"\n"),
    )
    .expect("write the set");
    let changed_arg = changed.to_string_lossy().into_owned();
    let journal_dir = dir.path().join("journal").to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "upload",
        &changed_arg,
        "--port",
        &port,
        "--address",
        "1",
        "--journal-dir",
        &journal_dir,
    ]);
    assert_eq!(
        code,
        Some(0),
        "upload\n{stdout}\n{stderr}\n{}\n{}",
        server.stderr(),
        log(&hub)
    );
    assert!(
        stdout.contains("address 1: complete (3 of 4 codes written"),
        "{stdout}"
    );
    let fingerprint = fingerprint_cli(&changed_arg);
    assert!(
        stdout
            .lines()
            .any(|l| l == format!("after:  {fingerprint}")),
        "{stdout}"
    );
    for line in [
        "  C5001 max_speed: 4500 rpm -> 5200.5 rpm  verified",
        "  C5003 accel_time: 0.25 s -> 0.4 s  verified",
    ] {
        assert!(stdout.lines().any(|l| l == line), "{line}\n{stdout}");
    }
    // every object as before (C0135 included) but the three written
    let want: Vec<String> = initial
        .iter()
        .map(|l| match l.split_once(' ').expect("CODE RAW").0 {
            "C5001" => "C5001 52005000".to_string(),
            "C5003" => "C5003 4000".to_string(),
            "C5016" => "C5016 20000".to_string(),
            _ => l.clone(),
        })
        .collect();
    assert_eq!(server.values(), want);

    // a code the LocalNode keeps read-only: the SDO abort, decoded
    let ro = dir.path().join("ro.toml");
    std::fs::write(
        &ro,
        format!("{schema_line}[values]\nC5010 = \"3000 rpm\"\n"),
    )
    .expect("write the set");
    let ro_arg = ro.to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "upload",
        &ro_arg,
        "--port",
        &port,
        "--address",
        "1",
        "--journal-dir",
        &journal_dir,
    ]);
    assert_eq!(code, Some(3), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("SDO abort 0x06010002") && stderr.to_lowercase().contains("read only"),
        "{stderr}"
    );
    assert_eq!(server.values(), want, "C5010 unchanged");

    server.quit();
    let stats = hub.stop().expect("hub stops");
    assert_eq!(stats.dropped, 0);
}

/// The same EDS on both sides: `driveset schema import` makes the schema,
/// canopen's own importer (`canopen.import_od`) builds the LocalNode's
/// object dictionary, and `driveset pull` / `upload` with the imported
/// schema talk to it over slcan (Lenze codes as FIX32 / BITCODED / VS,
/// CiA 301 objects by index with their own widths). The DCF that `show
/// --to dcf` writes from the pulled set is read back by canopen.
#[test]
fn imported_eds_schema_pulls_and_uploads_against_a_canopen_local_node() {
    if driveset_test_support::python_or_skip("canopen interop").is_none() {
        return;
    }
    let _serial = one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let eds = workspace_root().join("tests/data/eds/fictional-ecs-axis.eds");
    let eds_arg = eds.to_string_lossy().into_owned();
    let schema = dir.path().join("schemas/fictional-ecs-axis.toml");
    let schema_arg = schema.to_string_lossy().into_owned();
    let (code, _, stderr) = run(&["schema", "import", &eds_arg, "-o", &schema_arg]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.ends_with("25 Lenze codes, 13 objects by index, 18 lints\n"),
        "{stderr}"
    );

    let hub = driveset_sim::slcan_hub::SlcanHub::spawn(500_000).expect("slcan hub");
    let mut server = PySdoServer::start_with(hub.path_b(), &[&eds_arg]);
    let port = format!("slcan://{}?bitrate=500000", hub.path_a());
    let log = |hub: &driveset_sim::slcan_hub::SlcanHub| hub.log().join("\n");

    // pull every code of the imported schema
    let pulled = dir.path().join("pulled.toml");
    let pulled_arg = pulled.to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "pull",
        "--port",
        &port,
        "--address",
        "1",
        "--schema",
        &schema_arg,
        "-o",
        &pulled_arg,
    ]);
    assert_eq!(
        code,
        Some(0),
        "pull\n{stdout}\n{stderr}\n{}\n{}",
        server.stderr(),
        log(&hub)
    );
    let mut registry = driveset_sim::catalog::registry().expect("registry");
    let loaded_schema = registry.load_file(&schema).expect("imported schema loads");
    let cia_index = |number: u32| loaded_schema.code(number).and_then(|c| c.index);
    // a subindex kept as a code of its own (C5020's, 0x1018's) is at its subindex
    let own_sub = |number: u32| loaded_schema.code(number).and_then(|c| c.subindex);
    let canonical = std::process::Command::new(driveset_bin())
        .args(["show", &pulled_arg])
        .output()
        .expect("show");
    let canonical = String::from_utf8_lossy(&canonical.stdout).into_owned();
    // what the pulled set holds, in the server's spelling (index/sub raw)
    let mut got: Vec<String> = canonical
        .lines()
        .skip(2)
        .map(|l| {
            let (key, raw) = l.split_once(' ').expect("CODE RAW");
            let (num, sub) = match key.trim_start_matches('C').split_once('/') {
                Some((n, s)) => (n.parse::<u32>().expect("n"), s.parse::<u32>().expect("s")),
                None => {
                    let n = key.trim_start_matches('C').parse::<u32>().expect("n");
                    (n, own_sub(n).map_or(0, u32::from))
                }
            };
            let index = cia_index(num).map_or_else(|| 24575 - num, u32::from);
            let raw = raw.strip_prefix('s').unwrap_or(raw);
            format!("0x{index:04X}/{sub} {raw}")
        })
        .collect();
    got.sort();
    let served: Vec<String> = server.values();
    let mut expected: Vec<String> = served
        .iter()
        .filter(|l| {
            got.iter()
                .any(|g| g.split(' ').next() == l.split(' ').next())
        })
        .cloned()
        .collect();
    expected.sort();
    assert_eq!(got, expected, "{canonical}");
    // pull leaves out the read-only codes (C0150, C5070, C5080 and the
    // CiA 301 objects 0x1000, 0x1001, 0x1003, 0x1008, 0x1014, 0x1018) and
    // the control word C0135 (role `control-word`, kept from lenze-ecs)
    assert_eq!(got.len(), 24, "{got:#?}");
    for line in [
        "0x4C76/0 30000000",  // C5001 3000 rpm, FIX32
        "0x4C63/3 -5000000",  // C5020/3, a subcode
        "0x4C59/0 \"AXIS1\"", // C5030, VS
        "0x6073/0 1500",      // UNSIGNED16 CiA 301 object
        "0x6085/0 1000",      // UNSIGNED32 CiA 301 object
    ] {
        assert!(got.iter().any(|g| g == line), "{line}\n{got:?}");
    }

    // upload a changed set with the imported schema
    let changed = dir.path().join("changed.toml");
    std::fs::write(
        &changed,
        format!(
            "schema = {:?}\n[values]\nmax_speed = 4500\n\"C5020/2\" = -250.5\nC5030 = \"AXIS9\"\nproducer_heartbeat_time = 100\nC90227 = 2000\n",
            schema_arg
        ),
    )
    .expect("write the set");
    let changed_arg = changed.to_string_lossy().into_owned();
    let journal_dir = dir.path().join("journal").to_string_lossy().into_owned();
    // The imported schema keeps C0135 / C0150 as the built-in lenze-ecs
    // has them (control word, status word) but, like it, knows no running
    // bit: the upload needs --allow-running-unknown, and a set cannot hold
    // the control word.
    let (code, stdout, stderr) = run(&[
        "upload",
        &changed_arg,
        "--port",
        &port,
        "--address",
        "1",
        "--journal-dir",
        &journal_dir,
        "--allow-running-unknown",
    ]);
    assert_eq!(
        code,
        Some(0),
        "upload\n{stdout}\n{stderr}\n{}\n{}",
        server.stderr(),
        log(&hub)
    );
    assert!(
        stdout.contains("address 1: complete (5 of 5 codes written"),
        "{stdout}"
    );
    let after = server.values();
    for line in [
        "0x4C76/0 45000000",
        "0x4C63/2 -2505000",
        "0x4C59/0 \"AXIS9\"",
        "0x1017/0 100",
        "0x6073/0 2000",
        "0x5F78/0 0", // C0135: a set cannot hold the control word
    ] {
        assert!(after.iter().any(|g| g == line), "{line}\n{after:?}");
    }

    // the DCF of the changed set, read back by canopen's importer
    let dcf = dir.path().join("changed.dcf");
    let out = std::process::Command::new(driveset_bin())
        .args(["show", "--to", "dcf", "--node-id", "1", &changed_arg])
        .output()
        .expect("show --to dcf");
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::write(&dcf, &out.stdout).expect("write dcf");
    let read = std::process::Command::new(python())
        .args([
            "-c",
            "import sys, canopen\nod = canopen.import_od(sys.argv[1], 1)\nprint(od.node_id, od[0x4C76].value, od[0x4C63][2].value, od[0x4C59].value, od[0x1017].value, od[0x6073].value)",
        ])
        .arg(&dcf)
        .output()
        .expect("python");
    assert_eq!(
        String::from_utf8_lossy(&read.stdout),
        "1 45000000 -2505000 AXIS9 100 2000\n",
        "{}",
        String::from_utf8_lossy(&read.stderr)
    );

    // 0x1017 = 100 ms started canopen's heartbeat producer (NMT
    // heartbeat, COB-ID 0x700 + node): real CiA 301 behaviour, seen on the bus
    assert!(log(&hub).contains(" 701 [1] "), "{}", log(&hub));
    server.quit();
    hub.stop().expect("hub stops");
}
