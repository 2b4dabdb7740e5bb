//! An slcan adapter hub: two simulated USB-CAN adapters on one simulated
//! bus with nothing else on it, each served on its own pseudo terminal.
//! Every frame the host on one side transmits is delivered to the host on
//! the other side as a received frame. This joins two slcan *hosts* (which
//! both expect to talk to an adapter), e.g. driveset's `slcan://` link and
//! python-can's `slcan` interface with a `canopen` SDO server behind it, for
//! interoperability tests against CAN software driveset did not write.
//!
//! Each side answers the host's commands the way [`crate::slcan_serve`]'s
//! simulated adapter does (Lawicel protocol through the codec's
//! [`CommandDecoder`] / [`SlcanResponse`]):
//!
//! - `C`: CR (closes the channel); empty line: CR.
//! - `Sn`: CR while closed and `n` is the hub's bit rate, else BELL;
//!   `sxxyy`, `Z0` / `Z1`: CR while closed, BELL while open.
//! - `O` / `L`: CR if closed, BELL if already open.
//! - `V`: `V1013`, `N`: `NHUB`, `F`: `F00`.
//! - `t` / `T` / `r` / `R`: `z` / `Z` while open (and not listen-only),
//!   then the frame goes to the other side as a `t...` line (with a
//!   millisecond timestamp after its `Z1`) if that side's channel is open;
//!   dropped otherwise (an adapter with a closed channel receives nothing).
//!   BELL while closed or listen-only.
//! - anything undecodable: BELL.
//!
//! There is no wire timing: a frame is forwarded as soon as it is read.
//! One thread per side reads its pty's master end; writes to a master are
//! whole lines under that side's lock, so an answer and a forwarded frame
//! never interleave.

use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use driveset_link::CanFrame;
use driveset_proto::can::slcan::{Bitrate, CommandDecoder, SlcanCommand, SlcanResponse};
use serialport::{SerialPort, TTYPort};

/// The longest a side's thread reads before it looks at the stop flag.
pub const POLL: Duration = Duration::from_millis(20);

/// How long a write to a master end may block (the host not reading)
/// before the line is dropped.
const WRITE_TIMEOUT: Duration = Duration::from_millis(500);

/// The most log lines kept (older ones are dropped).
const LOG_LIMIT: usize = 10_000;

/// Why the hub could not start or stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum SlcanHubError {
    /// The hub's rate is not an slcan `Sn` rate.
    #[error("{0} bit/s is not an slcan bit rate (S0..S8)")]
    Bitrate(u32),
    /// A pseudo terminal could not be created.
    #[error("cannot create a pseudo terminal: {0}")]
    Pty(#[from] serialport::Error),
    /// The pseudo terminal has no slave path.
    #[error("the pseudo terminal's slave end has no path")]
    NoPath,
    /// Reading or writing a master end failed.
    #[error("side {side}: pseudo terminal I/O failed ({op}): {source}")]
    Io {
        /// `a` or `b`.
        side: char,
        /// What was being done.
        op: &'static str,
        /// The error.
        #[source]
        source: io::Error,
    },
    /// A thread panicked (a bug).
    #[error("an slcan hub thread panicked")]
    Panicked,
}

/// Counters of one hub run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HubStats {
    /// Frames side A's host transmitted that reached side B's host.
    pub a_to_b: u64,
    /// Frames side B's host transmitted that reached side A's host.
    pub b_to_a: u64,
    /// Frames dropped (the other channel closed, or its host not reading).
    pub dropped: u64,
    /// Host lines that did not decode or were refused (BELL).
    pub refused: u64,
}

/// One simulated adapter's state and the writing end of its pty.
#[derive(Debug)]
struct Adapter {
    open: bool,
    listen_only: bool,
    timestamps: bool,
    out: TTYPort,
}

#[derive(Debug)]
struct Shared {
    bitrate: Bitrate,
    sides: [Mutex<Adapter>; 2],
    a_to_b: AtomicU64,
    b_to_a: AtomicU64,
    dropped: AtomicU64,
    refused: AtomicU64,
    log: Mutex<Vec<String>>,
    start: Instant,
}

const NAMES: [char; 2] = ['a', 'b'];

impl Shared {
    fn side(&self, i: usize) -> MutexGuard<'_, Adapter> {
        self.sides[i].lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn note(&self, text: String) {
        let mut log = self.log.lock().unwrap_or_else(PoisonError::into_inner);
        if log.len() >= LOG_LIMIT {
            log.remove(0);
        }
        let ms = self.start.elapsed().as_secs_f64() * 1000.0;
        log.push(format!("{ms:10.3} ms {text}"));
    }

    fn stats(&self) -> HubStats {
        HubStats {
            a_to_b: self.a_to_b.load(Ordering::Relaxed),
            b_to_a: self.b_to_a.load(Ordering::Relaxed),
            dropped: self.dropped.load(Ordering::Relaxed),
            refused: self.refused.load(Ordering::Relaxed),
        }
    }
}

/// Two simulated slcan adapters joined by one bus, served on two ptys by
/// two threads. Dropping the hub stops it.
#[derive(Debug)]
pub struct SlcanHub {
    paths: [String; 2],
    stop: Arc<AtomicBool>,
    shared: Arc<Shared>,
    handles: Vec<JoinHandle<Result<(), SlcanHubError>>>,
    /// The slave ends, kept open so a master never sees a hang-up (EIO)
    /// while no host has the path open.
    _slaves: [TTYPort; 2],
}

impl SlcanHub {
    /// Creates the two ptys and starts serving them; both adapters accept
    /// only `bitrate` (one of the `Sn` rates).
    pub fn spawn(bitrate: u32) -> Result<SlcanHub, SlcanHubError> {
        let rate = Bitrate::from_bits_per_second(bitrate).ok_or(SlcanHubError::Bitrate(bitrate))?;
        let (master_a, slave_a) = TTYPort::pair()?;
        let (master_b, slave_b) = TTYPort::pair()?;
        let path_a = slave_a.name().ok_or(SlcanHubError::NoPath)?;
        let path_b = slave_b.name().ok_or(SlcanHubError::NoPath)?;
        let adapter = |master: &TTYPort| -> Result<Adapter, SlcanHubError> {
            let mut out = master.try_clone_native()?;
            out.set_timeout(WRITE_TIMEOUT)?;
            Ok(Adapter {
                open: false,
                listen_only: false,
                timestamps: false,
                out,
            })
        };
        let shared = Arc::new(Shared {
            bitrate: rate,
            sides: [
                Mutex::new(adapter(&master_a)?),
                Mutex::new(adapter(&master_b)?),
            ],
            a_to_b: AtomicU64::new(0),
            b_to_a: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
            refused: AtomicU64::new(0),
            log: Mutex::new(Vec::new()),
            start: Instant::now(),
        });
        let stop = Arc::new(AtomicBool::new(false));
        let mut handles = Vec::new();
        for (i, master) in [master_a, master_b].into_iter().enumerate() {
            let shared = Arc::clone(&shared);
            let stop = Arc::clone(&stop);
            let handle = std::thread::Builder::new()
                .name(format!("slcan-hub {}", NAMES[i]))
                .spawn(move || serve_side(i, master, &shared, &stop))
                .map_err(|source| SlcanHubError::Io {
                    side: NAMES[i],
                    op: "start the serving thread",
                    source,
                })?;
            handles.push(handle);
        }
        Ok(SlcanHub {
            paths: [path_a, path_b],
            stop,
            shared,
            handles,
            _slaves: [slave_a, slave_b],
        })
    }

    /// Side A's slave path (`/dev/pts/N`) for one host to open.
    pub fn path_a(&self) -> &str {
        &self.paths[0]
    }

    /// Side B's slave path for the other host.
    pub fn path_b(&self) -> &str {
        &self.paths[1]
    }

    /// The counters so far.
    pub fn stats(&self) -> HubStats {
        self.shared.stats()
    }

    /// What the hub saw so far, one line per host command and forwarded
    /// frame (for test failure messages).
    pub fn log(&self) -> Vec<String> {
        self.shared
            .log
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// Stops both threads (within [`POLL`]) and returns the counters, or
    /// the first I/O error a side stopped with.
    pub fn stop(mut self) -> Result<HubStats, SlcanHubError> {
        self.stop.store(true, Ordering::Relaxed);
        let mut result = Ok(());
        for h in self.handles.drain(..) {
            let r = h
                .join()
                .map_err(|_| SlcanHubError::Panicked)
                .and_then(|r| r);
            if result.is_ok() {
                result = r;
            }
        }
        result.map(|()| self.shared.stats())
    }
}

impl Drop for SlcanHub {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for h in self.handles.drain(..) {
            let _ = h.join();
        }
    }
}

fn quiet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

fn frame_text(frame: &CanFrame) -> String {
    let mut s = format!("{:03X} [{}]", frame.id, frame.len);
    for b in frame.payload() {
        s.push_str(&format!(" {b:02X}"));
    }
    s
}

/// Reads side `i`'s host lines until `stop` is set.
fn serve_side(
    i: usize,
    mut master: TTYPort,
    shared: &Shared,
    stop: &AtomicBool,
) -> Result<(), SlcanHubError> {
    let side = NAMES[i];
    let io_err = |op, source| SlcanHubError::Io { side, op, source };
    master
        .set_timeout(POLL)
        .map_err(|e| io_err("set the read timeout", e.into()))?;
    let mut decoder = CommandDecoder::new();
    let mut buf = [0u8; 512];
    while !stop.load(Ordering::Relaxed) {
        let n = match master.read(&mut buf) {
            Ok(n) => n,
            Err(e) if quiet(&e) => continue,
            Err(e) => return Err(io_err("read the host's bytes", e)),
        };
        for &byte in buf.get(..n).unwrap_or(&[]) {
            let Some(decoded) = decoder.push(byte) else {
                continue;
            };
            let command = match decoded {
                Ok(c) => c,
                Err(error) => {
                    shared.refused.fetch_add(1, Ordering::Relaxed);
                    shared.note(format!("{side}> bad line: {error} -> BELL"));
                    let mut adapter = shared.side(i);
                    write_line(&mut adapter.out, &SlcanResponse::Error)
                        .map_err(|e| io_err("write to the host", e))?;
                    continue;
                }
            };
            let accepted = {
                let mut adapter = shared.side(i);
                let answer = command_answer(&mut adapter, shared.bitrate, command);
                write_line(&mut adapter.out, &answer)
                    .map_err(|e| io_err("write to the host", e))?;
                answer != SlcanResponse::Error
            };
            if !accepted {
                shared.refused.fetch_add(1, Ordering::Relaxed);
            }
            let SlcanCommand::Transmit(frame) = command else {
                shared.note(format!(
                    "{side}> {command:?} -> {}",
                    if accepted { "ok" } else { "BELL" }
                ));
                continue;
            };
            if !accepted {
                shared.note(format!("{side}> {} refused (BELL)", frame_text(&frame)));
                continue;
            }
            forward(i, frame, shared).map_err(|e| io_err("write to the other host", e))?;
        }
    }
    Ok(())
}

/// Delivers `frame`, transmitted by side `from`, to the other side.
fn forward(from: usize, frame: CanFrame, shared: &Shared) -> io::Result<()> {
    let to = 1 - from;
    let route = format!("{}>{}", NAMES[from], NAMES[to]);
    let mut adapter = shared.side(to);
    if !adapter.open {
        drop(adapter);
        shared.dropped.fetch_add(1, Ordering::Relaxed);
        shared.note(format!(
            "{route} {} dropped (channel closed)",
            frame_text(&frame)
        ));
        return Ok(());
    }
    let timestamp = adapter
        .timestamps
        .then(|| (shared.start.elapsed().as_millis() % 60_000) as u16);
    let delivered = write_line(
        &mut adapter.out,
        &SlcanResponse::Received { frame, timestamp },
    )?;
    drop(adapter);
    let (counter, what) = if delivered {
        let c = if from == 0 {
            &shared.a_to_b
        } else {
            &shared.b_to_a
        };
        (c, "")
    } else {
        (&shared.dropped, " dropped (host not reading)")
    };
    counter.fetch_add(1, Ordering::Relaxed);
    shared.note(format!("{route} {}{what}", frame_text(&frame)));
    Ok(())
}

/// Applies a host command to an adapter; returns the answer line.
fn command_answer(adapter: &mut Adapter, bitrate: Bitrate, command: SlcanCommand) -> SlcanResponse {
    use SlcanResponse::{Error, Ok};
    match command {
        SlcanCommand::Empty => Ok,
        SlcanCommand::Close => {
            adapter.open = false;
            adapter.listen_only = false;
            Ok
        }
        SlcanCommand::SetBitrate(rate) if !adapter.open && rate == bitrate => Ok,
        SlcanCommand::SetBitrate(_) => Error,
        SlcanCommand::SetBtr { .. } | SlcanCommand::Timestamps(_) if adapter.open => Error,
        SlcanCommand::SetBtr { .. } => Ok,
        SlcanCommand::Timestamps(on) => {
            adapter.timestamps = on;
            Ok
        }
        SlcanCommand::Open | SlcanCommand::ListenOnly if adapter.open => Error,
        SlcanCommand::Open | SlcanCommand::ListenOnly => {
            adapter.open = true;
            adapter.listen_only = command == SlcanCommand::ListenOnly;
            Ok
        }
        SlcanCommand::Version => SlcanResponse::Version(*b"1013"),
        SlcanCommand::SerialNumber => SlcanResponse::SerialNumber(*b"NHUB"),
        SlcanCommand::StatusFlags => SlcanResponse::StatusFlags(0),
        SlcanCommand::Transmit(frame) if adapter.open && !adapter.listen_only => {
            SlcanResponse::TransmitAck {
                extended: frame.extended,
            }
        }
        SlcanCommand::Transmit(_) => Error,
    }
}

/// Writes one line. `Ok(false)` when the host did not take it within
/// [`WRITE_TIMEOUT`] (dropped).
fn write_line(out: &mut TTYPort, line: &SlcanResponse) -> io::Result<bool> {
    let Ok(bytes) = line.to_bytes() else {
        // Only an invalid frame fails to encode; decoded frames are valid.
        return Ok(false);
    };
    match out.write_all(&bytes) {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(false),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use driveset_link::slcan::SlcanLink;
    use driveset_link::{Clock, FrameLink};

    fn link(path: &str) -> SlcanLink {
        SlcanLink::open(path, 500_000, 115_200, Duration::from_secs(2)).expect("open slcan")
    }

    #[test]
    fn frames_cross_in_both_directions_between_two_slcan_hosts() {
        let hub = SlcanHub::spawn(500_000).expect("hub");
        let mut a = link(hub.path_a());
        let mut b = link(hub.path_b());
        let f1 = CanFrame::new(0x601, &[0x40, 0x76, 0x4C, 0, 0, 0, 0, 0]).expect("frame");
        let f2 = CanFrame::new(0x581, &[0x43, 0x76, 0x4C, 0, 1, 2, 3, 4]).expect("frame");
        let deadline = || driveset_link::RealClock.deadline_in(Duration::from_secs(5));
        a.send(&f1).expect("send a");
        assert_eq!(b.recv(deadline()).expect("recv b"), Some(f1));
        b.send(&f2).expect("send b");
        assert_eq!(a.recv(deadline()).expect("recv a"), Some(f2));
        drop((a, b));
        let stats = hub.stop().expect("stop");
        assert_eq!((stats.a_to_b, stats.b_to_a, stats.dropped), (1, 1, 0));
    }

    #[test]
    fn wrong_rate_is_refused_and_a_closed_side_receives_nothing() {
        let hub = SlcanHub::spawn(500_000).expect("hub");
        let err = SlcanLink::open(hub.path_a(), 250_000, 115_200, Duration::from_secs(2))
            .expect_err("250 kbit/s refused");
        assert!(err.to_string().contains("BELL"), "{err}");
        let mut a = link(hub.path_a());
        let f = CanFrame::new(0x601, &[0x40, 0, 0, 0, 0, 0, 0, 0]).expect("frame");
        a.send(&f).expect("send");
        // the hub's reader thread handles the frame asynchronously: wait
        // (bounded) until it has been accounted for before stopping
        let deadline = std::time::Instant::now() + Duration::from_secs(10);
        while hub.stats().dropped == 0 && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
        drop(a);
        let stats = hub.stop().expect("stop");
        assert_eq!(stats.dropped, 1);
        assert_eq!(stats.a_to_b, 0);
    }
}
