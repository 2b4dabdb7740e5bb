//! Parity: a simulated port is only a transport (docs/architecture.md, "A
//! simulated port is only a transport"). One script of commands runs
//! against `sim://` drives (in process, virtual time) and against the same
//! drives served by `driveset sim` on a pseudo terminal (real time, the
//! serial port code; CAN through the simulated slcan adapter), each side in
//! a directory of its own, and the two must print the same stdout (ports
//! and measured times masked) with the same exit codes, and write the same
//! pulled set. The script: scan (the line's protocol found by the probes),
//! identify (and, on LUSTBUS, identify with the other LUSTBUS family's
//! schema: the mismatch is identify's finding, exit 1), pull, schema pull,
//! twin capture, a rehearsal of the set against the captured twin
//! (`commission --rehearse`), live diff, dry run, upload. All four
//! families, and MC6000 / VF1000 drives that disagree with the spec facts
//! (another description layout and type characters; a `describe=`
//! contradiction), a factory-fresh MC6000 given its address, and for
//! LUSTBUS and LECOM the line commands: `replace` of a factory-fresh spare
//! and `recover` of an upload cut by a pulled cable.
//!
//! The pty side runs in real time: the suite's longest test (a hang guard
//! bounds each command; nothing here asserts how long anything took).
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::time::Duration;

use driveset_test_support::{Spawned, copy_dir, driveset, driveset_sim, outcome, workspace_root};

/// Hang guard of one command on either side.
const GUARD: Duration = Duration::from_secs(600);

/// One drive, on both sides.
struct Case {
    name: &'static str,
    /// `driveset sim` arguments (after `--family`).
    family: &'static str,
    address: u8,
    /// The same drive's `sim://` keys beyond `addresses=` (`&`-joined).
    keys: &'static [(&'static str, &'static str)],
    /// The same drive's `driveset sim` options.
    options: &'static [&'static str],
    /// The set uploaded, dry-run and compared live.
    set: &'static str,
    /// The bus protocol (`scan --protocol` on a LECOM line).
    protocol: &'static str,
    /// Served as an slcan adapter (`slcan://PTY`).
    can: bool,
}

/// One side: its directory (a copy of the sets) and its port.
struct Side {
    dir: PathBuf,
    port: String,
}

impl Side {
    fn new(root: &Path, name: &str, port: String) -> Side {
        let dir = root.join(name);
        copy_dir(
            &workspace_root().join("parameter-sets"),
            &dir.join("parameter-sets"),
        );
        std::fs::create_dir_all(dir.join("twins")).unwrap();
        Side { dir, port }
    }

    /// A one-drive line manifest `line.toml` of `case`'s drive on this
    /// side's port (the rehearsal's).
    fn manifest(&self, case: &Case) {
        let (bus, rate) = if case.can {
            ("can", "bitrate = 500000")
        } else {
            (case.protocol, "baud = 9600")
        };
        std::fs::write(
            self.dir.join("line.toml"),
            format!(
                "[line]\nname = \"parity\"\n\n[[bus]]\nname = \"bus\"\nport = \"{}\"\nprotocol = \"{bus}\"\n{rate}\n\n[[drive]]\nname = \"drive\"\nbus = \"bus\"\naddress = {}\nset = \"{}\"\n",
                self.port, case.address, case.set
            ),
        )
        .unwrap();
    }

    /// `driveset ARGS` in the side's directory, `PORT` replaced by its
    /// port: exit code, masked stdout.
    fn run(&self, args: &[&str]) -> (Option<i32>, String, String) {
        let args: Vec<String> = args.iter().map(|a| a.replace("PORT", &self.port)).collect();
        let (code, out, err) = outcome(
            driveset()
                .current_dir(&self.dir)
                .env("DRIVESET_LOCK_DIR", self.dir.join("locks"))
                .env_remove("DRIVESET_SIM_STATE_DIR")
                .args(&args)
                .timeout(GUARD),
        );
        (code, mask(&out, &self.port), err)
    }

    fn file(&self, rel: &str) -> String {
        mask(
            &std::fs::read_to_string(self.dir.join(rel)).unwrap_or_default(),
            &self.port,
        )
    }
}

/// `text` with the port's name as `PORT` (as given, or in a `sim://`
/// port's canonical form; a journal's file, named by its bus, as
/// `JOURNAL`), every measured time (`1.234 s`, `(2586 ms)`, `12.5 ms`) as
/// `T`, a written file's size (`(547 bytes)`: it holds the port's name)
/// and the MC dataset check's SLOAD polls, the retries (and so the
/// telegrams counted: measures of time) as `N`; the count of late replies
/// left out.
fn mask(text: &str, port: &str) -> String {
    let plain = port.strip_prefix("slcan://").unwrap_or(port);
    let mut text = text.replace(port, "PORT").replace(plain, "PORT");
    while let Some(p) = text.find("sim://") {
        let mut end = text[p..]
            .find([' ', ')', ',', ';', '"', '\n'])
            .map_or(text.len(), |e| p + e);
        // `PORT: ...`: the colon after a port is not the port's
        if text[..end].ends_with(':') {
            end -= 1;
        }
        text.replace_range(p..end, "PORT");
    }
    // a line's CAN port as the line runner names it, with its bit rate
    text = text.replace("PORT?bitrate=500000", "PORT");
    let mut out = String::new();
    for line in text.lines() {
        // replies that came after their timeout: how late a real-time
        // pty answers is a measure of time (so are the retries they cost)
        if line.starts_with("late replies: ") {
            continue;
        }
        let parts: Vec<&str> = line.split(' ').collect();
        let mut words = Vec::new();
        for (i, w) in parts.iter().enumerate() {
            let next = parts.get(i + 1).copied().unwrap_or("");
            let unit = next == "s"
                || next == "ms"
                || next.starts_with("s)")
                || next.starts_with("ms)")
                || next.starts_with("s,")
                || next.starts_with("ms,")
                || next.starts_with("ms;");
            let core = w.trim_start_matches('(');
            let numeric = !core.is_empty() && core.chars().all(|c| c.is_ascii_digit() || c == '.');
            if w.contains(".journal.json") {
                words.push("JOURNAL".to_string());
            } else if numeric && (next == "SLOAD" || next == "telegrams," || next == "retries,") {
                // the MC's dataset check polls until the drive is done: how
                // many polls (and so telegrams) is a measure of time
                words.push("N".to_string());
            } else if numeric && next.starts_with("bytes)") {
                words.push(format!("{}N", &w[..w.len() - core.len()]));
            } else if numeric && unit {
                words.push(format!("{}T", &w[..w.len() - core.len()]));
            } else {
                words.push((*w).to_string());
            }
        }
        out.push_str(&words.join(" "));
        out.push('\n');
    }
    out
}

/// `driveset sim` serving `case`'s drive on a pty; its port.
fn serve(case: &Case, dir: &Path) -> (Spawned, String) {
    std::fs::create_dir_all(dir).unwrap();
    let mut args: Vec<String> = vec![
        "--family".into(),
        case.family.into(),
        "--address".into(),
        case.address.to_string(),
        "--pty".into(),
    ];
    args.extend(case.options.iter().map(ToString::to_string));
    let stderr = std::fs::File::create(dir.join("sim.stderr")).unwrap();
    let mut child = driveset_sim(&args, stderr.into());
    let (first, _) = child.first_line();
    let pty = first
        .trim_end()
        .strip_prefix("pty ")
        .unwrap_or_else(|| panic!("first line `{first}`"))
        .to_string();
    let port = if case.can {
        format!("slcan://{pty}")
    } else {
        pty
    };
    (child, port)
}

/// The script, `A` the address.
fn script(case: &Case) -> Vec<Vec<String>> {
    let a = case.address.to_string();
    let mut s: Vec<Vec<&str>> = vec![
        // the line's protocol found by the probes (a LECOM line: named,
        // so the pty side does not wait out 30 LUSTBUS addresses first)
        if case.protocol == "lecom" {
            vec!["scan", "--port", "PORT", "--protocol", case.protocol]
        } else {
            vec!["scan", "--port", "PORT"]
        },
        vec!["identify", "--port", "PORT", "--address", &a],
        vec![
            "pull",
            "--port",
            "PORT",
            "--address",
            &a,
            "-o",
            "pulled/drive.toml",
        ],
    ];
    // a LUSTBUS drive named with the other LUSTBUS family's schema: the
    // family mismatch is identify's finding (exit 1), found the same way
    // on every port
    let other = match case.family {
        "mc6000" => Some("lust-vf1000"),
        "vf1000" => Some("lust-mc6000"),
        _ => None,
    };
    if let Some(other) = other {
        s.push(vec![
            "identify",
            "--port",
            "PORT",
            "--address",
            &a,
            "--schema",
            other,
        ]);
    }
    if !case.can && case.protocol == "lustbus" {
        s.push(vec![
            "schema",
            "pull",
            "--port",
            "PORT",
            "--address",
            &a,
            "-o",
            "schema.toml",
        ]);
    }
    s.extend([
        vec![
            "twin",
            "capture",
            "--port",
            "PORT",
            "--address",
            &a,
            "-o",
            "twins/drive.twin.toml",
        ],
        // the captured twin rehearses the set as the drive would take it
        vec![
            "commission",
            "line.toml",
            "--rehearse",
            "twins",
            "--report-dir",
            "rehearsal",
        ],
        vec!["diff", case.set, "--port", "PORT", "--address", &a],
        vec![
            "upload",
            case.set,
            "--port",
            "PORT",
            "--address",
            &a,
            "--dry-run",
        ],
        vec!["upload", case.set, "--port", "PORT", "--address", &a],
        vec!["diff", case.set, "--port", "PORT", "--address", &a],
    ]);
    s.into_iter()
        .map(|c| c.into_iter().map(str::to_string).collect())
        .collect()
}

fn parity(case: &Case) {
    let root = tempfile::tempdir().unwrap();
    let mut sim_port = format!("sim://{}?addresses={}", case.family, case.address);
    for (k, v) in case.keys {
        sim_port.push_str(&format!("&{k}={v}"));
    }
    let state = root.path().join("sim-side").join("state.json");
    std::fs::create_dir_all(state.parent().unwrap()).unwrap();
    sim_port.push_str(&format!("&state={}", state.display()));
    let sim = Side::new(root.path(), "sim-side", sim_port);
    let (mut server, pty_port) = serve(case, &root.path().join("server"));
    let pty = Side::new(root.path(), "pty-side", pty_port);
    sim.manifest(case);
    pty.manifest(case);
    for cmd in script(case) {
        let args: Vec<&str> = cmd.iter().map(String::as_str).collect();
        let (a_code, a_out, a_err) = sim.run(&args);
        let (b_code, b_out, b_err) = pty.run(&args);
        assert_eq!(
            (a_code, &a_out),
            (b_code, &b_out),
            "{}: `{}`: sim:// and pty differ\nsim:// stderr:\n{a_err}\npty stderr:\n{b_err}",
            case.name,
            args.join(" ")
        );
    }
    assert_eq!(
        sim.file("pulled/drive.toml"),
        pty.file("pulled/drive.toml"),
        "{}: the pulled sets differ",
        case.name
    );
    assert!(!sim.file("pulled/drive.toml").is_empty(), "{}", case.name);

    server.signal("-TERM", Duration::from_secs(30));
}

#[test]
fn parity_mc6000() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity(&Case {
        name: "mc6000",
        family: "mc6000",
        address: 1,
        keys: &[],
        options: &[],
        set: "parameter-sets/mc6000/axis-1.toml",
        protocol: "lustbus",
        can: false,
    });
}

#[test]
fn parity_mc6000_in_the_43_layout_with_table_type_characters() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity(&Case {
        name: "mc6000 layout 43, table",
        family: "mc6000",
        address: 2,
        keys: &[("layout", "43"), ("types", "table")],
        options: &["--layout", "43", "--types", "table"],
        set: "parameter-sets/mc6000/axis-1.toml",
        protocol: "lustbus",
        can: false,
    });
}

#[test]
fn parity_vf1000_whose_description_contradicts_the_spec() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity(&Case {
        name: "vf1000 describe",
        family: "vf1000",
        address: 3,
        keys: &[("describe", "11:actual:binary8")],
        options: &["--describe", "11:actual:binary8"],
        set: "parameter-sets/vf1000/conveyor-1.toml",
        protocol: "lustbus",
        can: false,
    });
}

#[test]
fn parity_tmd() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity(&Case {
        name: "tmd",
        family: "tmd",
        address: 4,
        keys: &[("c0001", "3")],
        options: &["--c0001", "3"],
        set: "parameter-sets/tmd/conveyor-3.toml",
        protocol: "lecom",
        can: false,
    });
}

#[test]
fn parity_ecs_over_slcan() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity(&Case {
        name: "ecs",
        family: "ecs",
        address: 1,
        keys: &[],
        options: &[],
        set: "parameter-sets/ecs/axis-1.toml",
        protocol: "sdo",
        can: true,
    });
}

/// A factory-fresh MC6000 given its address: the bus codes' types come
/// from the drive's own descriptions (the built-in schema has none), the
/// same on both sides.
#[test]
fn parity_address_on_a_factory_fresh_mc6000() {
    let _one = crate::e2e_pty::one_at_a_time();
    let root = tempfile::tempdir().unwrap();
    let state = root.path().join("sim-side").join("state.json");
    std::fs::create_dir_all(state.parent().unwrap()).unwrap();
    let sim = Side::new(
        root.path(),
        "sim-side",
        format!("sim://mc6000?factory=1&state={}", state.display()),
    );
    let mut server = driveset_sim(
        &["--family", "mc6000", "--factory", "1", "--pty"],
        std::process::Stdio::null(),
    );
    let (first, _) = server.first_line();
    let pty = Side::new(
        root.path(),
        "pty-side",
        first.trim_end().trim_start_matches("pty ").to_string(),
    );
    for args in [
        vec![
            "address",
            "--port",
            "PORT",
            "--protocol",
            "lustbus",
            "--to",
            "5",
            "--dry-run",
        ],
        vec![
            "address",
            "--port",
            "PORT",
            "--protocol",
            "lustbus",
            "--to",
            "5",
        ],
        vec!["identify", "--port", "PORT", "--address", "5"],
    ] {
        let (a_code, a_out, a_err) = sim.run(&args);
        let (b_code, b_out, b_err) = pty.run(&args);
        assert_eq!(
            (a_code, &a_out),
            (b_code, &b_out),
            "`{}`: sim:// and pty differ\nsim:// stderr:\n{a_err}\npty stderr:\n{b_err}",
            args.join(" ")
        );
        assert_eq!(a_code, Some(0), "{a_out}{a_err}");
    }
    server.signal("-TERM", Duration::from_secs(30));
}

/// A drive for the line commands' parity: a factory-fresh spare that
/// `replace` makes a demo-line drive, and a drive whose upload a pulled
/// cable cuts and `recover` settles.
struct LineCase {
    name: &'static str,
    /// The spare's family and its `driveset sim` / `sim://` extras.
    spare: &'static str,
    spare_keys: &'static [(&'static str, &'static str)],
    spare_options: &'static [&'static str],
    /// The demo line's drive the spare becomes.
    drive: &'static str,
    /// The drive whose upload is cut, its address and set.
    cut_family: &'static str,
    cut_address: u8,
    cut_keys: &'static [(&'static str, &'static str)],
    cut_options: &'static [&'static str],
    cut_set: &'static str,
    /// The pulled cable: at host telegram N (mid-write), for 20 s.
    cable: &'static str,
}

/// `driveset sim` of `family` with `options` on a pty; its port.
fn serve_line(family: &str, options: &[&str], dir: &Path, name: &str) -> (Spawned, String) {
    std::fs::create_dir_all(dir).unwrap();
    let mut args: Vec<String> = vec!["--family".into(), family.into()];
    args.extend(options.iter().map(ToString::to_string));
    args.push("--pty".into());
    let stderr = std::fs::File::create(dir.join(format!("{name}.stderr"))).unwrap();
    let mut child = driveset_sim(&args, stderr.into());
    let (first, _) = child.first_line();
    let pty = first
        .trim_end()
        .strip_prefix("pty ")
        .unwrap_or_else(|| panic!("first line `{first}`"))
        .to_string();
    (child, pty)
}

/// `sim://FAMILY?KEYS&state=DIR/NAME.json`.
fn sim_port(family: &str, keys: &[(&str, &str)], dir: &Path, name: &str) -> String {
    let mut p = format!("sim://{family}?");
    for (k, v) in keys {
        p.push_str(&format!("{k}={v}&"));
    }
    p.push_str(&format!(
        "state={}",
        dir.join(format!("{name}.json")).display()
    ));
    p
}

/// Runs `args` on both sides and asserts the same exit code and masked
/// stdout (`drop` lines left out of both: what only one transport says);
/// the exit code.
fn same(case: &str, sim: &Side, pty: &Side, args: &[&str], drop: &str) -> Option<i32> {
    let (a_code, a_out, a_err) = sim.run(args);
    let (b_code, b_out, b_err) = pty.run(args);
    let keep = |t: &str| {
        t.lines()
            .filter(|l| drop.is_empty() || !l.starts_with(drop))
            .map(|l| format!("{l}\n"))
            .collect::<String>()
    };
    assert_eq!(
        (a_code, keep(&a_out)),
        (b_code, keep(&b_out)),
        "{case}: `{}`: sim:// and pty differ\nsim:// stderr:\n{a_err}\npty stderr:\n{b_err}",
        args.join(" ")
    );
    a_code
}

/// `replace` of a factory-fresh spare alone on its port (it proves the
/// port holds exactly one device first), and an upload cut by a pulled
/// cable mid-write (exit 3, a journal with a mix of old and new values)
/// then `recover` of its journal (rolled back), on `sim://` and on a pty.
fn parity_line(case: &LineCase) {
    let root = tempfile::tempdir().unwrap();
    let states = root.path().join("states");
    std::fs::create_dir_all(&states).unwrap();

    let (mut spare_server, spare_pty) = serve_line(
        case.spare,
        case.spare_options,
        &root.path().join("server"),
        "spare",
    );
    let sim = Side::new(
        root.path(),
        "sim-spare",
        sim_port(case.spare, case.spare_keys, &states, "spare"),
    );
    let pty = Side::new(root.path(), "pty-spare", spare_pty);
    let code = same(
        case.name,
        &sim,
        &pty,
        &[
            "replace",
            "parameter-sets/demo-line/line.toml",
            "--drive",
            case.drive,
            "--port",
            "PORT",
            "--yes",
        ],
        "",
    );
    assert_eq!(code, Some(0), "{}: replace", case.name);
    spare_server.signal("-TERM", Duration::from_secs(30));

    let cut_options: Vec<&str> = case
        .cut_options
        .iter()
        .copied()
        .chain(["--faults", case.cable])
        .collect();
    let (mut cut_server, cut_pty) = serve_line(
        case.cut_family,
        &cut_options,
        &root.path().join("server"),
        "cut",
    );
    let mut keys = case.cut_keys.to_vec();
    keys.push(("faults", case.cable));
    let sim = Side::new(
        root.path(),
        "sim-cut",
        sim_port(case.cut_family, &keys, &states, "cut"),
    );
    let pty = Side::new(root.path(), "pty-cut", cut_pty);
    let a = case.cut_address.to_string();
    let code = same(
        case.name,
        &sim,
        &pty,
        &[
            "upload",
            case.cut_set,
            "--port",
            "PORT",
            "--address",
            &a,
            "--journal",
            "cut.journal.json",
        ],
        "",
    );
    assert_eq!(code, Some(3), "{}: the cut upload", case.name);
    // the pty's cable is back after its 20 s (the `sim://` side recovers
    // through its port without the run's faults). The outage outlasts the
    // cut upload's rollback on both sides: with 5 s a loaded machine's pty
    // run took longer than the outage, its rollback reached the drive and
    // the outcomes differed (rolled back there, "a mix" on `sim://`)
    std::thread::sleep(Duration::from_millis(20_500));
    let code = same(
        case.name,
        &sim,
        &pty,
        &["recover", "cut.journal.json"],
        // only a `sim://` port carries its faults in its string: its
        // journal's port differs from the one recover reaches it by
        "note: the journal was written through ",
    );
    assert_eq!(code, Some(0), "{}: recover", case.name);
    assert!(
        sim.file("cut.journal.json")
            .contains("\"state\": \"rolled-back\""),
        "{}",
        sim.file("cut.journal.json")
    );
    cut_server.signal("-TERM", Duration::from_secs(30));
}

/// LUSTBUS: an MC6000 spare becomes press-axis-3; a VF1000 upload cut.
#[test]
fn parity_replace_and_recover_on_lustbus() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity_line(&LineCase {
        name: "lustbus",
        spare: "mc6000",
        spare_keys: &[("factory", "1")],
        spare_options: &["--factory", "1"],
        drive: "press-axis-3",
        cut_family: "vf1000",
        cut_address: 4,
        cut_keys: &[("addresses", "4")],
        cut_options: &["--address", "4"],
        cut_set: "parameter-sets/vf1000/conveyor-1.toml",
        cable: "cable@48+20s",
    });
}

/// LECOM: a Tmd spare (C0001 = 3) becomes transfer-11; a Tmd upload cut.
#[test]
fn parity_replace_and_recover_on_lecom() {
    let _one = crate::e2e_pty::one_at_a_time();
    parity_line(&LineCase {
        name: "lecom",
        spare: "tmd",
        spare_keys: &[("factory", "1"), ("c0001", "3")],
        spare_options: &["--factory", "1", "--c0001", "3"],
        drive: "transfer-11",
        cut_family: "tmd",
        cut_address: 4,
        cut_keys: &[("addresses", "4"), ("c0001", "3")],
        cut_options: &["--address", "4", "--c0001", "3"],
        cut_set: "parameter-sets/tmd/conveyor-3.toml",
        cable: "cable@30+20s",
    });
}
