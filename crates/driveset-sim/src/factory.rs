//! Owns the factory-fresh drives of a `sim://` port and the service bench:
//! the `factory=` grammar ([`parse_factory`]), each family's factory
//! address and rate ([`factory_address`], [`FACTORY_BAUD`]), a drive's
//! stable place in its port ([`DriveSlot`], what a state dump matches on
//! when the drive's own address has changed) and the bench rule
//! ([`bench_pick`]).
//!
//! # Factory-fresh drives
//!
//! `sim://mc6000?factory=3`, `sim://tmd?factory=2`,
//! `sim://lustbus?factory=mc6000*4,vf1000*3`: drives as they leave the
//! factory, with their whole factory table, the family's factory address
//! and the factory rate 9600 baud (LUSTBUS section 4: "factory setting 9600
//! Baud"; lecom-ab-tmd-manual.txt C0125 = 0, 9600 bps). LUSTBUS section
//! 4.2 says every device's SIOA/SADDR is set at the factory "to the same
//! value" without saying which: the simulator uses 1 (FICTIONAL). A Tmd
//! leaves the factory at C0009 = 1 (the manual's default).
//!
//! Several factory drives thus share one address: every telegram to that
//! address (or, on LUSTBUS, to address 0, which every device answers,
//! section 4.1) is answered by all of them at once, and the host gets the
//! garbled mix the bus's collision model makes of it (`crate::bus`,
//! event `collision`): no valid answer, as section 4.2 warns.
//!
//! # The service bench (`bench=true`)
//!
//! A twin of the commissioning engineer who follows the tool's "connect
//! press-axis-3 alone to PORT" instructions: at each open of the port the
//! bus holds only the first factory drive (in port order) that has not been
//! given an address yet ([`bench_pick`]); once every factory drive has one,
//! all drives of the port are on the line together (the finished line).
//! A drive off the bench keeps its state in the state dump.
//!
//! ECS nodes are out of scope (their node id is set at the unit): a
//! `sim://ecs` port refuses `factory=`.

use std::fmt;
use std::time::Duration;

use driveset_schema::family::Keypad;

use crate::catalog::Family;
use crate::drive::ReactionTime;

/// The rate every factory-fresh drive runs at: LUSTBUS section 4 ("factory
/// setting 9600 Baud"), lecom-ab-tmd-manual.txt C0125 = 0 (9600 bps).
pub const FACTORY_BAUD: u32 = 9600;

/// The most factory drives one `factory=` item (and one port) holds: a
/// LUSTBUS line has 30 addresses (section 4.2).
pub const MAX_FACTORY: usize = 30;

/// The address a drive of `family` leaves the factory with, `None` for a
/// family the simulator has no factory model of (ECS).
///
/// LUSTBUS (MC6000/7000, VF1000): section 4.2 says only that every device
/// is set "to the same value": 1 is FICTIONAL. Tmd: C0009 = 1, the
/// default of lecom-ab-tmd-manual.txt Table 1 (C0009 network address).
pub fn factory_address(family: Family) -> Option<u8> {
    match family {
        Family::Mc6000 | Family::Vf1000 | Family::Tmd => Some(1),
        Family::Ecs => None,
    }
}

/// The spacing of factory drives' replies: 2.5 bit times at 9600 baud.
const REPLY_STEP: Duration = Duration::from_nanos(260_417);

/// The reaction time of the `k`-th factory drive of a port (from 0):
/// fixed, the family's shortest reaction plus `k` × 2.5 bit times at 9600
/// baud. FICTIONAL: the specs give only the range (LUSTBUS section 10;
/// none for the Tmd). Units fresh from one factory react alike, so their
/// answers to one telegram always overlap and garble each other (LUSTBUS
/// section 4.2: no address twice; several devices answering give no
/// valid answer), each shifted by a fraction of a character so that even
/// equal answers do not add up to a valid one (`crate::bus` samples every
/// bit).
pub fn factory_reaction(family: Family, keypad: Keypad, k: usize) -> ReactionTime {
    let min = ReactionTime::of(family, keypad).min;
    let step = REPLY_STEP.saturating_mul(u32::try_from(k).unwrap_or(u32::MAX));
    ReactionTime::fixed(min.saturating_add(step))
}

/// What to say when an ECS port names factory drives.
pub const ECS_REFUSAL: &str = "factory-fresh drives are modelled on LUSTBUS (mc6000, vf1000) and LECOM (tmd) only; an ECS node's id is set at the unit: give it with addresses=, e.g. sim://ecs?addresses=1";

/// The kind of bus a `factory=` value is for: one family's bus
/// (`sim://mc6000`), where an item may be a bare count, or a mixed LUSTBUS
/// (`sim://lustbus`), where every item names its family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FactoryBus {
    /// A one-family bus.
    OneFamily,
    /// A mixed LUSTBUS.
    Mixed,
}

impl FactoryBus {
    /// The kind of the bus of a `sim://` path: [`FactoryBus::Mixed`] for
    /// `lustbus` ([`crate::port::MIXED_LUSTBUS`], any case).
    pub fn of_path(bus: &str) -> Self {
        if bus.eq_ignore_ascii_case(crate::port::MIXED_LUSTBUS) {
            FactoryBus::Mixed
        } else {
            FactoryBus::OneFamily
        }
    }
}

/// Parse a `factory=` value into one family name per drive, in port
/// order. `bus` is the port's path: on a one-family bus an item is a
/// count (`3`) or `FAMILY*N` / `FAMILY` of that family; on
/// `sim://lustbus` every item names its family. `family_of` maps a name
/// to a family (the port's family parser).
pub fn parse_factory(
    bus: &str,
    kind: FactoryBus,
    value: &str,
    family_of: impl Fn(&str) -> Option<Family>,
) -> Result<Vec<String>, String> {
    let mixed = kind == FactoryBus::Mixed;
    let bus_family = if mixed { None } else { family_of(bus) };
    let mut out = Vec::new();
    for item in value.split(',') {
        let item = item.trim();
        let (name, count) = match item.split_once('*') {
            Some((name, n)) => (name.trim(), Some(n.trim())),
            None if item.parse::<usize>().is_ok() => ("", Some(item)),
            None => (item, None),
        };
        let count = match count {
            None => 1,
            Some(n) => match n.parse::<usize>() {
                Ok(n) if (1..=MAX_FACTORY).contains(&n) => n,
                _ => {
                    return Err(format!(
                        "`{item}`: the count is a whole number 1..={MAX_FACTORY}; write FAMILY*N (mc6000*3) or, on a one-family bus, N"
                    ));
                }
            },
        };
        let name = if name.is_empty() {
            if mixed {
                return Err(format!(
                    "`{item}`: on sim://{bus} every item names its family: FAMILY*N, e.g. factory=mc6000*4,vf1000*3"
                ));
            }
            bus.to_string()
        } else {
            let Some(f) = family_of(name) else {
                return Err(format!(
                    "`{item}`: unknown drive family `{name}`; use mc6000, mc7000, vf1000 or tmd"
                ));
            };
            if f == Family::Ecs {
                return Err(ECS_REFUSAL.into());
            }
            if mixed && !matches!(f, Family::Mc6000 | Family::Vf1000) {
                return Err(format!(
                    "`{item}`: {} drives cannot be on a mixed LUSTBUS; put them on sim://{}?factory=N",
                    f.name(),
                    f.name()
                ));
            }
            if let Some(b) = bus_family
                && b != f
            {
                return Err(format!(
                    "`{item}`: sim://{bus} holds {} drives only; put {} and {} drives on sim://lustbus?factory=...",
                    b.name(),
                    f.name(),
                    b.name()
                ));
            }
            name.to_string()
        };
        out.extend(std::iter::repeat_n(name, count));
    }
    if out.len() > MAX_FACTORY {
        return Err(format!(
            "{} factory drives; one bus holds at most {MAX_FACTORY}",
            out.len()
        ));
    }
    Ok(out)
}

/// The canonical `factory=` value of `drives` (family names as
/// [`parse_factory`] gives them): the count on a one-family bus,
/// `FAMILY*N` runs on a mixed LUSTBUS.
pub fn factory_text(kind: FactoryBus, drives: &[String]) -> String {
    if kind == FactoryBus::OneFamily {
        return drives.len().to_string();
    }
    let mut runs: Vec<(&str, usize)> = Vec::new();
    for d in drives {
        match runs.last_mut() {
            Some((name, n)) if *name == d.as_str() => *n += 1,
            _ => runs.push((d.as_str(), 1)),
        }
    }
    runs.iter()
        .map(|(name, n)| format!("{name}*{n}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// A drive's stable identity in its port: what a state dump matches a
/// drive by, so that a drive found again after its own address changed
/// (82-SADDR, C0009 written) is the same drive.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum DriveSlot {
    /// A drive the port names by address (`addresses=5`, `mc6000=5`):
    /// family and that address (`mc6000@5`).
    Port {
        /// The family.
        family: Family,
        /// The address the port names.
        address: u8,
    },
    /// The `n`-th factory drive of `family` in the port's `factory=`
    /// list, from 1 (`mc6000#2`).
    Factory {
        /// The family.
        family: Family,
        /// Its place among the port's factory drives of that family.
        n: usize,
    },
}

impl DriveSlot {
    /// The drive's family.
    pub fn family(&self) -> Family {
        match self {
            DriveSlot::Port { family, .. } | DriveSlot::Factory { family, .. } => *family,
        }
    }

    /// Whether this is a factory drive.
    pub fn is_factory(&self) -> bool {
        matches!(self, DriveSlot::Factory { .. })
    }

    /// Parse the text [`fmt::Display`] writes (`mc6000@5`, `tmd#1`).
    pub fn parse(text: &str) -> Option<DriveSlot> {
        if let Some((f, a)) = text.split_once('@') {
            return Some(DriveSlot::Port {
                family: Family::parse(f).ok()?,
                address: a.parse().ok()?,
            });
        }
        let (f, n) = text.split_once('#')?;
        Some(DriveSlot::Factory {
            family: Family::parse(f).ok()?,
            n: n.parse().ok().filter(|n| *n > 0)?,
        })
    }
}

impl fmt::Display for DriveSlot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DriveSlot::Port { family, address } => write!(f, "{}@{address}", family.name()),
            DriveSlot::Factory { family, n } => write!(f, "{}#{n}", family.name()),
        }
    }
}

/// One drive as the bench rule sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BenchView {
    /// Whether it is a factory drive (the port's `factory=`).
    pub factory: bool,
    /// Its address now.
    pub address: u8,
    /// Its family's factory address.
    pub factory_address: Option<u8>,
    /// Whether its address code was ever written over the bus (an
    /// engineer gave it an address, perhaps the factory one).
    pub assigned: bool,
}

impl BenchView {
    /// Whether the drive still waits on the bench for its address.
    pub fn waiting(&self) -> bool {
        self.factory && !self.assigned && Some(self.address) == self.factory_address
    }
}

/// The bench rule: the index of the first drive (in port order) still
/// waiting for its address ([`BenchView::waiting`]), alone on the bus;
/// `None` once none waits (all drives on the line together).
pub fn bench_pick(drives: &[BenchView]) -> Option<usize> {
    drives.iter().position(BenchView::waiting)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fam(name: &str) -> Option<Family> {
        crate::open::parse_family(name).ok()
    }

    #[test]
    fn the_grammar_and_its_canonical_form() {
        let p = |bus, kind, v| parse_factory(bus, kind, v, fam);
        assert_eq!(
            p("mc6000", FactoryBus::OneFamily, "3").unwrap(),
            ["mc6000"; 3]
        );
        assert_eq!(
            p("tmd", FactoryBus::OneFamily, "tmd*2").unwrap(),
            ["tmd"; 2]
        );
        assert_eq!(
            p("vf1000", FactoryBus::OneFamily, "vf1000").unwrap(),
            ["vf1000"]
        );
        let mixed = p("lustbus", FactoryBus::Mixed, "mc6000*2,vf1000,mc7000*1").unwrap();
        assert_eq!(mixed, ["mc6000", "mc6000", "vf1000", "mc7000"]);
        assert_eq!(
            factory_text(FactoryBus::Mixed, &mixed),
            "mc6000*2,vf1000*1,mc7000*1"
        );
        assert_eq!(
            factory_text(
                FactoryBus::OneFamily,
                &p("tmd", FactoryBus::OneFamily, "2").unwrap()
            ),
            "2"
        );
        assert_eq!(
            p("mc6000", FactoryBus::OneFamily, "0").unwrap_err(),
            "`0`: the count is a whole number 1..=30; write FAMILY*N (mc6000*3) or, on a one-family bus, N"
        );
        assert_eq!(
            p("lustbus", FactoryBus::Mixed, "3").unwrap_err(),
            "`3`: on sim://lustbus every item names its family: FAMILY*N, e.g. factory=mc6000*4,vf1000*3"
        );
        assert_eq!(
            p("mc6000", FactoryBus::OneFamily, "vf1000*2").unwrap_err(),
            "`vf1000*2`: sim://mc6000 holds mc6000 drives only; put vf1000 and mc6000 drives on sim://lustbus?factory=..."
        );
        assert_eq!(
            p("lustbus", FactoryBus::Mixed, "tmd*2").unwrap_err(),
            "`tmd*2`: tmd drives cannot be on a mixed LUSTBUS; put them on sim://tmd?factory=N"
        );
        assert_eq!(
            p("ecs", FactoryBus::OneFamily, "ecs*1").unwrap_err(),
            ECS_REFUSAL
        );
        assert_eq!(
            p("mc6000", FactoryBus::OneFamily, "servo*2").unwrap_err(),
            "`servo*2`: unknown drive family `servo`; use mc6000, mc7000, vf1000 or tmd"
        );
        assert_eq!(
            p("mc6000", FactoryBus::OneFamily, "20,11").unwrap_err(),
            "31 factory drives; one bus holds at most 30"
        );
    }

    #[test]
    fn slots_print_and_parse_back() {
        for s in [
            DriveSlot::Port {
                family: Family::Mc6000,
                address: 5,
            },
            DriveSlot::Factory {
                family: Family::Tmd,
                n: 2,
            },
        ] {
            assert_eq!(DriveSlot::parse(&s.to_string()), Some(s.clone()));
        }
        assert_eq!(
            DriveSlot::Factory {
                family: Family::Vf1000,
                n: 3
            }
            .to_string(),
            "vf1000#3"
        );
        assert_eq!(DriveSlot::parse("mc6000#0"), None);
        assert_eq!(DriveSlot::parse("x@1"), None);
    }

    #[test]
    fn the_bench_holds_the_first_waiting_factory_drive() {
        let v = |factory, address, assigned| BenchView {
            factory,
            address,
            factory_address: Some(1),
            assigned,
        };
        assert_eq!(
            bench_pick(&[v(false, 1, false), v(true, 1, false)]),
            Some(1)
        );
        assert_eq!(bench_pick(&[v(true, 5, false), v(true, 1, false)]), Some(1));
        // given the factory address itself: off the bench
        assert_eq!(bench_pick(&[v(true, 1, true), v(true, 1, false)]), Some(1));
        assert_eq!(bench_pick(&[v(true, 5, false), v(true, 1, true)]), None);
    }
}
