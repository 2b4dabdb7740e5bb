//! Issue 11's table in real time: `driveset upload` and `driveset diff SET
//! --port` for every serial family (MC6000 with the SLOAD dataset download,
//! Tmd over LECOM, VF1000 with its EEPROM ACK delays) against `driveset sim
//! --tcp`, through the [`crate::proxy`] that behaves like the hardware in
//! between: none, 16 ms +- 4 ms each way (an FTDI adapter's latency timer),
//! 40 ms +- 10 ms (a serial device server), 3 ms with every byte echoed (a
//! 2-wire RS-485 adapter: stripped by the link's `?echo=auto`), 5 ms forwarded
//! two bytes at a time, and 100 ms +- 20 ms. Short sets (four codes,
//! `tests/data/sets/latency/`), so the suite stays fast; the full sets in
//! the ignored [`full_sets_through_a_device_server`].
//!
//! Every case asserts exit code 0 for both commands, the drive's exact
//! final values from the simulator's `--dump` (the set's canonical lines),
//! and that the upload verified every code it wrote. Nothing asserts how
//! long anything took; the clients size their answer timeouts from the
//! link's measured round trips (engine `client::timing`).
#![cfg(unix)]

use std::net::SocketAddr;
use std::path::PathBuf;

use crate::e2e_pty::{Sim, dump_subset, load, run};
use crate::proxy::{PtyProxy, Shape, TcpProxy};

/// A family as the simulator names it, its drive's address and a set.
struct Family {
    sim: &'static str,
    address: u8,
    set: &'static str,
    /// Extra `driveset sim` arguments (the Tmd: C0001 = 3 at the keypad,
    /// so LECOM may write, manual §4e).
    sim_args: &'static [&'static str],
}

const MC6000: Family = Family {
    sim: "mc6000",
    address: 1,
    set: "tests/data/sets/latency/mc6000.toml",
    sim_args: &[],
};
const TMD: Family = Family {
    sim: "tmd",
    address: 13,
    set: "tests/data/sets/latency/tmd.toml",
    sim_args: &["--c0001", "3"],
};
const VF1000: Family = Family {
    sim: "vf1000",
    address: 4,
    set: "tests/data/sets/latency/vf1000.toml",
    sim_args: &[],
};

/// Where the proxy sits: between `--port` and the simulator's TCP port or
/// its pty.
enum Via {
    Tcp,
    Pty,
}

/// Upload `family.set` (or `set`) through a proxy shaped `shape`, diff it
/// live, stop the simulator and compare its dump with the set. Returns the
/// upload's stdout.
fn through(family: &Family, set_rel: &str, shape: Shape, via: Via, query: &str) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let set = load(set_rel);
    let (mut sim, tcp, pty);
    let port = match via {
        Via::Tcp => {
            sim = Sim::start_tcp(dir.path(), family.sim, family.address, family.sim_args);
            let target: SocketAddr = sim.path.parse().expect("sim address");
            tcp = TcpProxy::start(target, shape);
            tcp.port(query)
        }
        Via::Pty => {
            sim = Sim::start(dir.path(), family.sim, family.address, family.sim_args);
            pty = PtyProxy::start(&sim.path, shape);
            pty.port(query)
        }
    };
    let addr = family.address.to_string();
    let journal_dir = dir.path().join("journal");
    let journal_dir: PathBuf = journal_dir;
    let journal_arg = journal_dir.to_string_lossy().into_owned();
    let (code, stdout, stderr) = run(&[
        "upload",
        set_rel,
        "--port",
        &port,
        "--address",
        &addr,
        "--journal-dir",
        &journal_arg,
    ]);
    let context = |what: &str, out: &str, err: &str| {
        format!(
            "{what} through {shape:?}\n--- stdout\n{out}\n--- stderr\n{err}\n--- sim stderr\n{}",
            sim.stderr()
        )
    };
    assert_eq!(code, Some(0), "{}", context("upload", &stdout, &stderr));
    let head = stdout.lines().next().unwrap_or_default();
    assert!(
        head.contains(&format!("address {}: complete (", family.address)),
        "{}",
        context("upload", &stdout, &stderr)
    );
    let written: usize = head
        .split_once("complete (")
        .and_then(|(_, r)| r.split_once(' '))
        .and_then(|(w, _)| w.parse().ok())
        .expect("codes written");
    let verified = stdout.lines().filter(|l| l.ends_with("  verified")).count();
    assert_eq!(verified, written, "{}", context("upload", &stdout, &stderr));
    assert!(
        stdout
            .lines()
            .any(|l| l == format!("after:  {}", set.fingerprint())),
        "the drive holds the set's fingerprint\n{}",
        context("upload", &stdout, &stderr)
    );

    let (code, diff_out, diff_err) = run(&["diff", set_rel, "--port", &port, "--address", &addr]);
    assert_eq!(code, Some(0), "{}", context("diff", &diff_out, &diff_err));
    assert!(
        diff_out.contains("no differences"),
        "{}",
        context("diff", &diff_out, &diff_err)
    );

    let status = sim.terminate();
    assert!(status.success(), "{status}\n{}", sim.stderr());
    let dump: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join(format!("{}.dump.json", family.sim)))
            .expect("dump written"),
    )
    .expect("dump JSON");
    assert_eq!(
        dump_subset(&dump, family.address, &set),
        set.canonical(),
        "the drive's values of the set's codes after the upload through {shape:?}"
    );
    stdout
}

fn short(family: &Family, shape: Shape) -> String {
    through(family, family.set, shape, Via::Tcp, "")
}

/// The MC6000 runs through the dataset download; its poll count is in the
/// report.
fn mc6000_short(shape: Shape) {
    let stdout = short(&MC6000, shape);
    assert!(
        stdout.lines().any(|l| l == "dataset: accepted (SLOAD = 0)"),
        "{stdout}"
    );
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("dataset check: ") && l.ends_with(" SLOAD poll(s)")),
        "{stdout}"
    );
}

const NONE: Shape = Shape::direct();
const FTDI: Shape = Shape::delay(16, 4);
const DEVICE_SERVER: Shape = Shape::delay(40, 10);
const ECHO: Shape = Shape::delay(3, 0).echoing();
const FRAGMENTED: Shape = Shape::delay(5, 0).fragmented(2);
const FAR: Shape = Shape::delay(100, 20);

#[test]
fn mc6000_direct() {
    mc6000_short(NONE);
}

#[test]
fn mc6000_through_an_ftdi_latency_timer_16ms() {
    mc6000_short(FTDI);
}

#[test]
fn mc6000_through_a_device_server_40ms() {
    mc6000_short(DEVICE_SERVER);
}

#[test]
fn mc6000_fragmented_5ms() {
    mc6000_short(FRAGMENTED);
}

#[test]
fn mc6000_far_100ms() {
    mc6000_short(FAR);
}

#[test]
fn tmd_direct() {
    short(&TMD, NONE);
}

#[test]
fn tmd_through_an_ftdi_latency_timer_16ms() {
    short(&TMD, FTDI);
}

#[test]
fn tmd_through_a_device_server_40ms() {
    short(&TMD, DEVICE_SERVER);
}

#[test]
fn tmd_fragmented_5ms() {
    short(&TMD, FRAGMENTED);
}

#[test]
fn tmd_far_100ms() {
    short(&TMD, FAR);
}

#[test]
fn vf1000_direct() {
    short(&VF1000, NONE);
}

#[test]
fn vf1000_through_an_ftdi_latency_timer_16ms() {
    short(&VF1000, FTDI);
}

#[test]
fn vf1000_through_a_device_server_40ms() {
    short(&VF1000, DEVICE_SERVER);
}

#[test]
fn vf1000_fragmented_5ms() {
    short(&VF1000, FRAGMENTED);
}

#[test]
fn vf1000_far_100ms() {
    short(&VF1000, FAR);
}

/// The pty variant of the proxy: `--port /dev/pts/N` (a real serial port
/// to driveset) 16 ms +- 4 ms each way from the simulator's pty, merging
/// what arrives within 2 ms, as a USB adapter's latency timer does.
#[test]
fn mc6000_through_a_pty_proxy_16ms_merged() {
    let stdout = through(
        &MC6000,
        MC6000.set,
        FTDI.merging(std::time::Duration::from_millis(2)),
        Via::Pty,
        "",
    );
    assert!(
        stdout.lines().any(|l| l == "dataset: accepted (SLOAD = 0)"),
        "{stdout}"
    );
}

/// The port option: `?latency=` sizes the timeouts from the first telegram
/// on (no first-contact guess needed).
#[test]
fn tmd_with_a_given_latency_through_100ms() {
    through(&TMD, TMD.set, FAR, Via::Tcp, "?latency=240ms");
}

// The echo row (3 ms, every byte sent comes back): the link-level echo
// stripping (`?echo=auto`, the default) removes the master's own bytes.
#[test]
fn mc6000_with_echo_3ms() {
    mc6000_short(ECHO);
}

#[test]
fn tmd_with_echo_3ms() {
    short(&TMD, ECHO);
}

#[test]
fn vf1000_with_echo_3ms() {
    short(&VF1000, ECHO);
}

/// The full sets (MC6000 axis-1: 195 codes; Tmd conveyor-3; VF1000
/// conveyor-1) through 40 ms +- 10 ms and 100 ms +- 20 ms: several minutes
/// of real time. Run with `--ignored` (TESTING.md).
#[test]
#[ignore = "long real-time run (minutes): the full sets through 40 ms and 100 ms each way"]
fn full_sets_through_a_device_server() {
    for shape in [DEVICE_SERVER, FAR] {
        through(
            &MC6000,
            "parameter-sets/mc6000/axis-1.toml",
            shape,
            Via::Tcp,
            "",
        );
        through(
            &TMD,
            "parameter-sets/tmd/conveyor-3.toml",
            shape,
            Via::Tcp,
            "",
        );
        through(
            &VF1000,
            "parameter-sets/vf1000/conveyor-1.toml",
            shape,
            Via::Tcp,
            "",
        );
    }
}

/// Issue 28: a manifest's bus port carries its `?latency=` into every
/// connection of the line run, as a one-drive command's port does. A Tmd
/// behind a device server 150 ms away each way: with `latency=600ms` the
/// first telegram already waits long enough (no repetition); before, the
/// line runner connected with the default options, the first telegram
/// timed out after the first-contact allowance and was repeated.
#[test]
fn a_line_bus_port_carries_its_latency_into_the_run() {
    let _serial = crate::e2e_pty::one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let mut sim = Sim::start_tcp(d, TMD.sim, TMD.address, TMD.sim_args);
    let target: SocketAddr = sim.path.parse().expect("sim address");
    let proxy = TcpProxy::start(target, Shape::delay(150, 0));
    let port = proxy.port("?latency=600ms");
    std::fs::create_dir_all(d.join("sets")).unwrap();
    std::fs::write(
        d.join("sets/conveyor-13.toml"),
        "schema = \"lenze-tmd\"\ntitle = \"conveyor\"\n\n[values]\nC0010 = \"5.0 Hz\"\nC0011 = \"60.0 Hz\"\n",
    )
    .unwrap();
    std::fs::write(
        d.join("line.toml"),
        format!(
            "[line]\nname = \"far\"\n\n[[bus]]\nname = \"far\"\nport = \"{port}\"\nprotocol = \"lecom\"\nbaud = 9600\n\n[[drive]]\nname = \"conveyor-13\"\nbus = \"far\"\naddress = 13\nset = \"sets/conveyor-13.toml\"\n"
        ),
    )
    .unwrap();
    let (code, out, err) =
        driveset_test_support::outcome(driveset_test_support::driveset_at(d).args([
            "status",
            "line.toml",
            "--report-dir",
            "r",
        ]));
    // the drive differs from its set (factory values): exit 1, reached
    assert_eq!(code, Some(1), "{out}\n{err}\n{}", sim.stderr());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r/report.json")).unwrap()).unwrap();
    let drive = &report["drives"][0];
    assert_eq!(drive["result"], "drift", "{report}");
    assert!(drive["telegrams"].as_u64().unwrap() > 0, "{report}");
    assert_eq!(drive["retries"], 0, "{report}");
    drop(proxy);
    assert!(sim.terminate().success());
}
