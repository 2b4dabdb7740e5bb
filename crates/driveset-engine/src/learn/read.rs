//! Owns the learn run on the bus: asking each parameter for its
//! description (LUSTBUS sections 11.1, 11.2) and, for MC drives, the unit
//! strings (107-UNIT) and value substitution texts (108-STEXT + `61ppp`,
//! section 11.3). Only the RAM selector 108-STEXT is written, and set back.

use std::collections::{BTreeMap, BTreeSet};

use driveset_link::ByteLink;
use driveset_proto::lustbus::description::{STEXT, UNIT, decode_substitution_text};
use driveset_proto::lustbus::{ParameterCode, ParameterType};
use driveset_schema::Family;

use super::model::{Learned, RawDescription};
use super::scope::default_params;
use super::{LearnOptions, interpret, speaks_mc};
use crate::client::LustbusClient;
use crate::error::EngineError;

/// Asks every parameter of `params` for its description (a NAK: no such
/// parameter). Nothing is written. Returns the descriptions and how many
/// parameters the drive NAKed.
pub fn read_descriptions<L: ByteLink>(
    client: &mut LustbusClient<L>,
    protocol: Family,
    params: &[u32],
) -> Result<(Vec<RawDescription>, usize), EngineError> {
    let mc = speaks_mc(protocol);
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
/// NAK; the text as sent is kept in `raw`.
fn substitution_text<L: ByteLink>(
    client: &mut LustbusClient<L>,
    p: u32,
    index: u8,
    raw: &mut BTreeMap<(u32, u8), Vec<u8>>,
) -> Result<Option<String>, EngineError> {
    client.select_stext(index)?;
    let Some(code) = u16::try_from(p)
        .ok()
        .and_then(ParameterCode::substitution_text)
    else {
        return Ok(None);
    };
    Ok(client.enquire_code(code, 100)?.and_then(|t| {
        raw.insert((p, index), t.as_bytes().to_vec());
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
    if !speaks_mc(learned.protocol) {
        return Ok(());
    }
    let mut stext_old = None;
    let mut units: BTreeMap<u8, Option<String>> = BTreeMap::new();
    let mut read = 0;
    let mut raw_texts = std::mem::take(&mut learned.raw_texts);
    for c in &mut learned.codes {
        if let Some(u) = c.unit_index {
            if let std::collections::btree_map::Entry::Vacant(slot) = units.entry(u) {
                if stext_old.is_none() {
                    stext_old = Some(read_stext(client)?);
                }
                let t = substitution_text(client, u32::from(UNIT), u, &mut raw_texts)?;
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
            match substitution_text(client, c.number, i as u8, &mut raw_texts)? {
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
    learned.raw_texts = raw_texts;
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
