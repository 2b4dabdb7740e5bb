//! One path from a port to a drive (docs/architecture.md): clients are
//! built only by `connect` and the session, and ports are opened (and
//! their buses locked) only through the session's sequence, in every
//! crate above the transports.

use std::collections::BTreeSet;

use driveset_test_support::workspace_root;

use super::{Source, report, sources};

/// The client constructors: only `connect.rs` (which `engine::session`
/// calls) and the clients themselves use them.
const CLIENT_CONSTRUCTORS: &[&str] = &[
    "LustbusClient::new(",
    "LustbusClient::with_options(",
    "LecomClient::new(",
    "LecomClient::with_options(",
    "CanClient::new(",
];

/// Source files that still build a client themselves, with how many
/// constructions each holds (a count may only go down).
const CLIENTS_STILL_BUILT_ELSEWHERE: &[(&str, usize)] = &[];

/// `connect`'s clients on a link the caller keeps: a drive's work gets its
/// client from the session (`engine::session::BusSession`, whose `reach`
/// calls `connect_on`); only the bus-level work below asks `connect` for
/// one itself.
const BORROWED_CLIENTS: &[&str] = &["connect_on(", "lustbus_on(", "lecom_on("];

/// Source files that ask `connect` for a client on a link they keep, with
/// how many calls each holds (a count may only go down): a line's work on its bus rather than on one drive: the LUSTBUS
/// SELECT to address 31 and the transactions parked around it, the LECOM
/// MULTICAST and the running check of its members (docs/architecture.md,
/// "One path from a port to a drive").
const BORROWED_CLIENTS_OUTSIDE_THE_SESSION: &[(&str, usize)] = &[
    ("crates/driveset-engine/src/line/commission/broadcast.rs", 1),
    ("crates/driveset-engine/src/line/commission/multicast.rs", 2),
    ("crates/driveset-engine/src/line/commission/parked.rs", 2),
];

/// How often `patterns` occur in the code of `source` (comments and test
/// modules left out), and the 1-based line of the first.
fn occurrences(source: &Source, patterns: &[&str]) -> (usize, usize) {
    let mut n = 0;
    let mut first = 0;
    for (i, line) in source.code() {
        let here = patterns.iter().filter(|c| line.contains(*c)).count();
        if here > 0 && n == 0 {
            first = i;
        }
        n += here;
    }
    (n, first)
}

/// Where drive ports are what is opened rather than opened to reach a
/// drive: the link's transports and bus lock, the simulator's port opener
/// and its buses. Every other crate is held to the session's one path.
const THE_TRANSPORTS: &[&str] = &["crates/driveset-link/src/", "crates/driveset-sim/src/"];

#[test]
fn tidy_clients_are_built_only_by_connect_and_the_session() {
    let root = workspace_root();
    let mut problems = Vec::new();
    for source in sources() {
        let path = &source.path;
        if path == "crates/driveset-engine/src/connect.rs"
            || path.starts_with("crates/driveset-engine/src/client/")
        {
            continue;
        }
        let (n, first) = occurrences(source, CLIENT_CONSTRUCTORS);
        let allowed = CLIENTS_STILL_BUILT_ELSEWHERE
            .iter()
            .find(|(f, _)| f == path)
            .map_or(0, |(_, a)| *a);
        if n > allowed {
            problems.push(format!(
                "{path}:{first}: {n} client construction(s): reach a drive through `engine::session::Session` or `engine::connect` (docs/architecture.md, \"One path from a port to a drive\")"
            ));
        } else if n < allowed {
            problems.push(format!(
                "{path}:1: {n} client construction(s), the allowlist says {allowed}: lower or remove its entry in CLIENTS_STILL_BUILT_ELSEWHERE (tests/integration/tidy/session.rs)"
            ));
        }
        if path.starts_with("crates/driveset-engine/src/session/") {
            continue;
        }
        let (n, first) = occurrences(source, BORROWED_CLIENTS);
        let allowed = BORROWED_CLIENTS_OUTSIDE_THE_SESSION
            .iter()
            .find(|(f, _)| f == path)
            .map_or(0, |(_, a)| *a);
        if n > allowed {
            problems.push(format!(
                "{path}:{first}: {n} client(s) asked of `connect` on a kept link: reach the drive through `engine::session::BusSession` (docs/architecture.md, \"One path from a port to a drive\")"
            ));
        } else if n < allowed {
            problems.push(format!(
                "{path}:1: {n} client(s) asked of `connect` on a kept link, the allowlist says {allowed}: lower or remove its entry in BORROWED_CLIENTS_OUTSIDE_THE_SESSION (tests/integration/tidy/session.rs)"
            ));
        }
    }
    for (f, _) in BORROWED_CLIENTS_OUTSIDE_THE_SESSION {
        if !root.join(f).is_file() {
            problems.push(format!(
                "{f}: listed in BORROWED_CLIENTS_OUTSIDE_THE_SESSION (tests/integration/tidy/session.rs) but no such file: remove its entry"
            ));
        }
    }
    report("client construction (docs/architecture.md)", &problems);
}

/// What opens a port or takes a bus lock; only the session's sequence
/// (`session::open_port`, through the CLI's `Ports` in `cli/src/port.rs`)
/// may, so every bus is locked before a command drives it.
const PORT_OPENINGS: &[&str] = &[
    "driveset_link::open(",
    "port::reopen(",
    "open_with(",
    "open_sim_with(",
    "BusLock::acquire",
];

/// Files that open ports outside the session's sequence, and why (each
/// must still hold such a call).
const PORTS_OPENED_ELSEWHERE: &[(&str, &str)] = &[
    (
        "crates/driveset-cli/src/cmd/doctor.rs",
        "reopens, at each line rate it tries, the port the session opened and locked",
    ),
    (
        "crates/driveset-twin/src/rehearse.rs",
        "a rehearsal's buses of twins live in this process only: nothing to lock",
    ),
];

#[test]
fn tidy_ports_are_opened_only_through_the_session() {
    let mut problems = Vec::new();
    let mut used = BTreeSet::new();
    for source in sources() {
        let path = &source.path;
        if path == "crates/driveset-cli/src/port.rs"
            || THE_TRANSPORTS.iter().any(|t| source.under(t))
        {
            continue;
        }
        for (n, line) in source.code() {
            let Some(what) = PORT_OPENINGS.iter().find(|p| line.contains(*p)) else {
                continue;
            };
            if PORTS_OPENED_ELSEWHERE.iter().any(|(f, _)| f == path) {
                used.insert(path.clone());
                continue;
            }
            problems.push(format!(
                "{path}:{n}: `{what}` opens a port (or takes a bus lock) outside the session: open it with `engine::session::open_port` (the CLI's `port::open_port_at`), which locks its bus (docs/architecture.md, \"One path from a port to a drive\")"
            ));
        }
    }
    for (f, _) in PORTS_OPENED_ELSEWHERE {
        if !used.contains(*f) {
            problems.push(format!(
                "{f}:1: listed in PORTS_OPENED_ELSEWHERE (tests/integration/tidy/session.rs) but opens no port any more: remove its entry"
            ));
        }
    }
    report("port opening (docs/architecture.md)", &problems);
}
