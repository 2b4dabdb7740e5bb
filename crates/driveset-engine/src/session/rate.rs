//! Owns the last step of a session: the command's work at the line rate
//! the command asked for. With a transfer rate (`--transfer-baud RATE`,
//! [`crate::transfer`]: the drive and the port switched over, the work,
//! switched back, the switch journalled), else at the port's own rate. The
//! front end calls these and renders what they return; it does not choose
//! between the transfer wrapper and the plain command itself
//! (docs/architecture.md, "One path from a port to a drive").

use std::path::Path;

use driveset_schema::{Diff, ResolvedSet};

use crate::client::DriveClient;
use crate::error::EngineError;
use crate::observe::Hook;
use crate::pull::{PullOptions, Pulled};
use crate::transfer::{TransferReport, TransferRequest};
use crate::upload::{UploadFailure, UploadOptions, UploadReport, default_journal_path};

/// The rate a read-only command (pull, live diff) runs at: the port's, or
/// a transfer rate whose switch is journalled in `journal_dir`.
#[derive(Debug, Clone, Copy)]
pub enum ReadRate<'a> {
    /// The port's own rate.
    Port,
    /// A transfer rate; the switch's journal goes to `journal_dir` under
    /// the drive's journal name ([`default_journal_path`]).
    Transfer {
        /// The request.
        request: &'a TransferRequest,
        /// Where the switch's journal goes.
        journal_dir: &'a Path,
    },
}

impl<'a> ReadRate<'a> {
    /// [`ReadRate::Transfer`] when `request` is given, else
    /// [`ReadRate::Port`].
    pub fn of(request: Option<&'a TransferRequest>, journal_dir: &'a Path) -> Self {
        match request {
            Some(request) => ReadRate::Transfer {
                request,
                journal_dir,
            },
            None => ReadRate::Port,
        }
    }
}

/// Upload `set` (the transaction, [`crate::upload::upload`]), at the
/// transfer rate `transfer` asks for ([`crate::transfer::upload`]: the
/// report says whether the rate was switched).
pub fn upload(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    opts: &UploadOptions,
    transfer: Option<&TransferRequest>,
) -> Result<UploadReport, UploadFailure> {
    match transfer {
        Some(req) => crate::transfer::upload(client, set, opts, req),
        None => crate::upload::upload(client, set, opts),
    }
}

/// Pull the drive's values ([`crate::pull::pull_observed`]) at `rate`;
/// the transfer's report when the rate was a transfer rate.
pub fn pull(
    client: &mut dyn DriveClient,
    opts: &PullOptions,
    rate: ReadRate<'_>,
    hook: &Hook,
) -> Result<(Pulled, Option<TransferReport>), EngineError> {
    match rate {
        ReadRate::Port => Ok((crate::pull::pull_observed(client, opts, hook)?, None)),
        ReadRate::Transfer {
            request,
            journal_dir,
        } => {
            let journal = default_journal_path(journal_dir, client);
            let (pulled, report) = crate::transfer::pull(client, opts, request, &journal, hook)?;
            Ok((pulled, Some(report)))
        }
    }
}

/// Compare the drive with `set` ([`crate::live::live_diff`]) at `rate`;
/// the transfer's report when the rate was a transfer rate.
pub fn live_diff(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    rate: ReadRate<'_>,
) -> Result<(Diff, Option<TransferReport>), EngineError> {
    match rate {
        ReadRate::Port => Ok((crate::live::live_diff(client, set)?, None)),
        ReadRate::Transfer {
            request,
            journal_dir,
        } => {
            let journal = default_journal_path(journal_dir, client);
            let (diff, report) = crate::transfer::live_diff(client, set, request, &journal)?;
            Ok((diff, Some(report)))
        }
    }
}
