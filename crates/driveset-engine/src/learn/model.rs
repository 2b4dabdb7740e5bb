//! Owns the learning records: a description as the drive sent it, a
//! parameter learned from it, a finding about a description the learned
//! schema could not take as it came, and what one drive taught.

use std::collections::{BTreeMap, BTreeSet};

use driveset_proto::lustbus::ParameterType;
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::Family;
use driveset_schema::schema::StorageKind;

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
/// not take as it came (fields in the alphabetical order of the JSON keys
/// reports have always given them: [`crate::session::LearnDoc`]).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct LearnFinding {
    /// `left out`, `downgraded`, or `kept the spec's` (the drive's
    /// description contradicts a fact of the base schema, which stands).
    pub action: &'static str,
    /// The code as reports spell it (`11-STAT`; the description's name for
    /// a code the base schema does not name), filled by [`render_schema`](super::render_schema).
    pub code: String,
    /// Parameter number.
    pub number: u32,
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
    /// Every description as the drive sent it, in the order asked (a twin
    /// serves them as they came, docs/twins.md).
    pub raw: Vec<RawDescription>,
    /// MC: every substitution text the drive sent (section 11.3), as
    /// sent, by parameter (107-UNIT for the unit strings) and 108-STEXT
    /// index; a text it answered with NAK is not here.
    pub raw_texts: BTreeMap<(u32, u8), Vec<u8>>,
}

pub(super) fn new_code(number: u32, name: &str, kind: StorageKind) -> LearnedCode {
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

impl LearnedCode {
    /// Something of the description contradicts itself and was left out
    /// or kept in a weaker form (module docs of [`super`]): `reason` is
    /// kept among the code's guesses and reported as a `downgraded`
    /// finding.
    pub(super) fn downgrade(&mut self, findings: &mut Vec<LearnFinding>, reason: String) {
        self.guessed.push(reason.clone());
        findings.push(LearnFinding {
            code: String::new(),
            number: self.number,
            action: "downgraded",
            reason,
        });
    }
}

/// The [`LearnFinding::action`] of a contradiction: the base schema's
/// fact stands, the drive's is recorded in the learned file.
pub const KEPT_SPEC: &str = "kept the spec's";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_downgrade_is_a_guess_of_the_code_and_a_finding() {
        let mut c = new_code(82, "ADDR", StorageKind::Eeprom);
        let mut findings = Vec::new();
        c.downgrade(&mut findings, "its default is outside its range".into());
        assert_eq!(c.guessed, ["its default is outside its range"]);
        assert_eq!(
            findings,
            [LearnFinding {
                code: String::new(),
                number: 82,
                action: "downgraded",
                reason: "its default is outside its range".into(),
            }]
        );
    }
}
