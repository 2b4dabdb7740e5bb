//! Test support: a proxy that behaves like the hardware between a PC and an
//! RS-485 line (issue 11): per-direction delay `mean +- jitter` from a
//! seeded RNG (an FTDI adapter's latency timer, a serial device server),
//! optional echo of every byte the client sends (a 2-wire RS-485 adapter
//! without echo suppression), optional fragmenting into chunks of a few
//! bytes, optional merging of what arrives within a window into one write.
//!
//! - [`TcpProxy`]: listens on 127.0.0.1 (any free port), forwards each
//!   accepted connection to a target TCP address (a new target connection
//!   per client, so `driveset sim --tcp` sees clients one after another).
//! - [`PtyProxy`] (unix): a pseudo terminal the client opens by path,
//!   forwarded to another serial device path (the pty of `driveset sim
//!   --pty`).
//!
//! Bytes are never reordered: each chunk is delivered at `max(previous
//! delivery, arrival + delay)`, as a line would. Echoed bytes travel back
//! to the client with the client-bound delay, queued before any reply.

#![allow(dead_code)]

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What the proxy does to the bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    /// Mean one-way delay, each direction.
    pub mean: Duration,
    /// Uniform jitter: each chunk's delay is in `mean - jitter ..= mean +
    /// jitter` (clamped at 0).
    pub jitter: Duration,
    /// Send every byte the client sends back to the client as well.
    pub echo: bool,
    /// Forward at most this many bytes per write (a few bytes at a time),
    /// 1 ms apart.
    pub fragment: Option<usize>,
    /// Collect what is due within this window and write it at once.
    pub merge: Option<Duration>,
    /// RNG seed (delays are reproducible from it).
    pub seed: u64,
}

impl Shape {
    /// No delay, no echo, no fragmenting.
    pub const fn direct() -> Shape {
        Shape {
            mean: Duration::ZERO,
            jitter: Duration::ZERO,
            echo: false,
            fragment: None,
            merge: None,
            seed: 1,
        }
    }

    /// `mean_ms +- jitter_ms` each way.
    pub const fn delay(mean_ms: u64, jitter_ms: u64) -> Shape {
        Shape {
            mean: Duration::from_millis(mean_ms),
            jitter: Duration::from_millis(jitter_ms),
            ..Shape::direct()
        }
    }

    /// With echo of the client's bytes.
    pub const fn echoing(self) -> Shape {
        Shape { echo: true, ..self }
    }

    /// Forwarded `n` bytes at a time.
    pub const fn fragmented(self, n: usize) -> Shape {
        Shape {
            fragment: Some(n),
            ..self
        }
    }

    /// Merging what is due within `window`.
    pub const fn merging(self, window: Duration) -> Shape {
        Shape {
            merge: Some(window),
            ..self
        }
    }
}

/// splitmix64: small, seeded, good enough for delays.
#[derive(Debug)]
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A delay in `mean - jitter ..= mean + jitter`, to the microsecond.
    fn delay(&mut self, mean: Duration, jitter: Duration) -> Duration {
        let j = jitter.as_micros() as u64;
        if j == 0 {
            return mean;
        }
        let offset = self.next() % (2 * j + 1);
        let us = (mean.as_micros() as u64 + offset).saturating_sub(j);
        Duration::from_micros(us)
    }
}

/// Chunks waiting to be written to one side, with their delivery instant.
#[derive(Debug, Default)]
struct Queue {
    items: VecDeque<(Instant, Vec<u8>)>,
    /// The last delivery instant queued (no reordering).
    last: Option<Instant>,
    closed: bool,
}

#[derive(Debug, Default)]
struct Pipe {
    queue: Mutex<Queue>,
    ready: Condvar,
}

impl Pipe {
    fn push(&self, at: Instant, bytes: Vec<u8>) {
        let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
        let at = q.last.map_or(at, |l| l.max(at));
        q.last = Some(at);
        q.items.push_back((at, bytes));
        self.ready.notify_all();
    }

    fn close(&self) {
        let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
        q.closed = true;
        self.ready.notify_all();
    }

    /// The next write: the bytes due (merged within `merge`), or `None`
    /// when closed and empty or `stop` is set.
    fn next(&self, merge: Option<Duration>, stop: &AtomicBool) -> Option<Vec<u8>> {
        let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if stop.load(Ordering::SeqCst) {
                return None;
            }
            let Some(&(at, _)) = q.items.front() else {
                if q.closed {
                    return None;
                }
                q = self
                    .ready
                    .wait_timeout(q, Duration::from_millis(20))
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
                continue;
            };
            let until = at + merge.unwrap_or(Duration::ZERO);
            let now = Instant::now();
            if now < until {
                let wait = (until - now).min(Duration::from_millis(20));
                q = self
                    .ready
                    .wait_timeout(q, wait)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
                continue;
            }
            let mut out = Vec::new();
            while let Some((at, _)) = q.items.front() {
                if *at > until {
                    break;
                }
                if let Some((_, bytes)) = q.items.pop_front() {
                    out.extend_from_slice(&bytes);
                }
                if merge.is_none() {
                    break;
                }
            }
            return Some(out);
        }
    }
}

/// One direction's reader: reads `from`, queues chunks on `to` (and, for
/// the client's bytes with echo, on `echo`).
fn reader<R: Read>(
    mut from: R,
    to: Arc<Pipe>,
    echo: Option<Arc<Pipe>>,
    shape: Shape,
    seed: u64,
    stop: Arc<AtomicBool>,
) {
    let mut rng = Rng(seed);
    let mut buf = [0u8; 256];
    loop {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let n = match from.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) =>
            {
                continue;
            }
            Err(_) => break,
        };
        let now = Instant::now();
        let got = &buf[..n];
        let size = shape.fragment.unwrap_or(n).max(1);
        for (i, chunk) in got.chunks(size).enumerate() {
            let gap = if shape.fragment.is_some() {
                Duration::from_millis(i as u64)
            } else {
                Duration::ZERO
            };
            let at = now + rng.delay(shape.mean, shape.jitter) + gap;
            if let Some(echo) = &echo {
                echo.push(at, chunk.to_vec());
            }
            to.push(at, chunk.to_vec());
        }
    }
    to.close();
    if let Some(echo) = echo {
        echo.close();
    }
}

/// One direction's writer.
fn writer<W: Write>(mut to: W, pipe: Arc<Pipe>, merge: Option<Duration>, stop: Arc<AtomicBool>) {
    while let Some(bytes) = pipe.next(merge, &stop) {
        if to.write_all(&bytes).and_then(|()| to.flush()).is_err() {
            break;
        }
    }
    // let the other direction end as well
    stop.store(true, Ordering::SeqCst);
}

/// Pumps between a client and a target until either side closes or `stop`.
fn pump<CR, CW, TR, TW>(
    client: (CR, CW),
    target: (TR, TW),
    shape: Shape,
    seed: u64,
    stop: Arc<AtomicBool>,
) -> Vec<JoinHandle<()>>
where
    CR: Read + Send + 'static,
    CW: Write + Send + 'static,
    TR: Read + Send + 'static,
    TW: Write + Send + 'static,
{
    let to_target = Arc::new(Pipe::default());
    let to_client = Arc::new(Pipe::default());
    let echo = shape.echo.then(|| Arc::clone(&to_client));
    let mut threads = Vec::new();
    {
        let (to, stop) = (Arc::clone(&to_target), Arc::clone(&stop));
        let from = client.0;
        threads.push(std::thread::spawn(move || {
            reader(from, to, echo, shape, seed, stop)
        }));
    }
    {
        let (to, stop) = (Arc::clone(&to_client), Arc::clone(&stop));
        let from = target.0;
        let seed = seed ^ 0x5555_5555;
        threads.push(std::thread::spawn(move || {
            reader(from, to, None, shape, seed, stop)
        }));
    }
    {
        let stop = Arc::clone(&stop);
        let w = target.1;
        threads.push(std::thread::spawn(move || {
            writer(w, to_target, shape.merge, stop)
        }));
    }
    {
        let w = client.1;
        threads.push(std::thread::spawn(move || {
            writer(w, to_client, shape.merge, stop)
        }));
    }
    threads
}

/// A TCP proxy on 127.0.0.1 (see the module docs); stopped on drop.
#[derive(Debug)]
pub struct TcpProxy {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    accept: Option<JoinHandle<()>>,
}

impl TcpProxy {
    /// Listen on a free loopback port and forward to `target`.
    pub fn start(target: SocketAddr, shape: Shape) -> TcpProxy {
        let listener =
            TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind the proxy on 127.0.0.1");
        listener.set_nonblocking(true).expect("non-blocking");
        let addr = listener.local_addr().expect("proxy address");
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = Arc::clone(&stop);
        let accept = std::thread::spawn(move || {
            let mut sessions: Vec<(Arc<AtomicBool>, Vec<JoinHandle<()>>)> = Vec::new();
            let mut n = 0u64;
            while !stop2.load(Ordering::SeqCst) {
                match listener.accept() {
                    Ok((client, _)) => {
                        n += 1;
                        let Ok(server) = TcpStream::connect(target) else {
                            continue;
                        };
                        let session_stop = Arc::new(AtomicBool::new(false));
                        let threads = tcp_session(
                            client,
                            server,
                            shape,
                            shape.seed.wrapping_add(n),
                            &session_stop,
                        );
                        sessions.push((session_stop, threads));
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
            for (s, threads) in sessions {
                s.store(true, Ordering::SeqCst);
                for t in threads {
                    let _ = t.join();
                }
            }
        });
        TcpProxy {
            addr,
            stop,
            accept: Some(accept),
        }
    }

    /// `tcp://127.0.0.1:PORT` for `--port` (plus `query`, e.g. `?baud=9600`).
    pub fn port(&self, query: &str) -> String {
        format!("tcp://{}{query}", self.addr)
    }
}

fn tcp_session(
    client: TcpStream,
    server: TcpStream,
    shape: Shape,
    seed: u64,
    stop: &Arc<AtomicBool>,
) -> Vec<JoinHandle<()>> {
    for s in [&client, &server] {
        let _ = s.set_nonblocking(false);
        let _ = s.set_nodelay(true);
        let _ = s.set_read_timeout(Some(Duration::from_millis(20)));
    }
    let (Ok(cr), Ok(tr)) = (client.try_clone(), server.try_clone()) else {
        return Vec::new();
    };
    let closer_c = client.try_clone().ok();
    let closer_s = server.try_clone().ok();
    let mut threads = pump((cr, client), (tr, server), shape, seed, Arc::clone(stop));
    // Close both sockets once the session ends (either side closed).
    let stop = Arc::clone(stop);
    threads.push(std::thread::spawn(move || {
        while !stop.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(10));
        }
        for s in [closer_c, closer_s].into_iter().flatten() {
            let _ = s.shutdown(std::net::Shutdown::Both);
        }
    }));
    threads
}

impl Drop for TcpProxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.accept.take() {
            let _ = t.join();
        }
    }
}

/// A pty proxy (unix): the client opens [`PtyProxy::path`]; bytes go to
/// and from the serial device `target` (another pty's slave path).
#[cfg(unix)]
#[derive(Debug)]
pub struct PtyProxy {
    path: String,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    /// Kept open so the master does not see a hang-up between clients.
    _slave: serialport::TTYPort,
}

#[cfg(unix)]
impl PtyProxy {
    /// Open a pty and forward it to `target` with `shape`.
    pub fn start(target: &str, shape: Shape) -> PtyProxy {
        use serialport::SerialPort;
        let (mut master, slave) = serialport::TTYPort::pair().expect("open a pty for the proxy");
        let path = slave.name().unwrap_or_default();
        let mut target = serialport::new(target, 9600)
            .timeout(Duration::from_millis(20))
            .open_native()
            .expect("open the target pty");
        master
            .set_timeout(Duration::from_millis(20))
            .expect("master timeout");
        target
            .set_timeout(Duration::from_millis(20))
            .expect("target timeout");
        let cr = master.try_clone_native().expect("clone master");
        let tr = target.try_clone_native().expect("clone target");
        let stop = Arc::new(AtomicBool::new(false));
        let threads = pump(
            (cr, master),
            (tr, target),
            shape,
            shape.seed,
            Arc::clone(&stop),
        );
        PtyProxy {
            path,
            stop,
            threads,
            _slave: slave,
        }
    }

    /// The pty path for `--port` (plus `query`).
    pub fn port(&self, query: &str) -> String {
        format!("{}{query}", self.path)
    }
}

#[cfg(unix)]
impl Drop for PtyProxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// Self-tests of the proxy against a loopback echo server.
mod tests {
    use super::*;

    /// A TCP server that answers every read with the same bytes.
    fn mirror() -> (SocketAddr, Arc<AtomicBool>) {
        let l = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind");
        let addr = l.local_addr().expect("addr");
        let stop = Arc::new(AtomicBool::new(false));
        let s2 = Arc::clone(&stop);
        std::thread::spawn(move || {
            l.set_nonblocking(true).expect("nb");
            while !s2.load(Ordering::SeqCst) {
                let Ok((mut c, _)) = l.accept() else {
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                };
                let _ = c.set_nonblocking(false);
                let mut buf = [0u8; 64];
                while let Ok(n) = c.read(&mut buf) {
                    if n == 0 || c.write_all(&buf[..n]).is_err() {
                        break;
                    }
                }
            }
        });
        (addr, stop)
    }

    fn read_exactly(c: &mut TcpStream, n: usize) -> (Vec<u8>, usize) {
        c.set_read_timeout(Some(Duration::from_secs(5)))
            .expect("timeout");
        let mut out = Vec::new();
        let mut reads = 0;
        let mut buf = [0u8; 64];
        while out.len() < n {
            let k = c.read(&mut buf).expect("read");
            assert!(k > 0, "closed after {out:?}");
            reads += 1;
            out.extend_from_slice(&buf[..k]);
        }
        (out, reads)
    }

    #[test]
    fn proxy_delays_both_ways_in_order() {
        let (target, stop) = mirror();
        let p = TcpProxy::start(target, Shape::delay(30, 5));
        let mut c = TcpStream::connect(p.addr).expect("connect");
        let t0 = Instant::now();
        c.write_all(b"\x04@00091\x05").expect("send");
        let (got, _) = read_exactly(&mut c, 8);
        // Not a speed assertion: the delay is the proxy's contract (two
        // ways of at least 25 ms each).
        assert!(
            t0.elapsed() >= Duration::from_millis(50),
            "{:?}",
            t0.elapsed()
        );
        assert_eq!(got, b"\x04@00091\x05");
        stop.store(true, Ordering::SeqCst);
    }

    #[test]
    fn proxy_echoes_and_fragments() {
        let (target, stop) = mirror();
        let p = TcpProxy::start(target, Shape::delay(3, 0).echoing().fragmented(2));
        let mut c = TcpStream::connect(p.addr).expect("connect");
        c.set_nodelay(true).expect("nodelay");
        c.write_all(b"ABCDEF").expect("send");
        // the echo of every byte, then the mirror's answer
        let (got, _) = read_exactly(&mut c, 12);
        assert_eq!(&got[..6], b"ABCDEF");
        assert_eq!(&got[6..], b"ABCDEF");
        stop.store(true, Ordering::SeqCst);
    }

    #[test]
    fn rng_delays_stay_in_range_and_repeat_from_the_seed() {
        let mut a = Rng(7);
        let mut b = Rng(7);
        for _ in 0..1000 {
            let d = a.delay(Duration::from_millis(16), Duration::from_millis(4));
            assert!(d >= Duration::from_millis(12) && d <= Duration::from_millis(20));
            assert_eq!(
                d,
                b.delay(Duration::from_millis(16), Duration::from_millis(4))
            );
        }
    }
}
