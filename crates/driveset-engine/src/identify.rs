//! Identification helpers on top of [`DriveClient::identify`]: read what a
//! drive says it is, and refuse a schema (and so a set) for another family
//! (docs/architecture.md, "The data path of an upload": identify); what
//! `driveset identify` finds of a drive ([`examine`]: its identity, at the
//! port's rate or another, and whether the schema fits).

use crate::client::{DriveClient, IdentValue, Identity};
use serde::{Deserialize, Serialize};

use crate::error::{EngineError, LinkFailure};

/// What [`check_family`] refuses: a drive of another family than the
/// schema's. Gathered into [`Refusal`](crate::error::Refusal) as
/// `Refusal::Identify`, with the JSON kind journals hold (`wrong_type`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum IdentifyRefusal {
    /// The drive's TYPE is not one of the schema's (LUSTBUS 91-TYPE).
    #[error(
        "the drive reports {code} = {}, which is not a `{schema}` type ({expected:?}); use the set and schema of the drive's family",
        .found.map_or_else(|| "nothing".to_string(), |t| t.to_string())
    )]
    WrongType {
        /// The TYPE code as the schema spells it.
        code: String,
        /// What the drive reported (`None`: nothing readable).
        found: Option<i64>,
        /// Schema id.
        schema: String,
        /// The schema's TYPE values.
        expected: Vec<i64>,
    },
}

/// The identification codes of the client's schema, read from the drive.
pub fn identify(client: &mut dyn DriveClient) -> Result<Identity, EngineError> {
    client.identify()
}

/// Identifies the drive and checks it against the client's schema: the
/// protocol must match and, where the schema lists `type_values` (LUSTBUS
/// 91-TYPE, `Descriptor::device_type_code`), the drive's TYPE must be one
/// of them. A mismatch is refused ([`IdentifyRefusal`], a
/// [`Refused::Rule`](crate::error::Refused::Rule)); nothing is written
/// either way.
pub fn check_family(client: &mut dyn DriveClient) -> Result<Identity, EngineError> {
    let identity = client.identify()?;
    let schema = client.schema().clone();
    let Some(ident) = schema.identify.as_ref() else {
        return Ok(identity);
    };
    if ident.type_values.is_empty() {
        return Ok(identity);
    }
    let type_code = schema.family.descriptor().device_type_code();
    let type_name = schema.display_code(type_code, None);
    let found = identity.value_of(type_code).and_then(IdentValue::as_int);
    match found {
        Some(t) if ident.type_values.contains(&t) => Ok(identity),
        found => Err(EngineError::refused(
            client.target().clone(),
            IdentifyRefusal::WrongType {
                code: type_name,
                found,
                schema: schema.id.clone(),
                expected: ident.type_values.clone(),
            },
        )),
    }
}

/// Whether the drive's family, found by the read-only probes
/// ([`crate::session::detect`]: an MC6000/7000 answers its own CODE form
/// of 91-TYPE, a VF1000 NAKs it), is the schema's: `Some(finding)` when
/// another family than `expected` answered (the same words `identify`
/// and `schema pull` print, on every port). Nothing is written.
pub fn other_family(
    found: driveset_schema::Family,
    evidence: &str,
    expected: driveset_schema::Family,
) -> Option<String> {
    (found != expected).then(|| {
        format!(
            "the drive answers as {} ({evidence}), not {}",
            found.descriptor().title,
            expected.descriptor().title
        )
    })
}

/// [`other_family`] asked of the drive at `address` on `link` by the
/// read-only probes ([`crate::session::detect`]) when `schema`'s family
/// shares its protocol with others (a LUSTBUS dialect) and the probes did
/// not choose the schema already (`evidence`: what they found, when they
/// did). Nothing is written.
///
/// # Errors
/// [`crate::session::SessionError`]: the probes got no answer, or the link
/// failed.
pub fn probe_other_family(
    link: &mut driveset_link::Link,
    port: &str,
    address: u8,
    latency: Option<std::time::Duration>,
    schema: &driveset_schema::Schema,
    evidence: Option<&str>,
) -> Result<Option<String>, crate::session::SessionError> {
    if evidence.is_some() || schema.family.descriptor().dialect.is_none() {
        return Ok(None);
    }
    let (found, evidence) = crate::session::detect(link, port, address, latency)?;
    Ok(other_family(found, &evidence, schema.family))
}

/// What [`examine`] found of a drive.
#[derive(Debug, Clone)]
pub struct Examined {
    /// What the drive says it is.
    pub identity: Identity,
    /// The drive answered only at another rate: `(its rate, the port's)`
    /// (left at a transfer rate by an interrupted `--transfer-baud`).
    pub other_rate: Option<(u32, u32)>,
    /// Whether the schema fits the drive: `Err` says why not (another
    /// family or TYPE).
    pub fits: Result<(), String>,
}

impl Examined {
    /// What `identify` notes when the drive answered only at another rate
    /// than the port's ([`Examined::other_rate`]).
    pub fn rate_note(&self) -> Option<String> {
        self.other_rate.map(|(r, port_rate)| {
            format!(
                "the drive answers at {r} baud, not at the port's {port_rate} (left at a transfer rate by an interrupted --transfer-baud? `driveset recover JOURNAL` switches it back; or add ?baud={r} to the port)"
            )
        })
    }
}

/// Identifies the drive and checks the client's schema against it
/// ([`check_family`]; `other_family`, the read-only probes' finding of
/// another family ([`other_family`]), is the answer when given). A drive
/// that does not answer, of a family whose drives activate rates online,
/// may have been left at a transfer rate (`--transfer-baud`): every rate
/// is searched (LUSTBUS 5.1; [`crate::transfer::search`]). Nothing is
/// written.
pub fn examine(
    client: &mut dyn DriveClient,
    other_family: Option<String>,
) -> Result<Examined, EngineError> {
    let schema = client.schema().clone();
    let mut other_rate = None;
    let identity = match client.identify() {
        Ok(i) => i,
        Err(e)
            if matches!(e.link_failure(), Some(LinkFailure::NoAnswer { .. }))
                && schema.family.descriptor().line_rates.online.is_some() =>
        {
            let port_rate = client.line_rate().unwrap_or(0);
            match crate::transfer::search(client, &[])? {
                Some(r) => {
                    other_rate = Some((r, port_rate));
                    client.identify()?
                }
                None => return Err(e),
            }
        }
        Err(e) => return Err(e),
    };
    let fits = match (other_family, check_family(client)) {
        (Some(other), _) => Err(other),
        (None, Ok(_)) => Ok(()),
        (None, Err(e)) => match e.refusal() {
            Some(refusal) => Err(refusal.to_string()),
            None => return Err(e),
        },
    };
    Ok(Examined {
        identity,
        other_rate,
        fits,
    })
}

#[cfg(test)]
mod tests {
    use super::IdentifyRefusal;
    use crate::error::assert_refusal_json;

    /// The refusal is a `Refusal` whose JSON is the flat kind journals
    /// have always held, and reads back to the same refusal.
    #[test]
    fn the_family_refusal_keeps_its_json_kind_and_reads_back() {
        let refusal = IdentifyRefusal::WrongType {
            code: "91-TYPE".to_string(),
            found: Some(9999),
            schema: "x".to_string(),
            expected: vec![1],
        };
        assert_refusal_json(
            &refusal,
            r#"{"kind":"wrong_type","code":"91-TYPE","found":9999,"schema":"x","expected":[1]}"#,
        );
    }

    #[test]
    fn the_probes_find_another_family_only_where_the_protocol_is_shared() {
        use driveset_link::VirtualClock;
        use driveset_sim::catalog::Family;
        use driveset_sim::log::EventLog;
        use driveset_sim::open::{SimConfig, open_sim_with};

        use super::probe_other_family;
        let registry = driveset_schema::Registry::builtin().expect("registry");
        let vf = registry.get("lust-vf1000").expect("vf1000");
        let tmd = registry.get("lenze-tmd").expect("tmd");
        let config = SimConfig::new(Family::Mc6000, vec![1]);
        let sim =
            open_sim_with(&config, &VirtualClock::new(), "sim://t", EventLog::off()).expect("sim");
        let mut link = sim.link();
        let found = probe_other_family(&mut link, "sim://t", 1, None, &vf, None).expect("probe");
        assert!(
            found.is_some_and(|f| f.starts_with("the drive answers as ")),
            "an MC6000 is not a VF1000"
        );
        let chosen = probe_other_family(&mut link, "sim://t", 1, None, &vf, Some("probed"));
        assert_eq!(chosen.expect("not asked"), None);
        let lecom = probe_other_family(&mut link, "sim://t", 1, None, &tmd, None);
        assert_eq!(lecom.expect("not asked"), None);
    }

    #[test]
    fn the_rate_note_names_both_rates() {
        let ex = super::Examined {
            identity: crate::client::Identity::default(),
            other_rate: Some((38400, 9600)),
            fits: Ok(()),
        };
        let note = ex.rate_note().expect("note");
        assert!(
            note.starts_with("the drive answers at 38400 baud, not at the port's 9600"),
            "{note}"
        );
        assert!(note.ends_with("or add ?baud=38400 to the port)"), "{note}");
    }
}
