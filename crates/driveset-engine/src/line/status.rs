//! `driveset status LINE`: the read-only drift check. For every selected
//! drive: identify (refusing a drive of another family), read the set's
//! codes, compare the live fingerprint with the set's and list the
//! semantic differences. Nothing is written; no state file is touched.
//! A drive that holds its set is [`DriveResult::Unchanged`], one that does
//! not is [`DriveResult::Drift`] (exit 1); one with an unfinished journal in
//! the journal directory is `Failed` (exit 1: its values are not trusted,
//! see `commission`'s module docs); bus failures exit 3.
//!
//! [`DriveResult::Unchanged`]: super::report::DriveResult::Unchanged
//! [`DriveResult::Drift`]: super::report::DriveResult::Drift

use super::commission::{LineError, LineOptions, LineOutcome, Mode, Opener, run_line};
use super::manifest::Manifest;

/// Check every selected drive of the line against its set.
pub fn status(
    manifest: &Manifest,
    opts: &LineOptions,
    opener: &Opener<'_>,
) -> Result<LineOutcome, LineError> {
    run_line(manifest, opts, opener, Mode::Status)
}
