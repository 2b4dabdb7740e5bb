//! The Lenze Tmd descriptor data (`lecom-ab-tmd-manual.txt`, Table 1): its role
//! floor and the descriptor.

use super::*;

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

pub(super) const TMD: Descriptor = Descriptor {
    family: Family::Tmd,
    name: "tmd",
    aliases: &[],
    title: "Lenze Tmd",
    schema_protocol: "lecom",
    schema_id: "lenze-tmd",
    bus: BusProtocol::Lecom,
    identify: &[93, 99, 200],
    identify_rules: IdentifyRules {
        without_schema: &[93],
        skips_missing: true,
        software: Some(99),
        probe: &[93, 200],
    },
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
    bus_write: Some(BusWriteSource {
        code: 1,
        writes: &[2, 3],
    }),
    ram_loss: None,
};
