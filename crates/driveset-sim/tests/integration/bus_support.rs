//! Tiny fake drives for the bus tests (`bus*.rs`, used as `support`). They
//! do not depend on the real family models.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::can::CanFrame;
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use driveset_schema::schema::CodeStyle;
use driveset_sim::drive::{ByteDrive, FrameDrive, FrameReply, Heard, Reply};

pub const EOT: u8 = 0x04;
pub const ENQ: u8 = 0x05;
pub const ACK: u8 = 0x06;
pub const NAK: u8 = 0x15;

/// What a fake drive saw, shared with the test.
#[derive(Debug, Default)]
pub struct Seen {
    /// Every character heard: instant, byte, parity flag.
    pub heard: Vec<(Instant, u8, bool)>,
    /// Every power cycle: instant, off time.
    pub power: Vec<(Instant, Duration)>,
    /// Telegrams completed (instant of the last character).
    pub telegrams: Vec<Instant>,
}

pub type Shared = Arc<Mutex<Seen>>;

/// A fake character-line drive. Telegram: `EOT`, an address digit
/// (`'0'` = every drive), anything, `ENQ`. It answers `ACK`, its address
/// digit (or `NAK` + digit if a character had a parity error), after
/// `reaction`. A telegram with a `B` in it makes the drive switch to
/// 19200 baud. While powered off it hears nothing.
#[derive(Debug)]
pub struct FakeDrive {
    pub addr: u8,
    pub reaction: Duration,
    pub seen: Shared,
    buf: Vec<(u8, bool)>,
    off_until: Instant,
    baud_change: Option<u32>,
    value: i64,
}

impl FakeDrive {
    pub fn boxed(addr: u8, reaction: Duration) -> (Box<dyn ByteDrive>, Shared) {
        let seen = Shared::default();
        let d = FakeDrive {
            addr,
            reaction,
            seen: Arc::clone(&seen),
            buf: Vec::new(),
            off_until: Instant::ZERO,
            baud_change: None,
            value: 7,
        };
        (Box::new(d), seen)
    }
}

fn set(schema: &str, value: i64) -> ResolvedSet {
    let mut values = BTreeMap::new();
    values.insert(CodeKey::new(1), RawValue::Int(value));
    ResolvedSet {
        schema: schema.into(),
        code_style: CodeStyle::Lust,
        values,
        secrets: Default::default(),
    }
}

impl ByteDrive for FakeDrive {
    fn family(&self) -> &'static str {
        "fake"
    }

    fn address(&self) -> u8 {
        self.addr
    }

    fn hear(&mut self, now: Instant, byte: u8, parity_ok: bool) -> Heard {
        let mut seen = self.seen.lock().unwrap();
        seen.heard.push((now, byte, parity_ok));
        if now < self.off_until {
            return Heard::Nothing;
        }
        if byte == EOT && parity_ok {
            self.buf.clear();
        }
        self.buf.push((byte, parity_ok));
        if byte != ENQ || self.buf.first().map(|b| b.0) != Some(EOT) {
            return Heard::Nothing;
        }
        seen.telegrams.push(now);
        let digit = self.buf.get(1).map_or(0, |b| b.0);
        let all_ok = self.buf.iter().all(|b| b.1);
        let wants_baud = self.buf.iter().any(|b| b.0 == b'B');
        self.buf.clear();
        let mine = digit == b'0' + self.addr || digit == b'0';
        if !mine {
            return Heard::Telegram { reply: None };
        }
        if wants_baud && all_ok {
            self.baud_change = Some(19200);
        }
        let head = if all_ok { ACK } else { NAK };
        Heard::Telegram {
            reply: Some(Reply {
                bytes: vec![head, b'0' + self.addr],
                reaction: self.reaction,
            }),
        }
    }

    fn power_cycle(&mut self, now: Instant, off: Duration) {
        self.seen.lock().unwrap().power.push((now, off));
        self.off_until = now + off;
        self.buf.clear();
        self.value = 7;
    }

    fn state(&self) -> ResolvedSet {
        set("fake-schema", self.value)
    }

    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        match (key.number, raw) {
            (1, RawValue::Int(v)) => {
                self.value = v;
                Ok(())
            }
            _ => Err("the fake drive only has code 1 (integer)".into()),
        }
    }

    fn running(&self) -> bool {
        false
    }

    fn set_running(&mut self, _running: bool) {}

    fn take_baud_change(&mut self) -> Option<u32> {
        self.baud_change.take()
    }
}

/// A fake CAN node: answers a frame with id `0x600 + node` (or id 0,
/// "everyone") with id `0x580 + node` and the same payload.
#[derive(Debug)]
pub struct FakeNode {
    pub node: u8,
    pub reaction: Duration,
    pub seen: Arc<Mutex<Vec<(Instant, CanFrame)>>>,
    pub power: Arc<Mutex<Vec<(Instant, Duration)>>>,
}

impl FakeNode {
    pub fn boxed(node: u8, reaction: Duration) -> (Box<dyn FrameDrive>, FakeNodeHandles) {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let power = Arc::new(Mutex::new(Vec::new()));
        let n = FakeNode {
            node,
            reaction,
            seen: Arc::clone(&seen),
            power: Arc::clone(&power),
        };
        (Box::new(n), FakeNodeHandles { seen, power })
    }
}

pub struct FakeNodeHandles {
    pub seen: Arc<Mutex<Vec<(Instant, CanFrame)>>>,
    pub power: Arc<Mutex<Vec<(Instant, Duration)>>>,
}

impl FrameDrive for FakeNode {
    fn family(&self) -> &'static str {
        "fake-can"
    }

    fn node_id(&self) -> u8 {
        self.node
    }

    fn hear(&mut self, now: Instant, frame: &CanFrame) -> Option<FrameReply> {
        self.seen.lock().unwrap().push((now, *frame));
        if frame.id != 0x600 + u32::from(self.node) && frame.id != 0 {
            return None;
        }
        let reply = CanFrame::new(0x580 + u32::from(self.node), frame.payload()).ok()?;
        Some(FrameReply {
            frame: reply,
            reaction: self.reaction,
        })
    }

    fn power_cycle(&mut self, now: Instant, off: Duration) {
        self.power.lock().unwrap().push((now, off));
    }

    fn state(&self) -> ResolvedSet {
        set("fake-can-schema", i64::from(self.node))
    }

    fn poke(&mut self, _key: CodeKey, _raw: RawValue) -> Result<(), String> {
        Err("read-only fake".into())
    }

    fn running(&self) -> bool {
        false
    }

    fn set_running(&mut self, _running: bool) -> Result<(), String> {
        Err("the fake node has no motor".into())
    }
}

/// `EOT <addr digit> 0 0 1 1 2 ENQ`: an 8-character read request.
pub fn telegram(addr_digit: u8) -> Vec<u8> {
    let mut t = vec![EOT, addr_digit];
    t.extend_from_slice(b"00112");
    t.push(ENQ);
    t
}
