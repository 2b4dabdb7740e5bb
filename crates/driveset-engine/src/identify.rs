//! Identification helpers on top of [`DriveClient::identify`]: read what a
//! drive says it is, and refuse a schema (and so a set) for another family
//! (docs/architecture.md, "The data path of an upload": identify); what
//! `driveset identify` finds of a drive ([`examine`]: its identity, at the
//! port's rate or another, and whether the schema fits).

use crate::client::{DriveClient, IdentValue, Identity};
use crate::error::{EngineError, ErrorKind, Refusal};

/// The identification codes of the client's schema, read from the drive.
pub fn identify(client: &mut dyn DriveClient) -> Result<Identity, EngineError> {
    client.identify()
}

/// Identifies the drive and checks it against the client's schema: the
/// protocol must match and, where the schema lists `type_values` (LUSTBUS
/// 91-TYPE, `Descriptor::device_type_code`), the drive's TYPE must be one
/// of them. A mismatch is
/// [`ErrorKind::Refused`]; nothing is written either way.
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
            Refusal::WrongType {
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
            if matches!(e.kind(), ErrorKind::NoAnswer { .. })
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
