//! The commissioning report: a `LineReport` fixture (3 buses, 6 drives, one
//! failed with markup in its error, one with a diff) written as report.json
//! and rendered by `driveset report`, then loaded in headless Chromium
//! (`scripts/setup-browser` installs it): the rendered DOM and a screenshot.

use std::path::{Path, PathBuf};
use std::process::Command;

use driveset_engine::line::report::{
    BusReport, DiffLine, DiffLineKind, DriveReport, DriveResult, GitInfo, LineReport, LineResult,
    REPORT_VERSION, TimelineEntry,
};

use driveset_test_support::driveset;

const EVIL: &str = "<script>document.title='pwned'</script> & \"quoted\"";

fn fp(c: char) -> String {
    format!("sha256:{}", c.to_string().repeat(64))
}

fn entry(drive: &str, phase: &str, start_ms: f64, end_ms: f64) -> TimelineEntry {
    TimelineEntry {
        drive: drive.into(),
        phase: driveset_engine::observe::Phase::parse(phase).expect("a phase"),
        start_ms,
        end_ms,
    }
}

fn drive(name: &str, bus: &str, address: u8, result: DriveResult) -> DriveReport {
    DriveReport {
        name: name.into(),
        position: None,
        bus: bus.into(),
        address,
        set: format!("parameter-sets/{name}.toml"),
        schema: "lenze-tmd".into(),
        identity: vec![
            ("C0093".into(), "33".into()),
            ("C0200".into(), "33STMD-M_12000".into()),
        ],
        set_fingerprint: fp('a'),
        fingerprint_before: Some(fp('a')),
        fingerprint_after: Some(fp('a')),
        codes_written: 0,
        retries: 0,
        telegrams: 24,
        elapsed_ms: 310.0,
        result,
        error: None,
        diff: Vec::new(),
        learned_schema: None,
        factory_settings: false,
        replacement: None,
        stored: None,
        history: None,
    }
}

/// The fixture: 3 buses, 6 drives.
pub fn fixture() -> LineReport {
    let mut d1 = drive("conveyor-1", "lecom-1", 1, DriveResult::Verified);
    d1.position = Some("Line 1, station 3".into());
    d1.fingerprint_before = Some(fp('b'));
    d1.codes_written = 2;
    d1.retries = 1;
    d1.diff = vec![
        DiffLine {
            code: "C0011".into(),
            name: "maximum_output_frequency".into(),
            kind: DiffLineKind::Changed,
            old: Some("50 Hz".into()),
            new: Some("60 Hz".into()),
        },
        DiffLine {
            code: "C0034".into(),
            name: "configuration_analog_input".into(),
            kind: DiffLineKind::Changed,
            old: Some("\"0...10 V\"".into()),
            new: Some("\"4...20 mA\"".into()),
        },
    ];
    let d2 = drive("pump-2", "lecom-1", 2, DriveResult::Unchanged);
    let mut d3 = drive("axis-x", "lust-1", 1, DriveResult::Failed);
    d3.schema = "lust-mc6000".into();
    d3.identity = vec![("91-TYPE".into(), "6000".into())];
    d3.fingerprint_after = None;
    d3.fingerprint_before = Some(fp('c'));
    d3.retries = 3;
    d3.error = Some(format!(
        "lust-1/1 code 80-SLOAD: the drive rejected the dataset {EVIL}; check the set"
    ));
    let mut d4 = drive("axis-y", "lust-1", 2, DriveResult::RolledBack);
    d4.schema = "lust-mc6000".into();
    d4.error = Some("verify failed at 100-PWMF; old values restored".into());
    let d5 = drive("spindle-1", "can-1", 5, DriveResult::AlreadyVerified);
    let d6 = drive("spindle-2", "can-1", 6, DriveResult::NotSelected);
    let lecom = BusReport {
        name: "lecom-1".into(),
        port: "/dev/ttyUSB0".into(),
        protocol: driveset_schema::BusProtocol::Lecom,
        rate: 9600,
        elapsed_ms: 1840.0,
        timeline: vec![
            entry("conveyor-1", "identify", 0.0, 120.0),
            entry("conveyor-1", "read", 120.0, 610.0),
            entry("conveyor-1", "plan", 610.0, 615.0),
            entry("conveyor-1", "write", 615.0, 900.0),
            entry("conveyor-1", "verify", 900.0, 1210.0),
            entry("pump-2", "identify", 1210.0, 1320.0),
            entry("pump-2", "read", 1320.0, 1840.0),
        ],
    };
    let lust = BusReport {
        name: "lust-1".into(),
        port: "tcp://10.0.0.7:4001".into(),
        protocol: driveset_schema::BusProtocol::Lustbus,
        rate: 19200,
        elapsed_ms: 10_950.0,
        timeline: vec![
            entry("axis-x", "identify", 0.0, 80.0),
            entry("axis-x", "read", 80.0, 400.0),
            entry("axis-x", "write", 400.0, 10_400.0),
            entry("axis-y", "identify", 10_400.0, 10_450.0),
            entry("axis-y", "write", 10_450.0, 10_700.0),
            entry("axis-y", "rollback", 10_700.0, 10_950.0),
        ],
    };
    let can = BusReport {
        name: "can-1".into(),
        port: "slcan:///dev/ttyACM0".into(),
        protocol: driveset_schema::BusProtocol::CanSdo,
        rate: 500_000,
        elapsed_ms: 42.0,
        timeline: vec![entry("spindle-1", "identify", 0.0, 42.0)],
    };
    LineReport {
        report_version: REPORT_VERSION,
        command: "commission".into(),
        line: "Line <1> & \"packaging\"".into(),
        manifest: "parameter-sets/line-1.toml".into(),
        label: Some("FAT run 3 <night shift>".into()),
        started: "2025-03-04T05:06:07Z".into(),
        finished: "2025-03-04T05:06:19Z".into(),
        git: Some(GitInfo {
            commit: "0123456789abcdef0123456789abcdef01234567".into(),
            dirty: true,
        }),
        result: LineResult::Failed,
        buses: vec![lecom, lust, can],
        drives: vec![d1, d2, d3, d4, d5, d6],
        history: None,
    }
}

/// Write the fixture as report.json into `dir` and render it with `driveset report`.
fn render(report: &LineReport, dir: &Path) -> PathBuf {
    let json = dir.join("in.json");
    std::fs::write(&json, serde_json::to_string(report).unwrap()).unwrap();
    let out = dir.join("out");
    driveset()
        .arg("report")
        .arg(&json)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    out
}

#[test]
fn report_json_round_trips_and_html_is_self_contained_and_escaped() {
    let tmp = tempfile::tempdir().unwrap();
    let report = fixture();
    let out = render(&report, tmp.path());
    let back: LineReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(back, report);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // self-contained: no scripts, no external references
    for bad in ["<script", "src=", "href=\"http", "@import", "url("] {
        assert!(!html.contains(bad), "report.html contains {bad}");
    }
    assert!(html.contains("&lt;script&gt;document.title=&#39;pwned&#39;&lt;/script&gt;"));
    assert!(html.contains("Line &lt;1&gt; &amp; &quot;packaging&quot;"));
    assert!(html.contains("FAT run 3 &lt;night shift&gt;"));
    assert_eq!(html.matches("<rect class=\"span ").count(), 14);
}

#[test]
fn report_subcommand_rejects_a_file_that_is_not_a_report() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("x.json");
    std::fs::write(&p, "{\"line\": 1}").unwrap();
    driveset()
        .arg("report")
        .arg(&p)
        .assert()
        .code(2)
        .stderr(predicates::str::contains("not a line report"));
}

/// The Chromium binary: `$CHROMIUM`, else `chromium` on PATH.
fn find_chromium() -> Option<PathBuf> {
    let name = std::env::var_os("CHROMIUM").unwrap_or_else(|| "chromium".into());
    let found = std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .map(|d| d.join(&name))
            .find(|f| f.is_file())
    });
    let explicit = PathBuf::from(&name);
    found.or_else(|| (explicit.is_absolute() && explicit.is_file()).then_some(explicit))
}

/// [`find_chromium`], or a panic naming the set-up script.
fn chromium() -> PathBuf {
    let name = std::env::var_os("CHROMIUM").unwrap_or_else(|| "chromium".into());
    match find_chromium() {
        Some(f) => f,
        None => panic!(
            "chromium not found (looked for {:?} on PATH): run `scripts/setup-browser` \
             (installs Debian's chromium), or set CHROMIUM=/path/to/chromium",
            name
        ),
    }
}

fn headless(profile: &Path) -> Command {
    let mut c = Command::new(chromium());
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        "--hide-scrollbars",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    c
}

/// Run chromium, killing it after two minutes (a hung browser fails the
/// test instead of hanging the suite).
fn run(mut c: Command) -> std::process::Output {
    use std::io::Read;
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let mut child = c
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run chromium");
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut buf = Vec::new();
        let _ = stdout.read_to_end(&mut buf);
        buf
    });
    let mut stderr = child.stderr.take().unwrap();
    let err_reader = std::thread::spawn(move || {
        let mut buf = Vec::new();
        let _ = stderr.read_to_end(&mut buf);
        buf
    });
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("chromium did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    std::process::Output {
        status,
        stdout: reader.join().unwrap(),
        stderr: err_reader.join().unwrap(),
    }
}

fn file_url(p: &Path) -> String {
    format!("file://{}", p.canonicalize().unwrap().display())
}

#[test]
fn report_renders_in_headless_chromium() {
    if driveset_test_support::interop_or_skip(
        "report in headless chromium",
        find_chromium(),
        "chromium not found on PATH or in $CHROMIUM (scripts/setup-browser installs Debian's)",
    )
    .is_none()
    {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let report = fixture();
    let out = render(&report, tmp.path());
    let url = file_url(&out.join("report.html"));

    let mut c = headless(&tmp.path().join("profile-dom"));
    c.arg("--dump-dom").arg(&url);
    let dom = run(c);
    assert!(
        dom.status.success(),
        "chromium --dump-dom failed: {}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let dom = String::from_utf8(dom.stdout).unwrap();
    assert!(dom.contains("<svg"), "no DOM dumped:\n{dom}");

    // the page's title is the one the report sets (the escaped script never ran)
    assert!(
        dom.contains(
            "<title>FAILED: commissioning report of Line &lt;1&gt; &amp; \"packaging\"</title>"
        ),
        "{dom}"
    );
    // line, label, time, git, overall result
    assert!(dom.contains("FAT run 3 &lt;night shift&gt;"));
    assert!(dom.contains("2025-03-04T05:06:07Z"));
    assert!(dom.contains("0123456789abcdef0123456789abcdef01234567"));
    assert!(dom.contains("uncommitted changes"));
    assert!(dom.contains("id=\"result\""));
    assert!(dom.contains("FAILED</div>"));
    // every drive with its result and set
    for (name, result) in [
        ("conveyor-1", "verified"),
        ("pump-2", "unchanged"),
        ("axis-x", "failed"),
        ("axis-y", "rolled back"),
        ("spindle-1", "already verified"),
        ("spindle-2", "not selected"),
    ] {
        assert!(
            dom.contains(&format!("<h3 class=\"drive-name\">{name}</h3>")),
            "{name}"
        );
        assert!(
            dom.contains(&format!("parameter-sets/{name}.toml")),
            "{name}"
        );
        assert!(
            dom.contains(&format!("</span> {result}</span>")),
            "{result}"
        );
    }
    // fingerprints in full
    for c in ['a', 'b', 'c'] {
        assert!(dom.contains(&fp(c)), "fingerprint {c}");
    }
    // the diff: code, name, old -> new
    assert!(dom.contains("<code>C0011</code></td><td>maximum_output_frequency</td>"));
    assert!(dom.contains("<code>50 Hz</code>"));
    assert!(dom.contains("<code>60 Hz</code>"));
    assert!(dom.contains("<code>\"4...20 mA\"</code>"));
    // the error is text, not a parsed script element
    assert!(
        dom.contains("the drive rejected the dataset &lt;script&gt;document.title='pwned'&lt;/script&gt; &amp; \"quoted\"; check the set"),
        "{dom}"
    );
    assert!(!dom.contains("<script"), "a script element was parsed");
    assert!(!dom.contains("pwned</title>"));
    // the timelines: one svg per bus, one rect per timeline entry
    assert_eq!(dom.matches("<svg class=\"gantt\"").count(), 3);
    let entries: usize = report.buses.iter().map(|b| b.timeline.len()).sum();
    assert_eq!(dom.matches("<rect class=\"span ").count(), entries);
    for b in &report.buses {
        for e in &b.timeline {
            assert!(
                dom.contains(&format!(
                    "class=\"span phase-{}\" data-drive=\"{}\" data-phase=\"{}\"",
                    e.phase, e.drive, e.phase
                )),
                "{e:?}"
            );
        }
    }

    // a screenshot of the whole page
    let png = tmp.path().join("report.png");
    let mut c = headless(&tmp.path().join("profile-shot"));
    c.arg(format!("--screenshot={}", png.display()))
        .arg("--window-size=1280,2600")
        .arg(&url);
    let shot = run(c);
    assert!(
        shot.status.success(),
        "chromium --screenshot failed: {}",
        String::from_utf8_lossy(&shot.stderr)
    );
    let bytes = std::fs::read(&png).expect("screenshot written");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert!(
        bytes.len() > 10 * 1024,
        "screenshot only {} bytes",
        bytes.len()
    );
    if let Some(keep) = std::env::var_os("DRIVESET_KEEP_SCREENSHOT") {
        std::fs::copy(&png, keep).unwrap();
    }
}
