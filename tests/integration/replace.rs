//! `driveset replace LINE --drive NAME --port SERVICE_PORT` (issue 20): a
//! factory-fresh spare alone on a simulated service port (its own state
//! file) becomes drive press-axis-3 of the demo line: its manifest address,
//! the bus's rate, then its whole set; refusals write nothing.

use std::path::Path;

use predicates::prelude::*;

use driveset_test_support::{demo_line_dir, driveset_in};

const LINE: &str = "ps/demo-line/line.toml";

fn spare(dir: &Path, family: &str) -> String {
    format!(
        "sim://{family}?factory=1&state={}",
        dir.join("spare.json").display()
    )
}

/// The spare's state: (address, canonical values).
fn spare_state(dir: &Path) -> (u8, String) {
    let dump = driveset_sim::open::StateDump::read(&dir.join("spare.json")).expect("spare state");
    let d = &dump.drives[0];
    (d.address, d.canonical.clone())
}

#[test]
fn a_factory_fresh_spare_gets_the_address_the_rate_and_the_whole_set() {
    let dir = demo_line_dir();
    let d = dir.path();
    let port = spare(d, "mc6000");
    let out = driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port, "--yes"])
        .assert()
        .code(0)
        .stdout(predicate::str::contains(format!(
            "spare on {port}: mc6000 at address 0, 9600 baud (91-TYPE = 6000)\nwrote 82-SADDR = 3 at address 0\npress-axis-3: address 3, 9600 baud, 21 codes written and verified (46 codes in the set); the spare was at factory settings ("
        )))
        .stdout(predicate::str::contains(
            "report: target/driveset-report/replace-press-axis-3/report.json target/driveset-report/replace-press-axis-3/report.html\nnext: plug it into the line (bus `lustbus`, sim://lustbus?mc6000=1,2,3,4&vf1000=5,6,7&baud=9600) and run `driveset status ps/demo-line/line.toml --only press-axis-3`\n",
        ))
        .get_output()
        .clone();
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // the spare holds the manifest's address, the rate and every value of the set
    let (address, canonical) = spare_state(d);
    assert_eq!(address, 3);
    assert!(canonical.lines().any(|l| l == "82 3"), "{canonical}");
    assert!(canonical.lines().any(|l| l == "81 9600"), "{canonical}");
    let fp = driveset_in(d)
        .args(["fingerprint", "ps/demo-line/sets/press-axis-3.toml"])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let set_fp = String::from_utf8(fp).unwrap();
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(d.join("target/driveset-report/replace-press-axis-3/report.json"))
            .unwrap(),
    )
    .unwrap();
    assert_eq!(r["command"], "replace");
    assert_eq!(r["result"], "ok");
    assert_eq!(r["drives"].as_array().unwrap().len(), 1);
    let dr = &r["drives"][0];
    assert_eq!(dr["name"], "press-axis-3");
    assert_eq!(dr["result"], "verified");
    assert_eq!(dr["codes_written"], 21);
    assert_eq!(dr["fingerprint_after"], dr["set_fingerprint"]);
    assert!(
        set_fp.contains(dr["set_fingerprint"].as_str().unwrap()),
        "{set_fp}"
    );
    assert_eq!(dr["factory_settings"], true);
    let rep = &dr["replacement"];
    assert_eq!(rep["service_port"], port.as_str());
    assert_eq!(rep["found_address"], 0);
    assert_eq!(rep["found_rate"], 9600);
    assert_eq!(rep["old_address"], 1);
    assert_eq!(rep["address"], 3);
    assert_eq!(rep["rate"], 9600);
    assert_eq!(rep["assigned"][0], "82-SADDR = 3 at address 0");
    let html =
        std::fs::read_to_string(d.join("target/driveset-report/replace-press-axis-3/report.html"))
            .unwrap();
    assert!(
        html.contains("Replacement unit"),
        "the HTML says it is a replacement"
    );
}

#[test]
fn replace_json_reports_the_virtual_time() {
    let dir = demo_line_dir();
    let d = dir.path();
    let port = spare(d, "mc6000");
    let out = driveset_in(d)
        .args([
            "replace",
            LINE,
            "--drive",
            "press-axis-3",
            "--port",
            &port,
            "--yes",
            "--format",
            "json",
        ])
        .assert()
        .code(0)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["result"], "replaced");
    assert_eq!(v["address"], 3);
    assert_eq!(v["rate"], 9600);
    assert_eq!(v["codes"], 46);
    assert_eq!(v["codes_written"], 21);
    let total = v["virtual_ms"]["total"].as_f64().unwrap();
    let sum =
        v["virtual_ms"]["assign"].as_f64().unwrap() + v["virtual_ms"]["upload"].as_f64().unwrap();
    assert!((total - sum).abs() < 1e-6, "{v}");
    assert!(total > 0.0, "{v}");
    eprintln!("replace press-axis-3 (MC6000, demo set) at 9600 baud: {total:.3} ms virtual");
}

#[test]
fn a_spare_of_another_family_is_refused_with_nothing_written() {
    let dir = demo_line_dir();
    let d = dir.path();
    let port = spare(d, "vf1000");
    driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port, "--yes"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            "error: the unit on the port is vf1000 with 91-TYPE 1000, but drive `press-axis-3`'s set `sets/press-axis-3.toml` (schema `fictional-mc6000-demo`) is for mc6000; nothing was written. Connect a spare of the drive's family and type\n",
        );
    // the spare still at its factory address, nothing assigned
    let dump = driveset_sim::open::StateDump::read(&d.join("spare.json")).expect("spare state");
    assert_eq!(dump.drives[0].address, 1);
    assert!(
        !d.join("target/driveset-report/replace-press-axis-3")
            .exists()
    );
}

#[test]
fn without_yes_a_non_interactive_stdin_is_refused_and_no_is_no() {
    let dir = demo_line_dir();
    let d = dir.path();
    let port = spare(d, "mc6000");
    driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port])
        .write_stdin("y\n")
        .assert()
        .code(2)
        .stderr(
            "error: replace asks before writing, and stdin is not a terminal; give --yes to run without asking (nothing was written)\n",
        );
    assert!(
        !d.join("spare.json").exists(),
        "the port was not even opened"
    );
    // answered (the test hook reads stdin as a terminal would be read): no
    driveset_in(d)
        .args(["replace", LINE, "--drive", "press-axis-3", "--port", &port, "--prompt-stdin"])
        .write_stdin("n\n")
        .assert()
        .code(1)
        .stderr(format!(
            "replace press-axis-3: write address 3, 9600 baud and 46 codes to the unit on {port}? [y/N] not replaced: nothing was written\n"
        ));
    assert_eq!(spare_state(d).0, 1);
    // yes
    driveset_in(d)
        .args([
            "replace",
            LINE,
            "--drive",
            "press-axis-3",
            "--port",
            &port,
            "--prompt-stdin",
        ])
        .write_stdin("y\n")
        .assert()
        .code(0);
    assert_eq!(spare_state(d).0, 3);
}

/// The drives of a LECOM line served by `driveset sim` on a pty (issue
/// 28): `replace` must prove the service port holds the spare alone.
mod on_a_pty {
    use std::path::Path;

    use crate::e2e_pty::{Sim, one_at_a_time};
    use driveset_test_support::{driveset_at, outcome};

    /// A Tmd set of a few codes (no bus address, no rate: the manifest's
    /// are the truth).
    const TMD_SET: &str = "schema = \"lenze-tmd\"\ntitle = \"conveyor\"\n\n[values]\nC0010 = \"5.0 Hz\"\nC0011 = \"60.0 Hz\"\nC0012 = \"8.0 s\"\n";

    /// `line.toml` in `dir`: bus `conveyors` on `port` (LECOM, 9600 baud)
    /// with conveyor-1 (address 1), conveyor-3 (13) and conveyor-4 (14).
    pub(super) fn lecom_line(dir: &Path, port: &str) {
        std::fs::create_dir_all(dir.join("sets")).unwrap();
        let mut line = format!(
            "[line]\nname = \"conveyors\"\n\n[[bus]]\nname = \"conveyors\"\nport = \"{port}\"\nprotocol = \"lecom\"\nbaud = 9600\n"
        );
        for (name, address) in [("conveyor-1", 1), ("conveyor-3", 13), ("conveyor-4", 14)] {
            std::fs::write(dir.join(format!("sets/{name}.toml")), TMD_SET).unwrap();
            line.push_str(&format!(
                "\n[[drive]]\nname = \"{name}\"\nbus = \"conveyors\"\naddress = {address}\nset = \"sets/{name}.toml\"\n"
            ));
        }
        std::fs::write(dir.join("line.toml"), line).unwrap();
    }

    /// What the simulator's drives hold after SIGTERM: (address, canonical
    /// lines without the address code C0009) per drive.
    pub(super) fn held(sim: &mut Sim, dir: &Path, family: &str) -> Vec<(u8, String)> {
        assert!(sim.terminate().success(), "{}", sim.stderr());
        let dump: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("{family}.dump.json"))).unwrap(),
        )
        .unwrap();
        dump["drives"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| {
                let canonical: Vec<&str> = d["canonical"]
                    .as_str()
                    .unwrap()
                    .lines()
                    .filter(|l| !l.starts_with("C0009 "))
                    .collect();
                (d["address"].as_u64().unwrap() as u8, canonical.join("\n"))
            })
            .collect()
    }

    /// The host's telegrams that change a drive (LECOM SEND: STX after the
    /// address, §8) in the simulator's `--log`.
    pub(super) fn sends(dir: &Path) -> usize {
        let log = std::fs::read_to_string(dir.join("sim.log")).unwrap_or_default();
        log.lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|e| e["dir"] == "host")
            .filter(|e| e["hex"].as_str().unwrap_or_default().contains("02"))
            .count()
    }

    fn serve_two(dir: &Path) -> Sim {
        let log = dir.join("sim.log");
        Sim::start(
            dir,
            "tmd",
            1,
            &[
                "--address",
                "14",
                "--c0001",
                "3",
                "--log",
                log.to_str().unwrap(),
            ],
        )
    }

    /// The case: the service port is the line's own LECOM bus,
    /// where conveyor-1 (1) and conveyor-4 (14) answer. Refused before
    /// anything is sent, naming the bus; both drives keep what they hold.
    #[test]
    fn replace_through_the_lines_own_bus_is_refused_before_anything_is_sent() {
        let _serial = one_at_a_time();
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut sim = serve_two(d);
        lecom_line(d, &sim.path);
        let (code, stdout, stderr) = outcome(driveset_at(d).args([
            "replace",
            "line.toml",
            "--drive",
            "conveyor-3",
            "--port",
            &sim.path,
            "--yes",
        ]));
        assert_eq!(code, Some(2), "{stdout}\n{stderr}");
        assert_eq!(stdout, "");
        assert_eq!(
            stderr,
            format!(
                "error: the service port {p} reaches bus `conveyors` of the line ({p}?baud=9600; bus id serial:{p}): the line's drives are on it, and a spare must be alone on its port; nothing was sent. Connect the spare alone to a service port and run again\n",
                p = sim.path
            )
        );
        assert_eq!(sends(d), 0);
        let held = held(&mut sim, d, "tmd");
        assert_eq!(held.iter().map(|h| h.0).collect::<Vec<_>>(), [1, 14]);
        assert_eq!(
            held[0].1, held[1].1,
            "conveyor-1 still holds what conveyor-4 holds"
        );
    }

    /// A service port (not the line's bus) that holds two units: refused
    /// after the scan of every LECOM address, naming both; nothing written.
    #[test]
    fn replace_with_two_units_on_the_service_port_is_refused_naming_them() {
        let _serial = one_at_a_time();
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut sim = serve_two(d);
        lecom_line(d, "sim://tmd?c0001=3");
        let (code, stdout, stderr) =
            outcome(driveset_at(d).env_remove("DRIVESET_SIM_STATE_DIR").args([
                "replace",
                "line.toml",
                "--drive",
                "conveyor-3",
                "--port",
                &sim.path,
                "--yes",
            ]));
        assert_eq!(code, Some(2), "{stdout}\n{stderr}");
        assert_eq!(stdout, "");
        assert_eq!(
            stderr,
            format!(
                "error: {} address 1: refused: the service port holds more than one device (a scan of the LECOM stations 01..99 finds address 1: C0093 = 0; address 14: C0093 = 0); a spare must be alone on its port; nothing was written. Connect the spare alone and run again\n",
                sim.path
            )
        );
        assert_eq!(sends(d), 0);
        let held = held(&mut sim, d, "tmd");
        assert_eq!(held.iter().map(|h| h.0).collect::<Vec<_>>(), [1, 14]);
        assert_eq!(held[0].1, held[1].1);
    }
}

/// Issue 28: `replace` on a spare whose motor runs wrote the address first
/// and refused the upload after (exit 1). Refused before anything is sent
/// (exit 2), as upload refuses.
#[test]
fn a_running_spare_on_a_pty_is_refused_before_anything_is_sent() {
    let _serial = crate::e2e_pty::one_at_a_time();
    let dir = demo_line_dir();
    let d = dir.path();
    let mut sim = crate::address::running_mc6000_on_a_pty(d, &[]);
    let (code, stdout, stderr) =
        driveset_test_support::outcome(driveset_test_support::driveset_at(d).args([
            "replace",
            LINE,
            "--drive",
            "press-axis-3",
            "--port",
            &sim.path,
            "--yes",
        ]));
    assert_eq!(code, Some(2), "{stdout}\n{stderr}\n{}", sim.stderr());
    assert_eq!(stdout, "");
    assert_eq!(
        stderr,
        format!(
            "error: {} address 0: refused: the drive reports a running motor; driveset changes a drive's bus address or line rate only at standstill: stop it (standstill), or pass --allow-running\n",
            sim.path
        )
    );
    assert_eq!(crate::address::selects_in_log(d), Vec::<String>::new());
    assert!(sim.terminate().success());
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("mc6000.dump.json")).unwrap())
            .unwrap();
    assert_eq!(
        dump["drives"][0]["address"], 1,
        "the spare keeps its address"
    );
}
