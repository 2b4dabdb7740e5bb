//! The CLI crate's one integration-test binary (ripgrep style: one binary,
//! fast to link). Each module tests one area of the `driveset` CLI; `tidy`
//! reads the repository's sources and docs and holds docs/architecture.md's
//! invariants. The shared helpers are in the `driveset-test-support` crate.

mod address;
mod address_truth;
mod assign;
mod audit;
mod bus_cmds;
mod bus_identity;
mod campaign;
mod ci;
mod decode;
mod diff;
mod doctor;
mod e2e_pty;
mod echo;
mod eds_quirks;
mod eds_sim;
mod encode;
mod factory_settings;
mod fingerprint;
mod git_setup;
mod harden;
mod harden_small;
mod history;
mod inputs;
mod json_schema;
mod junit;
mod latency;
mod latency_discovery;
mod learn;
mod learn_disagree;
mod line;
mod lsp;
mod lsp_frames;
mod parity;
mod proxy;
mod pull;
mod recover;
mod rehearse;
mod replace;
mod report;
mod rfc2217;
mod safety;
mod schema_check;
mod schema_import;
mod show;
mod sim;
mod store;
mod tidy;
mod transfer_pty;
mod twin;
mod twin_pty;
mod upload;
mod validate;
