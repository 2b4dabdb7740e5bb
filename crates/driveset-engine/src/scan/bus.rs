//! Owns what `driveset scan` does on a bus once its port is open and its
//! protocols are chosen ([`ScanPlan`]): each protocol's addresses probed
//! in turn until drives answer ([`scan_bus`]); on a character line where
//! nobody answers at the port's rate, every other LUSTBUS rate on the same
//! port (a servo left at a transfer rate, LUSTBUS 5.1); with
//! `--detect-baud` every rate of each protocol, highest first, the port
//! reopened by the caller at each ([`scan_rates`]). The outcome
//! ([`BusScanned`]) says what answered, at which rate and which ranges
//! were probed; the front end renders it (docs/ports.md).

use std::sync::Arc;

use driveset_link::{ByteLink, Link};
use driveset_schema::{BusProtocol, Schema};

use super::{
    Found, LECOM_BAUDS, LUSTBUS_BAUDS, Reopen, ScanOptions, can_nodes, detect_baud,
    lecom_addresses, lustbus_addresses, scan_can, scan_lecom, scan_lustbus,
};
use crate::error::{EngineError, Layer};
use crate::session::{Catalog, CatalogError, SchemaAsk};

/// What to scan for: the protocols, each with the schema that gives its
/// probe code, in the order they are tried, and the probes' options.
#[derive(Debug, Clone)]
pub struct ScanPlan {
    /// The protocols in turn (never empty): one asked for, or on a
    /// character line of unknown protocol LUSTBUS, then LECOM.
    pub choices: Vec<(BusProtocol, Arc<Schema>)>,
    /// Timeouts and tries of each probe.
    pub options: ScanOptions,
}

impl ScanPlan {
    /// `driveset scan`'s plan (docs/ports.md): the protocol asked for
    /// (`protocol`, `--protocol`; the front end gives CAN SDO on a CAN
    /// port when neither it nor `schema` is given), else the family's of
    /// `schema` (`--schema`), else on a character line LUSTBUS, then
    /// LECOM; each with the schema `catalog` gives it (`schema`, else the
    /// protocol's built-in one).
    ///
    /// # Errors
    /// [`CatalogError`]: `schema` does not load or is unknown.
    pub fn resolve(
        catalog: &Catalog,
        schema: Option<&str>,
        protocol: Option<BusProtocol>,
        options: ScanOptions,
    ) -> Result<ScanPlan, CatalogError> {
        let asked: Vec<BusProtocol> = match protocol {
            Some(p) => vec![p],
            None if schema.is_some() => Vec::new(),
            None => vec![BusProtocol::Lustbus, BusProtocol::Lecom],
        };
        let choices = if asked.is_empty() {
            let s = choose(catalog, schema, None)?;
            vec![(s.family.bus(), s)]
        } else {
            let mut v = Vec::new();
            for p in asked {
                v.push((p, choose(catalog, schema, Some(p))?));
            }
            v
        };
        Ok(ScanPlan { choices, options })
    }

    /// The plan on a CAN port: when it asks CAN SDO first with a schema of
    /// a serial family (`--protocol can --schema lust-vf1000`), it probes
    /// with the built-in CAN schema instead.
    ///
    /// # Errors
    /// [`CatalogError`]: the built-in CAN schema is missing.
    pub fn on_can_port(mut self, catalog: &Catalog) -> Result<ScanPlan, CatalogError> {
        if self.first() == BusProtocol::CanSdo
            && let Some((_, schema)) = self.choices.first_mut()
            && schema.family.bus() != BusProtocol::CanSdo
        {
            *schema = choose(catalog, None, Some(BusProtocol::CanSdo))?;
        }
        Ok(self)
    }

    /// The protocol reported when nothing answers: the first asked.
    pub fn first(&self) -> BusProtocol {
        self.choices
            .first()
            .map_or(BusProtocol::Lustbus, |(p, _)| *p)
    }
}

/// The schema `schema` names, else `protocol`'s built-in one
/// ([`Catalog::chosen`]).
fn choose(
    catalog: &Catalog,
    schema: Option<&str>,
    protocol: Option<BusProtocol>,
) -> Result<Arc<Schema>, CatalogError> {
    let ask = SchemaAsk { schema, protocol };
    match catalog.chosen(ask)? {
        Some(c) => Ok(c.schema),
        // a protocol that carries no family: a build defect
        None => Err(CatalogError::MissingBuiltin {
            id: protocol.map_or("", BusProtocol::name),
        }),
    }
}

/// What a scan found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BusScanned {
    /// The protocol the drives answered (the first asked when none did).
    pub protocol: BusProtocol,
    /// The drives that answered, by address.
    pub found: Vec<Found>,
    /// The rate they answered at, when a rate search found them.
    pub baud: Option<u32>,
    /// The port's own rate, when the drives answered at another rate on
    /// the same port (left at a transfer rate).
    pub other_rate: Option<u32>,
    /// The protocols whose addresses the report names as probed: every
    /// one asked when nothing answered, else the one that did.
    pub probed: Vec<BusProtocol>,
}

impl BusScanned {
    fn of(plan: &ScanPlan, protocol: BusProtocol, found: Vec<Found>) -> Self {
        let probed = if found.is_empty() {
            plan.choices.iter().map(|(p, _)| *p).collect()
        } else {
            vec![protocol]
        };
        BusScanned {
            protocol,
            found,
            baud: None,
            other_rate: None,
            probed,
        }
    }
}

/// Why a scan could not run.
#[derive(Debug, thiserror::Error)]
pub enum ScanError {
    /// The link or a probe failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// CAN SDO asked of a character line.
    #[error("{port} is a character line: scan it with --protocol lustbus or lecom")]
    CharacterLine {
        /// The port.
        port: String,
    },
    /// A character-line protocol asked of a CAN port.
    #[error("{port} is a CAN port: scan it with --protocol sdo")]
    CanPort {
        /// The port.
        port: String,
    },
    /// A rate search asked of CAN SDO.
    #[error(
        "--detect-baud is for serial lines (LUSTBUS, LECOM); a CAN bus runs at the bit rate the port names"
    )]
    RatesOnCan,
}

impl ScanError {
    /// The layer the failure comes from: the engine's, else the command's
    /// input (nothing was sent).
    pub fn layer(&self) -> Layer {
        match self {
            ScanError::Engine(e) => e.layer(),
            ScanError::CharacterLine { .. } | ScanError::CanPort { .. } | ScanError::RatesOnCan => {
                Layer::Input
            }
        }
    }
}

/// Scans the open `link` (named `port`) at its rate for the plan's
/// protocols in turn (module docs). A CAN port scans CAN SDO with the
/// first choice's schema, which must be a CAN schema.
pub fn scan_bus(link: &mut Link, port: &str, plan: &ScanPlan) -> Result<BusScanned, ScanError> {
    match link {
        Link::Bytes(l) => scan_line(l.as_mut(), port, plan),
        Link::Frames(l) => {
            let protocol = plan.first();
            if protocol != BusProtocol::CanSdo {
                return Err(ScanError::CanPort { port: port.into() });
            }
            let Some((_, schema)) = plan.choices.first() else {
                return Ok(BusScanned::of(plan, protocol, Vec::new()));
            };
            let found = scan_can(l.as_mut(), schema, &can_nodes(), &plan.options)?;
            Ok(BusScanned::of(plan, protocol, found))
        }
    }
}

/// A character line: each protocol in turn at the port's rate, then every
/// other LUSTBUS rate on the same port.
fn scan_line(l: &mut dyn ByteLink, port: &str, plan: &ScanPlan) -> Result<BusScanned, ScanError> {
    let opts = &plan.options;
    for (p, schema) in &plan.choices {
        let found = match p {
            BusProtocol::Lustbus => scan_lustbus(l, &lustbus_addresses(), opts)?,
            BusProtocol::Lecom => scan_lecom(l, Some(schema), &lecom_addresses(), opts)?,
            BusProtocol::CanSdo => {
                return Err(ScanError::CharacterLine { port: port.into() });
            }
        };
        if !found.is_empty() {
            return Ok(BusScanned::of(plan, *p, found));
        }
    }
    // Nobody at the port's rate: a servo may have been left at a transfer
    // rate (--transfer-baud); LUSTBUS 5.1 tries every rate, on the same
    // port (a port that cannot change its rate stops the search).
    if plan.choices.iter().any(|(p, _)| *p == BusProtocol::Lustbus) {
        let here = l.baud();
        for r in LUSTBUS_BAUDS.iter().copied().filter(|r| *r != here) {
            if l.set_baud(r).is_err() {
                break;
            }
            let found = scan_lustbus(l, &lustbus_addresses(), opts)?;
            if !found.is_empty() {
                return Ok(BusScanned {
                    baud: Some(r),
                    other_rate: Some(here),
                    ..BusScanned::of(plan, BusProtocol::Lustbus, found)
                });
            }
        }
    }
    Ok(BusScanned::of(plan, plan.first(), Vec::new()))
}

/// `--detect-baud`: for each protocol of the plan in turn, every rate it
/// runs at, highest first, the line reopened at each by `reopen`
/// ([`detect_baud`]); the first rate at which drives answer.
pub fn scan_rates(plan: &ScanPlan, reopen: &mut Reopen<'_>) -> Result<BusScanned, ScanError> {
    let opts = &plan.options;
    for (p, schema) in &plan.choices {
        let rates: &[u32] = match p {
            BusProtocol::Lustbus => &LUSTBUS_BAUDS,
            BusProtocol::Lecom => &LECOM_BAUDS,
            BusProtocol::CanSdo => return Err(ScanError::RatesOnCan),
        };
        let mut line_scan = |link: &mut dyn ByteLink| match p {
            BusProtocol::Lecom => scan_lecom(link, Some(schema), &lecom_addresses(), opts),
            _ => scan_lustbus(link, &lustbus_addresses(), opts),
        };
        if let Some(b) = detect_baud(rates, reopen, &mut line_scan)? {
            return Ok(BusScanned {
                baud: Some(b.baud),
                ..BusScanned::of(plan, *p, b.found)
            });
        }
    }
    Ok(BusScanned::of(plan, plan.first(), Vec::new()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(schema: Option<&str>, protocol: Option<BusProtocol>) -> ScanPlan {
        ScanPlan::resolve(&Catalog::new(&[]), schema, protocol, ScanOptions::default()).unwrap()
    }

    fn ids(p: &ScanPlan) -> Vec<(BusProtocol, &str)> {
        p.choices.iter().map(|(b, s)| (*b, s.id.as_str())).collect()
    }

    #[test]
    fn a_scan_asks_the_protocol_given_else_the_schemas_else_lustbus_then_lecom() {
        let both = plan(None, None);
        assert_eq!(both.choices.len(), 2);
        assert_eq!(both.choices[0].0, BusProtocol::Lustbus);
        assert_eq!(ids(&both)[1], (BusProtocol::Lecom, "lenze-tmd"));
        assert_eq!(
            ids(&plan(Some("lenze-tmd"), None)),
            vec![(BusProtocol::Lecom, "lenze-tmd")]
        );
        assert_eq!(
            ids(&plan(None, Some(BusProtocol::Lecom))),
            vec![(BusProtocol::Lecom, "lenze-tmd")]
        );
        let named = plan(Some("lust-vf1000"), Some(BusProtocol::CanSdo));
        assert_eq!(ids(&named), vec![(BusProtocol::CanSdo, "lust-vf1000")]);
        let can = named.on_can_port(&Catalog::new(&[])).unwrap();
        assert_eq!(can.choices[0].1.family.bus(), BusProtocol::CanSdo);
        assert!(
            ScanPlan::resolve(
                &Catalog::new(&[]),
                Some("no-such"),
                None,
                ScanOptions::default()
            )
            .is_err()
        );
    }
}
