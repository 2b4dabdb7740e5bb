//! The contract between a simulated bus and a family model.
//!
//! A bus hands every character (LUSTBUS / LECOM) or frame (CAN) that
//! appears on the line to every drive on it, in order, with the instant the
//! character's stop bit ended. A drive answers a telegram addressed to it
//! with a [`Reply`] (or [`FrameReply`]): the bytes it puts on the line and
//! its reaction time, counted from the end of the host telegram to the
//! start of the reply. The bus schedules the reply's characters on the
//! line (10 bit times each at the line's baud), applies fault injection,
//! and logs both directions.
//!
//! A model owns its parameter table (loaded from a schema and, for codes
//! the specs do not document, a fixture schema marked fictional), its
//! decoder state, and its own seeded [`crate::rng::SimRng`].

use std::collections::BTreeMap;
use std::time::Duration;

use driveset_link::Instant;
use driveset_proto::can::CanFrame;
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};

use crate::rng::SimRng;

/// What a drive puts on the line in answer to a host telegram.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reply {
    /// The reply's characters (7-bit).
    pub bytes: Vec<u8>,
    /// From the end of the host telegram to the first reply character.
    pub reaction: Duration,
}

/// What a drive made of one character it heard.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Heard {
    /// The character did not complete a telegram (or was noise).
    Nothing,
    /// The character completed a host telegram (addressed to this drive or
    /// not); `reply` is the drive's answer, if it answers.
    Telegram {
        /// The answer, if any (none for broadcasts, other addresses, bad
        /// frames the spec says go unanswered, a drive that is booting).
        reply: Option<Reply>,
    },
}

/// A simulated drive on a character line (LUSTBUS, LECOM-A/B).
pub trait ByteDrive: Send + std::fmt::Debug {
    /// The drive family (`"mc6000"`, `"vf1000"`, `"tmd"`), for logs.
    fn family(&self) -> &'static str;

    /// The drive's bus address.
    fn address(&self) -> u8;

    /// One character from the line, parity bit already stripped; `now` is
    /// the end of the character's stop bit. `parity_ok` is false when the
    /// character arrived with a parity error (the bus's fault injection
    /// flipped a bit of it): LECOM drives answer such a RECEIVE with "?",
    /// LUSTBUS drives treat the telegram as broken.
    fn hear(&mut self, now: Instant, byte: u8, parity_ok: bool) -> Heard;

    /// Power is cut at `now` and comes back after `off`: volatile state is
    /// lost (RAM values back to factory values, decoder reset), the drive
    /// answers nothing until it has booted, and the family's power-on
    /// indication (LUSTBUS SIOF/SERR bit 0) is set.
    fn power_cycle(&mut self, now: Instant, off: Duration);

    /// Every parameter value the drive holds now, raw, keyed by code.
    fn state(&self) -> ResolvedSet;

    /// Set a value directly, bypassing the protocol (tests, `status` drift
    /// demos). Refused with a message for an unknown code.
    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String>;

    /// Whether the drive's motor is running (LUSTBUS control word, LECOM
    /// C0150 / C0068); a running drive refuses some writes.
    fn running(&self) -> bool;

    /// Start or stop the motor (test hook for the refusal rules).
    fn set_running(&mut self, running: bool);

    /// A new line rate the drive switched to since the last call (MC6000
    /// 4-PROG = 111 activates a new 81-SBAUD at once, LUSTBUS 11.5); the bus
    /// then runs that drive's replies at the new rate.
    fn take_baud_change(&mut self) -> Option<u32> {
        None
    }

    /// The line rate the drive runs at now (`None`: the line's; a state
    /// file keeps it, so a drive left at a transfer rate stays there
    /// between commands, as a powered drive does).
    fn active_rate(&self) -> Option<u32> {
        None
    }

    /// The numbers of the drive's codes whose values are secrets
    /// (passwords: `role = "password"` or PT_PASSWORD in its schema); the
    /// bus's log masks their values ([`crate::log::SecretMask`]). None by
    /// default (a test drive without a schema).
    fn secret_codes(&self) -> Vec<u32> {
        Vec::new()
    }

    /// Run at `baud` from now on (a state file's rate; no restart).
    fn restore_rate(&mut self, baud: u32) {
        let _ = baud;
    }

    /// Whether the drive's own address code (LUSTBUS 82-SIOA/SADDR, Tmd
    /// C0009) was ever written over the bus and acknowledged: an engineer
    /// gave it an address, perhaps the one it had. The service bench
    /// (`crate::factory`) moves on to the next drive then.
    fn address_assigned(&self) -> bool {
        false
    }

    /// Mark the address as given (a state file's `assigned`).
    fn restore_address_assigned(&mut self) {}

    /// The line rate the drive's rate code says (LUSTBUS 81-SIOC/SBAUD,
    /// Tmd C0125), the rate it boots at; `None` when it has none.
    fn coded_rate(&self) -> Option<u32> {
        None
    }

    /// Refuse every read of `key` from now on with `answer` (a twin's
    /// `[refused]`, the `refuse=` option of a `sim://` port). `Err` when
    /// the drive has no such code or its protocol cannot answer so.
    fn refuse_read(&mut self, key: CodeKey, answer: ReadRefusal) -> Result<(), String> {
        let _ = (key, answer);
        Err(format!("a {} drive cannot refuse reads", self.family()))
    }

    /// The drive has no code `key` from now on: reads and writes of it are
    /// answered as the family answers a code it does not have (a twin's
    /// codes its drive did not show, `crate::twin`). `Err` for a code the
    /// drive never had.
    fn forget(&mut self, key: CodeKey) -> Result<(), String> {
        Err(format!("a {} drive cannot forget {key:?}", self.family()))
    }

    /// Describe the parameters with `descriptions` (the VALUE characters
    /// of each, by parameter) and answer substitution texts with `texts`
    /// (by parameter and 108-STEXT index), as a twin's drive sent them;
    /// every other description and text is refused. `Err` for a drive
    /// without descriptions (LECOM).
    fn describe_as(
        &mut self,
        descriptions: &BTreeMap<u32, Vec<u8>>,
        texts: &BTreeMap<(u32, u8), Vec<u8>>,
    ) -> Result<(), String> {
        let _ = (descriptions, texts);
        Err(format!(
            "a {} drive has no parameter descriptions",
            self.family()
        ))
    }
}

/// How a simulated drive refuses a read of one code, as a real drive did
/// (a twin's `[refused]`, docs/twins.md): the answer on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadRefusal {
    /// LUSTBUS: `ADR NAK` to the ENQUIRY, nothing entered in SIOF/SERR
    /// (LUSTBUS 6.1 note).
    Nak,
    /// LUSTBUS: `ADR NAK`, the bits latched in SIOF/SERR (LUSTBUS 9.2).
    NakSiof(u8),
    /// LECOM: `STX code EOT` to the RECEIVE, no such code (LECOM 8.H).
    NoSuchCode,
    /// CAN: an SDO abort with this code (DS301 table 22).
    SdoAbort(u32),
}

impl ReadRefusal {
    /// The text a twin file writes: `NAK`, `NAK SIOF 80H`, `EOT`, `SDO
    /// abort 0x06010001`.
    pub fn text(self) -> String {
        match self {
            ReadRefusal::Nak => "NAK".into(),
            ReadRefusal::NakSiof(b) => format!("NAK SIOF {b:02X}H"),
            ReadRefusal::NoSuchCode => "EOT".into(),
            ReadRefusal::SdoAbort(c) => format!("SDO abort 0x{c:08X}"),
        }
    }

    /// Read a [`ReadRefusal::text`] back.
    pub fn parse(s: &str) -> Option<ReadRefusal> {
        let s = s.trim();
        if s == "NAK" {
            return Some(ReadRefusal::Nak);
        }
        if s == "EOT" {
            return Some(ReadRefusal::NoSuchCode);
        }
        if let Some(bits) = s.strip_prefix("NAK SIOF ") {
            let hex = bits.strip_suffix('H')?;
            return u8::from_str_radix(hex, 16).ok().map(ReadRefusal::NakSiof);
        }
        let hex = s.strip_prefix("SDO abort 0x")?;
        u32::from_str_radix(hex, 16).ok().map(ReadRefusal::SdoAbort)
    }
}

/// What a CAN node sends in answer to a frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameReply {
    /// The answer frame.
    pub frame: CanFrame,
    /// From the end of the request frame to the start of the answer.
    pub reaction: Duration,
}

/// A simulated node on a CAN bus (Lenze system bus, SDO server).
pub trait FrameDrive: Send + std::fmt::Debug {
    /// The drive family (`"ecs"`), for logs.
    fn family(&self) -> &'static str;

    /// The node id (1..=127).
    fn node_id(&self) -> u8;

    /// One frame from the bus; `now` is the end of the frame.
    fn hear(&mut self, now: Instant, frame: &CanFrame) -> Option<FrameReply>;

    /// Power cut at `now`, back after `off` (see [`ByteDrive::power_cycle`]).
    fn power_cycle(&mut self, now: Instant, off: Duration);

    /// Every parameter value the drive holds now, raw, keyed by code.
    fn state(&self) -> ResolvedSet;

    /// Set a value directly, bypassing the protocol.
    fn poke(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String>;

    /// Whether the node reports a running motor (the schema's running
    /// indicator, `Schema::running_indicator`; false when it names none).
    fn running(&self) -> bool;

    /// Start or stop the motor (test hook): sets or clears the running bit
    /// the node reports. `Err` when the schema names no running bit (the
    /// node cannot report it).
    fn set_running(&mut self, running: bool) -> Result<(), String>;

    /// Refuse every read of `key` from now on with `answer`
    /// ([`ByteDrive::refuse_read`]).
    fn refuse_read(&mut self, key: CodeKey, answer: ReadRefusal) -> Result<(), String> {
        let _ = (key, answer);
        Err(format!("a {} node cannot refuse reads", self.family()))
    }

    /// What the node has stored, where it keeps writes only until a store
    /// command (`[schema.store] keeps = "on-command"`); `None` where every
    /// write is kept (a state dump then holds the values alone).
    fn stored_state(&self) -> Option<ResolvedSet> {
        None
    }

    /// Set what the node has stored (loading a state dump); a node that
    /// keeps every write ignores it.
    fn restore_stored(
        &mut self,
        values: std::collections::BTreeMap<CodeKey, RawValue>,
    ) -> Result<(), String> {
        let _ = values;
        Ok(())
    }

    /// The node has no code `key` from now on ([`ByteDrive::forget`]).
    fn forget(&mut self, key: CodeKey) -> Result<(), String> {
        Err(format!("a {} node cannot forget {key:?}", self.family()))
    }
}

/// A device reaction time range, drawn uniformly per telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReactionTime {
    /// Shortest reaction.
    pub min: Duration,
    /// Longest reaction.
    pub max: Duration,
}

impl ReactionTime {
    /// A range in milliseconds.
    pub const fn ms(min: u64, max: u64) -> Self {
        ReactionTime {
            min: Duration::from_millis(min),
            max: Duration::from_millis(max),
        }
    }

    /// The reaction range of `family` as its descriptor gives it (LUSTBUS
    /// section 10 for the Lust families; FICTIONAL assumptions for Tmd and
    /// ECS, whose documents give none), with or without a KEYPAD.
    pub fn of(family: driveset_schema::Family, keypad: driveset_schema::family::Keypad) -> Self {
        let r = family.descriptor().reaction;
        ReactionTime {
            min: r.min,
            max: r.longest(keypad),
        }
    }

    /// A fixed reaction (min = max), for exact-timing tests.
    pub const fn fixed(d: Duration) -> Self {
        ReactionTime { min: d, max: d }
    }

    /// Draw one reaction time.
    pub fn draw(&self, rng: &mut SimRng) -> Duration {
        rng.duration(self.min, self.max)
    }
}
