//! The MC description layouts and type characters driveset tells apart
//! (errata L22, L23: `lustbus-protocol.txt` §11.2 leaves both open): raw
//! descriptions read in one layout, the type-character readings, and
//! encoding in any layout.

use super::*;

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
