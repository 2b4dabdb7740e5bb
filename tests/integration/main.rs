//! The workspace's one integration-test binary (ripgrep style: one binary,
//! fast to link). Each module tests one area of the `driveset` CLI; `util`
//! holds the shared helpers.

mod bus_cmds;
mod decode;
mod diff;
mod e2e_pty;
mod encode;
mod fingerprint;
mod git_setup;
mod junit;
mod line;
mod pull;
mod recover;
mod report;
mod safety;
mod schema_check;
mod show;
mod sim;
mod upload;
mod util;
mod validate;
