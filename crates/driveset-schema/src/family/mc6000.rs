//! The Lust MASTERCONTROL MC6000/7000 descriptor data (`lustbus-protocol.txt`):
//! its role floor, line rates, the 80-SLOAD dataset handshake (§11.4) and
//! the descriptor.

use super::*;

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

/// §4: servocontrollers run "in steps ranging from 2400 Baud to 57600
/// Baud" (the steps are the usual doubling ones plus 38400 and 57600).
pub const SERVO_RATES: &[u32] = &[57600, 38400, 19200, 9600, 4800, 2400];

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

pub(super) const MC6000: Descriptor = Descriptor {
    family: Family::Mc6000,
    name: "mc6000",
    aliases: &["mc7000", "mc"],
    title: "Lust MASTERCONTROL MC6000/7000",
    schema_protocol: "lustbus-mc",
    schema_id: "lust-mc6000",
    bus: BusProtocol::Lustbus,
    identify: &[91],
    identify_rules: IdentifyRules {
        without_schema: &[TYPE],
        skips_missing: false,
        software: None,
        probe: &[TYPE],
    },
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
    bus_write: None,
    ram_loss: Some(
        "lustbus-protocol.txt §11.2.1: RAM control values \"lose their values on power down\"",
    ),
};
