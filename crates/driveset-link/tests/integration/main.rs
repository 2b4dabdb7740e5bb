//! The link crate's one integration-test binary (one binary per crate,
//! fast to link). Each module tests one transport; the shared helpers (pty
//! pairs, bounded reads, `recv_n`) come from `driveset-test-support`.
//! `hardware` is built only with `--features hardware`
//! (TESTING.md, "Hardware tests").

#[cfg(feature = "hardware")]
mod hardware;
mod mem;
#[cfg(unix)]
mod pty;
mod spec;
mod tcp;
