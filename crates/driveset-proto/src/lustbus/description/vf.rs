//! VF1000 parameter descriptions (`lustbus-protocol.txt` §11.1): the 26-character
//! layout, its kind and storage, and the hex fields both layouts share.

use super::*;

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

pub(super) fn hex_field(
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
