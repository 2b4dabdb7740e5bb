//! MC6000/7000 parameter descriptions (`lustbus-protocol.txt` §11.2): kind, user
//! level, attribute and filter words, subject and activity areas, and the
//! 52-character layout driveset reads and writes (module docs of
//! [`super`]).

use super::*;

/// MC6000/7000 parameter kind (section 11.2.1; note the order differs from
/// VF1000's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum McKind {
    /// `'0'`: RAM actual value, not editable, 0 after a start.
    RamActual,
    /// `'1'`: RAM control value, editable, reference value after a start.
    RamControl,
    /// `'2'`: EEPROM value; a SELECT needs a wait of 5 ms per byte x 3.
    Eeprom,
}

impl McKind {
    /// The kind character.
    pub const fn code(self) -> u8 {
        match self {
            McKind::RamActual => b'0',
            McKind::RamControl => b'1',
            McKind::Eeprom => b'2',
        }
    }
    /// Reads a kind character.
    pub const fn from_code(c: u8) -> Option<Self> {
        match c {
            b'0' => Some(McKind::RamActual),
            b'1' => Some(McKind::RamControl),
            b'2' => Some(McKind::Eeprom),
            _ => None,
        }
    }
}

/// User level byte (section 11.2.1): low nibble read level, high nibble
/// write level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct UserLevel {
    /// Read level 0..=15.
    pub read: u8,
    /// Write level 0..=15.
    pub write: u8,
}

impl UserLevel {
    /// Splits the byte.
    pub const fn from_byte(b: u8) -> Self {
        Self {
            read: b & 0x0F,
            write: b >> 4,
        }
    }
    /// The byte (nibbles above 15 are cut to 4 bits).
    pub const fn to_byte(self) -> u8 {
        ((self.write & 0x0F) << 4) | (self.read & 0x0F)
    }
}

bit_flags! {
    /// Attribute word (section 11.2.1 "The attribute").
    pub struct Attributes: u16 {
        /// Bit 2: the value names another parameter (e.g. BARG).
        const SHOW_PARA_TEXT = 0x0004, "ShowParaText";
        /// Bit 3: FIXPOINT16 shown without decimals.
        const SHOW_NO_FRACT = 0x0008, "ShowNoFract";
        /// Bit 4: FIXPOINT16 shown with one decimal.
        const SHOW_FRACT1 = 0x0010, "ShowFract1";
        /// Bit 5: values shown as substitution texts (usign8 only).
        const SHOW_TEXT = 0x0020, "ShowText";
        /// Bit 6: writing triggers a re-initialisation.
        const INIT_CONTROL = 0x0040, "InitControl";
        /// Bit 7: RAM control value not pre-initialised at start.
        const NO_INIT = 0x0080, "NoInit";
        /// Bit 8: shown in hex.
        const SHOW_HEX = 0x0100, "ShowHex";
        /// Bit 9: a password.
        const PASSWORD = 0x0200, "Password";
    }
}

bit_flags! {
    /// Hardware filter word (section 11.2.1). MPTC is bit 14, mask 0x4000:
    /// the spec's table prints 8000H for both MPTC and Brake (errata).
    pub struct HardwareFilter: u16 {
        /// Bit 0: resolver.
        const RESOLVER = 0x0001, "Resolver";
        /// Bit 1: sin incremental encoder.
        const ENCODER_SIN = 0x0002, "EncoderSin";
        /// Bit 2: square-wave incremental encoder.
        const ENCODER_REC = 0x0004, "EncoderRec";
        /// Bit 3: SSI single-turn.
        const ENCD_SSI_SINGLE = 0x0008, "EncdSsiSingle";
        /// Bit 4: SSI multi-turn.
        const ENCD_SSI_MULTI = 0x0010, "EncdSsiMulti";
        /// Bit 5: option slot 1.
        const OPTION1 = 0x0020, "Option1";
        /// Bit 6: option slot 2.
        const OPTION2 = 0x0040, "Option2";
        /// Bit 7: asynchronous machine.
        const ASM = 0x0080, "ASM";
        /// Bit 8: synchronous machine.
        const SM = 0x0100, "SM";
        /// Bit 9: special drive.
        const SPECIAL_DRIVE = 0x0200, "Special-drive";
        /// Bit 10: EA extension 1.
        const EA1 = 0x0400, "EA1";
        /// Bit 11: EA extension 2.
        const EA2 = 0x0800, "EA2";
        /// Bit 12: CAN module.
        const CAN = 0x1000, "CAN";
        /// Bit 13: memory extension.
        const EXTENDED_MEMORY = 0x2000, "Extended Memory";
        /// Bit 14: motor PTC (table: "8000H", errata).
        const MPTC = 0x4000, "MPTC";
        /// Bit 15: brake driver.
        const BRAKE = 0x8000, "Brake";
    }
}

bit_flags! {
    /// Structure filter word (section 11.2.1).
    pub struct StructureFilter: u16 {
        /// Bit 0: torque control.
        const TORQUE_CTRL = 0x0001, "TorqueCtrl";
        /// Bit 1: speed control.
        const SPEED_CTRL = 0x0002, "SpeedCtrl";
        /// Bit 2: position control.
        const POS_CTRL = 0x0004, "PosCtrl";
        /// Bit 3: voltage-frequency control.
        const VF_CONV = 0x0008, "VF_Conv";
        /// Bit 4: electric master.
        const E_MASTER = 0x0010, "EMaster";
        /// Bit 5: electric slave.
        const E_SLAVE = 0x0020, "ESlave";
    }
}

const SUBJECTS: [(&str, &str); 22] = [
    ("CONF", "System configuration"),
    ("ENCD", "Encoder"),
    ("OPT1", "Option slot 1"),
    ("OPT2", "Option slot 2"),
    ("MOT", "Motor type"),
    ("TCON", "Torque control"),
    ("SCON", "Speed control"),
    ("PCON", "Position control"),
    ("VFCN", "Voltage-frequency characteristic curve"),
    ("SIO", "Serial interface"),
    ("KPAD", "KEYPAD"),
    ("PWM", "Pulse-width modulation"),
    ("SCTY", "Security-and-error-reaction parameter"),
    (
        "USER",
        "Special user-triggered parameter from special software",
    ),
    ("SYS", "Diagnosis and digital scope"),
    ("REF", "Reference value structure"),
    ("IO1", "EA-extension 1"),
    ("IO2", "EA-extension 2"),
    ("CAN", "CAN-bus"),
    ("PMOD", "Positioner unit"),
    ("MENU", "Parameter for menu control on the KEYPAD KP100"),
    (
        "VAL",
        "Actual value parameter from the VAL menu of the KEYPAD",
    ),
];

/// Subject area 0..=21 (section 11.2.1 "Filtering the Subject Area").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SubjectArea(u8);

impl SubjectArea {
    /// A defined area 0..=21.
    pub const fn new(n: u8) -> Option<Self> {
        if (n as usize) < SUBJECTS.len() {
            Some(Self(n))
        } else {
            None
        }
    }
    /// Sequential number.
    pub const fn number(self) -> u8 {
        self.0
    }
    /// Abbreviation, e.g. `"MOT"`.
    pub const fn abbreviation(self) -> &'static str {
        SUBJECTS[self.0 as usize].0
    }
    /// Description, e.g. `"Motor type"`.
    pub const fn description(self) -> &'static str {
        SUBJECTS[self.0 as usize].1
    }
}

const ACTIVITIES: [(&str, &str); 9] = [
    ("SC_Nothing", "Not for data exchange with the SMARTCARD"),
    ("SC_OPT1", "Programming of optional slot 1"),
    ("SC_OPT2", "Programming of optional slot 2"),
    ("SC_APP", "Equipment specific parameter"),
    ("SC_SYS", "General system parameter"),
    (
        "SC_DRIVE",
        "Parameter for configuration of the drive system",
    ),
    (
        "SC_REF",
        "Parameter for EA's and the reference value generation",
    ),
    ("SC_CAN", "Parameter for CAN-bus"),
    ("SC_PMOD", "Parameter for Positioner Unit"),
];

/// SMARTCARD activity area 0..=8 (section 11.2.1). 0 means the parameter
/// is *not* for SMARTCARD/database exchange (the table's description of
/// SC_Nothing says the opposite; errata).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ActivityArea(u8);

impl ActivityArea {
    /// A defined area 0..=8.
    pub const fn new(n: u8) -> Option<Self> {
        if (n as usize) < ACTIVITIES.len() {
            Some(Self(n))
        } else {
            None
        }
    }
    /// Value.
    pub const fn number(self) -> u8 {
        self.0
    }
    /// Reference name, e.g. `"SC_DRIVE"`.
    pub const fn name(self) -> &'static str {
        ACTIVITIES[self.0 as usize].0
    }
    /// Description.
    pub const fn description(self) -> &'static str {
        ACTIVITIES[self.0 as usize].1
    }
    /// Whether the parameter takes part in SMARTCARD / SLOAD exchange.
    pub const fn card_exchange(self) -> bool {
        self.0 != 0
    }
}

/// The extended MC description (from "Level" on) in driveset's layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct McExtension {
    /// Read and write level.
    pub level: UserLevel,
    /// Attribute bits.
    pub attributes: Attributes,
    /// Hardware filter bits.
    pub hardware: HardwareFilter,
    /// Structure filter bits.
    pub structure: StructureFilter,
    /// Subject area number (see [`McExtension::subject_area`]).
    pub subject: u8,
    /// Activity area number (see [`McExtension::activity_area`]).
    pub activity: u8,
}

impl McExtension {
    /// The subject area, if the number is defined.
    pub const fn subject_area(&self) -> Option<SubjectArea> {
        SubjectArea::new(self.subject)
    }
    /// The activity area, if the number is defined.
    pub const fn activity_area(&self) -> Option<ActivityArea> {
        ActivityArea::new(self.activity)
    }
}

/// What followed the reference value in a received MC description.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum McExtended {
    /// 34 characters: only the basic description.
    Absent,
    /// 52 characters: driveset's layout, decoded.
    Decoded(McExtension),
    /// 42/43 characters laid out as the table literally reads: the 9 or 10
    /// characters after the reference value, uninterpreted.
    Literal {
        /// The raw characters.
        raw: [u8; 10],
        /// How many of `raw` are valid (9 or 10).
        len: u8,
    },
}

/// MC6000/7000 parameter description (section 11.2), the VALUE of CODE
/// `3 0 ppp`; layout in the module docs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct McDescription {
    /// Short name (at most 5 characters on the wire).
    pub name: ShortText,
    /// Unit: index into the 107-UNIT substitution texts.
    pub unit: u8,
    /// Kind.
    pub kind: McKind,
    /// Type.
    pub ty: ParameterType,
    /// Minimum, the 32-bit raw value as transmitted.
    pub min: u32,
    /// Maximum, raw.
    pub max: u32,
    /// Reference value (factory default), raw.
    pub default: u32,
    /// Level, attribute, filters and areas.
    pub extended: McExtended,
}

impl McDescription {
    /// Length [`McDescription::encode`] writes.
    pub const LEN: usize = 52;
    /// Length of the basic part (through the reference value).
    pub const BASIC_LEN: usize = 34;

    /// Decodes 34, 42, 43 or 52 characters (see the module docs).
    pub fn decode(v: &[u8]) -> Result<Self, DescriptionError> {
        let literal = matches!(v.len(), 42 | 43);
        if !(literal || v.len() == Self::BASIC_LEN || v.len() == Self::LEN) {
            return Err(DescriptionError::Length {
                family: Dialect::Mc,
                found: v.len(),
                expected: "52 (34 basic; 42/43 literal table layout)",
            });
        }
        let name = ShortText::read("name", 0, &v[0..6])?;
        // Offsets of unit, kind, type, min in the two layouts.
        let (unit, k, base) = if literal {
            (v[6], 7, 9)
        } else {
            (hex_field("unit", v, 6, 2)? as u8, 8, 10)
        };
        let kind = McKind::from_code(v[k]).ok_or(DescriptionError::Kind {
            offset: k,
            found: v[k],
            expected: "'0', '1', '2'",
        })?;
        let ty = ParameterType::from_code(v[k + 1])
            .filter(|t| t.in_family(Dialect::Mc))
            .ok_or(DescriptionError::Type {
                offset: k + 1,
                found: v[k + 1],
                family: Dialect::Mc,
            })?;
        let min = hex_field("minimum", v, base, 8)?;
        let max = hex_field("maximum", v, base + 8, 8)?;
        let default = hex_field("reference value", v, base + 16, 8)?;
        let rest = base + 24;
        let extended = if literal {
            let mut raw = [0u8; 10];
            let tail = &v[rest..];
            raw[..tail.len()].copy_from_slice(tail);
            McExtended::Literal {
                raw,
                len: tail.len() as u8,
            }
        } else if v.len() == Self::BASIC_LEN {
            McExtended::Absent
        } else {
            McExtended::Decoded(McExtension {
                level: UserLevel::from_byte(hex_field("level", v, 34, 2)? as u8),
                attributes: Attributes(hex_field("attribute", v, 36, 4)? as u16),
                hardware: HardwareFilter(hex_field("hardware filter", v, 40, 4)? as u16),
                structure: StructureFilter(hex_field("structure filter", v, 44, 4)? as u16),
                subject: hex_field("subject area", v, 48, 2)? as u8,
                activity: hex_field("activity area", v, 50, 2)? as u8,
            })
        };
        Ok(Self {
            name,
            unit,
            kind,
            ty,
            min,
            max,
            default,
            extended,
        })
    }

    /// Encodes driveset's 52-character layout ([`McExtended::Decoded`]), or
    /// the 34-character basic part if the extension is [`McExtended::Absent`];
    /// a [`McExtended::Literal`] extension is written as all zeros.
    pub fn encode(&self) -> Result<ValueText, DescriptionError> {
        if !self.ty.in_family(Dialect::Mc) {
            return Err(DescriptionError::TypeNotInFamily {
                ty: self.ty,
                family: Dialect::Mc,
            });
        }
        let name = self.name.as_bytes();
        if name.len() > 5 {
            return Err(DescriptionError::TooLong {
                field: "name",
                max: 5,
                found: name.len(),
            });
        }
        if let Some(&c) = name
            .iter()
            .find(|c| !(c.is_ascii_uppercase() || c.is_ascii_digit() || **c == b'_' || **c == b'-'))
        {
            return Err(DescriptionError::BadChar {
                field: "name",
                found: c,
            });
        }
        let mut out = [0u8; Self::LEN];
        out[..name.len()].copy_from_slice(name);
        let mut put = |at: usize, width: usize, v: u32| {
            let mut h = [0u8; 8];
            hex_into(v, Some(width), &mut h);
            out[at..at + width].copy_from_slice(&h[..width]);
        };
        put(6, 2, u32::from(self.unit));
        put(10, 8, self.min);
        put(18, 8, self.max);
        put(26, 8, self.default);
        let ext = match self.extended {
            McExtended::Absent => None,
            McExtended::Decoded(e) => Some(e),
            McExtended::Literal { .. } => Some(McExtension::default()),
        };
        if let Some(e) = ext {
            put(34, 2, u32::from(e.level.to_byte()));
            put(36, 4, u32::from(e.attributes.0));
            put(40, 4, u32::from(e.hardware.0));
            put(44, 4, u32::from(e.structure.0));
            put(48, 2, u32::from(e.subject));
            put(50, 2, u32::from(e.activity));
        }
        out[8] = self.kind.code();
        out[9] = self.ty.code();
        let len = if ext.is_some() {
            Self::LEN
        } else {
            Self::BASIC_LEN
        };
        Ok(ValueText::from_valid(&out[..len]))
    }

    fn typed(&self, raw: u32) -> Option<ParameterValue> {
        // A C device holding min/max in a long sign-extends PT_INTEGER16.
        let raw = if self.ty == ParameterType::Integer16 && raw >= 0xFFFF_8000 {
            raw & 0xFFFF
        } else {
            raw
        };
        ParameterValue::from_raw(self.ty, raw)
    }
    /// The minimum as a typed value.
    pub fn min_value(&self) -> Option<ParameterValue> {
        self.typed(self.min)
    }
    /// The maximum as a typed value.
    pub fn max_value(&self) -> Option<ParameterValue> {
        self.typed(self.max)
    }
    /// The reference value as a typed value.
    pub fn default_value(&self) -> Option<ParameterValue> {
        self.typed(self.default)
    }
}
