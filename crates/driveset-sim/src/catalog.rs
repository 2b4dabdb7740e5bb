//! Which schema each simulated family loads. The real schemas in
//! `schemas/` hold only what the specs document; for realistic set sizes
//! (MC6000: 200+ parameters) the simulator loads the fictional fixture
//! schemas in `parameter-sets/fixtures/` that extend them. Both are embedded
//! at build time, so `sim://` works from any directory.

use std::sync::Arc;

use driveset_schema::error::SourceFile;
use driveset_schema::schema::{Registry, Schema};

/// The drive families (the schema crate's descriptor owns their names).
pub use driveset_schema::Family;

/// The id of the schema a simulated drive of `family` loads its table from
/// (the fictional fixtures where the real schema documents too little).
pub fn sim_schema_id(family: Family) -> &'static str {
    match family {
        Family::Mc6000 => "fictional-mc6000-demo",
        Family::Vf1000 => "fictional-vf1000-demo",
        Family::Tmd => "lenze-tmd",
        Family::Ecs => "fictional-ecs-demo",
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

/// The fixture schemas' ids and files (`parameter-sets/fixtures/ID.toml`).
pub fn fixtures() -> impl Iterator<Item = (&'static str, &'static str)> {
    FIXTURES.iter().map(|(path, _)| {
        let id = path
            .rsplit('/')
            .next()
            .and_then(|f| f.strip_suffix(".toml"))
            .unwrap_or(path);
        (id, *path)
    })
}

/// The fixture schemas' ids, files and texts, for a user's registry to
/// withhold ([`Registry::withhold`]).
pub fn withheld() -> Vec<(&'static str, &'static str, &'static str)> {
    fixtures()
        .zip(FIXTURES)
        .map(|((id, path), (_, text))| (id, path, text))
        .collect()
}

/// Withhold the fixture schemas' ids in `registry` (a user's registry: a
/// set naming a fixture by id is told to name its file,
/// [`Registry::withhold`]).
pub fn withhold_fixtures(registry: &mut Registry) {
    for ((id, path), (_, text)) in fixtures().zip(FIXTURES) {
        registry.withhold(id, path, text);
    }
}

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
    r.get(sim_schema_id(family)).ok_or_else(|| {
        format!(
            "schema `{}` missing from the simulator's catalog",
            sim_schema_id(family)
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
    fn fixture_ids_are_the_schemas_ids() {
        let r = registry().unwrap();
        let ids: Vec<&str> = fixtures().map(|f| f.0).collect();
        assert_eq!(
            ids,
            [
                "fictional-mc6000-demo",
                "fictional-vf1000-demo",
                "fictional-ecs-demo"
            ]
        );
        for id in ids {
            assert!(r.get(id).is_some(), "{id}");
        }
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
