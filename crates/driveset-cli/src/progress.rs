//! Progress of long bus work on stderr, fed by the engine's observer
//! ([`driveset_engine::observe`]): the runners name their own phase, so a
//! rollback shows as `rolling back`, never as writing and verifying.
//!
//! [`Progress`] serves `upload`, `pull` and `recover`; [`LineProgress`]
//! serves `commission` and `status` (one bar per bus). On a terminal
//! (stderr is a tty and `CI` is not set) they draw `indicatif` progress
//! bars; otherwise (pipes, logs, CI, the tests) they print plain lines: for
//! one drive a line when a phase starts (`upload: reading 195 codes from
//! the drive`, `upload: writing`, `upload: verifying`, `upload: rolling
//! back`), for a line one line per drive done. Nothing is printed with
//! `quiet` (JSON output). What a phase shows as, the plain lines and the
//! bar's messages are `driveset_report::progress`'s text.

use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::sync::{Arc, Mutex, PoisonError};

use driveset_engine::line::commission::{DriveDone, LineObserver};
use driveset_engine::observe::{Event, Hook, Observer};
use driveset_link::Instant;
use driveset_report::progress::{Shows, bus_message, plain_line};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Whether progress is drawn as bars: stderr is a terminal and `CI` is not
/// set.
pub fn bars_wanted() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("CI").is_none()
}

enum Out {
    Quiet,
    Lines,
    Bar(ProgressBar),
}

/// Progress of one drive's work (`upload`, `pull`, `recover`): an
/// [`Observer`] to hand to the engine through [`Progress::hook`].
pub struct Progress {
    what: &'static str,
    out: Out,
    shows: Mutex<Shows>,
}

impl Progress {
    /// Progress of `what` (`upload`); none with `--format json`, whose
    /// stdout is the document alone.
    pub fn new(what: &'static str, format: crate::output::OutputFormat) -> Arc<Self> {
        let out = if format == crate::output::OutputFormat::Json {
            Out::Quiet
        } else if bars_wanted() {
            let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::hidden());
            bar.set_style(
                ProgressStyle::with_template("{prefix}: {msg:<12} [{bar:30}] {pos}/{len}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("#>-"),
            );
            bar.set_prefix(what);
            Out::Bar(bar)
        } else {
            Out::Lines
        };
        Arc::new(Progress {
            what,
            out,
            shows: Mutex::new(Shows::default()),
        })
    }

    /// The hook to put into the engine's options.
    pub fn hook(self: &Arc<Self>) -> Hook {
        Hook::new(self.clone())
    }

    /// End the bar (call before printing the report).
    pub fn done(&self) {
        if let Out::Bar(b) = &self.out {
            b.finish_and_clear();
        }
    }
}

impl Observer for Progress {
    fn event(&self, _at: Instant, event: Event) {
        let mut shows = self.shows.lock().unwrap_or_else(PoisonError::into_inner);
        match event {
            Event::Enter { phase, total } => {
                let Some((now, changed)) = shows.enter(phase, total) else {
                    return;
                };
                match &self.out {
                    Out::Quiet => {}
                    Out::Lines => {
                        if changed {
                            let line = plain_line(self.what, now, total);
                            let _ = writeln!(std::io::stderr().lock(), "{line}");
                        }
                    }
                    Out::Bar(b) => {
                        b.set_message(now.verb());
                        let n = total.map(|n| n as u64);
                        if changed || (n.is_some() && b.length() != n) {
                            b.set_position(0);
                            b.set_length(n.unwrap_or(0));
                        }
                        if b.is_hidden() {
                            // drawn from the first phase on, not before
                            b.set_draw_target(ProgressDrawTarget::stderr());
                        }
                    }
                }
            }
            Event::Step { phase, done, total } => {
                if let Out::Bar(b) = &self.out
                    && shows.counts(phase, total)
                {
                    b.set_length(total as u64);
                    b.set_position(done as u64);
                }
            }
            Event::End => self.done(),
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.done();
    }
}

/// Renders a drive done as its progress line, given the bus column's
/// width.
pub type DriveLine = fn(&DriveDone<'_>, usize) -> String;

/// Progress of a line run (`commission`, `status`): one line per drive
/// done; on a terminal above one bar per bus (drives done of the bus's
/// selected drives, the current drive and its phase).
pub struct LineProgress {
    width: usize,
    line: DriveLine,
    multi: Option<MultiProgress>,
    bars: Mutex<BTreeMap<String, ProgressBar>>,
}

impl LineProgress {
    /// `width`: the longest bus name (the lines' bus column); `line`
    /// renders a drive done.
    pub fn new(width: usize, line: DriveLine) -> Arc<Self> {
        Arc::new(LineProgress {
            width,
            line,
            multi: bars_wanted()
                .then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr())),
            bars: Mutex::new(BTreeMap::new()),
        })
    }

    /// Remove the bars (call before printing the summary).
    pub fn done(&self) {
        if let Some(m) = &self.multi {
            let _ = m.clear();
        }
    }
}

impl LineObserver for LineProgress {
    fn bus(&self, bus: &str, drives: usize) {
        let Some(m) = &self.multi else { return };
        let bar = m.add(ProgressBar::new(drives as u64));
        bar.set_style(
            ProgressStyle::with_template("[{prefix}] [{bar:20}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("#>-"),
        );
        bar.set_prefix(format!("{bus:w$}", w = self.width));
        self.bars
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(bus.to_string(), bar);
    }

    fn event(&self, bus: &str, drive: &str, _at: Instant, event: Event) {
        if self.multi.is_none() {
            return;
        }
        let bars = self.bars.lock().unwrap_or_else(PoisonError::into_inner);
        let Some(b) = bars.get(bus) else { return };
        if let Some(message) = bus_message(drive, event) {
            b.set_message(message);
        }
    }

    /// A drive is done: print its line, advance its bus's bar.
    fn drive_done(&self, p: &DriveDone<'_>) {
        let text = (self.line)(p, self.width);
        match &self.multi {
            None => {
                let _ = writeln!(std::io::stderr().lock(), "{text}");
            }
            Some(m) => {
                let _ = m.println(&text);
                let bars = self.bars.lock().unwrap_or_else(PoisonError::into_inner);
                if let Some(b) = bars.get(p.bus) {
                    b.set_position(p.done as u64);
                    if p.done >= p.total {
                        b.finish_with_message("done");
                    }
                }
            }
        }
    }
}
