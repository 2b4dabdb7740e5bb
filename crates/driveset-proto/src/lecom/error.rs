//! Typed errors of the LECOM-A/B codec: what is wrong with which bytes.
//! Offsets are counted from the first byte of the piece being parsed (the
//! frame for [`FrameError`], the value field V1..Vn for [`ValueError`]).

use thiserror::Error;

use super::address::ControllerAddress;

/// A code number or extended address that cannot be encoded or decoded
/// (sections 8.A, 8.B, 8.D).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum CodeError {
    /// Standard addressing covers 0..=6229 only.
    #[error(
        "code number {code} is outside 0..=6229 of standard addressing (8.A); use extended addressing"
    )]
    OutOfRange { code: u32 },
    /// C1 or C2 outside 48..=127 (8.A).
    #[error("C{position} = {byte:#04x} is outside 48..=127 (8.A)")]
    CharOutOfRange { position: u8, byte: u8 },
    /// C1 C2 in range, but no code number 0..=6229 encodes to them.
    #[error(
        "C1 C2 = {c1:#04x} {c2:#04x} is not produced by the /790 formula for any code 0..=6229 (8.A)"
    )]
    NotFromFormula { c1: u8, c2: u8 },
    /// A character of `!CH1..CH4 SC1 SC2` that is not 0-9 or A-F.
    #[error(
        "extended address character {position} = {byte:#04x} is not an uppercase hex digit (8.D)"
    )]
    BadExtendedDigit { position: u8, byte: u8 },
    /// C0249 code bank outside 0..=15.
    #[error("code bank {bank} is outside 0..=15 (C0249)")]
    BankOutOfRange { bank: u8 },
}

/// A parameter value V1..Vn that does not follow its format (section 8.E).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum ValueError {
    /// No value characters at all.
    #[error("empty parameter value")]
    Empty,
    /// The first character is none of '-', '0'..'9', 'H', 'S', 'O'.
    #[error("value starts with {byte:#04x}, which selects none of VD/VH/VS/VO (8.E)")]
    UnknownFormat { byte: u8 },
    /// VD: a character that is not a digit, a leading '-' or one '.'.
    #[error("VD: unexpected byte {byte:#04x} at offset {at} (8.E)")]
    DecimalSyntax { at: usize, byte: u8 },
    /// VD: no digit before the decimal point.
    #[error("VD: no digit before the decimal point (8.E)")]
    DecimalNoIntegerDigits,
    /// VD: more than 6 digits before the decimal point.
    #[error("VD: {count} digits before the decimal point, at most 6 (8.E)")]
    DecimalTooManyIntegerDigits { count: usize },
    /// VD: a decimal point without 1..=4 digits after it.
    #[error("VD: {count} digits after the decimal point, expected 1..=4 (8.E)")]
    DecimalFractionDigits { count: usize },
    /// VD: outside -214748.3648 ..= 214748.3647.
    #[error("VD: {raw} / 10000 is outside -214748.3648..=214748.3647 (8.E)")]
    DecimalOutOfRange { raw: i64 },
    /// VH: not 2, 4 or 8 hex digits after 'H'.
    #[error("VH: {len} hex digits, expected 2, 4 or 8 (8.E)")]
    HexLength { len: usize },
    /// VH / VO: a character that is not 0-9 or A-F.
    #[error("{format}: byte {byte:#04x} at offset {at} is not an uppercase hex digit (8.E)")]
    HexDigit {
        format: &'static str,
        at: usize,
        byte: u8,
    },
    /// VS: longer than 20 characters.
    #[error("VS: {len} characters, at most 20 (8.E)")]
    StringTooLong { len: usize },
    /// VS: a character that is not visible ASCII (0x20..=0x7E).
    #[error("VS: byte {byte:#04x} at offset {at} is not a visible ASCII character (8.E)")]
    StringChar { at: usize, byte: u8 },
    /// VO: more than 240 nibbles (120 bytes).
    #[error("VO: {nibbles} hex characters, at most 240 (8.E)")]
    OctetsTooLong { nibbles: usize },
    /// VO: an odd number of nibbles (each byte is sent as two).
    #[error("VO: {nibbles} hex characters, expected an even number (two per byte, 8.E)")]
    OctetsOddLength { nibbles: usize },
    /// A value in another format than the one a code needs.
    #[error("expected a {expected} value")]
    WrongFormat { expected: &'static str },
}

/// A frame (telegram or response) that cannot be decoded (sections 8.F-8.J).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum FrameError {
    #[error(transparent)]
    Code(#[from] CodeError),
    #[error(transparent)]
    Value(#[from] ValueError),
    /// AD1 AD2 not two ASCII digits (8.F).
    #[error("controller address {ad1:#04x} {ad2:#04x} is not two ASCII digits (8.F)")]
    BadAddress { ad1: u8, ad2: u8 },
    /// A control character or field missing where the frame needs it.
    #[error("expected {expected} at offset {at}, found {found:#04x}")]
    Expected {
        expected: &'static str,
        at: usize,
        found: u8,
    },
    /// The frame ends before it is complete.
    #[error("frame ends after {len} bytes before it is complete")]
    Truncated { len: usize },
    /// Bytes after a complete frame.
    #[error("{extra} unexpected bytes after the frame, from offset {at}")]
    Trailing { at: usize, extra: usize },
    /// The code field is neither C1 C2 nor `!` + 6 hex characters.
    #[error("code field of {len} bytes; expected 2 (C1 C2) or 7 ('!' + 6 hex) (8.A, 8.D)")]
    CodeLength { len: usize },
    /// More text between STX and ETX than any telegram can hold.
    #[error("more than {limit} bytes of text between STX and ETX")]
    TextTooLong { limit: usize },
    /// The BCC byte does not match the XOR of the text and ETX (8.G).
    #[error("BCC {found:#04x} does not match the computed {expected:#04x} (8.G)")]
    BadBcc { expected: u8, found: u8 },
    /// A RECEIVE to 00 or x0: nobody would answer (8.J).
    #[error("RECEIVE to broadcast address {address}: reserved for BROADCAST (8.J)")]
    ReceiveToBroadcast { address: ControllerAddress },
}

/// A telegram that must not be put on the wire as built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum EncodeError {
    /// SEND needs a station address; 00 and x0 make it a BROADCAST (8.J).
    #[error("SEND to {address}, a broadcast address (8.J); build a Broadcast instead")]
    SendToBroadcast { address: ControllerAddress },
    /// RECEIVE needs a station address: nobody answers 00 or x0 (8.J).
    #[error("RECEIVE from {address}, a broadcast address (8.J)")]
    ReceiveFromBroadcast { address: ControllerAddress },
    /// BROADCAST needs 00 or x0 (8.J).
    #[error("BROADCAST to {address}, a station address; only 00 and x0 are reserved for it (8.J)")]
    BroadcastToStation { address: ControllerAddress },
}
