//! The workspace's one integration-test binary (ripgrep style: one binary,
//! fast to link). Each module tests one area of the `driveset` CLI; `util`
//! holds the shared helpers.

mod decode;
mod diff;
mod encode;
mod fingerprint;
mod schema_check;
mod show;
mod sim;
mod util;
mod validate;
