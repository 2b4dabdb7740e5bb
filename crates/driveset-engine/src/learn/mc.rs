//! Owns reading MC6000/7000 descriptions (specifier 3, LUSTBUS section
//! 11.2): telling each description's layout by length and content (errata
//! L22: the 52-character form and the table's 43 / 42 / 34) and choosing the
//! type-character reading that fits the drive's descriptions best (errata
//! L23: driveset's order or the table's).

use std::collections::BTreeSet;

use driveset_proto::lustbus::ParameterType;
use driveset_proto::lustbus::description::{
    Attributes, DescriptionError, McKind, McLayout, McRawDescription, McTypeChars,
};
use driveset_schema::schema::StorageKind;

use super::LearnOptions;
use super::bounds::{fits, ordered, set_bounds, show_char};
use super::interpret::Reading;
use super::model::{LearnFinding, RawDescription, new_code};

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

/// Reads MC descriptions (pure): each one's layout by length and content
/// (or `opts.layout`); the type-character reading by which of driveset's
/// and the table order fits more descriptions (ties: driveset's), or
/// `opts.type_chars`.
pub(super) fn interpret(raws: &[RawDescription], opts: &LearnOptions) -> Reading {
    let mut findings = Vec::new();
    let mut codes = Vec::new();
    let mut layouts = BTreeSet::new();
    let mut type_chars_guessed = false;
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
            c.downgrade(&mut findings, msg);
        }
        codes.push(c);
    }
    Reading {
        codes,
        findings,
        layouts,
        type_chars: Some(reading),
        type_chars_guessed,
    }
}
