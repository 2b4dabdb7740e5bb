//! Interoperability with the Python CAN ecosystem: python-can's `slcan`
//! interface and the `canopen` package's SDO client talk to simulated Lenze
//! ECS drives through driveset-sim's slcan adapter on a real pseudo
//! terminal. Part of the normal test run: needs the venv that
//! `scripts/setup-python` makes at `target/py` (pinned versions in
//! `tests/python/requirements.txt`); `DRIVESET_PYTHON` may name another
//! interpreter with those packages.

use crate::ecs_support as support;

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant as StdInstant};

use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_sim::can_bus::FrameLine;
use driveset_sim::drive::FrameDrive;
use driveset_sim::slcan_serve::SlcanServer;
use support::test_drive;

use driveset_test_support::{pty_lock, python_or_skip};

/// How long the script may run before the test kills it (a hang guard,
/// not a timing assertion: the script needs well under a second).
const HANG_GUARD: Duration = Duration::from_secs(120);

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/python/sdo_client.py")
}

/// Runs the script to its end (or kills it after [`HANG_GUARD`]); returns
/// (exit code, stdout, stderr).
fn run_script(python: &PathBuf, path: &str) -> (Option<i32>, String, String) {
    let mut child = Command::new(python)
        .arg(script())
        .arg(path)
        .arg("1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.display()));
    let mut stdout = child.stdout.take().expect("stdout piped");
    let mut stderr = child.stderr.take().expect("stderr piped");
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let err = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let start = StdInstant::now();
    let status = loop {
        match child.try_wait().expect("wait for the script") {
            Some(status) => break status,
            None if start.elapsed() > HANG_GUARD => {
                let _ = child.kill();
                break child.wait().expect("reap the killed script");
            }
            None => std::thread::sleep(Duration::from_millis(20)),
        }
    };
    (
        status.code(),
        out.join().unwrap_or_default(),
        err.join().unwrap_or_default(),
    )
}

#[test]
fn python_can_slcan_and_canopen_sdo_client_against_simulated_ecs() {
    // Without the venv a plain `cargo test` skips this test with a message
    // naming `scripts/setup`; `./scripts/test` (DRIVESET_REQUIRE_INTEROP=1)
    // fails it.
    let Some(python) = python_or_skip("python-can interop") else {
        return;
    };

    let mut node1 = test_drive(1);
    node1
        .poke(CodeKey::new(150), RawValue::Int(0x0000_8421))
        .expect("poke C0150");
    let node2 = test_drive(2);
    let node2_before = node2.state();
    let drives: Vec<Box<dyn FrameDrive>> = vec![Box::new(node1), Box::new(node2)];

    let events = Arc::new(Mutex::new(Vec::<String>::new()));
    let sink = Arc::clone(&events);
    let line = FrameLine::new(500_000, drives).expect("a 500 kbit/s bus");
    let server = {
        let _guard = pty_lock();
        SlcanServer::spawn(line, move |e| {
            sink.lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push(e.to_string())
        })
    }
    .expect("serve on a pty");
    let (code, stdout, stderr) = run_script(&python, server.path());
    let (line, stats) = server.stop().expect("server stops cleanly");
    let drives = line.drives();
    let log = events
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .join("\n");

    assert_eq!(
        code,
        Some(0),
        "sdo_client.py failed (a ModuleNotFoundError means: run scripts/setup-python)\n--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- adapter log\n{log}"
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(
        lines,
        [
            "read C5001 index=0x4C76 raw=30000000 value=3000.0000",
            "write C5002 raw=12345678 ok",
            "read C5002 raw=12345678 value=1234.5678",
            "write C5017 abort 0x06010002",
            "write C5001 raw=160000001 abort 0x06090031",
            "read C0150 raw=0x00008421",
            "write C0135 raw=0x00000401 ok",
            "write C5003 segmented raw=25000 ok",
            "write C5004 segmented 8 bytes abort 0x06070010",
            "read C9999 abort 0x06020000",
            "done",
        ],
        "stderr:\n{stderr}\nadapter log:\n{log}"
    );

    // What the drive holds now.
    let s1 = drives[0].state();
    let v = |k: u32| s1.values[&CodeKey::new(k)].clone();
    assert_eq!(v(5001), RawValue::Int(30_000_000));
    assert_eq!(v(5002), RawValue::Int(12_345_678));
    assert_eq!(v(5003), RawValue::Int(25_000));
    assert_eq!(v(5004), RawValue::Int(10_000));
    assert_eq!(v(135), RawValue::Int(0x401));
    assert_eq!(v(150), RawValue::Int(0x8421));
    assert_eq!(v(5017), RawValue::Int(0));
    // Node 2 heard everything and answered nothing.
    assert_eq!(drives[1].state(), node2_before);

    // 15 SDO requests: 5 single reads / writes (C5001, C5017, C5001 too
    // high, C0150, C9999), C5002 and C0135 write + read, C5003 initiate +
    // segment + read, C5004 initiate + 2 segments; each answered once.
    assert_eq!(stats.frames_from_host, 15, "{log}");
    assert_eq!(stats.answers, 15, "{log}");
    assert_eq!(stats.dropped, 0, "{log}");
    assert_eq!(stats.bad_lines, 0, "{log}");
}
