//! The CLI crate's one integration-test binary (ripgrep style: one binary,
//! fast to link). Each module tests one area of the `driveset` CLI; `util`
//! holds the shared helpers.

mod audit;
mod bus_cmds;
mod decode;
mod diff;
mod doctor;
mod e2e_pty;
mod echo;
mod encode;
mod fingerprint;
mod git_setup;
mod inputs;
mod junit;
mod latency;
mod learn;
mod line;
mod proxy;
mod pull;
mod recover;
mod report;
mod rfc2217;
mod safety;
mod schema_check;
mod schema_import;
mod show;
mod sim;
mod transfer_pty;
mod upload;
mod util;
mod validate;
