//! Clap value types over the family descriptor: `--protocol` and the
//! LUSTBUS commands' `--family` take the names and aliases the schema
//! crate's [`BusProtocol`] and [`Family`] give, so no command spells a
//! protocol or a family itself.

use clap::ValueEnum;
use clap::builder::PossibleValue;
use driveset_proto::lustbus::Dialect;
use driveset_schema::{BusProtocol, Family};

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

/// `--family` of the LUSTBUS commands (`decode`, `encode`, `schema pull`):
/// a family on a LUSTBUS line (`mc6000`, `vf1000`, and their aliases).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LustFamilyArg(pub Family);

/// The LUSTBUS families, in descriptor order (a test holds this list to
/// `BusProtocol::Lustbus.families()`).
const LUST_FAMILIES: [LustFamilyArg; 2] = {
    let a = Family::ALL;
    [LustFamilyArg(a[0]), LustFamilyArg(a[1])]
};

impl LustFamilyArg {
    /// The codec dialect of the family.
    pub fn dialect(self) -> Dialect {
        driveset_engine::client::lustbus::dialect_of(self.0).unwrap_or(Dialect::Mc)
    }
}

impl ValueEnum for LustFamilyArg {
    fn value_variants<'a>() -> &'a [Self] {
        &LUST_FAMILIES
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let d = self.0.descriptor();
        Some(
            PossibleValue::new(d.name)
                .aliases(d.aliases.iter().copied())
                .help(d.title),
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
        let lust: Vec<Family> = LUST_FAMILIES.iter().map(|f| f.0).collect();
        assert_eq!(lust, BusProtocol::Lustbus.families().collect::<Vec<_>>());
        assert_eq!(
            LustFamilyArg::from_str("mc7000", true).map(LustFamilyArg::dialect),
            Ok(Dialect::Mc)
        );
        assert_eq!(
            LustFamilyArg::from_str("vf1000", false).map(LustFamilyArg::dialect),
            Ok(Dialect::Vf1000)
        );
    }
}
