//! Learning a schema from a LUSTBUS drive: reading its own parameter
//! descriptions (VF1000 specifier 1, section 11.1; MC6000/7000 specifier
//! 3, section 11.2), the unit strings (107-UNIT) and value substitution
//! texts (108-STEXT + `61ppp`, section 11.3), interpreting them whatever
//! layout and type characters the drive uses (errata L22, L23), and writing
//! the result as a schema file that `extends` the built-in schema.
//!
//! # Merge rule
//!
//! The learned file `extends` the built-in schema (`lust-vf1000` /
//! `lust-mc6000`) and so merges like a fixture: **a fact the built-in schema
//! gives (from the spec) stands**; the drive's description only fills the
//! facts it leaves unset (type, unit, min, max, default, kind, width,
//! card_writeable, access, value texts), and adds the parameters the spec
//! does not name. Where the drive contradicts a spec fact (another kind,
//! type, unit, min, max or default; an actual value where the spec has a
//! command, control word or setpoint), the spec's fact stands for that
//! code, the drive's is recorded as a guess in a `# drive says:` comment
//! above the entry, and a [`KEPT_SPEC`] finding names the code, both facts
//! and the spec section (docs/file-formats.md, "Learned schemas").
//!
//! # A learned schema is a schema
//!
//! The file carries `[schema.learned] asked` (the parameters asked for).
//! [`needs_learning`] is false for a learned schema that asked for every
//! parameter of its family; one that did not is learned on top of for the
//! others only ([`options_for`]), and the result is the earlier file's own
//! text with the new entries appended, so it extends the same base (an id
//! every reader resolves).
//!
//! # Markers
//!
//! Every learned code carries a `# learned: ...` comment listing the facts
//! taken from the drive; a code the spec does not name has
//! `spec = "learned from the drive's description ..."`; whatever is a
//! guess rather than read (the layout or type-character reading chosen by
//! content, a type kept as a raw integer because its character is unknown,
//! a range left out because the description contradicts itself) is said in
//! `note = "guessed: ..."` (or a `# guessed:` comment where the spec has a
//! note).
//!
//! # Descriptions that contradict themselves
//!
//! Minimum above maximum: the range is left out. Default outside the
//! range: the default is left out. A bound the type cannot hold: the type
//! is downgraded to the raw integer the bounds need. An unknown type
//! character: the code is kept as a raw integer of the width its min / max
//! / default need (PT_USIGN8, PT_USIGN16 or PT_INTEGER16; a code that needs
//! 32 bits is kept without a type, since LUSTBUS has no raw 32-bit type).
//! A description that does not decode at all is left out. Each case is a
//! [`LearnFinding`] naming the parameter and why. After rendering, the
//! schema is parsed and checked ([`driveset_schema::check_schema`]); a code
//! the check still objects to (the objection's line in its learned entry,
//! or in the base entry a learned fact merged into) is left out, and the
//! finding names the code and the check, so a learned file always passes
//! `driveset schema check`; only an objection outside every code fails.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::sync::Arc;

use driveset_link::ByteLink;
use driveset_proto::lustbus::description::McKind;
use driveset_proto::lustbus::description::{
    Attributes, DescriptionError, McLayout, McRawDescription, McTypeChars, STEXT, UNIT,
    VfDescription, VfStorage, decode_substitution_text,
};
use driveset_proto::lustbus::{ParameterCode, ParameterType};
use driveset_schema::error::SourceFile;
use driveset_schema::schema::{StorageKind, number_list_text};
use driveset_schema::value::raw_to_engineering;
use driveset_schema::{Code, Family, Location, Registry, Role, Schema, ValueType, check_schema};

use crate::client::{DriveClient as _, IdentValue, Identity, LustbusClient};
use crate::error::EngineError;

/// How to learn.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LearnOptions {
    /// Parameters to ask for (default VF1000 1..=99, MC6000/7000 1..=999).
    pub params: Option<Vec<u32>>,
    /// MC: read every description in this layout instead of telling the
    /// layout by length and content.
    pub layout: Option<McLayout>,
    /// MC: read type characters this way instead of guessing the reading
    /// from the descriptions' content.
    pub type_chars: Option<McTypeChars>,
    /// Do not read units and substitution texts (no 108-STEXT writes).
    pub no_texts: bool,
}

/// One description as the drive sent it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawDescription {
    /// Parameter number.
    pub number: u32,
    /// The VALUE characters.
    pub text: Vec<u8>,
}

/// A parameter learned from its description.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LearnedCode {
    /// Parameter number.
    pub number: u32,
    /// The description's name.
    pub name: String,
    /// The type, when known or guessed.
    pub ty: Option<ParameterType>,
    /// Unit string (VF1000: the description's; MC: the 107-UNIT text).
    pub unit: Option<String>,
    /// MC: the unit index into 107-UNIT.
    pub unit_index: Option<u8>,
    /// Storage kind.
    pub kind: StorageKind,
    /// VF1000: basis parameter.
    pub basis: Option<bool>,
    /// MC: CardWriteable (activity area other than SC_Nothing), when the
    /// description carries the activity area.
    pub card_writeable: Option<bool>,
    /// The description's kind character as sent (VF1000 '0'..'7',
    /// MC '0'..'2').
    pub kind_char: u8,
    /// Password (type PT_PASSWORD or the Password attribute).
    pub password: bool,
    /// MC: values shown as substitution texts: `Some(true)` by the
    /// ShowText attribute, `None` when the description does not carry the
    /// attribute (texts are then probed for PT_USIGN8 parameters).
    pub show_text: Option<bool>,
    /// Minimum, raw (sign-extended for signed types).
    pub min: Option<i64>,
    /// Maximum, raw.
    pub max: Option<i64>,
    /// Factory default, raw.
    pub default: Option<i64>,
    /// Value substitution texts.
    pub texts: BTreeMap<i64, String>,
    /// What is guessed, not read (rendered as `note = "guessed: ..."`).
    pub guessed: Vec<String>,
}

/// Something about one parameter's description the learned schema could
/// not take as it came.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct LearnFinding {
    /// The code as reports spell it (`11-STAT`; the description's name for
    /// a code the base schema does not name), filled by [`render_schema`].
    pub code: String,
    /// Parameter number.
    pub number: u32,
    /// `left out`, `downgraded`, or `kept the spec's` (the drive's
    /// description contradicts a fact of the base schema, which stands).
    pub action: &'static str,
    /// Why.
    pub reason: String,
}

/// What was learned from one drive.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Learned {
    /// The drive's protocol (LUSTBUS VF1000 or MC).
    pub protocol: Family,
    /// MC: the layouts the descriptions came in (by length and content, or
    /// forced).
    pub layouts: BTreeSet<McLayout>,
    /// MC: the type-character reading used.
    pub type_chars: Option<McTypeChars>,
    /// MC: whether that reading was guessed from the content (not forced).
    pub type_chars_guessed: bool,
    /// The parameters learned.
    pub codes: Vec<LearnedCode>,
    /// Parameters left out or downgraded, and why.
    pub findings: Vec<LearnFinding>,
    /// Parameters asked for.
    pub asked: usize,
    /// Their numbers (written as `[schema.learned] asked`).
    pub asked_params: BTreeSet<u32>,
    /// Parameters the drive NAKed (no such parameter).
    pub absent: usize,
    /// Substitution texts read.
    pub texts_read: usize,
    /// FNV-1a of every description received (stands in for a software
    /// version: LUSTBUS names no software-version parameter).
    pub descriptions_hash: u32,
}

fn fnv1a(data: &[u8], mut h: u32) -> u32 {
    for &b in data {
        h ^= u32::from(b);
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

/// Whether `schema` lacks facts a drive's descriptions could fill: a
/// learned schema (`[schema.learned]`) that did not ask for every
/// parameter of its family ([`unasked`]); or a LUSTBUS schema (not itself
/// learned, `learned-...`, nor a fictional fixture, which is what the
/// simulated drives are built from) with a code (other than a status code
/// whose reading clears it) without a type, kind or range. A learned
/// schema that asked for every parameter is used as it is, and so is a
/// schema of the user's own (a file by path or in `--schemas DIR` whose id
/// is not its family's built-in one): a learned file names its base by id,
/// and only the built-in and learned schemas have an id every later
/// command resolves.
pub fn needs_learning(schema: &Schema) -> bool {
    if schema.learned.is_some() {
        return !unasked(schema).is_empty();
    }
    schema.id == schema.family.descriptor().schema_id
        && !schema.fictional
        && matches!(schema.family, Family::Mc6000 | Family::Vf1000)
        && schema.codes.iter().any(|c| {
            c.read_clears != Some(true)
                && (schema.type_of(c).is_none()
                    || c.kind.is_none()
                    || (c.min.is_none() && c.max.is_none() && c.values.is_none()))
        })
}

/// The parameters of `schema`'s family a learned schema did not ask for
/// (empty for a schema that is not learned).
pub fn unasked(schema: &Schema) -> Vec<u32> {
    match &schema.learned {
        Some(l) => default_params(schema.family)
            .into_iter()
            .filter(|p| !l.asked.contains(p))
            .collect(),
        None => Vec::new(),
    }
}

/// The options to learn on top of `base`: a learned base asks only for
/// the parameters it did not ask for ([`unasked`]) unless `opts` names
/// them.
pub fn options_for(base: &Schema, opts: &LearnOptions) -> LearnOptions {
    let mut o = opts.clone();
    if base.learned.is_some() && o.params.is_none() {
        o.params = Some(unasked(base));
    }
    o
}

/// The file (and schema id) a learned schema is stored under:
/// `learned-<family>-type<TYPE>-<software>.toml`, the software being the
/// identity's software version where the drive reports one, else
/// `d<8 hex>`, the hash of the descriptions the drive sent.
pub fn learned_id(protocol: Family, identity: &Identity, learned: &Learned) -> String {
    let family = match protocol {
        Family::Vf1000 => "vf1000",
        _ => "mc6000",
    };
    let ty = identity
        .value_of(91)
        .map_or_else(|| "unknown".to_string(), ToString::to_string);
    let sw = identity.software.as_deref().map_or_else(
        || format!("d{:08x}", learned.descriptions_hash),
        |s| {
            s.chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect()
        },
    );
    format!("learned-{family}-type{}-{sw}", slug(&ty))
}

fn slug(s: &str) -> String {
    s.chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_')
        .collect()
}

/// The highest parameter number a LUSTBUS family describes (VF1000: 99,
/// two CODE digits; MC6000/7000: 999, three); `None` for the families
/// whose drives have no LUSTBUS descriptions.
pub fn max_parameter(protocol: Family) -> Option<u32> {
    match protocol {
        Family::Vf1000 => Some(99),
        Family::Mc6000 => Some(999),
        Family::Tmd | Family::Ecs => None,
    }
}

/// The parameters asked for by default.
pub fn default_params(protocol: Family) -> Vec<u32> {
    (1..=max_parameter(protocol).unwrap_or(999)).collect()
}

/// Asks every parameter of `params` for its description (a NAK: no such
/// parameter). Nothing is written. Returns the descriptions and how many
/// parameters the drive NAKed.
pub fn read_descriptions<L: ByteLink>(
    client: &mut LustbusClient<L>,
    protocol: Family,
    params: &[u32],
) -> Result<(Vec<RawDescription>, usize), EngineError> {
    let mc = protocol == Family::Mc6000;
    let mut out = Vec::new();
    let mut absent = 0;
    for &p in params {
        let code = if mc {
            u16::try_from(p)
                .ok()
                .and_then(ParameterCode::mc_description)
        } else {
            u8::try_from(p)
                .ok()
                .and_then(|n| ParameterCode::vf_description(1, n))
        };
        let Some(code) = code else { continue };
        match client.enquire_code(code, if mc { 52 } else { 26 })? {
            Some(t) => out.push(RawDescription {
                number: p,
                text: t.as_bytes().to_vec(),
            }),
            None => absent += 1,
        }
    }
    Ok((out, absent))
}

/// Whether `raw` (32 bits as sent) is a value of `ty`.
fn fits(ty: ParameterType, raw: u32) -> bool {
    match ty {
        ParameterType::Usign8 | ParameterType::Binary8 => raw <= 0xFF,
        ParameterType::Integer16 => raw <= 0xFFFF || raw >= 0xFFFF_8000,
        ParameterType::Usign16
        | ParameterType::Fixpoint16
        | ParameterType::Password
        | ParameterType::VfError => raw <= 0xFFFF,
        ParameterType::Int32Q16 | ParameterType::FloatIeee | ParameterType::McError => true,
    }
}

/// The raw integer of a bound in `ty` (signed types sign-extended).
fn signed(ty: ParameterType, raw: u32) -> i64 {
    match ty {
        ParameterType::Integer16 => i64::from(raw as u16 as i16),
        ParameterType::Int32Q16 => i64::from(raw as i32),
        _ => i64::from(raw),
    }
}

/// The raw integer type the bounds need (an unknown type character).
fn raw_type(bounds: [u32; 3], mc: bool) -> Option<ParameterType> {
    if bounds.iter().all(|&b| b <= 0xFF) {
        Some(ParameterType::Usign8)
    } else if bounds.iter().all(|&b| b <= 0xFFFF) {
        Some(ParameterType::Usign16)
    } else if mc && bounds.iter().all(|&b| fits(ParameterType::Integer16, b)) {
        Some(ParameterType::Integer16)
    } else {
        None
    }
}

fn width_of(ty: ParameterType) -> u8 {
    match ty {
        ParameterType::Usign8 | ParameterType::Binary8 => 1,
        ParameterType::Int32Q16 | ParameterType::FloatIeee | ParameterType::McError => 4,
        _ => 2,
    }
}

/// How well a type-character reading fits a drive's descriptions: one
/// point per description whose character it knows and whose bounds the
/// type holds in order, one more where the attribute agrees (ShowText is
/// only allowed on PT_USIGN8, Password marks PT_PASSWORD).
fn score(reading: &McTypeChars, raws: &[McRawDescription]) -> usize {
    raws.iter()
        .map(|r| {
            let Some(ty) = reading.type_of(r.type_char) else {
                return 0;
            };
            let mut s = 0;
            if [r.min, r.max, r.default].into_iter().all(|b| fits(ty, b))
                && ordered(ty, r.min, r.max)
            {
                s += 1;
            }
            if let Some(e) = r.extension {
                let show = e.attributes.0 & Attributes::SHOW_TEXT.0 != 0;
                let pw = e.attributes.0 & Attributes::PASSWORD.0 != 0;
                if show && ty == ParameterType::Usign8 {
                    s += 1;
                }
                if pw && ty == ParameterType::Password {
                    s += 1;
                }
            }
            s
        })
        .sum()
}

fn ordered(ty: ParameterType, min: u32, max: u32) -> bool {
    if ty == ParameterType::FloatIeee {
        let (a, b) = (f32::from_bits(min), f32::from_bits(max));
        return a <= b;
    }
    signed(ty, min) <= signed(ty, max)
}

/// Fills `c`'s type and bounds from a description, downgrading what
/// contradicts itself (module docs).
fn set_bounds(
    c: &mut LearnedCode,
    ty: Option<ParameterType>,
    bounds: [u32; 3],
    mc: bool,
    findings: &mut Vec<LearnFinding>,
    type_char: u8,
) {
    let n = c.number;
    let mut ty = ty;
    if ty.is_none() {
        ty = raw_type(bounds, mc);
        let what = match ty {
            Some(t) => format!(
                "kept as a raw integer {} (the width its min/max/default need)",
                t.name()
            ),
            None => "kept without a type (its min/max/default need 32 bits; LUSTBUS has no raw 32-bit type), so it is not read".to_string(),
        };
        let msg = format!(
            "type character {} is not one driveset knows; {what}",
            show_char(type_char)
        );
        c.guessed.push(msg.clone());
        findings.push(LearnFinding {
            code: String::new(),
            number: n,
            action: "downgraded",
            reason: msg,
        });
    } else if let Some(t) = ty
        && !bounds.iter().all(|&b| fits(t, b))
    {
        let down = raw_type(bounds, mc);
        let msg = format!(
            "its min/max/default ({:#X}, {:#X}, {:#X}) do not fit its type {}; {}",
            bounds[0],
            bounds[1],
            bounds[2],
            t.name(),
            match down {
                Some(d) => format!("type downgraded to the raw integer {}", d.name()),
                None => "kept without a type, so it is not read".into(),
            }
        );
        c.guessed.push(msg.clone());
        findings.push(LearnFinding {
            code: String::new(),
            number: n,
            action: "downgraded",
            reason: msg,
        });
        ty = down;
    }
    c.ty = ty;
    let Some(t) = ty else { return };
    if matches!(
        t,
        ParameterType::Password | ParameterType::VfError | ParameterType::McError
    ) {
        return;
    }
    if !ordered(t, bounds[0], bounds[1]) {
        let msg = format!(
            "its minimum {} is above its maximum {}; range and default left out",
            raw_to_engineering(value_type(t), signed(t, bounds[0])),
            raw_to_engineering(value_type(t), signed(t, bounds[1]))
        );
        c.guessed.push(msg.clone());
        findings.push(LearnFinding {
            code: String::new(),
            number: n,
            action: "downgraded",
            reason: msg,
        });
        return;
    }
    if t == ParameterType::FloatIeee
        && [bounds[0], bounds[1], bounds[2]]
            .iter()
            .any(|b| !f32::from_bits(*b).is_finite())
    {
        return;
    }
    let (min, max, def) = (
        signed(t, bounds[0]),
        signed(t, bounds[1]),
        signed(t, bounds[2]),
    );
    if (min, max) != (0, 0) {
        c.min = Some(min);
        c.max = Some(max);
    }
    let inside = if t == ParameterType::FloatIeee {
        let d = f32::from_bits(bounds[2]);
        f32::from_bits(bounds[0]) <= d && d <= f32::from_bits(bounds[1])
    } else {
        (min..=max).contains(&def)
    };
    if c.kind == StorageKind::RamActual {
        return;
    }
    if inside || (min, max) == (0, 0) {
        c.default = Some(def);
    } else {
        let msg = format!(
            "its default {} is outside its range {}..{}; default left out",
            raw_to_engineering(value_type(t), def),
            raw_to_engineering(value_type(t), min),
            raw_to_engineering(value_type(t), max)
        );
        c.guessed.push(msg.clone());
        findings.push(LearnFinding {
            code: String::new(),
            number: n,
            action: "downgraded",
            reason: msg,
        });
    }
}

fn show_char(c: u8) -> String {
    if (0x21..=0x7E).contains(&c) {
        format!("'{}'", c as char)
    } else {
        format!("{c:#04x}")
    }
}

fn value_type(t: ParameterType) -> ValueType {
    ValueType::from_name(t.name()).unwrap_or(ValueType::PT_USIGN16)
}

fn new_code(number: u32, name: &str, kind: StorageKind) -> LearnedCode {
    LearnedCode {
        number,
        name: name.to_string(),
        ty: None,
        unit: None,
        unit_index: None,
        kind,
        basis: None,
        card_writeable: None,
        kind_char: b'?',
        password: false,
        show_text: None,
        min: None,
        max: None,
        default: None,
        texts: BTreeMap::new(),
        guessed: Vec::new(),
    }
}

/// Interprets the descriptions of a drive (pure; no bus). MC: each
/// description's layout by length and content (or `opts.layout`); the
/// type-character reading by which of driveset's and the table order fits
/// more descriptions (ties: driveset's), or `opts.type_chars`.
pub fn interpret(protocol: Family, raws: &[RawDescription], opts: &LearnOptions) -> Learned {
    let mut findings = Vec::new();
    let mut codes = Vec::new();
    let mut layouts = BTreeSet::new();
    let mut hash = 0x811C_9DC5;
    for r in raws {
        hash = fnv1a(&r.number.to_le_bytes(), hash);
        hash = fnv1a(&r.text, hash);
    }
    let mut type_chars = None;
    let mut type_chars_guessed = false;
    if protocol == Family::Mc6000 {
        let mut decoded = Vec::new();
        for r in raws {
            let layout = match opts.layout {
                Some(l) => Some(l),
                None => McLayout::candidates(&r.text).into_iter().next(),
            };
            let d = match layout {
                Some(l) => McRawDescription::decode(&r.text, l),
                None => McLayout::ALL
                    .into_iter()
                    .find(|l| l.value_len() == r.text.len())
                    .map_or(
                        Err(DescriptionError::Length {
                            family: driveset_proto::lustbus::Dialect::Mc,
                            found: r.text.len(),
                            expected: "52, 43, 42 or 34",
                        }),
                        |l| McRawDescription::decode(&r.text, l),
                    ),
            };
            match d {
                Ok(d) => {
                    layouts.insert(d.layout);
                    decoded.push((r.number, d));
                }
                Err(e) => findings.push(LearnFinding {
                    code: String::new(),
                    number: r.number,
                    action: "left out",
                    reason: format!("its description does not decode: {e}"),
                }),
            }
        }
        let reading = match &opts.type_chars {
            Some(t) => t.clone(),
            None => {
                let all: Vec<McRawDescription> = decoded.iter().map(|d| d.1).collect();
                let (a, b) = (
                    score(&McTypeChars::Driveset, &all),
                    score(&McTypeChars::Table, &all),
                );
                type_chars_guessed = true;
                if b > a {
                    McTypeChars::Table
                } else {
                    McTypeChars::Driveset
                }
            }
        };
        for (number, d) in decoded {
            let kind = match d.kind {
                McKind::RamActual => StorageKind::RamActual,
                McKind::RamControl => StorageKind::RamControl,
                McKind::Eeprom => StorageKind::Eeprom,
            };
            let mut c = new_code(number, d.name.as_str(), kind);
            c.kind_char = d.kind.code();
            c.unit_index = (d.unit != 0).then_some(d.unit);
            if let Some(e) = d.extension {
                c.show_text = Some(e.attributes.0 & Attributes::SHOW_TEXT.0 != 0);
                c.password = e.attributes.0 & Attributes::PASSWORD.0 != 0;
                c.card_writeable = e.activity_area().map(|a| a.card_exchange());
                if matches!(d.layout, McLayout::Table43 | McLayout::Table42) {
                    c.guessed.push(format!(
                        "attribute and activity area read from the {}-character layout, one byte per printable character '0'+n (errata L22)",
                        d.layout.value_len()
                    ));
                }
            }
            if type_chars_guessed && reading != McTypeChars::Driveset {
                c.guessed.push(format!(
                    "type character {} read in the {} reading (chosen by content, errata L23)",
                    show_char(d.type_char),
                    reading.name()
                ));
            }
            let ty = reading.type_of(d.type_char);
            set_bounds(
                &mut c,
                ty,
                [d.min, d.max, d.default],
                true,
                &mut findings,
                d.type_char,
            );
            if c.ty == Some(ParameterType::Password) {
                c.password = true;
            }
            if c.show_text == Some(true) && c.ty != Some(ParameterType::Usign8) {
                let msg = "it has the ShowText attribute but is not PT_USIGN8 (section 11.2.1 allows texts only on usign8); texts not read".to_string();
                c.show_text = Some(false);
                c.guessed.push(msg.clone());
                findings.push(LearnFinding {
                    code: String::new(),
                    number,
                    action: "downgraded",
                    reason: msg,
                });
            }
            codes.push(c);
        }
        type_chars = Some(reading);
    } else {
        for r in raws {
            let (d, unknown_type) = match VfDescription::decode(&r.text) {
                Ok(d) => (Ok(d), None),
                Err(DescriptionError::Type { offset, found, .. }) => {
                    // Read the rest with a placeholder type; the character
                    // is unknown (not '1'..'6').
                    let mut t = r.text.clone();
                    t[offset] = b'3';
                    (VfDescription::decode(&t), Some(found))
                }
                Err(e) => (Err(e), None),
            };
            let d = match d {
                Ok(d) => d,
                Err(e) => {
                    findings.push(LearnFinding {
                        code: String::new(),
                        number: r.number,
                        action: "left out",
                        reason: format!("its description does not decode: {e}"),
                    });
                    continue;
                }
            };
            let kind = match d.kind.storage {
                VfStorage::RamActual => StorageKind::RamActual,
                VfStorage::RamControl => StorageKind::RamControl,
                VfStorage::Eeprom => StorageKind::Eeprom,
                VfStorage::FselIsel => StorageKind::FselIsel,
            };
            let mut c = new_code(r.number, d.name.as_str().trim(), kind);
            c.kind_char = d.kind.code();
            let unit = d.unit.as_str().trim().to_string();
            c.unit = (!unit.is_empty()).then_some(unit);
            c.basis = Some(!d.kind.inverter_specific);
            let ty = if unknown_type.is_some() {
                None
            } else {
                Some(d.ty)
            };
            set_bounds(
                &mut c,
                ty,
                [u32::from(d.min), u32::from(d.max), u32::from(d.default)],
                false,
                &mut findings,
                unknown_type.unwrap_or(d.ty.code()),
            );
            if c.ty == Some(ParameterType::Password) {
                c.password = true;
            }
            codes.push(c);
        }
    }
    Learned {
        protocol,
        layouts,
        type_chars,
        type_chars_guessed,
        codes,
        findings,
        asked: raws.len(),
        asked_params: raws.iter().map(|r| r.number).collect(),
        absent: 0,
        texts_read: 0,
        descriptions_hash: hash,
    }
}

/// What 108-STEXT holds now (to set it back).
fn read_stext<L: ByteLink>(client: &mut LustbusClient<L>) -> Result<u8, EngineError> {
    let code = ParameterCode::mc_value(STEXT).unwrap_or(ParameterCode::POSMOD);
    let v = client.enquire_code(code, 8)?;
    Ok(v.and_then(|t| {
        std::str::from_utf8(t.as_bytes())
            .ok()
            .and_then(|s| u32::from_str_radix(s, 16).ok())
    })
    .and_then(|n| u8::try_from(n).ok())
    .unwrap_or(0))
}

/// Substitution text `index` of parameter `p` (section 11.3), `None` on
/// NAK.
fn substitution_text<L: ByteLink>(
    client: &mut LustbusClient<L>,
    p: u32,
    index: u8,
) -> Result<Option<String>, EngineError> {
    client.select_stext(index)?;
    let Some(code) = u16::try_from(p)
        .ok()
        .and_then(ParameterCode::substitution_text)
    else {
        return Ok(None);
    };
    Ok(client.enquire_code(code, 100)?.and_then(|t| {
        decode_substitution_text(t.as_bytes())
            .ok()
            .map(str::to_string)
    }))
}

/// MC: reads the unit strings (107-UNIT texts) and the value substitution
/// texts of ShowText parameters (where the description does not carry the
/// attribute, of every PT_USIGN8 parameter that answers text 0 or its
/// minimum). Only the RAM selector 108-STEXT is written, and set back.
pub fn read_texts<L: ByteLink>(
    client: &mut LustbusClient<L>,
    learned: &mut Learned,
) -> Result<(), EngineError> {
    if learned.protocol != Family::Mc6000 {
        return Ok(());
    }
    let mut stext_old = None;
    let mut units: BTreeMap<u8, Option<String>> = BTreeMap::new();
    let mut read = 0;
    for c in &mut learned.codes {
        if let Some(u) = c.unit_index {
            if let std::collections::btree_map::Entry::Vacant(slot) = units.entry(u) {
                if stext_old.is_none() {
                    stext_old = Some(read_stext(client)?);
                }
                let t = substitution_text(client, u32::from(UNIT), u)?;
                slot.insert(t.filter(|t| !t.is_empty()));
            }
            c.unit = units.get(&u).cloned().flatten();
        }
        if c.ty != Some(ParameterType::Usign8) || c.show_text == Some(false) {
            continue;
        }
        let lo = c.min.unwrap_or(0).clamp(0, 255);
        let hi = c.max.unwrap_or(255).clamp(0, 255);
        if stext_old.is_none() {
            stext_old = Some(read_stext(client)?);
        }
        let mut seen = BTreeSet::new();
        for i in lo..=hi {
            match substitution_text(client, c.number, i as u8)? {
                Some(t) if !t.is_empty() => {
                    let fresh = seen.insert(t.clone());
                    if fresh {
                        c.texts.insert(i, t);
                    }
                    read += usize::from(fresh);
                }
                // No ShowText attribute known: a NAK for the first value
                // means the parameter has no texts.
                _ if c.show_text.is_none() && i == lo => break,
                _ => {}
            }
        }
        if c.show_text.is_none() && !c.texts.is_empty() {
            c.guessed.push(
                "value texts found by asking for them (the description does not carry the ShowText attribute)".into(),
            );
        }
    }
    if let Some(old) = stext_old {
        client.select_stext(old)?;
    }
    learned.texts_read = read;
    Ok(())
}

/// Reads and interprets a drive's descriptions and texts.
pub fn learn<L: ByteLink>(
    client: &mut LustbusClient<L>,
    protocol: Family,
    opts: &LearnOptions,
) -> Result<Learned, EngineError> {
    let params = opts
        .params
        .clone()
        .unwrap_or_else(|| default_params(protocol));
    let (raws, absent) = read_descriptions(client, protocol, &params)?;
    let mut learned = interpret(protocol, &raws, opts);
    learned.asked = params.len();
    learned.asked_params = params.iter().copied().collect();
    learned.absent = absent;
    if !opts.no_texts {
        read_texts(client, &mut learned)?;
    }
    Ok(learned)
}

fn q(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

/// Where a learned schema comes from, for its file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LearnSource {
    /// `<port> address <a>`.
    pub drive: String,
    /// The drive's identity (for the header and `[schema.identify]`).
    pub identity: Identity,
}

/// A rendered, checked learned schema.
#[derive(Debug, Clone)]
pub struct LearnedSchema {
    /// Its id (also the file stem).
    pub id: String,
    /// The file text.
    pub text: String,
    /// The schema, parsed and checked.
    pub schema: Arc<Schema>,
    /// Codes in the file that came from the drive.
    pub codes: usize,
}

/// The [`LearnFinding::action`] of a contradiction: the base schema's
/// fact stands, the drive's is recorded in the learned file.
pub const KEPT_SPEC: &str = "kept the spec's";

/// One fact on which a drive's description contradicts its base schema
/// (whose fact stands; module docs, merge rule).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Disagreement {
    /// The schema key (`kind`, `type`, `min`, `max`, `default`, `unit`).
    fact: &'static str,
    /// The drive's value, as a schema file spells it.
    drive: String,
    /// The base schema's value, as its file spells it.
    spec: String,
}

/// What a drive's description of `c` contradicts in its base code `b`:
/// the facts the base gives otherwise, and the role (a command, control
/// word or setpoint the drive calls an actual value).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct Contradictions {
    facts: Vec<Disagreement>,
    /// The base's role where the drive describes a read-only actual value
    /// of a code that role must write.
    role: Option<Role>,
}

impl Contradictions {
    fn is_empty(&self) -> bool {
        self.facts.is_empty() && self.role.is_none()
    }
}

/// A storage kind as schema files spell it (`kind = "..."`).
fn kind_name(k: StorageKind) -> &'static str {
    match k {
        StorageKind::RamActual => "ram-actual",
        StorageKind::RamControl => "ram-control",
        StorageKind::Eeprom => "eeprom",
        StorageKind::FselIsel => "fsel-isel",
    }
}

fn kind_words(k: StorageKind) -> &'static str {
    match k {
        StorageKind::RamActual => "an actual value",
        StorageKind::RamControl => "a RAM control value",
        StorageKind::Eeprom => "an EEPROM value",
        StorageKind::FselIsel => "an FSEL/ISEL variable",
    }
}

fn fact_text(f: &driveset_schema::schema::Fact) -> String {
    match &f.value {
        driveset_schema::doc::NodeKind::Str(t) | driveset_schema::doc::NodeKind::Num(t) => {
            t.clone()
        }
        other => format!("{other:?}"),
    }
}

/// Whether a drive's unit string says the spec's (VF1000 descriptions
/// carry at most 6 characters: a cut spec unit agrees).
fn same_unit(drive: &str, spec: &str) -> bool {
    let (d, s) = (drive.trim(), spec.trim());
    d.eq_ignore_ascii_case(s)
        || (d.chars().count() == 6 && s.to_ascii_lowercase().starts_with(&d.to_ascii_lowercase()))
}

fn contradictions(c: &LearnedCode, b: &Code, base: &Schema) -> Contradictions {
    let mut out = Contradictions::default();
    let base_type = base.type_of(b);
    if let (Some(bt), Some(t)) = (base_type, c.ty)
        && bt.name() != t.name()
    {
        out.facts.push(Disagreement {
            fact: "type",
            drive: t.name().into(),
            spec: bt.name().into(),
        });
    }
    let write_role = b.role.filter(|r| {
        matches!(r, Role::ControlWord | Role::Command | Role::Setpoint)
            && b.access != Some(driveset_schema::schema::Access::Ro)
    });
    match b.kind {
        Some(k) if k != c.kind => out.facts.push(Disagreement {
            fact: "kind",
            drive: kind_name(c.kind).into(),
            spec: kind_name(k).into(),
        }),
        None if c.kind == StorageKind::RamActual && write_role.is_some() => {
            out.role = write_role;
        }
        _ => {}
    }
    if let (Some(u), Some(bu)) = (&c.unit, &b.unit)
        && !same_unit(u, bu)
    {
        out.facts.push(Disagreement {
            fact: "unit",
            drive: u.clone(),
            spec: bu.clone(),
        });
    }
    // Bounds compare raw, in the spec's type, else the drive's (a type
    // disagreement says the rest).
    let vt = base_type.or_else(|| c.ty.and_then(|t| ValueType::from_name(t.name())));
    if let Some(vt) = vt
        && c.ty.is_none_or(|t| t.name() == vt.name())
    {
        for (fact, drive, spec) in [
            ("min", c.min, b.min.as_ref()),
            ("max", c.max, b.max.as_ref()),
            ("default", c.default, b.default.as_ref()),
        ] {
            let (Some(d), Some(f)) = (drive, spec) else {
                continue;
            };
            // The spec's fact in raw units: as the schema converts it,
            // or (a code the spec gives no type) in the drive's type.
            let spec_raw = match base.fact_raw(b, f) {
                Ok(driveset_schema::canonical::RawValue::Int(raw)) => Some(raw),
                Ok(_) => None,
                Err(_) => driveset_schema::Decimal::parse(&fact_text(f))
                    .ok()
                    .and_then(|v| driveset_schema::value::decimal_to_raw(vt, b.width, &v).ok()),
            };
            if let Some(raw) = spec_raw
                && raw != d
            {
                out.facts.push(Disagreement {
                    fact,
                    drive: raw_to_engineering(vt, d),
                    spec: fact_text(f),
                });
            }
        }
    }
    out
}

/// Where the base schema's facts of `b` come from, as reports cite it
/// (`lustbus-protocol.txt section 8.1.1`).
fn spec_source(b: &Code, base: &Schema) -> String {
    b.spec
        .clone()
        .or_else(|| base.spec.clone())
        .unwrap_or_else(|| format!("schema {}", base.id))
        .replace('§', "section ")
}

/// The report's sentence for a contradiction (issue 18's wording).
fn contradiction_message(c: &LearnedCode, b: &Code, base: &Schema, x: &Contradictions) -> String {
    let code = base.display_code(c.number, None);
    let spec = spec_source(b, base);
    let ty = c.ty.map_or_else(
        || "an unknown type".to_string(),
        |t| t.name().trim_start_matches("PT_").to_string(),
    );
    let mut parts = Vec::new();
    if let Some(role) = x.role {
        let role = role.as_str().replace('-', " ");
        parts.push(format!(
            "the drive describes {} (kind {}, {ty}); {spec} makes it a {role}: kept as a {role}{}",
            kind_words(c.kind),
            show_char(c.kind_char).trim_matches('\''),
            if x.role.is_some_and(Role::left_out_of_pulled_sets) {
                ", left out of the set"
            } else {
                ""
            }
        ));
    }
    if !x.facts.is_empty() {
        parts.push(format!(
            "the drive describes {}; {spec} gives {}: the spec's {} (the drive's recorded in the learned file)",
            x.facts
                .iter()
                .map(|d| format!("{} {}", d.fact, d.drive))
                .collect::<Vec<_>>()
                .join(", "),
            x.facts
                .iter()
                .map(|d| format!("{} {}", d.fact, d.spec))
                .collect::<Vec<_>>()
                .join(", "),
            if x.facts.len() == 1 { "stands" } else { "stand" }
        ));
    }
    format!("{code}: {}", parts.join("; "))
}

/// How reports name learned parameter `number`: the base schema's display
/// code, else `<number>-<the description's name>`.
fn code_name(learned: &Learned, base: &Schema, number: u32) -> String {
    if base.code(number).is_some() {
        return base.display_code(number, None);
    }
    match learned.codes.iter().find(|c| c.number == number) {
        Some(c) if !c.name.trim().is_empty() => format!("{number}-{}", c.name.trim()),
        _ => number.to_string(),
    }
}

/// Renders `learned` as a schema file extending `base` (merge rule in the
/// module docs), parses and checks it, and leaves out any code the check
/// objects to (recorded in `learned.findings`, naming the code and the
/// check). Where the drive contradicts a fact of `base`, the base's fact
/// stands, the drive's is recorded in the file (`# drive says:`) and a
/// `kept the spec's` finding names the code, both facts and the spec
/// section. `registry` must hold `base`. Fails only when the file's own
/// head (not a code) does not check.
pub fn render_schema(
    learned: &mut Learned,
    base: &Schema,
    id: &str,
    source: &LearnSource,
    registry: &Registry,
) -> Result<LearnedSchema, String> {
    for c in &learned.codes {
        if let Some(b) = base.code(c.number) {
            let x = contradictions(c, b, base);
            if !x.is_empty() {
                learned.findings.push(LearnFinding {
                    code: String::new(),
                    number: c.number,
                    action: KEPT_SPEC,
                    reason: contradiction_message(c, b, base, &x),
                });
            }
        }
    }
    // A type the learner downgraded or dropped does not matter where the
    // spec gives the type: say so rather than "not read".
    for f in &mut learned.findings {
        if let Some(bt) = base.code(f.number).and_then(|b| base.type_of(b))
            && f.action == "downgraded"
            && f.reason.contains("type")
        {
            let head = f
                .reason
                .rsplit_once("; ")
                .map_or(f.reason.as_str(), |(h, _)| h);
            f.reason = format!("{head}; the spec's type {} stands", bt.name());
        }
    }
    let file = format!("{id}.toml");
    let mut dropped: BTreeSet<u32> = BTreeSet::new();
    let result = loop {
        let (text, spans) = render_text(learned, base, id, source, &dropped);
        let mut reg = registry.clone();
        let parsed = reg.add_source(SourceFile::new(file.clone(), text.clone()));
        let objections: Vec<(Location, String)> = match &parsed {
            Ok(schema) => check_schema(schema)
                .into_iter()
                .map(|f| (f.location, f.message))
                .collect(),
            Err(e) => vec![((*e.location).clone(), e.message.clone())],
        };
        if objections.is_empty() {
            let schema = reg
                .get(id)
                .ok_or_else(|| format!("learned schema {id} vanished"))?;
            let codes = learned.codes.len() - dropped.len();
            break Ok(LearnedSchema {
                id: id.to_string(),
                text,
                schema,
                codes,
            });
        }
        // The code an objection is about: the learned entry holding its
        // line, or (a fact merged into a base code) the base code whose
        // entry holds it.
        let owner = |loc: &Location| -> Option<u32> {
            if loc.file == file {
                return spans
                    .iter()
                    .find(|(_, r)| r.contains(&loc.line))
                    .map(|(n, _)| *n);
            }
            let codes = parsed.as_ref().map_or(&base.codes, |s| &s.codes);
            codes
                .iter()
                .filter(|c| c.loc.file == loc.file && c.loc.line <= loc.line)
                .max_by_key(|c| c.loc.line)
                .map(|c| c.number)
                .filter(|n| learned.codes.iter().any(|c| c.number == *n))
        };
        let mut progress = false;
        let mut unowned = Vec::new();
        for (loc, msg) in objections {
            match owner(&loc) {
                Some(n) if !dropped.contains(&n) => {
                    dropped.insert(n);
                    learned.findings.push(LearnFinding {
                        code: String::new(),
                        number: n,
                        action: "left out",
                        reason: format!(
                            "the learned entry fails `schema check` ({}:{}): {msg}",
                            loc.file, loc.line
                        ),
                    });
                    progress = true;
                }
                Some(_) => {}
                None => unowned.push(format!("{}:{}: {msg}", loc.file, loc.line)),
            }
        }
        if !progress {
            break Err(format!(
                "the learned schema {id} fails `schema check` outside any learned code: {}",
                unowned.join("; ")
            ));
        }
    };
    let names: Vec<String> = learned
        .findings
        .iter()
        .map(|f| code_name(learned, base, f.number))
        .collect();
    for (f, name) in learned.findings.iter_mut().zip(names) {
        f.code = name;
    }
    result
}

/// The file text and the line range of each learned code's entry.
fn render_text(
    learned: &Learned,
    base: &Schema,
    id: &str,
    source: &LearnSource,
    dropped: &BTreeSet<u32>,
) -> (String, Vec<(u32, std::ops::Range<usize>)>) {
    let mc = learned.protocol == Family::Mc6000;
    if let Some(prev) = &base.learned {
        return render_on_learned(learned, base, prev, id, source, dropped);
    }
    let mut out = String::new();
    let ident: Vec<String> = source
        .identity
        .codes
        .iter()
        .map(|c| format!("{} = {}", c.name, c.value))
        .collect();
    let _ = writeln!(
        out,
        "# Schema learned by driveset from the drive's own parameter descriptions\n# (LUSTBUS section {}){}.",
        if mc { "11.2" } else { "11.1" },
        if mc {
            " and substitution texts (section 11.3)"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "# Drive: {}{}{}.",
        source.drive,
        if ident.is_empty() { "" } else { ", " },
        ident.join(", ")
    );
    let _ = writeln!(
        out,
        "# Merge rule: extends `{}`; the built-in schema's spec facts stand, the\n# drive's descriptions fill in what it leaves unset. `# learned:` lists the\n# facts taken from the drive, `guessed:` what is a guess.",
        base.id
    );
    if mc {
        let _ = writeln!(
            out,
            "# Description layout(s): {}; type characters: {}{}.",
            learned
                .layouts
                .iter()
                .map(|l| l.name())
                .collect::<Vec<_>>()
                .join(", "),
            learned
                .type_chars
                .as_ref()
                .map_or_else(|| "-".to_string(), McTypeChars::name),
            if learned.type_chars_guessed {
                " (guessed from the content)"
            } else {
                " (given)"
            }
        );
    }
    let _ = writeln!(out, "\n[schema]");
    let _ = writeln!(out, "id = {}", q(id));
    let _ = writeln!(
        out,
        "title = {}",
        q(&format!(
            "{} learned from {}",
            if mc { "MC6000/7000" } else { "VF1000" },
            source.drive
        ))
    );
    let _ = writeln!(out, "extends = {}", q(&base.id));
    let _ = writeln!(
        out,
        "protocol = {}",
        q(if mc { "lustbus-mc" } else { "lustbus-vf1000" })
    );
    let _ = writeln!(
        out,
        "spec = {}",
        q(&format!(
            "learned from the drive's descriptions ({}); spec facts from {}",
            source.drive, base.id
        ))
    );
    let ty_value = source.identity.value_of(91).and_then(IdentValue::as_int);
    let _ = writeln!(out, "\n[schema.identify]\ncodes = [91]");
    if let Some(t) = ty_value {
        let _ = writeln!(out, "type_values = [{t}]");
    }
    let _ = writeln!(
        out,
        "note = {}",
        q("learned: the TYPE the drive reported when its descriptions were read")
    );
    let _ = writeln!(
        out,
        "\n[schema.learned]\nasked = {}",
        q(&number_list_text(&learned.asked_params))
    );
    let (out, spans) = render_entries(out, learned, base, dropped, mc);
    (out, spans)
}

/// Appends the entries of the learned codes (not in `dropped`) to `out`;
/// returns the text and the line range of each entry.
fn render_entries(
    mut out: String,
    learned: &Learned,
    base: &Schema,
    dropped: &BTreeSet<u32>,
    mc: bool,
) -> (String, Vec<(u32, std::ops::Range<usize>)>) {
    let mut names: BTreeSet<String> = base.codes.iter().map(|c| c.name.clone()).collect();
    let mut spans = Vec::new();
    for c in &learned.codes {
        if dropped.contains(&c.number) {
            continue;
        }
        let start = out.lines().count() + 1;
        render_code(&mut out, c, base, &mut names, mc);
        let end = out.lines().count() + 1;
        spans.push((c.number, start..end));
    }
    (out, spans)
}

/// A schema learned on top of a learned one (`prev`, the file `base` was
/// read from): that file's own text with the new `id` and the union of
/// the parameters asked for, and the newly learned codes' entries
/// appended, so the result extends the same base as `prev` (a schema id
/// every reader resolves) and carries every entry of both.
fn render_on_learned(
    learned: &Learned,
    base: &Schema,
    prev: &driveset_schema::schema::LearnedFrom,
    id: &str,
    source: &LearnSource,
    dropped: &BTreeSet<u32>,
) -> (String, Vec<(u32, std::ops::Range<usize>)>) {
    let mc = learned.protocol == Family::Mc6000;
    let asked: BTreeSet<u32> = prev.asked.union(&learned.asked_params).copied().collect();
    let mut out = String::new();
    let mut table = "";
    for line in prev.text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            table = if t == "[schema]" {
                "schema"
            } else if t == "[schema.learned]" {
                "learned"
            } else {
                "other"
            };
        }
        if table == "schema" && t.starts_with("id ") | t.starts_with("id=") {
            let _ = writeln!(out, "id = {}", q(id));
        } else if table == "learned" && t.starts_with("asked") {
            let _ = writeln!(out, "asked = {}", q(&number_list_text(&asked)));
        } else {
            let _ = writeln!(out, "{line}");
        }
    }
    let _ = writeln!(
        out,
        "\n# Learned on top of `{}` from {}: parameters {}.",
        base.id,
        source.drive,
        number_list_text(&learned.asked_params)
    );
    render_entries(out, learned, base, dropped, mc)
}

fn render_code(
    out: &mut String,
    c: &LearnedCode,
    base: &Schema,
    names: &mut BTreeSet<String>,
    mc: bool,
) {
    let b = base.code(c.number);
    let mut learned_facts: Vec<&str> = Vec::new();
    let mut lines: Vec<String> = Vec::new();
    let mut comments: Vec<String> = Vec::new();
    lines.push(format!("number = {}", c.number));
    match b {
        Some(b) if !b.name.is_empty() => lines.push(format!("name = {}", q(&b.name))),
        _ => {
            let mut name: String = c
                .name
                .chars()
                .filter(|ch| ch.is_ascii_alphanumeric() || *ch == '_' || *ch == '-')
                .collect();
            if name.is_empty()
                || name.chars().all(|ch| ch.is_ascii_digit())
                || name.starts_with(['C', 'c']) && name[1..].chars().all(|ch| ch.is_ascii_digit())
            {
                name = format!("P{}", c.number);
            }
            if names.contains(&name) {
                name = format!("{name}_{}", c.number);
            }
            names.insert(name.clone());
            lines.push(format!("name = {}", q(&name)));
        }
    }
    if b.is_none_or(|b| b.title.is_none()) && !c.name.is_empty() {
        lines.push(format!("title = {}", q(&c.name)));
    }
    if b.is_none_or(|b| b.spec.is_none()) {
        lines.push(format!(
            "spec = {}",
            q(&format!(
                "learned from the drive's description (LUSTBUS section {})",
                if mc { "11.2" } else { "11.1" }
            ))
        ));
    }
    let base_type = b.and_then(|b| base.type_of(b));
    let against = b.map(|b| contradictions(c, b, base)).unwrap_or_default();
    if !against.is_empty() {
        // The drive's facts as a guess beside the spec's (docs/file-formats.md,
        // "Learned schema files").
        let mut said: Vec<String> = Vec::new();
        let mut stands: Vec<String> = Vec::new();
        if let Some(r) = against.role {
            said.push(format!("kind = {}", q(kind_name(c.kind))));
            stands.push(format!("role = {}", q(r.as_str())));
        }
        for d in &against.facts {
            said.push(format!("{} = {}", d.fact, q(&d.drive)));
            stands.push(format!("{} = {}", d.fact, q(&d.spec)));
        }
        comments.push(format!(
            "# drive says: {} (a guess; the spec's {} stands, {})",
            said.join(", "),
            stands.join(", "),
            b.map(|b| spec_source(b, base)).unwrap_or_default()
        ));
    }
    let ty_ok = !against.facts.iter().any(|d| d.fact == "type");
    if let (None, Some(t)) = (base_type, c.ty) {
        lines.push(format!("type = {}", q(t.name())));
        learned_facts.push("type");
    }
    let eff_type = base_type.or_else(|| c.ty.and_then(|t| ValueType::from_name(t.name())));
    if let Some(u) = &c.unit
        && b.is_none_or(|b| b.unit.is_none())
    {
        lines.push(format!("unit = {}", q(u)));
        learned_facts.push("unit");
    }
    if let (Some(vt), true) = (eff_type, ty_ok) {
        let e = |raw: i64| q(&raw_to_engineering(vt, raw));
        if let (Some(min), Some(max)) = (c.min, c.max)
            && b.is_none_or(|b| b.min.is_none() && b.max.is_none())
        {
            lines.push(format!("min = {}", e(min)));
            lines.push(format!("max = {}", e(max)));
            learned_facts.push("min");
            learned_facts.push("max");
        }
        if let Some(d) = c.default
            && b.is_none_or(|b| b.default.is_none() && b.min.is_none() && b.max.is_none())
        {
            lines.push(format!("default = {}", e(d)));
            learned_facts.push("default");
        }
    }
    let role_stands = against.role.is_some();
    if c.kind == StorageKind::RamActual && !role_stands && b.is_none_or(|b| b.access.is_none()) {
        lines.push("access = \"ro\"".into());
        learned_facts.push("access");
    }
    if !role_stands && b.is_none_or(|b| b.kind.is_none()) {
        lines.push(format!("kind = {}", q(kind_name(c.kind))));
        learned_facts.push("kind");
    }
    if let Some(basis) = c.basis
        && b.is_none_or(|b| b.basis.is_none())
    {
        lines.push(format!("basis = {basis}"));
        learned_facts.push("basis");
    }
    if let Some(t) = c.ty
        && ty_ok
        && b.is_none_or(|b| b.width.is_none())
    {
        lines.push(format!("width = {}", width_of(t)));
        learned_facts.push("width");
    }
    if let Some(cw) = c.card_writeable
        && b.is_none_or(|b| b.card_writeable.is_none())
    {
        lines.push(format!("card_writeable = {cw}"));
        learned_facts.push("card_writeable");
    }
    if c.password && b.is_none_or(|b| b.role.is_none()) {
        lines.push("role = \"password\"".into());
        learned_facts.push("role");
    }
    if b.is_none() && matches!(c.number, 81..=85 | 91) {
        lines.push("compatible = true".into());
    }
    if b.is_none() && c.number == 85 {
        lines.push("read_clears = true".into());
    }
    if !c.guessed.is_empty() {
        let text = format!("guessed: {}", c.guessed.join("; "));
        if b.is_none_or(|b| b.note.is_none()) {
            lines.push(format!("note = {}", q(&text)));
        } else {
            comments.push(format!("# {}", text.replace('\n', " ")));
        }
    }
    let texts = !c.texts.is_empty() && ty_ok && b.is_none_or(|b| b.values.is_none());
    if texts {
        lines.push("values_partial = true".into());
        learned_facts.push("values");
    }
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "# learned: {}",
        if learned_facts.is_empty() {
            "nothing (the spec gives every fact)".to_string()
        } else {
            learned_facts.join(", ")
        }
    );
    for cm in &comments {
        let _ = writeln!(out, "{cm}");
    }
    let _ = writeln!(out, "[[code]]");
    for l in &lines {
        let _ = writeln!(out, "{l}");
    }
    if texts {
        let _ = writeln!(out, "\n[code.values]");
        for (k, v) in &c.texts {
            let _ = writeln!(out, "{k} = {}", q(v));
        }
    }
}

/// A schema learned from one drive ([`pull_schema`]).
#[derive(Debug, Clone)]
pub struct PulledSchema {
    /// The drive's identity.
    pub identity: Identity,
    /// What was read and how it was interpreted.
    pub learned: Learned,
    /// The rendered, checked schema.
    pub rendered: LearnedSchema,
}

/// Why [`pull_schema`] failed.
#[derive(Debug, thiserror::Error)]
pub enum PullSchemaError {
    /// The bus or the drive failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The learned schema does not render into a file that checks.
    #[error("{0}")]
    Render(String),
}

/// `schema pull` and the learning commands: identify the drive, read and
/// interpret its descriptions (and MC texts) with `opts`, end the
/// exchange, and render the schema extending `base` with `id` (default:
/// [`learned_id`]); `drive` names it in the file (`<port> address <a>`).
/// `registry` must hold `base`. Nothing but the RAM selector 108-STEXT is
/// written, and it is set back.
pub fn pull_schema<L: ByteLink>(
    client: &mut LustbusClient<L>,
    base: &Schema,
    opts: &LearnOptions,
    id: Option<&str>,
    drive: String,
    registry: &Registry,
) -> Result<PulledSchema, PullSchemaError> {
    let identity = client.identify()?;
    let mut learned = learn(client, base.family, &options_for(base, opts))?;
    client.finish()?;
    let id = id.map_or_else(
        || learned_id(base.family, &identity, &learned),
        str::to_string,
    );
    let source = LearnSource {
        drive,
        identity: identity.clone(),
    };
    let rendered = render_schema(&mut learned, base, &id, &source, registry)
        .map_err(PullSchemaError::Render)?;
    Ok(PulledSchema {
        identity,
        learned,
        rendered,
    })
}
