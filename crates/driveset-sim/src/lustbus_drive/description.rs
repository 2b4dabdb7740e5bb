//! The LUSTBUS drives' parameter descriptions (VF1000 section 11.1,
//! MC6000/7000 section 11.2) and substitution texts, from the fixture
//! table and the `describe=` overrides; and the parameter a twin's drive
//! described that the table does not have.

use super::*;
use driveset_proto::lustbus::description::McRawDescription;

impl LustCore {
    /// A VF1000 parameter description (section 11.1, 26 characters).
    /// Name: the schema name upper-cased, characters outside
    /// `A-Z 0-9 _ -` dropped, at most 6; unit at most 6 characters. Kind
    /// characters '4'..'7' for parameters the schema marks `basis = false`.
    pub fn vf_description(&self, p: &Param) -> Option<ValueText> {
        let storage = match p.kind {
            Some(StorageKind::RamActual) => VfStorage::RamActual,
            Some(StorageKind::Eeprom) => VfStorage::Eeprom,
            Some(StorageKind::FselIsel) => VfStorage::FselIsel,
            Some(StorageKind::RamControl) => VfStorage::RamControl,
            None if p.writable() => VfStorage::RamControl,
            None => VfStorage::RamActual,
        };
        let code = self.table.schema().code(p.key.number);
        let unit = code.and_then(|c| c.unit.clone()).unwrap_or_default();
        let w = |r: Option<i64>| {
            r.and_then(|r| self.to_wire(p, r))
                .map_or(0, |v| (v.raw() & 0xFFFF) as u16)
        };
        let factory = match p.factory {
            RawValue::Int(v) => Some(v),
            _ => None,
        };
        let mut d = VfDescription {
            name: ShortText::new(&short_name(&p.name, 6)).unwrap_or_default(),
            unit: ShortText::new(&truncate(&printable(&unit), 6)).unwrap_or_default(),
            kind: VfKind {
                storage,
                inverter_specific: code.and_then(|c| c.basis) == Some(false),
            },
            ty: self.wire_type(p),
            min: w(p.min),
            max: w(p.max),
            default: w(factory),
        };
        if let Some(o) = self.describe.get(&p.key.number) {
            let raw = |v: i64| (v & 0xFFFF) as u16;
            d.kind.storage = match o.kind {
                Some(StorageKind::RamActual) => VfStorage::RamActual,
                Some(StorageKind::RamControl) => VfStorage::RamControl,
                Some(StorageKind::Eeprom) => VfStorage::Eeprom,
                Some(StorageKind::FselIsel) => VfStorage::FselIsel,
                None => d.kind.storage,
            };
            d.ty = o.ty.unwrap_or(d.ty);
            d.min = o.min.map_or(d.min, raw);
            d.max = o.max.map_or(d.max, raw);
            d.default = o.default.map_or(d.default, raw);
            if let Some(u) = &o.unit {
                d.unit = ShortText::new(&truncate(&printable(u), 6)).unwrap_or_default();
            }
        }
        d.encode().ok()
    }

    /// An MC parameter description (section 11.2) in the layout and with
    /// the type characters of [`LustOptions::description_layout`] /
    /// [`LustOptions::type_chars`] (default the codec's 52-character layout,
    /// errata L22, L23). Unit: index into [`Self::units`]
    /// (0 = no unit). Simulator choices for the KEYPAD elements: levels 0,
    /// filters 0, attribute ShowText for PT_USIGN8 parameters with value
    /// texts and Password for PT_PASSWORD, subject area SIO (9) for the
    /// compatible parameters 81..85 and 0 (CONF) otherwise, activity area
    /// SC_DRIVE (5) for CardWriteable parameters and 0 otherwise.
    pub fn mc_description(&self, p: &Param) -> Option<ValueText> {
        let kind = match p.kind {
            Some(StorageKind::RamActual) => McKind::RamActual,
            Some(StorageKind::RamControl) => McKind::RamControl,
            Some(StorageKind::Eeprom) | Some(StorageKind::FselIsel) => McKind::Eeprom,
            None if p.writable() => McKind::RamControl,
            None => McKind::RamActual,
        };
        let over = self.describe.get(&p.key.number);
        let kind = match over.and_then(|o| o.kind) {
            Some(StorageKind::RamActual) => McKind::RamActual,
            Some(StorageKind::RamControl) => McKind::RamControl,
            Some(StorageKind::Eeprom | StorageKind::FselIsel) => McKind::Eeprom,
            None => kind,
        };
        let ty = over.and_then(|o| o.ty).unwrap_or_else(|| self.wire_type(p));
        let fixture = |r: Option<i64>| r.and_then(|r| self.to_wire(p, r)).map_or(0, |v| v.raw());
        let given = |v: i64| match ty {
            ParameterType::Integer16 => u32::from(v as i16 as u16),
            _ => v as u32,
        };
        let factory = match p.factory {
            RawValue::Int(v) => Some(v),
            _ => None,
        };
        let (min, max, default) = (
            over.and_then(|o| o.min).map_or(fixture(p.min), given),
            over.and_then(|o| o.max).map_or(fixture(p.max), given),
            over.and_then(|o| o.default).map_or(fixture(factory), given),
        );
        let mut attributes = Attributes(0);
        if ty == ParameterType::Usign8 && !p.enum_values.is_empty() {
            attributes = Attributes(attributes.0 | Attributes::SHOW_TEXT.0);
        }
        if ty == ParameterType::Password {
            attributes = Attributes(attributes.0 | Attributes::PASSWORD.0);
        }
        let d = McDescription {
            name: ShortText::new(&short_name(&p.name, 5)).unwrap_or_default(),
            unit: self.unit_index(p),
            kind,
            ty,
            min,
            max,
            default,
            extended: McExtended::Decoded(McExtension {
                level: UserLevel::default(),
                attributes,
                subject: if (81..=85).contains(&p.key.number) {
                    9
                } else {
                    0
                },
                activity: if p.card_writeable { 5 } else { 0 },
                ..McExtension::default()
            }),
        };
        d.encode_as(self.description_layout, &self.type_chars).ok()
    }

    pub(super) fn unit_index(&self, p: &Param) -> u8 {
        let unit = self
            .describe
            .get(&p.key.number)
            .and_then(|d| d.unit.clone())
            .or_else(|| self.table.schema().code(p.key.number)?.unit.clone())
            .map(|u| printable(&u))
            .unwrap_or_default();
        self.units
            .iter()
            .position(|u| *u == unit)
            .and_then(|i| u8::try_from(i).ok())
            .unwrap_or(0)
    }

    /// The value substitution text number `index` of parameter `number`
    /// (section 11.3): the enumeration label of that value from the schema,
    /// or for 107-UNIT the unit string of that index (index 0, no unit, is
    /// a single blank, which readers trim). `None` (NAK) if the parameter
    /// does not exist, has no texts, `index` exceeds its maximum, or that
    /// value has no label.
    pub fn substitution_text(&self, number: u32, index: i64) -> Option<ValueText> {
        let p = self.param(number)?;
        if p.max.is_some_and(|m| index > m) {
            return None;
        }
        let text = if number == 107 {
            let t = self.units.get(usize::try_from(index).ok()?)?.clone();
            if t.is_empty() { " ".to_string() } else { t }
        } else {
            let code = self.table.schema().code(number)?;
            let e = self.table.schema().enum_of(code.values.as_ref()?)?;
            printable(e.label(index)?)
        };
        let text = truncate(&text, 100);
        if text.is_empty() {
            return None;
        }
        ValueText::new(text.as_bytes()).ok()
    }
}

impl LustCore {
    /// The parameter a description of `number` says (VF1000 section 11.1;
    /// MC6000/7000 section 11.2 in the drive's layout and type characters):
    /// type, kind, bounds, factory value, CardWriteable. For a twin's
    /// parameter the simulator's table does not have: the drive's own
    /// description is the one account of it there is.
    pub fn param_described(&self, number: u32, v: &[u8]) -> Result<Param, String> {
        let bad = |e: String| format!("the description of {number} does not decode: {e}");
        let (name, ty, kind, bounds, card) = if self.wire == WireFamily::Vf1000 {
            let d = VfDescription::decode(v).map_err(|e| bad(e.to_string()))?;
            let kind = match d.kind.storage {
                VfStorage::RamActual => StorageKind::RamActual,
                VfStorage::RamControl => StorageKind::RamControl,
                VfStorage::Eeprom => StorageKind::Eeprom,
                VfStorage::FselIsel => StorageKind::FselIsel,
            };
            let b = [d.min, d.max, d.default].map(u32::from);
            (d.name.as_str().trim().to_string(), d.ty, kind, b, false)
        } else {
            let d = McRawDescription::decode(v, self.description_layout)
                .map_err(|e| bad(e.to_string()))?;
            let ty = self.type_chars.type_of(d.type_char).ok_or_else(|| {
                bad(format!(
                    "type character {:?} unknown in the {} reading",
                    char::from(d.type_char),
                    self.type_chars.name()
                ))
            })?;
            let kind = match d.kind {
                McKind::RamActual => StorageKind::RamActual,
                McKind::RamControl => StorageKind::RamControl,
                McKind::Eeprom => StorageKind::Eeprom,
            };
            let card = d
                .extension
                .and_then(|e| e.activity_area())
                .is_some_and(|a| a.card_exchange());
            (
                d.name.as_str().trim().to_string(),
                ty,
                kind,
                [d.min, d.max, d.default],
                card,
            )
        };
        // the raw value as the type reads it (two's complement where signed)
        let raw = |b: u32| match ty {
            ParameterType::Integer16 => i64::from(b as u16 as i16),
            ParameterType::Int32Q16 => i64::from(b as i32),
            _ => i64::from(b),
        };
        let value_type = driveset_schema::ValueType::from_name(ty.name());
        Ok(Param {
            key: CodeKey::new(number),
            name,
            ty: value_type,
            min: Some(raw(bounds[0])),
            max: Some(raw(bounds[1])),
            factory: RawValue::Int(raw(bounds[2])),
            access: if kind == StorageKind::RamActual {
                driveset_schema::schema::Access::Ro
            } else {
                driveset_schema::schema::Access::default()
            },
            kind: Some(kind),
            width: None,
            card_writeable: card,
            read_clears: false,
            enum_values: Vec::new(),
        })
    }
}

/// Printable 7-bit ASCII of `s` (others become '?').
pub(super) fn printable(s: &str) -> String {
    s.chars()
        .map(|c| if (' '..='~').contains(&c) { c } else { '?' })
        .collect()
}

pub(super) fn truncate(s: &str, n: usize) -> String {
    s.chars().take(n).collect()
}

/// A description name: upper case, only `A-Z 0-9 _ -`, at most `n`.
pub(super) fn short_name(name: &str, n: usize) -> String {
    name.chars()
        .map(|c| c.to_ascii_uppercase())
        .filter(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == '_' || *c == '-')
        .take(n)
        .collect()
}
