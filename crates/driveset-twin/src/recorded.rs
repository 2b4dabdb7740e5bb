//! Twins from a recorded bus session (docs/twins.md, "Twins from a
//! recorded session"): owns the check that the schema is one of the
//! session's bus, the session decoded by the engine
//! ([`driveset_engine::decode::decode`]), what it showed of each station
//! ([`crate::capture::sessions`]) and one twin per station address
//! ([`crate::capture::of_session`]). Reading the file and loading the
//! schema are the caller's.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use driveset_engine::decode::Capture as Format;
use driveset_engine::env::Environment;
use driveset_schema::{Family, Registry, Schema};
use driveset_sim::twin::Twin;

use crate::capture::Stamp;

/// Why a recorded session gives no twin.
#[derive(Debug, thiserror::Error)]
pub enum RecordedError {
    /// The schema is not of a family the session's bus carries.
    #[error("--schema {schema}: a {family} schema; a {bus} session needs a schema of {wanted}")]
    Schema {
        /// The schema's id.
        schema: String,
        /// The schema's family.
        family: &'static str,
        /// The session's bus.
        bus: &'static str,
        /// The bus's families (`mc6000 or vf1000`).
        wanted: String,
    },
    /// No schema given for a session of a bus of several families
    /// (LUSTBUS): it does not say which family it talks to.
    #[error(
        "twin from-capture --protocol lustbus: give the drives' schema with --schema (an MC6000/7000 or VF1000 schema id or file, e.g. lust-vf1000): a LUSTBUS session does not say which family it talks to"
    )]
    NoSchema,
    /// No drive answered in the session.
    #[error(
        "{}: the session shows no drive answering (no VALUE, no acknowledged write); is it a {bus} capture?",
        file.display()
    )]
    NoDrive {
        /// The session's file.
        file: PathBuf,
        /// The session's bus.
        bus: &'static str,
    },
}

/// The twin file of the station at `address` in `dir`:
/// `DIR/twin-<address>.twin.toml` (rename it to `<drive name>.twin.toml`
/// for a rehearsal).
pub fn path_in(dir: &Path, address: u8) -> PathBuf {
    crate::file::path_in(dir, &format!("twin-{address}"))
}

/// The schema a session in `format` is read with when none is given: the
/// built-in schema of its bus's one family (none on a bus of several).
pub fn default_schema(format: Format) -> Option<&'static str> {
    format.bus().only_family().map(|f| f.descriptor().schema_id)
}

/// The schema a session in `format` is read with: `given` (`--schema`),
/// else [`default_schema`].
///
/// # Errors
/// [`RecordedError::NoSchema`]: none given on a bus of several families.
pub fn schema_of(format: Format, given: Option<&str>) -> Result<&str, RecordedError> {
    given
        .or(default_schema(format))
        .ok_or(RecordedError::NoSchema)
}

/// One twin per station address the session `bytes` in `format` (read
/// from `file`) shows answering, read with `schema` (`registry`: the
/// schemas the decoder knows), each stamped now (`env`'s clock) as
/// captured from `capture FILE`; in address order.
///
/// # Errors
/// `schema` is not of the session's bus, or no drive answered in it.
pub fn twins(
    format: Format,
    bytes: &[u8],
    file: &Path,
    registry: Registry,
    schema: &Arc<Schema>,
    env: &dyn Environment,
) -> Result<Vec<Twin>, RecordedError> {
    // the session's families are its bus's
    let bus = format.bus();
    let families: Vec<Family> = bus.families().collect();
    if !families.contains(&schema.family) {
        return Err(RecordedError::Schema {
            schema: schema.id.clone(),
            family: schema.family.name(),
            bus: bus.name(),
            wanted: families
                .iter()
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(" or "),
        });
    }
    let ctx = driveset_engine::decode::Context {
        registry,
        schema: Some(schema.clone()),
        family: None,
    };
    let events = driveset_engine::decode::decode(format, bytes, &ctx);
    let sessions = crate::capture::sessions(format, &events, schema);
    if sessions.is_empty() {
        return Err(RecordedError::NoDrive {
            file: file.to_path_buf(),
            bus: bus.name(),
        });
    }
    Ok(sessions
        .into_iter()
        .map(|(address, session)| {
            let stamp = Stamp::now(env, format!("capture {}", file.display()));
            crate::capture::of_session(format, session, schema, address, stamp)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use driveset_engine::env::Memory;

    use super::*;

    #[test]
    fn a_stations_twin_is_named_by_its_address() {
        assert_eq!(
            path_in(Path::new("twins"), 7),
            Path::new("twins/twin-7.twin.toml")
        );
    }

    #[test]
    fn a_bus_of_one_family_defaults_to_its_schema() {
        assert_eq!(default_schema(Format::Lecom), Some("lenze-tmd"));
        assert_eq!(default_schema(Format::Slcan), Some("lenze-ecs"));
        assert_eq!(default_schema(Format::Lustbus), None);
        assert_eq!(schema_of(Format::Lecom, None).unwrap(), "lenze-tmd");
        assert_eq!(
            schema_of(Format::Lustbus, Some("lust-vf1000")).unwrap(),
            "lust-vf1000"
        );
        let e = schema_of(Format::Lustbus, None).unwrap_err();
        assert!(matches!(e, RecordedError::NoSchema), "{e:?}");
        assert!(
            e.to_string()
                .ends_with("a LUSTBUS session does not say which family it talks to"),
            "{e}"
        );
    }

    #[test]
    fn a_schema_off_the_bus_and_a_silent_session_are_refused() {
        let registry = Registry::builtin().expect("built-in schemas");
        let env = Memory::at("2026-12-07T10:11:12Z".parse().expect("timestamp"));
        let file = Path::new("session.bin");
        let vf1000 = registry.get("lust-vf1000").expect("vf1000");
        let e = twins(Format::Lecom, b"", file, registry.clone(), &vf1000, &env)
            .expect_err("a LUSTBUS schema for a LECOM session");
        assert_eq!(
            e.to_string(),
            "--schema lust-vf1000: a vf1000 schema; a lecom session needs a schema of tmd"
        );
        let tmd = registry.get("lenze-tmd").expect("tmd");
        let e = twins(Format::Lecom, b"", file, registry, &tmd, &env).expect_err("no drive");
        assert!(matches!(e, RecordedError::NoDrive { .. }), "{e:?}");
    }
}
