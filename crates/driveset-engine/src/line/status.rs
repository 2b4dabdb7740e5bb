//! `driveset status LINE`: the read-only drift check, a walk of its own
//! over the loop every line run shares ([`super::commission`], "One loop,
//! two walks"). For every selected drive: identify (refusing a drive of
//! another family), read the set's codes, compare the live fingerprint
//! with the set's and list the semantic differences. Nothing is written;
//! no state file is touched; a schema is learned read-only (descriptions
//! only, an earlier `commission`'s file reused:
//! [`LearnStep::ReuseEarlier`]). A drive that holds its set is
//! [`DriveResult::Unchanged`], one that does not is [`DriveResult::Drift`]
//! (exit 1); one with an unfinished journal in the journal directory is
//! `Failed` (exit 1: its values are not trusted, see `commission`'s module
//! docs); bus failures exit 3.

use super::commission::{Job, LineError, LineOptions, LineOutcome, Opener, Walk, run_walk};
use super::manifest::Manifest;
use super::report::{DriveReport, DriveResult};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::history::{Unit, read_codes};
use crate::identify::check_family;
use crate::journal::Unfinished;
use crate::live::live_values;
use crate::observe::Phase;
use crate::session::LearnStep;

/// Check every selected drive of the line against its set.
pub fn status(
    manifest: &Manifest,
    opts: &LineOptions,
    opener: &Opener<'_>,
) -> Result<LineOutcome, LineError> {
    run_walk(manifest, opts, opener, || Ok(Status))
}

/// `status`'s walk: reads every drive, writes nothing.
struct Status;

impl Walk for Status {
    fn command(&self) -> &'static str {
        "status"
    }

    fn learn_step(&self) -> LearnStep {
        LearnStep::ReuseEarlier
    }

    /// A drive with an unfinished journal fails (its values are not
    /// trusted); any other is identified, its set's codes read and
    /// compared.
    fn work(
        &self,
        job: &Job<'_>,
        client: &mut dyn DriveClient,
        r: &mut DriveReport,
        unfinished: &[Unfinished],
        _recovered: &mut Vec<String>,
    ) -> Result<(), EngineError> {
        if !unfinished.is_empty() {
            return Err(untrusted(client, unfinished));
        }
        let d = job.d;
        job.hook.enter(client.clock(), Phase::Identify, None);
        let id = check_family(&mut *client)?;
        r.identity = id.pairs();
        job.hook
            .enter(client.clock(), Phase::Read, Some(d.set.values.len()));
        job.rec.borrow_mut().unit = Some(Unit::of(&d.schema, &id));
        let live = live_values(&mut *client, &d.set)?;
        job.rec.borrow_mut().codes = read_codes(&d.schema, &live, &d.set);
        let fp = live.fingerprint();
        r.diff = super::commission::diff_lines(&d.schema, &live, &d.set);
        r.factory_settings = super::factory::live_at_factory_settings(&d.schema, &live, &d.set);
        // values, not fingerprints: a fingerprint does not cover a
        // secret's value, a drifted password is drift too
        r.result = if live.values == d.set.values {
            DriveResult::Unchanged
        } else {
            DriveResult::Drift
        };
        r.fingerprint_before = Some(fp.clone());
        r.fingerprint_after = Some(fp);
        Ok(())
    }
}

/// The error of a drive with unfinished journals: its values are not
/// trusted.
fn untrusted(client: &dyn DriveClient, unfinished: &[Unfinished]) -> EngineError {
    let list: Vec<String> = unfinished
        .iter()
        .map(|u| format!("{} (state {})", u.path.display(), u.journal.state.as_str()))
        .collect();
    EngineError::journal(
        unfinished[0].path.display().to_string(),
        format!(
            "the drive at {} has an unfinished transaction ({}); its values are not trusted. Run `driveset commission` (it recovers the journal first) or `driveset recover {}`",
            client.target(),
            list.join(", "),
            unfinished[0].path.display()
        ),
    )
}
