//! `driveset sim`: the real binary serving simulated drives on TCP and on a
//! pty, stopped with SIGTERM; the first stdout line, exact reply bytes, the
//! event log, the dump, and argument errors.

use std::io::{BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, ChildStdout, ExitStatus, Stdio};
use std::time::Duration;

use driveset_test_support::{Spawned, driveset, driveset_sim, read_until};

const STX: u8 = 0x02;
const ETX: u8 = 0x03;
const EOT: u8 = 0x04;
const ENQ: u8 = 0x05;

/// A running `driveset sim`; killed if a test fails before stopping it.
struct Sim {
    child: Spawned,
    _stdout: BufReader<ChildStdout>,
    first_line: String,
}

impl Sim {
    fn start(args: &[&str]) -> Sim {
        let mut child = driveset_sim(args, Stdio::piped());
        let (mut first_line, stdout) = child.first_line();
        assert!(
            first_line.ends_with('\n'),
            "no first line; stderr: {}",
            stderr_of(&mut child)
        );
        first_line.pop();
        Sim {
            child,
            _stdout: stdout,
            first_line,
        }
    }

    /// SIGTERM, then wait (bounded) for the exit.
    fn terminate(&mut self, within: Duration) -> (ExitStatus, String) {
        self.signal("-TERM", within)
    }

    /// Send `signal` (`-TERM`, `-INT`), then wait (bounded) for the exit.
    fn signal(&mut self, signal: &str, within: Duration) -> (ExitStatus, String) {
        let status = self.child.signal(signal, within);
        (status, stderr_of(&mut self.child))
    }
}

fn stderr_of(child: &mut Child) -> String {
    let mut s = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut s);
    }
    s
}

fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()))
}

/// The log's lines, each parsed.
fn log_lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn tcp_mc6000_first_enquiry_of_85_reports_power_on_then_dumps_on_sigterm() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bus.jsonl");
    let dump = dir.path().join("dump.json");
    let mut sim = Sim::start(&[
        "--family",
        "mc6000",
        "--address",
        "1",
        "--tcp",
        "127.0.0.1:0",
        "--log",
        log.to_str().unwrap(),
        "--dump",
        dump.to_str().unwrap(),
    ]);
    let addr = sim
        .first_line
        .strip_prefix("tcp ")
        .unwrap_or_else(|| panic!("first line `{}`", sim.first_line));
    assert!(addr.starts_with("127.0.0.1:"), "{addr}");
    assert!(!addr.ends_with(":0"), "{addr}");

    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    // LUSTBUS 6.1.1.2 ENQUIRY: EOT ADR CODE ENQ, drive 1 ('A'), SERR (85).
    s.write_all(&[EOT, b'A', b'0', b'0', b'0', b'8', b'5', ENQ])
        .unwrap();
    let reply = read_until(&mut s, 12, Duration::from_secs(3));
    // ADR STX 00085 = 01 ETX BCC: the power-on bit; BCC = XOR of
    // "00085=01" and ETX.
    assert_eq!(reply, b"A\x0200085=01\x03\x02");
    // The read cleared it.
    s.write_all(&[EOT, b'A', b'0', b'0', b'0', b'8', b'5', ENQ])
        .unwrap();
    assert_eq!(
        read_until(&mut s, 12, Duration::from_secs(3)),
        b"A\x0200085=00\x03\x03"
    );
    drop(s);

    let (status, stderr) = sim.terminate(Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("serving 1 simulated mc6000 drive"),
        "{stderr}"
    );

    let d = read_json(&dump);
    assert_eq!(d["format"], "driveset-sim-state 1");
    assert_eq!(d["family"], "mc6000");
    let drive = &d["drives"][0];
    assert_eq!(drive["family"], "mc6000");
    assert_eq!(drive["address"], 1);
    assert_eq!(drive["schema"], "fictional-mc6000-demo");
    let fp = drive["fingerprint"].as_str().unwrap();
    assert!(fp.starts_with("sha256:") && fp.len() == 71, "{fp}");
    let canonical = drive["canonical"].as_str().unwrap();
    assert!(
        canonical.starts_with("driveset-canonical 1\n"),
        "{canonical}"
    );
    assert!(canonical.contains("\n85 0\n"), "SERR cleared: {canonical}");

    let lines = log_lines(&log);
    let host: Vec<_> = lines.iter().filter(|l| l["dir"] == "host").collect();
    assert_eq!(host.len(), 2, "{lines:?}");
    assert_eq!(host[0]["hex"], "04 41 30 30 30 38 35 05");
    assert_eq!(host[0]["text"], "<EOT>A00085<ENQ>");
    let replies: Vec<_> = lines.iter().filter(|l| l["dir"] == "drive").collect();
    assert_eq!(replies.len(), 2, "{lines:?}");
    assert_eq!(replies[0]["addr"], 1);
    assert_eq!(replies[0]["hex"], "41 02 30 30 30 38 35 3D 30 31 03 02");
    assert!(lines.iter().any(|l| l["fault"] == "connect"));
}

#[cfg(unix)]
#[test]
fn pty_tmd_receive_of_c46_answers_the_manuals_example() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dir.path().join("dump.json");
    let state = dir.path().join("state.json");

    // A state file where C46 holds 35.4 Hz (raw 354000, VD x 10000), as in
    // the manual's example 8.H b: factory state with that line changed.
    let factory = dir.path().join("factory.json");
    let mut first = Sim::start(&[
        "--family",
        "tmd",
        "--address",
        "1",
        "--dump",
        factory.to_str().unwrap(),
    ]);
    assert!(
        first.first_line.starts_with("pty /dev/"),
        "{}",
        first.first_line
    );
    let (status, stderr) = first.terminate(Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
    let mut d = read_json(&factory);
    let canonical = d["drives"][0]["canonical"].as_str().unwrap().to_string();
    let c46 = canonical
        .lines()
        .find(|l| l.starts_with("C0046 "))
        .expect("C0046 in the Tmd state")
        .to_string();
    d["drives"][0]["canonical"] = canonical.replace(&c46, "C0046 354000").into();
    std::fs::write(&state, serde_json::to_string(&d).unwrap()).unwrap();

    let mut sim = Sim::start(&[
        "--family",
        "tmd",
        "--address",
        "1",
        "--pty",
        "--state",
        state.to_str().unwrap(),
        "--dump",
        dump.to_str().unwrap(),
    ]);
    let path = sim
        .first_line
        .strip_prefix("pty ")
        .unwrap_or_else(|| panic!("first line `{}`", sim.first_line))
        .to_string();
    let mut port = serialport::new(&path, 9600)
        .timeout(Duration::from_millis(50))
        .open()
        .unwrap_or_else(|e| panic!("open {path}: {e}"));
    // LECOM 8.H: EOT AD1 AD2 C1 C2 ENQ.
    port.write_all(&[EOT, b'0', b'1', b'4', b'6', ENQ]).unwrap();
    let reply = read_until(&mut port, 9, Duration::from_secs(3));
    // STX 4 6 3 5 . 4 ETX BCC, BCC = XOR of "4635.4" and ETX.
    let bcc = b"4635.4".iter().fold(ETX, |a, b| a ^ b);
    assert_eq!(bcc, 0x1D);
    assert_eq!(
        reply,
        [STX, b'4', b'6', b'3', b'5', b'.', b'4', ETX, bcc],
        "{:?}",
        String::from_utf8_lossy(&reply)
    );
    drop(port);

    let (status, stderr) = sim.terminate(Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
    let out = read_json(&dump);
    let drive = &out["drives"][0];
    assert_eq!(
        (drive["family"].as_str(), drive["address"].as_u64()),
        (Some("tmd"), Some(1))
    );
    assert!(
        drive["canonical"]
            .as_str()
            .unwrap()
            .contains("\nC0046 354000\n")
    );
    // The state file was written back with the same drive.
    let saved = read_json(&state);
    assert_eq!(saved["drives"][0]["fingerprint"], drive["fingerprint"]);
    assert_ne!(
        drive["fingerprint"],
        read_json(&factory)["drives"][0]["fingerprint"],
        "C46 differs from factory"
    );
}

#[cfg(unix)]
#[test]
fn pty_ecs_serves_an_slcan_adapter() {
    let mut sim = Sim::start(&["--family", "ecs", "--address", "5", "--pty"]);
    let path = sim.first_line.strip_prefix("pty ").unwrap().to_string();
    let mut port = serialport::new(&path, 115_200)
        .timeout(Duration::from_millis(50))
        .open()
        .unwrap();
    port.write_all(b"C\rS6\rO\r").unwrap();
    assert_eq!(read_until(&mut port, 3, Duration::from_secs(3)), b"\r\r\r");
    // SDO upload request of C0001 (index 0x5FFE) to node 5.
    port.write_all(b"t605840FE5F0000000000\r").unwrap();
    let got = read_until(&mut port, 2 + 22, Duration::from_secs(3));
    let text = String::from_utf8_lossy(&got);
    assert!(text.starts_with("z\rt5858"), "{text:?}");
    drop(port);
    // Ctrl-C stops it as cleanly as SIGTERM.
    let (status, stderr) = sim.signal("-INT", Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
}

#[test]
fn bad_arguments_exit_2_with_the_reason() {
    for (args, message) in [
        (
            &["--family", "s7", "--address", "1"][..],
            "unknown drive family `s7`",
        ),
        (&["--family", "mc6000", "--address", "31"], "1..=30"),
        (&["--family", "vf1000", "--address", "0"], "1..=30"),
        (&["--family", "tmd", "--address", "20"], "10, 20, ... 90"),
        (&["--family", "tmd", "--address", "1,1"], "given twice"),
        (&["--family", "ecs", "--address", "128"], "1..=127"),
        (
            &["--family", "ecs", "--address", "300"],
            "invalid value '300'",
        ),
        (
            &["--family", "mc6000", "--address", "1", "--baud", "1000"],
            "1000 baud is not supported",
        ),
        (
            &["--family", "ecs", "--address", "1", "--bitrate", "33000"],
            "CAN bit rate 33000 is not supported",
        ),
        (
            &["--family", "ecs", "--address", "1", "--baud", "9600"],
            "give the bus rate with --bitrate",
        ),
        (
            &[
                "--family",
                "vf1000",
                "--address",
                "1",
                "--bitrate",
                "500000",
            ],
            "give its rate with --baud",
        ),
        (
            &["--family", "tmd", "--address", "1", "--faults", "lose=2"],
            "--faults: invalid fault item `lose=2`",
        ),
        (
            &["--family", "ecs", "--address", "1", "--tcp", "4001"],
            "use --pty",
        ),
        (
            &["--family", "tmd", "--address", "1", "--tcp", "localhost"],
            "give PORT or IP:PORT",
        ),
        (
            &["--family", "tmd", "--address", "1", "--tcp", "1", "--pty"],
            "cannot be used with",
        ),
        (&["--family", "tmd"], "--address"),
    ] {
        let out = driveset().arg("sim").args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
}

#[test]
fn tcp_clients_wait_their_turn_and_an_idle_one_is_dropped() {
    let mut sim = Sim::start(&[
        "--family",
        "mc6000",
        "--address",
        "1",
        "--tcp",
        "127.0.0.1:0",
        "--idle-timeout",
        "1",
    ]);
    let addr = sim
        .first_line
        .strip_prefix("tcp ")
        .unwrap_or_else(|| panic!("first line `{}`", sim.first_line))
        .to_string();
    // The first client connects and says nothing; the second waits.
    let idle = TcpStream::connect(&addr).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let mut second = TcpStream::connect(&addr).unwrap();
    second
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    second
        .write_all(&[EOT, b'A', b'0', b'0', b'0', b'8', b'5', ENQ])
        .unwrap();
    // Served once the first is dropped after 1 s of silence (hang guard 20 s).
    let reply = read_until(&mut second, 12, Duration::from_secs(20));
    assert_eq!(reply, b"A\x0200085=01\x03\x02");
    let idle_addr = idle.local_addr().unwrap();
    let second_addr = second.local_addr().unwrap();
    drop(second);
    let (status, stderr) = sim.terminate(Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("(one connection at a time, others wait; idle clients dropped after 1 s)"),
        "{stderr}"
    );
    for line in [
        format!("sim: host connected from {idle_addr}\n"),
        format!("sim: host {second_addr} waits: the line is in use by {idle_addr}\n"),
        format!("sim: host {idle_addr} dropped: sent nothing for 1000 ms (idle timeout)\n"),
        format!("sim: host {second_addr} closed the connection\n"),
    ] {
        assert!(stderr.contains(&line), "{line}\n{stderr}");
    }
    assert!(
        stderr.contains(&format!("sim: host connected from {second_addr} (waited ")),
        "{stderr}"
    );
    drop(idle);
}

#[test]
fn idle_timeout_needs_tcp() {
    driveset()
        .args([
            "sim",
            "--family",
            "mc6000",
            "--address",
            "1",
            "--idle-timeout",
            "5",
        ])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("--tcp"));
}

#[test]
fn pty_tmd_log_is_0600_and_masks_a_password_across_chunks() {
    use std::os::unix::fs::PermissionsExt as _;
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bus.jsonl");
    // an existing, world-readable log file is restricted too
    std::fs::write(&log, "old").unwrap();
    std::fs::set_permissions(&log, std::fs::Permissions::from_mode(0o644)).unwrap();
    let mut sim = Sim::start(&[
        "--family",
        "tmd",
        "--address",
        "1",
        "--c0001",
        "3",
        "--pty",
        "--log",
        log.to_str().unwrap(),
    ]);
    let path = sim.first_line.strip_prefix("pty ").unwrap().to_string();
    let mut port = serialport::new(&path, 9600)
        .timeout(Duration::from_millis(50))
        .open()
        .unwrap_or_else(|e| panic!("open {path}: {e}"));
    // SEND C0094 (user password) = 77 in two writes: the simulator may
    // read it in two chunks; the mask follows the telegram across them
    // and shows `***` whatever the password's length (issue 29)
    let bcc = b"9477".iter().fold(ETX, |a, b| a ^ b);
    port.write_all(&[EOT, b'0', b'1', STX, b'9', b'4']).unwrap();
    port.flush().unwrap();
    std::thread::sleep(Duration::from_millis(100));
    port.write_all(&[b'7', b'7', ETX, bcc]).unwrap();
    assert_eq!(
        read_until(&mut port, 1, Duration::from_secs(3)),
        [0x06],
        "ACK"
    );
    // RECEIVE C0094: the drive answers with the value
    port.write_all(&[EOT, b'0', b'1', b'9', b'4', ENQ]).unwrap();
    assert_eq!(
        read_until(&mut port, 7, Duration::from_secs(3)),
        [STX, b'9', b'4', b'7', b'7', ETX, bcc],
        "the wire carries the value (only the log masks it)"
    );
    drop(port);
    let (status, stderr) = sim.terminate(Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
    let mode = std::fs::metadata(&log).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o600);
    let lines = log_lines(&log);
    // the bytes' fields (t_ns may hold any digits)
    for l in &lines {
        for field in ["hex", "text", "detail"] {
            let v = l[field].as_str().unwrap_or("");
            assert!(!v.contains("9477") && !v.contains("37 37"), "{l}");
        }
    }
    let host: String = lines
        .iter()
        .filter(|l| l["dir"] == "host")
        .map(|l| l["text"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(host, "<EOT>01<STX>94***<ETX>*<EOT>0194<ENQ>");
    let drive: Vec<&str> = lines
        .iter()
        .filter(|l| l["dir"] == "drive")
        .map(|l| l["text"].as_str().unwrap())
        .collect();
    assert_eq!(drive, ["<ACK>", "<STX>94***<ETX>*"]);
}

/// `--factory 2`: two factory-fresh MC6000 at the factory address 1 (docs/ports.md);
/// an ENQUIRY to 1 gets their colliding answers, never the valid one; the
/// dump names each drive's slot.
#[test]
fn tcp_two_factory_mc6000_answer_address_1_with_garbage_and_dump_their_slots() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bus.jsonl");
    let dump = dir.path().join("dump.json");
    let mut sim = Sim::start(&[
        "--family",
        "mc6000",
        "--factory",
        "2",
        "--tcp",
        "127.0.0.1:0",
        "--log",
        log.to_str().unwrap(),
        "--dump",
        dump.to_str().unwrap(),
    ]);
    let addr = sim.first_line.strip_prefix("tcp ").unwrap().to_string();
    let mut s = TcpStream::connect(&addr).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    s.write_all(&[EOT, b'A', b'0', b'0', b'0', b'8', b'5', ENQ])
        .unwrap();
    let reply = read_until(&mut s, 64, Duration::from_secs(1));
    assert!(!reply.is_empty());
    assert_ne!(reply, b"A\x0200085=01\x03\x02");
    drop(s);
    let (status, stderr) = sim.terminate(Duration::from_secs(5));
    assert_eq!(status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "serving 2 simulated mc6000 drives (addresses 1, 1; 2 factory-fresh) at 9600 baud 7E1"
        ),
        "{stderr}"
    );
    let d = read_json(&dump);
    assert_eq!(d["drives"][0]["slot"], "mc6000#1");
    assert_eq!(d["drives"][1]["slot"], "mc6000#2");
    assert_eq!(d["drives"][1]["address"], 1);
    let lines = log_lines(&log);
    assert!(lines.iter().any(|l| l["fault"] == "collision"), "{lines:?}");
}

#[test]
fn factory_and_bench_arguments_are_checked() {
    for (args, message) in [
        (
            &["--family", "ecs", "--factory", "1"][..],
            "factory-fresh drives are modelled on LUSTBUS (mc6000, vf1000) and LECOM (tmd) only",
        ),
        (
            &["--family", "mc6000", "--address", "1", "--bench"],
            "--factory",
        ),
        (
            &[
                "--family",
                "lustbus",
                "--address",
                "1",
                "--factory",
                "mc6000*2",
            ],
            "--family lustbus (a mixed LUSTBUS) takes its drives from --factory",
        ),
        (
            &["--family", "lustbus", "--factory", "3"],
            "--factory 3: `3`: on sim://lustbus every item names its family",
        ),
        (
            &["--family", "tmd", "--factory", "vf1000*1"],
            "sim://tmd holds tmd drives only",
        ),
    ] {
        let out = driveset().arg("sim").args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
}

/// `--address` on a port of factory drives adds no drive of its own: the
/// command talks to the new unit the port names (it answers address 1),
/// not to a second drive slipped in beside it.
#[test]
fn address_on_a_factory_port_adds_no_drive() {
    let out = driveset()
        .args([
            "identify",
            "--port",
            "sim://mc6000?factory=1",
            "--address",
            "1",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert_eq!(
        stdout.lines().next(),
        Some("port:     sim://mc6000?factory=1"),
        "{stdout}"
    );
}
