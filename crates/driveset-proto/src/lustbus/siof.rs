//! The serial interface error status 85-SIOF (VF1000) / 85-SERR (MC), read
//! with CODE `00085` on both families (sections 5.2, 6, 9.2): its bits,
//! their causes and remedies, and what a transaction engine should do.
//!
//! Reading SIOF/SERR clears it; while any bit is set every SELECT is refused
//! (section 9.2). An ENQUIRY answered with NAK never sets a bit (6.1 note).

use core::fmt;

bit_flags! {
    /// The SIOF/SERR bits of the section 9.2 table. Bit 4 (0x10) is not
    /// documented; it is kept and reported as unknown.
    pub struct Siof: u8 {
        /// 01H: power on. Set at every start of the device.
        const POWER_ON = 0x01, "power on";
        /// 02H: the device watchdog (SIOT/SWDGT) timed out.
        const WATCHDOG = 0x02, "watchdog";
        /// 04H: EEPROM busy burning in a value.
        const EEPROM_BUSY = 0x04, "EEPROM busy";
        /// 08H: checksum (BCC) error.
        const CHECKSUM = 0x08, "checksum error";
        /// 20H: no parameter with that number.
        const NO_PARAMETER = 0x20, "no parameter";
        /// 40H: change not permitted (generally or in this operating state).
        const NO_CHANGE = 0x40, "no change";
        /// 80H: value not permissible.
        const INVALID_VALUE = 0x80, "invalid value";
    }
}

/// One row of the section 9.2 table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SiofCause {
    /// The bit.
    pub flag: Siof,
    /// Bit number 0..=7.
    pub bit: u8,
    /// "Short descriptor" column.
    pub descriptor: &'static str,
    /// "Cause" column.
    pub cause: &'static str,
    /// "What to do" column.
    pub remedy: &'static str,
}

const TABLE: [SiofCause; 7] = [
    SiofCause {
        flag: Siof::POWER_ON,
        bit: 0,
        descriptor: "Power on",
        cause: "Bit is set for each ON",
        remedy: "No error, information about device new start",
    },
    SiofCause {
        flag: Siof::WATCHDOG,
        bit: 1,
        descriptor: "Watchdog",
        cause: "Device watchdog has timed out",
        remedy: "Fix the malfunction in the Host computer. Or Host computer is too slow",
    },
    SiofCause {
        flag: Siof::EEPROM_BUSY,
        bit: 2,
        descriptor: "EEPROM busy",
        cause: "EEPROM is currently doing a memory burn in",
        remedy: "Wait (> 60 ms) and repeat telegram",
    },
    SiofCause {
        flag: Siof::CHECKSUM,
        bit: 3,
        descriptor: "Checksum error",
        cause: "Error in data transfer - checksum is wrong",
        remedy: "Repeat telegram",
    },
    SiofCause {
        flag: Siof::NO_PARAMETER,
        bit: 5,
        descriptor: "No parameter",
        cause: "There is no parameter for the given number",
        remedy: "General service error or error in the software of the Host computer.",
    },
    SiofCause {
        flag: Siof::NO_CHANGE,
        bit: 6,
        descriptor: "No change",
        cause: "Change of the parameter is not permitted",
        remedy: "Check if the parameter cannot be written to generally, or if it is due to the current operating mode.",
    },
    SiofCause {
        flag: Siof::INVALID_VALUE,
        bit: 7,
        descriptor: "Invalid value",
        cause: "The transfer parameter value is not permissible",
        remedy: "Choose a different value",
    },
];

const UNDOCUMENTED_BIT4: SiofCause = SiofCause {
    flag: Siof(0x10),
    bit: 4,
    descriptor: "Undocumented bit 4",
    cause: "Bit 4 (10H) is not described by the LUSTBUS specification",
    remedy: "Treat as an unknown device error",
};

/// What a transaction engine should do after a SELECT was refused with NAK
/// and SIOF/SERR was read back (DESIGN "Transactions" step 3; section 9.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SiofAction {
    /// No bit set: nothing recorded.
    None,
    /// 0x08 checksum: send the same telegram again.
    Repeat,
    /// 0x04 EEPROM busy: wait (section 9.2: more than 60 ms) and repeat.
    RepeatAfter {
        /// Minimum wait in milliseconds.
        wait_ms: u32,
    },
    /// 0x01 power on during a transaction: the device restarted, what was
    /// written before is void; start the transaction over.
    RestartTransaction,
    /// 0x02 watchdog, 0x20 no parameter, 0x40 no change, 0x80 invalid value
    /// or an undocumented bit: give up and report [`Siof::causes`].
    Fail,
}

impl Siof {
    /// The table rows of the bits set, in bit order; an undocumented bit 4
    /// gets a row of its own. (Bits are never lost: [`Siof::bits`].)
    pub fn causes(self) -> impl Iterator<Item = SiofCause> {
        let undocumented = (self.0 & 0x10 != 0).then_some(UNDOCUMENTED_BIT4);
        TABLE
            .into_iter()
            .filter(move |c| self.contains(c.flag))
            .chain(undocumented)
    }

    /// The most severe action the bits call for: fail > restart > wait and
    /// repeat > repeat > none. Power on alone, read at the start of a
    /// transaction, is the expected state after a device start; the engine
    /// only treats it as a restart when it shows up mid-transaction.
    pub const fn action(self) -> SiofAction {
        if self.intersects(Siof(
            Siof::WATCHDOG.0 | Siof::NO_PARAMETER.0 | Siof::NO_CHANGE.0 | Siof::INVALID_VALUE.0,
        )) || self.unknown_bits() != 0
        {
            SiofAction::Fail
        } else if self.contains(Siof::POWER_ON) {
            SiofAction::RestartTransaction
        } else if self.contains(Siof::EEPROM_BUSY) {
            SiofAction::RepeatAfter { wait_ms: 60 }
        } else if self.contains(Siof::CHECKSUM) {
            SiofAction::Repeat
        } else {
            SiofAction::None
        }
    }
}

impl fmt::Display for Siof {
    /// `"80H invalid value"`, `"05H power on, EEPROM busy"`, `"00H no error"`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02X}H", self.0)?;
        if self.is_empty() {
            return f.write_str(" no error");
        }
        let mut sep = " ";
        for c in self.causes() {
            write!(f, "{sep}{}", c.descriptor)?;
            sep = ", ";
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_values() {
        assert_eq!(Siof::POWER_ON.bits(), 0x01);
        assert_eq!(Siof::WATCHDOG.bits(), 0x02);
        assert_eq!(Siof::EEPROM_BUSY.bits(), 0x04);
        assert_eq!(Siof::CHECKSUM.bits(), 0x08);
        assert_eq!(Siof::NO_PARAMETER.bits(), 0x20);
        assert_eq!(Siof::NO_CHANGE.bits(), 0x40);
        assert_eq!(Siof::INVALID_VALUE.bits(), 0x80);
        assert_eq!(Siof::KNOWN.bits(), 0xEF);
        for c in TABLE {
            assert_eq!(c.flag.bits(), 1 << c.bit);
        }
    }

    #[test]
    fn causes_and_actions() {
        let s = Siof(0x81);
        let c: Vec<_> = s.causes().collect();
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].descriptor, "Power on");
        assert_eq!(c[1].remedy, "Choose a different value");
        assert_eq!(s.action(), SiofAction::Fail);
        assert_eq!(Siof(0x01).action(), SiofAction::RestartTransaction);
        assert_eq!(Siof(0x04).action(), SiofAction::RepeatAfter { wait_ms: 60 });
        assert_eq!(Siof(0x0C).action(), SiofAction::RepeatAfter { wait_ms: 60 });
        assert_eq!(Siof(0x08).action(), SiofAction::Repeat);
        assert_eq!(Siof(0x00).action(), SiofAction::None);
        assert_eq!(Siof(0x10).action(), SiofAction::Fail);
        assert_eq!(Siof(0x40).action(), SiofAction::Fail);
        assert_eq!(Siof(0x02).action(), SiofAction::Fail);
        assert_eq!(Siof(0x10).causes().next().unwrap().bit, 4);
        assert_eq!(
            Siof(0x85).to_string(),
            "85H Power on, EEPROM busy, Invalid value"
        );
        assert_eq!(Siof(0).to_string(), "00H no error");
        assert_eq!(
            format!("{:?}", Siof(0x90)),
            "Siof(0x90: invalid value | unknown 0x10)"
        );
    }
}
