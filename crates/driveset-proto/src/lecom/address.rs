//! Controller addresses AD1 AD2 (section 8.F) and the addresses reserved for
//! BROADCAST / MULTICAST (section 8.J). Owns [`ControllerAddress`] and
//! [`AddressKind`].

use core::fmt;

use super::error::FrameError;

/// What a controller address selects (section 8.J table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AddressKind {
    /// `00`: every controller on the bus (broadcast).
    All,
    /// `x0` for x = 1..=9: the group of controllers `x1`..=`x9` (multicast).
    /// Carries the tens digit `x`.
    Group(u8),
    /// Any other address: one controller, which acknowledges.
    Station,
}

/// A controller address: two ASCII digits AD1 (tens) AD2 (units), 00..=99
/// (section 8.F). Addresses ending in 0 are reserved for BROADCAST /
/// MULTICAST (section 8.J), so stations use 01..09, 11..19, ..., 91..99.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ControllerAddress(u8);

impl ControllerAddress {
    /// `00`: all controllers.
    pub const ALL: Self = Self(0);

    /// The address `n` (0..=99); `None` above 99.
    pub const fn new(n: u8) -> Option<Self> {
        if n <= 99 { Some(Self(n)) } else { None }
    }

    /// The group address `x0` for the group `x1..=x9`, x = 1..=9.
    pub const fn group(tens: u8) -> Option<Self> {
        if tens >= 1 && tens <= 9 {
            Some(Self(tens * 10))
        } else {
            None
        }
    }

    /// The address as a number 0..=99.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// Which controllers this address selects (section 8.J).
    pub const fn kind(self) -> AddressKind {
        if self.0 == 0 {
            AddressKind::All
        } else if self.0.is_multiple_of(10) {
            AddressKind::Group(self.0 / 10)
        } else {
            AddressKind::Station
        }
    }

    /// `true` for `00` and `x0`: telegrams to it are not acknowledged.
    pub const fn is_broadcast(self) -> bool {
        self.0.is_multiple_of(10)
    }

    /// Whether a telegram sent to `self` reaches the station `station`:
    /// equal addresses, `00`, or the group address of the station's tens.
    pub const fn reaches(self, station: ControllerAddress) -> bool {
        match self.kind() {
            AddressKind::All => true,
            AddressKind::Group(tens) => station.0 / 10 == tens && !station.0.is_multiple_of(10),
            AddressKind::Station => self.0 == station.0,
        }
    }

    /// AD1 AD2 as ASCII digits (section 8.F: 30..39 hex each).
    pub const fn to_ascii(self) -> [u8; 2] {
        [b'0' + self.0 / 10, b'0' + self.0 % 10]
    }

    /// Parses AD1 AD2 (already parity-masked).
    ///
    /// # Errors
    /// [`FrameError::BadAddress`] when either byte is not an ASCII digit.
    pub const fn from_ascii(ad: [u8; 2]) -> Result<Self, FrameError> {
        if ad[0].is_ascii_digit() && ad[1].is_ascii_digit() {
            Ok(Self((ad[0] - b'0') * 10 + (ad[1] - b'0')))
        } else {
            Err(FrameError::BadAddress {
                ad1: ad[0],
                ad2: ad[1],
            })
        }
    }
}

impl fmt::Display for ControllerAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reserved_addresses_follow_section_8j() {
        assert_eq!(ControllerAddress::ALL.kind(), AddressKind::All);
        for tens in 1..=9 {
            let g = ControllerAddress::group(tens).unwrap();
            assert_eq!(g.get(), tens * 10);
            assert_eq!(g.kind(), AddressKind::Group(tens));
            assert!(g.is_broadcast());
            for unit in 1..=9 {
                let s = ControllerAddress::new(tens * 10 + unit).unwrap();
                assert_eq!(s.kind(), AddressKind::Station);
                assert!(g.reaches(s));
                assert!(ControllerAddress::ALL.reaches(s));
            }
        }
        let a25 = ControllerAddress::new(25).unwrap();
        assert!(!ControllerAddress::group(3).unwrap().reaches(a25));
        assert!(!ControllerAddress::new(24).unwrap().reaches(a25));
        assert_eq!(ControllerAddress::new(100), None);
        assert_eq!(ControllerAddress::group(0), None);
        assert_eq!(ControllerAddress::group(10), None);
    }

    #[test]
    fn ascii_digits() {
        let a = ControllerAddress::new(34).unwrap();
        assert_eq!(a.to_ascii(), *b"34");
        assert_eq!(ControllerAddress::from_ascii(*b"01").unwrap().get(), 1);
        assert_eq!(ControllerAddress::from_ascii(*b"99").unwrap().get(), 99);
        assert_eq!(
            ControllerAddress::from_ascii(*b"3A"),
            Err(FrameError::BadAddress {
                ad1: b'3',
                ad2: b'A'
            })
        );
        assert_eq!(a.to_string(), "34");
        assert_eq!(ControllerAddress::new(5).unwrap().to_string(), "05");
    }
}
