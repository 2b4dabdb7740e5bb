//! The Lenze ECS descriptor data (CiA 402 objects over the system bus,
//! `lenze-system-bus-can-sdo.txt`): its role floor and the descriptor.

use super::*;

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

pub(super) const ECS: Descriptor = Descriptor {
    family: Family::Ecs,
    name: "ecs",
    aliases: &[],
    title: "Lenze ECS",
    schema_protocol: "lenze-can-sdo",
    schema_id: "lenze-ecs",
    bus: BusProtocol::CanSdo,
    identify: &[],
    identify_rules: IdentifyRules {
        without_schema: &[],
        skips_missing: false,
        software: None,
        probe: &[],
    },
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
    bus_write: None,
    ram_loss: None,
};
