//! The Lust SMARTDRIVE VF1000 descriptor data (`lustbus-protocol.txt`): its
//! role floor, line rates and the descriptor.

use super::*;

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

/// §4: frequency inverters "from 2400 Baud to 9600 Baud".
pub const INVERTER_RATES: &[u32] = &[9600, 4800, 2400];

pub(super) const VF1000: Descriptor = Descriptor {
    family: Family::Vf1000,
    name: "vf1000",
    aliases: &["vf"],
    title: "Lust SMARTDRIVE VF1000",
    schema_protocol: "lustbus-vf1000",
    schema_id: "lust-vf1000",
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
    bus_write: None,
    ram_loss: Some(
        "lustbus-protocol.txt §11.1: RAM control sizes (kinds '0', '4') \"lose their values on power down\"",
    ),
};
