//! A CANopen device simulated from its data sheet (`sim://eds?file=`,
//! `driveset sim --eds`): an EDS imported with `schema import`, a set
//! validated against it and uploaded to the device the same sheet
//! describes, a power cycle, a diff. The sheet with CiA 301 0x1010 keeps
//! the set once the upload stored it; the one without loses it, and the
//! upload said so. A schema edited to disagree with the sheet meets the
//! device's SDO aborts. The fault campaign through the binary cuts the
//! upload at each of its telegrams and power-cycles the device after every
//! run that ends complete. Every step runs the built binary on state files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use driveset_test_support::{driveset_in_with_locks, outcome, workspace_root};

fn eds(name: &str) -> PathBuf {
    workspace_root().join(format!("tests/data/eds/{name}.eds"))
}

fn port(name: &str, state: &Path) -> String {
    format!(
        "sim://eds?file={}&addresses=5&state={}",
        eds(name).display(),
        state.display()
    )
}

/// `schema import` into `DIR/schemas/NAME.toml` and a set of three
/// changed values against it.
fn import_and_set(dir: &Path, name: &str) -> PathBuf {
    let schema = dir.join(format!("schemas/{name}.toml"));
    let (code, out, err) = outcome(
        driveset_in_with_locks(dir)
            .args(["schema", "import"])
            .arg(eds(name))
            .arg("-o")
            .arg(&schema),
    );
    // exit 1: the lints (the skipped 0x1010 sub 0, the device name)
    assert_eq!(code, Some(1), "{out}{err}");
    let set = dir.join(format!("{name}.toml"));
    std::fs::write(
        &set,
        format!(
            "schema = \"schemas/{name}.toml\"\n\n[values]\nopening_time = 1200\nclosing_time = 900\npressure_offset = -25\n"
        ),
    )
    .unwrap();
    let (code, out, err) = outcome(driveset_in_with_locks(dir).arg("validate").arg(&set));
    assert_eq!(code, Some(0), "{out}{err}");
    set
}

fn upload(dir: &Path, set: &Path, port: &str, journal: &str) -> (Option<i32>, String, String) {
    outcome(driveset_in_with_locks(dir).arg("upload").arg(set).args([
        "--port",
        port,
        "--address",
        "5",
        "--journal",
        journal,
        // the sheet names no running indicator
        "--allow-running-unknown",
    ]))
}

fn power_cycle(dir: &Path, name: &str, state: &Path) {
    let (code, _, err) = outcome(
        driveset_in_with_locks(dir)
            .args(["sim", "--eds"])
            .arg(eds(name))
            .arg("--state")
            .arg(state)
            .arg("--power-cycle"),
    );
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(
        err,
        format!(
            "power-cycled 1 simulated ecs drive of {}\n",
            state.display()
        )
    );
}

fn diff(dir: &Path, set: &Path, port: &str) -> (Option<i32>, String) {
    let (code, out, err) = outcome(driveset_in_with_locks(dir).arg("diff").arg(set).args([
        "--port",
        port,
        "--address",
        "5",
    ]));
    (code, format!("{out}{err}"))
}

#[test]
fn an_eds_with_0x1010_is_stored_and_held_over_a_power_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let name = "fictional-valve-store";
    let set = import_and_set(d, name);
    let schema = std::fs::read_to_string(d.join(format!("schemas/{name}.toml"))).unwrap();
    assert!(
        schema.contains(
            "[schema.store]\nkeeps = \"on-command\"\ncode = 17829889\nvalue = 0x65766173\n"
        ),
        "{schema}"
    );
    let state = d.join("valve.json");
    let p = port(name, &state);
    let (code, out, err) = upload(d, &set, &p, "j.json");
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("  0x2000 opening_time: 800 -> 1200  verified\n"),
        "{out}"
    );
    assert!(out.contains("\nstore: stored\n"), "{out}");
    // the state file holds a data sheet's device: a power cycle without
    // the sheet is refused, naming the option, and changes nothing
    let before = std::fs::read(&state).unwrap();
    let (code, _, err) = outcome(
        driveset_in_with_locks(d)
            .args(["sim", "--power-cycle", "--state"])
            .arg(&state),
    );
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(
        err,
        format!(
            "error: --state {}: drive 5 was saved with schema `fictional-valve-store`, not the simulated ecs drives' `fictional-ecs-demo`; power-cycle it as it was served: add --eds FILE (a device from its data sheet) or --twin FILE\n",
            state.display()
        )
    );
    assert_eq!(std::fs::read(&state).unwrap(), before);
    power_cycle(d, name, &state);
    let (code, text) = diff(d, &set, &p);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.ends_with("no differences\n"), "{text}");
}

#[test]
fn an_eds_without_0x1010_is_reported_not_stored_and_lost_over_a_power_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let name = "fictional-valve";
    let set = import_and_set(d, name);
    let schema = std::fs::read_to_string(d.join(format!("schemas/{name}.toml"))).unwrap();
    assert!(
        schema.contains("[schema.store]\nkeeps = \"unknown\"\nspec = \"fictional-valve.eds: declares no store parameters object (0x1010)\"\n"),
        "{schema}"
    );
    let state = d.join("valve.json");
    let p = port(name, &state);
    let (code, out, err) = upload(d, &set, &p, "j.json");
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("\nstore: not stored: lost at power off (the schema gives no store step: [schema.store] keeps = \"unknown\")\n"),
        "{out}"
    );
    // held until the power goes
    assert_eq!(diff(d, &set, &p).0, Some(0));
    power_cycle(d, name, &state);
    let (code, text) = diff(d, &set, &p);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("~ 0x2000 opening_time: 800 -> 1200\n~ 0x2001 closing_time: 600 -> 900\n~ 0x2002 pressure_offset: 0 -> -25\n"),
        "{text}"
    );
}

#[test]
fn a_device_from_its_sheet_aborts_what_the_sheet_forbids() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let name = "fictional-valve";
    import_and_set(d, name);
    // a schema that disagrees with the sheet on purpose: a wider limit, a
    // read-only object made writable, an object the sheet does not list
    let text = std::fs::read_to_string(d.join(format!("schemas/{name}.toml"))).unwrap();
    let mut edited = text
        .replacen(
            "id = \"fictional-valve\"",
            "id = \"fictional-valve-edited\"",
            1,
        )
        .replacen("max = \"5000\"", "max = \"9000\"", 1);
    let at = edited.find("name = \"valve_count\"").unwrap();
    let ro = at + edited[at..].find("access = \"ro\"").unwrap();
    edited.replace_range(ro..ro + "access = \"ro\"".len(), "access = \"rw\"");
    edited.push_str("\n[[code]]\nnumber = 73732\nindex = 0x2004\nname = \"flush_time\"\ntitle = \"Flush time (not on the sheet)\"\nspec = \"hand-added\"\ntype = \"UNSIGNED16\"\naccess = \"rw\"\n");
    std::fs::write(d.join("schemas/edited.toml"), edited).unwrap();
    let state = d.join("valve.json");
    let p = port(name, &state);
    for (i, (value, abort)) in [
        ("opening_time = 6000", "write 0x2000 (raw 6000) refused: Value range of parameter exceeded (only for write access) (SDO abort 0x06090030 at index 0x2000 subindex 0)"),
        ("valve_count = 5", "write 0x2003 (raw 5) refused: Attempt to write a read only object (SDO abort 0x06010002 at index 0x2003 subindex 0)"),
        ("flush_time = 3", "read 0x2004 refused: Object does not exist in the object dictionary (SDO abort 0x06020000 at index 0x2004 subindex 0)"),
    ]
    .into_iter()
    .enumerate()
    {
        let set = d.join(format!("x{i}.toml"));
        std::fs::write(
            &set,
            format!("schema = \"schemas/edited.toml\"\n\n[values]\n{value}\n"),
        )
        .unwrap();
        let (code, out, err) = upload(d, &set, &p, &format!("j{i}.json"));
        assert_eq!(code, Some(3), "{out}{err}");
        assert!(err.contains(abort), "{err}");
    }
    // nothing of it landed: the device holds its sheet's defaults
    let dump = driveset_sim::open::StateDump::read(&state).unwrap();
    let canonical = &dump.drives[0].canonical;
    // 0x2000 is code 65536 + 0x2000, 0x2003 code 65536 + 0x2003
    assert!(canonical.contains("\nC73728 800\n"), "{canonical}");
    assert!(canonical.contains("\nC73731 4\n"), "{canonical}");
}

/// The journal's last state, `None` where the run wrote no journal.
fn journal_state(journal: &Path) -> Option<String> {
    let text = std::fs::read_to_string(journal).ok()?;
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    let last = j["transitions"].as_array()?.last()?;
    Some(last["state"].as_str()?.to_string())
}

/// The fault campaign through the built binary: the upload of three values
/// to the device with 0x1010 (13 telegrams when nothing goes wrong) cut at
/// each of its telegrams, by a pulled cable (odd telegrams) or a power cycle
/// (even ones, the store command's among them), `recover` where the journal
/// is left unsettled; then, whatever the run ended in, the device is
/// power-cycled and diffed. After every "complete" it still holds the set
/// (and the run said `store: stored`); after a rollback or a run cut before
/// anything was written it holds the sheet's defaults: never a set that was
/// called complete and lost at power off.
#[test]
fn the_fault_campaign_power_cycles_after_every_complete_and_the_device_holds_its_set() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let name = "fictional-valve-store";
    let set = import_and_set(d, name);
    let defaults = "~ 0x2000 opening_time: 800 -> 1200\n~ 0x2001 closing_time: 600 -> 900\n~ 0x2002 pressure_offset: 0 -> -25\n";
    let mut ends: BTreeMap<&str, u32> = BTreeMap::new();
    for i in 1..=13u32 {
        let fault = if i % 2 == 1 {
            format!("cable@{i}+600s")
        } else {
            format!("power-cycle@{i}:off=200ms")
        };
        let state = d.join(format!("valve-{i}.json"));
        let journal = d.join(format!("j{i}.json"));
        let p = port(name, &state);
        let (code, out, err) = upload(
            d,
            &set,
            &format!("{p}&faults={fault}"),
            journal.to_str().unwrap(),
        );
        let mut said = format!("{out}{err}");
        let mut end = journal_state(&journal);
        match end.as_deref() {
            Some("complete") => assert_eq!(code, Some(0), "{fault}: {said}"),
            _ => assert_eq!(code, Some(3), "{fault}: {said}"),
        }
        let recovered = !matches!(end.as_deref(), None | Some("complete" | "rolled-back"));
        if recovered {
            let (code, out, err) = outcome(
                driveset_in_with_locks(d)
                    .arg("recover")
                    .arg(&journal)
                    .args(["--port", &p, "--address", "5"]),
            );
            said = format!("{out}{err}");
            assert_eq!(code, Some(0), "{fault}: recover: {said}");
            end = journal_state(&journal);
        }
        power_cycle(d, name, &state);
        let (code, text) = diff(d, &set, &p);
        let kind = match end.as_deref() {
            Some("complete") => {
                assert!(
                    said.contains("\nstore: stored"),
                    "{fault}: complete without the store: {said}"
                );
                assert_eq!(
                    code,
                    Some(0),
                    "{fault}: complete, then lost at power off: {text}"
                );
                assert!(text.ends_with("no differences\n"), "{fault}: {text}");
                if recovered {
                    "recovered to the set"
                } else {
                    "complete"
                }
            }
            Some("rolled-back") | None => {
                assert_eq!(code, Some(1), "{fault}: {text}");
                assert!(text.contains(defaults), "{fault}: {text}");
                if recovered {
                    "recovered to the defaults"
                } else {
                    "rolled back"
                }
            }
            Some(other) => panic!("{fault}: the journal was left `{other}`: {said}"),
        };
        *ends.entry(kind).or_default() += 1;
    }
    eprintln!("{ends:?}");
    // every outcome of the campaign was met at least once
    for kind in ["complete", "rolled back", "recovered to the set"] {
        assert!(ends.contains_key(kind), "no run ended {kind}: {ends:?}");
    }
}
