//! The engine's one integration-test binary (one binary per crate, fast to
//! link). Each module tests one area; `support` holds the engine's own
//! test rigs (the fault campaigns, also used by the benches, and the
//! in-memory fake drive, `support::fake`); the helpers every crate's tests
//! share are in the `driveset-test-support` crate. Unit tests live beside
//! the code in `src/`.

mod assign_cut;
mod campaign;
mod client_lecom;
mod client_lustbus;
mod client_scan;
mod client_sdo;
#[cfg(unix)]
mod interop_canopen;
mod journal_forms;
mod line;
mod support;
mod transfer_cut;
mod txn;
mod txn_sim;
