//! `driveset commission LINE --assign` (issue 20): the demo line's LUSTBUS,
//! seven drives fresh from the factory on a simulated service bench
//! (`sim://lustbus?factory=mc6000*4,vf1000*3&bench=true&state=F`: at each
//! open of the port only the first drive still at the factory address is
//! connected; once every drive has its address, all are on the line): each
//! gets its manifest address, the final scan holds, the commission follows.

use std::path::Path;

use predicates::prelude::*;

use driveset_test_support::{copy_dir, driveset_at, workspace_root};

const NAMES: [&str; 7] = [
    "press-axis-1",
    "press-axis-2",
    "press-axis-3",
    "press-axis-4",
    "conveyor-5",
    "conveyor-6",
    "conveyor-7",
];

/// The demo line's LUSTBUS bus and drives, on a factory bench.
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    copy_dir(
        &workspace_root().join("parameter-sets/demo-line"),
        &d.join("ps/demo-line"),
    );
    copy_dir(
        &workspace_root().join("parameter-sets/fixtures"),
        &d.join("ps/fixtures"),
    );
    let demo = std::fs::read_to_string(d.join("ps/demo-line/line.toml")).unwrap();
    let drives = &demo[demo.find("# lustbus: MC6000 servo axes").unwrap()
        ..demo.find("# transfer: Tmd inverters").unwrap()];
    let line = format!(
        "[line]\nname = \"bench-line\"\n\n[[bus]]\nname = \"lustbus\"\nport = \"sim://lustbus?factory=mc6000*4,vf1000*3&bench=true&state={}\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n{drives}",
        d.join("bench.json").display()
    );
    std::fs::write(d.join("ps/demo-line/bench.toml"), line).unwrap();
    dir
}

const LINE: &str = "ps/demo-line/bench.toml";

fn scan_table(port: &str) -> String {
    let rows = [
        "ADDRESS  DRIVE         EXPECTED  ANSWERED          CHECK",
        "      1  press-axis-1  mc6000    mc6000 TYPE 6000  ok",
        "      2  press-axis-2  mc6000    mc6000 TYPE 6000  ok",
        "      3  press-axis-3  mc6000    mc6000 TYPE 6000  ok",
        "      4  press-axis-4  mc6000    mc6000 TYPE 6000  ok",
        "      5  conveyor-5    vf1000    vf1000 TYPE 1000  ok",
        "      6  conveyor-6    vf1000    vf1000 TYPE 1000  ok",
        "      7  conveyor-7    vf1000    vf1000 TYPE 1000  ok",
    ];
    format!(
        "\nbus `lustbus` ({port}), scanned:\n{}\nbus `lustbus`: 7 drive(s) assigned, every manifest address answers as its set's family, nothing else answers; ",
        rows.join("\n")
    )
}

fn bench_addresses(dir: &Path) -> Vec<u8> {
    let dump = driveset_sim::open::StateDump::read(&dir.join("bench.json")).expect("bench state");
    dump.drives.iter().map(|d| d.address).collect()
}

fn port(dir: &Path) -> String {
    format!(
        "sim://lustbus?factory=mc6000*4,vf1000*3&bench=true&baud=9600&state={}",
        dir.join("bench.json").display()
    )
}

#[test]
fn assign_yes_gives_seven_factory_drives_their_addresses_then_commissions() {
    let dir = setup();
    let d = dir.path();
    let mut expect_assigned = String::new();
    for (i, n) in NAMES.iter().enumerate() {
        let (fam, ty) = if i < 4 {
            ("mc6000", 6000)
        } else {
            ("vf1000", 1000)
        };
        expect_assigned.push_str(&format!(
            "{n}: address {}, 9600 baud ({fam} TYPE {ty}, found at 9600 baud)\n",
            i + 1
        ));
    }
    let out = driveset_at(d)
        .args(["commission", LINE, "--assign", "--yes"])
        .assert()
        .code(0)
        .stdout(predicate::str::starts_with(format!(
            "{expect_assigned}{}",
            scan_table(&port(d))
        )))
        .stdout(predicate::str::contains(
            "7 of 7 drives commissioned: 7 verified, 0 unchanged, 0 already verified, 0 drift, 0 rolled back, 0 failed; line bench-line: ok\n",
        ))
        .stderr(predicate::str::contains(format!(
            "press-axis-1: assigning address 1 on {} (--yes: the manifest's order, no prompt)\n",
            port(d)
        )))
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let secs = text
        .split("nothing else answers; ")
        .nth(1)
        .and_then(|t| t.split(" s on the bus").next())
        .unwrap();
    eprintln!(
        "commission --assign of 7 factory drives at 9600 baud: {secs} s virtual (assignment and final scan)"
    );
    assert_eq!(bench_addresses(d), [1, 2, 3, 4, 5, 6, 7]);
}

#[test]
fn assign_interactive_prompts_for_each_drive_in_manifest_order() {
    let dir = setup();
    let d = dir.path();
    let assert = driveset_at(d)
        .args(["commission", LINE, "--assign", "--prompt-stdin"])
        .write_stdin("\n".repeat(7))
        .assert()
        .code(0);
    let err = String::from_utf8(assert.get_output().stderr.clone()).unwrap();
    let prompts: Vec<String> = err
        .split("then press Enter ")
        .filter(|p| p.contains("connect "))
        .map(|p| p[p.rfind("connect ").unwrap()..].to_string())
        .collect();
    let want: Vec<String> = NAMES
        .iter()
        .map(|n| format!("connect {n} alone to {}, ", port(d)))
        .collect();
    assert_eq!(prompts, want);
    assert_eq!(bench_addresses(d), [1, 2, 3, 4, 5, 6, 7]);
}

#[test]
fn assign_without_yes_on_a_non_interactive_stdin_is_refused() {
    let dir = setup();
    let d = dir.path();
    driveset_at(d)
        .args(["commission", LINE, "--assign"])
        .assert()
        .code(2)
        .stdout("")
        .stderr(
            "error: commission --assign asks before writing, and stdin is not a terminal; give --yes to run without asking (nothing was written)\n",
        );
    assert!(!d.join("bench.json").exists());
}

#[test]
fn a_can_bus_is_skipped_with_a_message() {
    let dir = setup();
    let d = dir.path();
    let demo = std::fs::read_to_string(d.join("ps/demo-line/line.toml")).unwrap();
    let handling = &demo[demo.find("# handling: ECS servo axes").unwrap()..];
    let line = format!(
        "[line]\nname = \"can-line\"\n\n[[bus]]\nname = \"handling\"\nport = \"sim://ecs\"\nprotocol = \"can\"\nbitrate = 500000\n\n{handling}"
    );
    std::fs::write(d.join("ps/demo-line/can.toml"), line).unwrap();
    driveset_at(d)
        .env("DRIVESET_SIM_STATE_DIR", d.join("sim"))
        .args(["commission", "ps/demo-line/can.toml", "--assign", "--yes"])
        .assert()
        .code(0)
        .stdout(predicate::str::starts_with(
            "bus `handling`: skipped: bus `handling` is a CAN bus: an ECS node id is set at the unit, not assigned over the bus; its drives are not assigned\n",
        ))
        .stdout(predicate::str::contains("3 of 3 drives commissioned: 3 verified"));
}

/// Issue 28: one unit on the port (an MC6000 served by `driveset sim` on a
/// pty, always connected) and two drives of the manifest. The first gets
/// address 3; the second finds the same unit holding 3, which this run
/// gave press-axis-3, and is refused before anything is written (before:
/// the unit was addressed twice and ended at 4).
#[test]
fn assign_never_gives_one_unit_two_manifest_addresses() {
    let _serial = crate::e2e_pty::one_at_a_time();
    let dir = setup();
    let d = dir.path();
    let mut sim = crate::e2e_pty::Sim::start(d, "mc6000", 1, &[]);
    let demo = std::fs::read_to_string(d.join("ps/demo-line/line.toml")).unwrap();
    let drives = &demo[demo.find("[[drive]]\nname = \"press-axis-3\"").unwrap()
        ..demo.find("# lustbus: VF1000 conveyor").unwrap()];
    std::fs::write(
        d.join("ps/demo-line/one-unit.toml"),
        format!(
            "[line]\nname = \"one-unit\"\n\n[[bus]]\nname = \"lustbus\"\nport = \"{}\"\nprotocol = \"lustbus\"\nbaud = 9600\n\n{drives}",
            sim.path
        ),
    )
    .unwrap();
    let (code, out, err) = driveset_test_support::outcome(driveset_at(d).args([
        "commission",
        "ps/demo-line/one-unit.toml",
        "--assign",
        "--yes",
    ]));
    assert_eq!(code, Some(1), "{out}\n{err}\n{}", sim.stderr());
    assert!(
        out.starts_with(
            "press-axis-3: address 3, 9600 baud (mc6000 TYPE 6000, found at 9600 baud)\npress-axis-4: FAILED: the unit on the port holds address 3, which this run gave `press-axis-3`: it is `press-axis-3`'s unit again, not `press-axis-4`'s; nothing was written. Disconnect it and connect `press-axis-4`'s unit alone\nbus `lustbus`: not scanned: a drive of bus `lustbus` was not assigned\n"
        ),
        "{out}\n{err}"
    );
    assert!(sim.terminate().success());
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("mc6000.dump.json")).unwrap())
            .unwrap();
    assert_eq!(dump["drives"][0]["address"], 3, "addressed once: {dump}");
}
