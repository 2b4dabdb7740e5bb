//! Finding the drives on a bus.
//!
//! - LUSTBUS (section 5.2): an ENQUIRY of 91-TYPE (CODE `00091`, the same
//!   on inverters and servocontrollers) to every address 1..30; any answer
//!   (value or NAK) means a drive is there. Address 0 (every drive answers)
//!   and 31 (broadcast, nobody answers) are refused as scan targets.
//! - LECOM-A/B: a RECEIVE of the schema's first identification code (Tmd:
//!   C0093) to every station 01..99 except the group addresses 00, 10 .. 90
//!   (8.J), which are refused; any answer (a value, "?" or "no such code")
//!   counts.
//! - CAN SDO: a read of a schema code (the first identification code, else
//!   the schema's first code) from every node 1..127; a value or an SDO
//!   abort counts. Node 0 is refused.
//!
//! Every probe uses a short timeout ([`ScanOptions::timeout`], defaults per
//! protocol below) and one try unless [`ScanOptions::tries`] says more.
//!
//! [`detect_protocol`] finds the protocol and family of the drive at one
//! address of a serial line with the same read-only probes: LUSTBUS ENQUIRY
//! of 91-TYPE (then of the MC CODE `20091`: a servocontroller answers it, an
//! inverter NAKs it), else LECOM RECEIVE of C0093, then C0200.
//!
//! [`detect_baud`] runs a serial scan at every allowed rate, highest first
//! (LUSTBUS 5.1: "the connection will be attempted using all possible
//! transfer rates"), reopening the line through a caller's closure, and
//! stops at the first rate where a drive answers.
//!
//! `driveset scan`'s walk over a bus (the protocols in turn, the other
//! rates, `--detect-baud`) is `scan/bus.rs`'s: [`scan_bus`], [`scan_rates`].

mod bus;

use std::sync::Arc;
use std::time::Duration;

use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, FrameLink, LinkError};
use driveset_proto::can::NodeId;
use driveset_proto::lecom::ControllerAddress;
use driveset_proto::lustbus::{Address, Dialect};
use driveset_schema::family::TYPE;
use driveset_schema::{BusProtocol, CodeKey, Family, Schema};

use crate::client::lecom::{C0093, LecomLine};
use crate::client::lustbus::LustLine;
use crate::client::sdo::SdoLine;
use crate::client::{
    BorrowedByteLink, BorrowedFrameLink, IdentCode, IdentProtocol, IdentValue, Identity, Target,
};
use crate::error::{AddressRefused, EngineError, Refusal};

pub use bus::{BusScanned, ScanError, ScanPlan, scan_bus, scan_rates};

/// What a scan refuses before it probes (beside the address rule,
/// [`AddressRefused`]). Gathered into [`Refusal`] as `Refusal::Scan`, with
/// the JSON kind journals hold (`no_probe_code`).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ScanRefusal {
    /// A schema with no code to probe a CAN scan with.
    #[error("schema `{schema}` has no code to probe with")]
    NoProbeCode {
        /// Schema id.
        schema: String,
    },
}

/// LUSTBUS line rates, highest first (section 4: 2400..9600 inverters,
/// 2400..57600 servocontrollers): the descriptor's
/// [`BusProtocol::line_rates`].
pub const LUSTBUS_BAUDS: [u32; 6] = rates(BusProtocol::Lustbus.line_rates());
/// LECOM line rates of the Tmd (C0125), highest first: the descriptor's
/// [`BusProtocol::line_rates`].
pub const LECOM_BAUDS: [u32; 4] = rates(BusProtocol::Lecom.line_rates());

/// A bus's rate list as the array its constant has always been (a build
/// error if the descriptor's list has another length).
const fn rates<const N: usize>(list: &[u32]) -> [u32; N] {
    assert!(list.len() == N, "the descriptor's rate list changed length");
    let mut out = [0; N];
    let mut i = 0;
    while i < N {
        out[i] = list[i];
        i += 1;
    }
    out
}

/// The longest reaction of any drive on `bus`, with a KEYPAD where that is
/// longer (the descriptors' [`driveset_schema::family::Reaction`]: LUSTBUS
/// 60 ms, a VF1000 with KEYPAD, section 10; LECOM 20 ms).
fn longest_reaction(bus: BusProtocol) -> Duration {
    bus.families()
        .map(|f| {
            f.descriptor()
                .reaction
                .longest(driveset_schema::family::Keypad::Fitted)
        })
        .max()
        .unwrap_or_default()
}

/// A LUSTBUS probe's answer timeout: `opts.timeout`, else the longest
/// reaction + 5 ms + the wire time of a 14-character reply.
fn lustbus_timeout(opts: &ScanOptions, baud: u32) -> Duration {
    opts.timeout.unwrap_or_else(|| {
        longest_reaction(BusProtocol::Lustbus)
            + Duration::from_millis(5)
            + wire_time(14, baud)
            + opts.allowance
    })
}

/// A LECOM probe's answer timeout: `opts.timeout`, else twice the longest
/// reaction + the wire time of the answer (24 characters).
fn lecom_timeout(opts: &ScanOptions, baud: u32) -> Duration {
    opts.timeout.unwrap_or_else(|| {
        2 * longest_reaction(BusProtocol::Lecom) + wire_time(24, baud) + opts.allowance
    })
}

/// The family of the drives on `bus` when it carries one (LECOM: Tmd; CAN
/// SDO: ECS; [`BusProtocol::only_family`]), else the bus: what a found
/// drive's identity names.
fn ident_protocol(bus: BusProtocol) -> IdentProtocol {
    bus.only_family()
        .map_or(IdentProtocol::Bus(bus), IdentProtocol::Family)
}

/// How to scan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScanOptions {
    /// Per-address answer timeout. `None`: LUSTBUS 60 ms (the longest
    /// reaction time, VF1000 with KEYPAD) + the wire time of a 14-character
    /// reply + 5 ms; LECOM 2 x 20 ms + the wire time of the answer; CAN
    /// 20 ms.
    pub timeout: Option<Duration>,
    /// Probes per address. Default 1.
    pub tries: u32,
    /// What the transport adds to the default timeouts, by the clients'
    /// rules (`client::timing`): [`ScanOptions::behind`]. Default none (a
    /// direct line).
    pub allowance: Duration,
}

impl Default for ScanOptions {
    fn default() -> Self {
        ScanOptions {
            timeout: None,
            tries: 1,
            allowance: Duration::ZERO,
        }
    }
}

impl ScanOptions {
    /// A scan of many addresses behind a transport that adds `latency`
    /// round trip (the port's `?latency=`): each probe's timeout gets the
    /// clients' least allowance, `latency` + the floor
    /// ([`crate::client::timing::LinkLatency`]); none without one (a silent
    /// address is a scan's normal case, so nothing is added per probe).
    pub fn behind(latency: Option<Duration>) -> Self {
        ScanOptions {
            allowance: latency.map_or(Duration::ZERO, |l| {
                l.saturating_add(crate::client::timing::LATENCY_FLOOR)
            }),
            ..ScanOptions::default()
        }
    }

    /// The probes of one drive (identify's, pull's, a twin capture's
    /// protocol detection) behind a transport that adds `latency` (the
    /// port's `?latency=`, or unknown): the clients' first-contact
    /// allowance ([`crate::client::timing::LinkLatency::allowance`] before
    /// any sample), so a slow link is not taken for a missing drive.
    pub fn first_contact(latency: Option<Duration>) -> Self {
        ScanOptions {
            allowance: crate::client::timing::LinkLatency::new(latency).allowance(),
            ..ScanOptions::default()
        }
    }
}

/// A drive that answered.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Found {
    /// Its address / node id.
    pub address: u8,
    /// What the probe read.
    pub identity: Identity,
}

impl Found {
    /// The drive as scans list it: `address 3: 91-TYPE = 1000, ...` (its
    /// identify codes).
    pub fn text(&self) -> String {
        let codes: Vec<String> = self
            .identity
            .codes
            .iter()
            .map(|c| format!("{} = {}", c.name, c.value))
            .collect();
        format!("address {}: {}", self.address, codes.join(", "))
    }

    /// The drive at `address` on `bus` that answered a scan's probe with
    /// `code`.
    fn probed(address: u8, bus: BusProtocol, code: IdentCode) -> Self {
        Found {
            address,
            identity: Identity {
                protocol: ident_protocol(bus),
                codes: vec![code],
                software: None,
            },
        }
    }
}

/// The result of [`detect_baud`].
#[derive(Debug)]
pub struct BaudScan {
    /// The rate the drives answered at.
    pub baud: u32,
    /// The line, open at that rate.
    pub link: Box<dyn ByteLink>,
    /// The drives found.
    pub found: Vec<Found>,
}

fn refuse(port: &str, address: u8, refusal: Refusal) -> EngineError {
    EngineError::refused(
        Target {
            port: port.to_string(),
            address,
        },
        refusal,
    )
}

/// The codec's addresses (`make`) of the scan targets `addresses` on
/// `bus`, each checked by the bus's rule for a scan first
/// ([`AddressRefused::check_scan`]); the first refused ends the scan
/// before anything is sent.
fn scan_targets<A>(
    port: &str,
    bus: BusProtocol,
    addresses: &[u8],
    make: impl Fn(u8) -> Option<A>,
) -> Result<Vec<A>, EngineError> {
    addresses
        .iter()
        .map(|&a| {
            AddressRefused::check_scan(bus, a).map_err(|r| refuse(port, a, r))?;
            // the codec could not carry an address the rule took (it
            // takes only addresses the codec carries)
            make(a).ok_or_else(|| {
                refuse(
                    port,
                    a,
                    Refusal::Encode {
                        what: None,
                        detail: format!("address {a}"),
                    },
                )
            })
        })
        .collect()
}

fn link_err(port: &str, address: u8, source: LinkError) -> EngineError {
    EngineError::link(
        Target {
            port: port.to_string(),
            address,
        },
        source,
    )
}

/// LUSTBUS addresses 1..=30 ([`BusProtocol::drive_addresses`]).
pub fn lustbus_addresses() -> Vec<u8> {
    BusProtocol::Lustbus.drive_addresses().collect()
}

/// LECOM stations 01..99 without 00 and the group addresses x0
/// ([`BusProtocol::drive_addresses`] less [`BusProtocol::is_group_address`]).
pub fn lecom_addresses() -> Vec<u8> {
    let lecom = BusProtocol::Lecom;
    lecom
        .drive_addresses()
        .filter(|a| !lecom.is_group_address(i64::from(*a)))
        .collect()
}

/// CAN node ids 1..=127 ([`BusProtocol::drive_addresses`]).
pub fn can_nodes() -> Vec<u8> {
    BusProtocol::CanSdo.drive_addresses().collect()
}

/// Scans a LUSTBUS line (see the module docs).
pub fn scan_lustbus(
    link: &mut dyn ByteLink,
    addresses: &[u8],
    opts: &ScanOptions,
) -> Result<Vec<Found>, EngineError> {
    let port = link.port().to_string();
    let targets = scan_targets(&port, BusProtocol::Lustbus, addresses, Address::new)?;
    let timeout = lustbus_timeout(opts, link.baud());
    let mut line = LustLine::new(BorrowedByteLink(link));
    // Replies carry the address: a late one from the previous address is
    // told apart, so no late window after each silent address.
    line.wait_late = false;
    let mut found = Vec::new();
    for ad in targets {
        let got = crate::client::lustbus::probe_type(&mut line, ad, timeout, opts.tries)
            .map_err(|e| link_err(&port, ad.number(), e))?;
        if let Some(value) = got {
            found.push(Found::probed(
                ad.number(),
                BusProtocol::Lustbus,
                IdentCode::new(
                    CodeKey::new(TYPE),
                    format!("{TYPE}-TYPE"),
                    value.map_or_else(|| IdentValue::Text("NAK".into()), IdentValue::Int),
                ),
            ));
        }
    }
    line.finish().map_err(|e| link_err(&port, 0, e))?;
    Ok(found)
}

/// Scans a LECOM-A/B line (see the module docs). `schema` gives the probe
/// code (its first identification code), else C0093.
pub fn scan_lecom(
    link: &mut dyn ByteLink,
    schema: Option<&Schema>,
    addresses: &[u8],
    opts: &ScanOptions,
) -> Result<Vec<Found>, EngineError> {
    let port = link.port().to_string();
    let targets = scan_targets(&port, BusProtocol::Lecom, addresses, ControllerAddress::new)?;
    let number = schema
        .and_then(|s| s.identify.as_ref())
        .and_then(|i| i.codes.first().copied())
        .unwrap_or(C0093);
    let key = CodeKey::new(number);
    let name = format!("C{number:04}");
    let timeout = lecom_timeout(opts, link.baud());
    // Answers carry no address: after a silent address the probe listens
    // for a late answer as long again, so it is not taken for the next
    // address's (client::timing).
    let mut line = LecomLine::new(BorrowedByteLink(link));
    let mut found = Vec::new();
    for ad in targets {
        let got = crate::client::lecom::probe(&mut line, ad, key, timeout, opts.tries)
            .map_err(|e| link_err(&port, ad.get(), e))?;
        if let Some(text) = got {
            found.push(Found::probed(
                ad.get(),
                BusProtocol::Lecom,
                IdentCode::new(key, name.clone(), IdentValue::Text(text)),
            ));
        }
    }
    line.finish().map_err(|e| link_err(&port, 0, e))?;
    Ok(found)
}

/// Scans a CAN bus for SDO servers (see the module docs).
pub fn scan_can(
    link: &mut dyn FrameLink,
    schema: &Arc<Schema>,
    nodes: &[u8],
    opts: &ScanOptions,
) -> Result<Vec<Found>, EngineError> {
    let port = link.port().to_string();
    let targets = scan_targets(&port, BusProtocol::CanSdo, nodes, |n| NodeId::new(n).ok())?;
    let number = schema
        .identify
        .as_ref()
        .and_then(|i| i.codes.first().copied())
        .or_else(|| schema.codes.first().map(|c| c.number))
        .ok_or_else(|| {
            refuse(
                &port,
                0,
                ScanRefusal::NoProbeCode {
                    schema: schema.id.clone(),
                }
                .into(),
            )
        })?;
    let key = CodeKey::new(number);
    let name = schema.display_code(number, None);
    let timeout = opts.timeout.unwrap_or(Duration::from_millis(20));
    let mut line = SdoLine::new(BorrowedFrameLink(link));
    let mut found = Vec::new();
    for node in targets {
        let got = crate::client::sdo::probe(&mut line, schema, node, key, timeout, opts.tries)
            .map_err(|e| link_err(&port, node.get(), e))?;
        if let Some(text) = got {
            found.push(Found::probed(
                node.get(),
                BusProtocol::CanSdo,
                IdentCode::new(key, name.clone(), IdentValue::Text(text)),
            ));
        }
    }
    Ok(found)
}

/// Reopens a serial line at a rate (for [`detect_baud`]).
pub type Reopen<'a> = dyn FnMut(u32) -> Result<Box<dyn ByteLink>, LinkError> + 'a;
/// Scans an open line (for [`detect_baud`]), e.g. a closure over
/// [`scan_lustbus`].
pub type LineScan<'a> = dyn FnMut(&mut dyn ByteLink) -> Result<Vec<Found>, EngineError> + 'a;

/// Baud detection: for every rate of `rates`, highest first, opens the line
/// with `open` and runs `scan` on it; returns the first rate at which a
/// drive answered, with the open line. `Ok(None)` when no rate finds one.
/// A rate the port cannot be opened at is skipped.
pub fn detect_baud(
    rates: &[u32],
    open: &mut Reopen<'_>,
    scan: &mut LineScan<'_>,
) -> Result<Option<BaudScan>, EngineError> {
    let mut rates = rates.to_vec();
    rates.sort_unstable_by(|a, b| b.cmp(a));
    rates.dedup();
    for baud in rates {
        let mut link = match open(baud) {
            Ok(l) => l,
            Err(LinkError::UnsupportedBaud { .. }) => continue,
            Err(e) => return Err(link_err("(reopen)", 0, e)),
        };
        let found = scan(link.as_mut())?;
        if !found.is_empty() {
            return Ok(Some(BaudScan { baud, link, found }));
        }
    }
    Ok(None)
}

/// The read-only probes [`detect_protocol`] sends, as messages name them
/// (`LUSTBUS ENQUIRY of 91-TYPE, LECOM RECEIVE of C0093 and C0200`): the
/// LUSTBUS TYPE code and the LECOM family's `IdentifyRules::probe`.
pub fn probes_text() -> String {
    let lecom: Vec<String> = BusProtocol::Lecom
        .only_family()
        .map_or(&[][..], |f| f.descriptor().identify_rules.probe)
        .iter()
        .map(|n| format!("C{n:04}"))
        .collect();
    format!(
        "LUSTBUS ENQUIRY of {TYPE}-TYPE, LECOM RECEIVE of {}",
        lecom.join(" and ")
    )
}

/// What [`detect_protocol`] found at an address.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Detected {
    /// The protocol (and so the family) of the drive.
    pub protocol: driveset_schema::Family,
    /// What answered, for messages (`91-TYPE = 6000 and MC CODE 20091`).
    pub evidence: String,
}

/// The protocol and family of the drive at `address` on a serial line, by
/// read-only probes (module docs). `Ok(None)` when nothing answers any of
/// them. Nothing is written.
pub fn detect_protocol(
    link: &mut dyn ByteLink,
    address: u8,
    opts: &ScanOptions,
) -> Result<Option<Detected>, EngineError> {
    let port = link.port().to_string();
    let lust_timeout = lustbus_timeout(opts, link.baud());
    if let Some(ad) = Address::new(address).filter(|a| a.is_individual()) {
        let mut line = LustLine::new(BorrowedByteLink(&mut *link));
        let got = crate::client::lustbus::probe_type(&mut line, ad, lust_timeout, opts.tries)
            .map_err(|e| link_err(&port, address, e))?;
        if let Some(value) = got {
            let code = u16::try_from(TYPE)
                .ok()
                .and_then(driveset_proto::lustbus::ParameterCode::mc_value)
                .unwrap_or(driveset_proto::lustbus::ParameterCode::POSMOD);
            let mc = crate::client::lustbus::probe_code(&mut line, ad, code, lust_timeout, 1)
                .map_err(|e| link_err(&port, address, e))?;
            line.finish().map_err(|e| link_err(&port, address, e))?;
            let ty = value.map_or_else(|| "NAK".to_string(), |v| v.to_string());
            return Ok(Some(match mc {
                Some(Some(_)) => Detected {
                    protocol: Family::from_dialect(Dialect::Mc),
                    evidence: format!(
                        "LUSTBUS ENQUIRY of {TYPE}-TYPE answered ({ty}) and the MC6000/7000 CODE 20091 too"
                    ),
                },
                _ => Detected {
                    protocol: Family::from_dialect(Dialect::Vf1000),
                    evidence: format!(
                        "LUSTBUS ENQUIRY of {TYPE}-TYPE answered ({ty}), the MC6000/7000 CODE 20091 not: a VF1000"
                    ),
                },
            }));
        }
        line.finish().map_err(|e| link_err(&port, address, e))?;
    }
    if let Some(ad) = ControllerAddress::new(address).filter(|a| !a.is_broadcast()) {
        let timeout = lecom_timeout(opts, link.baud());
        let mut line = LecomLine::new(BorrowedByteLink(&mut *link));
        // The LECOM family's probe codes (C0093, then C0200: its identify
        // codes without the software version, `IdentifyRules::probe`).
        let probe = BusProtocol::Lecom
            .only_family()
            .map_or(&[][..], |f| f.descriptor().identify_rules.probe);
        for &number in probe {
            let got = crate::client::lecom::probe(
                &mut line,
                ad,
                CodeKey::new(number),
                timeout,
                opts.tries,
            )
            .map_err(|e| link_err(&port, address, e))?;
            if let Some(text) = got
                && let Some(family) = BusProtocol::Lecom.only_family()
            {
                line.finish().map_err(|e| link_err(&port, address, e))?;
                return Ok(Some(Detected {
                    protocol: family,
                    evidence: format!("LECOM RECEIVE of C{number:04} answered ({text})"),
                }));
            }
        }
        line.finish().map_err(|e| link_err(&port, address, e))?;
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The refusal is a `Refusal` whose JSON is the flat kind journals
    /// have always held, and reads back to the same refusal.
    #[test]
    fn the_scan_refusal_keeps_its_json_kind_and_reads_back() {
        crate::error::assert_refusal_json(
            &ScanRefusal::NoProbeCode {
                schema: "x".to_string(),
            },
            r#"{"kind":"no_probe_code","schema":"x"}"#,
        );
    }

    #[test]
    fn scan_targets_pass_the_scan_rule_then_the_codec_and_stop_at_the_first_refused() {
        let got =
            scan_targets("sim://line", BusProtocol::Lecom, &[1, 11, 99], Some).expect("stations");
        assert_eq!(got, [1, 11, 99]);
        // LUSTBUS 0 is refused for a scan (every drive would answer)
        let e = scan_targets("sim://line", BusProtocol::Lustbus, &[3, 0, 4], Some)
            .expect_err("0 refused");
        assert_eq!(e.target.as_ref().map(|t| t.address), Some(0));
        assert!(matches!(e.refusal(), Some(Refusal::Address(_))), "{e}");
        // then the codec
        let e = scan_targets("sim://line", BusProtocol::CanSdo, &[5], |_| None::<u8>)
            .expect_err("the codec refused");
        assert!(
            matches!(e.refusal(), Some(Refusal::Encode { what: None, detail }) if detail == "address 5"),
            "{e}"
        );
    }

    #[test]
    fn a_probed_drive_names_its_family_where_the_bus_has_one() {
        let code = IdentCode::new(CodeKey::new(93), "C0093", IdentValue::Text("x".into()));
        let lecom = Found::probed(7, BusProtocol::Lecom, code.clone());
        assert_eq!(lecom.address, 7);
        assert_eq!(lecom.identity.protocol, ident_protocol(BusProtocol::Lecom));
        assert!(matches!(lecom.identity.protocol, IdentProtocol::Family(_)));
        assert_eq!(lecom.identity.codes, std::slice::from_ref(&code));
        let lust = Found::probed(3, BusProtocol::Lustbus, code);
        assert_eq!(
            lust.identity.protocol,
            IdentProtocol::Bus(BusProtocol::Lustbus)
        );
    }

    #[test]
    fn the_probes_are_named_from_the_type_code_and_the_lecom_probe_list() {
        assert_eq!(
            super::probes_text(),
            "LUSTBUS ENQUIRY of 91-TYPE, LECOM RECEIVE of C0093 and C0200"
        );
    }
}
