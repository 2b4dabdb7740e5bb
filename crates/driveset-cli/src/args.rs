//! Clap value types over the family descriptor: `--protocol` takes the
//! names and aliases the schema crate's [`BusProtocol`] gives, so no
//! command spells a protocol itself.

use clap::ValueEnum;
use clap::builder::PossibleValue;
use driveset_schema::BusProtocol;

/// `--protocol NAME`: a bus protocol (`lustbus`, `lecom`, `can`; `sdo` too).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusArg(pub BusProtocol);

const BUSES: [BusArg; 3] = {
    let a = BusProtocol::ALL;
    [BusArg(a[0]), BusArg(a[1]), BusArg(a[2])]
};

impl ValueEnum for BusArg {
    fn value_variants<'a>() -> &'a [Self] {
        &BUSES
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(
            PossibleValue::new(self.0.name())
                .aliases(self.0.aliases().iter().copied())
                .help(self.0.title()),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_aliases_come_from_the_descriptor() {
        assert_eq!(
            BusArg::from_str("sdo", false),
            Ok(BusArg(BusProtocol::CanSdo))
        );
        assert_eq!(
            BusArg::from_str("can", false),
            Ok(BusArg(BusProtocol::CanSdo))
        );
        assert!(BusArg::from_str("modbus", false).is_err());
    }
}
