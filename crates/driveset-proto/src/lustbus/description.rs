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

mod layout;
mod mc;
mod texts;
mod vf;
pub use layout::*;
pub use mc::*;
pub use texts::*;
pub use vf::*;

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

#[cfg(test)]
mod tests;
