//! Simulated CAN drives behind a simulated USB-CAN adapter: serves
//! [`FrameDrive`]s (e.g. [`crate::ecs::EcsDrive`]) on a pseudo terminal the
//! way a Lawicel slcan adapter would, in real time, so any slcan host
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
//! - `Sn` (bit rate, S0..S8): CR while the channel is closed, BELL while it is
//!   open (Lawicel). `sxxyy` likewise (the rate then stays as it was: BTR
//!   values are not interpreted).
//! - empty line (python-can's empty CAN FD data bit rate): CR.
//! - `O` / `L` (open / listen-only): CR if closed, BELL if already open
//!   (Lawicel; python-can sends `O` twice and ignores the BELL).
//! - `V`: `V1013`, `N`: `NDSIM`, `F`: `F00` (fictional adapter identity).
//! - `Z0` / `Z1`: CR while closed (timestamps off / on), BELL while open.
//! - `t...` / `T...` / `r...` / `R...`: `z\r` / `Z\r` (accepted, as a
//!   Lawicel adapter in auto-poll mode) while open, BELL while closed or
//!   listen-only. The frame is handed to every drive at the instant its
//!   last bit left the adapter (wire time at the bit rate, exact stuffing,
//!   [`driveset_proto::can::timing`]); a drive's answer is written as a
//!   `t...\r` line when its reaction time and its own wire time have passed.
//!   Answers that fall due while the channel is closed are dropped, as an
//!   adapter receives nothing then.
//! - anything undecodable: BELL.
//!
//! Before any `Sn` the bus runs at 500 kbit/s (simulator choice).
//!
//! Drives only hear the host: a drive's answer is not handed to the other
//! drives (SDO servers ignore each other's responses anyway).

use std::io::{self, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use driveset_link::{CanFrame, Clock, Instant, RealClock};
use driveset_proto::can::slcan::{
    Bitrate, CommandDecoder, SlcanCommand, SlcanError, SlcanResponse,
};
use driveset_proto::can::timing::{self, Stuffing};
use serialport::{SerialPort, TTYPort};

use crate::drive::FrameDrive;

/// The longest the server sleeps before it looks at the stop flag again.
pub const POLL: Duration = Duration::from_millis(20);

/// How long a write to the master end may block (the host not reading)
/// before the line is dropped.
const WRITE_TIMEOUT: Duration = Duration::from_millis(500);

/// The bus rate before the host sends `Sn` (simulator choice).
pub const DEFAULT_BITRATE: Bitrate = Bitrate::K500;

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
    /// A drive's answer was written to the host.
    Answer {
        /// When it was written.
        at: Instant,
        /// The drive's family.
        family: &'static str,
        /// The drive's node id.
        node: u8,
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
            SlcanEvent::Answer {
                at,
                family,
                node,
                frame,
            } => write!(f, "{at} {family} node {node}> {}", frame_text(frame)),
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
    bitrate: Bitrate,
    timestamps: bool,
}

/// A drive answer waiting for its instant.
#[derive(Debug)]
struct Pending {
    due: Instant,
    seq: u64,
    family: &'static str,
    node: u8,
    frame: CanFrame,
}

/// Wire time of `frame` at `rate` (SOF..intermission, exact stuffing).
fn wire_time(frame: &CanFrame, rate: Bitrate) -> Duration {
    timing::frame_bits(frame, Stuffing::Exact)
        .ok()
        .and_then(|bits| timing::frame_time_ns(bits, rate.bits_per_second()))
        .map_or(Duration::ZERO, Duration::from_nanos)
}

/// Serves `drives` on `pty` until `stop` is set (checked at least every
/// [`POLL`]), in real time ([`RealClock`]). Returns the run's counters; an
/// error only when the pty itself fails.
pub fn serve_slcan(
    pty: &mut SlcanPty,
    drives: &mut [Box<dyn FrameDrive>],
    stop: &AtomicBool,
    log: &mut dyn FnMut(&SlcanEvent),
) -> Result<SlcanStats, SlcanServeError> {
    let clock = RealClock;
    let mut adapter = Adapter {
        open: false,
        listen_only: false,
        bitrate: DEFAULT_BITRATE,
        timestamps: false,
    };
    let mut decoder = CommandDecoder::new();
    let mut pending: Vec<Pending> = Vec::new();
    let mut stats = SlcanStats::default();
    let mut seq = 0u64;
    let mut buf = [0u8; 256];
    let master = &mut pty.master;

    while !stop.load(Ordering::Relaxed) {
        // Deliver what is due.
        let now = clock.now();
        pending.sort_by_key(|p| (p.due, p.seq));
        let due = pending.iter().take_while(|p| p.due <= now).count();
        for p in pending.drain(..due) {
            if !adapter.open {
                stats.dropped += 1;
                log(&SlcanEvent::Dropped {
                    at: now,
                    frame: p.frame,
                });
                continue;
            }
            let timestamp = adapter
                .timestamps
                .then(|| (now.as_nanos() / 1_000_000 % 60_000) as u16);
            let line = SlcanResponse::Received {
                frame: p.frame,
                timestamp,
            };
            if write_line(master, &line)? {
                stats.answers += 1;
                log(&SlcanEvent::Answer {
                    at: now,
                    family: p.family,
                    node: p.node,
                    frame: p.frame,
                });
            } else {
                stats.dropped += 1;
                log(&SlcanEvent::Dropped {
                    at: now,
                    frame: p.frame,
                });
            }
        }

        // Wait for host bytes, at most until the next answer is due.
        let wait = pending
            .iter()
            .map(|p| p.due - now)
            .min()
            .map_or(POLL, |d| d.min(POLL));
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
                let heard = at + wire_time(&frame, adapter.bitrate);
                for drive in drives.iter_mut() {
                    if let Some(reply) = drive.hear(heard, &frame) {
                        seq += 1;
                        pending.push(Pending {
                            due: heard + reply.reaction + wire_time(&reply.frame, adapter.bitrate),
                            seq,
                            family: drive.family(),
                            node: drive.node_id(),
                            frame: reply.frame,
                        });
                    }
                }
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
        SlcanCommand::SetBitrate(rate) if !adapter.open => {
            adapter.bitrate = rate;
            Ok
        }
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

/// What a finished [`SlcanServer`] hands back.
pub type ServedDrives = (Vec<Box<dyn FrameDrive>>, SlcanStats);

/// [`serve_slcan`] on its own thread with its own pty and stop flag.
#[derive(Debug)]
pub struct SlcanServer {
    path: String,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<Result<ServedDrives, SlcanServeError>>>,
}

impl SlcanServer {
    /// Creates a pty and starts serving `drives` on it; every event goes
    /// to `log`.
    pub fn spawn(
        drives: Vec<Box<dyn FrameDrive>>,
        mut log: impl FnMut(&SlcanEvent) + Send + 'static,
    ) -> Result<Self, SlcanServeError> {
        let mut pty = SlcanPty::open()?;
        let path = pty.path().to_owned();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name(format!("slcan-sim {path}"))
            .spawn(move || {
                let mut drives = drives;
                let stats = serve_slcan(&mut pty, &mut drives, &flag, &mut log)?;
                Ok((drives, stats))
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

    /// Stops serving (within [`POLL`]) and hands back the drives with their
    /// final state, and the run's counters.
    pub fn stop(mut self) -> Result<ServedDrives, SlcanServeError> {
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
            bitrate: DEFAULT_BITRATE,
            timestamps: false,
        }
    }

    #[test]
    fn python_can_open_sequence_is_accepted() {
        // python-can 4.6: C, S6, empty line, O, then O again.
        let mut a = adapter();
        let answers: Vec<SlcanResponse> = [
            SlcanCommand::Close,
            SlcanCommand::SetBitrate(Bitrate::K250),
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
        assert_eq!(a.bitrate, Bitrate::K250);
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

    #[test]
    fn wire_time_of_an_sdo_frame_at_500k() {
        let f = CanFrame::new(0x601, &[0x40, 0x88, 0x4A, 0, 0, 0, 0, 0]).unwrap();
        let t = wire_time(&f, Bitrate::K500);
        // 111 bits without stuffing, at most 135 with: 222..=270 us.
        assert!(
            t >= Duration::from_micros(222) && t <= Duration::from_micros(270),
            "{t:?}"
        );
    }
}
