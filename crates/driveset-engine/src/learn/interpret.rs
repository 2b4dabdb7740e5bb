//! Owns the pure interpretation of a drive's descriptions (no bus): the
//! family's reader ([`super::mc`], LUSTBUS section 11.2; [`super::vf`],
//! section 11.1) turns them into [`LearnedCode`]s and findings, and the
//! descriptions' hash stands in for a software version in the learned
//! file's name.

use super::model::{Learned, RawDescription};
use super::{LearnOptions, mc, speaks_mc, vf};
use std::collections::BTreeSet;

use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::Family;

use super::model::{LearnFinding, LearnedCode};

/// What one family's reader made of the descriptions.
#[derive(Debug, Default)]
pub(super) struct Reading {
    /// The parameters read, in the order of their descriptions.
    pub codes: Vec<LearnedCode>,
    /// Descriptions left out or downgraded, in the order found.
    pub findings: Vec<LearnFinding>,
    /// MC: the layouts the descriptions came in.
    pub layouts: BTreeSet<McLayout>,
    /// MC: the type-character reading used.
    pub type_chars: Option<McTypeChars>,
    /// MC: whether that reading was guessed from the content.
    pub type_chars_guessed: bool,
}

/// FNV-1a over `data`, continuing from `h`.
fn fnv1a(data: &[u8], mut h: u32) -> u32 {
    for &b in data {
        h ^= u32::from(b);
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

/// Interprets the descriptions of a drive (pure; no bus). MC: each
/// description's layout by length and content (or `opts.layout`); the
/// type-character reading by which of driveset's and the table order fits
/// more descriptions (ties: driveset's), or `opts.type_chars`.
pub fn interpret(protocol: Family, raws: &[RawDescription], opts: &LearnOptions) -> Learned {
    let mut hash = 0x811C_9DC5;
    for r in raws {
        hash = fnv1a(&r.number.to_le_bytes(), hash);
        hash = fnv1a(&r.text, hash);
    }
    let reading = if speaks_mc(protocol) {
        mc::interpret(raws, opts)
    } else {
        vf::interpret(raws)
    };
    Learned {
        protocol,
        layouts: reading.layouts,
        type_chars: reading.type_chars,
        type_chars_guessed: reading.type_chars_guessed,
        codes: reading.codes,
        findings: reading.findings,
        asked: raws.len(),
        asked_params: raws.iter().map(|r| r.number).collect(),
        absent: 0,
        texts_read: 0,
        descriptions_hash: hash,
        raw: raws.to_vec(),
        raw_texts: std::collections::BTreeMap::new(),
    }
}
