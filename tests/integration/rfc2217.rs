//! RFC 2217 interop: pyserial's RFC 2217 server (`serial.rfc2217.PortManager`,
//! in `scripts/rfc2217-bridge.py`) in front of `driveset sim --pty`, and
//! `driveset identify` / `pull` through `rfc2217://127.0.0.1:PORT`. The
//! bridge prints the line settings driveset gave it: the test checks they
//! are 7E1 at the port's rate.
//!
//! Needs pyserial from `scripts/setup-python` (target/py; `DRIVESET_PYTHON`
//! may name another interpreter). Without it the test is skipped with a
//! message under plain `cargo test`; `./scripts/test` sets
//! `DRIVESET_REQUIRE_INTEROP=1`, which turns the skip into a failure.
//! Timeouts are hang guards only.
#![cfg(unix)]

use std::io::BufRead;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use driveset_test_support::{Spawned, driveset, driveset_sim, outcome, workspace_root};

/// The interpreter with pyserial, or `None` (after saying why) when the
/// test should be skipped ([`driveset_test_support::python_or_skip`]).
pub(crate) fn python_or_skip(what: &str) -> Option<PathBuf> {
    driveset_test_support::python_or_skip(what)
}

/// The running bridge: its port and every stdout line after the first.
struct Bridge {
    _child: Spawned,
    addr: String,
    lines: Arc<Mutex<Vec<String>>>,
}

impl Bridge {
    fn start(python: &PathBuf, pty: &str) -> Bridge {
        let child = Command::new(python)
            .arg(workspace_root().join("scripts/rfc2217-bridge.py"))
            .arg(pty)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()));
        let mut child = Spawned::new(child, "rfc2217-bridge.py");
        let (first, out) = child.first_line();
        let addr = first
            .trim_end()
            .strip_prefix("rfc2217 ")
            .unwrap_or_else(|| {
                panic!(
                    "bridge said `{first}` (a ModuleNotFoundError means: run scripts/setup-python)"
                )
            })
            .to_string();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&lines);
        std::thread::spawn(move || {
            for line in out.lines().map_while(Result::ok) {
                sink.lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .push(line);
            }
        });
        Bridge {
            _child: child,
            addr,
            lines,
        }
    }

    /// Wait (hang guard) until the bridge has printed `n` lines.
    fn lines(&self, n: usize) -> Vec<String> {
        let give_up = Instant::now() + Duration::from_secs(30);
        loop {
            let l = self
                .lines
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .clone();
            if l.len() >= n || Instant::now() > give_up {
                return l;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

/// A running `driveset sim --pty`.
struct PtySim {
    _child: Spawned,
    path: String,
}

impl PtySim {
    fn start(args: &[&str]) -> PtySim {
        let mut child = driveset_sim(&[args, &["--pty"]].concat(), Stdio::null());
        let (first, _) = child.first_line();
        let path = first
            .trim_end()
            .strip_prefix("pty ")
            .unwrap_or_else(|| panic!("sim said `{first}`"))
            .to_string();
        PtySim {
            _child: child,
            path,
        }
    }
}

fn run(args: &[&str]) -> (Option<i32>, String, String) {
    outcome(driveset().args(args).timeout(Duration::from_secs(300)))
}

#[test]
fn identify_and_pull_through_pyserials_rfc2217_server_set_7e1_and_the_rate() {
    let Some(python) = python_or_skip("RFC 2217 interop test") else {
        return;
    };
    let _one = crate::e2e_pty::one_at_a_time();
    let dir = tempfile::tempdir().expect("tempdir");
    let sim = PtySim::start(&["--family", "mc6000", "--address", "1", "--baud", "19200"]);
    let bridge = Bridge::start(&python, &sim.path);
    let port = format!("rfc2217://{}?baud=19200", bridge.addr);

    let (code, out, err) = run(&[
        "identify",
        "--port",
        &port,
        "--address",
        "1",
        "--protocol",
        "lustbus",
    ]);
    assert_eq!(code, Some(0), "identify: {out}\n{err}");
    assert!(out.contains(&format!("port:     {port}\n")), "{out}");
    assert!(out.contains("family:   lustbus-mc\n"), "{out}");

    let file = dir.path().join("axis.toml");
    let (code, out, err) = run(&[
        "pull",
        "--port",
        &port,
        "--address",
        "1",
        "--schema",
        "parameter-sets/fixtures/fictional-mc6000-demo.toml",
        "-o",
        file.to_str().expect("utf-8 path"),
    ]);
    assert_eq!(code, Some(0), "pull: {out}\n{err}");
    assert!(
        out.starts_with(&format!("pulled 209 values from {port} address 1 into ")),
        "{out}"
    );
    // the bus address and rate are the manifest's (issue 20): left out
    assert!(
        out.contains("\nleft out 81-SBAUD, 82-SADDR: the line manifest gives the drive's address and the bus's rate (--keep-bus-codes keeps them)\n"),
        "{out}"
    );
    let text = std::fs::read_to_string(&file).expect("pulled set");
    assert!(
        text.starts_with(&format!("# Pulled by driveset from {port} address 1.\n")),
        "{text}"
    );

    let lines = bridge.lines(6);
    let settings = "set baud=19200 bytesize=7 parity=E stopbits=1";
    assert_eq!(lines.len(), 6, "{lines:?}");
    for (i, want) in ["connected 127.0.0.1:", settings, "disconnected"]
        .iter()
        .cycle()
        .take(6)
        .enumerate()
    {
        assert!(lines[i].starts_with(want), "line {i}: {lines:?}");
    }
    // Exactly the settings, nothing else after `set`.
    assert_eq!(lines[1], settings);
    assert_eq!(lines[4], settings);
}
