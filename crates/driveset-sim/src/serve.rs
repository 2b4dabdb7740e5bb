//! Real-time serving for `driveset sim --pty | --tcp`: owns the loop that
//! runs a [`ByteLine`] (the same core [`crate::bus::SimByteBus`] runs in
//! virtual time) on [`RealClock`] against a byte stream: the master end of
//! a pseudo terminal ([`open_pty`]) or an accepted TCP connection
//! ([`serve_tcp`] on a loopback listener from [`bind_loopback`]).
//!
//! The loop reads host bytes (parity bit masked off), hands them to the
//! drives as arrived at the instant they were read, and writes each reply
//! character when the core says it has arrived: after the drive's reaction
//! time, one character every 10 bit times at the line's baud. It checks
//! the stop flag at least every [`POLL`] so Ctrl-C / SIGTERM handlers in
//! the CLI stop it cleanly; the caller keeps the [`ByteLine`] (drives,
//! log) and can dump the drives' state afterwards.
//!
//! On TCP ([`serve_tcp_with`]) the simulator behaves like a serial device
//! server in raw mode: one client at a time owns the line; a client that
//! connects meanwhile is accepted and waits (logged as `wait`) until the
//! one before it closes or is dropped, then is served; a client that sends
//! nothing for the idle timeout ([`TcpServeOptions::idle_timeout`],
//! default [`DEFAULT_IDLE_TIMEOUT`]) is dropped (logged as `idle`), so a
//! forgotten session does not hold the line for ever.
//!
//! A pty has no baud rate on the wire: the host's characters cross it at
//! once, so they reach the drives in a burst at the instant they are read
//! (the reply pacing is what the host sees of the line rate). It does keep
//! the rate the client set in its termios: the loop reads it back (through
//! the master) before handing host bytes to the line and runs the line's
//! host side at it, so a drive switched to another rate (MC6000 4-PROG =
//! 111, `--transfer-baud`) answers only a host that followed.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use driveset_link::{Clock, Instant, RealClock};

use crate::bus::ByteLine;
use crate::log::{Event, LogError};

/// The longest the loop goes without looking at the stop flag.
pub const POLL: Duration = Duration::from_millis(50);

/// How long a TCP client may send nothing before it is dropped, unless
/// [`TcpServeOptions::idle_timeout`] says otherwise (device servers
/// typically default to tens of seconds).
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(30);

/// How [`serve_tcp_with`] treats its clients.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TcpServeOptions {
    /// Drop a client that has sent nothing for this long; `None`: never.
    pub idle_timeout: Option<Duration>,
}

impl Default for TcpServeOptions {
    fn default() -> Self {
        TcpServeOptions {
            idle_timeout: Some(DEFAULT_IDLE_TIMEOUT),
        }
    }
}

/// The shortest read timeout the loop sets (sockets refuse zero).
const MIN_WAIT: Duration = Duration::from_micros(100);

/// Why serving stopped with an error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServeError {
    /// Reading or writing the stream failed.
    #[error("{what}: {op} failed: {source}; restart `driveset sim`")]
    Io {
        /// The pty or socket.
        what: String,
        /// What was being done.
        op: &'static str,
        /// The cause.
        #[source]
        source: io::Error,
    },
    /// A pseudo terminal could not be opened.
    #[error(
        "cannot open a pseudo terminal: {0}; check that /dev/ptmx exists and is usable, or serve on --tcp instead"
    )]
    Pty(#[source] serialport::Error),
    /// The TCP port could not be bound.
    #[error("cannot listen on {addr}: {source}; pick another --tcp port or stop what holds it")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The cause.
        #[source]
        source: io::Error,
    },
    /// The event log could not be written.
    #[error(transparent)]
    Log(#[from] LogError),
}

/// How one stream's session ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamEnd {
    /// The stop flag was set.
    Stopped,
    /// The other end closed the connection.
    Closed,
    /// The other end sent nothing for the idle timeout and was dropped.
    Idle,
}

/// A byte stream the serve loop can run on: it must be able to bound how
/// long a read blocks.
pub trait ServeStream: Read + Write {
    /// Make the next reads return (with `TimedOut` or `WouldBlock`) after
    /// at most `timeout` without data.
    fn set_poll_timeout(&mut self, timeout: Duration) -> io::Result<()>;

    /// Whether a hang-up (`BrokenPipe`) means "nobody is connected right
    /// now" rather than the end of the session (a pty whose slave side is
    /// closed).
    fn hangup_is_transient(&self) -> bool {
        false
    }

    /// The rate the host set its end to, where the stream has one (a
    /// pty: the termios speed the client set on the slave, read through
    /// the master); `None`: the stream has no rate (TCP).
    fn host_baud(&self) -> Option<u32> {
        None
    }

    /// A name for errors.
    fn describe(&self) -> String;
}

impl ServeStream for TcpStream {
    fn set_poll_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_read_timeout(Some(timeout.max(MIN_WAIT)))
    }

    fn describe(&self) -> String {
        match self.peer_addr() {
            Ok(a) => format!("TCP connection from {a}"),
            Err(_) => "TCP connection".into(),
        }
    }
}

#[cfg(unix)]
impl ServeStream for serialport::TTYPort {
    fn set_poll_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        serialport::SerialPort::set_timeout(self, timeout.max(MIN_WAIT)).map_err(io::Error::from)
    }

    fn hangup_is_transient(&self) -> bool {
        true
    }

    fn host_baud(&self) -> Option<u32> {
        // TCGETS on a pty master reads the slave's termios (Linux
        // tty_mode_ioctl), which is what the client set.
        serialport::SerialPort::baud_rate(self).ok()
    }

    fn describe(&self) -> String {
        "pseudo terminal".into()
    }
}

fn quiet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

fn closed(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::BrokenPipe
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::UnexpectedEof
    )
}

/// Write the characters that have reached the host by `now`.
fn write_due<S: ServeStream>(
    line: &mut ByteLine,
    stream: &mut S,
    now: Instant,
) -> Result<Option<StreamEnd>, ServeError> {
    let mut out = [0u8; 256];
    loop {
        let n = line.take_arrived(now, &mut out);
        if n == 0 {
            return Ok(None);
        }
        let written = stream.write_all(&out[..n]).and_then(|()| stream.flush());
        match written {
            Ok(()) => {}
            // A pty nobody has open drops what the drives say.
            Err(e) if closed(&e) && stream.hangup_is_transient() => {}
            Err(e) if closed(&e) => return Ok(Some(StreamEnd::Closed)),
            Err(source) => {
                return Err(ServeError::Io {
                    what: stream.describe(),
                    op: "write",
                    source,
                });
            }
        }
    }
}

/// Serve `line` in real time on `stream` until `stop` is set
/// ([`StreamEnd::Stopped`]) or the other end closes
/// ([`StreamEnd::Closed`]). Time-triggered faults count from the first
/// session's start (see [`ByteLine::ensure_started`]).
pub fn serve_stream<S: ServeStream>(
    line: &mut ByteLine,
    stream: &mut S,
    stop: &AtomicBool,
) -> Result<StreamEnd, ServeError> {
    serve_session(line, stream, stop, None, &mut |_| Ok(()))
}

/// [`serve_stream`] with an idle timeout ([`StreamEnd::Idle`] once the
/// other end has sent nothing for `idle` and no reply is pending) and a
/// hook called with the line at least every [`POLL`] (the TCP server looks
/// for waiting clients there).
fn serve_session<S: ServeStream>(
    line: &mut ByteLine,
    stream: &mut S,
    stop: &AtomicBool,
    idle: Option<Duration>,
    tick: &mut dyn FnMut(&mut ByteLine) -> Result<(), ServeError>,
) -> Result<StreamEnd, ServeError> {
    let clock = RealClock;
    line.ensure_started(clock.now());
    let mut last_heard = clock.now();
    let mut buf = [0u8; 512];
    loop {
        if stop.load(Ordering::SeqCst) {
            line.log().check()?;
            return Ok(StreamEnd::Stopped);
        }
        tick(line)?;
        let now = clock.now();
        line.advance(now);
        if let Some(end) = write_due(line, stream, now)? {
            return Ok(end);
        }
        if let Some(idle) = idle
            && line.next_wakeup().is_none()
            && now - last_heard >= idle
        {
            return Ok(StreamEnd::Idle);
        }
        let mut wait = line
            .next_wakeup()
            .map_or(POLL, |t| (t - clock.now()).min(POLL));
        if let Some(idle) = idle {
            let left = (last_heard + idle).saturating_duration_since(clock.now());
            wait = wait.min(left.max(MIN_WAIT));
        }
        if let Err(source) = stream.set_poll_timeout(wait) {
            return Err(ServeError::Io {
                what: stream.describe(),
                op: "set the read timeout",
                source,
            });
        }
        match stream.read(&mut buf) {
            Ok(0) if stream.hangup_is_transient() => clock.sleep(wait.max(MIN_WAIT)),
            Ok(0) => return Ok(StreamEnd::Closed),
            Ok(n) => {
                let bytes: Vec<u8> = buf[..n].iter().map(|b| b & 0x7F).collect();
                last_heard = clock.now();
                follow_host_rate(line, stream, last_heard);
                line.host_send_at_once(last_heard, &bytes);
            }
            Err(e) if quiet(&e) => {}
            Err(e) if closed(&e) && stream.hangup_is_transient() => {
                // Nobody has the slave side open: wait for a client.
                clock.sleep(wait.clamp(MIN_WAIT, Duration::from_millis(10)));
            }
            Err(e) if closed(&e) => return Ok(StreamEnd::Closed),
            Err(source) => {
                return Err(ServeError::Io {
                    what: stream.describe(),
                    op: "read",
                    source,
                });
            }
        }
    }
}

/// Put the line's host side at the rate the host set its end of the
/// stream to (a pty runs 8N1 at any rate, so the rate is only the number
/// the client wrote into termios): a drive running at another rate then
/// hears garbage and the host gets garbage back, as on a real line
/// ([`crate::bus`], "Baud"). Rates a 7E1 line does not run at are ignored.
fn follow_host_rate<S: ServeStream>(line: &mut ByteLine, stream: &S, now: Instant) {
    let Some(b) = stream.host_baud() else {
        return;
    };
    if b != line.baud() && line.set_baud(b).is_ok() {
        line.log().push(Event::note(
            now.as_nanos(),
            None,
            "host-baud",
            format!("the host's port runs at {b} baud from here"),
        ));
    }
}

/// A pseudo terminal for `driveset sim --pty`: serve on `master`, give
/// `path` to the user. Keep `slave` open while serving (so the master
/// does not see a hang-up between two client runs).
#[cfg(unix)]
#[derive(Debug)]
pub struct Pty {
    /// The end the simulator serves on.
    pub master: serialport::TTYPort,
    /// The end clients open (by `path`); hold it while serving.
    pub slave: serialport::TTYPort,
    /// The slave's device path, e.g. `/dev/pts/7`.
    pub path: String,
}

/// Open a pseudo terminal pair (raw mode).
#[cfg(unix)]
pub fn open_pty() -> Result<Pty, ServeError> {
    let (master, slave) = serialport::TTYPort::pair().map_err(ServeError::Pty)?;
    let path = serialport::SerialPort::name(&slave).unwrap_or_default();
    Ok(Pty {
        master,
        slave,
        path,
    })
}

/// Serve `line` on the master end of a pty until `stop` is set.
#[cfg(unix)]
pub fn serve_pty(
    line: &mut ByteLine,
    master: &mut serialport::TTYPort,
    stop: &AtomicBool,
) -> Result<(), ServeError> {
    // The pty starts at the line's rate, so a client that leaves the rate
    // alone talks to the drives at theirs.
    serialport::SerialPort::set_baud_rate(master, line.baud()).map_err(|e| ServeError::Io {
        what: "pseudo terminal".into(),
        op: "set the rate",
        source: io::Error::from(e),
    })?;
    loop {
        match serve_stream(line, master, stop)? {
            StreamEnd::Stopped => return Ok(()),
            // A pty does not really close; look again after a pause.
            StreamEnd::Closed | StreamEnd::Idle => RealClock.sleep(Duration::from_millis(10)),
        }
    }
}

/// A listener on `127.0.0.1:port` (port 0: any free port; read it back
/// with `local_addr`). Serving beyond loopback is the caller's explicit
/// choice: bind a `TcpListener` yourself.
pub fn bind_loopback(port: u16) -> Result<TcpListener, ServeError> {
    let addr = SocketAddr::from((Ipv4Addr::LOCALHOST, port));
    TcpListener::bind(addr).map_err(|source| ServeError::Bind { addr, source })
}

/// Serve `line` to TCP clients of `listener`, one at a time (like a
/// serial device server in raw mode), with the default
/// [`TcpServeOptions`], until `stop` is set.
pub fn serve_tcp(
    line: &mut ByteLine,
    listener: &TcpListener,
    stop: &AtomicBool,
) -> Result<(), ServeError> {
    serve_tcp_with(
        line,
        listener,
        stop,
        &TcpServeOptions::default(),
        &mut |_| {},
    )
}

/// Serve `line` to TCP clients of `listener`, one at a time, until `stop`
/// is set (see the module docs: waiting clients, idle timeout). The drives
/// keep their state from one connection to the next. Every `connect`,
/// `wait`, `idle` and `disconnect` event goes to the line's log and to
/// `report`.
pub fn serve_tcp_with(
    line: &mut ByteLine,
    listener: &TcpListener,
    stop: &AtomicBool,
    options: &TcpServeOptions,
    report: &mut dyn FnMut(&Event),
) -> Result<(), ServeError> {
    let what = || match listener.local_addr() {
        Ok(a) => format!("TCP listener {a}"),
        Err(_) => "TCP listener".into(),
    };
    listener
        .set_nonblocking(true)
        .map_err(|source| ServeError::Io {
            what: what(),
            op: "set non-blocking mode",
            source,
        })?;
    let mut note = |line: &ByteLine, kind: &str, detail: String| {
        let event = Event::note(RealClock.now().as_nanos(), None, kind, detail);
        report(&event);
        line.log().push(event);
    };
    // Clients accepted while another had the line, oldest first, with the
    // instant they connected.
    let mut waiting: VecDeque<(TcpStream, SocketAddr, Instant)> = VecDeque::new();
    loop {
        if stop.load(Ordering::SeqCst) {
            for (_, peer, _) in waiting.drain(..) {
                note(
                    line,
                    "disconnect",
                    format!("host {peer} dropped while waiting: the simulator stops"),
                );
            }
            line.log().check()?;
            return Ok(());
        }
        let next = match waiting.pop_front() {
            Some((stream, peer, since)) => Some((stream, peer, Some(since))),
            None => accept(listener, &what)?.map(|(stream, peer)| (stream, peer, None)),
        };
        let Some((mut stream, peer, since)) = next else {
            RealClock.sleep(Duration::from_millis(20));
            continue;
        };
        let setup = stream
            .set_nonblocking(false)
            .and_then(|()| stream.set_nodelay(true));
        if let Err(source) = setup {
            return Err(ServeError::Io {
                what: format!("TCP connection from {peer}"),
                op: "configure",
                source,
            });
        }
        let waited = since.map_or(String::new(), |t| {
            format!(" (waited {} ms)", (RealClock.now() - t).as_millis())
        });
        note(
            line,
            "connect",
            format!("host connected from {peer}{waited}"),
        );
        let mut tick = |line: &mut ByteLine| -> Result<(), ServeError> {
            while let Some((s, p)) = accept(listener, &what)? {
                note(
                    line,
                    "wait",
                    format!("host {p} waits: the line is in use by {peer}"),
                );
                waiting.push_back((s, p, RealClock.now()));
            }
            Ok(())
        };
        let end = serve_session(line, &mut stream, stop, options.idle_timeout, &mut tick)?;
        match end {
            StreamEnd::Stopped => note(
                line,
                "disconnect",
                format!("host {peer} dropped: the simulator stops"),
            ),
            StreamEnd::Closed => note(
                line,
                "disconnect",
                format!("host {peer} closed the connection"),
            ),
            StreamEnd::Idle => {
                let idle = options.idle_timeout.unwrap_or_default();
                note(
                    line,
                    "idle",
                    format!(
                        "host {peer} dropped: sent nothing for {} ms (idle timeout)",
                        idle.as_millis()
                    ),
                );
                let _ = stream.shutdown(std::net::Shutdown::Both);
            }
        }
    }
}

/// Accept one pending connection, if any (the listener is non-blocking).
fn accept(
    listener: &TcpListener,
    what: &dyn Fn() -> String,
) -> Result<Option<(TcpStream, SocketAddr)>, ServeError> {
    match listener.accept() {
        Ok((stream, peer)) => Ok(Some((stream, peer))),
        Err(e) if quiet(&e) => Ok(None),
        Err(source) => Err(ServeError::Io {
            what: what(),
            op: "accept",
            source,
        }),
    }
}
