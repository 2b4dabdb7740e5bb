//! Which schema each simulated family loads. The real schemas in
//! `schemas/` hold only what the specs document; for realistic set sizes
//! (MC6000: 200+ parameters) the simulator loads the fictional fixture
//! schemas in `parameter-sets/fixtures/` that extend them. Both are embedded
//! at build time, so `sim://` works from any directory.

use std::sync::Arc;

use driveset_schema::error::SourceFile;
use driveset_schema::schema::{Registry, Schema};

/// A simulated drive family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Lust MASTERCONTROL MC6000/7000 (LUSTBUS, enhanced).
    Mc6000,
    /// Lust SMARTDRIVE VF1000 (LUSTBUS).
    Vf1000,
    /// Lenze Tmd (LECOM-A/B).
    Tmd,
    /// Lenze ECS (system bus CAN, SDO).
    Ecs,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 4] = [Family::Mc6000, Family::Vf1000, Family::Tmd, Family::Ecs];

    /// The name used in `sim://FAMILY` and `--family`.
    pub fn name(self) -> &'static str {
        match self {
            Family::Mc6000 => "mc6000",
            Family::Vf1000 => "vf1000",
            Family::Tmd => "tmd",
            Family::Ecs => "ecs",
        }
    }

    /// Parse a family name (`mc6000`, `mc7000`, `vf1000`, `tmd`, `ecs`).
    pub fn parse(name: &str) -> Result<Family, String> {
        match name.to_ascii_lowercase().as_str() {
            "mc6000" | "mc7000" | "mc" => Ok(Family::Mc6000),
            "vf1000" | "vf" => Ok(Family::Vf1000),
            "tmd" => Ok(Family::Tmd),
            "ecs" => Ok(Family::Ecs),
            other => Err(format!(
                "unknown drive family `{other}`: use one of mc6000, vf1000, tmd, ecs"
            )),
        }
    }

    /// The id of the schema the simulated drive's table comes from.
    pub fn schema_id(self) -> &'static str {
        match self {
            Family::Mc6000 => "fictional-mc6000-demo",
            Family::Vf1000 => "fictional-vf1000-demo",
            Family::Tmd => "lenze-tmd",
            Family::Ecs => "fictional-ecs-demo",
        }
    }
}

const FIXTURES: [(&str, &str); 3] = [
    (
        "parameter-sets/fixtures/fictional-mc6000-demo.toml",
        include_str!("../../../parameter-sets/fixtures/fictional-mc6000-demo.toml"),
    ),
    (
        "parameter-sets/fixtures/fictional-vf1000-demo.toml",
        include_str!("../../../parameter-sets/fixtures/fictional-vf1000-demo.toml"),
    ),
    (
        "parameter-sets/fixtures/fictional-ecs-demo.toml",
        include_str!("../../../parameter-sets/fixtures/fictional-ecs-demo.toml"),
    ),
];

/// The built-in schemas plus the simulator's fictional fixtures.
pub fn registry() -> Result<Registry, String> {
    let mut r = Registry::builtin().map_err(|e| e.to_string())?;
    for (path, text) in FIXTURES {
        r.add_source(SourceFile::new(path, text))
            .map_err(|e| e.to_string())?;
    }
    Ok(r)
}

/// The schema a simulated drive of `family` loads.
pub fn schema(family: Family) -> Result<Arc<Schema>, String> {
    let r = registry()?;
    r.get(family.schema_id()).ok_or_else(|| {
        format!(
            "schema `{}` missing from the simulator's catalog",
            family.schema_id()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::ParamTable;

    #[test]
    fn every_family_loads_a_table() {
        for f in Family::ALL {
            let s = schema(f).unwrap_or_else(|e| panic!("{}: {e}", f.name()));
            let t = ParamTable::from_schema(s).unwrap_or_else(|e| panic!("{}: {e}", f.name()));
            assert!(!t.is_empty(), "{}", f.name());
        }
        let mc = ParamTable::from_schema(schema(Family::Mc6000).unwrap()).unwrap();
        assert!(mc.len() >= 200, "MC6000 table has {} parameters", mc.len());
    }

    #[test]
    fn family_names_parse_back() {
        for f in Family::ALL {
            assert_eq!(Family::parse(f.name()), Ok(f));
        }
        assert!(
            Family::parse("xyz")
                .unwrap_err()
                .contains("mc6000, vf1000, tmd, ecs")
        );
    }
}
