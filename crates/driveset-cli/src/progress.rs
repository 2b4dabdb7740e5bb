//! Progress of long bus work (`upload`, `pull`, `recover`) on stderr.
//!
//! [`Progress`] wraps a [`DriveClient`] and counts what goes through it:
//! reads before the first write are the read-back, writes, then reads after
//! writes are verification. On a terminal (stderr is a tty and `NO_COLOR`
//! does not matter here) one line is redrawn in place with a bar over the
//! read-back and counters for the rest; otherwise plain lines are printed
//! when a phase starts, so logs stay short and readable. Nothing is printed
//! with `quiet` (JSON output).

// EngineError is large by design; it is built on the failure path only.
#![allow(clippy::result_large_err)]

use std::io::{IsTerminal, Write};
use std::sync::Arc;
use std::time::Duration;

use driveset_engine::client::{ClientStats, DatasetOutcome, DriveClient, Identity, Target};
use driveset_engine::error::EngineError;
use driveset_link::{Clock, Instant};
use driveset_schema::{CodeKey, RawValue, Schema};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Start,
    Reading,
    Writing,
    Verifying,
}

/// A [`DriveClient`] that reports progress on stderr.
pub struct Progress<'a> {
    inner: &'a mut dyn DriveClient,
    what: &'static str,
    expected_reads: usize,
    reads: usize,
    writes: usize,
    verified: usize,
    phase: Phase,
    tty: bool,
    quiet: bool,
    drawn: bool,
}

impl<'a> Progress<'a> {
    /// Wrap `inner`; `what` names the work (`upload`), `expected_reads` the
    /// codes of the read-back (for the bar).
    pub fn new(
        inner: &'a mut dyn DriveClient,
        what: &'static str,
        expected_reads: usize,
        quiet: bool,
    ) -> Self {
        Progress {
            inner,
            what,
            expected_reads,
            reads: 0,
            writes: 0,
            verified: 0,
            phase: Phase::Start,
            tty: std::io::stderr().is_terminal(),
            quiet,
            drawn: false,
        }
    }

    fn enter(&mut self, phase: Phase) {
        if self.phase == phase {
            return;
        }
        self.phase = phase;
        if self.quiet || self.tty {
            return;
        }
        let line = match phase {
            Phase::Start => return,
            Phase::Reading => format!(
                "{}: reading {} codes from the drive",
                self.what, self.expected_reads
            ),
            Phase::Writing => format!("{}: writing", self.what),
            Phase::Verifying => format!("{}: verifying", self.what),
        };
        eprintln!("{line}");
    }

    fn draw(&mut self) {
        if self.quiet || !self.tty {
            return;
        }
        let total = self.expected_reads.max(1);
        let done = self.reads.min(total);
        let width = 30;
        let filled = done * width / total;
        let bar: String = "#".repeat(filled) + &"-".repeat(width - filled);
        let mut err = std::io::stderr().lock();
        let _ = write!(
            err,
            "\r{}: [{bar}] read {done}/{total}  written {}  verified {}\x1b[K",
            self.what, self.writes, self.verified
        );
        let _ = err.flush();
        self.drawn = true;
    }

    /// End the progress line (call before printing the report).
    pub fn done(&mut self) {
        if self.drawn {
            eprintln!();
            self.drawn = false;
        }
    }
}

impl Drop for Progress<'_> {
    fn drop(&mut self) {
        self.done();
    }
}

impl DriveClient for Progress<'_> {
    fn target(&self) -> &Target {
        self.inner.target()
    }
    fn bus_id(&self) -> String {
        self.inner.bus_id()
    }
    fn schema(&self) -> &Arc<Schema> {
        self.inner.schema()
    }
    fn clock(&self) -> &dyn Clock {
        self.inner.clock()
    }
    fn identify(&mut self) -> Result<Identity, EngineError> {
        self.inner.identify()
    }
    fn read(&mut self, key: CodeKey) -> Result<RawValue, EngineError> {
        let r = self.inner.read(key);
        if self.writes == 0 {
            self.enter(Phase::Reading);
            self.reads += 1;
        } else {
            self.enter(Phase::Verifying);
            self.verified += 1;
        }
        self.draw();
        r
    }
    fn write(&mut self, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        self.enter(Phase::Writing);
        let r = self.inner.write(key, raw);
        self.writes += 1;
        self.draw();
        r
    }
    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        self.inner.ready_for_write(key)
    }
    fn read_time(&self, key: CodeKey) -> Duration {
        self.inner.read_time(key)
    }
    fn write_time(&self, key: CodeKey) -> Duration {
        self.inner.write_time(key)
    }
    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        self.inner.running()
    }
    fn stats(&self) -> ClientStats {
        self.inner.stats()
    }
    fn finish(&mut self) -> Result<(), EngineError> {
        self.inner.finish()
    }
    fn has_dataset_download(&self) -> bool {
        self.inner.has_dataset_download()
    }
    fn line_rate(&self) -> Option<u32> {
        self.inner.line_rate()
    }
    fn set_line_rate(&mut self, baud: u32) -> Result<(), EngineError> {
        self.inner.set_line_rate(baud)
    }
    fn dataset_begin(&mut self) -> Result<(), EngineError> {
        self.enter(Phase::Writing);
        self.inner.dataset_begin()
    }
    fn dataset_commit(&mut self, timeout: Duration) -> Result<DatasetOutcome, EngineError> {
        self.inner.dataset_commit(timeout)
    }
}
