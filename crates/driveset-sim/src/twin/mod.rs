//! Twins: a file that answers as one real drive did. Owns the twin file
//! format (`NAME.twin.toml`, [`Twin`], [`Twin::parse`], [`Twin::to_toml`]),
//! loading one file or a directory of them ([`load_file`], [`load_dir`]),
//! the recapture rule that keeps an unchanged twin byte-identical
//! ([`Twin::same_drive`], [`keep_or_replace`]), and turning a twin into a
//! simulated drive ([`Twin::apply_byte`], [`Twin::apply_frame`]).
//!
//! A twin is served on the simulator's own family models (`crate::mc6000`,
//! `crate::vf1000`, `crate::tmd`, `crate::ecs`): the model of the twin's
//! family at the twin's address, built with the captured state that decides
//! its refusals (Tmd C0001, §4e; the running state; the MC6000/7000
//! description layout and type characters, errata L22 / L23) and reaction
//! time range, and then holding every captured value. So SLOAD (LUSTBUS
//! 11.4), the running and C0001 refusals, EEPROM pacing and state across a
//! session behave as the simulator's drives do. The format is described in
//! docs/twins.md.
//!
//! A twin never holds a secret's value: password codes are listed by code
//! in `secrets` only; the served model accepts any password write and reads
//! the code as the model hides it.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::canonical::{CodeKey, RawValue};
use driveset_schema::family::Keypad;
use driveset_schema::{Family, Schema};

use crate::drive::{ByteDrive, FrameDrive, ReactionTime, ReadRefusal};

mod reader;

use reader::Reader;

/// The `format` value of a twin file.
pub const TWIN_FORMAT: &str = "driveset-twin 2";

/// The `format` value of a first-version twin file (no descriptions, no
/// `[codes] unread`): still read, docs/twins.md.
pub const TWIN_FORMAT_1: &str = "driveset-twin 1";

/// The file name ending of a twin: `NAME.twin.toml`.
pub const TWIN_SUFFIX: &str = ".twin.toml";

/// Why a twin file cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TwinError {
    /// The file or directory could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a regular file, larger than the twin cap, or not
    /// UTF-8 (the one input reader's refusal, `driveset_schema::input`).
    #[error("{message}; {help}")]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the file.
        message: String,
        /// What to do.
        help: String,
    },
    /// The text is not TOML.
    #[error("{}: {detail}", path.display())]
    Toml {
        /// The file.
        path: PathBuf,
        /// The parser's message (with line and column).
        detail: String,
    },
    /// A key is missing or has a bad value.
    #[error("{}: {key}: {reason}", path.display())]
    Field {
        /// The file.
        path: PathBuf,
        /// The key (`[section] key`).
        key: String,
        /// What is wrong and what it should be.
        reason: String,
    },
    /// A directory holds no twin.
    #[error("{}: no *{TWIN_SUFFIX} file in the directory; capture one with `driveset twin capture`", path.display())]
    Empty {
        /// The directory.
        path: PathBuf,
    },
    /// Two twins of one bus at one address.
    #[error("{} and {}: both twins are at address {address}; one bus holds one drive per address", first.display(), second.display())]
    SameAddress {
        /// The first file.
        first: PathBuf,
        /// The second file.
        second: PathBuf,
        /// The address.
        address: u8,
    },
    /// Twins of families that cannot share one bus.
    #[error("{}: a {family} twin cannot share a bus with {other} twins (LUSTBUS holds mc6000 and vf1000, LECOM tmd, CAN ecs); serve it from a directory of its own", path.display())]
    MixedBus {
        /// The file.
        path: PathBuf,
        /// Its family.
        family: &'static str,
        /// The family of the first twin.
        other: &'static str,
    },
    /// A captured value the family's model cannot hold.
    #[error("{}: {reason}", path.display())]
    Apply {
        /// The file.
        path: PathBuf,
        /// What the model said.
        reason: String,
    },
}

/// One twin (module docs; the file format in docs/twins.md).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Twin {
    /// Where the twin was read from (empty for a twin built in memory).
    pub path: PathBuf,
    /// The driveset version that wrote it.
    pub driveset: String,
    /// The capture date, `YYYY-MM-DD` (UTC).
    pub captured: String,
    /// What it was captured from: `drive PORT`, or `capture FILE`.
    pub source: String,
    /// The drive's family.
    pub family: Family,
    /// Its bus address (node id on CAN).
    pub address: u8,
    /// The schema the capture read with.
    pub schema: String,
    /// The identify codes as the drive answered them (label, value).
    pub identity: Vec<(String, String)>,
    /// Whether the motor ran (`None`: not known).
    pub running: Option<bool>,
    /// Tmd: C0001 (§4e).
    pub c0001: Option<u8>,
    /// MC6000/7000: 80-SLOAD as read.
    pub sload: Option<i64>,
    /// MC6000/7000: the layout its parameter descriptions came in (L22).
    pub layout: Option<McLayout>,
    /// MC6000/7000: the type characters of its descriptions (L23).
    pub types: Option<McTypeChars>,
    /// The line rate (baud) or CAN bit rate it answered at.
    pub rate: Option<u32>,
    /// The shortest and longest reaction time it showed.
    pub reaction: Option<(Duration, Duration)>,
    /// Every code it answered, raw.
    pub values: BTreeMap<CodeKey, RawValue>,
    /// Codes it refused to read, with its reason.
    pub refused: BTreeMap<CodeKey, String>,
    /// How it refused them on the wire, where known (a code of `refused`
    /// without one, "no answer" say, is answered by the model).
    pub refusals: BTreeMap<CodeKey, ReadRefusal>,
    /// Password codes: never read, no value stored.
    pub secrets: Vec<CodeKey>,
    /// Codes not read on purpose: reading clears them (85-SIOF/SERR). The
    /// served model latches them itself.
    pub unread: Vec<CodeKey>,
    /// Codes of the schema the source did not show (not answered in a
    /// recorded session, no type in the capture's schema). The served twin
    /// does not have them.
    pub unknown: Vec<CodeKey>,
    /// LUSTBUS: every parameter description the drive sent, as it sent it
    /// (the VALUE characters, by parameter; `None`: none recorded, as from
    /// a recorded session). The served twin describes these and no other.
    pub descriptions: Option<BTreeMap<u32, Vec<u8>>>,
    /// MC6000/7000: every substitution text the drive sent, as it sent it,
    /// by parameter (107-UNIT for the units) and 108-STEXT index.
    pub texts: BTreeMap<(u32, u8), Vec<u8>>,
}

impl Twin {
    /// An empty twin of `family` at `address` (no values yet).
    pub fn new(family: Family, address: u8, schema: &str) -> Self {
        Twin {
            path: PathBuf::new(),
            driveset: String::new(),
            captured: String::new(),
            source: String::new(),
            family,
            address,
            schema: schema.to_string(),
            identity: Vec::new(),
            running: None,
            c0001: None,
            sload: None,
            layout: None,
            types: None,
            rate: None,
            reaction: None,
            values: BTreeMap::new(),
            refused: BTreeMap::new(),
            refusals: BTreeMap::new(),
            secrets: Vec::new(),
            unread: Vec::new(),
            unknown: Vec::new(),
            descriptions: None,
            texts: BTreeMap::new(),
        }
    }

    /// Whether the capture saw `key`: a value, a refusal, a password
    /// (never read), or a code not read on purpose. The served twin has
    /// these codes and no other.
    pub fn saw(&self, key: CodeKey) -> bool {
        self.values.contains_key(&key)
            || self.refused.contains_key(&key)
            || self.secrets.contains(&key)
            || self.unread.contains(&key)
    }

    /// Whether `other` describes the same drive as this twin: everything
    /// but the capture date, the driveset version and the measured
    /// reaction times (which jitter on a real bus) equal, and `other`'s
    /// reaction times within this twin's range ([`keep_or_replace`]).
    pub fn same_drive(&self, other: &Twin) -> bool {
        let strip = |t: &Twin| Twin {
            path: PathBuf::new(),
            driveset: String::new(),
            captured: String::new(),
            // where it was captured from: the same drive through another
            // spelling of its port (`?latency=`) is the same drive
            source: String::new(),
            reaction: None,
            ..t.clone()
        };
        // Reaction times measured over a real port hold the host's
        // scheduling too, so two captures of one drive never show the same
        // range. What the served twin draws from is the range clamped to the
        // family's documented one ([`Twin::reaction_time`]): two captures
        // whose clamped ranges overlap describe the same drive, compared at
        // the file's resolution (whole microseconds, `reaction_*_us`).
        let us = |d: Duration| d.as_micros();
        let within = match (self.reaction_time(), other.reaction_time()) {
            (Some(a), Some(b)) => us(a.min) <= us(b.max) && us(b.min) <= us(a.max),
            (None, None) => true,
            _ => false,
        };
        within && strip(self) == strip(other)
    }

    /// The reaction range the served drive draws from: the recorded one
    /// within the family's range (with a KEYPAD, the longest it has;
    /// LUSTBUS section 10, the descriptor's figures). Times measured over
    /// a real port hold the host's latency too (a read the operating
    /// system delayed shows as a slow reaction); beyond the family's range
    /// they are the host's, not the drive's, and a twin drawing them would
    /// miss answer deadlines the drive meets.
    pub fn reaction_time(&self) -> Option<ReactionTime> {
        let family = ReactionTime::of(self.family, Keypad::Fitted);
        self.reaction.map(|(min, max)| {
            let min = min.clamp(family.min, family.max);
            ReactionTime {
                min,
                max: max.clamp(min, family.max),
            }
        })
    }

    /// Parse a twin file's text; errors name `path` and the key.
    pub fn parse(text: &str, path: &Path) -> Result<Twin, TwinError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| TwinError::Toml {
            path: path.to_path_buf(),
            detail: e.to_string().trim_end().replace('\n', " "),
        })?;
        Reader {
            path,
            table: &table,
        }
        .twin()
    }

    /// The file text (docs/twins.md): stable (fixed key order, codes in
    /// code order), with a comment beside each value naming the code and
    /// its value in engineering units when `schema` is given.
    pub fn to_toml(&self, schema: Option<&Schema>) -> String {
        let mut s = String::new();
        let q = |v: &str| toml_str(v);
        let _ = writeln!(
            s,
            "# A twin of one drive: it answers as the drive did when captured\n# (docs/twins.md). Serve it with sim://twin?file=THIS_FILE."
        );
        let _ = writeln!(s, "format = {}", q(TWIN_FORMAT));
        let _ = writeln!(s, "driveset = {}", q(&self.driveset));
        let _ = writeln!(s, "captured = {}", q(&self.captured));
        let _ = writeln!(s, "source = {}", q(&self.source));
        let _ = writeln!(s, "family = {}", q(self.family.name()));
        let _ = writeln!(s, "address = {}", self.address);
        let _ = writeln!(s, "schema = {}", q(&self.schema));
        s.push_str("\n[identity]\n");
        for (k, v) in &self.identity {
            let _ = writeln!(s, "{} = {}", q(k), q(v));
        }
        s.push_str("\n[state]\n");
        if let Some(r) = self.running {
            let _ = writeln!(s, "running = {r}");
        }
        if let Some(c) = self.c0001 {
            let _ = writeln!(s, "c0001 = {c}");
        }
        if let Some(v) = self.sload {
            let _ = writeln!(s, "sload = {v}");
        }
        if let Some(l) = self.layout {
            let _ = writeln!(s, "layout = {}", q(l.name()));
        }
        if let Some(t) = &self.types {
            let _ = writeln!(s, "types = {}", q(&t.name()));
        }
        s.push_str("\n[timing]\n");
        if let Some(r) = self.rate {
            let _ = writeln!(s, "rate = {r}");
        }
        if let Some((lo, hi)) = self.reaction {
            let _ = writeln!(s, "reaction_min_us = {}", lo.as_micros());
            let _ = writeln!(s, "reaction_max_us = {}", hi.as_micros());
        }
        s.push_str("\n[values]\n");
        for (k, v) in &self.values {
            let value = match v {
                RawValue::Int(i) => i.to_string(),
                RawValue::Text(t) => q(t),
                RawValue::Octets(o) => format!("{{ hex = {} }}", q(&hex(o))),
            };
            let _ = write!(s, "{} = {value}", q(&key_text(*k)));
            if let Some(schema) = schema {
                let _ = write!(s, "  # {}", comment(schema, *k, v));
            }
            s.push('\n');
        }
        s.push_str("\n[refused]\n");
        for (k, why) in &self.refused {
            match self.refusals.get(k) {
                Some(a) => {
                    let _ = writeln!(
                        s,
                        "{} = {{ answer = {}, reason = {} }}",
                        q(&key_text(*k)),
                        q(&a.text()),
                        q(why)
                    );
                }
                None => {
                    let _ = writeln!(s, "{} = {}", q(&key_text(*k)), q(why));
                }
            }
        }
        let list = |keys: &[CodeKey]| {
            keys.iter()
                .map(|k| q(&key_text(*k)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        s.push_str("\n[codes]\n");
        let _ = writeln!(s, "secrets = [{}]", list(&self.secrets));
        let _ = writeln!(s, "unread = [{}]", list(&self.unread));
        let _ = writeln!(s, "unknown = [{}]", list(&self.unknown));
        if let Some(descriptions) = &self.descriptions {
            s.push_str("\n[descriptions]\n");
            for (n, v) in descriptions {
                let _ = writeln!(s, "\"{n}\" = {}", q(&wire_text(v)));
            }
        }
        if !self.texts.is_empty() {
            s.push_str("\n[texts]\n");
            for ((n, i), v) in &self.texts {
                let _ = writeln!(s, "\"{n}.{i}\" = {}", q(&wire_text(v)));
            }
        }
        s
    }

    /// Put the twin's state on a freshly built model of its family: every
    /// captured value, then the running state. Derived codes the model
    /// refuses to be poked (Tmd C0068 / C0150 / C1962) follow from the
    /// state; a captured code the model does not have is an error. The
    /// codes the capture did not see ([`Twin::saw`]) are taken out of the
    /// model, so no value of the model's fills a gap; a LUSTBUS twin
    /// describes its parameters as its drive did (`descriptions`, `texts`),
    /// and nothing else.
    pub fn apply_byte(&self, drive: &mut dyn ByteDrive) -> Result<(), TwinError> {
        // first the descriptions: a parameter the model's table lacks is
        // taken as its drive described it
        if self.family.bus() == driveset_schema::BusProtocol::Lustbus {
            let none = BTreeMap::new();
            drive
                .describe_as(self.descriptions.as_ref().unwrap_or(&none), &self.texts)
                .map_err(|reason| self.apply_error(reason))?;
        }
        let held = drive.state();
        for (k, v) in &self.values {
            if let Err(reason) = drive.poke(*k, v.clone())
                && !held.values.contains_key(k)
            {
                return Err(self.apply_error(reason));
            }
        }
        if let Some(r) = self.running {
            drive.set_running(r);
        }
        for (k, a) in &self.refusals {
            if let Err(reason) = drive.refuse_read(*k, *a)
                && held.values.contains_key(k)
            {
                return Err(self.apply_error(reason));
            }
        }
        for k in held.values.keys().filter(|k| !self.saw(**k)) {
            drive
                .forget(*k)
                .map_err(|reason| self.apply_error(reason))?;
        }
        Ok(())
    }

    /// [`Twin::apply_byte`] for a CAN node.
    pub fn apply_frame(&self, drive: &mut dyn FrameDrive) -> Result<(), TwinError> {
        let held = drive.state();
        for (k, v) in &self.values {
            if let Err(reason) = drive.poke(*k, v.clone())
                && !held.values.contains_key(k)
            {
                return Err(self.apply_error(reason));
            }
        }
        if let Some(r) = self.running
            && drive.running() != r
        {
            drive
                .set_running(r)
                .map_err(|reason| self.apply_error(reason))?;
        }
        for (k, a) in &self.refusals {
            if let Err(reason) = drive.refuse_read(*k, *a)
                && held.values.contains_key(k)
            {
                return Err(self.apply_error(reason));
            }
        }
        for k in held.values.keys().filter(|k| !self.saw(**k)) {
            drive
                .forget(*k)
                .map_err(|reason| self.apply_error(reason))?;
        }
        Ok(())
    }

    fn apply_error(&self, reason: String) -> TwinError {
        TwinError::Apply {
            path: self.path.clone(),
            reason: format!(
                "{reason}; the twin does not fit the simulator's {} model",
                self.family.name()
            ),
        }
    }
}

/// What a recapture writes: the previous file's text unchanged when it
/// describes the same drive ([`Twin::same_drive`]: only the date, the
/// version, the port's spelling or reaction times whose ranges overlap
/// within the family's documented one differ), so a
/// second capture of an unchanged drive is byte-identical; else the new
/// twin's text.
pub fn keep_or_replace(previous: Option<&str>, new: &Twin, schema: Option<&Schema>) -> String {
    if let Some(old_text) = previous
        && let Ok(old) = Twin::parse(old_text, Path::new(""))
        && old.same_drive(new)
    {
        return old_text.to_string();
    }
    new.to_toml(schema)
}

/// The code key as a twin file writes it: `11`, `11.2` with a subcode.
pub fn key_text(k: CodeKey) -> String {
    match k.subcode {
        Some(s) => format!("{}.{s}", k.number),
        None => k.number.to_string(),
    }
}

/// Read a [`key_text`] back.
pub fn parse_key(s: &str) -> Option<CodeKey> {
    match s.split_once('.') {
        Some((n, sub)) => Some(CodeKey::sub(n.parse().ok()?, sub.parse().ok()?)),
        None => Some(CodeKey::new(s.parse().ok()?)),
    }
}

/// The wire answer a first-version `[refused]` reason names in its raw
/// part (the capture wrote `cause (raw)`, `DeviceCause::raw`): `STX code
/// EOT`, `NAK to ENQUIRY`, `SIOF 80H` / `SERR 80H`, `SDO abort 0x...`.
/// `None` for a refusal that was no answer of the drive's (no answer, an
/// answer that does not fit the type).
fn answer_in_reason(reason: &str) -> Option<ReadRefusal> {
    let raw = reason.rsplit_once('(')?.1.strip_suffix(')')?;
    if raw.starts_with("STX ") && raw.ends_with(" EOT") {
        return Some(ReadRefusal::NoSuchCode);
    }
    if raw.starts_with("NAK to ENQUIRY") {
        return Some(ReadRefusal::Nak);
    }
    if let Some(rest) = raw.strip_prefix("SDO abort 0x") {
        let hex = rest.split(' ').next()?;
        return u32::from_str_radix(hex, 16).ok().map(ReadRefusal::SdoAbort);
    }
    let bits = raw
        .strip_prefix("SIOF ")
        .or_else(|| raw.strip_prefix("SERR "))?;
    let hex = bits.split('H').next()?;
    u8::from_str_radix(hex, 16).ok().map(ReadRefusal::NakSiof)
}

fn comment(schema: &Schema, k: CodeKey, v: &RawValue) -> String {
    let code = schema.display_code(k.number, k.subcode);
    match schema.code(k.number) {
        Some(c) => {
            let shown = driveset_schema::validate::display_value(schema, c, v);
            if c.name.is_empty() || code.contains(&c.name) {
                format!("{code} = {shown}")
            } else {
                format!("{code} {} = {shown}", c.name)
            }
        }
        None => code,
    }
}

/// Characters a drive sent (7-bit, a NUL included) as a string a twin
/// file holds.
fn wire_text(v: &[u8]) -> String {
    v.iter().map(|b| char::from(*b)).collect()
}

/// A [`wire_text`] back; `None` when a character is not 7-bit.
fn wire_bytes(s: &str) -> Option<Vec<u8>> {
    s.chars()
        .map(|c| u8::try_from(u32::from(c)).ok().filter(|b| *b < 0x80))
        .collect()
}

fn toml_str(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

fn hex(o: &[u8]) -> String {
    o.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(s: &str) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(2) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok())
        .collect()
}

/// Read one twin file.
pub fn load_file(path: &Path) -> Result<Twin, TwinError> {
    // the one input reader: regular files only, the twin cap checked first
    let input = |message: String, help: String| TwinError::Input {
        path: path.to_path_buf(),
        message,
        help,
    };
    let bytes = driveset_schema::input::read_input(path, driveset_schema::input::InputKind::TWIN)
        .map_err(|e| input(e.message, e.help))?;
    let text = String::from_utf8(bytes).map_err(|_| {
        input(
            format!("{} is not UTF-8 text", path.display()),
            "a twin file is TOML text; capture it again with `driveset twin capture`".into(),
        )
    })?;
    Twin::parse(&text, path)
}

/// Every `*.twin.toml` of `dir`, in file-name order, checked to share one
/// bus (one address each; LUSTBUS families together, or one Lenze family).
pub fn load_dir(dir: &Path) -> Result<Vec<Twin>, TwinError> {
    let io = |source| TwinError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.ends_with(TWIN_SUFFIX))
        })
        .collect();
    files.sort();
    let twins = files
        .iter()
        .map(|f| load_file(f))
        .collect::<Result<Vec<_>, _>>()?;
    check_one_bus(&twins)?;
    if twins.is_empty() {
        return Err(TwinError::Empty {
            path: dir.to_path_buf(),
        });
    }
    Ok(twins)
}

/// Check that `twins` can share one simulated bus.
pub fn check_one_bus(twins: &[Twin]) -> Result<(), TwinError> {
    let Some(first) = twins.first() else {
        return Ok(());
    };
    for (i, t) in twins.iter().enumerate() {
        if t.family.bus() != first.family.bus() {
            return Err(TwinError::MixedBus {
                path: t.path.clone(),
                family: t.family.name(),
                other: first.family.name(),
            });
        }
        if let Some(o) = twins[..i].iter().find(|o| o.address == t.address) {
            return Err(TwinError::SameAddress {
                first: o.path.clone(),
                second: t.path.clone(),
                address: t.address,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Twin {
        let mut t = Twin::new(Family::Tmd, 4, "lenze-tmd");
        t.driveset = "0.1.0".into();
        t.captured = "2026-12-02".into();
        t.source = "drive sim://tmd?addresses=4".into();
        t.identity.push(("C0093".into(), "8201".into()));
        t.running = Some(false);
        t.c0001 = Some(3);
        t.rate = Some(9600);
        t.reaction = Some((Duration::from_micros(1500), Duration::from_micros(4200)));
        t.values.insert(CodeKey::new(11), RawValue::Int(500));
        t.values
            .insert(CodeKey::sub(17, 2), RawValue::Text("a \"b\"".into()));
        t.values
            .insert(CodeKey::new(9), RawValue::Octets(vec![0xa1, 0x02]));
        t.refused.insert(CodeKey::new(99), "no such code".into());
        t.secrets.push(CodeKey::new(94));
        t
    }

    #[test]
    fn a_twin_round_trips_through_its_text() {
        let t = sample();
        let text = t.to_toml(None);
        assert!(
            text.contains(
                "\n[values]\n\"9\" = { hex = \"a102\" }\n\"11\" = 500\n\"17.2\" = \"a \\\"b\\\"\"\n"
            ),
            "{text}"
        );
        assert!(text.contains("secrets = [\"94\"]"), "{text}");
        let back = Twin::parse(&text, Path::new("t.twin.toml")).unwrap();
        assert_eq!(
            back,
            Twin {
                path: "t.twin.toml".into(),
                ..t
            }
        );
        assert_eq!(back.to_toml(None), text);
    }

    #[test]
    fn a_recapture_of_the_same_drive_keeps_the_file() {
        let t = sample();
        let old = t.to_toml(None);
        let mut again = t.clone();
        again.captured = "2027-01-15".into();
        again.reaction = Some((Duration::from_micros(1600), Duration::from_micros(4000)));
        assert_eq!(keep_or_replace(Some(&old), &again, None), old);
        // a range measured on a busier host overlaps the recorded one: the
        // same drive (a real port's times hold the host's scheduling)
        again.reaction = Some((Duration::from_micros(1500), Duration::from_micros(4201)));
        assert_eq!(keep_or_replace(Some(&old), &again, None), old);
        again.reaction = Some((Duration::from_micros(1600), Duration::from_micros(9000)));
        assert_eq!(keep_or_replace(Some(&old), &again, None), old);
        // beyond the family's range (Tmd 1..20 ms) a time is the host's: a
        // 30 ms one is the 20 ms the twin serves, still no change
        again.reaction = Some((Duration::from_micros(4000), Duration::from_millis(30)));
        assert_eq!(keep_or_replace(Some(&old), &again, None), old);
        // the file holds whole microseconds: 4200.4 us is the recorded
        // 4200 us, 4201 us lies beyond it
        again.reaction = Some((Duration::from_nanos(4_200_400), Duration::from_millis(9)));
        assert_eq!(keep_or_replace(Some(&old), &again, None), old);
        // a range that no longer meets the recorded one is another drive's
        again.reaction = Some((Duration::from_micros(4201), Duration::from_millis(9)));
        assert_ne!(keep_or_replace(Some(&old), &again, None), old);
        let mut changed = t.clone();
        changed.captured = "2027-01-15".into();
        changed.values.insert(CodeKey::new(11), RawValue::Int(501));
        let text = keep_or_replace(Some(&old), &changed, None);
        assert!(text.contains("captured = \"2027-01-15\"") && text.contains("\"11\" = 501"));
    }

    #[test]
    fn refusals_round_trip_and_first_version_reasons_name_their_answer() {
        let mut t = sample();
        t.refusals.insert(CodeKey::new(99), ReadRefusal::NoSuchCode);
        t.refused
            .insert(CodeKey::new(98), "no answer (3 tries)".into());
        let text = t.to_toml(None);
        assert!(
            text.contains("\n[refused]\n\"98\" = \"no answer (3 tries)\"\n\"99\" = { answer = \"EOT\", reason = \"no such code\" }\n"),
            "{text}"
        );
        let back = Twin::parse(&text, Path::new("t.twin.toml")).unwrap();
        assert_eq!(back.refusals, t.refusals);
        for r in [
            ReadRefusal::Nak,
            ReadRefusal::NakSiof(0x80),
            ReadRefusal::NoSuchCode,
            ReadRefusal::SdoAbort(0x0601_0001),
        ] {
            assert_eq!(ReadRefusal::parse(&r.text()), Some(r));
        }
        for (reason, answer) in [
            (
                "no such code in this controller (STX C0012 EOT)",
                Some(ReadRefusal::NoSuchCode),
            ),
            (
                "no such parameter (NAK to ENQUIRY 00105)",
                Some(ReadRefusal::Nak),
            ),
            (
                "invalid value (80) (SERR 80H invalid value)",
                Some(ReadRefusal::NakSiof(0x80)),
            ),
            (
                "Attempt to read a write only object (SDO abort 0x06010001 at index 0x4C76 subindex 0)",
                Some(ReadRefusal::SdoAbort(0x0601_0001)),
            ),
            ("no answer (3 tries)", None),
        ] {
            assert_eq!(answer_in_reason(reason), answer, "{reason}");
        }
        let e = Twin::parse(
            &text.replace("answer = \"EOT\"", "answer = \"ACK\""),
            Path::new("x.twin.toml"),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.twin.toml: [refused] \"99\": answer `ACK`: use NAK, NAK SIOF 80H, EOT or SDO abort 0x06010001"
        );
    }

    #[test]
    fn descriptions_texts_and_unread_codes_round_trip() {
        let mut t = Twin::new(Family::Mc6000, 1, "learned-mc6000-type6000-1");
        t.driveset = "0.1.0".into();
        t.captured = "2026-12-03".into();
        t.unread.push(CodeKey::new(85));
        t.unknown.push(CodeKey::new(96));
        // the 43-character layout ends with a NUL
        let d43 = b"MODE\x00\x000024000000000000000A000000000000000000\x00".to_vec();
        t.descriptions = Some(BTreeMap::from([(1, d43.clone())]));
        t.texts.insert((100, 2), b"8 kHz".to_vec());
        let text = t.to_toml(None);
        assert!(
            text.contains(
                "\n[codes]\nsecrets = []\nunread = [\"85\"]\nunknown = [\"96\"]\n\n[descriptions]\n\"1\" = \"MODE\\u0000\\u00000024000000000000000A000000000000000000\\u0000\"\n\n[texts]\n\"100.2\" = \"8 kHz\"\n"
            ),
            "{text}"
        );
        let back = Twin::parse(&text, Path::new("t.twin.toml")).unwrap();
        assert_eq!(back.descriptions, Some(BTreeMap::from([(1, d43)])));
        assert_eq!(back.texts, t.texts);
        assert_eq!(back.unread, [CodeKey::new(85)]);
        assert_eq!(back.unknown, [CodeKey::new(96)]);
        assert!(back.saw(CodeKey::new(85)) && !back.saw(CodeKey::new(96)));
        let e = Twin::parse(
            &text.replace("\"100.2\" = ", "\"100\" = "),
            Path::new("x.twin.toml"),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.twin.toml: [texts] \"100\": not PARAMETER.INDEX (the 108-STEXT index 0..=255)"
        );
        let e = Twin::parse(
            &text.replace("8 kHz", "8 \u{b5}s"),
            Path::new("x.twin.toml"),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.twin.toml: [texts] \"100.2\": holds a character a drive cannot send (not 7-bit)"
        );
    }

    /// A first-version file of a LUSTBUS drive holds no descriptions: it is
    /// refused with what to do; one of a Tmd is read, its `unknown` codes
    /// (what the first version did not read on purpose) as `unread`.
    #[test]
    fn first_version_files_are_read_or_refused_with_what_to_do() {
        let v1 = |family: &str, address: u8| {
            format!(
                "format = \"driveset-twin 1\"\ndriveset = \"0.1.0\"\ncaptured = \"2026-12-02\"\nfamily = \"{family}\"\naddress = {address}\nschema = \"x\"\n[codes]\nsecrets = []\nunknown = [\"85\"]\n"
            )
        };
        let e = Twin::parse(&v1("mc6000", 1), Path::new("old.twin.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "old.twin.toml: format: a `driveset-twin 1` twin of a mc6000 holds neither the drive's parameter descriptions nor its substitution texts, so it cannot answer as the drive did; capture the drive again with `driveset twin capture` (docs/twins.md)"
        );
        let t = Twin::parse(&v1("tmd", 4), Path::new("old.twin.toml")).unwrap();
        assert_eq!(t.unread, [CodeKey::new(85)]);
        assert!(t.unknown.is_empty());
    }

    #[test]
    fn bad_fields_are_named() {
        let t = sample().to_toml(None);
        let p = Path::new("x.twin.toml");
        let e = Twin::parse(&t.replace("c0001 = 3", "c0001 = 12"), p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.twin.toml: [state] c0001: C0001 takes 0..=11 (Table 1; §4e)"
        );
        let e = Twin::parse(&t.replace("\"11\" = 500", "\"C11\" = 500"), p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.twin.toml: [values] \"C11\": not a code: write the code number, or NUMBER.SUBCODE"
        );
        let e = Twin::parse(&t.replace("address = 4", "address = 10"), p).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("x.twin.toml: address: tmd: address 10 is not allowed"),
            "{e}"
        );
        let e = Twin::parse("format = [", p).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("x.twin.toml: TOML parse error at line 1, column"),
            "{e}"
        );
    }
}
