//! Owns the state dump format ([`StateDump`], [`DriveDump`]), which of a
//! port's drives a line holds ([`LineDrives`]) and loading a dump into the
//! drives (by slot, then family and address; module docs of
//! [`crate::open`]).

use std::collections::BTreeMap;
use std::io;
use std::path::Path;

use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use serde::{Deserialize, Serialize};

use super::{STATE_FORMAT, SimOpenError, parse_family};
use crate::bus::ByteLine;
use crate::can_bus::FrameLine;
use crate::catalog::Family;
use crate::drive::{ByteDrive, FrameDrive};
use crate::factory::DriveSlot;

/// Which of a port's drives a line holds, by slot ([`DriveSlot`]), and the
/// state of those it does not (the service bench, [`crate::factory`]):
/// what a state dump of the line is made of.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LineDrives {
    /// The slot of each drive on the line, in line order.
    pub slots: Vec<DriveSlot>,
    /// The drives off the line, with their state (`slot` set).
    pub detached: Vec<DriveDump>,
    /// Every slot of the port, in port order (the order of a dump).
    pub order: Vec<DriveSlot>,
}

impl LineDrives {
    fn dump<D: StateDrive>(&self, bus: &str, drives: &[D]) -> StateDump {
        let mut entries: Vec<DriveDump> = drives
            .iter()
            .enumerate()
            .map(|(j, d)| entry_of(d, self.slots.get(j)))
            .chain(self.detached.iter().cloned())
            .collect();
        let place = |e: &DriveDump| {
            e.slot
                .as_deref()
                .and_then(|s| self.order.iter().position(|o| o.to_string() == s))
                .unwrap_or(usize::MAX)
        };
        entries.sort_by_key(place);
        StateDump {
            format: STATE_FORMAT.into(),
            family: bus.into(),
            baud: None,
            bitrate: None,
            telegrams: None,
            drives: entries,
        }
    }

    /// The dump of `line` (named `bus`: a family or `lustbus`) and the
    /// drives off it, with rate and telegram count: what `driveset sim`
    /// writes to `--state` / `--dump`.
    pub fn byte_line_dump(&self, bus: &str, line: &ByteLine) -> StateDump {
        StateDump {
            baud: Some(line.baud()),
            telegrams: Some(line.telegrams()),
            ..self.dump(bus, line.drives())
        }
    }

    /// The dump of a CAN bus's nodes, as [`LineDrives::byte_line_dump`].
    pub fn frame_line_dump(&self, bus: &str, line: &FrameLine) -> StateDump {
        StateDump {
            bitrate: Some(line.bitrate()),
            telegrams: Some(line.telegrams()),
            ..self.dump(bus, line.drives())
        }
    }
}

/// The dump entry of `d`, in `slot`.
pub(super) fn entry_of<D: StateDrive>(d: &D, slot: Option<&DriveSlot>) -> DriveDump {
    DriveDump {
        rate: d.dump_rate(),
        slot: slot.map(DriveSlot::to_string),
        assigned: d.dump_assigned(),
        stored: d.dump_stored().map(|s| s.canonical_with_secrets()),
        ..DriveDump::new(d.dump_family(), d.dump_address(), &d.dump_state())
    }
}

/// A state dump: every drive of one simulated bus (module docs).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateDump {
    /// [`STATE_FORMAT`].
    pub format: String,
    /// The bus's family ([`Family::name`]), or `lustbus` for a mixed
    /// LUSTBUS.
    pub family: String,
    /// The line rate (character lines), informative.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baud: Option<u32>,
    /// The bit rate (CAN), informative.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bitrate: Option<u32>,
    /// Host telegrams the bus saw in this run, informative.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub telegrams: Option<u64>,
    /// The drives, in bus order.
    pub drives: Vec<DriveDump>,
}

/// One drive in a [`StateDump`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveDump {
    /// The drive's family.
    pub family: String,
    /// Its bus address (node id on CAN).
    pub address: u8,
    /// The schema its table comes from.
    pub schema: String,
    /// The fingerprint of `canonical`.
    pub fingerprint: String,
    /// Its whole state, canonical form.
    pub canonical: String,
    /// The rate the drive runs at, when its 81-SBAUD does not say it (an
    /// MC6000 left at a transfer rate, LUSTBUS 11.5): it stays there in
    /// the next command, as a powered drive does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate: Option<u32>,
    /// Its place in the port ([`DriveSlot`]: `mc6000@5`, `mc6000#2`): what
    /// loading matches it by, so that it is found again after its own
    /// address changed. Absent in dumps of older versions (matched by
    /// family and address).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slot: Option<String>,
    /// Its address code was written over the bus
    /// ([`ByteDrive::address_assigned`]; the bench moves on).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub assigned: bool,
    /// What the drive has stored, canonical form, where it keeps writes
    /// only until a store command (`[schema.store] keeps = "on-command"`):
    /// `canonical` is its RAM, this what a power cycle brings back. Absent
    /// where every write is kept (and in older dumps: loaded as stored).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stored: Option<String>,
}

impl DriveDump {
    /// The entry for a drive holding `state`.
    pub fn new(family: &str, address: u8, state: &ResolvedSet) -> Self {
        DriveDump {
            family: family.to_string(),
            address,
            schema: state.schema.clone(),
            fingerprint: state.fingerprint(),
            // the drive's memory, secrets included (a state file is as private as the drive)
            canonical: state.canonical_with_secrets(),
            rate: None,
            slot: None,
            assigned: false,
            stored: None,
        }
    }
}

/// A drive whose state can be dumped and restored (both bus kinds).
pub(super) trait StateDrive {
    fn dump_family(&self) -> &'static str;
    fn dump_address(&self) -> u8;
    fn dump_state(&self) -> ResolvedSet;
    fn restore(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String>;
    fn dump_rate(&self) -> Option<u32> {
        None
    }
    fn restore_rate(&mut self, baud: u32) {
        let _ = baud;
    }
    fn dump_assigned(&self) -> bool {
        false
    }
    fn restore_assigned(&mut self) {}
    fn dump_stored(&self) -> Option<ResolvedSet> {
        None
    }
    fn restore_stored(&mut self, values: BTreeMap<CodeKey, RawValue>) -> Result<(), String> {
        let _ = values;
        Ok(())
    }
}

impl StateDrive for Box<dyn ByteDrive> {
    fn dump_family(&self) -> &'static str {
        self.family()
    }
    fn dump_address(&self) -> u8 {
        self.address()
    }
    fn dump_state(&self) -> ResolvedSet {
        self.state()
    }
    fn restore(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        self.poke(key, raw)
    }
    fn dump_rate(&self) -> Option<u32> {
        self.active_rate()
    }
    fn restore_rate(&mut self, baud: u32) {
        ByteDrive::restore_rate(self.as_mut(), baud);
    }
    fn dump_assigned(&self) -> bool {
        self.address_assigned()
    }
    fn restore_assigned(&mut self) {
        self.restore_address_assigned();
    }
}

impl StateDrive for Box<dyn FrameDrive> {
    fn dump_family(&self) -> &'static str {
        self.family()
    }
    fn dump_address(&self) -> u8 {
        self.node_id()
    }
    fn dump_state(&self) -> ResolvedSet {
        self.state()
    }
    fn restore(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        self.poke(key, raw)
    }
    fn dump_stored(&self) -> Option<ResolvedSet> {
        self.stored_state()
    }
    fn restore_stored(&mut self, values: BTreeMap<CodeKey, RawValue>) -> Result<(), String> {
        FrameDrive::restore_stored(self.as_mut(), values)
    }
}

fn dump_of<D: StateDrive>(bus: &str, drives: &[D]) -> StateDump {
    StateDump {
        format: STATE_FORMAT.into(),
        family: bus.into(),
        baud: None,
        bitrate: None,
        telegrams: None,
        drives: drives.iter().map(|d| entry_of(d, None)).collect(),
    }
}

/// The dump of a character line's drives, with rate and telegram count.
pub fn byte_line_dump(family: Family, line: &ByteLine) -> StateDump {
    named_byte_line_dump(family.name(), line)
}

/// [`byte_line_dump`] of a bus named `bus` (a family or `lustbus`).
fn named_byte_line_dump(bus: &str, line: &ByteLine) -> StateDump {
    StateDump {
        baud: Some(line.baud()),
        telegrams: Some(line.telegrams()),
        ..dump_of(bus, line.drives())
    }
}

/// The dump of a CAN bus's nodes, with bit rate and telegram count.
pub fn frame_line_dump(family: Family, line: &FrameLine) -> StateDump {
    StateDump {
        bitrate: Some(line.bitrate()),
        telegrams: Some(line.telegrams()),
        ..dump_of(family.name(), line.drives())
    }
}

impl StateDump {
    /// Read a dump file.
    pub fn read(path: &Path) -> Result<StateDump, SimOpenError> {
        use driveset_schema::input::{InputKind, read_input};
        let bytes = read_input(path, InputKind::SIM_STATE).map_err(|e| SimOpenError::StateIo {
            path: path.into(),
            op: "read it",
            source: io::Error::other(e.detail()),
        })?;
        let text = String::from_utf8_lossy(&bytes);
        let dump: StateDump =
            serde_json::from_str(&text).map_err(|e| SimOpenError::StateFormat {
                path: path.into(),
                reason: format!("not a simulator state dump ({e})"),
            })?;
        if dump.format != STATE_FORMAT {
            return Err(SimOpenError::StateFormat {
                path: path.into(),
                reason: format!(
                    "format `{}` is not `{STATE_FORMAT}` (written by another driveset version?)",
                    dump.format
                ),
            });
        }
        Ok(dump)
    }

    /// Write the dump as pretty JSON: to a temporary file (mode 0600) next
    /// to `path`, then renamed over it (a crash never leaves half a file).
    pub fn write(&self, path: &Path) -> Result<(), SimOpenError> {
        // through a symlink to the file it names: the rename below would
        // otherwise replace the link with a file of its own, and the next
        // command given the link would drive another bus
        let target = std::fs::canonicalize(path).ok();
        let path = target.as_deref().unwrap_or(path);
        let io_err = |op, source| SimOpenError::StateIo {
            path: path.into(),
            op,
            source,
        };
        let mut text = serde_json::to_string_pretty(self)
            .map_err(|e| io_err("serialize it", io::Error::other(e)))?;
        text.push('\n');
        // the one writer; 0600: a drive's memory holds its passwords
        driveset_schema::output::write_private(path, text.as_bytes())
            .map_err(|e| io_err("write it", io::Error::other(e.detail())))
    }
}

/// Parse the canonical text of one drive back into values.
pub fn parse_canonical(text: &str) -> Result<(String, BTreeMap<CodeKey, RawValue>), String> {
    let mut lines = text.lines();
    if lines.next() != Some("driveset-canonical 1") {
        return Err("canonical text does not start with `driveset-canonical 1`".into());
    }
    let schema = lines
        .next()
        .and_then(|l| l.strip_prefix("schema "))
        .ok_or("canonical text has no `schema` line")?
        .to_string();
    let mut values = BTreeMap::new();
    for line in lines {
        let (code, value) = line
            .split_once(' ')
            .ok_or_else(|| format!("canonical line `{line}` is not `CODE VALUE`"))?;
        let bad = || format!("canonical line `{line}`: bad code");
        let digits = code.strip_prefix('C').unwrap_or(code);
        let key = match digits.split_once('/') {
            Some((n, s)) => {
                CodeKey::sub(n.parse().map_err(|_| bad())?, s.parse().map_err(|_| bad())?)
            }
            None => CodeKey::new(digits.parse().map_err(|_| bad())?),
        };
        let raw = if let Some(json) = value.strip_prefix('s') {
            RawValue::Text(
                serde_json::from_str(json)
                    .map_err(|e| format!("canonical line `{line}`: bad text ({e})"))?,
            )
        } else if let Some(hex) = value.strip_prefix('o') {
            let bytes = (0..hex.len())
                .step_by(2)
                .map(|i| {
                    hex.get(i..i + 2)
                        .and_then(|h| u8::from_str_radix(h, 16).ok())
                })
                .collect::<Option<Vec<u8>>>()
                .ok_or_else(|| format!("canonical line `{line}`: bad octets"))?;
            RawValue::Octets(bytes)
        } else {
            RawValue::Int(
                value
                    .parse()
                    .map_err(|_| format!("canonical line `{line}`: bad integer"))?,
            )
        };
        values.insert(key, raw);
    }
    Ok((schema, values))
}

/// Load the state file at `path` (if it exists) into `drives` of the bus
/// named `bus` (a family or `lustbus`).
pub(super) fn load_state_into<D: StateDrive>(
    path: &Path,
    bus: &str,
    drives: &mut [D],
    slots: &[DriveSlot],
) -> Result<(), SimOpenError> {
    if !path.exists() {
        return Ok(());
    }
    let dump = StateDump::read(path)?;
    apply_dump(path, bus, &dump, drives, slots)
}

/// The entry of `dump` for the drive in `slot` now at `address`: the
/// entry of that slot; else (a dump of an older version, or of another
/// port of the same bus) an unused entry of the same family at that
/// address whose slot is none of this port's.
fn entry_for<'a>(
    dump: &'a StateDump,
    slot: &DriveSlot,
    address: u8,
    slots: &[String],
    used: &[usize],
) -> Option<(usize, &'a DriveDump)> {
    let own = slot.to_string();
    let family = slot.family().name();
    dump.drives
        .iter()
        .enumerate()
        .find(|(_, e)| e.slot.as_deref() == Some(own.as_str()))
        .or_else(|| {
            dump.drives.iter().enumerate().find(|(i, e)| {
                !used.contains(i)
                    && e.address == address
                    && bus_key(&e.family) == family
                    && e.slot.as_ref().is_none_or(|s| !slots.contains(s))
            })
        })
}

/// A family or bus name as dumps compare it (`lust-mc6000` is `mc6000`).
fn bus_key(name: &str) -> String {
    parse_family(name).map_or_else(|_| name.trim().to_ascii_lowercase(), |f| f.name().into())
}

fn apply_dump<D: StateDrive>(
    path: &Path,
    bus: &str,
    dump: &StateDump,
    drives: &mut [D],
    slots: &[DriveSlot],
) -> Result<(), SimOpenError> {
    let format_err = |reason: String| SimOpenError::StateFormat {
        path: path.into(),
        reason,
    };
    if bus_key(&dump.family) != bus_key(bus) {
        return Err(format_err(format!(
            "it holds {} drives, this bus has {bus} drives",
            dump.family
        )));
    }
    let slot_texts: Vec<String> = slots.iter().map(DriveSlot::to_string).collect();
    let mut used: Vec<usize> = Vec::new();
    for (i, drive) in drives.iter_mut().enumerate() {
        let address = drive.dump_address();
        let found = match slots.get(i) {
            Some(slot) => entry_for(dump, slot, address, &slot_texts, &used),
            None => {
                let family = bus_key(drive.dump_family());
                dump.drives
                    .iter()
                    .enumerate()
                    .find(|(_, e)| e.address == address && bus_key(&e.family) == family)
            }
        };
        let Some((at, entry)) = found else {
            continue;
        };
        used.push(at);
        let (schema, values) = parse_canonical(&entry.canonical)
            .map_err(|e| format_err(format!("drive {address}: {e}")))?;
        let current = drive.dump_state();
        if schema != current.schema {
            return Err(format_err(format!(
                "drive {address} was saved with schema `{schema}`, the simulator now uses `{}`",
                current.schema
            )));
        }
        // Poke what differs; codes derived from others (Tmd C0068, C0150)
        // refuse a poke and must come out equal once the rest is set.
        let mut refused = Vec::new();
        for (key, raw) in &values {
            if current.values.get(key) != Some(raw)
                && let Err(e) = drive.restore(*key, raw.clone())
            {
                refused.push((*key, e));
            }
        }
        // what it has stored: the dump's, else (an older dump) what it holds
        let stored = match &entry.stored {
            Some(text) => {
                parse_canonical(text)
                    .map_err(|e| format_err(format!("drive {address} (stored): {e}")))?
                    .1
            }
            None => values.clone(),
        };
        drive
            .restore_stored(stored)
            .map_err(|e| format_err(format!("drive {address} (stored): {e}")))?;
        if let Some(rate) = entry.rate {
            drive.restore_rate(rate);
        }
        if entry.assigned {
            drive.restore_assigned();
        }
        let now = drive.dump_state();
        if now.values != values {
            let differing: Vec<String> = values
                .keys()
                .chain(now.values.keys())
                .filter(|k| now.values.get(k) != values.get(k))
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .take(3)
                .map(|k| match refused.iter().find(|(r, _)| r == k) {
                    Some((_, e)) => e.clone(),
                    None => format!("{} differs after loading", k.canonical(now.code_style)),
                })
                .collect();
            return Err(format_err(format!(
                "drive {address}: its saved state cannot be restored ({})",
                differing.join("; ")
            )));
        }
    }
    Ok(())
}
