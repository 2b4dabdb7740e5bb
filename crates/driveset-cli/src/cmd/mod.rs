//! One module per subcommand; each has `Args` (clap) and `run(Args) -> Result<u8>`
//! returning the process exit code.

pub mod address;
pub mod commission;
pub mod completions;
pub mod decode;
pub mod diff;
pub mod doctor;
pub mod encode;
pub mod fingerprint;
pub mod git_setup;
pub mod identify;
pub mod lsp;
pub mod pull;
pub mod recover;
pub mod replace;
pub mod scan;
pub mod schema;
pub mod show;
pub mod sim;
pub mod status;
pub mod twin;
pub mod upload;
pub mod validate;
