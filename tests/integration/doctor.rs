//! `driveset doctor`: against `sim://` ports (virtual time: exact output),
//! a `driveset sim --pty` line with a fake sysfs latency timer, and a `driveset sim --tcp` line behind a proxy that echoes and
//! reads 7E1 as 8 data bits. Read-only is checked from the simulator's
//! event log: no host telegram carries STX (SELECT / SEND do).
#![cfg(unix)]

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use driveset_test_support::{Spawned, driveset, driveset_sim, outcome, send_signal};

fn run(args: &[&str]) -> (Option<i32>, String, String) {
    outcome(
        driveset()
            .arg("doctor")
            .args(args)
            .timeout(Duration::from_secs(120)),
    )
}

#[test]
fn doctor_on_a_simulated_mc6000_prints_every_finding_exactly() {
    let (code, out, err) = run(&[
        "--port",
        "sim://mc6000?addresses=1",
        "--address",
        "1",
        "--protocol",
        "lustbus",
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        out,
        "\
doctor sim://mc6000?addresses=1 (LUSTBUS, address 1; read-only: reads 91-TYPE (ENQUIRY 00091) only)
rates:
     9600 baud (the port's): answers (1770)
    57600 baud: silent
    38400 baud: silent
    19200 baud: silent
     4800 baud: silent
     2400 baud: silent
round trips at 9600 baud: 20 of 20 answered; min 26.919 ms, median 40.580 ms, p95 47.299 ms, max 47.464 ms; wire time 22.916 ms
echo: none (21 exchanges with an answer)
parity: ok: 0 of 294 answer bytes with bit 7 set, 147 with odd 8-bit weight, 0 bad BCC, 0 garbled
latency timer: none found (no USB serial adapter in /sys/bus/usb-serial, or not Linux)
advice: none, the line looks fine
"
    );
}

#[test]
fn doctor_json_and_exit_codes() {
    let (code, out, err) = run(&[
        "--port",
        "sim://tmd?addresses=1",
        "--protocol",
        "lecom",
        "--probes",
        "4",
        "--format",
        "json",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["protocol"], "lecom");
    assert_eq!(v["address"], 1);
    assert_eq!(v["answering"], serde_json::json!([9600]));
    assert_eq!(v["rates"].as_array().map(Vec::len), Some(4));
    assert_eq!(v["rates"][0]["kind"], "answer");
    assert_eq!(v["rates"][1]["kind"], "silent");
    assert_eq!(v["round_trips"]["probes"], 4);
    assert_eq!(v["round_trips"]["answered"], 4);
    assert_eq!(v["echo"]["echo"], false);
    assert_eq!(v["parity"]["read_as_8_bits"], false);
    assert_eq!(v["advice"], serde_json::json!([]));

    // Nobody at address 5: exit 3 with what to check.
    let (code, out, _) = run(&[
        "--port",
        "sim://mc6000?addresses=1",
        "--address",
        "5",
        "--protocol",
        "lustbus",
        "--probes",
        "2",
        "--timeout",
        "100",
    ]);
    assert_eq!(code, Some(3));
    assert!(out.ends_with("advice:\n  - nothing answered address 5 at any rate (9600, 57600, 38400, 19200, 4800, 2400): check the wiring (A/B swapped?), the termination, that the drive is powered and set to this address, and that the port runs 7E1 (on a tcp:// device server set 7E1 there, or use rfc2217:// so driveset sets it)\n"), "{out}");

    // CAN: an SDO read from node 1.
    let (code, out, err) = run(&["--port", "sim://ecs?addresses=1", "--probes", "3"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.starts_with("doctor sim://ecs?addresses=1 (CAN SDO, node 1; read-only: reads the schema's first identification code (SDO upload) only)\nrates: only the port's (a CAN bus runs at the port's bit rate (?bitrate=)):\n   500000 bit/s (the port's): answers (C0135 = 0)\nround trips at 500000 bit/s: 3 of 3 answered; "), "{out}");

    // Usage errors: exit 2.
    let (code, _, err) = run(&["--port", "tcp://127.0.0.1:1"]);
    assert_eq!(code, Some(3), "{err}");
    let (code, _, err) = run(&["--port", "sim://mc6000?addresses=1", "--protocol", "can"]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(
        err,
        "error: sim://mc6000?addresses=1 is a character line: use --protocol lustbus or lecom\n"
    );
    let (code, _, err) = run(&[
        "--port",
        "sim://mc6000?addresses=1",
        "--address",
        "31",
        "--protocol",
        "lustbus",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("31 is not a LUSTBUS drive address"), "{err}");
}

/// A running `driveset sim`; killed when dropped.
pub(crate) struct Sim {
    child: Spawned,
    pub(crate) first: String,
}

impl Sim {
    pub(crate) fn start(args: &[&str]) -> Sim {
        let mut child = driveset_sim(args, Stdio::null());
        let (first, _) = child.first_line();
        Sim {
            child,
            first: first.trim_end().to_string(),
        }
    }

    pub(crate) fn stop(&mut self) {
        send_signal(self.child.id(), "-TERM");
        let _ = self.child.wait();
    }
}

/// Every host chunk in the sim's log; panics on one with STX (a write).
pub(crate) fn host_chunks_are_reads(log: &Path) -> usize {
    let text = std::fs::read_to_string(log).expect("sim log");
    let mut n = 0;
    for line in text.lines() {
        let v: serde_json::Value = serde_json::from_str(line).expect("log line");
        if v["dir"] == "host" {
            n += 1;
            let hex = v["hex"].as_str().unwrap_or_default();
            assert!(!hex.split(' ').any(|h| h == "02"), "a write: {line}");
        }
    }
    n
}

#[test]
fn doctor_on_a_pty_finds_the_usb_latency_timer_and_writes_nothing() {
    let _one = crate::e2e_pty::one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("bus.jsonl");
    let mut sim = Sim::start(&[
        "--family",
        "vf1000",
        "--address",
        "3",
        "--pty",
        "--log",
        log.to_str().expect("utf-8"),
    ]);
    let pty = sim
        .first
        .strip_prefix("pty ")
        .expect("pty line")
        .to_string();
    // A fake sysfs: this port's adapter at the FTDI default, another one.
    let name = Path::new(&pty)
        .file_name()
        .expect("pts name")
        .to_string_lossy()
        .into_owned();
    let sysfs = dir.path().join("sys");
    for (dev, ms) in [(name.as_str(), "16\n"), ("ttyUSB9", "1\n")] {
        let d = sysfs.join("bus/usb-serial/devices").join(dev);
        std::fs::create_dir_all(&d).expect("mkdir");
        std::fs::write(d.join("latency_timer"), ms).expect("write");
    }
    let (code, out, err) = run(&[
        "--port",
        &pty,
        "--protocol",
        "lustbus",
        "--address",
        "3",
        "--probes",
        "5",
        "--sysfs",
        sysfs.to_str().expect("utf-8"),
    ]);
    assert_eq!(code, Some(1), "{out}\n{err}");
    assert!(
        out.contains("rates: only the port's (a pseudo terminal has no line rate):\n     9600 baud (the port's): answers ("),
        "{out}"
    );
    assert!(
        out.contains("round trips at 9600 baud: 5 of 5 answered; "),
        "{out}"
    );
    assert!(
        out.contains(&format!(
            "latency timer: {name} 16 ms (this port), ttyUSB9 1 ms\n"
        )),
        "{out}"
    );
    let lat = sysfs.join(format!("bus/usb-serial/devices/{name}/latency_timer"));
    assert!(
        out.ends_with(&format!(
            "advice:\n  - {name}: the USB adapter's latency timer is 16 ms, so every answer waits up to 16 ms in the adapter: set it to 1 (echo 1 > {}, or a udev rule ATTR{{latency_timer}}=\"1\")\n",
            lat.display()
        )),
        "{out}"
    );
    sim.stop();
    assert!(host_chunks_are_reads(&log) > 0);
}

/// A proxy like a 2-wire adapter on a device server: every byte from the
/// client comes straight back; with `eight_bits` (a server left at 8N1)
/// the drive's 7E1 characters arrive with their parity bit in bit 7.
pub(crate) fn echo_proxy(upstream: String, eight_bits: bool) -> u16 {
    let l = TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = l.local_addr().expect("addr").port();
    std::thread::spawn(move || {
        for client in l.incoming() {
            let Ok(mut client) = client else { return };
            let Ok(mut sim) = TcpStream::connect(&upstream) else {
                return;
            };
            let mut back = client.try_clone().expect("clone");
            let mut sim_in = sim.try_clone().expect("clone");
            let down = std::thread::spawn(move || {
                let mut buf = [0u8; 256];
                while let Ok(n) = sim_in.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    for b in &mut buf[..n] {
                        if eight_bits && b.count_ones() % 2 == 1 {
                            *b |= 0x80;
                        }
                    }
                    if back.write_all(&buf[..n]).is_err() {
                        break;
                    }
                }
            });
            let mut buf = [0u8; 256];
            while let Ok(n) = client.read(&mut buf) {
                if n == 0
                    || client.write_all(&buf[..n]).is_err()
                    || sim.write_all(&buf[..n]).is_err()
                {
                    break;
                }
            }
            let _ = sim.shutdown(std::net::Shutdown::Both);
            let _ = down.join();
        }
    });
    port
}

#[test]
fn doctor_through_tcp_finds_echo_and_7e1_read_as_8_bits() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("bus.jsonl");
    let mut sim = Sim::start(&[
        "--family",
        "mc6000",
        "--address",
        "1",
        "--tcp",
        "0",
        "--log",
        log.to_str().expect("utf-8"),
    ]);
    let upstream = sim
        .first
        .strip_prefix("tcp ")
        .expect("tcp line")
        .to_string();
    let port = echo_proxy(upstream, true);
    let (code, out, err) = run(&[
        "--port",
        &format!("tcp://127.0.0.1:{port}"),
        "--protocol",
        "lustbus",
        "--probes",
        "5",
        "--format",
        "json",
    ]);
    assert_eq!(code, Some(1), "{out}\n{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["answering"], serde_json::json!([9600]));
    assert_eq!(v["echo"]["echo"], true);
    assert_eq!(v["echo"]["echoed"], v["echo"]["exchanges"]);
    assert_eq!(v["parity"]["read_as_8_bits"], true);
    assert_eq!(v["parity"]["odd_weight"], 0);
    let advice: Vec<&str> = v["advice"]
        .as_array()
        .expect("advice")
        .iter()
        .filter_map(|a| a.as_str())
        .collect();
    assert!(
        advice[0].starts_with("the line returns every byte driveset sends"),
        "{advice:?}"
    );
    assert!(advice[1].ends_with("answer bytes have the parity bit in bit 7: the port reads 8 data bits on a 7E1 line (an adapter or device server left at 8N1); set it to 7 data bits, even parity, 1 stop bit (rfc2217:// sets it on the server); the drives may see driveset's characters with a wrong parity bit"), "{advice:?}");
    sim.stop();
    assert!(host_chunks_are_reads(&log) > 0);
}

/// Without `--protocol` (and without `--schema` for scan) the line's
/// protocol is found by the read-only probes, on a simulated port and on
/// a pty alike (issue 28: after the transport change both asked for
/// `--protocol` on a `sim://` character line, which had worked before).
#[test]
fn doctor_and_scan_find_the_protocol_without_protocol_on_every_port() {
    // (the VF1000's slow reaction draws advice: exit 1)
    for (family, head, proto, exit) in [
        ("tmd", "(LECOM-A/B, address 1;", "\"lecom\"", 0),
        (
            "vf1000",
            "(LUSTBUS, address 0 (any drive);",
            "\"lustbus\"",
            1,
        ),
    ] {
        let port = format!("sim://{family}?addresses=1");
        let (code, out, err) = run(&["--port", &port, "--probes", "2"]);
        assert_eq!(code, Some(exit), "{family}: {out}{err}");
        assert!(out.starts_with(&format!("doctor {port} {head}")), "{out}");
        let (code, out, err) =
            outcome(driveset().args(["scan", "--port", &port, "--format", "json"]));
        assert_eq!(code, Some(0), "{family}: {err}");
        assert!(out.contains(&format!("\"protocol\": {proto}")), "{out}");
    }
    // nobody at the probed address: exit 3, saying what to give
    let (code, _, err) = run(&["--port", "sim://mc6000?addresses=5", "--probes", "2"]);
    assert_eq!(code, Some(3), "{err}");
    assert!(
        err.contains("address 1: no drive answered the read-only probes (LUSTBUS ENQUIRY of 91-TYPE, LECOM RECEIVE of C0093 and C0200)")
            && err.ends_with("; or say which protocol the line speaks: --protocol lustbus|lecom|can\n"),
        "{err}"
    );

    // the same on a pty: a LECOM drive for the doctor, an MC for scan
    let mut sim = Sim::start(&["--family", "tmd", "--address", "1", "--pty"]);
    let pty = sim.first.trim_start_matches("pty ").to_string();
    let (code, out, err) = run(&["--port", &pty, "--address", "1", "--probes", "2"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.starts_with(&format!("doctor {pty} (LECOM-A/B, address 1;")),
        "{out}"
    );
    sim.stop();
    let mut sim = Sim::start(&["--family", "mc6000", "--address", "4", "--pty"]);
    let pty = sim.first.trim_start_matches("pty ").to_string();
    let (code, out, err) = outcome(driveset().args(["scan", "--port", &pty]));
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        out,
        format!(
            "scanned {pty} (LUSTBUS addresses 1..30)\naddress 4: 91-TYPE = 6000\n1 drive found\n"
        )
    );
    sim.stop();
}
