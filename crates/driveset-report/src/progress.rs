//! Long bus work's progress as text (docs/architecture.md, "The engine's
//! seams"): what each phase the engine's observer reports
//! ([`driveset_engine::observe`]) shows as, so a rollback shows as
//! `rolling back`, never as writing and verifying; the plain line a phase
//! prints off a terminal (`upload: reading 195 codes from the drive`,
//! `upload: writing`, `upload: verifying`, `upload: rolling back`); and the
//! message a line run's bus bar carries. Drawing bars and printing is the
//! caller's.

use driveset_engine::observe::{Event, Phase};

/// What a phase shows as on the terminal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shown {
    /// Reading values back from the drive.
    Reading,
    /// Writing values (the dataset, its commit and the writes).
    Writing,
    /// Verifying what was written.
    Verifying,
    /// Storing to the drive's non-volatile memory.
    Storing,
    /// Putting the old values back.
    RollingBack,
}

impl Shown {
    /// What `phase` shows as (`total`: the codes it covers); `None`: shown
    /// as the phase before it.
    pub fn of(phase: Phase, total: Option<usize>) -> Option<Shown> {
        match phase {
            // an untotalled read (a status word) is part of what runs around it
            Phase::Read => total.map(|_| Shown::Reading),
            Phase::Dataset | Phase::Write | Phase::Commit => Some(Shown::Writing),
            Phase::Verify => Some(Shown::Verifying),
            Phase::Store => Some(Shown::Storing),
            Phase::Rollback => Some(Shown::RollingBack),
            Phase::Identify
            | Phase::Plan
            | Phase::Journal
            | Phase::Recover
            | Phase::Learn
            | Phase::Broadcast => None,
        }
    }

    /// The verb the bar's message and the plain line show (`rolling back`).
    pub fn verb(self) -> &'static str {
        match self {
            Shown::Reading => "reading",
            Shown::Writing => "writing",
            Shown::Verifying => "verifying",
            Shown::Storing => "storing",
            Shown::RollingBack => "rolling back",
        }
    }
}

/// The plain line printed off a terminal when `now` starts (`what`: the
/// command, `upload`).
pub fn plain_line(what: &str, now: Shown, total: Option<usize>) -> String {
    match (now, total) {
        (Shown::Reading, Some(n)) => format!("{what}: reading {n} codes from the drive"),
        _ => format!("{what}: {}", now.verb()),
    }
}

/// What one drive's work shows at the moment: the phase shown last.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Shows {
    last: Option<Shown>,
}

impl Shows {
    /// An [`Event::Enter`] of `phase`: what is shown from now on and whether
    /// that changed; `None` when the phase shows as the one before it.
    pub fn enter(&mut self, phase: Phase, total: Option<usize>) -> Option<(Shown, bool)> {
        let now = Shown::of(phase, total)?;
        let changed = self.last != Some(now);
        self.last = Some(now);
        Some((now, changed))
    }

    /// Whether an [`Event::Step`] of `phase` (of `total`) counts for what
    /// is shown.
    pub fn counts(&self, phase: Phase, total: usize) -> bool {
        Shown::of(phase, Some(total)) == self.last
    }
}

/// The plain lines a run of `events` prints off a terminal.
pub fn plain_lines(what: &str, events: &[Event]) -> Vec<String> {
    let mut shows = Shows::default();
    let mut out = Vec::new();
    for e in events {
        if let Event::Enter { phase, total } = *e
            && let Some((now, true)) = shows.enter(phase, total)
        {
            out.push(plain_line(what, now, total));
        }
    }
    out
}

/// The message of a line run's bus bar when `drive` reports `event`
/// (`drive: phase`, `drive: phase done/total`); `None`: unchanged.
pub fn bus_message(drive: &str, event: Event) -> Option<String> {
    match event {
        Event::Enter { phase, .. } => Some(format!("{drive}: {phase}")),
        Event::Step {
            phase, done, total, ..
        } => Some(format!("{drive}: {phase} {done}/{total}")),
        Event::End => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enter(phase: Phase, total: Option<usize>) -> Event {
        Event::Enter { phase, total }
    }
    #[test]
    fn plain_lines_follow_the_runners_phases() {
        // an MC6000 upload that fails after the dataset's commit: the
        // dataset, its commit and the other writes are one `writing`; the
        // status read of the running check and the steps print nothing
        let events = [
            enter(Phase::Identify, None),
            enter(Phase::Read, Some(195)),
            Event::Step {
                phase: Phase::Read,
                done: 1,
                total: 195,
            },
            enter(Phase::Plan, None),
            enter(Phase::Read, None),
            enter(Phase::Journal, None),
            enter(Phase::Dataset, None),
            enter(Phase::Write, Some(78)),
            Event::Step {
                phase: Phase::Verify,
                done: 1,
                total: 78,
            },
            enter(Phase::Commit, None),
            enter(Phase::Write, Some(78)),
            enter(Phase::Rollback, Some(40)),
            Event::End,
        ];
        assert_eq!(
            plain_lines("upload", &events),
            [
                "upload: reading 195 codes from the drive",
                "upload: writing",
                "upload: rolling back",
            ]
        );
        // a redo after a restart reads again; a clean end verifies
        let events = [
            enter(Phase::Read, Some(3)),
            enter(Phase::Write, Some(2)),
            enter(Phase::Read, Some(3)),
            enter(Phase::Write, Some(2)),
            enter(Phase::Verify, Some(2)),
        ];
        assert_eq!(
            plain_lines("upload", &events),
            [
                "upload: reading 3 codes from the drive",
                "upload: writing",
                "upload: reading 3 codes from the drive",
                "upload: writing",
                "upload: verifying",
            ]
        );
    }
}
