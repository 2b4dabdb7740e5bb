//! Owns learning the type of `driveset address`'s bus codes from the
//! drive's own descriptions when the schema lacks it: LUSTBUS 82-SADDR,
//! 81-SBAUD and the MC's 4-PROG that activates a rate (VF1000 82-SIOA),
//! which the vendors' built-in schemas leave untyped (`lustbus-protocol.txt` §5.2, §11.1, §11.2). Only the
//! descriptions of the codes the change needs are read (no texts, nothing
//! written), through the session's learning (the same interpretation of
//! the MC layouts and type characters as `pull` and `schema pull`); a
//! schema that types them, or one of the user's own that is not learned
//! from drives, is used as it is.

use std::sync::Arc;

use driveset_link::Link;
use driveset_schema::{CodeKey, Family, Registry, Schema};

use super::AssignRefusal;
use super::refusal::refuse;
use crate::error::EngineError;
use crate::learn::LearnOptions;
use crate::session::{BusSession, LearnPolicy, LearnStep, SessionError, SessionPolicy};

/// The command code that activates a new rate online (MC 4-PROG = 111,
/// the descriptor's `line_rates.online`), for a family that has one.
pub(super) fn online_command(family: Family) -> Option<CodeKey> {
    family
        .descriptor()
        .line_rates
        .online
        .map(|o| CodeKey::new(o.command))
}

/// The codes of `keys` that `schema` gives no type for.
fn untyped(schema: &Schema, keys: &[CodeKey]) -> Vec<u32> {
    keys.iter()
        .filter(|k| {
            schema
                .code(k.number)
                .is_none_or(|c| schema.type_of(c).is_none())
        })
        .map(|k| k.number)
        .collect()
}

/// `schema`, with the types of `keys` learned from the descriptions of
/// the drive at `address` of `link` when it lacks them and its family
/// learns (module docs); else `schema` unchanged (the refusal that it
/// gives no type is the caller's, `need_type`).
pub(super) fn typed_bus_codes(
    link: &mut Link,
    port: &str,
    schema: Arc<Schema>,
    address: u8,
    keys: &[CodeKey],
) -> Result<Arc<Schema>, EngineError> {
    let params = untyped(&schema, keys);
    if params.is_empty() || !crate::learn::needs_learning(&schema) {
        return Ok(schema);
    }
    let mut registry = Registry::new();
    registry.insert_as(&schema.id, schema.clone());
    let env = crate::env::Memory::at(jiff::Timestamp::UNIX_EPOCH);
    let policy = SessionPolicy {
        learn: Some(LearnPolicy {
            options: LearnOptions {
                params: Some(params),
                layout: None,
                type_chars: None,
                no_texts: true,
            },
            registry: &registry,
            dir: None,
            env: &env,
            step: LearnStep::Render,
        }),
    };
    let session = match BusSession::open(link, port, schema.clone(), address, &policy) {
        Ok(s) => s,
        Err(SessionError::Engine(e)) => return Err(e),
        Err(e) => {
            return Err(refuse(
                port,
                address,
                AssignRefusal::SchemaLacks {
                    schema: schema.id.clone(),
                    code: format!(
                        "{} (the drive's own description did not give one: {e})",
                        keys.iter()
                            .map(|k| crate::plan::code_label(&schema, *k))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                },
            ));
        }
    };
    let learned = session.schema.clone();
    let mut client = session.client;
    client.finish()?;
    Ok(learned)
}
