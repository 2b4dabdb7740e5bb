//! Interoperability with an SDO server driveset did not write: the
//! `canopen` Python package's `LocalNode` (object dictionary with the Lenze
//! index mapping, built in `tests/python/sdo_server.py`) on python-can's
//! `slcan` interface, and driveset's engine (`pull`, `upload`, `CanClient`)
//! on its own `slcan://` link. Both are slcan hosts, so
//! `driveset_sim::slcan_hub` sits between them: two simulated USB-CAN
//! adapters on two ptys, joined by one bus.
//!
//! Part of the normal test run: needs the venv that `scripts/setup-python`
//! makes at `target/py`; `DRIVESET_PYTHON` may name another interpreter
//! with python-can 4.6 and canopen 2.4.
use std::time::Duration;

use driveset_engine::client::{CanClient, CanOptions, DriveClient};
use driveset_engine::error::{DeviceFailure, ErrorKind};
use driveset_engine::journal::TxnState;
use driveset_engine::live::live_diff;
use driveset_engine::pull::{PullOptions, pull};
use driveset_engine::upload::{CodeOutcome, UploadOptions, upload};
use driveset_link::slcan::SlcanLink;
use driveset_schema::{CodeKey, RawValue, ResolvedSet, load_set_str};
use driveset_sim::catalog::{self, Family};
use driveset_sim::slcan_hub::SlcanHub;

use driveset_test_support::{LinePeer, python_or_skip, sdo_server, workspace_root};

/// Hang guard for one line from the script (not a timing assertion).
const LINE_GUARD: Duration = Duration::from_secs(60);

/// How long driveset waits for each SDO response. The Python server
/// answers within milliseconds; the margin is for a loaded test machine.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(2);

/// The LocalNode's initial values (raw), as `sdo_server.py` builds them.
const INITIAL: [(u32, i64); 18] = [
    (135, 0x0401),
    (150, 0x8421),
    (5001, 45_000_000),
    (5002, 0),
    (5003, 2_500),
    (5004, 2_500),
    (5005, 500),
    (5006, 2_000_000),
    (5007, 145_000),
    (5008, 120_000),
    (5009, 250_000),
    (5010, 45_000_000),
    (5011, 68_000),
    (5012, 45_000),
    (5013, 40_000),
    (5014, 800_000),
    (5015, 5_000),
    (5016, 0),
];

/// (code number, raw value) pairs.
type Values = Vec<(u32, i64)>;

/// The Python SDO server, talked to over its stdin / stdout.
struct Server(LinePeer);

impl Server {
    fn start(path: &str, node: u8) -> Server {
        Server(sdo_server(path, node, &[], LINE_GUARD))
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

    /// The object dictionary's values and the accepted writes, in order.
    fn dump(&mut self) -> (Values, Values) {
        self.send("dump");
        let mut values = Vec::new();
        let mut writes = Vec::new();
        loop {
            let line = self.line();
            if line == "end" {
                return (values, writes);
            }
            let parse = |s: &str| -> (u32, i64) {
                let (code, raw) = s.split_once(' ').expect("`CODE RAW`");
                (
                    code.trim_start_matches('C').parse().expect("code"),
                    raw.parse().expect("raw"),
                )
            };
            match line.strip_prefix("wrote ") {
                Some(rest) => writes.push(parse(rest)),
                None => values.push(parse(&line)),
            }
        }
    }

    fn quit(self) {
        let (status, stderr) = self.0.quit("quit", "bye");
        assert!(status.success(), "{status}\n{stderr}");
    }
}

fn client(hub: &SlcanHub, node: u8) -> CanClient<SlcanLink> {
    let link = SlcanLink::open(hub.path_a(), 500_000, 115_200, Duration::from_secs(2))
        .expect("open driveset's slcan link on the hub");
    let schema = catalog::schema(Family::Ecs).expect("fictional-ecs-demo schema");
    CanClient::with_options(
        link,
        schema,
        node,
        CanOptions {
            tries: 3,
            answer_timeout: ANSWER_TIMEOUT,
        },
    )
    .expect("client")
}

/// A set of the fictional ECS fixture, from TOML text.
fn set(name: &str, text: &str) -> ResolvedSet {
    let path = workspace_root().join("parameter-sets/ecs").join(name);
    let mut registry = driveset_schema::Registry::builtin().expect("registry");
    let loaded = load_set_str(&path, text, &mut registry).expect("set loads");
    assert!(loaded.findings.is_empty(), "{:?}", loaded.findings);
    loaded.resolved.expect("resolved")
}

fn hub_log(hub: &SlcanHub) -> String {
    hub.log().join("\n")
}

/// A hub, the Python server on side B (node 1), driveset on side A.
fn session() -> (SlcanHub, Server, CanClient<SlcanLink>) {
    let hub = SlcanHub::spawn(500_000).expect("slcan hub");
    let server = Server::start(hub.path_b(), 1);
    let c = client(&hub, 1);
    (hub, server, c)
}

/// Close driveset's link, stop the server and the hub; every request was
/// answered once, nothing refused or dropped.
fn finish(hub: SlcanHub, server: Server, c: CanClient<SlcanLink>) {
    drop(c);
    server.quit();
    let log = hub_log(&hub);
    let stats = hub.stop().expect("hub stops cleanly");
    // python-can opens the channel twice (the second `O` is answered
    // BELL and ignored); nothing else was refused.
    let bells: Vec<&str> = log.lines().filter(|l| l.ends_with("BELL")).collect();
    assert!(
        bells.iter().all(|l| l.ends_with("b> Open -> BELL")),
        "{log}"
    );
    assert_eq!(stats.refused, bells.len() as u64, "{log}");
    assert_eq!(stats.dropped, 0, "{log}");
    assert_eq!(stats.a_to_b, stats.b_to_a, "one answer per request\n{log}");
}

#[test]
fn engine_pulls_uploads_and_decodes_aborts_against_a_canopen_local_node() {
    if python_or_skip("canopen interop").is_none() {
        return;
    }
    let (hub, mut server, mut c) = session();

    // 1. pull: every code of the schema, exact values.
    let pulled = pull(&mut c, &PullOptions::default())
        .unwrap_or_else(|e| panic!("pull: {e}\n{}\n{}", server.stderr(), hub_log(&hub)));
    // C0135 (role control-word) and the fixture's store step (0x1010 sub 1,
    // role command) are left out: a set cannot hold them
    let skipped: Vec<(u32, &str)> = pulled
        .skipped
        .iter()
        .map(|s| (s.number, s.reason.as_str()))
        .collect();
    assert_eq!(
        skipped,
        vec![
            (135, "role `control-word`: left out, a set cannot hold it"),
            (
                driveset_schema::schema::index_number(0x1010, Some(1)),
                "role `command`: left out, a set cannot hold it"
            )
        ]
    );
    assert_eq!(pulled.read, INITIAL.len() - 1);
    let got: Vec<(u32, RawValue)> = pulled
        .set
        .values
        .iter()
        .map(|(k, v)| (k.number, v.clone()))
        .collect();
    let want: Vec<(u32, RawValue)> = INITIAL
        .iter()
        .filter(|&&(n, _)| n != 135)
        .map(|&(n, v)| (n, RawValue::Int(v)))
        .collect();
    assert_eq!(got, want);
    // The pulled set holds what parameter-sets/ecs/axis-1.toml says (the
    // server's initial values were chosen so), plus C5009, C5015 and the
    // two bit-coded codes.
    let axis1 = {
        let path = workspace_root().join("parameter-sets/ecs/axis-1.toml");
        let text = std::fs::read_to_string(&path).expect("axis-1.toml");
        set("axis-1.toml", &text)
    };
    for (k, v) in &axis1.values {
        assert_eq!(pulled.set.values.get(k), Some(v), "{k:?}");
    }
    assert!(live_diff(&mut c, &axis1).expect("live diff").is_empty());

    // 2. upload a changed set: only the differing codes are written, the
    // LocalNode's dictionary holds the new values, driveset verified them.
    let changed = set(
        "interop-changed.toml",
        r#"
schema = "../fixtures/fictional-ecs-demo.toml"
[values]
C5001 = "5200.5 rpm"
C5002 = "0 rpm"
C5003 = "0.400 s"
C5007 = 16.25
C5015 = "0.0125 rev"
C5016 = "Position control"
code_0135 = 1539  # bit 9 (controller inhibit, FICTIONAL fixture meaning) set: a set holds a control word only inhibited
"#,
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let report = upload(
        &mut c,
        &changed,
        &UploadOptions::new(dir.path().join("j.json")),
    )
    .unwrap_or_else(|f| {
        panic!(
            "upload: {f}\n{}\n{}\n{}",
            f.report.as_ref().map(|r| r.render()).unwrap_or_default(),
            server.stderr(),
            hub_log(&hub)
        )
    });
    assert_eq!(report.state, TxnState::Complete, "{}", report.render());
    assert_eq!(report.codes_in_set, 7, "{}", report.render());
    assert_eq!(report.codes_written, 6, "{}", report.render());
    assert_eq!(
        report.fingerprint_after.as_deref(),
        Some(changed.fingerprint().as_str())
    );
    for code in &report.codes {
        let want = if code.number == 5002 {
            CodeOutcome::Unchanged
        } else {
            CodeOutcome::Verified
        };
        assert_eq!(code.outcome, want, "{}", report.render());
    }
    let (values, writes) = server.dump();
    let mut expected: Vec<(u32, i64)> = INITIAL.to_vec();
    let new = [
        (135, 1539),
        (5001, 52_005_000),
        (5003, 4_000),
        (5007, 162_500),
        (5015, 125),
        (5016, 20_000),
    ];
    for (n, v) in new {
        expected.iter_mut().find(|(m, _)| *m == n).expect("code").1 = v;
    }
    assert_eq!(values, expected, "{}", report.render());
    let mut written = writes.clone();
    written.sort_unstable();
    assert_eq!(written, new, "each changed code written once: {writes:?}");
    assert!(live_diff(&mut c, &changed).expect("live diff").is_empty());

    // 3. a write the LocalNode refuses (C5010 is read-only there, not in
    // driveset's schema): the abort, decoded.
    let err = c
        .write(CodeKey::new(5010), &RawValue::Int(30_000_000))
        .expect_err("read-only object");
    let ErrorKind::Device(DeviceFailure::Refused { cause, .. }) = &*err.kind else {
        panic!("not a device error: {err}");
    };
    assert_eq!(
        cause.raw(),
        "SDO abort 0x06010002 at index 0x4C6D subindex 0",
        "{err}"
    );
    assert!(
        cause.cause().to_lowercase().contains("read only"),
        "{cause:?}"
    );
    let text = err.to_string();
    assert!(
        text.contains("C5010") && text.contains("0x06010002"),
        "{text}"
    );

    finish(hub, server, c);
}

/// A write the drive refused (SDO abort: not applied) is not rolled back;
/// the codes written before it are, and the drive ends exactly as it was.
#[test]
fn upload_touching_a_read_only_object_rolls_back() {
    if python_or_skip("canopen interop").is_none() {
        return;
    }
    let (hub, mut server, mut c) = session();
    let dir = tempfile::tempdir().expect("tempdir");
    let ro = set(
        "interop-read-only.toml",
        r#"
schema = "../fixtures/fictional-ecs-demo.toml"
[values]
C5004 = "0.300 s"
C5010 = "3000 rpm"
"#,
    );
    let failure = upload(&mut c, &ro, &UploadOptions::new(dir.path().join("ro.json")))
        .expect_err("the read-only write fails the upload");
    let report = failure.report.as_ref().expect("a report");
    assert_eq!(
        report.state,
        TxnState::RolledBack,
        "{failure}\n{}",
        report.render()
    );
    assert!(failure.to_string().contains("0x06010002"), "{failure}");
    let (values, _) = server.dump();
    assert_eq!(values, INITIAL.to_vec(), "nothing changed: {failure}");
    finish(hub, server, c);
}
