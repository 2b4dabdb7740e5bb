//! Local echo on 2-wire RS-485 lines: owns [`EchoLink`], a wrapper over any
//! [`ByteLink`] that removes the master's own characters from what comes
//! back, the port option's [`EchoMode`] (`?echo=auto|on|off`) and the pure
//! detection function [`detect_echo`] (shared with `driveset doctor`).
//!
//! A 2-wire (half-duplex) RS-485 adapter whose receiver stays enabled while
//! it transmits hands every character the master sends back to it, before
//! the drive's reply. Both LUSTBUS and LECOM replies would then start with
//! a copy of the request; the codecs would take it for garbage (or, worse,
//! for a telegram). The wrapper strips the echo for every serial protocol:
//!
//! - `on`: every character sent is expected back, in order, before
//!   anything else; matching characters are dropped. A character that
//!   differs from the expected echo means the echo was lost or corrupted:
//!   the rest of the expected echo is forgotten and the character is passed
//!   on (the codec then sees it, as it would without the wrapper).
//! - `off`: nothing is changed.
//! - `auto` (the default): the first exchange decides. If the first
//!   characters received after a send equal the characters just sent, in
//!   order ([`detect_echo`]), the line echoes: they are dropped and the
//!   wrapper works as `on` from then on. If the first character received
//!   differs, the line does not echo: it is passed on with everything after
//!   it and the wrapper works as `off`. While what has arrived is a proper
//!   prefix of the request (a reply that happens to start like the request,
//!   or an echo split across reads) it is held back until the next
//!   character decides; if the deadline passes first, the held characters
//!   are a reply (an echo would have arrived whole within the characters'
//!   own wire time) and the line is taken as not echoing. An exchange in
//!   which nothing comes back decides nothing.
//!
//! Characters are compared without bit 7: a receiver set to 8 data bits
//! on a 7E1 line sees the parity bit there, and the codecs mask it too.

use std::collections::VecDeque;
use std::fmt;

use crate::ByteLink;
use crate::clock::{Clock, Instant};
use crate::error::LinkError;

/// The `echo=` port option.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum EchoMode {
    /// Detect from the first exchange (the default).
    #[default]
    Auto,
    /// The line echoes: strip every character sent.
    On,
    /// The line does not echo: pass everything on.
    Off,
}

impl EchoMode {
    /// The option's values, as the port syntax spells them.
    pub const NAMES: &'static [&'static str] = &["auto", "on", "off"];

    /// The value as the port syntax spells it.
    pub fn name(self) -> &'static str {
        match self {
            EchoMode::Auto => "auto",
            EchoMode::On => "on",
            EchoMode::Off => "off",
        }
    }

    /// Parse `auto`, `on` or `off`.
    pub fn parse(text: &str) -> Option<EchoMode> {
        match text {
            "auto" => Some(EchoMode::Auto),
            "on" => Some(EchoMode::On),
            "off" => Some(EchoMode::Off),
            _ => None,
        }
    }
}

impl fmt::Display for EchoMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What [`detect_echo`] concludes from one exchange.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EchoVerdict {
    /// The bytes received start with the bytes sent: the line echoes.
    Echo,
    /// The first byte received that can be compared differs from the
    /// request: the line does not echo.
    NoEcho,
    /// Nothing received, or what arrived is a proper prefix of the
    /// request: not decided yet.
    Undecided,
}

/// Whether `received` (the bytes that came back after `sent` went out,
/// before anything else was sent) starts with an echo of `sent`, comparing
/// without bit 7. Pure: no IO, no clock.
///
/// ```
/// use driveset_link::echo::{EchoVerdict, detect_echo};
/// let req = b"\x04AA00091\x05";
/// assert_eq!(detect_echo(req, b"\x04AA00091\x05\x02..."), EchoVerdict::Echo);
/// assert_eq!(detect_echo(req, b"\x02"), EchoVerdict::NoEcho);
/// assert_eq!(detect_echo(req, b"\x04AA"), EchoVerdict::Undecided);
/// assert_eq!(detect_echo(req, b""), EchoVerdict::Undecided);
/// ```
pub fn detect_echo(sent: &[u8], received: &[u8]) -> EchoVerdict {
    if received.is_empty() || sent.is_empty() {
        return EchoVerdict::Undecided;
    }
    let n = sent.len().min(received.len());
    let same = sent[..n]
        .iter()
        .zip(&received[..n])
        .all(|(a, b)| (a ^ b) & 0x7F == 0);
    match (same, received.len() >= sent.len()) {
        (false, _) => EchoVerdict::NoEcho,
        (true, true) => EchoVerdict::Echo,
        (true, false) => EchoVerdict::Undecided,
    }
}

/// What an [`EchoLink`] knows about its line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EchoState {
    /// `auto`, nothing decided yet.
    Unknown,
    /// The line echoes (`on`, or detected).
    Echoing,
    /// The line does not echo (`off`, or detected).
    Clean,
}

/// A [`ByteLink`] that strips the line's echo of what it sends (see the
/// module docs).
#[derive(Debug)]
pub struct EchoLink<L> {
    inner: L,
    mode: EchoMode,
    state: EchoState,
    /// Characters sent whose echo has not come back yet.
    expected: VecDeque<u8>,
    /// `auto`, undecided: the characters sent in this exchange, and those
    /// received so far (a prefix of them), held back.
    probe: Vec<u8>,
    held: Vec<u8>,
    /// Characters received and decided to be reply, not yet handed out.
    ready: VecDeque<u8>,
    stripped: u64,
}

impl<L: ByteLink> EchoLink<L> {
    /// Wrap `inner` with echo handling `mode`.
    pub fn new(inner: L, mode: EchoMode) -> Self {
        let state = match mode {
            EchoMode::Auto => EchoState::Unknown,
            EchoMode::On => EchoState::Echoing,
            EchoMode::Off => EchoState::Clean,
        };
        EchoLink {
            inner,
            mode,
            state,
            expected: VecDeque::new(),
            probe: Vec::new(),
            held: Vec::new(),
            ready: VecDeque::new(),
            stripped: 0,
        }
    }

    /// The mode it was made with.
    pub fn mode(&self) -> EchoMode {
        self.mode
    }

    /// What it knows about the line now.
    pub fn state(&self) -> EchoState {
        self.state
    }

    /// Echo characters dropped so far.
    pub fn stripped(&self) -> u64 {
        self.stripped
    }

    /// The wrapped link.
    pub fn inner(&self) -> &L {
        &self.inner
    }

    /// The wrapped link, to use it directly.
    pub fn inner_mut(&mut self) -> &mut L {
        &mut self.inner
    }

    /// Unwrap.
    pub fn into_inner(self) -> L {
        self.inner
    }

    /// Sort freshly received characters into echo (dropped), held
    /// (undecided) and reply (`ready`).
    fn absorb(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match self.state {
                EchoState::Clean => self.ready.push_back(b),
                EchoState::Echoing => match self.expected.front() {
                    Some(&e) if (e ^ b) & 0x7F == 0 => {
                        self.expected.pop_front();
                        self.stripped += 1;
                    }
                    Some(_) => {
                        // The echo was lost or garbled: forget the rest.
                        self.expected.clear();
                        self.ready.push_back(b);
                    }
                    None => self.ready.push_back(b),
                },
                EchoState::Unknown => {
                    self.held.push(b);
                    match detect_echo(&self.probe, &self.held) {
                        EchoVerdict::Undecided => {}
                        EchoVerdict::Echo => {
                            self.state = EchoState::Echoing;
                            self.stripped += self.held.len() as u64;
                            self.held.clear();
                            self.probe.clear();
                        }
                        EchoVerdict::NoEcho => self.decide_clean(),
                    }
                }
            }
        }
    }

    /// `auto`: the line does not echo; what was held is reply.
    fn decide_clean(&mut self) {
        self.state = EchoState::Clean;
        self.ready.extend(self.held.drain(..));
        self.probe.clear();
        self.expected.clear();
    }

    fn hand_out(&mut self, buf: &mut [u8]) -> usize {
        let n = buf.len().min(self.ready.len());
        for (slot, b) in buf.iter_mut().zip(self.ready.drain(..n)) {
            *slot = b;
        }
        n
    }
}

impl<L: ByteLink> ByteLink for EchoLink<L> {
    fn port(&self) -> &str {
        self.inner.port()
    }

    /// The wrapped link's bus: stripping an echo does not change the bus.
    fn bus_id(&self) -> String {
        self.inner.bus_id()
    }

    fn baud(&self) -> u32 {
        self.inner.baud()
    }

    fn clock(&self) -> &dyn Clock {
        self.inner.clock()
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.inner.send(bytes)?;
        match self.state {
            EchoState::Clean => {}
            EchoState::Echoing => self.expected.extend(bytes.iter().copied()),
            EchoState::Unknown => {
                // Nothing came back from the previous exchange (or only a
                // prefix of it, which is reply): this one decides.
                if !self.held.is_empty() {
                    self.decide_clean();
                } else {
                    self.probe.clear();
                    self.probe.extend_from_slice(bytes);
                }
            }
        }
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let mut scratch = [0u8; 256];
        loop {
            if !self.ready.is_empty() {
                return Ok(self.hand_out(buf));
            }
            let n = self.inner.recv(&mut scratch, deadline)?;
            if n == 0 {
                if self.state == EchoState::Unknown && !self.held.is_empty() {
                    // An echo arrives whole within its own wire time: a
                    // prefix still incomplete at the deadline is reply.
                    self.decide_clean();
                    return Ok(self.hand_out(buf));
                }
                return Ok(0);
            }
            self.absorb(&scratch[..n]);
        }
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        // Echo already here is dropped with the input; echo of what was
        // sent that is still on its way stays expected.
        let mut scratch = [0u8; 256];
        let now = self.inner.clock().now();
        for _ in 0..64 {
            let n = self.inner.recv(&mut scratch, now)?;
            if n == 0 {
                break;
            }
            self.absorb(&scratch[..n]);
        }
        self.inner.discard_input()?;
        self.ready.clear();
        if self.state == EchoState::Unknown && !self.held.is_empty() {
            self.decide_clean();
            self.ready.clear();
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), LinkError> {
        self.inner.flush()
    }

    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.inner.set_baud(baud)
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::VirtualClock;
    use crate::mem::{MemByteLink, byte_pair, wire_time};

    const REQ: &[u8] = b"\x04AA00091\x05";
    const REPLY: &[u8] = b"\x02000911234\x03\x30";

    fn pair() -> (VirtualClock, MemByteLink, MemByteLink) {
        let clock = VirtualClock::new();
        let (host, drive) = byte_pair(&clock, 9600).expect("pair");
        (clock, host, drive)
    }

    /// The drive end: read what the host sent, echo it (`echo`), then
    /// answer `reply`.
    fn answer(drive: &mut MemByteLink, clock: &VirtualClock, echo: bool, reply: &[u8]) {
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        loop {
            let n = drive
                .recv(&mut buf, clock.deadline_in(Duration::from_millis(1)))
                .expect("drive recv");
            if n == 0 {
                break;
            }
            got.extend_from_slice(&buf[..n]);
        }
        if echo {
            drive.send(&got).expect("echo");
        }
        drive.send(reply).expect("reply");
    }

    fn read_all<L: ByteLink>(host: &mut L, clock: &VirtualClock) -> Vec<u8> {
        let mut out = Vec::new();
        let mut buf = [0u8; 64];
        loop {
            let n = host
                .recv(&mut buf, clock.deadline_in(Duration::from_millis(50)))
                .expect("host recv");
            if n == 0 {
                return out;
            }
            out.extend_from_slice(&buf[..n]);
        }
    }

    #[test]
    fn detection_is_exact() {
        assert_eq!(detect_echo(REQ, REQ), EchoVerdict::Echo);
        assert_eq!(detect_echo(REQ, b"\x04AA00091\x05\x02"), EchoVerdict::Echo);
        // Bit 7 (a parity bit read as data) does not count.
        assert_eq!(
            detect_echo(b"\x04A", &[0x84, b'A' | 0x80]),
            EchoVerdict::Echo
        );
        assert_eq!(detect_echo(REQ, b"\x04AB"), EchoVerdict::NoEcho);
        assert_eq!(detect_echo(REQ, b"\x04A"), EchoVerdict::Undecided);
        assert_eq!(detect_echo(REQ, b""), EchoVerdict::Undecided);
        assert_eq!(detect_echo(b"", b"x"), EchoVerdict::Undecided);
    }

    /// A link whose reads are scripted: each chunk becomes readable at its
    /// instant (virtual time), one chunk per read; sends are recorded.
    #[derive(Debug)]
    struct Script {
        clock: VirtualClock,
        chunks: VecDeque<(Instant, Vec<u8>)>,
        sent: Vec<u8>,
    }

    impl ByteLink for Script {
        fn port(&self) -> &str {
            "script"
        }
        fn bus_id(&self) -> String {
            "test:script".into()
        }
        fn baud(&self) -> u32 {
            9600
        }
        fn clock(&self) -> &dyn Clock {
            &self.clock
        }
        fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
            self.sent.extend_from_slice(bytes);
            Ok(())
        }
        fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
            match self.chunks.front() {
                Some((at, _)) if *at <= deadline => {
                    self.clock.sleep_until(*at);
                    let (_, chunk) = self.chunks.pop_front().expect("front");
                    buf[..chunk.len()].copy_from_slice(&chunk);
                    Ok(chunk.len())
                }
                _ => {
                    self.clock.sleep_until(deadline);
                    Ok(0)
                }
            }
        }
        fn discard_input(&mut self) -> Result<(), LinkError> {
            let now = self.clock.now();
            while self.chunks.front().is_some_and(|(at, _)| *at <= now) {
                self.chunks.pop_front();
            }
            Ok(())
        }
        fn flush(&mut self) -> Result<(), LinkError> {
            Ok(())
        }
    }

    fn ms(n: u64) -> Instant {
        Instant::from_nanos(n * 1_000_000)
    }

    #[test]
    fn auto_detects_an_echo_split_across_reads_and_strips_it() {
        let clock = VirtualClock::new();
        let script = Script {
            clock: clock.clone(),
            chunks: VecDeque::from([
                (ms(2), REQ[..3].to_vec()),
                (ms(5), REQ[3..].to_vec()),
                (ms(9), REPLY[..4].to_vec()),
                (ms(10), REPLY[4..].to_vec()),
            ]),
            sent: Vec::new(),
        };
        let mut link = EchoLink::new(script, EchoMode::Auto);
        link.send(REQ).expect("send");
        let mut buf = [0u8; 32];
        let n = link.recv(&mut buf, ms(100)).expect("recv");
        // The two echo pieces were swallowed; the first read hands out the
        // reply's first chunk, at the instant it arrived.
        assert_eq!(&buf[..n], &REPLY[..4]);
        assert_eq!(clock.now(), ms(9));
        assert_eq!(link.state(), EchoState::Echoing);
        assert_eq!(link.stripped(), REQ.len() as u64);
        let n = link.recv(&mut buf, ms(100)).expect("recv");
        assert_eq!(&buf[..n], &REPLY[4..]);
        assert_eq!(link.inner().sent, REQ);
    }

    #[test]
    fn auto_holds_a_partial_echo_and_releases_a_diverging_reply_whole() {
        let clock = VirtualClock::new();
        let script = Script {
            clock: clock.clone(),
            chunks: VecDeque::from([(ms(2), b"\x04A".to_vec()), (ms(4), b"Z\x05".to_vec())]),
            sent: Vec::new(),
        };
        let mut link = EchoLink::new(script, EchoMode::Auto);
        link.send(REQ).expect("send");
        let mut buf = [0u8; 32];
        let n = link.recv(&mut buf, ms(100)).expect("recv");
        // Nothing handed out at 2 ms: the held prefix comes with the
        // character that decided, at 4 ms.
        assert_eq!(&buf[..n], b"\x04AZ\x05");
        assert_eq!(clock.now(), ms(4));
        assert_eq!(link.state(), EchoState::Clean);
    }

    #[test]
    fn echo_through_the_in_memory_line_in_virtual_time() {
        let (clock, host, mut drive) = pair();
        let mut link = EchoLink::new(host, EchoMode::Auto);
        link.send(REQ).expect("send");
        let sent_at = clock.now();
        answer(&mut drive, &clock, true, REPLY);
        let mut one = [0u8; 1];
        let n = link
            .recv(&mut one, clock.deadline_in(Duration::from_millis(100)))
            .expect("recv");
        assert_eq!((n, one[0]), (1, 0x02));
        // The drive read for 1 ms, echoed 9 characters and sent 12: all of
        // it had arrived when the host looked.
        assert_eq!(
            clock.now() - sent_at,
            Duration::from_millis(1) + wire_time(9 + REPLY.len(), 9600)
        );
        let mut out = vec![0x02];
        out.extend(read_all(&mut link, &clock));
        assert_eq!(out, REPLY);
        assert_eq!(link.stripped(), REQ.len() as u64);
    }

    #[test]
    fn auto_passes_a_reply_that_starts_like_the_request() {
        let (clock, host, mut drive) = pair();
        let mut link = EchoLink::new(host, EchoMode::Auto);
        link.send(REQ).expect("send");
        // No echo; the reply's first three characters equal the request's.
        let reply = b"\x04AAX";
        answer(&mut drive, &clock, false, reply);
        assert_eq!(read_all(&mut link, &clock), reply);
        assert_eq!(link.state(), EchoState::Clean);
        assert_eq!(link.stripped(), 0);
        // From now on nothing is stripped, not even an exact copy.
        link.send(REQ).expect("send");
        answer(&mut drive, &clock, false, REQ);
        assert_eq!(read_all(&mut link, &clock), REQ);
    }

    #[test]
    fn auto_releases_a_short_prefix_reply_at_the_deadline() {
        let (clock, host, mut drive) = pair();
        let mut link = EchoLink::new(host, EchoMode::Auto);
        link.send(REQ).expect("send");
        // A LECOM drive answering a lone EOT (the request's first byte).
        answer(&mut drive, &clock, false, b"\x04");
        let mut buf = [0u8; 8];
        let deadline = clock.deadline_in(Duration::from_millis(30));
        let n = link.recv(&mut buf, deadline).expect("recv");
        assert_eq!(&buf[..n], b"\x04");
        assert_eq!(clock.now(), deadline);
        assert_eq!(link.state(), EchoState::Clean);
    }

    #[test]
    fn auto_stays_undecided_when_nothing_answers_then_detects() {
        let (clock, host, mut drive) = pair();
        let mut link = EchoLink::new(host, EchoMode::Auto);
        link.send(b"\x04BB00091\x05").expect("send");
        assert_eq!(read_all(&mut link, &clock), b"");
        assert_eq!(link.state(), EchoState::Unknown);
        let mut sink = [0u8; 32];
        let _ = drive.recv(&mut sink, clock.now()).expect("drain");
        link.send(REQ).expect("send");
        answer(&mut drive, &clock, true, REPLY);
        assert_eq!(read_all(&mut link, &clock), REPLY);
        assert_eq!(link.state(), EchoState::Echoing);
        // Every later exchange is stripped too, with a discard between.
        link.discard_input().expect("discard");
        link.send(b"\x04").expect("send EOT");
        link.send(REQ).expect("send");
        answer(&mut drive, &clock, true, REPLY);
        assert_eq!(read_all(&mut link, &clock), REPLY);
        assert_eq!(link.stripped(), 2 * REQ.len() as u64 + 1);
    }

    #[test]
    fn on_strips_and_a_garbled_echo_passes_through() {
        let (clock, host, mut drive) = pair();
        let mut link = EchoLink::new(host, EchoMode::On);
        link.send(REQ).expect("send");
        answer(&mut drive, &clock, true, REPLY);
        assert_eq!(read_all(&mut link, &clock), REPLY);
        link.send(b"\x04AB").expect("send");
        let mut sink = [0u8; 8];
        let _ = drive.recv(&mut sink, clock.deadline_in(Duration::from_millis(5)));
        // The echo's last character came back as 'X': it and what follows
        // are handed on.
        drive.send(b"\x04AX\x15").expect("garbled echo");
        assert_eq!(read_all(&mut link, &clock), b"X\x15");
    }

    #[test]
    fn off_changes_nothing() {
        let (clock, host, mut drive) = pair();
        let mut link = EchoLink::new(host, EchoMode::Off);
        link.send(REQ).expect("send");
        answer(&mut drive, &clock, true, REPLY);
        let mut want = REQ.to_vec();
        want.extend_from_slice(REPLY);
        assert_eq!(read_all(&mut link, &clock), want);
        assert_eq!(link.state(), EchoState::Clean);
    }

    #[test]
    fn mode_names_round_trip() {
        for name in EchoMode::NAMES {
            assert_eq!(EchoMode::parse(name).map(EchoMode::name), Some(*name));
        }
        assert_eq!(EchoMode::parse("yes"), None);
    }
}
