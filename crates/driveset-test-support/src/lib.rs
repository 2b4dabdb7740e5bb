//! The helpers the driveset crates' integration tests share (dev-only,
//! never published): the workspace root and its files, the interop tests'
//! Python interpreter and skip rule, the one pty lock of a test process,
//! bounded reads from sockets and ptys, child processes killed when
//! dropped, the built `driveset` binary
//! (feature `cli`), pty pairs (feature `pty`), byte-link reads (feature
//! `link`) and simulated buses in virtual time with their wire logs
//! (feature `sim`).
//!
//! Every crate's `tests/integration/` binary takes it as a
//! `[dev-dependency]`; a helper lives here once instead of a copy per
//! crate (TESTING.md, "Shared test helpers").
//!
//! Helpers panic with a message naming what failed: they run inside
//! tests, where a panic is the failure report.

#[cfg(feature = "cli")]
mod cli;
mod interop;
mod io;
mod paths;
mod process;
#[cfg(all(feature = "pty", unix))]
mod pty;
#[cfg(feature = "sim")]
mod sim;
mod text;

#[cfg(feature = "cli")]
pub use cli::{
    driveset, driveset_at, driveset_bin, driveset_in, driveset_in_with_locks, driveset_sim,
    driveset_with_sim_state, outcome,
};
pub use interop::{interop_or_skip, python, python_or_skip};
#[cfg(feature = "link")]
pub use io::recv_n;
pub use io::{pty_lock, read_exact_n, read_n_within, read_until};
pub use paths::{
    copy_dir, demo_line_dir, files_in, mkfifo, sim_dir, toml_files_starting, workspace_root,
};
pub use process::{LinePeer, Spawned, sdo_server, send_signal};
#[cfg(all(feature = "pty", unix))]
pub use pty::pty_pair;
#[cfg(feature = "sim")]
pub use sim::{
    poke_state, sim_byte_bus, sim_can_bus, sim_openers, state_raw, wire_bytes, wire_timed,
};
pub use text::shows_value;
