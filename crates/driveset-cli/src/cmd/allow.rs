//! The named overrides of `upload` and `commission` (driveset-engine's
//! `overrides`): one flag per refusal, each lifting exactly that one.
//! Commands and control words that could start a motor have no override.

use driveset_engine::overrides::Overrides;

use crate::port::Fail;

/// `--allow-*` flags.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct AllowArgs {
    /// Upload a set of another schema, or to a drive that identifies as
    /// (or a simulated drive of) another family.
    #[arg(long)]
    pub allow_family: bool,
    /// Upload to a drive that reports a running motor.
    #[arg(long)]
    pub allow_running: bool,
    /// Upload to a drive whose running state cannot be known (its schema
    /// names no running bit, e.g. lenze-ecs).
    #[arg(long)]
    pub allow_running_unknown: bool,
    /// Write a change of the bus address of the drive being talked to
    /// (it stops answering: not verified, not rolled back).
    #[arg(long)]
    pub allow_address_change: bool,
    /// Removed: use the named --allow-* overrides.
    #[arg(long, hide = true)]
    pub force: bool,
}

/// The message for the removed `--force`.
pub const FORCE_REMOVED: &str = "--force was replaced by named overrides, each lifting one refusal: --allow-family, --allow-running, --allow-running-unknown, --allow-address-change (commands and control words that could start a motor have none)";

impl AllowArgs {
    /// The engine's overrides; `--force` is an input error.
    pub fn overrides(&self) -> Result<Overrides, Fail> {
        if self.force {
            return Err(Fail::input(FORCE_REMOVED));
        }
        Ok(Overrides {
            allow_family: self.allow_family,
            allow_running: self.allow_running,
            allow_running_unknown: self.allow_running_unknown,
            allow_address_change: self.allow_address_change,
        })
    }
}
