//! The engine's one integration-test binary (one binary per crate, fast to
//! link). Each module tests one area; `support` (fault campaigns, also used
//! by the benches), `txn_support` (the in-memory fake drive) and `util`
//! hold the shared helpers. Unit tests live beside the code in `src/`.

mod assign_cut;
mod campaign;
mod client_lecom;
mod client_lustbus;
mod client_scan;
mod client_sdo;
#[cfg(unix)]
mod interop_canopen;
mod line;
mod support;
mod transfer_cut;
mod txn;
mod txn_sim;
mod txn_support;
mod util;
