//! Control characters and the block check character (BCC) shared by the two
//! ISO 1745 style serial protocols, LUSTBUS and LECOM-A/B.
//!
//! Both run 7E1: a character carries 7 data bits. A UART configured 7E1 adds
//! and strips the parity bit itself; a link that delivers 8 bits (a pty, a TCP
//! serial server in 8N1) may hand over the parity bit as bit 7, so decoders
//! mask every received byte with [`mask7`] before looking at it.

/// Start of text.
pub const STX: u8 = 0x02;
/// End of text.
pub const ETX: u8 = 0x03;
/// End of transmission: resets every receiver's state machine.
pub const EOT: u8 = 0x04;
/// Enquiry: ends a read request.
pub const ENQ: u8 = 0x05;
/// Positive acknowledge.
pub const ACK: u8 = 0x06;
/// Negative acknowledge (0x15; the LUSTBUS table's "15 decimal" is an erratum,
/// see docs/errata/lustbus.md, L11).
pub const NAK: u8 = 0x15;

/// Strips the parity bit: a 7E1 line carries 7 data bits.
#[inline]
pub const fn mask7(b: u8) -> u8 {
    b & 0x7F
}

/// Block check character: XOR of every byte after STX up to and including ETX.
///
/// `text_and_etx` is the slice that starts right after STX and ends with the
/// ETX byte itself. LUSTBUS section 2.2 ("All bytes between STX (exclusive)
/// and ETX (inclusive) are EXOR'ed"); LECOM section 8.G (DIN 66219). On
/// LUSTBUS the result is always 0..=0x7F since every operand is 7-bit.
#[inline]
pub fn bcc(text_and_etx: &[u8]) -> u8 {
    text_and_etx.iter().fold(0u8, |acc, b| acc ^ b)
}

/// The block check of a telegram as received, its BCC the last byte: the
/// BCC it carries (7 bits) and the one its text computes to, the XOR of
/// every byte after its first STX up to the BCC ([`bcc`]; LUSTBUS §2.2,
/// LECOM §8.G). A telegram without an STX counts from its first byte.
/// `None` for an empty slice. The one annotation both capture decoders
/// show.
pub fn telegram_bcc(telegram: &[u8]) -> Option<BccCheck> {
    let (&last, body) = telegram.split_last()?;
    let text = body
        .iter()
        .position(|&b| mask7(b) == STX)
        .map_or(0, |p| p + 1);
    Some(BccCheck {
        found: mask7(last),
        computed: bcc(&body[text.min(body.len())..]),
    })
}

/// A telegram's BCC against its text ([`telegram_bcc`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BccCheck {
    /// The BCC byte received (parity bit stripped).
    pub found: u8,
    /// The BCC its text computes to.
    pub computed: u8,
}

impl BccCheck {
    /// Whether they agree.
    pub const fn ok(self) -> bool {
        self.found == self.computed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bcc_xors_text_and_etx() {
        // "00105=03E8" ETX from the VF1000 SELECT example (LUSTBUS 6.2.2).
        let text = b"00105=03E8\x03";
        let expected = text.iter().fold(0, |a, b| a ^ b);
        assert_eq!(bcc(text), expected);
        assert_eq!(bcc(&[ETX]), ETX);
        assert_eq!(bcc(&[]), 0);
    }

    #[test]
    fn telegram_bcc_checks_after_the_first_stx() {
        let mut t = vec![EOT, b'0', b'0', STX];
        t.extend_from_slice(b"00105=03E8\x03");
        let b = bcc(b"00105=03E8\x03");
        t.push(b | 0x80);
        let c = telegram_bcc(&t).expect("non-empty");
        assert_eq!(
            c,
            BccCheck {
                found: b,
                computed: b
            }
        );
        assert!(c.ok());
        *t.last_mut().expect("bcc") ^= 1;
        assert!(!telegram_bcc(&t).expect("non-empty").ok());
        assert_eq!(
            telegram_bcc(&[b'A', ETX, 0x42]),
            Some(BccCheck {
                found: 0x42,
                computed: b'A' ^ ETX
            })
        );
        assert_eq!(
            telegram_bcc(&[0x07]),
            Some(BccCheck {
                found: 7,
                computed: 0
            })
        );
        assert_eq!(telegram_bcc(&[]), None);
    }

    #[test]
    fn mask7_strips_parity_bit() {
        assert_eq!(mask7(0x84), EOT);
        assert_eq!(mask7(0x7F), 0x7F);
    }
}
