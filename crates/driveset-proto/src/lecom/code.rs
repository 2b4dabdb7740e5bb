//! Code numbers and how a telegram addresses a parameter: standard
//! addressing C1 C2 (section 8.A), code banks via C0249 (8.B, Table 1 C0249),
//! input selection via C0248 (8.C, Table 1 C0248) and extended addressing
//! `!CH1 CH2 CH3 CH4 SC1 SC2` (8.D). Owns [`CodeNumber`], [`ExtendedAddress`],
//! [`CodeAddress`], [`CodeBank`] and [`LegacyAccess`].

use core::fmt;

use super::error::{CodeError, FrameError};

/// A code number in standard addressing, 0..=6229, sent as two characters
/// C1 C2 (section 8.A):
///
/// ```text
/// C1 = INTEGER(REMAINDER(code/790) / 10) + 48
/// C2 = REMAINDER(REMAINDER(code/790) / 10) + INTEGER(code/790) * 10 + 48
/// ```
///
/// Codes below 100 come out as their two decimal digits (C46 -> "46").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CodeNumber(u16);

impl CodeNumber {
    /// The highest code number standard addressing reaches (8.A).
    pub const MAX: u16 = 6229;
    /// C0068 operating status bit word (Table 1).
    pub const C0068: Self = Self(68);
    /// C0248 LECOM input selection, always reachable as 248 (8.C).
    pub const C0248: Self = Self(248);
    /// C0249 LECOM code bank, always reachable as 249 (8.B).
    pub const C0249: Self = Self(249);
    /// C1962 extended error code (Table 1).
    pub const C1962: Self = Self(1962);

    /// The code number `code`, if standard addressing reaches it.
    ///
    /// # Errors
    /// [`CodeError::OutOfRange`] above 6229.
    pub const fn new(code: u16) -> Result<Self, CodeError> {
        if code <= Self::MAX {
            Ok(Self(code))
        } else {
            Err(CodeError::OutOfRange { code: code as u32 })
        }
    }

    /// The number.
    pub const fn get(self) -> u16 {
        self.0
    }

    /// C1 C2 by the /790 formula of section 8.A (1002 -> "E<").
    pub const fn to_c1c2(self) -> [u8; 2] {
        let rem = self.0 % 790;
        let quot = self.0 / 790;
        [(rem / 10 + 48) as u8, (rem % 10 + quot * 10 + 48) as u8]
    }

    /// The exact inverse of [`to_c1c2`](Self::to_c1c2). C1 C2 are expected
    /// parity-masked.
    ///
    /// # Errors
    /// [`CodeError::CharOutOfRange`] for a byte outside 48..=127;
    /// [`CodeError::NotFromFormula`] for a pair the formula never produces
    /// for codes 0..=6229 (C1 = 127, or a code above 6229).
    pub const fn from_c1c2(c: [u8; 2]) -> Result<Self, CodeError> {
        let [c1, c2] = c;
        if c1 < 48 || c1 > 127 {
            return Err(CodeError::CharOutOfRange {
                position: 1,
                byte: c1,
            });
        }
        if c2 < 48 || c2 > 127 {
            return Err(CodeError::CharOutOfRange {
                position: 2,
                byte: c2,
            });
        }
        let tens = (c1 - 48) as u16; // REMAINDER(code/790) / 10, 0..=78
        let low = (c2 - 48) as u16; // units + 10 * INTEGER(code/790)
        let rem = tens * 10 + low % 10;
        let code = (low / 10) * 790 + rem;
        if rem >= 790 || code > Self::MAX {
            return Err(CodeError::NotFromFormula { c1, c2 });
        }
        Ok(Self(code))
    }
}

impl fmt::Display for CodeNumber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "C{:04}", self.0)
    }
}

/// Extended addressing `! CH1 CH2 CH3 CH4 SC1 SC2` (section 8.D): code
/// 0..=65535 and subcode 0..=255 as uppercase hex, highest nibble first.
/// Code banks (C0249) and input selection (C0248) do not apply to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExtendedAddress {
    pub code: u16,
    pub subcode: u8,
}

impl ExtendedAddress {
    /// Length of the field on the wire: `!` and six hex characters.
    pub const LEN: usize = 7;

    /// The seven characters (1002 / 0 -> "!03EA00").
    pub const fn to_ascii(self) -> [u8; 7] {
        let c = self.code;
        let s = self.subcode as u16;
        [
            b'!',
            hex_digit(c >> 12),
            hex_digit(c >> 8),
            hex_digit(c >> 4),
            hex_digit(c),
            hex_digit(s >> 4),
            hex_digit(s),
        ]
    }

    /// Parses the seven characters (parity-masked).
    ///
    /// # Errors
    /// [`CodeError::BadExtendedDigit`] when the first byte is not `!` or a
    /// hex character is not 0-9 / A-F (position 0 is the `!`).
    pub fn from_ascii(field: [u8; 7]) -> Result<Self, CodeError> {
        if field[0] != b'!' {
            return Err(CodeError::BadExtendedDigit {
                position: 0,
                byte: field[0],
            });
        }
        let mut n: u32 = 0;
        for (i, &b) in field.iter().enumerate().skip(1) {
            let Some(d) = hex_value(b) else {
                return Err(CodeError::BadExtendedDigit {
                    position: i as u8,
                    byte: b,
                });
            };
            n = (n << 4) | u32::from(d);
        }
        Ok(Self {
            code: (n >> 8) as u16,
            subcode: (n & 0xFF) as u8,
        })
    }
}

impl fmt::Display for ExtendedAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "C{:04}/{}", self.code, self.subcode)
    }
}

/// The code field of a telegram or response: C1 C2 or extended addressing
/// (sections 8.A, 8.D; 8.H: "C1, C2 code number (two ASCII characters) or
/// extended addressing").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CodeAddress {
    /// C1 C2; the subcode, if any, comes from C0248 (8.C) and the code
    /// offset from C0249 (8.B).
    Standard(CodeNumber),
    /// `!` + 4 hex code + 2 hex subcode.
    Extended(ExtendedAddress),
}

impl CodeAddress {
    /// Picks the addressing for `(code, subcode)`: standard C1 C2 when
    /// `code <= 6229` and `subcode == 0` (the form every LECOM-A/B driver and
    /// controller understands, and two bytes instead of seven), extended
    /// addressing otherwise. Note that standard addressing is subject to the
    /// drive's current C0249 code bank and C0248 input selection; a host
    /// that uses this helper leaves both at 0 (their power-on value).
    pub const fn select(code: u16, subcode: u8) -> Self {
        if code <= CodeNumber::MAX && subcode == 0 {
            Self::Standard(CodeNumber(code))
        } else {
            Self::Extended(ExtendedAddress { code, subcode })
        }
    }

    /// The code number this field names (for standard addressing: with code
    /// bank 0, i.e. as sent).
    pub const fn code(self) -> u16 {
        match self {
            Self::Standard(c) => c.0,
            Self::Extended(e) => e.code,
        }
    }

    /// The subcode the field names; standard addressing carries none (0,
    /// unless C0248 says otherwise on the drive).
    pub const fn subcode(self) -> u8 {
        match self {
            Self::Standard(_) => 0,
            Self::Extended(e) => e.subcode,
        }
    }

    /// Bytes on the wire: 2 or 7.
    pub const fn wire_len(self) -> usize {
        match self {
            Self::Standard(_) => 2,
            Self::Extended(_) => ExtendedAddress::LEN,
        }
    }

    /// Appends the field to `out`.
    pub fn write(self, out: &mut Vec<u8>) {
        match self {
            Self::Standard(c) => out.extend_from_slice(&c.to_c1c2()),
            Self::Extended(e) => out.extend_from_slice(&e.to_ascii()),
        }
    }

    /// The length of the code field at the start of `text`: 7 if it starts
    /// with `!` (C1 is never `!`, 33 < 48), else 2.
    pub fn field_len(text: &[u8]) -> usize {
        if text.first() == Some(&b'!') {
            ExtendedAddress::LEN
        } else {
            2
        }
    }

    /// Parses a complete code field (parity-masked), 2 or 7 bytes.
    ///
    /// # Errors
    /// [`FrameError::CodeLength`] for another length, else the
    /// [`CodeError`] of the field.
    pub fn parse(field: &[u8]) -> Result<Self, FrameError> {
        match *field {
            [c1, c2] => Ok(Self::Standard(CodeNumber::from_c1c2([c1, c2])?)),
            [a, b, c, d, e, f, g] => Ok(Self::Extended(ExtendedAddress::from_ascii([
                a, b, c, d, e, f, g,
            ])?)),
            _ => Err(FrameError::CodeLength { len: field.len() }),
        }
    }

    /// Splits `text` (the bytes after STX, or after AD2 of a RECEIVE) into
    /// the code field and the rest.
    ///
    /// # Errors
    /// [`FrameError::CodeLength`] when `text` is shorter than the field.
    pub fn split(text: &[u8]) -> Result<(Self, &[u8]), FrameError> {
        let n = Self::field_len(text);
        if text.len() < n {
            return Err(FrameError::CodeLength { len: text.len() });
        }
        let (field, rest) = text.split_at(n);
        Ok((Self::parse(field)?, rest))
    }
}

impl fmt::Display for CodeAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Standard(c) => c.fmt(f),
            Self::Extended(e) => e.fmt(f),
        }
    }
}

/// What a controller's standard addressing reaches: its C0249 code bank
/// and C0248 input selection (sections 8.B, 8.C). One mapping for every
/// crate: the simulated Tmd resolves the telegrams it receives with it,
/// and `driveset decode` follows C0249 / C0248 writes in a capture with it.
///
/// A standard code field `n` names code `250 x C0249 + n` with subcode
/// C0248, except that 248 and 249 are always C0248 / C0249 (subcode 0).
/// The offset is added to numbers above 255 too (8.B note: "If the
/// selected code numbers are higher than 255, the code-number range
/// increases correspondingly"; the other reading is discussed in
/// docs/errata/lecom.md). Extended addressing ignores both (8.D, Table 1
/// C0249).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct StandardAddressing {
    /// C0249.
    pub bank: CodeBank,
    /// C0248 (0 = no subcode).
    pub input_selection: u8,
}

impl StandardAddressing {
    /// The power-on state: bank 0, no input selection (Table 1: C0248 and
    /// C0249 "always set to 0 when switching on").
    pub const POWER_ON: Self = Self {
        bank: CodeBank(0),
        input_selection: 0,
    };

    /// The (code, subcode) a code field names on a controller in this state.
    pub const fn resolve(self, code: CodeAddress) -> (u16, u8) {
        match code {
            CodeAddress::Standard(CodeNumber(n)) => {
                if n == CodeNumber::C0248.0 || n == CodeNumber::C0249.0 {
                    (n, 0)
                } else {
                    (self.bank.offset() + n, self.input_selection)
                }
            }
            CodeAddress::Extended(e) => (e.code, e.subcode),
        }
    }

    /// Whether `code` is a write target that changes this state: C0248 or
    /// C0249 (by their fixed standard numbers or extended with subcode 0).
    pub const fn is_selector(code: CodeAddress) -> bool {
        matches!(
            code,
            CodeAddress::Standard(CodeNumber(248 | 249))
                | CodeAddress::Extended(ExtendedAddress {
                    code: 248 | 249,
                    subcode: 0
                })
        )
    }

    /// The state after `code` was written with the integer `value`; `None`
    /// when the write is not to C0248 / C0249 or the value is not one they
    /// hold (C0249 0..=15, C0248 0..=255; Table 1), i.e. a controller
    /// refuses it.
    pub const fn after_write(self, code: CodeAddress, value: i64) -> Option<Self> {
        if !Self::is_selector(code) {
            return None;
        }
        if code.code() == 249 {
            if value < 0 || value > CodeBank::MAX as i64 {
                return None;
            }
            Some(Self {
                bank: CodeBank(value as u8),
                ..self
            })
        } else {
            if value < 0 || value > u8::MAX as i64 {
                return None;
            }
            Some(Self {
                input_selection: value as u8,
                ..self
            })
        }
    }
}

/// A LECOM code bank, the value of C0249 (section 8.B; Table 1 C0249 lists
/// banks 0..=15). The bank adds `250 * bank` to every code number sent with
/// standard addressing, except 248 (C0248) and 249 (C0249), which stay
/// reachable in every bank. Extended addressing ignores it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct CodeBank(u8);

impl CodeBank {
    /// The highest bank (Table 1 C0249: 15 = 3750..4005).
    pub const MAX: u8 = 15;
    /// Width of a bank's window of local code numbers 0..=255 (8.B).
    pub const WINDOW: u16 = 256;
    /// Offset step between banks (8.B).
    pub const STEP: u16 = 250;

    /// # Errors
    /// [`CodeError::BankOutOfRange`] above 15.
    pub const fn new(bank: u8) -> Result<Self, CodeError> {
        if bank <= Self::MAX {
            Ok(Self(bank))
        } else {
            Err(CodeError::BankOutOfRange { bank })
        }
    }

    /// The bank number, the value to write into C0249.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// Code offset: 250 x bank (8.B table).
    pub const fn offset(self) -> u16 {
        self.0 as u16 * Self::STEP
    }

    /// The code a local number 0..=255 reaches in this bank; `None` above
    /// 255. 248 and 249 are C0248 / C0249 in every bank (8.B, 8.C).
    pub const fn resolve(self, local: u16) -> Option<u16> {
        if local >= Self::WINDOW {
            None
        } else if local == 248 || local == 249 {
            Some(local)
        } else {
            Some(self.offset() + local)
        }
    }

    /// The bank and local number that reach `code` through C0249: bank
    /// `INTEGER(code / 250)` as in the 8.B example (1002 -> bank 4, local 2),
    /// bank 15 for 4000..=4005. `None` for codes no bank reaches: above 4005,
    /// and the codes `250 * b + 248` / `+ 249` (b >= 1), whose local number
    /// is shadowed by C0248 / C0249. Use extended addressing for those.
    pub const fn locate(code: u16) -> Option<(Self, CodeNumber)> {
        let bank = if code / Self::STEP <= Self::MAX as u16 {
            code / Self::STEP
        } else {
            Self::MAX as u16
        };
        let offset = bank * Self::STEP;
        if code < offset {
            return None;
        }
        let local = code - offset;
        if local >= Self::WINDOW || (bank > 0 && (local == 248 || local == 249)) {
            return None;
        }
        Some((Self(bank as u8), CodeNumber(local)))
    }
}

/// How a driver limited to standard addressing (LECOM-A/B V1.0) reaches a
/// code and subcode: write `bank` into C0249 and `subcode` into C0248, then
/// access `local` (sections 8.B, 8.C). Afterwards C0248 should be set back
/// to 0 (8.C tip); C0249 too, to leave the drive in its power-on state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LegacyAccess {
    pub bank: CodeBank,
    pub input_selection: u8,
    pub local: CodeNumber,
}

impl LegacyAccess {
    /// `None` when no code bank reaches `code` (see [`CodeBank::locate`]).
    pub const fn new(code: u16, subcode: u8) -> Option<Self> {
        match CodeBank::locate(code) {
            Some((bank, local)) => Some(Self {
                bank,
                input_selection: subcode,
                local,
            }),
            None => None,
        }
    }
}

pub(crate) const fn hex_digit(n: u16) -> u8 {
    b"0123456789ABCDEF"[(n & 0xF) as usize]
}

/// Uppercase hex digit value; lowercase is rejected (8.D, 8.E: "0 to 9;
/// A to F").
pub(crate) const fn hex_value(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn spec_8a_example_1002_is_e_less_than() {
        let c = CodeNumber::new(1002).unwrap();
        assert_eq!(c.to_c1c2(), *b"E<");
        assert_eq!(c.to_c1c2(), [0x45, 0x3C]);
        assert_eq!(CodeNumber::from_c1c2(*b"E<").unwrap().get(), 1002);
    }

    #[test]
    fn small_codes_are_their_decimal_digits() {
        for (code, s) in [
            (46, b"46"),
            (68, b"68"),
            (11, b"11"),
            (40, b"40"),
            (5, b"05"),
        ] {
            assert_eq!(CodeNumber::new(code).unwrap().to_c1c2(), *s);
        }
    }

    #[test]
    fn formula_ends() {
        assert_eq!(CodeNumber::new(0).unwrap().to_c1c2(), *b"00");
        assert_eq!(CodeNumber::new(789).unwrap().to_c1c2(), [48 + 78, 48 + 9]);
        assert_eq!(CodeNumber::new(6229).unwrap().to_c1c2(), [117, 127]);
        assert_eq!(
            CodeNumber::new(6230),
            Err(CodeError::OutOfRange { code: 6230 })
        );
    }

    #[test]
    fn inverse_rejects_what_the_formula_never_produces() {
        assert_eq!(
            CodeNumber::from_c1c2([47, 48]),
            Err(CodeError::CharOutOfRange {
                position: 1,
                byte: 47
            })
        );
        assert_eq!(
            CodeNumber::from_c1c2([48, 128]),
            Err(CodeError::CharOutOfRange {
                position: 2,
                byte: 128
            })
        );
        // C1 = 127: REMAINDER(code/790) would be >= 790.
        assert_eq!(
            CodeNumber::from_c1c2([127, 48]),
            Err(CodeError::NotFromFormula { c1: 127, c2: 48 })
        );
        // 7 * 790 + 700 = 6230 > 6229.
        assert_eq!(
            CodeNumber::from_c1c2([118, 118]),
            Err(CodeError::NotFromFormula { c1: 118, c2: 118 })
        );
    }

    #[test]
    fn the_inverse_is_exact_over_all_pairs() {
        let mut hits = 0;
        for c1 in 0..=255u8 {
            for c2 in 0..=255u8 {
                if let Ok(c) = CodeNumber::from_c1c2([c1, c2]) {
                    assert_eq!(c.to_c1c2(), [c1, c2]);
                    hits += 1;
                }
            }
        }
        assert_eq!(hits, 6230);
    }

    #[test]
    fn spec_8d_example_extended_1002() {
        let e = ExtendedAddress {
            code: 1002,
            subcode: 0,
        };
        assert_eq!(e.to_ascii(), *b"!03EA00");
        assert_eq!(ExtendedAddress::from_ascii(*b"!03EA00").unwrap(), e);
        // The manual's "!03EAOO" (letter O) is an erratum and is rejected.
        assert_eq!(
            ExtendedAddress::from_ascii(*b"!03EAOO"),
            Err(CodeError::BadExtendedDigit {
                position: 5,
                byte: b'O'
            })
        );
        assert_eq!(
            ExtendedAddress::from_ascii(*b"!03ea00"),
            Err(CodeError::BadExtendedDigit {
                position: 3,
                byte: b'e'
            })
        );
        assert_eq!(
            ExtendedAddress {
                code: 0xFFFF,
                subcode: 0xFF
            }
            .to_ascii(),
            *b"!FFFFFF"
        );
    }

    #[test]
    fn select_prefers_standard_addressing() {
        assert_eq!(
            CodeAddress::select(1002, 0),
            CodeAddress::Standard(CodeNumber::new(1002).unwrap())
        );
        assert_eq!(
            CodeAddress::select(1002, 1),
            CodeAddress::Extended(ExtendedAddress {
                code: 1002,
                subcode: 1
            })
        );
        assert_eq!(
            CodeAddress::select(6230, 0),
            CodeAddress::Extended(ExtendedAddress {
                code: 6230,
                subcode: 0
            })
        );
        let mut out = Vec::new();
        CodeAddress::select(1002, 3).write(&mut out);
        assert_eq!(out, b"!03EA03");
        assert_eq!(CodeAddress::parse(b"!03EA03").unwrap().subcode(), 3);
        assert_eq!(
            CodeAddress::parse(b"123"),
            Err(FrameError::CodeLength { len: 3 })
        );
    }

    #[test]
    fn spec_8b_code_bank_example() {
        // "Set the code bank INTEGER(1002/250) = 4 in C0249 ... C1002 is then
        // accessed via the code number C02."
        let (bank, local) = CodeBank::locate(1002).unwrap();
        assert_eq!(bank.get(), 4);
        assert_eq!(bank.offset(), 1000);
        assert_eq!(local.get(), 2);
        assert_eq!(local.to_c1c2(), *b"02");
        assert_eq!(bank.resolve(2), Some(1002));
        // C0248 / C0249 are reachable in every bank.
        assert_eq!(bank.resolve(248), Some(248));
        assert_eq!(bank.resolve(249), Some(249));
        assert_eq!(bank.resolve(256), None);
        // Table 1 C0249: banks up to 15 (3750..4005).
        assert_eq!(CodeBank::new(15).unwrap().offset(), 3750);
        assert_eq!(
            CodeBank::new(16),
            Err(CodeError::BankOutOfRange { bank: 16 })
        );
        let (b, l) = CodeBank::locate(4005).unwrap();
        assert_eq!((b.get(), l.get()), (15, 255));
        assert_eq!(CodeBank::locate(4006), None);
        // Shadowed by C0248 / C0249.
        assert_eq!(CodeBank::locate(498), None);
        assert_eq!(CodeBank::locate(749), None);
        assert_eq!(CodeBank::locate(248).unwrap().0.get(), 0);
        let legacy = LegacyAccess::new(39, 1).unwrap();
        assert_eq!(
            (
                legacy.bank.get(),
                legacy.input_selection,
                legacy.local.get()
            ),
            (0, 1, 39)
        );
    }

    proptest! {
        #[test]
        fn c1c2_round_trip(code in 0u16..=6229) {
            let c = CodeNumber::new(code).unwrap();
            let [c1, c2] = c.to_c1c2();
            prop_assert!((48..=127).contains(&c1) && (48..=127).contains(&c2));
            prop_assert_eq!(CodeNumber::from_c1c2([c1, c2]).unwrap(), c);
        }

        #[test]
        fn extended_round_trip(code: u16, subcode: u8) {
            let e = ExtendedAddress { code, subcode };
            prop_assert_eq!(ExtendedAddress::from_ascii(e.to_ascii()).unwrap(), e);
        }

        #[test]
        fn code_bank_locate_resolves_back(code in 0u16..=4005) {
            if let Some((bank, local)) = CodeBank::locate(code) {
                prop_assert_eq!(bank.resolve(local.get()), Some(code));
            } else {
                prop_assert!(code % 250 >= 248 && code >= 250);
            }
        }
    }
}

#[cfg(test)]
mod standard_addressing_tests {
    use super::*;

    #[test]
    fn bank_and_input_selection_resolve_standard_fields_only() {
        let s = StandardAddressing::POWER_ON;
        let c173 = CodeAddress::Standard(CodeNumber(173));
        assert_eq!(s.resolve(c173), (173, 0));
        let s = s
            .after_write(CodeAddress::Standard(CodeNumber::C0249), 7)
            .unwrap();
        assert_eq!(s.resolve(c173), (1923, 0));
        // 248 / 249 stay themselves in every bank (8.B, 8.C)
        assert_eq!(
            s.resolve(CodeAddress::Standard(CodeNumber::C0249)),
            (249, 0)
        );
        // above 255 the offset applies too (8.B note; errata lecom 18)
        assert_eq!(s.resolve(CodeAddress::Standard(CodeNumber(300))), (2050, 0));
        let s = s
            .after_write(
                CodeAddress::Extended(ExtendedAddress {
                    code: 248,
                    subcode: 0,
                }),
                1,
            )
            .unwrap();
        assert_eq!(s.resolve(CodeAddress::Standard(CodeNumber(39))), (1789, 1));
        // extended addressing ignores both (8.D)
        let ext = CodeAddress::Extended(ExtendedAddress {
            code: 39,
            subcode: 2,
        });
        assert_eq!(s.resolve(ext), (39, 2));
        // values the registers do not hold, and other codes, change nothing
        assert_eq!(
            s.after_write(CodeAddress::Standard(CodeNumber::C0249), 16),
            None
        );
        assert_eq!(
            s.after_write(CodeAddress::Standard(CodeNumber(11)), 1),
            None
        );
    }
}
