//! Code numbers and their text: number lists (`1-99,101`, the form of
//! `--params` and `[schema.learned] asked`), the numbers of CiA 301 objects
//! kept by index (CiA 301 7.4), and integer literal text.

use std::collections::BTreeSet;

/// Parses a list of parameter numbers and ranges, `1-99` or
/// `1,5,100-120`, into the numbers (the form of `--params` and of
/// `[schema.learned] asked`).
pub fn parse_number_list(text: &str) -> Result<BTreeSet<u32>, String> {
    let mut out = BTreeSet::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (a.trim(), b.trim()),
            None => (part, part),
        };
        let num = |s: &str| {
            s.parse::<u32>()
                .map_err(|_| format!("`{part}` is not a number or a range like 1-99"))
        };
        let (a, b) = (num(a)?, num(b)?);
        if a > b {
            return Err(format!("`{part}`: a range goes up"));
        }
        out.extend(a..=b);
    }
    if out.is_empty() {
        return Err("names no parameter".into());
    }
    Ok(out)
}

/// The shortest [`parse_number_list`] text of `numbers` (`1-99,101`).
pub fn number_list_text(numbers: &BTreeSet<u32>) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut it = numbers.iter().copied().peekable();
    while let Some(a) = it.next() {
        let mut b = a;
        while it.peek() == Some(&(b + 1)) {
            b += 1;
            it.next();
        }
        parts.push(if a == b {
            a.to_string()
        } else {
            format!("{a}-{b}")
        });
    }
    parts.join(",")
}

/// Code numbers of CiA 301 objects kept by index (`[[code]] index`):
/// number = 65536 + index, above every Lenze code (index = 24575 - code).
pub const CIA_NUMBER_BASE: u32 = 0x1_0000;

/// Code numbers of single subindexes kept by index (`[[code]] index` and
/// `subindex`): number = 16777216 + index x 256 + subindex, above every
/// whole object's number.
pub const SUBINDEX_NUMBER_BASE: u32 = 0x100_0000;

/// The code number of an object kept by index: 65536 + index, or with a
/// subindex 16777216 + index x 256 + subindex.
pub fn index_number(index: u16, subindex: Option<u8>) -> u32 {
    match subindex {
        None => CIA_NUMBER_BASE + u32::from(index),
        Some(s) => SUBINDEX_NUMBER_BASE + (u32::from(index) << 8) + u32::from(s),
    }
}

/// `C` + digits or digits only: the shape of a code-number key.
pub(crate) fn looks_numeric_key(key: &str) -> bool {
    let d = key.strip_prefix(['C', 'c']).unwrap_or(key);
    !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit())
}

/// Integer literal text (decimal, `0x`, `0o`, `0b`, `_` separators).
pub(crate) fn parse_int_text(t: &str) -> Option<i128> {
    match crate::value::parse_radix_int(t) {
        Some(r) => r.ok(),
        None => crate::decimal::Decimal::parse(t).ok()?.to_integer(),
    }
}
