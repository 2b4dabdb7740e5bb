//! Parameter descriptions and value substitution texts: the VALUE of an
//! ENQUIRY with specifier 1 on VF1000 (section 11.1, 26 characters) or
//! specifier 3 on MC6000/7000 (section 11.2), and the text of CODE `61xxx`
//! (section 11.3).
//!
//! # VF1000 layout (section 11.1), 26 characters
//!
//! | offset | chars | element | coding |
//! |---|---|---|---|
//! | 0 | 6 | name | right-justified, blank-padded |
//! | 6 | 6 | unit | right-justified, blank-padded |
//! | 12 | 1 | kind | `'0'..'7'`, see [`VfKind`] |
//! | 13 | 1 | type | `'1'..'6'`, see [`ParameterType::code`] |
//! | 14 | 4 | minimum | 4 hex, like the value |
//! | 18 | 4 | maximum | 4 hex |
//! | 22 | 4 | basis (default) | 4 hex |
//!
//! # MC6000/7000 layout: driveset's interpretation, 52 characters
//!
//! The section 11.2 table gives element lengths "in bytes" that add up to
//! 42 while its total says 43, and puts binary bytes and 16-bit words
//! (level, attribute, filters, areas) into a 7-bit ASCII telegram, where a
//! raw byte could be a framing control character (ETX, EOT) and could not
//! carry bit 7 at all. Only the kind is said to be a printable character.
//! No 43-character layout carries every documented bit in printable
//! characters, so driveset uses one coherent rule: **text stays text, the
//! kind and type stay one character, every binary byte travels as two
//! uppercase hex digits** (like every other LUSTBUS number):
//!
//! | offset | chars | element | coding |
//! |---|---|---|---|
//! | 0 | 6 | name | up to 5 characters, then `'\0'` (NUL-padded) |
//! | 6 | 2 | unit | hex byte, index into the 107-UNIT substitution texts |
//! | 8 | 1 | kind | `'0'` RAM actual, `'1'` RAM control, `'2'` EEPROM |
//! | 9 | 1 | type | [`ParameterType::code`] |
//! | 10 | 8 | minimum | 8 hex (32 bits) |
//! | 18 | 8 | maximum | 8 hex |
//! | 26 | 8 | reference value (default) | 8 hex |
//! | 34 | 2 | level | hex byte: high nibble write level, low nibble read level |
//! | 36 | 4 | attribute | hex word, [`Attributes`] |
//! | 40 | 4 | hardware filter | hex word, [`HardwareFilter`] |
//! | 44 | 4 | structure filter | hex word, [`StructureFilter`] |
//! | 48 | 2 | subject area | hex byte, [`SubjectArea`] 0..=21 |
//! | 50 | 2 | activity area | hex byte, [`ActivityArea`] 0..=8 |
//!
//! [`McDescription::encode`] always writes these 52 characters. The decoder
//! also accepts the first 34 (the spec: "up to the element reference value
//! is sufficient") and, tolerantly, 42 or 43 characters laid out literally
//! as the table reads (name 6, unit 1 raw character, kind 1, type 1, three
//! times 8 hex), keeping the remaining 9 or 10 characters uninterpreted in
//! [`McExtended::Literal`] because their coding is unknowable from the spec.
//! See `docs/errata/lustbus.md`, "MC description length and coding".

use core::fmt;

use thiserror::Error;

use super::frame::{Address, Enquiry, ParameterCode, Select, ValueText};
use super::value::{Dialect, ParameterType, ParameterValue, ValueError, hex_into, parse_hex};

/// Why a description or substitution text could not be read or written.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum DescriptionError {
    /// Wrong VALUE length.
    #[error("{family} parameter description has {found} characters; expected {expected}")]
    Length {
        /// Dialect.
        family: Dialect,
        /// Characters received.
        found: usize,
        /// Accepted lengths.
        expected: &'static str,
    },
    /// A numeric element is not valid hex.
    #[error("description element {field} (characters {offset}..): {error}")]
    Field {
        /// Element name.
        field: &'static str,
        /// Offset of the element in VALUE.
        offset: usize,
        /// What is wrong.
        error: ValueError,
    },
    /// A text element holds a character that is not printable ASCII.
    #[error("description element {field}: character {offset} is {found:#04x}, not printable ASCII")]
    Text {
        /// Element name.
        field: &'static str,
        /// Offset in VALUE.
        offset: usize,
        /// The character.
        found: u8,
    },
    /// The kind character is not defined.
    #[error("parameter kind character {found:#04x} at {offset} is not one of {expected}")]
    Kind {
        /// Offset in VALUE.
        offset: usize,
        /// The character.
        found: u8,
        /// The valid characters.
        expected: &'static str,
    },
    /// The type character is not defined (or not of the family).
    #[error("parameter type character {found:#04x} at {offset} is not a {family} type")]
    Type {
        /// Offset in VALUE.
        offset: usize,
        /// The character.
        found: u8,
        /// Dialect.
        family: Dialect,
    },
    /// Encoding: an element does not fit.
    #[error("description element {field} is {found} characters; at most {max} fit")]
    TooLong {
        /// Element name.
        field: &'static str,
        /// Maximum.
        max: usize,
        /// Given.
        found: usize,
    },
    /// Encoding: a name or unit holds a character that cannot be sent.
    #[error("description element {field}: character {found:#04x} is not allowed")]
    BadChar {
        /// Element name.
        field: &'static str,
        /// The character.
        found: u8,
    },
    /// Encoding: the type does not exist on the family.
    #[error("{ty} does not exist on {family}")]
    TypeNotInFamily {
        /// Type.
        ty: ParameterType,
        /// Dialect.
        family: Dialect,
    },
    /// Encoding: a VF1000 value area element is wider than 16 bits.
    #[error("VF1000 description {field} {value:#X} does not fit 4 hex digits")]
    ValueTooWide {
        /// Element name.
        field: &'static str,
        /// The value.
        value: u32,
    },
}

/// A short text element (name or unit, at most 6 characters), trimmed.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ShortText {
    len: u8,
    bytes: [u8; 6],
}

impl ShortText {
    /// Up to 6 printable ASCII characters.
    pub fn new(s: &str) -> Option<Self> {
        let b = s.as_bytes();
        if b.len() > 6 || !b.iter().all(|c| (0x20..=0x7E).contains(c)) {
            return None;
        }
        let mut t = Self::default();
        t.bytes[..b.len()].copy_from_slice(b);
        t.len = b.len() as u8;
        Some(t)
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        // Only printable ASCII is ever stored.
        core::str::from_utf8(&self.bytes[..self.len as usize]).unwrap_or("")
    }

    fn as_bytes(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }

    /// Reads a padded field: NUL ends it, blanks and NULs around it are
    /// padding; anything else non-printable is an error.
    fn read(field: &'static str, base: usize, raw: &[u8]) -> Result<Self, DescriptionError> {
        let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
        let body = &raw[..end];
        if let Some(i) = body.iter().position(|b| !(0x20..=0x7E).contains(b)) {
            return Err(DescriptionError::Text {
                field,
                offset: base + i,
                found: body[i],
            });
        }
        if let Some(i) = raw[end..].iter().position(|&b| b != 0 && b != b' ') {
            return Err(DescriptionError::Text {
                field,
                offset: base + end + i,
                found: raw[end + i],
            });
        }
        let s = core::str::from_utf8(body).unwrap_or("").trim_matches(' ');
        Ok(Self::new(s).unwrap_or_default())
    }
}

impl fmt::Debug for ShortText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

impl fmt::Display for ShortText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Storage of a VF1000 parameter (section 11.1 "Parameter kind").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VfStorage {
    /// RAM control size: editable, lost on power down.
    RamControl,
    /// RAM actual value: display only.
    RamActual,
    /// EEPROM: kept; on SMARTDRIVE editable only at motor standstill.
    Eeprom,
    /// FSEL/ISEL variable: RAM when controlled via the serial interface
    /// (CSEL = 3), EEPROM when CSEL < 3 (the spec's "CSEL <= 3" overlaps,
    /// errata).
    FselIsel,
}

/// VF1000 parameter kind `'0'..='7'` (section 11.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VfKind {
    /// Storage class.
    pub storage: VfStorage,
    /// `'4'..='7'`: inverter-specific parameter, reachable only with the
    /// specific device number in CODE; `'0'..='3'`: basis parameter (device
    /// number 0 or the specific one).
    pub inverter_specific: bool,
}

impl VfKind {
    /// The kind character.
    pub const fn code(self) -> u8 {
        let s = match self.storage {
            VfStorage::RamControl => 0,
            VfStorage::RamActual => 1,
            VfStorage::Eeprom => 2,
            VfStorage::FselIsel => 3,
        };
        b'0' + s + if self.inverter_specific { 4 } else { 0 }
    }

    /// Reads a kind character.
    pub const fn from_code(c: u8) -> Option<Self> {
        if c < b'0' || c > b'7' {
            return None;
        }
        let n = c - b'0';
        let storage = match n % 4 {
            0 => VfStorage::RamControl,
            1 => VfStorage::RamActual,
            2 => VfStorage::Eeprom,
            _ => VfStorage::FselIsel,
        };
        Some(Self {
            storage,
            inverter_specific: n >= 4,
        })
    }
}

fn hex_field(
    field: &'static str,
    v: &[u8],
    offset: usize,
    len: usize,
) -> Result<u32, DescriptionError> {
    parse_hex(&v[offset..offset + len]).map_err(|error| DescriptionError::Field {
        field,
        offset,
        error: match error {
            ValueError::NotHex { offset: o, found } => ValueError::NotHex {
                offset: offset + o,
                found,
            },
            e => e,
        },
    })
}

/// VF1000 parameter description (section 11.1), the 26-character VALUE of
/// CODE `1 0 d pp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VfDescription {
    /// Parameter name, e.g. `FSSIO`.
    pub name: ShortText,
    /// Unit abbreviation, e.g. `Hz`.
    pub unit: ShortText,
    /// Kind.
    pub kind: VfKind,
    /// Data type.
    pub ty: ParameterType,
    /// Minimum, raw (same scaling as the value).
    pub min: u16,
    /// Maximum, raw.
    pub max: u16,
    /// Basis value (factory default), raw.
    pub default: u16,
}

impl VfDescription {
    /// VALUE length.
    pub const LEN: usize = 26;

    /// Decodes the 26-character VALUE.
    pub fn decode(v: &[u8]) -> Result<Self, DescriptionError> {
        if v.len() != Self::LEN {
            return Err(DescriptionError::Length {
                family: Dialect::Vf1000,
                found: v.len(),
                expected: "26",
            });
        }
        let name = ShortText::read("name", 0, &v[0..6])?;
        let unit = ShortText::read("unit", 6, &v[6..12])?;
        let kind = VfKind::from_code(v[12]).ok_or(DescriptionError::Kind {
            offset: 12,
            found: v[12],
            expected: "'0'..='7'",
        })?;
        let ty = ParameterType::from_code(v[13])
            .filter(|t| t.in_family(Dialect::Vf1000))
            .ok_or(DescriptionError::Type {
                offset: 13,
                found: v[13],
                family: Dialect::Vf1000,
            })?;
        Ok(Self {
            name,
            unit,
            kind,
            ty,
            min: hex_field("minimum", v, 14, 4)? as u16,
            max: hex_field("maximum", v, 18, 4)? as u16,
            default: hex_field("basis value", v, 22, 4)? as u16,
        })
    }

    /// Encodes the 26-character VALUE (name and unit right-justified).
    pub fn encode(&self) -> Result<ValueText, DescriptionError> {
        if !self.ty.in_family(Dialect::Vf1000) {
            return Err(DescriptionError::TypeNotInFamily {
                ty: self.ty,
                family: Dialect::Vf1000,
            });
        }
        let mut out = [b' '; Self::LEN];
        let n = self.name.as_bytes();
        out[6 - n.len()..6].copy_from_slice(n);
        let u = self.unit.as_bytes();
        out[12 - u.len()..12].copy_from_slice(u);
        out[12] = self.kind.code();
        out[13] = self.ty.code();
        for (i, v) in [self.min, self.max, self.default].into_iter().enumerate() {
            let mut h = [0u8; 8];
            hex_into(u32::from(v), Some(4), &mut h);
            out[14 + 4 * i..18 + 4 * i].copy_from_slice(&h[..4]);
        }
        Ok(ValueText::from_valid(&out))
    }

    /// The minimum as a typed value.
    pub fn min_value(&self) -> Option<ParameterValue> {
        ParameterValue::from_raw(self.ty, u32::from(self.min))
    }
    /// The maximum as a typed value.
    pub fn max_value(&self) -> Option<ParameterValue> {
        ParameterValue::from_raw(self.ty, u32::from(self.max))
    }
    /// The default as a typed value.
    pub fn default_value(&self) -> Option<ParameterValue> {
        ParameterValue::from_raw(self.ty, u32::from(self.default))
    }
}

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

/// The MC description layouts driveset accepts (errata L22: section 11.2
/// gives element lengths adding up to 42 and a total of 43, and binary
/// bytes in a 7-bit telegram, so drives may differ). Told apart by length
/// and content ([`McLayout::candidates`]); a caller may also name one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum McLayout {
    /// 52 characters, driveset's reading (module docs): every binary byte
    /// as two hex digits.
    Hex52,
    /// 43 characters: the table read literally with the one-byte elements
    /// as printable characters (unit, level, subject and activity one
    /// character each, attribute and filters two), plus one closing
    /// character (section 11.2's "Total length 43").
    Table43,
    /// 42 characters: the table read literally (the sum of its element
    /// lengths), one-byte elements as printable characters.
    Table42,
    /// 34 characters: name, unit (two hex digits), kind, type, minimum,
    /// maximum and reference value only ("up to the element reference
    /// value is sufficient").
    Basic34,
}

impl McLayout {
    /// Every layout, in the order [`McLayout::candidates`] prefers them.
    pub const ALL: [McLayout; 4] = [
        McLayout::Hex52,
        McLayout::Table43,
        McLayout::Table42,
        McLayout::Basic34,
    ];

    /// The VALUE length of the layout.
    pub const fn value_len(self) -> usize {
        match self {
            McLayout::Hex52 => 52,
            McLayout::Table43 => 43,
            McLayout::Table42 => 42,
            McLayout::Basic34 => 34,
        }
    }

    /// The name used on the command line and in files (`"52"`, `"43"`,
    /// `"42"`, `"34"`).
    pub const fn name(self) -> &'static str {
        match self {
            McLayout::Hex52 => "52",
            McLayout::Table43 => "43",
            McLayout::Table42 => "42",
            McLayout::Basic34 => "34",
        }
    }

    /// Parses [`McLayout::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|l| l.name() == s)
    }

    /// Whether the unit, kind and type follow the literal table (unit one
    /// character at offset 6).
    const fn literal(self) -> bool {
        matches!(self, McLayout::Table43 | McLayout::Table42)
    }

    /// Offsets of the unit, the kind character and the minimum.
    const fn offsets(self) -> (usize, usize, usize) {
        if self.literal() {
            (6, 7, 9)
        } else {
            (6, 8, 10)
        }
    }

    /// The layouts a VALUE of this length and content can be: the length
    /// must match, the kind must be a kind character and the three value
    /// elements hex. Usually one; empty when none fits.
    pub fn candidates(v: &[u8]) -> Vec<McLayout> {
        Self::ALL
            .into_iter()
            .filter(|l| l.value_len() == v.len() && McRawDescription::decode(v, *l).is_ok())
            .collect()
    }
}

/// The MC type characters in the order section 2.3.2 tables the types
/// (PT_USIGN8 .. PT_PASSWORD as `'1'..'8'`): one reading of the open
/// question L23. driveset's own characters are [`ParameterType::code`].
pub const TABLE_ORDER_TYPES: [ParameterType; 8] = [
    ParameterType::Usign8,
    ParameterType::Usign16,
    ParameterType::Fixpoint16,
    ParameterType::Integer16,
    ParameterType::Int32Q16,
    ParameterType::FloatIeee,
    ParameterType::McError,
    ParameterType::Password,
];

/// How the type character of an MC description is read (errata L23).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum McTypeChars {
    /// driveset's characters ([`ParameterType::code`]: VF1000's '2' '3' '4'
    /// '6', then '7' INTEGER16, '8' INT32Q16, '9' FLOAT_IEEE, 'A' MC_ERROR).
    Driveset,
    /// Section 2.3.2's table order ([`TABLE_ORDER_TYPES`], '1'..'8').
    Table,
    /// An explicit map (character, type); characters it does not name are
    /// unknown.
    Map(Vec<(u8, ParameterType)>),
}

impl McTypeChars {
    /// The type of a character, `None` if this reading does not know it.
    pub fn type_of(&self, c: u8) -> Option<ParameterType> {
        match self {
            McTypeChars::Driveset => {
                ParameterType::from_code(c).filter(|t| t.in_family(Dialect::Mc))
            }
            McTypeChars::Table => c
                .checked_sub(b'1')
                .and_then(|i| TABLE_ORDER_TYPES.get(usize::from(i)).copied()),
            McTypeChars::Map(m) => m.iter().find(|(k, _)| *k == c).map(|(_, t)| *t),
        }
    }

    /// The character of a type, `None` if this reading has none for it.
    pub fn char_of(&self, ty: ParameterType) -> Option<u8> {
        match self {
            McTypeChars::Driveset => ty.in_family(Dialect::Mc).then(|| ty.code()),
            McTypeChars::Table => TABLE_ORDER_TYPES
                .iter()
                .position(|t| *t == ty)
                .map(|i| b'1' + i as u8),
            McTypeChars::Map(m) => m.iter().find(|(_, t)| *t == ty).map(|(k, _)| *k),
        }
    }

    /// The name used on the command line (`driveset`, `table`, or the map
    /// as `C=TYPE,...`).
    pub fn name(&self) -> String {
        match self {
            McTypeChars::Driveset => "driveset".into(),
            McTypeChars::Table => "table".into(),
            McTypeChars::Map(m) => m
                .iter()
                .map(|(c, t)| format!("{}={}", *c as char, t.name()))
                .collect::<Vec<_>>()
                .join(","),
        }
    }

    /// Parses `driveset`, `table`, or a map `1=PT_USIGN8,2=PT_USIGN16,...`
    /// (one printable character per entry, MC type names with or without
    /// the `PT_` prefix, any case).
    pub fn parse(s: &str) -> Result<Self, String> {
        match s.trim() {
            "driveset" => return Ok(McTypeChars::Driveset),
            "table" => return Ok(McTypeChars::Table),
            _ => {}
        }
        let mut map = Vec::new();
        for item in s.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let Some((c, t)) = item.split_once('=') else {
                return Err(format!(
                    "`{item}` is not CHAR=TYPE (e.g. 1=PT_USIGN8); or use `driveset` or `table`"
                ));
            };
            let c = c.trim().as_bytes();
            if c.len() != 1 || !(0x21..=0x7E).contains(&c[0]) {
                return Err(format!(
                    "`{item}`: the type character must be one printable character"
                ));
            }
            let t = t.trim().to_ascii_uppercase();
            let t = if t.starts_with("PT_") {
                t
            } else {
                format!("PT_{t}")
            };
            let Some(ty) = ALL_PARAMETER_TYPES
                .into_iter()
                .find(|ty| ty.name() == t && ty.in_family(Dialect::Mc))
            else {
                return Err(format!(
                    "`{item}`: {t} is not an MC6000/7000 type (PT_USIGN8, PT_USIGN16, PT_FIXPOINT16, PT_INTEGER16, PT_INT32Q16, PT_FLOAT_IEEE, PT_MC_ERROR, PT_PASSWORD)"
                ));
            };
            if map.iter().any(|(k, _)| *k == c[0]) {
                return Err(format!("`{item}`: character given twice"));
            }
            map.push((c[0], ty));
        }
        if map.is_empty() {
            return Err("the type-character map is empty".into());
        }
        Ok(McTypeChars::Map(map))
    }
}

const ALL_PARAMETER_TYPES: [ParameterType; 10] = [
    ParameterType::Binary8,
    ParameterType::Fixpoint16,
    ParameterType::Usign16,
    ParameterType::Usign8,
    ParameterType::VfError,
    ParameterType::Password,
    ParameterType::Integer16,
    ParameterType::Int32Q16,
    ParameterType::FloatIeee,
    ParameterType::McError,
];

/// An MC description read in one [`McLayout`] without interpreting the
/// type character (which reading applies is decided over all of a drive's
/// descriptions, errata L23).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct McRawDescription {
    /// The layout it was read in.
    pub layout: McLayout,
    /// Short name.
    pub name: ShortText,
    /// Unit index into 107-UNIT: two hex digits in [`McLayout::Hex52`] /
    /// [`McLayout::Basic34`]; in the literal layouts one character, read as
    /// `c - '0'` when it is `'0'` or above (printable, like the kind) and
    /// as the raw character below.
    pub unit: u8,
    /// Kind.
    pub kind: McKind,
    /// The type character as transmitted.
    pub type_char: u8,
    /// Minimum, raw 32 bits.
    pub min: u32,
    /// Maximum, raw.
    pub max: u32,
    /// Reference value, raw.
    pub default: u32,
    /// Level, attribute, filters and areas, where the layout carries them
    /// and they read (literal layouts: each byte a character `'0' + n`).
    pub extension: Option<McExtension>,
}

impl McRawDescription {
    /// Reads `v` in `layout` (the length must be the layout's).
    pub fn decode(v: &[u8], layout: McLayout) -> Result<Self, DescriptionError> {
        if v.len() != layout.value_len() {
            return Err(DescriptionError::Length {
                family: Dialect::Mc,
                found: v.len(),
                expected: "52, 43, 42 or 34 (the layout's length)",
            });
        }
        let name = ShortText::read("name", 0, &v[0..6])?;
        let (u, k, base) = layout.offsets();
        let unit = if layout.literal() {
            let c = v[u];
            if c >= b'0' { c - b'0' } else { c }
        } else {
            hex_field("unit", v, u, 2)? as u8
        };
        let kind = McKind::from_code(v[k]).ok_or(DescriptionError::Kind {
            offset: k,
            found: v[k],
            expected: "'0', '1', '2'",
        })?;
        let type_char = v[k + 1];
        if !(0x20..=0x7E).contains(&type_char) {
            return Err(DescriptionError::Type {
                offset: k + 1,
                found: type_char,
                family: Dialect::Mc,
            });
        }
        let min = hex_field("minimum", v, base, 8)?;
        let max = hex_field("maximum", v, base + 8, 8)?;
        let default = hex_field("reference value", v, base + 16, 8)?;
        let rest = base + 24;
        let extension = match layout {
            McLayout::Basic34 => None,
            McLayout::Hex52 => Some(McExtension {
                level: UserLevel::from_byte(hex_field("level", v, 34, 2)? as u8),
                attributes: Attributes(hex_field("attribute", v, 36, 4)? as u16),
                hardware: HardwareFilter(hex_field("hardware filter", v, 40, 4)? as u16),
                structure: StructureFilter(hex_field("structure filter", v, 44, 4)? as u16),
                subject: hex_field("subject area", v, 48, 2)? as u8,
                activity: hex_field("activity area", v, 50, 2)? as u8,
            }),
            McLayout::Table43 | McLayout::Table42 => printable_extension(&v[rest..rest + 9]),
        };
        Ok(Self {
            layout,
            name,
            unit,
            kind,
            type_char,
            min,
            max,
            default,
            extension,
        })
    }
}

/// One byte as a printable character `'0' + n` (n 0..=78), the kind's
/// convention applied to the other one-byte elements.
fn printable_byte(c: u8) -> Option<u8> {
    (b'0'..=b'~').contains(&c).then(|| c - b'0')
}

fn printable_extension(t: &[u8]) -> Option<McExtension> {
    let b = |i: usize| printable_byte(t[i]);
    let w = |i: usize| Some(u16::from(b(i)?) << 8 | u16::from(b(i + 1)?));
    Some(McExtension {
        level: UserLevel::from_byte(b(0)?),
        attributes: Attributes(w(1)?),
        hardware: HardwareFilter(w(3)?),
        structure: StructureFilter(w(5)?),
        subject: b(7)?,
        activity: b(8)?,
    })
}

impl McDescription {
    /// Encodes in any [`McLayout`] with the type characters of `types`
    /// (for simulated drives that follow another reading of section 11.2).
    /// The literal layouts write each byte as `'0' + n` and need every byte
    /// (unit, level, each half of attribute and filters, areas) to be at
    /// most 78; [`McLayout::Table43`] ends with a NUL.
    pub fn encode_as(
        &self,
        layout: McLayout,
        types: &McTypeChars,
    ) -> Result<ValueText, DescriptionError> {
        let hex = self.encode()?;
        let type_char = types
            .char_of(self.ty)
            .ok_or(DescriptionError::TypeNotInFamily {
                ty: self.ty,
                family: Dialect::Mc,
            })?;
        let h = hex.as_bytes();
        let mut out = Vec::with_capacity(52);
        let printable = |field: &'static str, n: u32| -> Result<u8, DescriptionError> {
            u8::try_from(n)
                .ok()
                .filter(|n| *n <= b'~' - b'0')
                .map(|n| b'0' + n)
                .ok_or(DescriptionError::ValueTooWide { field, value: n })
        };
        match layout {
            McLayout::Hex52 | McLayout::Basic34 => {
                out.extend_from_slice(&h[..34]);
                out[9] = type_char;
                if layout == McLayout::Hex52 {
                    let e = match self.extended {
                        McExtended::Decoded(e) => e,
                        _ => McExtension::default(),
                    };
                    let mut d = *self;
                    d.extended = McExtended::Decoded(e);
                    out.extend_from_slice(&d.encode()?.as_bytes()[34..]);
                }
            }
            McLayout::Table43 | McLayout::Table42 => {
                out.extend_from_slice(&h[..6]);
                out.push(printable("unit", u32::from(self.unit))?);
                out.push(self.kind.code());
                out.push(type_char);
                out.extend_from_slice(&h[10..34]);
                let e = match self.extended {
                    McExtended::Decoded(e) => e,
                    _ => McExtension::default(),
                };
                out.push(printable("level", u32::from(e.level.to_byte()))?);
                for (f, w) in [
                    ("attribute", e.attributes.0),
                    ("hardware filter", e.hardware.0),
                    ("structure filter", e.structure.0),
                ] {
                    out.push(printable(f, u32::from(w >> 8))?);
                    out.push(printable(f, u32::from(w & 0xFF))?);
                }
                out.push(printable("subject area", u32::from(e.subject))?);
                out.push(printable("activity area", u32::from(e.activity))?);
                if layout == McLayout::Table43 {
                    out.push(0);
                }
            }
        }
        Ok(ValueText::from_valid(&out))
    }
}

/// 108-STEXT: selects which value substitution text `61xxx` returns
/// (section 11.3).
pub const STEXT: u16 = 108;
/// 107-UNIT: its substitution texts are the unit strings a description's
/// unit index points to (section 11.2.1).
pub const UNIT: u16 = 107;

/// The two telegrams that fetch the substitution text number `index` of
/// MC parameter `parameter` (section 11.3 steps 2 and 3): SELECT 108-STEXT =
/// `index`, then ENQUIRY `61ppp`. `None` if `parameter > 999`.
pub fn substitution_text_request(
    address: Address,
    parameter: u16,
    index: u8,
) -> Option<(Select, Enquiry)> {
    let code = ParameterCode::substitution_text(parameter)?;
    let stext = ParameterCode::mc_value(STEXT)?;
    let value = ParameterValue::Usign8(index).encode(Dialect::Mc).ok()?;
    Some((
        Select::new(address, stext, value),
        Enquiry::new(address, code),
    ))
}

/// The text of a `61xxx` reply: printable ASCII, trailing NULs and blanks
/// removed (a C device may send its terminator or padding).
pub fn decode_substitution_text(value: &[u8]) -> Result<&str, DescriptionError> {
    let end = value
        .iter()
        .rposition(|&b| b != 0 && b != b' ')
        .map_or(0, |i| i + 1);
    let text = &value[..end];
    if let Some(i) = text.iter().position(|b| !(0x20..=0x7E).contains(b)) {
        return Err(DescriptionError::Text {
            field: "substitution text",
            offset: i,
            found: text[i],
        });
    }
    Ok(core::str::from_utf8(text).unwrap_or(""))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vf_example() -> VfDescription {
        VfDescription {
            name: ShortText::new("FSSIO").unwrap(),
            unit: ShortText::new("Hz").unwrap(),
            kind: VfKind::from_code(b'3').unwrap(),
            ty: ParameterType::Fixpoint16,
            min: 0,
            max: 8000,
            default: 0,
        }
    }

    #[test]
    fn vf_layout_exact() {
        let d = vf_example();
        let v = d.encode().unwrap();
        assert_eq!(v.as_bytes(), b" FSSIO    Hz3200001F400000");
        assert_eq!(v.len(), 26);
        assert_eq!(VfDescription::decode(v.as_bytes()), Ok(d));
        assert_eq!(d.kind.storage, VfStorage::FselIsel);
        assert!(!d.kind.inverter_specific);
    }

    #[test]
    fn vf_errors() {
        assert!(matches!(
            VfDescription::decode(b"short"),
            Err(DescriptionError::Length { found: 5, .. })
        ));
        assert_eq!(
            VfDescription::decode(b" FSSIO    Hz8200001F400000"),
            Err(DescriptionError::Kind {
                offset: 12,
                found: b'8',
                expected: "'0'..='7'"
            })
        );
        assert_eq!(
            VfDescription::decode(b" FSSIO    Hz3700001F400000"),
            Err(DescriptionError::Type {
                offset: 13,
                found: b'7',
                family: Dialect::Vf1000
            })
        );
        assert_eq!(
            VfDescription::decode(b" FSSIO    Hz32000g1F400000"),
            Err(DescriptionError::Field {
                field: "minimum",
                offset: 14,
                error: ValueError::NotHex {
                    offset: 17,
                    found: b'g'
                }
            })
        );
    }

    #[test]
    fn vf_kinds() {
        for c in b'0'..=b'7' {
            assert_eq!(VfKind::from_code(c).unwrap().code(), c);
        }
        assert!(VfKind::from_code(b'6').unwrap().inverter_specific);
        assert_eq!(VfKind::from_code(b'6').unwrap().storage, VfStorage::Eeprom);
    }

    fn mc_example() -> McDescription {
        McDescription {
            name: ShortText::new("RSIO").unwrap(),
            unit: 3,
            kind: McKind::RamControl,
            ty: ParameterType::Int32Q16,
            min: 0xE000_0000,
            max: 0x2000_0000,
            default: 0,
            extended: McExtended::Decoded(McExtension {
                level: UserLevel { read: 1, write: 2 },
                attributes: Attributes::SHOW_TEXT | Attributes::PASSWORD,
                hardware: HardwareFilter::MPTC | HardwareFilter::BRAKE,
                structure: StructureFilter::SPEED_CTRL,
                subject: 15,
                activity: 6,
            }),
        }
    }

    #[test]
    fn mc_layout_exact() {
        let d = mc_example();
        let v = d.encode().unwrap();
        assert_eq!(
            v.as_bytes(),
            concat!(
                "RSIO\0\0", "03", "1", "8", "E0000000", "20000000", "00000000", "21", "0220",
                "C000", "0002", "0F", "06"
            )
            .as_bytes()
        );
        assert_eq!(v.len(), 52);
        assert_eq!(McDescription::decode(v.as_bytes()), Ok(d));
        let McExtended::Decoded(e) = d.extended else {
            panic!()
        };
        assert_eq!(e.subject_area().unwrap().abbreviation(), "REF");
        assert_eq!(e.activity_area().unwrap().name(), "SC_REF");
        assert_eq!(e.hardware.labels().collect::<Vec<_>>(), ["MPTC", "Brake"]);
        // Basic part only.
        let basic = McDescription::decode(&v.as_bytes()[..34]).unwrap();
        assert_eq!(basic.extended, McExtended::Absent);
        assert_eq!(basic.encode().unwrap().as_bytes(), &v.as_bytes()[..34]);
        assert_eq!(
            d.min_value(),
            Some(ParameterValue::Int32Q16(super::super::value::Int32Q16(
                -0x2000_0000
            )))
        );
    }

    #[test]
    fn mc_literal_layout_tolerated() {
        let mut v = b"SPEED\0".to_vec();
        v.push(b'#'); // unit as one raw character
        v.extend(b"17"); // kind, type INTEGER16
        v.extend(b"FFFF800000007FFF00000000");
        v.extend(b"ABCDEFGHI\0"); // 10 uninterpreted characters
        assert_eq!(v.len(), 43);
        let d = McDescription::decode(&v).unwrap();
        assert_eq!(d.name.as_str(), "SPEED");
        assert_eq!(d.unit, b'#');
        assert_eq!(d.ty, ParameterType::Integer16);
        assert_eq!(d.min_value(), Some(ParameterValue::Integer16(-32768)));
        assert!(matches!(d.extended, McExtended::Literal { len: 10, .. }));
    }

    #[test]
    fn mc_errors() {
        let mut v = mc_example().encode().unwrap().as_bytes().to_vec();
        v[8] = b'3';
        assert_eq!(
            McDescription::decode(&v),
            Err(DescriptionError::Kind {
                offset: 8,
                found: b'3',
                expected: "'0', '1', '2'"
            })
        );
        v[8] = b'1';
        v[9] = b'1'; // PT_BINARY8 is VF1000 only
        assert!(matches!(
            McDescription::decode(&v),
            Err(DescriptionError::Type { offset: 9, .. })
        ));
        v[0] = 0x03;
        assert!(matches!(
            McDescription::decode(&v),
            Err(DescriptionError::Text { offset: 0, .. })
        ));
        let mut long = mc_example();
        long.name = ShortText::new("SPEEDX").unwrap();
        assert!(matches!(
            long.encode(),
            Err(DescriptionError::TooLong { max: 5, .. })
        ));
        assert!(McDescription::decode(&[b'0'; 40]).is_err());
    }

    #[test]
    fn layouts_round_trip_and_are_told_apart() {
        let d = mc_example();
        let mut d = d;
        // Printable layouts need bytes <= 78: ShowText (0x20) and Password
        // (0x0200) fit, MPTC/Brake (0xC000) do not.
        if let McExtended::Decoded(e) = &mut d.extended {
            e.hardware = HardwareFilter(0);
        }
        for layout in McLayout::ALL {
            for types in [McTypeChars::Driveset, McTypeChars::Table] {
                let v = d.encode_as(layout, &types).unwrap();
                assert_eq!(v.len(), layout.value_len());
                assert_eq!(McLayout::candidates(v.as_bytes()), vec![layout]);
                let r = McRawDescription::decode(v.as_bytes(), layout).unwrap();
                assert_eq!(types.type_of(r.type_char), Some(ParameterType::Int32Q16));
                assert_eq!((r.min, r.max, r.default), (0xE000_0000, 0x2000_0000, 0));
                assert_eq!(r.unit, 3);
                assert_eq!(r.kind, McKind::RamControl);
                match layout {
                    McLayout::Basic34 => assert_eq!(r.extension, None),
                    _ => {
                        let e = r.extension.unwrap();
                        assert_eq!(e.attributes, Attributes::SHOW_TEXT | Attributes::PASSWORD);
                        assert_eq!((e.subject, e.activity), (15, 6));
                        assert_eq!((e.level.read, e.level.write), (1, 2));
                    }
                }
            }
        }
        assert_eq!(
            d.encode_as(McLayout::Table43, &McTypeChars::Table)
                .unwrap()
                .as_bytes(),
            b"RSIO\0\x00315E00000002000000000000000Q2P0002?6\0"
        );
        // Table order: '1' PT_USIGN8 .. '8' PT_PASSWORD; driveset: '8' INT32Q16.
        assert_eq!(
            McTypeChars::Table.type_of(b'8'),
            Some(ParameterType::Password)
        );
        assert_eq!(
            McTypeChars::Driveset.type_of(b'8'),
            Some(ParameterType::Int32Q16)
        );
        assert_eq!(McTypeChars::Driveset.type_of(b'1'), None);
        assert_eq!(
            McTypeChars::parse("1=usign8, Z=PT_INTEGER16").unwrap(),
            McTypeChars::Map(vec![
                (b'1', ParameterType::Usign8),
                (b'Z', ParameterType::Integer16)
            ])
        );
        assert!(
            McTypeChars::parse("1=PT_BINARY8")
                .unwrap_err()
                .contains("not an MC6000/7000 type")
        );
        assert!(McTypeChars::parse("12=PT_USIGN8").is_err());
        assert!(McLayout::candidates(b"short").is_empty());
    }

    #[test]
    fn substitution_texts() {
        let (sel, enq) = substitution_text_request(Address::ALL, 300, 2).unwrap();
        assert_eq!(sel.encode().as_bytes(), b"\x04@\x0220108=2\x03\x37");
        assert_eq!(enq.encode().as_bytes(), b"\x04@61300\x05");
        assert_eq!(decode_substitution_text(b"SCON\0\0"), Ok("SCON"));
        assert_eq!(decode_substitution_text(b"1/min  "), Ok("1/min"));
        assert!(decode_substitution_text(b"A\x01B").is_err());
    }

    #[test]
    fn user_level_nibbles() {
        let l = UserLevel::from_byte(0x21);
        assert_eq!((l.read, l.write), (1, 2));
        assert_eq!(l.to_byte(), 0x21);
    }
}
