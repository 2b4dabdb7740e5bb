//! Discovery behind latency (issue 28): the read-only protocol probes of
//! `identify`, `pull` and `twin capture` (no schema named) and of `scan`
//! wait as the clients do (engine `client::timing`: the first-contact
//! allowance, or the port's `?latency=` plus the floor), so they find
//! drives behind a serial device server that adds 40 ms +- 10 ms each way
//! ([`crate::proxy`]), with and without `?latency=80ms` (README's example);
//! `scan` with it. Before, the probes used a direct line's timeouts and
//! reported "no drive answered" where `--schema` worked.
//!
//! Real time, one at a time; nothing asserts how long anything took.
#![cfg(unix)]

use std::net::SocketAddr;

use crate::e2e_pty::{Sim, run};
use crate::proxy::{Shape, TcpProxy};

const DEVICE_SERVER: Shape = Shape::delay(40, 10);

/// `driveset sim --tcp` behind the device server; the port with `query`.
fn behind(dir: &std::path::Path, family: &str, address: u8, args: &[&str]) -> (Sim, TcpProxy) {
    let sim = Sim::start_tcp(dir, family, address, args);
    let target: SocketAddr = sim.path.parse().expect("sim address");
    let proxy = TcpProxy::start(target, DEVICE_SERVER);
    (sim, proxy)
}

#[test]
fn identify_pull_and_twin_capture_find_a_tmd_behind_a_40ms_device_server() {
    let _one = crate::e2e_pty::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let (mut sim, proxy) = behind(dir.path(), "tmd", 13, &["--c0001", "3"]);
    for query in ["", "?latency=80ms"] {
        let port = proxy.port(query);
        let (code, out, err) = run(&["identify", "--port", &port, "--address", "13"]);
        assert_eq!(code, Some(0), "{query}: {out}{err}\n{}", sim.stderr());
        assert!(out.contains("family:   lecom\n"), "{out}");
        assert!(out.contains("schema:   lenze-tmd (fits)\n"), "{out}");
    }
    let port = proxy.port("?latency=80ms");
    let set = dir.path().join("tmd.toml");
    let (code, out, err) = run(&[
        "pull",
        "--port",
        &port,
        "--address",
        "13",
        "-o",
        set.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(
        out.contains("protocol: lecom (LECOM RECEIVE of C0093 answered ("),
        "{out}"
    );
    let twin = dir.path().join("tmd.twin.toml");
    let (code, out, err) = run(&[
        "twin",
        "capture",
        "--port",
        &proxy.port(""),
        "--address",
        "13",
        "-o",
        twin.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(twin.is_file());
    // scan, with the latency the port names: every probe waits for it
    let (code, out, err) = run(&["scan", "--port", &port, "--protocol", "lecom"]);
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(out.contains("address 13: C0093 = "), "{out}");
    assert!(out.ends_with("1 drive found\n"), "{out}");
    assert!(sim.terminate().success(), "{}", sim.stderr());
}

#[test]
fn identify_and_scan_find_a_vf1000_behind_a_40ms_device_server() {
    let _one = crate::e2e_pty::one_at_a_time();
    let dir = tempfile::tempdir().unwrap();
    let (mut sim, proxy) = behind(dir.path(), "vf1000", 4, &[]);
    for query in ["", "?latency=80ms"] {
        let port = proxy.port(query);
        let (code, out, err) = run(&["identify", "--port", &port, "--address", "4"]);
        assert_eq!(code, Some(0), "{query}: {out}{err}\n{}", sim.stderr());
        assert!(out.contains("family:   lustbus-vf1000\n"), "{out}");
    }
    let (code, out, err) = run(&[
        "scan",
        "--port",
        &proxy.port("?latency=80ms"),
        "--protocol",
        "lustbus",
    ]);
    assert_eq!(code, Some(0), "{out}{err}\n{}", sim.stderr());
    assert!(out.contains("address 4: 91-TYPE = "), "{out}");
    assert!(sim.terminate().success(), "{}", sim.stderr());
}
