//! Simulated CAN drives behind a simulated USB-CAN adapter: serves a
//! simulated bus ([`FrameLine`], the core of [`crate::can_bus::SimCanBus`],
//! with its drives, e.g. [`crate::ecs::EcsDrive`], arbitration, fault plan
//! and event log) on a pseudo terminal the way a Lawicel slcan adapter
//! would, in real time ([`RealClock`] instants), so any slcan host
//! (driveset's own `slcan://` link, python-can's `slcan` interface) can talk
//! to them by opening the pty's slave path.
//!
//! The slcan protocol is not in the specs: the Lawicel CANUSB ASCII protocol
//! as the codec implements it ([`driveset_proto::can::slcan`], notes in
//! `docs/errata/can.md`). Each host line is decoded by the codec's
//! [`CommandDecoder`] and answered:
//!
//! - `C` (close): CR, always (closing a closed channel is harmless; python-can
//!   sends `C` first).
//! - `Sn` (bit rate, S0..S8): CR while the channel is closed and `n` is the
//!   simulated bus's rate; BELL while open (Lawicel) or for another rate
//!   (the simulated bus runs at the one rate it was built with, as a
//!   machine's bus does; a real adapter would accept the rate and then see
//!   only errors). `sxxyy`: CR while closed (BTR values not interpreted).
//! - empty line (python-can's empty CAN FD data bit rate): CR.
//! - `O` / `L` (open / listen-only): CR if closed, BELL if already open
//!   (Lawicel; python-can sends `O` twice and ignores the BELL).
//! - `V`: `V1013`, `N`: `NDSIM`, `F`: `F00` (fictional adapter identity).
//! - `Z0` / `Z1`: CR while closed (timestamps off / on), BELL while open.
//! - `t...` / `T...` / `r...` / `R...`: `z\r` / `Z\r` (accepted, as a
//!   Lawicel adapter in auto-poll mode) while open, BELL while closed or
//!   listen-only. The frame goes on the simulated bus
//!   ([`FrameLine::host_send`]: arbitration, wire time, faults; every drive
//!   hears it at its end); each answer that reaches the host
//!   ([`FrameLine::take_arrived`]) is written as a `t...\r` line (with a
//!   4-digit millisecond timestamp after `Z1`). Answers that arrive while the
//!   channel is closed are dropped, as an adapter receives nothing then.
//! - anything undecodable: BELL.

use std::io::{self, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use driveset_link::{CanFrame, Clock, Instant, RealClock};
use driveset_proto::can::slcan::{
    Bitrate, CommandDecoder, SlcanCommand, SlcanError, SlcanResponse,
};
use serialport::{SerialPort, TTYPort};

use crate::can_bus::FrameLine;

/// The longest the server sleeps before it looks at the stop flag again.
pub const POLL: Duration = Duration::from_millis(20);

/// How long a write to the master end may block (the host not reading)
/// before the line is dropped.
const WRITE_TIMEOUT: Duration = Duration::from_millis(500);

/// Why serving stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum SlcanServeError {
    /// The pseudo terminal could not be created.
    #[error("cannot create a pseudo terminal: {0}")]
    Pty(#[from] serialport::Error),
    /// The pseudo terminal has no slave path.
    #[error("the pseudo terminal's slave end has no path")]
    NoPath,
    /// Reading or writing the master end failed.
    #[error("pseudo terminal I/O failed ({op}): {source}")]
    Io {
        /// What was being done.
        op: &'static str,
        /// The error.
        source: io::Error,
    },
    /// The serving thread panicked (a bug).
    #[error("the slcan serving thread panicked")]
    Panicked,
}

/// A pseudo terminal for [`serve_slcan`]: the master end the server reads
/// and writes, and the slave end's path for the host to open.
///
/// Made by `serialport::TTYPort::pair()`, which neither sets TIOCEXCL nor
/// takes a flock on either end (checked in serialport 4.10 source), so the
/// slave path opens by name for any user, also exclusively (driveset's
/// `slcan://` link takes TIOCEXCL + flock on its own descriptor). The
/// first slave descriptor is kept open and never read: with no slave open
/// Linux makes master reads fail (EIO) and a host that closes and reopens
/// the path would hang up the line in between.
#[derive(Debug)]
pub struct SlcanPty {
    master: TTYPort,
    _slave: TTYPort,
    path: String,
}

impl SlcanPty {
    /// A new pseudo terminal pair.
    pub fn open() -> Result<Self, SlcanServeError> {
        let (master, slave) = TTYPort::pair()?;
        let path = slave.name().ok_or(SlcanServeError::NoPath)?;
        Ok(SlcanPty {
            master,
            _slave: slave,
            path,
        })
    }

    /// The slave end's path (`/dev/pts/N`): what the host opens.
    pub fn path(&self) -> &str {
        &self.path
    }
}

/// Something the server saw or did, for the caller's log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SlcanEvent {
    /// A host line decoded, and what the adapter answered.
    Command {
        /// When it was read.
        at: Instant,
        /// The command.
        command: SlcanCommand,
        /// Whether the adapter accepted it (CR / `z`) or refused (BELL).
        accepted: bool,
    },
    /// A host line that does not decode (answered BELL).
    BadLine {
        /// When it was read.
        at: Instant,
        /// Why.
        error: SlcanError,
    },
    /// A frame from the bus (a drive's answer) was written to the host.
    Answer {
        /// When it was written.
        at: Instant,
        /// The frame.
        frame: CanFrame,
    },
    /// A drive's answer was dropped (channel closed, host not reading).
    Dropped {
        /// When.
        at: Instant,
        /// The frame.
        frame: CanFrame,
    },
}

impl std::fmt::Display for SlcanEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let frame_text = |frame: &CanFrame| {
            let mut s = format!("{:03X} [{}]", frame.id, frame.len);
            for b in frame.payload() {
                s.push_str(&format!(" {b:02X}"));
            }
            s
        };
        match self {
            SlcanEvent::Command {
                at,
                command,
                accepted,
            } => write!(
                f,
                "{at} host> {command:?} -> {}",
                if *accepted { "ok" } else { "BELL" }
            ),
            SlcanEvent::BadLine { at, error } => write!(f, "{at} host> bad line: {error} -> BELL"),
            SlcanEvent::Answer { at, frame } => write!(f, "{at} bus> {}", frame_text(frame)),
            SlcanEvent::Dropped { at, frame } => {
                write!(
                    f,
                    "{at} dropped (channel closed or host not reading): {}",
                    frame_text(frame)
                )
            }
        }
    }
}

/// Counters of one serving run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SlcanStats {
    /// Host lines decoded (including frames).
    pub commands: u64,
    /// Host lines that did not decode.
    pub bad_lines: u64,
    /// Frames the host transmitted on the bus.
    pub frames_from_host: u64,
    /// Drive answers written to the host.
    pub answers: u64,
    /// Drive answers dropped.
    pub dropped: u64,
}

/// The simulated adapter's state.
#[derive(Debug)]
struct Adapter {
    open: bool,
    listen_only: bool,
    /// The simulated bus's rate (`None`: not an `Sn` rate).
    bitrate: Option<Bitrate>,
    timestamps: bool,
}

/// Serves the simulated bus `line` on `pty` until `stop` is set (checked
/// at least every [`POLL`]), in real time ([`RealClock`]; the line's origin
/// for time-triggered faults is set to the start). Every adapter-level
/// event goes to `log` (the bus's own frames and faults go to the line's
/// event log). Returns the run's counters; an error only when the pty
/// itself fails.
pub fn serve_slcan(
    pty: &mut SlcanPty,
    line: &mut FrameLine,
    stop: &AtomicBool,
    log: &mut dyn FnMut(&SlcanEvent),
) -> Result<SlcanStats, SlcanServeError> {
    let clock = RealClock;
    let mut adapter = Adapter {
        open: false,
        listen_only: false,
        bitrate: Bitrate::from_bits_per_second(line.bitrate()),
        timestamps: false,
    };
    let mut decoder = CommandDecoder::new();
    let mut stats = SlcanStats::default();
    let mut buf = [0u8; 256];
    let master = &mut pty.master;
    line.set_origin(clock.now());

    while !stop.load(Ordering::Relaxed) {
        // Deliver what has arrived.
        let now = clock.now();
        line.advance(now);
        while let Some(frame) = line.take_arrived(now) {
            if !adapter.open {
                stats.dropped += 1;
                log(&SlcanEvent::Dropped { at: now, frame });
                continue;
            }
            let timestamp = adapter
                .timestamps
                .then(|| (now.as_nanos() / 1_000_000 % 60_000) as u16);
            let received = SlcanResponse::Received { frame, timestamp };
            if write_line(master, &received)? {
                stats.answers += 1;
                log(&SlcanEvent::Answer { at: now, frame });
            } else {
                stats.dropped += 1;
                log(&SlcanEvent::Dropped { at: now, frame });
            }
        }

        // Wait for host bytes, at most until the bus has news.
        let wait = line.next_wakeup().map_or(POLL, |t| (t - now).min(POLL));
        master.set_timeout(wait).map_err(|e| SlcanServeError::Io {
            op: "set the read timeout",
            source: e.into(),
        })?;
        let n = match master.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                continue;
            }
            Err(source) => {
                return Err(SlcanServeError::Io {
                    op: "read the host's bytes",
                    source,
                });
            }
        };
        for &byte in buf.get(..n).unwrap_or(&[]) {
            let Some(decoded) = decoder.push(byte) else {
                continue;
            };
            let at = clock.now();
            let command = match decoded {
                Ok(c) => c,
                Err(error) => {
                    stats.bad_lines += 1;
                    write_line(master, &SlcanResponse::Error)?;
                    log(&SlcanEvent::BadLine { at, error });
                    continue;
                }
            };
            stats.commands += 1;
            let answer = command_answer(&mut adapter, command);
            let accepted = answer != SlcanResponse::Error;
            write_line(master, &answer)?;
            log(&SlcanEvent::Command {
                at,
                command,
                accepted,
            });
            if let (SlcanCommand::Transmit(frame), true) = (command, accepted) {
                stats.frames_from_host += 1;
                // Decoded frames are valid; an invalid one would be dropped.
                let _ = line.host_send(at, &frame);
            }
        }
    }
    Ok(stats)
}

/// Applies a host command to the adapter state; returns the answer line.
fn command_answer(adapter: &mut Adapter, command: SlcanCommand) -> SlcanResponse {
    use SlcanResponse::{Error, Ok};
    match command {
        SlcanCommand::Empty => Ok,
        SlcanCommand::Close => {
            adapter.open = false;
            adapter.listen_only = false;
            Ok
        }
        SlcanCommand::SetBitrate(rate) if !adapter.open && adapter.bitrate == Some(rate) => Ok,
        SlcanCommand::SetBtr { .. } | SlcanCommand::Timestamps(_) if adapter.open => Error,
        SlcanCommand::SetBtr { .. } => Ok,
        SlcanCommand::Timestamps(on) => {
            adapter.timestamps = on;
            Ok
        }
        SlcanCommand::SetBitrate(_) => Error,
        SlcanCommand::Open | SlcanCommand::ListenOnly if adapter.open => Error,
        SlcanCommand::Open | SlcanCommand::ListenOnly => {
            adapter.open = true;
            adapter.listen_only = command == SlcanCommand::ListenOnly;
            Ok
        }
        SlcanCommand::Version => SlcanResponse::Version(*b"1013"),
        SlcanCommand::SerialNumber => SlcanResponse::SerialNumber(*b"DSIM"),
        SlcanCommand::StatusFlags => SlcanResponse::StatusFlags(0),
        SlcanCommand::Transmit(frame) if adapter.open && !adapter.listen_only => {
            SlcanResponse::TransmitAck {
                extended: frame.extended,
            }
        }
        SlcanCommand::Transmit(_) => Error,
    }
}

/// Writes one line to the master end. `Ok(false)` when the host did not
/// take it within [`WRITE_TIMEOUT`] (dropped).
fn write_line(master: &mut TTYPort, line: &SlcanResponse) -> Result<bool, SlcanServeError> {
    let Ok(bytes) = line.to_bytes() else {
        // Only an invalid frame fails to encode; drives build valid ones.
        return Ok(false);
    };
    master
        .set_timeout(WRITE_TIMEOUT)
        .map_err(|e| SlcanServeError::Io {
            op: "set the write timeout",
            source: e.into(),
        })?;
    match master.write_all(&bytes) {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(false),
        Err(source) => Err(SlcanServeError::Io {
            op: "write to the host",
            source,
        }),
    }
}

/// What a finished [`SlcanServer`] hands back: the bus with its drives in
/// their final state ([`FrameLine::drives`], [`FrameLine::into_drives`]),
/// and the run's counters.
pub type ServedBus = (FrameLine, SlcanStats);

/// [`serve_slcan`] on its own thread with its own pty and stop flag.
#[derive(Debug)]
pub struct SlcanServer {
    path: String,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<Result<ServedBus, SlcanServeError>>>,
}

impl SlcanServer {
    /// Creates a pty and starts serving the bus `line` on it; every
    /// adapter event goes to `log`.
    pub fn spawn(
        line: FrameLine,
        mut log: impl FnMut(&SlcanEvent) + Send + 'static,
    ) -> Result<Self, SlcanServeError> {
        let mut pty = SlcanPty::open()?;
        let path = pty.path().to_owned();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name(format!("slcan-sim {path}"))
            .spawn(move || {
                let mut line = line;
                let stats = serve_slcan(&mut pty, &mut line, &flag, &mut log)?;
                Ok((line, stats))
            })
            .map_err(|source| SlcanServeError::Io {
                op: "start the serving thread",
                source,
            })?;
        Ok(SlcanServer {
            path,
            stop,
            handle: Some(handle),
        })
    }

    /// The slave path for the host to open.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The stop flag (set it to stop serving).
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.stop)
    }

    /// Stops serving (within [`POLL`]) and hands back the bus and the
    /// run's counters.
    pub fn stop(mut self) -> Result<ServedBus, SlcanServeError> {
        self.stop.store(true, Ordering::Relaxed);
        match self.handle.take() {
            Some(h) => h.join().map_err(|_| SlcanServeError::Panicked)?,
            None => Err(SlcanServeError::Panicked),
        }
    }
}

impl Drop for SlcanServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter() -> Adapter {
        Adapter {
            open: false,
            listen_only: false,
            bitrate: Some(Bitrate::K500),
            timestamps: false,
        }
    }

    #[test]
    fn python_can_open_sequence_is_accepted() {
        // python-can 4.6: C, S6, empty line, O, then O again.
        let mut a = adapter();
        let answers: Vec<SlcanResponse> = [
            SlcanCommand::Close,
            SlcanCommand::SetBitrate(Bitrate::K500),
            SlcanCommand::Empty,
            SlcanCommand::Open,
            SlcanCommand::Open,
        ]
        .into_iter()
        .map(|c| command_answer(&mut a, c))
        .collect();
        assert_eq!(
            answers,
            [
                SlcanResponse::Ok,
                SlcanResponse::Ok,
                SlcanResponse::Ok,
                SlcanResponse::Ok,
                SlcanResponse::Error
            ]
        );
        assert!(a.open);
        // no rate change while open, nor to a rate the bus does not run at
        assert_eq!(
            command_answer(&mut a, SlcanCommand::SetBitrate(Bitrate::K500)),
            SlcanResponse::Error
        );
        command_answer(&mut a, SlcanCommand::Close);
        assert_eq!(
            command_answer(&mut a, SlcanCommand::SetBitrate(Bitrate::M1)),
            SlcanResponse::Error
        );
    }

    #[test]
    fn frames_only_while_open_and_not_listen_only() {
        let mut a = adapter();
        let f = CanFrame::new(0x601, &[0x40, 0, 0, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            command_answer(&mut a, SlcanCommand::Transmit(f)),
            SlcanResponse::Error
        );
        command_answer(&mut a, SlcanCommand::ListenOnly);
        assert_eq!(
            command_answer(&mut a, SlcanCommand::Transmit(f)),
            SlcanResponse::Error
        );
        command_answer(&mut a, SlcanCommand::Close);
        command_answer(&mut a, SlcanCommand::Open);
        assert_eq!(
            command_answer(&mut a, SlcanCommand::Transmit(f)),
            SlcanResponse::TransmitAck { extended: false }
        );
    }
}
