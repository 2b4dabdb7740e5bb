//! PosMOD1 user data (MC6000 only, section 11.6): the VALUE of SELECT and
//! ENQUIRY telegrams on CODE 49999 is a status byte followed by 0..=80
//! characters of ASCII data.
//!
//! Status byte (11.6.3): bit 0 request (1) / data (0) telegram, bit 1 always
//! 0, bit 2 multiblock (1) / single or last (0), bits 4 and 5 always 1, bits
//! 6 and 7 always 0 (so the byte is a printable `'0'..='?'`). Bit 3 is not
//! described, yet the host data telegrams of the examples set it (`38H`,
//! `3CH`) while requests (`31H`) and the device's answers (`30H`, `34H`) do
//! not; driveset keeps it as [`PosModStatus::BIT3`] (errata).

use core::fmt;

use thiserror::Error;

use super::frame::{ValueText, is_value_byte};

/// Most data characters after the status byte.
pub const MAX_POSMOD_DATA: usize = 80;

/// Why a PosMOD1 VALUE is not valid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Error)]
pub enum PosModError {
    /// VALUE is empty: the status byte is missing.
    #[error("PosMOD1 VALUE is empty; the status byte is missing")]
    MissingStatus,
    /// The status byte has a fixed bit wrong.
    #[error(
        "PosMOD1 status byte {found:#04x} has a fixed bit wrong (bits 4,5 must be 1; bits 1,6,7 must be 0)"
    )]
    BadStatus {
        /// The byte.
        found: u8,
    },
    /// More than 80 data characters.
    #[error("PosMOD1 data has {0} characters; at most 80")]
    TooLong(usize),
    /// A data byte cannot be sent inside a telegram.
    #[error(
        "PosMOD1 data character {offset} is {found:#04x}, which cannot be sent inside a telegram"
    )]
    BadByte {
        /// Offset in the data (after the status byte).
        offset: usize,
        /// The byte.
        found: u8,
    },
}

bit_flags! {
    /// The PosMOD1 status byte (section 11.6.3).
    pub struct PosModStatus: u8 {
        /// Bit 0: request telegram (1) / data telegram (0).
        const REQUEST = 0x01, "request";
        /// Bit 2: multiblock telegram, more follow.
        const MULTIBLOCK = 0x04, "multiblock";
        /// Bit 3: undocumented; set in the examples' host data telegrams.
        const BIT3 = 0x08, "bit 3 (undocumented)";
        /// Bits 4 and 5: always 1.
        const FIXED = 0x30, "fixed bits 4,5";
    }
}

impl PosModStatus {
    /// A data telegram's status byte: the fixed bits set, bits 0, 2 and 3
    /// clear.
    pub const fn data() -> Self {
        Self::FIXED
    }

    /// A request telegram's status byte: the fixed bits and bit 0 set,
    /// bits 2 and 3 clear.
    pub const fn request() -> Self {
        Self(Self::FIXED.0 | Self::REQUEST.0)
    }

    /// This status byte with bit 2 set: a multiblock telegram, more follow.
    pub const fn multiblock(self) -> Self {
        Self(self.0 | Self::MULTIBLOCK.0)
    }

    /// Checks the fixed bits (4, 5 set; 1, 6, 7 clear).
    pub const fn from_byte(b: u8) -> Result<Self, PosModError> {
        if b & 0x30 != 0x30 || b & 0xC2 != 0 {
            return Err(PosModError::BadStatus { found: b });
        }
        Ok(Self(b))
    }

    /// Bit 0.
    pub const fn is_request(self) -> bool {
        self.contains(Self::REQUEST)
    }
    /// Bit 2.
    pub const fn is_multiblock(self) -> bool {
        self.contains(Self::MULTIBLOCK)
    }
}

/// PosMOD1 user data: status byte and up to 80 data characters.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct PosModData {
    /// Status byte.
    pub status: PosModStatus,
    len: u8,
    data: [u8; MAX_POSMOD_DATA],
}

impl PosModData {
    /// Status and data (0..=80 characters that can travel in VALUE).
    pub fn new(status: PosModStatus, data: &[u8]) -> Result<Self, PosModError> {
        let status = PosModStatus::from_byte(status.0)?;
        if data.len() > MAX_POSMOD_DATA {
            return Err(PosModError::TooLong(data.len()));
        }
        if let Some(offset) = data.iter().position(|&b| !is_value_byte(b)) {
            return Err(PosModError::BadByte {
                offset,
                found: data[offset],
            });
        }
        let mut d = [0u8; MAX_POSMOD_DATA];
        d[..data.len()].copy_from_slice(data);
        Ok(Self {
            status,
            len: data.len() as u8,
            data: d,
        })
    }

    /// The data after the status byte.
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// The VALUE string: status byte, then the data.
    pub fn encode(&self) -> ValueText {
        let mut v = ValueText::empty();
        v.push(self.status.0);
        for &b in self.data() {
            v.push(b);
        }
        v
    }

    /// Reads a VALUE string.
    pub fn decode(value: &[u8]) -> Result<Self, PosModError> {
        let (&s, data) = value.split_first().ok_or(PosModError::MissingStatus)?;
        Self::new(PosModStatus::from_byte(s)?, data)
    }
}

impl fmt::Debug for PosModData {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "PosModData({:02X}H, \"{}\")",
            self.status.0,
            self.data().escape_ascii()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_bits() {
        assert_eq!(PosModStatus::data().bits(), 0x30);
        assert_eq!(PosModStatus::request().bits(), 0x31);
        assert_eq!(PosModStatus::data().multiblock().bits(), 0x34);
        let s = PosModStatus::from_byte(0x3C).unwrap();
        assert!(s.is_multiblock() && !s.is_request() && s.contains(PosModStatus::BIT3));
        assert_eq!(
            PosModStatus::from_byte(0x20),
            Err(PosModError::BadStatus { found: 0x20 })
        );
        assert_eq!(
            PosModStatus::from_byte(0x32),
            Err(PosModError::BadStatus { found: 0x32 })
        );
        assert_eq!(
            PosModStatus::from_byte(0x70),
            Err(PosModError::BadStatus { found: 0x70 })
        );
    }

    #[test]
    fn data_round_trip() {
        let d = PosModData::decode(b"8GOA0V1000").unwrap();
        assert_eq!(d.status.bits(), 0x38);
        assert_eq!(d.data(), b"GOA0V1000");
        assert_eq!(d.encode().as_bytes(), b"8GOA0V1000");
        assert_eq!(PosModData::decode(b""), Err(PosModError::MissingStatus));
        assert_eq!(
            PosModData::new(PosModStatus::data(), &[b'x'; 81]),
            Err(PosModError::TooLong(81))
        );
        assert!(PosModData::new(PosModStatus::data(), &[b'x'; 80]).is_ok());
        assert_eq!(
            PosModData::decode(b"0A\x03"),
            Err(PosModError::BadByte {
                offset: 1,
                found: 0x03
            })
        );
        // Status only: zero data bytes.
        assert_eq!(PosModData::decode(b"0").unwrap().data(), b"");
    }
}
