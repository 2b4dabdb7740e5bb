//! The simulator's event log: owns [`Event`] (one line of the log) and
//! [`EventLog`] (where the lines go: any `Write` such as the `--log FILE`,
//! or memory for tests).
//!
//! One JSON object per line, fields always in this order:
//!
//! ```text
//! {"t_ns":8333333,"dir":"drive","addr":1,"hex":"06","text":"<ACK>","fault":null,"detail":null}
//! ```
//!
//! - `t_ns`: nanoseconds on the bus clock (virtual: since the clock's
//!   epoch; real: since the process's first `RealClock` use). For a host
//!   chunk and a reply: the instant its first character starts on the wire;
//!   for an event: when it happens.
//! - `dir`: `"host"` (one line per host `send`, or per chunk read from the
//!   pty / socket when serving), `"drive"` (one line per reply, as the
//!   drive sent it, before drive-to-host faults unless `detail` says
//!   otherwise) or `"event"` (a fault or bus event on its own line).
//! - `addr`: the replying drive's address (node id on CAN); the affected
//!   drive for events; `null` for host lines and bus-wide events.
//! - `hex`: the bytes, two hex digits each, separated by one space (CAN:
//!   the payload).
//! - `text`: the bytes as ASCII with control characters named (`<EOT>`,
//!   `<STX>`, bytes above 0x7E as `<0xNN>`); CAN: `ID#PAYLOAD` as candump
//!   prints it (`R` for a remote frame).
//! - `fault`: `null`, or what happened to this telegram or the event's
//!   kind: `flip`, `lose`, `truncate`, `garbage`, `collision`,
//!   `baud-mismatch`, `cable`, `power-cycle`, `cable-pulled`, `baud-change`,
//!   `invalid-frame` (CAN); serving on TCP adds `connect` / `disconnect`.
//! - `detail`: `null` or a short human text (which character and bit, how
//!   many characters were kept, off time).
//!
//! Secrets are masked ([`SecretMask`]): the value characters and the BCC
//! of a telegram that carries a password (a code with `role =
//! "password"` or type PT_PASSWORD in a drive's schema: LECOM `STX C1 C2
//! VALUE ETX BCC`, LUSTBUS `STX CODE = VALUE ETX BCC`, in both directions)
//! are logged as `*` (hex `2A`), whatever chunks the telegram arrives in.
//! Everything else is logged as sent; `driveset sim --log` creates the
//! file with mode 0600 all the same: treat it like the bus capture it is.

use std::io::Write;
use std::sync::{Arc, Mutex, PoisonError};

use serde::Serialize;

/// Direction or kind of a log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Dir {
    /// Host to drives.
    Host,
    /// A drive's reply.
    Drive,
    /// A fault or bus event.
    Event,
}

/// One log line.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Event {
    /// Bus clock, nanoseconds.
    pub t_ns: u64,
    /// Direction / kind.
    pub dir: Dir,
    /// Drive address or node id, if any.
    pub addr: Option<u8>,
    /// Bytes in hex.
    pub hex: String,
    /// Bytes as readable text.
    pub text: String,
    /// The fault, if any.
    pub fault: Option<String>,
    /// Details, if any.
    pub detail: Option<String>,
}

impl Event {
    /// A telegram line for `bytes`.
    pub fn bytes(t_ns: u64, dir: Dir, addr: Option<u8>, bytes: &[u8]) -> Self {
        Event {
            t_ns,
            dir,
            addr,
            hex: hex(bytes),
            text: text(bytes),
            fault: None,
            detail: None,
        }
    }

    /// An event line of kind `fault`.
    pub fn note(t_ns: u64, addr: Option<u8>, fault: &str, detail: impl Into<String>) -> Self {
        Event {
            t_ns,
            dir: Dir::Event,
            addr,
            hex: String::new(),
            text: String::new(),
            fault: Some(fault.to_string()),
            detail: Some(detail.into()),
        }
    }

    /// With a fault and detail.
    pub fn with_fault(mut self, fault: &str, detail: impl Into<String>) -> Self {
        self.fault = Some(fault.to_string());
        self.detail = Some(detail.into());
        self
    }

    /// The JSON line (without the newline).
    pub fn to_json(&self) -> String {
        // Serializing plain strings and integers cannot fail.
        serde_json::to_string(self).unwrap_or_default()
    }
}

/// The protocol a [`SecretMask`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaskProtocol {
    /// LECOM-A/B: the code is the two characters C1 C2 after STX (8.A) or
    /// `!` and six characters (8.D).
    Lecom,
    /// LUSTBUS: the CODE is the five digits after STX, up to `=` (2.4).
    Lustbus,
}

#[derive(Debug, Clone, Default, PartialEq, Eq)]
enum MaskState {
    /// Outside a text.
    #[default]
    Idle,
    /// After STX: the code field so far.
    Head(Vec<u8>),
    /// The value, masked or not, until ETX.
    Value(bool),
    /// The BCC after ETX, masked or not.
    Bcc(bool),
}

/// Masks secrets' values in the bytes the log records, as a stream: the
/// state carries over from one chunk to the next (a pty read may end in
/// the middle of a telegram), one state per direction.
#[derive(Debug, Clone)]
pub struct SecretMask {
    protocol: MaskProtocol,
    secrets: Vec<u32>,
    host: MaskState,
    drive: MaskState,
}

/// What a masked character (a secret's BCC) is logged as.
pub const MASKED: u8 = b'*';

/// What a secret's value is logged as, whatever its length.
pub const SECRET_VALUE: &[u8] = b"***";

impl SecretMask {
    /// A mask for the codes `secrets` (numbers) of a `protocol` line.
    pub fn new(protocol: MaskProtocol, mut secrets: Vec<u32>) -> Self {
        secrets.sort_unstable();
        secrets.dedup();
        SecretMask {
            protocol,
            secrets,
            host: MaskState::Idle,
            drive: MaskState::Idle,
        }
    }

    /// `bytes` as the log records them: the characters of a secret's value
    /// and its BCC replaced by [`MASKED`]. `dir` is who sent them.
    pub fn apply(&mut self, dir: Dir, bytes: &[u8]) -> Vec<u8> {
        let mut state = std::mem::take(match dir {
            Dir::Drive => &mut self.drive,
            _ => &mut self.host,
        });
        let mut out = Vec::with_capacity(bytes.len());
        for &b in bytes {
            let (next, masked) = self.step(state.clone(), b & 0x7F);
            // a secret value's characters are dropped and its end shows
            // as `***`, whatever its length (the length is a hint too)
            if masked && matches!(state, MaskState::Value(true)) {
                if b & 0x7F == 0x03 {
                    out.extend_from_slice(SECRET_VALUE);
                    out.push(b);
                }
            } else if masked {
                out.push(MASKED);
            } else {
                out.push(b);
            }
            state = next;
        }
        *match dir {
            Dir::Drive => &mut self.drive,
            _ => &mut self.host,
        } = state;
        out
    }

    /// One character: the next state and whether to mask it.
    fn step(&self, state: MaskState, b: u8) -> (MaskState, bool) {
        const STX: u8 = 0x02;
        const ETX: u8 = 0x03;
        const EOT: u8 = 0x04;
        match state {
            // the byte after ETX is the BCC, whatever it is (LECOM 8.G)
            MaskState::Bcc(secret) => (MaskState::Idle, secret),
            _ if b == EOT => (MaskState::Idle, false),
            MaskState::Idle if b == STX => (MaskState::Head(Vec::new()), false),
            MaskState::Idle => (MaskState::Idle, false),
            MaskState::Head(_) if b == ETX => (MaskState::Bcc(false), false),
            MaskState::Head(mut head) => {
                head.push(b);
                match self.code_of(&head) {
                    Some(Some(n)) => (
                        MaskState::Value(self.secrets.binary_search(&n).is_ok()),
                        false,
                    ),
                    Some(None) => (MaskState::Value(false), false),
                    None => (MaskState::Head(head), false),
                }
            }
            MaskState::Value(secret) if b == ETX => (MaskState::Bcc(secret), secret),
            MaskState::Value(secret) => (MaskState::Value(secret), secret),
        }
    }

    /// The code the head names: `None` while incomplete, `Some(None)` when
    /// complete but no value code (or not a code at all).
    fn code_of(&self, head: &[u8]) -> Option<Option<u32>> {
        match self.protocol {
            MaskProtocol::Lecom => {
                use driveset_proto::lecom::CodeAddress;
                let want = if head.first() == Some(&b'!') { 7 } else { 2 };
                if head.len() < want {
                    return None;
                }
                Some(CodeAddress::parse(head).ok().map(|c| match c {
                    CodeAddress::Standard(n) => u32::from(n.get()),
                    CodeAddress::Extended(x) => u32::from(x.code),
                }))
            }
            MaskProtocol::Lustbus => {
                use driveset_proto::lustbus::{CodeMeaning, ParameterCode};
                if head.last() != Some(&b'=') && head.len() <= 5 {
                    return None;
                }
                let digits: Option<[u8; 5]> = head.get(..5).and_then(|d| d.try_into().ok());
                Some(
                    digits
                        .filter(|_| head.len() == 6)
                        .and_then(ParameterCode::from_digits)
                        .and_then(|code| {
                            if let Some(c) = code.compatible_parameter() {
                                return Some(u32::from(c.number()));
                            }
                            match code.meaning() {
                                CodeMeaning::VfValue { parameter, .. } => {
                                    Some(u32::from(parameter))
                                }
                                CodeMeaning::McValue { parameter } => Some(u32::from(parameter)),
                                _ => None,
                            }
                        }),
                )
            }
        }
    }
}

/// Bytes as hex pairs separated by spaces.
pub fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        s.push_str(&format!("{b:02X}"));
    }
    s
}

const CONTROL_NAMES: [&str; 32] = [
    "NUL", "SOH", "STX", "ETX", "EOT", "ENQ", "ACK", "BEL", "BS", "HT", "LF", "VT", "FF", "CR",
    "SO", "SI", "DLE", "DC1", "DC2", "DC3", "DC4", "NAK", "SYN", "ETB", "CAN", "EM", "SUB", "ESC",
    "FS", "GS", "RS", "US",
];

/// Bytes as ASCII, control characters as `<NAME>`, others as `<0xNN>`.
pub fn text(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len());
    for &b in bytes {
        match b {
            0x20..=0x7E => s.push(char::from(b)),
            0x7F => s.push_str("<DEL>"),
            0x00..=0x1F => {
                s.push('<');
                s.push_str(CONTROL_NAMES[usize::from(b)]);
                s.push('>');
            }
            _ => s.push_str(&format!("<0x{b:02X}>")),
        }
    }
    s
}

/// Why the log could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write the event log: {0}; check the --log path and free disk space")]
pub struct LogError(#[source] pub std::io::Error);

#[derive(Debug, Default)]
enum Sink {
    #[default]
    Off,
    Memory(Vec<Event>),
    Writer {
        out: WriterBox,
        failed: Option<std::io::Error>,
    },
}

struct WriterBox(Box<dyn Write + Send>);

impl std::fmt::Debug for WriterBox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Write")
    }
}

/// Where log lines go. Cheap to clone: clones share the sink, so a test can
/// keep a handle to a memory log it gave to a bus.
#[derive(Debug, Clone, Default)]
pub struct EventLog {
    sink: Arc<Mutex<Sink>>,
}

impl EventLog {
    /// A log that records nothing.
    pub fn off() -> Self {
        EventLog::default()
    }

    /// A log kept in memory; read it with [`EventLog::events`].
    pub fn memory() -> Self {
        EventLog {
            sink: Arc::new(Mutex::new(Sink::Memory(Vec::new()))),
        }
    }

    /// A log written as JSON lines to `out` (e.g. a `BufWriter<File>`).
    /// The first write error stops the log; [`EventLog::check`] reports it.
    pub fn writer(out: impl Write + Send + 'static) -> Self {
        EventLog {
            sink: Arc::new(Mutex::new(Sink::Writer {
                out: WriterBox(Box::new(out)),
                failed: None,
            })),
        }
    }

    /// Whether lines are recorded at all.
    pub fn is_on(&self) -> bool {
        !matches!(*self.lock(), Sink::Off)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Sink> {
        self.sink.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Record one line.
    pub fn push(&self, event: Event) {
        let mut sink = self.lock();
        match &mut *sink {
            Sink::Off => {}
            Sink::Memory(v) => v.push(event),
            Sink::Writer { out, failed } => {
                if failed.is_none() {
                    let mut line = event.to_json();
                    line.push('\n');
                    if let Err(e) = out.0.write_all(line.as_bytes()) {
                        *failed = Some(e);
                    }
                }
            }
        }
    }

    /// The lines recorded so far (memory logs; empty otherwise).
    pub fn events(&self) -> Vec<Event> {
        match &*self.lock() {
            Sink::Memory(v) => v.clone(),
            _ => Vec::new(),
        }
    }

    /// The lines recorded so far as JSON (memory logs).
    pub fn lines(&self) -> Vec<String> {
        self.events().iter().map(Event::to_json).collect()
    }

    /// Flush a writer log and report the first write error, if any.
    pub fn check(&self) -> Result<(), LogError> {
        let mut sink = self.lock();
        if let Sink::Writer { out, failed } = &mut *sink {
            if let Some(e) = failed.take() {
                // Keep the log stopped: later lines would leave a hole.
                *failed = Some(std::io::Error::new(e.kind(), "an earlier write failed"));
                return Err(LogError(e));
            }
            out.0.flush().map_err(LogError)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn masked(mask: &mut SecretMask, dir: Dir, chunks: &[&[u8]]) -> String {
        chunks
            .iter()
            .map(|c| text(&mask.apply(dir, c)))
            .collect::<String>()
    }

    #[test]
    fn a_lecom_password_is_masked_in_any_chunking_and_other_codes_are_not() {
        let telegram = b"\x0401\x0294777\x039\x0401\x0211600\x036";
        let whole = masked(
            &mut SecretMask::new(MaskProtocol::Lecom, vec![94]),
            Dir::Host,
            &[telegram],
        );
        assert_eq!(whole, "<EOT>01<STX>94***<ETX>*<EOT>01<STX>11600<ETX>6");
        // every split point gives the same log text
        for cut in 0..telegram.len() {
            let mut m = SecretMask::new(MaskProtocol::Lecom, vec![94]);
            let (a, b) = telegram.split_at(cut);
            assert_eq!(masked(&mut m, Dir::Host, &[a, b]), whole, "cut at {cut}");
        }
        // a reply to a RECEIVE, in the drive's direction
        let mut m = SecretMask::new(MaskProtocol::Lecom, vec![94]);
        assert_eq!(
            masked(&mut m, Dir::Drive, &[b"\x0294777\x039"]),
            "<STX>94***<ETX>*"
        );
        // extended addressing `!` + 4 hex code digits + 2 subcode digits
        let mut m = SecretMask::new(MaskProtocol::Lecom, vec![94]);
        assert_eq!(
            masked(&mut m, Dir::Host, &[b"\x0401\x02!005E0012\x03x"]),
            "<EOT>01<STX>!005E00***<ETX>*"
        );
    }

    #[test]
    fn a_lustbus_password_is_masked_and_the_bcc_byte_too() {
        let mut m = SecretMask::new(MaskProtocol::Lustbus, vec![70]);
        assert_eq!(
            masked(
                &mut m,
                Dir::Host,
                &[b"\x04A\x02001", b"70=04D2\x03z\x04A\x0200112=03E8\x03r"]
            ),
            "<EOT>A<STX>00170=***<ETX>*<EOT>A<STX>00112=03E8<ETX>r"
        );
        // the BCC after ETX is masked even when it is an EOT byte
        let mut m = SecretMask::new(MaskProtocol::Lustbus, vec![70]);
        assert_eq!(
            masked(&mut m, Dir::Drive, &[b"A\x0200170=1\x03\x04"]),
            "A<STX>00170=***<ETX>*"
        );
        // a password of any length, also none, logs alike
        for value in ["", "1", "04D2", "FFFFFFFF"] {
            let mut m = SecretMask::new(MaskProtocol::Lustbus, vec![70]);
            let t = format!("A\x0200170={value}\x03z");
            assert_eq!(
                masked(&mut m, Dir::Drive, &[t.as_bytes()]),
                "A<STX>00170=***<ETX>*"
            );
        }
    }
}
