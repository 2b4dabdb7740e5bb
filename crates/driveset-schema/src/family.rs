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
//! Sources: `lustbus-protocol.txt` §1, §2.4, §3, §4.2, §5, §10, §11.4;
//! `lecom-ab-tmd-manual.txt` (addresses, C0093/C0200 identification);
//! `lenze-system-bus-can-sdo.txt` (node ids, index mapping).

use std::fmt;
use std::ops::RangeInclusive;
use std::time::Duration;

use driveset_proto::lustbus::{CompatibleParameter, Dialect};

use crate::role::{BitRole, Role};
use crate::schema::{CIA_NUMBER_BASE, Code, StorageKind};

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

/// The bus protocol a family speaks (what a port carries).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BusProtocol {
    /// LUSTBUS (ISO 1745 fast select, ASCII 7E1): VF1000 and MC6000/7000
    /// share one line (`lustbus-protocol.txt` §1).
    Lustbus,
    /// LECOM-A/B (DIN 66019, ASCII 7E1): Tmd.
    Lecom,
    /// Lenze system bus (CAN), SDO: ECS.
    CanSdo,
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

impl Reaction {
    /// The longest reaction, with or without a KEYPAD.
    pub fn longest(&self, keypad: bool) -> Duration {
        match (keypad, self.max_with_keypad) {
            (true, Some(k)) => k,
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
        let ty: String = device_type
            .unwrap_or("unknown")
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_')
            .collect();
        let sw = software.map_or_else(
            || format!("d{descriptions_hash:08x}"),
            |s| {
                s.chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect()
            },
        );
        format!("learned-{}-type{ty}-{sw}", self.stem)
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

/// MC6000/7000 (`lustbus-protocol.txt`).
const MC6000_FLOOR: &[FloorRole] = &[
    floor(
        4,
        Role::Command,
        "§10 exception 1 (PROG = 1 factory settings), §11.5 (PROG = 111)",
    ),
    floor(80, Role::Command, "§11.4: SLOAD -1 / -2 dataset handshake"),
    floor(81, Role::BaudRate, "§4, §11.5: SBAUD"),
    floor(82, Role::BusAddress, "§4.2, §5.2: SADDR"),
    FloorRole {
        code: 416,
        role: Role::ControlWord,
        bits: &[
            FloorBit {
                name: "start",
                bit: 0,
                role: BitRole::Start,
            },
            FloorBit {
                name: "error_reset",
                bit: 7,
                role: BitRole::Reset,
            },
        ],
        stopped: &[],
        source: "§7.2.1: SCTL1 = 0 standstill, bit 0 start; §8.1.2: bit 7 error reset",
    },
];

/// VF1000 (`lustbus-protocol.txt`).
const VF1000_FLOOR: &[FloorRole] = &[
    FloorRole {
        code: 3,
        role: Role::ControlWord,
        bits: &[FloorBit {
            name: "start_clockwise",
            bit: 7,
            role: BitRole::Start,
        }],
        stopped: &[],
        source: "§7.1 step 4, §7.1.1: CNTL = 128 (80H) start clockwise",
    },
    floor(
        11,
        Role::Command,
        "§8.1.1: STAT = 000F resets an error and reboots",
    ),
    floor(
        71,
        Role::Command,
        "§10 exception 1: PROG = 1 factory settings",
    ),
    floor(81, Role::BaudRate, "§4, §11.5: SIOC"),
    floor(82, Role::BusAddress, "§4.2, §5.2: SIOA"),
];

/// Tmd (`lecom-ab-tmd-manual.txt`, Table 1).
const TMD_FLOOR: &[FloorRole] = &[
    floor(2, Role::Command, "Table 1: C0002 load Lenze setting"),
    floor(9, Role::BusAddress, "Table 1, §4c: C0009 network address"),
    floor(14, Role::OperatingMode, "Table 1: C0014 operating mode"),
    FloorRole {
        code: 40,
        role: Role::ControlWord,
        bits: &[],
        stopped: &[0],
        source: "Table 1: C0040 0 = controller inhibited, 1 = controller enabled",
    },
    floor(43, Role::Command, "Table 1: C0043 fault reset"),
    floor(94, Role::Password, "Table 1: C0094 user password"),
    floor(
        125,
        Role::BaudRate,
        "Table 1, §3c, §4d: C0125 LECOM baud rate",
    ),
    FloorRole {
        code: 135,
        role: Role::ControlWord,
        bits: &[
            FloorBit {
                name: "quick_stop",
                bit: 3,
                role: BitRole::Inhibit,
            },
            FloorBit {
                name: "controller_inhibit",
                bit: 9,
                role: BitRole::Inhibit,
            },
            FloorBit {
                name: "trip_reset",
                bit: 11,
                role: BitRole::Reset,
            },
        ],
        stopped: &[],
        source: "Table 1, §4f: C0135 bit 3 quick stop, bit 9 controller inhibit, bit 11 TRIP reset",
    },
];

/// ECS: the CiA 402 drive profile's objects (the system bus excerpt
/// documents none of its own; CiA 402 §6040h..60FFh).
const ECS_FLOOR: &[FloorRole] = &[
    FloorRole {
        code: cia(0x6040),
        role: Role::ControlWord,
        bits: &[
            FloorBit {
                name: "switch_on",
                bit: 0,
                role: BitRole::Enable,
            },
            FloorBit {
                name: "enable_operation",
                bit: 3,
                role: BitRole::Enable,
            },
            FloorBit {
                name: "fault_reset",
                bit: 7,
                role: BitRole::Reset,
            },
        ],
        stopped: &[],
        source: "CiA 402 0x6040 controlword: bit 0 switch on, bit 3 enable operation, bit 7 fault reset",
    },
    floor(
        cia(0x6060),
        Role::OperatingMode,
        "CiA 402 0x6060 modes of operation",
    ),
    floor(
        cia(0x607A),
        Role::Setpoint,
        "CiA 402 0x607A target position",
    ),
    floor(
        cia(0x60FF),
        Role::Setpoint,
        "CiA 402 0x60FF target velocity",
    ),
    floor(cia(0x6071), Role::Setpoint, "CiA 402 0x6071 target torque"),
];

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

/// §4: servocontrollers run "in steps ranging from 2400 Baud to 57600
/// Baud" (the steps are the usual doubling ones plus 38400 and 57600).
pub const SERVO_RATES: &[u32] = &[57600, 38400, 19200, 9600, 4800, 2400];
/// §4: frequency inverters "from 2400 Baud to 9600 Baud".
pub const INVERTER_RATES: &[u32] = &[9600, 4800, 2400];

/// The MC6000/7000 handshake: 80-SLOAD (`lustbus-protocol.txt` §11.4).
pub const SLOAD: DatasetHandshake = DatasetHandshake {
    code: 80,
    name: "SLOAD",
    begin: -1,
    commit: -2,
    checking: -1,
    accepted: 0,
    timeout: Duration::from_secs(10),
};

/// 91-TYPE, the device type both LUSTBUS families report
/// (`lustbus-protocol.txt` §5.2, a numerically compatible parameter).
pub const TYPE: u32 = 91;

const MC6000: Descriptor = Descriptor {
    family: Family::Mc6000,
    name: "mc6000",
    aliases: &["mc7000", "mc"],
    title: "Lust MASTERCONTROL MC6000/7000",
    schema_protocol: "lustbus-mc",
    schema_id: "lust-mc6000",
    bus: BusProtocol::Lustbus,
    identify: &[91],
    reaction: Reaction {
        min: Duration::from_millis(1),
        max: Duration::from_millis(25),
        max_with_keypad: Some(Duration::from_millis(30)),
        source: "lustbus-protocol.txt §10 (servocontroller 1...30 ms with KEYPAD, 1...25 ms without)",
    },
    eeprom: EepromPacing::StoreInBackground {
        per_byte: Duration::from_millis(15),
        unknown_width: 4,
    },
    dataset: Some(SLOAD),
    long_acks: &[LongAck {
        code: 4,
        value: 1,
        within: Duration::from_secs(10),
    }],
    line_rates: LineRates {
        rates: SERVO_RATES,
        code: Some(81),
        online: Some(OnlineBaud {
            command: 4,
            activate: 111,
        }),
    },
    floor: MC6000_FLOOR,
    dialect: Some(Dialect::Mc),
    type_code: Some(TYPE),
    learning: Some(Learning {
        stem: "mc6000",
        max_parameter: 999,
    }),
    broadcast_as_own: false,
};

const VF1000: Descriptor = Descriptor {
    family: Family::Vf1000,
    name: "vf1000",
    aliases: &["vf"],
    title: "Lust SMARTDRIVE VF1000",
    schema_protocol: "lustbus-vf1000",
    schema_id: "lust-vf1000",
    bus: BusProtocol::Lustbus,
    identify: &[91],
    reaction: Reaction {
        min: Duration::from_millis(1),
        max: Duration::from_millis(30),
        max_with_keypad: Some(Duration::from_millis(60)),
        source: "lustbus-protocol.txt §10 (inverter 1...60 ms with KEYPAD, 1...30 ms without)",
    },
    eeprom: EepromPacing::AckDelay {
        per_byte: Duration::from_millis(60),
        unknown_width: 2,
    },
    dataset: None,
    long_acks: &[LongAck {
        code: 71,
        value: 1,
        within: Duration::from_secs(10),
    }],
    line_rates: LineRates {
        rates: INVERTER_RATES,
        code: Some(81),
        online: None,
    },
    floor: VF1000_FLOOR,
    dialect: Some(Dialect::Vf1000),
    type_code: Some(TYPE),
    learning: Some(Learning {
        stem: "vf1000",
        max_parameter: 99,
    }),
    broadcast_as_own: true,
};

const TMD: Descriptor = Descriptor {
    family: Family::Tmd,
    name: "tmd",
    aliases: &[],
    title: "Lenze Tmd",
    schema_protocol: "lecom",
    schema_id: "lenze-tmd",
    bus: BusProtocol::Lecom,
    identify: &[93, 99, 200],
    reaction: Reaction {
        min: Duration::from_millis(1),
        max: Duration::from_millis(20),
        max_with_keypad: None,
        source: "FICTIONAL: the manual gives no reaction time; 1..20 ms assumed",
    },
    eeprom: EepromPacing::None,
    dataset: None,
    long_acks: &[],
    line_rates: LineRates {
        rates: &[9600, 4800, 2400, 1200],
        code: Some(125),
        online: None,
    },
    floor: TMD_FLOOR,
    dialect: None,
    type_code: None,
    learning: None,
    broadcast_as_own: false,
};

const ECS: Descriptor = Descriptor {
    family: Family::Ecs,
    name: "ecs",
    aliases: &[],
    title: "Lenze ECS",
    schema_protocol: "lenze-can-sdo",
    schema_id: "lenze-ecs",
    bus: BusProtocol::CanSdo,
    identify: &[],
    reaction: Reaction {
        min: Duration::from_millis(1),
        max: Duration::from_millis(2),
        max_with_keypad: None,
        source: "FICTIONAL: the system bus excerpt gives no reaction time; 1..2 ms assumed",
    },
    eeprom: EepromPacing::None,
    dataset: None,
    long_acks: &[],
    line_rates: LineRates {
        rates: &[],
        code: None,
        online: None,
    },
    floor: ECS_FLOOR,
    dialect: None,
    type_code: None,
    learning: None,
    broadcast_as_own: false,
};

impl Family {
    /// Every family, in the order listings show them.
    pub const ALL: [Family; 4] = [Family::Mc6000, Family::Vf1000, Family::Tmd, Family::Ecs];

    /// The family's descriptor.
    pub const fn descriptor(self) -> &'static Descriptor {
        match self {
            Family::Mc6000 => &MC6000,
            Family::Vf1000 => &VF1000,
            Family::Tmd => &TMD,
            Family::Ecs => &ECS,
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
    pub fn from_dialect(dialect: Dialect) -> Family {
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

/// Why an address is not a drive's own address on a bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddressProblem {
    /// A group or broadcast address.
    Group,
    /// Outside the protocol's range.
    OutOfRange,
}

impl AddressProblem {
    /// Kebab-case kind for findings.
    pub fn kind(self) -> &'static str {
        match self {
            AddressProblem::Group => "group-address",
            AddressProblem::OutOfRange => "address-out-of-range",
        }
    }
}

impl BusProtocol {
    /// Every bus protocol.
    pub const ALL: [BusProtocol; 3] = [
        BusProtocol::Lustbus,
        BusProtocol::Lecom,
        BusProtocol::CanSdo,
    ];

    /// Name in manifests, `--protocol` and reports.
    pub fn name(self) -> &'static str {
        match self {
            BusProtocol::Lustbus => "lustbus",
            BusProtocol::Lecom => "lecom",
            BusProtocol::CanSdo => "can",
        }
    }

    /// Other accepted spellings.
    pub fn aliases(self) -> &'static [&'static str] {
        match self {
            BusProtocol::CanSdo => &["sdo"],
            _ => &[],
        }
    }

    /// One line for `--help`.
    pub fn title(self) -> &'static str {
        match self {
            BusProtocol::Lustbus => "LUSTBUS (Lust VF1000, MC6000/7000)",
            BusProtocol::Lecom => "LECOM-A/B (Lenze Tmd)",
            BusProtocol::CanSdo => "CAN SDO over the Lenze system bus (Lenze ECS)",
        }
    }

    /// Parse a name or alias (any case).
    pub fn parse(s: &str) -> Option<BusProtocol> {
        let s = s.to_ascii_lowercase();
        BusProtocol::ALL
            .into_iter()
            .find(|p| p.name() == s || p.aliases().contains(&s.as_str()))
    }

    /// The families this protocol carries.
    pub fn families(self) -> impl Iterator<Item = Family> {
        Family::ALL.into_iter().filter(move |f| f.bus() == self)
    }

    /// Whether a drive of `family` runs on this bus.
    pub fn carries(self, family: Family) -> bool {
        family.bus() == self
    }

    /// Every address a drive of this protocol may have as its own.
    pub fn drive_addresses(self) -> RangeInclusive<u8> {
        match self {
            BusProtocol::Lustbus => 1..=30,
            BusProtocol::Lecom => 1..=99,
            BusProtocol::CanSdo => 1..=127,
        }
    }

    /// The address every drive executes without answering (LUSTBUS 31,
    /// §4.2; LECOM 00, the broadcast address). CAN SDO has none.
    pub fn broadcast_address(self) -> Option<u8> {
        match self {
            BusProtocol::Lustbus => Some(31),
            BusProtocol::Lecom => Some(0),
            BusProtocol::CanSdo => None,
        }
    }

    /// Whether `address` addresses several drives at once (LUSTBUS 0 and
    /// 31; LECOM 00 and the group addresses 10, 20 .. 90).
    pub fn is_group_address(self, address: i64) -> bool {
        match self {
            BusProtocol::Lustbus => matches!(address, 0 | 31),
            BusProtocol::Lecom => (0..=90).contains(&address) && address % 10 == 0,
            BusProtocol::CanSdo => false,
        }
    }

    /// Every address a telegram of this protocol can carry: a drive's own,
    /// the group and the broadcast addresses (LUSTBUS 0..31, §4.2; LECOM
    /// 00..99; CAN node ids 1..127).
    pub fn wire_addresses(self) -> RangeInclusive<u8> {
        match self {
            BusProtocol::Lustbus => 0..=31,
            BusProtocol::Lecom => 0..=99,
            BusProtocol::CanSdo => 1..=127,
        }
    }

    /// The rule [`BusProtocol::wire_addresses`] follows, in words.
    pub fn wire_address_rule(self) -> &'static str {
        match self {
            BusProtocol::Lustbus => "LUSTBUS addresses are 0..31 (0 all devices, 31 broadcast)",
            BusProtocol::Lecom => {
                "LECOM addresses are 00..99 (00 broadcast, 10, 20, ... 90 groups)"
            }
            BusProtocol::CanSdo => "CAN node ids are 1..127",
        }
    }

    /// Check a drive's own address. The one address rule: every refusal
    /// of an address as a drive's own (manifest, simulator, CLI, engine) is
    /// rendered from the [`AddressRefusal`] it returns.
    pub fn check_address(self, address: i64) -> Result<(), AddressRefusal> {
        let refuse = |problem, rule| {
            Err(AddressRefusal {
                bus: self,
                address,
                problem,
                rule,
            })
        };
        if self.is_group_address(address) {
            return refuse(
                AddressProblem::Group,
                match self {
                    BusProtocol::Lustbus => {
                        "LUSTBUS address 0 is the group address and 31 the broadcast address; a drive needs its own address 1..30"
                    }
                    _ => {
                        "LECOM 00 is the broadcast address and 10, 20, ... 90 are group addresses; a drive needs its own address 1..99 not ending in 0"
                    }
                },
            );
        }
        let r = self.drive_addresses();
        if address < i64::from(*r.start()) || address > i64::from(*r.end()) {
            return refuse(
                AddressProblem::OutOfRange,
                match self {
                    BusProtocol::Lustbus => "LUSTBUS drive addresses are 1..30",
                    BusProtocol::Lecom => "LECOM station addresses are 1..99",
                    BusProtocol::CanSdo => "CAN node ids are 1..127",
                },
            );
        }
        Ok(())
    }
}

/// Why [`BusProtocol::check_address`] refused an address as a drive's own:
/// the one typed address refusal. Its `Display` is `address A: RULE`;
/// callers that say more (the bus's name, the manifest line) add it around
/// [`AddressRefusal::rule`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("address {address}: {rule}")]
pub struct AddressRefusal {
    /// The bus protocol whose rule refused it.
    pub bus: BusProtocol,
    /// The address refused.
    pub address: i64,
    /// Group / broadcast or out of range.
    pub problem: AddressProblem,
    /// The rule, in words (LUSTBUS §4.2, LECOM §4c, CAN node ids).
    pub rule: &'static str,
}

impl AddressRefusal {
    /// Kebab-case kind for findings ([`AddressProblem::kind`]).
    pub fn kind(&self) -> &'static str {
        self.problem.kind()
    }

    /// What to do about it: `give the drive its own address 1..30`.
    pub fn hint(&self) -> String {
        let r = self.bus.drive_addresses();
        format!("give the drive its own address {}..{}", r.start(), r.end())
    }
}

/// A bus protocol is written by its name (`lustbus`, `lecom`, `can`), as
/// manifests, reports and refusals spell it.
impl serde::Serialize for BusProtocol {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for BusProtocol {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = <String as serde::Deserialize>::deserialize(d)?;
        BusProtocol::parse(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("unknown bus protocol `{name}`")))
    }
}

impl fmt::Display for BusProtocol {
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
    /// when it does not differ, for RAM values and for other families. The
    /// planner and the client both use this one rule.
    pub fn ack_delay(&self, code: &Code, changes_value: bool) -> Duration {
        match self.eeprom {
            EepromPacing::AckDelay {
                per_byte,
                unknown_width,
            } if changes_value && Self::paced(code) => per_byte * Self::width(code, unknown_width),
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
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_aliases_resolve() {
        for f in Family::ALL {
            assert_eq!(Family::parse(f.name()), Ok(f));
            assert_eq!(
                Family::from_schema_protocol(f.descriptor().schema_protocol),
                Some(f)
            );
        }
        assert_eq!(Family::parse("MC7000"), Ok(Family::Mc6000));
        assert_eq!(Family::parse("vf"), Ok(Family::Vf1000));
        assert_eq!(
            Family::parse("xyz").unwrap_err(),
            "unknown drive family `xyz`: use one of mc6000, vf1000, tmd, ecs"
        );
        assert_eq!(BusProtocol::parse("SDO"), Some(BusProtocol::CanSdo));
        assert_eq!(BusProtocol::parse("can"), Some(BusProtocol::CanSdo));
        assert_eq!(
            BusProtocol::Lustbus.families().collect::<Vec<_>>(),
            [Family::Mc6000, Family::Vf1000]
        );
    }

    #[test]
    fn addresses_follow_the_specs() {
        let l = BusProtocol::Lustbus;
        assert_eq!(
            l.check_address(0).unwrap_err().problem,
            AddressProblem::Group
        );
        assert_eq!(
            l.check_address(31).unwrap_err().problem,
            AddressProblem::Group
        );
        assert_eq!(
            l.check_address(32).unwrap_err().problem,
            AddressProblem::OutOfRange
        );
        assert!(l.check_address(30).is_ok());
        let c = BusProtocol::Lecom;
        for g in [0, 10, 50, 90] {
            assert_eq!(
                c.check_address(g).unwrap_err().problem,
                AddressProblem::Group
            );
        }
        assert!(c.check_address(99).is_ok());
        assert_eq!(
            c.check_address(100).unwrap_err().problem,
            AddressProblem::OutOfRange
        );
        assert_eq!(
            BusProtocol::CanSdo.check_address(0).unwrap_err().problem,
            AddressProblem::OutOfRange
        );
        assert!(BusProtocol::CanSdo.check_address(127).is_ok());
    }

    #[test]
    fn address_refusals_carry_their_rule() {
        let e = BusProtocol::Lustbus.check_address(31).unwrap_err();
        assert_eq!(
            e.to_string(),
            "address 31: LUSTBUS address 0 is the group address and 31 the broadcast address; a drive needs its own address 1..30"
        );
        assert_eq!(e.kind(), "group-address");
        assert_eq!(e.hint(), "give the drive its own address 1..30");
        let e = Family::Tmd.descriptor().check_address(100).unwrap_err();
        assert_eq!(
            e.to_string(),
            "address 100: LECOM station addresses are 1..99"
        );
        assert_eq!(e.kind(), "address-out-of-range");
        assert_eq!(e.hint(), "give the drive its own address 1..99");
        assert_eq!(
            Family::Ecs
                .descriptor()
                .check_address(128)
                .unwrap_err()
                .rule,
            "CAN node ids are 1..127"
        );
        assert_eq!(BusProtocol::Lustbus.wire_addresses(), 0..=31);
        assert_eq!(Family::Vf1000.descriptor().broadcast_address(), Some(31));
        assert_eq!(Family::Tmd.descriptor().broadcast_address(), Some(0));
        assert_eq!(Family::Ecs.descriptor().broadcast_address(), None);
    }

    #[test]
    fn lustbus_facts_come_from_the_descriptor() {
        let mc = Family::Mc6000.descriptor();
        let vf = Family::Vf1000.descriptor();
        for d in [mc, vf] {
            assert_eq!(d.compatible(), [81, 82, 83, 84, 85, 91]);
            assert!(d.is_compatible(85) && d.is_compatible(91));
            assert!(!d.is_compatible(86) && !d.is_compatible(80));
            assert_eq!(d.type_code, Some(91));
            assert_eq!(d.type_code, Some(TYPE));
            assert!(!d.on_can());
        }
        for f in [Family::Tmd, Family::Ecs] {
            let d = f.descriptor();
            assert!(d.compatible().is_empty() && !d.is_compatible(81));
            assert_eq!((d.type_code, d.dialect, d.learning), (None, None, None));
            assert_eq!(d.learned_id(Some("1"), None, 0), None);
        }
        assert!(Family::Ecs.descriptor().on_can());
        assert!(vf.broadcast_as_own && !mc.broadcast_as_own);
        assert_eq!(mc.dataset_code(), Some(80));
        assert_eq!(vf.dataset_code(), None);
        assert_eq!(mc.dialect, Some(Dialect::Mc));
        assert_eq!(Family::from_dialect(Dialect::Vf1000), Family::Vf1000);
        assert_eq!(Family::from_dialect(Dialect::Mc), Family::Mc6000);
        assert_eq!(mc.max_parameter(), Some(999));
        assert_eq!(vf.max_parameter(), Some(99));
        assert_eq!(vf.learning.map(|l| l.default_params()), Some(1..=99));
        assert_eq!(
            mc.learned_id(Some("6.1"), Some("V 2.30/a"), 0xab),
            Some("learned-mc6000-type61-V_2_30_a".to_string())
        );
        assert_eq!(
            vf.learned_id(None, None, 0xab),
            Some("learned-vf1000-typeunknown-d000000ab".to_string())
        );
        assert_eq!(Family::from_learned_stem("vf1000"), Some(Family::Vf1000));
        assert_eq!(Family::from_learned_stem("tmd"), None);
    }

    #[test]
    fn reaction_and_pacing_figures() {
        let mc = Family::Mc6000.descriptor();
        assert_eq!(mc.reaction.longest(true), Duration::from_millis(30));
        assert_eq!(mc.reaction.longest(false), Duration::from_millis(25));
        let vf = Family::Vf1000.descriptor();
        assert_eq!(vf.reaction.longest(true), Duration::from_millis(60));
        assert!(vf.reaction.from_spec());
        assert!(!Family::Tmd.descriptor().reaction.from_spec());
        assert_eq!(mc.dataset.map(|d| d.code), Some(80));
        assert_eq!(vf.long_ack(71, 1), Some(Duration::from_secs(10)));
        assert_eq!(vf.long_ack(71, 0), None);
    }

    fn parsed(text: &str) -> std::sync::Arc<crate::Schema> {
        let mut r = crate::Registry::new();
        r.add_source(crate::error::SourceFile::new("t.toml", text))
            .expect("test schema parses")
    }

    #[test]
    fn the_floor_holds_whatever_a_schema_file_says() {
        use crate::{BitRole, ControlState, RawValue, Role};
        // 416 as a "setpoint" with bit 0 an "inhibit" bit, 4-PROG without a
        // role: the floor makes 416 a control word whose bit 0 starts and
        // PROG a command, and adds the reset bit
        let mc = parsed(
            r#"
[schema]
id = "f"
title = "f"
protocol = "lustbus-mc"
code_style = "lust"

[[code]]
number = 4
name = "PROG"

[[code]]
number = 416
name = "SCTL1"
type = "PT_USIGN16"
role = "setpoint"

[[code.bits]]
name = "hold"
bits = [0, 0]
role = "inhibit"
"#,
        );
        assert_eq!(mc.role_of(4), Some(Role::Command));
        let c = mc.code(416).expect("416");
        assert_eq!(c.role, Some(Role::ControlWord));
        let roles: Vec<(u32, Option<BitRole>)> = c.bits.iter().map(|b| (b.lsb, b.role)).collect();
        assert_eq!(
            roles,
            [(0, Some(BitRole::Start)), (7, Some(BitRole::Reset))]
        );
        assert_eq!(
            mc.control_state(c, &RawValue::Int(1)),
            ControlState::Moving(vec!["hold".into()])
        );
        assert_eq!(
            mc.control_state(c, &RawValue::Int(0)),
            ControlState::Stopped
        );
        // Tmd C0040 whose file widens the stopped values to 0 and 1
        let tmd = parsed(
            r#"
[schema]
id = "g"
title = "g"
protocol = "lecom"
code_style = "lenze"

[[code]]
number = 40
name = "c40"
type = "VD"
stopped = [0, 1]
"#,
        );
        let c = tmd.code(40).expect("40");
        assert_eq!(c.role, Some(Role::ControlWord));
        assert_eq!(c.stopped, [0]);
        assert!(!tmd.control_state(c, &RawValue::Int(10_000)).is_safe());
        assert!(tmd.control_state(c, &RawValue::Int(0)).is_safe());
        // every floor code of the built-in schemas carries its floor role
        let r = crate::Registry::builtin().expect("built-in schemas parse");
        for f in Family::ALL {
            let s = r.get(f.descriptor().schema_id).expect("schema");
            for fl in f.descriptor().floor {
                if let Some(c) = s.code(fl.code) {
                    assert_eq!(c.role, Some(fl.role), "{} {}", s.id, fl.code);
                }
            }
        }
    }

    #[test]
    fn the_built_in_schemas_agree_with_their_descriptors() {
        let r = crate::Registry::builtin().expect("built-in schemas parse");
        for f in Family::ALL {
            let d = f.descriptor();
            let s = r.get(d.schema_id).expect(d.schema_id);
            assert_eq!(s.family, f, "{}", d.schema_id);
            let codes = s
                .identify
                .as_ref()
                .map(|i| i.codes.clone())
                .unwrap_or_default();
            assert_eq!(codes, d.identify, "{}", d.schema_id);
            if let Some(h) = d.dataset {
                assert_eq!(s.code(h.code).map(|c| c.name.as_str()), Some(h.name));
            }
        }
    }

    #[test]
    fn one_pacing_rule_for_planner_and_client() {
        let s = parsed(
            r#"
[schema]
id = "t"
title = "t"
protocol = "lustbus-vf1000"
code_style = "lust"

[[code]]
number = 10
name = "ONE"
kind = "eeprom"
width = 1

[[code]]
number = 11
name = "UNKNOWN"

[[code]]
number = 12
name = "RAM"
kind = "ram-control"
width = 2

[[code]]
number = 13
name = "FSEL"
kind = "fsel-isel"
width = 2
"#,
        );
        let vf = Family::Vf1000.descriptor();
        let ms = Duration::from_millis;
        let c = |n| s.code(n).expect("code");
        assert_eq!(vf.ack_delay(c(10), true), ms(60));
        assert_eq!(vf.ack_delay(c(10), false), ms(0));
        assert_eq!(vf.ack_delay(c(11), true), ms(120));
        assert_eq!(vf.ack_delay(c(12), true), ms(0));
        assert_eq!(vf.ack_delay(c(13), true), ms(120));
        assert_eq!(vf.store_time(c(10)), ms(0));
        let mc = Family::Mc6000.descriptor();
        assert_eq!(mc.store_time(c(10)), ms(15));
        assert_eq!(mc.store_time(c(11)), ms(60));
        assert_eq!(mc.store_time(c(12)), ms(0));
        assert_eq!(mc.ack_delay(c(10), true), ms(0));
    }
}
