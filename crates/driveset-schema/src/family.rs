//! Owns what driveset knows about each drive family that is not a fact of
//! one code: its id and names, the bus protocol it speaks and that
//! protocol's addresses, how it is identified, its timing rules (reaction
//! ranges, EEPROM pacing, ACK delays, long acknowledgements) and its dataset
//! handshake. Per-code facts (types, ranges, storage, roles) live in the
//! family's schema file (`schemas/*.toml`); [`Descriptor::schema_id`] names
//! the built-in one.
//!
//! This is the one home of those facts: the planner, the clients, pull,
//! schema pull, the simulator and the CLI (its value enums included) ask a
//! [`Descriptor`] instead of naming a family or a code number themselves.
//!
//! Layout: this file holds the descriptor's types and questions; `bus.rs`
//! the bus protocols and their address rules; one file per family holds
//! that family's data (`mc6000.rs`, `vf1000.rs`, `tmd.rs`, `ecs.rs`: its
//! role floor and its [`Descriptor`]).
//!
//! Sources: `lustbus-protocol.txt` §1, §2.4, §3, §4.2, §5, §10, §11.4;
//! `lecom-ab-tmd-manual.txt` (addresses, C0093/C0200 identification);
//! `lenze-system-bus-can-sdo.txt` (node ids, index mapping).

use std::fmt;
use std::ops::RangeInclusive;
use std::time::Duration;

use driveset_proto::lustbus::{CompatibleParameter, Dialect};

use crate::role::{BitRole, Role};
use crate::schema::{CIA_NUMBER_BASE, Code, StorageKind};

mod bus;
mod ecs;
mod mc6000;
mod tmd;
mod vf1000;

pub use bus::{AddressProblem, AddressRefusal, BusProtocol};
pub use mc6000::{SERVO_RATES, SLOAD};
pub use vf1000::INVERTER_RATES;

/// A drive family driveset knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Lust MASTERCONTROL MC6000/7000 servocontroller (LUSTBUS, enhanced).
    Mc6000,
    /// Lust SMARTDRIVE VF1000 inverter (LUSTBUS).
    Vf1000,
    /// Lenze Tmd vector inverter (LECOM-A/B).
    Tmd,
    /// Lenze ECS servo axis (system bus CAN, SDO).
    Ecs,
}

/// The shape of the drive's reaction time: the answer comes `min..=max`
/// after the request's last character.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reaction {
    /// Shortest reaction.
    pub min: Duration,
    /// Longest reaction without a KEYPAD (or the only figure).
    pub max: Duration,
    /// Longest reaction with a KEYPAD attached (LUSTBUS §10), where it differs.
    pub max_with_keypad: Option<Duration>,
    /// Where the figures come from; `FICTIONAL` where no spec gives them.
    pub source: &'static str,
}

/// Whether a KEYPAD is attached to a LUSTBUS drive (it slows the drive's
/// longest reaction, LUSTBUS §10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Keypad {
    /// A KEYPAD is attached.
    Fitted,
    /// No KEYPAD.
    #[default]
    Absent,
}

/// Whether a write gives a code a value other than the one the drive
/// holds ([`Descriptor::ack_delay`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueChange {
    /// The written value differs from the held one (or may: a caller that
    /// does not know allows for it).
    Differs,
    /// The written value is the held one.
    Same,
}

impl Reaction {
    /// The longest reaction, with or without a KEYPAD.
    pub fn longest(&self, keypad: Keypad) -> Duration {
        match (keypad, self.max_with_keypad) {
            (Keypad::Fitted, Some(k)) => k,
            _ => self.max,
        }
    }

    /// Whether a spec gives the figures (false: driveset assumes them).
    pub fn from_spec(&self) -> bool {
        !self.source.starts_with("FICTIONAL")
    }
}

/// How a family paces writes of stored (EEPROM) values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EepromPacing {
    /// No pacing the spec states.
    None,
    /// MC6000/7000 (§3, §10.2.2): the ACK comes at once; the drive then
    /// stores every byte three times at 5 ms in the background, so the next
    /// EEPROM write must wait `per_byte` x width from the ACK.
    StoreInBackground {
        /// Store time per byte of the value's width (3 x 5 ms).
        per_byte: Duration,
        /// Width assumed when the schema gives none (the widest value).
        unknown_width: u8,
    },
    /// VF1000 (§10 exception 4): writing an EEPROM value that differs from
    /// the old one delays the ACK by `per_byte` x width (60 ms one-byte,
    /// 120 ms two-byte).
    AckDelay {
        /// Delay per byte of the value's width.
        per_byte: Duration,
        /// Width assumed when the schema gives none (the safe, longer delay).
        unknown_width: u8,
    },
}

/// The dataset download handshake of MC6000/7000 (`lustbus-protocol.txt`
/// §11.4): SLOAD = -1 registers a download, the CardWriteable values are
/// staged, SLOAD = -2 asks the drive to check and store them, and SLOAD is
/// polled: `checking` while the drive works, `accepted` when the set is in
/// EEPROM, a positive parameter number when it rejected the set there (and
/// reactivated the old one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DatasetHandshake {
    /// The handshake parameter (80-SLOAD).
    pub code: u32,
    /// Its name.
    pub name: &'static str,
    /// Value that opens a download.
    pub begin: i64,
    /// Value that closes it and starts the check.
    pub commit: i64,
    /// Value while the drive checks and stores.
    pub checking: i64,
    /// Value once the drive took the set.
    pub accepted: i64,
    /// How long the drive may check (§11.4: 10 s).
    pub timeout: Duration,
}

/// A command whose acknowledgement the drive holds back while it works
/// (LUSTBUS §10 exception 1: PROG = 1 reinitialises every parameter and
/// ACKs only when done, up to 10 s).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LongAck {
    /// The command parameter.
    pub code: u32,
    /// The value that triggers the long acknowledgement.
    pub value: i64,
    /// The longest the ACK may take.
    pub within: Duration,
}

/// Everything driveset knows about one family beyond its codes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Descriptor {
    /// The family.
    pub family: Family,
    /// Short name: `sim://NAME`, `--family NAME`, manifests, reports.
    pub name: &'static str,
    /// Other accepted spellings of `name`.
    pub aliases: &'static [&'static str],
    /// The product as people say it.
    pub title: &'static str,
    /// `[schema] protocol` of this family's schema files.
    pub schema_protocol: &'static str,
    /// The built-in schema (`schemas/*.toml`).
    pub schema_id: &'static str,
    /// The bus protocol.
    pub bus: BusProtocol,
    /// Codes read to identify a drive of this family, in order (the
    /// built-in schema's `[schema.identify] codes` say the same: a test
    /// holds them together).
    pub identify: &'static [u32],
    /// How identification reads those codes ([`IdentifyRules`]).
    pub identify_rules: IdentifyRules,
    /// Reaction time.
    pub reaction: Reaction,
    /// EEPROM pacing.
    pub eeprom: EepromPacing,
    /// Dataset download handshake, where the family has one.
    pub dataset: Option<DatasetHandshake>,
    /// Commands acknowledged late.
    pub long_acks: &'static [LongAck],
    /// How the family's line rate is set: the rates it runs at (highest
    /// first) and, where the drive can activate a new rate without a
    /// restart, how.
    pub line_rates: LineRates,
    /// The roles the specs give this family's codes ([`FloorRole`]): every
    /// schema of the family gets at least these when it is loaded
    /// (`schema::parse_schema`), whatever its file says.
    pub floor: &'static [FloorRole],
    /// The LUSTBUS wire dialect the family speaks (`lustbus-protocol.txt`
    /// §2.3: VF1000 four hex digits, MC6000/7000 one to eight); `None` off
    /// LUSTBUS.
    pub dialect: Option<Dialect>,
    /// The code whose value is the device type (LUSTBUS 91-TYPE, §5.2),
    /// where identification reads one: learned file names, the manifest's
    /// `type =` check and `identify` print it.
    pub type_code: Option<u32>,
    /// Learning a schema from the drive's own descriptions (LUSTBUS §11.1,
    /// §11.2), where the family's drives describe their parameters.
    pub learning: Option<Learning>,
    /// Whether the drive executes every SELECT to the broadcast address as
    /// a write of its own parameter of that number, whatever the CODE's
    /// device digit says (VF1000, `lustbus-protocol.txt` §4.2, §5.2): a bus
    /// holding one takes no broadcast.
    pub broadcast_as_own: bool,
    /// The code whose value decides whether the bus may write the drive's
    /// parameters, where the family has one (Tmd C0001,
    /// `lecom-ab-tmd-manual.txt` §4e, §4f): `driveset address` reads it
    /// before writing an address.
    pub bus_write: Option<BusWriteSource>,
    /// Where the family's spec says a RAM value is lost at power down (the
    /// section that defines its storage kinds), cited by the `ram-code`
    /// finding ([`crate::schema::ram_note`]): LUSTBUS §11.1 (VF1000 kinds
    /// '0' / '4') and §11.2.1 (MC6000/7000 "RAM control value"); `None`
    /// where the family's codes have no storage kinds (Tmd, ECS).
    pub ram_loss: Option<&'static str>,
}

/// The code that says where a drive takes its parameter writes from, and
/// the values of it under which the bus may write (`lecom-ab-tmd-manual.txt`
/// §4e, §4f: C0001 0 and 1 read only, 2 and 3 write).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusWriteSource {
    /// The code (C0001, setpoint and control source).
    pub code: u32,
    /// The values that let the bus write.
    pub writes: &'static [i64],
}

impl BusWriteSource {
    /// Whether `value` of [`BusWriteSource::code`] lets the bus write.
    pub fn allows(&self, value: i64) -> bool {
        self.writes.contains(&value)
    }
}

/// How a drive of the family is identified beyond the codes read
/// ([`Descriptor::identify`]), where the families differ: the one identify
/// loop of the clients (`driveset-engine`'s `client/identify.rs`) follows
/// these.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdentifyRules {
    /// The codes read when the schema names none (no `[schema.identify]
    /// codes`): LUSTBUS 91-TYPE (§5.2), as the built-in schemas; LECOM
    /// C0093 only (`lecom-ab-tmd-manual.txt` Table 1), since a schema that
    /// names no identification codes may not know C0099 or C0200; none on
    /// CAN.
    pub without_schema: &'static [u32],
    /// Whether a code the drive says it lacks (LECOM "no such code", a
    /// device error) is left out instead of failing identification: Tmd
    /// controllers differ in which of C0099 / C0200 they hold. LUSTBUS and
    /// CAN fail on any code.
    pub skips_missing: bool,
    /// The code whose value is the drive's software version (Tmd C0099,
    /// Table 1), where the family reports one.
    pub software: Option<u32>,
    /// The codes a read-only probe of an unknown drive reads, in order, to
    /// tell whether one of the family is there (`driveset-engine`'s
    /// `scan::detect_protocol`; the first that answers decides): LUSTBUS
    /// 91-TYPE (§5.2); LECOM C0093, then C0200 (`lecom-ab-tmd-manual.txt`
    /// Table 1). The identify codes without the software version: a
    /// probe needs no version, and leaving C0099 out saves one telegram
    /// (and its timeout) per silent address. None on CAN (no probe).
    pub probe: &'static [u32],
}

/// How a family's drives describe their parameters, for learning a schema
/// from them (`lustbus-protocol.txt` §11.1, §11.2), and the file a learned
/// schema is stored under.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Learning {
    /// The family's part of a learned file's name (`learned-<stem>-...`).
    pub stem: &'static str,
    /// The highest parameter number the drive describes (§11.1: VF1000
    /// CODE `000pp`, two digits: 99; MC6000/7000 `00ppp`, three: 999).
    pub max_parameter: u32,
}

impl Learning {
    /// How every learned file's name (and schema id) starts, whatever its
    /// family ([`Learning::file_prefix`]).
    pub const PREFIX: &'static str = "learned-";

    /// Whether schema id `id` is a learned schema's ([`Learning::PREFIX`]):
    /// `identify` tells a learned schema named by its file this way.
    pub fn is_learned_id(id: &str) -> bool {
        id.starts_with(Self::PREFIX)
    }

    /// The file (and schema id) a learned schema is stored under:
    /// `learned-<stem>-type<TYPE>-<software>`. `device_type` is the value of
    /// [`Descriptor::type_code`] (`unknown` where the drive gave none), kept
    /// to its ASCII letters, digits, `-` and `_`; `software` the identity's
    /// software version, its other characters made `_`, or, where the drive
    /// reports none, `d<8 hex>` of `descriptions_hash` (the hash of the
    /// descriptions the drive sent).
    pub fn file_id(
        &self,
        device_type: Option<&str>,
        software: Option<&str>,
        descriptions_hash: u32,
    ) -> String {
        let ty = Self::type_slug(device_type);
        let sw = software.map_or_else(
            || format!("d{descriptions_hash:08x}"),
            |s| {
                s.chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect()
            },
        );
        format!("{}{sw}", self.file_prefix(Some(&ty)))
    }

    /// The TYPE as a learned file's name holds it: `device_type` kept to
    /// its ASCII letters, digits, `-` and `_` (`MC 6000/A` is `MC6000A`),
    /// `unknown` where the drive gave none. The one slug of
    /// [`Learning::file_id`] and [`Learning::file_prefix`], so a file is
    /// looked for by the name it was written under.
    pub fn type_slug(device_type: Option<&str>) -> String {
        device_type
            .unwrap_or("unknown")
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_')
            .collect()
    }

    /// How every learned file of a drive of `device_type` starts:
    /// `learned-<stem>-type<TYPE>-`, the TYPE slugged as
    /// [`Learning::file_id`] names the file ([`Learning::type_slug`]).
    pub fn file_prefix(&self, device_type: Option<&str>) -> String {
        format!(
            "{}{}-type{}-",
            Self::PREFIX,
            self.stem,
            Self::type_slug(device_type)
        )
    }

    /// The parameters a learning run asks for by default: 1 ..= the highest.
    pub fn default_params(&self) -> std::ops::RangeInclusive<u32> {
        1..=self.max_parameter
    }
}

/// A role the specs give one code of a family, which no schema file can
/// take away (docs/file-formats.md, "Code roles"; docs/architecture.md,
/// "The role floor"). Applied to every schema of the family when it is
/// loaded: the code's role becomes `role`; a control word's bits get the
/// floor's bit roles; a control word's `stopped` values are those the floor
/// gives (a schema may narrow them, never widen them); and a schema's
/// `inhibit` bits on a floor control word count only where the floor names
/// them (an added inhibit bit would make a start value look safe).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FloorRole {
    /// Code number ([`CIA_NUMBER_BASE`] + index for a CiA object).
    pub code: u32,
    /// Its role.
    pub role: Role,
    /// Control word: the bits and what they do.
    pub bits: &'static [FloorBit],
    /// Control word without bit roles: the values that keep it stopped
    /// (engineering integers, as `stopped = [...]` in a schema file).
    pub stopped: &'static [i64],
    /// Where the spec says so.
    pub source: &'static str,
}

/// A one-bit member of a floor control word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FloorBit {
    /// The member's name where the schema gives the bit none.
    pub name: &'static str,
    /// The bit (0 = least significant).
    pub bit: u32,
    /// What a set bit does.
    pub role: BitRole,
}

const fn floor(code: u32, role: Role, source: &'static str) -> FloorRole {
    FloorRole {
        code,
        role,
        bits: &[],
        stopped: &[],
        source,
    }
}

const fn cia(index: u32) -> u32 {
    CIA_NUMBER_BASE + index
}

/// A serial family's line rates (`lustbus-protocol.txt` §4, §11.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineRates {
    /// The rates the family runs at, highest first (empty: not a serial
    /// family).
    pub rates: &'static [u32],
    /// The code holding the rate, where the family has one (LUSTBUS 81).
    pub code: Option<u32>,
    /// Online activation of a new rate (MC6000/7000 only).
    pub online: Option<OnlineBaud>,
}

/// §11.5: "first set the new Baudrate. Then use the value 111 in the
/// 4-PROG parameter to order the servocontroller to activate the
/// Baudrate."
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OnlineBaud {
    /// The command code (4-PROG).
    pub command: u32,
    /// The value that activates the rate written to [`LineRates::code`] (111).
    pub activate: i64,
}

/// 91-TYPE, the device type both LUSTBUS families report
/// (`lustbus-protocol.txt` §5.2, a numerically compatible parameter).
pub const TYPE: u32 = 91;

impl Family {
    /// Every family, in the order listings show them.
    pub const ALL: [Family; 4] = [Family::Mc6000, Family::Vf1000, Family::Tmd, Family::Ecs];

    /// The family's descriptor.
    pub const fn descriptor(self) -> &'static Descriptor {
        match self {
            Family::Mc6000 => &mc6000::MC6000,
            Family::Vf1000 => &vf1000::VF1000,
            Family::Tmd => &tmd::TMD,
            Family::Ecs => &ecs::ECS,
        }
    }

    /// Short name (`mc6000`, `vf1000`, `tmd`, `ecs`).
    pub fn name(self) -> &'static str {
        self.descriptor().name
    }

    /// Parse a family name or alias (any case).
    pub fn parse(name: &str) -> Result<Family, String> {
        let n = name.to_ascii_lowercase();
        Family::ALL
            .into_iter()
            .find(|f| {
                let d = f.descriptor();
                d.name == n || d.aliases.contains(&n.as_str())
            })
            .ok_or_else(|| {
                format!(
                    "unknown drive family `{name}`: use one of {}",
                    Family::ALL.map(Family::name).join(", ")
                )
            })
    }

    /// The family a port or a listing names: a family name or alias, or a
    /// schema id built on one (`lust-vf1000`, `fictional-tmd-demo`,
    /// `lenze_ecs`), in any case and with `_` for `-`; the prefixes
    /// `fictional-`, `lust-`, `lenze-` and the suffix `-demo` are left off
    /// first. How `sim://` ports name their drives (a manifest's check of a
    /// simulated bus asks this instead of spelling families itself);
    /// `None` when the name is no family's.
    pub fn from_port_name(name: &str) -> Option<Family> {
        let lower = name.trim().to_ascii_lowercase().replace('_', "-");
        let mut short = lower.as_str();
        for prefix in ["fictional-", "lust-", "lenze-"] {
            short = short.strip_prefix(prefix).unwrap_or(short);
        }
        short = short.strip_suffix("-demo").unwrap_or(short);
        Family::parse(short).ok()
    }

    /// The family whose schema files say `[schema] protocol = "s"`.
    pub fn from_schema_protocol(s: &str) -> Option<Family> {
        Family::ALL
            .into_iter()
            .find(|f| f.descriptor().schema_protocol == s)
    }

    /// The `[schema] protocol` values, for messages.
    pub fn schema_protocols() -> String {
        Family::ALL
            .map(|f| f.descriptor().schema_protocol)
            .join(" | ")
    }

    /// The bus protocol.
    pub fn bus(self) -> BusProtocol {
        self.descriptor().bus
    }

    /// The family that speaks LUSTBUS dialect `dialect` ([`Descriptor::dialect`]).
    /// A `const fn`, so that constants of one family's figures (the
    /// planner's reaction times) ask by dialect too.
    pub const fn from_dialect(dialect: Dialect) -> Family {
        match dialect {
            Dialect::Vf1000 => Family::Vf1000,
            Dialect::Mc => Family::Mc6000,
        }
    }

    /// The family whose learned files start `learned-<stem>-`
    /// ([`Learning::stem`]).
    pub fn from_learned_stem(stem: &str) -> Option<Family> {
        Family::ALL
            .into_iter()
            .find(|f| f.descriptor().learning.is_some_and(|l| l.stem == stem))
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Descriptor {
    /// The numerically compatible parameters the family serves under CODE
    /// `000xx` (LUSTBUS §5.2: 81..85, 91, proto's [`CompatibleParameter`]
    /// table); empty off LUSTBUS.
    pub fn compatible(&self) -> &'static [u32] {
        match self.bus {
            BusProtocol::Lustbus => &CompatibleParameter::NUMBERS,
            BusProtocol::Lecom | BusProtocol::CanSdo => &[],
        }
    }

    /// Whether `code` is one of [`Descriptor::compatible`].
    pub fn is_compatible(&self, code: u32) -> bool {
        self.bus == BusProtocol::Lustbus && CompatibleParameter::contains(code)
    }

    /// The code a drive's device type is read from (LUSTBUS 91-TYPE, §5.2):
    /// [`Descriptor::type_code`], or [`TYPE`] for a family whose
    /// identification reads none (no identity of its drives holds 91, so a
    /// schema's `[schema.identify] type_values` find nothing to check there).
    /// What `type_values` are checked against and learned files are named by.
    pub fn device_type_code(&self) -> u32 {
        self.type_code.unwrap_or(TYPE)
    }

    /// The dataset handshake's code (MC6000/7000 80-SLOAD, §11.4), where
    /// the family has one.
    pub fn dataset_code(&self) -> Option<u32> {
        self.dataset.map(|h| h.code)
    }

    /// The address every drive on the family's bus executes without
    /// answering ([`BusProtocol::broadcast_address`]: LUSTBUS 31, LECOM 00).
    pub fn broadcast_address(&self) -> Option<u8> {
        self.bus.broadcast_address()
    }

    /// Check a drive's own address on the family's bus
    /// ([`BusProtocol::check_address`], the one rule).
    pub fn check_address(&self, address: i64) -> Result<(), AddressRefusal> {
        self.bus.check_address(address)
    }

    /// Whether the family's drives are on CAN (frames) rather than a
    /// character line.
    pub fn on_can(&self) -> bool {
        self.bus == BusProtocol::CanSdo
    }

    /// Whether a new line rate takes effect only at the drive's next
    /// restart: a LUSTBUS family without [`LineRates::online`]
    /// (`lustbus-protocol.txt` §11.5: "the change first becomes active
    /// once the device is restarted"; only the servocontroller activates
    /// one online). `false` off LUSTBUS, whose specs say nothing of it.
    pub fn rate_at_restart_only(&self) -> bool {
        self.bus == BusProtocol::Lustbus && self.line_rates.online.is_none()
    }

    /// The file (and schema id) a schema learned from a drive of this
    /// family is stored under ([`Learning::file_id`]); `None` for families
    /// whose drives do not describe their parameters.
    pub fn learned_id(
        &self,
        device_type: Option<&str>,
        software: Option<&str>,
        descriptions_hash: u32,
    ) -> Option<String> {
        self.learning
            .map(|l| l.file_id(device_type, software, descriptions_hash))
    }

    /// The highest parameter the family's drives describe (VF1000 99,
    /// MC6000/7000 999; [`Learning::max_parameter`]).
    pub fn max_parameter(&self) -> Option<u32> {
        self.learning.map(|l| l.max_parameter)
    }

    /// The floor role of code `number`, where the specs give it one.
    pub fn floor_of(&self, number: u32) -> Option<&'static FloorRole> {
        self.floor.iter().find(|f| f.code == number)
    }

    /// The width a pacing rule counts for `code` (its schema width, or the
    /// rule's assumption for an unknown one).
    fn width(code: &Code, unknown: u8) -> u32 {
        u32::from(code.width.unwrap_or(unknown))
    }

    /// Whether a write of `code` goes to EEPROM as far as pacing is
    /// concerned: `eeprom` and `fsel-isel` values, and values whose kind the
    /// schema does not give (the safe assumption); never RAM values.
    pub fn paced(code: &Code) -> bool {
        !matches!(
            code.kind,
            Some(StorageKind::RamControl | StorageKind::RamActual)
        )
    }

    /// MC6000/7000: how long the drive stores `code` after its ACK (§3,
    /// §10.2.2: width x 3 x 5 ms); zero for families that ACK after storing
    /// or need no pacing, and for RAM values.
    pub fn store_time(&self, code: &Code) -> Duration {
        match self.eeprom {
            EepromPacing::StoreInBackground {
                per_byte,
                unknown_width,
            } if code.kind == Some(StorageKind::Eeprom) || code.kind.is_none() => {
                per_byte * Self::width(code, unknown_width)
            }
            _ => Duration::ZERO,
        }
    }

    /// VF1000: how much later the ACK to a write of `code` comes when the
    /// value differs from the one the drive holds (§10 exception 4); zero
    /// when it does not differ ([`ValueChange::Same`]), for RAM values and
    /// for other families. The planner and the client both use this one
    /// rule.
    pub fn ack_delay(&self, code: &Code, change: ValueChange) -> Duration {
        match self.eeprom {
            EepromPacing::AckDelay {
                per_byte,
                unknown_width,
            } if change == ValueChange::Differs && Self::paced(code) => {
                per_byte * Self::width(code, unknown_width)
            }
            _ => Duration::ZERO,
        }
    }

    /// The long acknowledgement of writing `value` to `code`, if any.
    pub fn long_ack(&self, code: u32, value: i64) -> Option<Duration> {
        self.long_acks
            .iter()
            .find(|l| l.code == code && l.value == value)
            .map(|l| l.within)
    }
}

#[cfg(test)]
mod tests;
