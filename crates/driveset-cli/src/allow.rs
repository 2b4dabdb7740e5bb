//! The named overrides of `upload` and `commission` (driveset-engine's
//! `overrides`): one flag per refusal, each lifting exactly that one.
//! Commands and control words that could start a motor have no override.

use driveset_engine::overrides::{Override, Overrides};

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
    /// With --transfer-baud on a bus shared with drives that cannot follow
    /// the rate (VF1000s: 9600 baud at most): switch anyway (they hear
    /// garbage meanwhile and their watchdog 84-SIOT may fire).
    #[arg(long)]
    pub allow_shared_transfer_baud: bool,
    /// Removed: use the named --allow-* overrides.
    #[arg(long, hide = true)]
    pub force: bool,
}

/// The message for the removed `--force`.
pub const FORCE_REMOVED: &str = "--force was replaced by named overrides, each lifting one refusal: --allow-family, --allow-running, --allow-running-unknown, --allow-address-change, --allow-shared-transfer-baud (commands and control words that could start a motor have none)";

impl AllowArgs {
    /// The engine's overrides; `--force` is an input error.
    pub fn overrides(&self) -> Result<Overrides, Fail> {
        if self.force {
            return Err(Fail::input(FORCE_REMOVED));
        }
        let given = [
            (self.allow_family, Override::AllowFamily),
            (self.allow_running, Override::AllowRunning),
            (self.allow_running_unknown, Override::AllowRunningUnknown),
            (self.allow_address_change, Override::AllowAddressChange),
            (
                self.allow_shared_transfer_baud,
                Override::AllowSharedTransferBaud,
            ),
        ];
        Ok(given
            .into_iter()
            .filter(|(on, _)| *on)
            .map(|(_, o)| o)
            .collect())
    }
}

/// `--transfer-baud RATE` of `upload`, `pull` and `diff --port`.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct TransferArgs {
    /// MC6000/7000 at standstill: switch the drive and the port to RATE
    /// for the transaction and back afterwards (81-SBAUD, then 4-PROG =
    /// 111; lustbus-protocol.txt 11.5), when the estimate says it pays.
    /// 2400, 4800, 9600, 19200, 38400 or 57600.
    #[arg(long, value_name = "RATE")]
    pub transfer_baud: Option<u32>,
}

impl TransferArgs {
    /// The engine's request (a single-drive command: no other drives known).
    pub fn request(
        &self,
        overrides: &Overrides,
    ) -> Option<driveset_engine::transfer::TransferRequest> {
        self.transfer_baud.map(|rate| {
            let mut r = driveset_engine::transfer::TransferRequest::new(rate);
            r.allow_shared = overrides.allows(Override::AllowSharedTransferBaud);
            r
        })
    }
}
