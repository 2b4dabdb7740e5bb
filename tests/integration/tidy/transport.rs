//! Holds docs/architecture.md's rule "A simulated port is only a
//! transport": outside the opener registration (`crates/driveset-cli/src/port.rs`,
//! the CLI's `CliPorts` and `openers`) and the twin bridge's rehearsal
//! buses, no source of the CLI or the engine asks
//! whether a port is simulated, names the simulator's port or bus types,
//! or keeps a schema, registry, fit rule or lock rule for `sim://` ports.

use std::collections::BTreeMap;

use driveset_test_support::workspace_root;

use super::{read, report, sources};

/// What a `sim://`-specific branch looks like in the CLI's and the
/// engine's sources.
const SIM_BRANCHES: &[&str] = &[
    "\"sim://",
    "PortSpec::Sim",
    "SimSpec",
    "SimOpener",
    "SimBus",
    "SimLink",
    "open_sim",
    "peek_sim_family",
    "sim_registry",
    "registry_for",
    "simulated_family",
    "SimulatedDrives",
    "FitError::Simulated",
    ".simulated",
    "sim_bus",
    "driveset_sim::catalog::schema",
    "driveset_sim::port",
];

/// The files that may name them: the opener registration and the twin
/// bridge's rehearsal buses (`driveset sim`'s work is the simulator's own,
/// `driveset_sim::command`).
const SIM_REGISTRATION: &[(&str, &str)] = &[
    (
        "crates/driveset-cli/src/port.rs",
        "the opener registration: `CliPorts` opens `sim://` ports with the simulator, `openers` registers its opener",
    ),
    (
        "crates/driveset-twin/src/rehearse.rs",
        "the twin bridge: a rehearsal serves the twins (the simulator's file format) on simulated buses of its own (docs/twins.md)",
    ),
];

/// Files that still name the link's opaque-port variant, with their
/// count (which may only go down) and why: they ask the registered opener
/// of an opaque port, whatever its scheme, and name none.
const OPAQUE_PORTS: &[(&str, usize, &str)] = &[(
    "crates/driveset-engine/src/line/manifest/reader/ports.rs",
    3,
    "a manifest's bus port: the registered opener of an opaque port checks it and puts the manifest's drives on it (PortOpener::check, with_drives); no scheme is named",
)];

/// The lines of the CLI's, the engine's and the twin bridge's sources
/// (comments and test modules left out) that name a `sim://`-specific
/// item, by file.
fn sim_branches() -> BTreeMap<String, Vec<(usize, String)>> {
    let mut out: BTreeMap<String, Vec<(usize, String)>> = BTreeMap::new();
    for source in sources() {
        let scanned = [
            "crates/driveset-engine/src/",
            "crates/driveset-twin/src/",
            "crates/driveset-cli/src/",
        ]
        .iter()
        .any(|d| source.under(d));
        if !scanned || source.path.ends_with("tests.rs") {
            continue;
        }
        for (n, line) in source.code() {
            if line.trim_start().starts_with("#[arg") {
                continue;
            }
            if let Some(what) = SIM_BRANCHES.iter().find(|p| line.contains(*p)) {
                out.entry(source.path.clone())
                    .or_default()
                    .push((n, (*what).to_string()));
            }
        }
    }
    out
}

#[test]
fn tidy_no_sim_branch_outside_the_opener_registration() {
    let mut problems = Vec::new();
    let found = sim_branches();
    for (path, hits) in &found {
        if SIM_REGISTRATION.iter().any(|(f, _)| f == path) {
            continue;
        }
        let opaque_only = hits.iter().all(|(_, w)| w == "PortSpec::Sim");
        if let Some((_, max, _)) = OPAQUE_PORTS.iter().find(|(f, ..)| f == path)
            && opaque_only
        {
            if hits.len() > *max {
                problems.push(format!(
                    "{path}:{}: {} opaque-port branches, {max} listed in OPAQUE_PORTS (tests/integration/tidy/transport.rs): ask the registered opener, do not add branches",
                    hits[0].0,
                    hits.len()
                ));
            }
            continue;
        }
        for (line, what) in hits {
            problems.push(format!(
                "{path}:{line}: `{what}` is a sim://-specific branch outside the opener registration: a simulated port is only a transport; resolve, open and check it as every port is (docs/architecture.md, \"A simulated port is only a transport\")"
            ));
        }
    }
    for (f, max, _) in OPAQUE_PORTS {
        let n = found.get(*f).map_or(0, Vec::len);
        if n < *max {
            problems.push(format!(
                "{f}:1: {n} opaque-port branches, {max} listed in OPAQUE_PORTS: lower its count to {n}"
            ));
        }
    }
    report("sim:// is a transport (docs/architecture.md)", &problems);
}

#[test]
fn tidy_the_sim_branch_check_sees_a_branch() {
    // the patterns catch what the rule forbids, and not comments
    let line = "    let sim = port::peek_sim_family_at(&args.port, Some(args.address));";
    assert!(SIM_BRANCHES.iter().any(|p| line.contains(p)));
    let line = "        if matches!(spec, PortSpec::Sim(_)) {";
    assert!(SIM_BRANCHES.iter().any(|p| line.contains(p)));
    let line = "    if opened.simulated.is_some() {";
    assert!(SIM_BRANCHES.iter().any(|p| line.contains(p)));
    // the registration exists and still registers the simulator
    let found = sim_branches();
    assert!(found.contains_key("crates/driveset-cli/src/port.rs"));
}

/// The commands that open a drive port: their port arguments come from
/// the CLI's one `Port<C>` (`crates/driveset-cli/src/port_args.rs`).
const PORT_COMMANDS: &[&str] = &[
    "address",
    "diff",
    "doctor",
    "identify",
    "pull",
    "recover",
    "replace",
    "scan",
    "schema/pull",
    "twin",
    "upload",
];

/// Fields a command would define its own port arguments with.
const PORT_FIELDS: &[&str] = &[
    "pub port:",
    "pub address:",
    "pub schemas:",
    "pub allow_family:",
    "pub schema_dir:",
    "pub no_learn:",
    "pub description_layout:",
    "pub type_chars:",
];

#[test]
fn tidy_port_arguments_are_defined_once() {
    let root = workspace_root();
    let mut problems = Vec::new();
    for cmd in PORT_COMMANDS {
        let path = format!("crates/driveset-cli/src/cmd/{cmd}.rs");
        let text = read(&root.join(&path));
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let field = line.trim_start();
            // a clap field: an `#[arg(...)]` (or its doc comment) above it
            let clap = lines[..i]
                .iter()
                .rev()
                .take_while(|l| {
                    l.trim_start().starts_with("#[") || l.trim_start().starts_with("///")
                })
                .any(|l| l.trim_start().starts_with("#[arg"));
            if clap && PORT_FIELDS.iter().any(|f| field.starts_with(f)) {
                problems.push(format!(
                    "{path}:{}: `{field}` defines a port argument of its own: flatten `Port<Args>` and say what the command takes in its `PortCommand::TAKES` (crates/driveset-cli/src/port_args.rs)",
                    i + 1
                ));
            }
        }
        assert!(
            text.contains("impl PortCommand for"),
            "{path}: takes no `Port<C>`"
        );
    }
    report(
        "one set of port arguments (docs/architecture.md)",
        &problems,
    );
}
