//! The manifest reader's buses (module docs of [`super`]): each bus's
//! port parsed (an opaque port checked by its registered opener, which
//! puts the manifest's drives on it), its kind fitting the protocol, the
//! drives a simulated port holds against the manifest's, its rate given
//! once, then the bus built.

use std::collections::BTreeMap;
use std::ops::Range;

use driveset_link::{PortShape, PortSpec};
use driveset_schema::{Family, Schema};

use super::{RawBus, Reader};
use crate::line::manifest::{Bus, BusProtocol, Drive, ManifestFinding};

impl Reader<'_> {
    /// Every bus whose name, port, protocol and rate hold.
    pub(super) fn buses(&mut self, raw_buses: &[RawBus], drives: &[Drive]) -> Vec<Bus> {
        raw_buses
            .iter()
            .enumerate()
            .filter_map(|(i, b)| self.bus(i, b, drives))
            .collect()
    }

    /// Bus `b` (index `i`; `drives`: the manifest's drives that hold).
    fn bus(&mut self, i: usize, b: &RawBus, drives: &[Drive]) -> Option<Bus> {
        let (Some((bname, _)), Some((port_text, pspan)), Some(protocol)) =
            (&b.name, &b.port, b.protocol)
        else {
            return None;
        };
        let (spec, shape) = self.port(i, port_text, pspan, drives)?;
        if !self.port_fits(&spec, shape.as_ref(), protocol, port_text, pspan) {
            return None;
        }
        if let Some(sim) = &shape {
            self.check_sim_drives(sim, port_text, drives, i, bname, pspan);
        }
        let (rate, spec) = self.rate(b, protocol, spec, port_text)?;
        if let Some((_, span)) = &b.transfer_baud
            && protocol != BusProtocol::Lustbus
        {
            self.push(
                "unknown-key",
                span,
                format!("a {protocol} bus has no `transfer_baud`"),
                "only MC6000/7000 servos on a LUSTBUS bus switch their rate online (lustbus-protocol.txt §11.5); remove it",
            );
        }
        let port_name = match (&spec, &shape) {
            (PortSpec::Sim(o), Some(_)) => self
                .openers
                .get(&o.scheme)
                .and_then(|op| op.check(o).ok())
                .map_or_else(|| spec.to_string(), |sh| sh.name),
            _ => spec.to_string(),
        };
        Some(Bus {
            name: bname.clone(),
            port_text: port_text.clone(),
            port: spec,
            port_name,
            protocol,
            rate,
            transfer_baud: b.transfer_baud.as_ref().map(|t| t.0),
            families: Vec::new(),
            location: self.loc(&b.span),
            rate_location: b
                .baud
                .as_ref()
                .map(|x| x.1.clone())
                .or_else(|| b.port.as_ref().map(|x| x.1.clone()))
                .map(|span| self.loc(&span)),
        })
    }

    /// The bus's port parsed; a port of an opener (`sim://`) checked by it,
    /// with what it holds.
    fn port(
        &mut self,
        i: usize,
        port_text: &str,
        pspan: &Range<usize>,
        drives: &[Drive],
    ) -> Option<(PortSpec, Option<PortShape>)> {
        let mut spec = match PortSpec::parse(port_text) {
            Ok(s) => s,
            Err(e) => {
                self.push(
                    "bad-port",
                    pspan,
                    format!("port `{port_text}`: {e}"),
                    "use the common port syntax: /dev/ttyUSB0?baud=19200, tcp://host:4001, slcan:///dev/ttyACM0, can://can0, sim://FAMILY",
                );
                return None;
            }
        };
        // A port of an opener (`sim://`): the opener checks it and says
        // what it holds; without drives it takes the manifest's.
        let mut shape: Option<PortShape> = None;
        if let PortSpec::Sim(o) = &spec {
            let checked = match self.openers.get(&o.scheme) {
                None => Err(format!(
                    "no opener for {}:// ports is registered; this program cannot open simulated buses",
                    o.scheme
                )),
                Some(opener) => {
                    let here: Vec<(&str, u8)> = drives
                        .iter()
                        .filter(|d| d.bus_index == i)
                        .map(|d| (d.schema.family.name(), d.address))
                        .collect();
                    let filled = opener.with_drives(o, &here);
                    opener
                        .check(&filled)
                        .map(|sh| (sh, filled))
                        .map_err(|e| e.to_string())
                }
            };
            match checked {
                Ok((sh, filled)) => {
                    spec = PortSpec::Sim(filled);
                    shape = Some(sh);
                }
                Err(e) => {
                    self.push(
                        "bad-port",
                        pspan,
                        format!("port `{port_text}`: {e}"),
                        "use the common port syntax: /dev/ttyUSB0?baud=19200, tcp://host:4001, slcan:///dev/ttyACM0, can://can0, sim://FAMILY",
                    );
                    return None;
                }
            }
        }
        Some((spec, shape))
    }

    /// Whether the port's kind (CAN or character line) fits the protocol.
    fn port_fits(
        &mut self,
        spec: &PortSpec,
        shape: Option<&PortShape>,
        protocol: BusProtocol,
        port_text: &str,
        pspan: &Range<usize>,
    ) -> bool {
        let port_can = shape.as_ref().map_or_else(|| spec.is_can(), |sh| sh.frames);
        if port_can != (protocol == BusProtocol::CanSdo) {
            self.push(
                "bad-port",
                pspan,
                format!(
                    "port `{port_text}` is a {} port, but the bus protocol is {protocol}",
                    if port_can { "CAN" } else { "character line" }
                ),
                "CAN buses need a CAN port (slcan://, can://, sim://ecs); LUSTBUS and LECOM need a serial or TCP port",
            );
            return false;
        }
        true
    }

    /// The drives a simulated port holds against the manifest's drives of
    /// bus `bname` (index `i`).
    fn check_sim_drives(
        &mut self,
        sim: &PortShape,
        port_text: &str,
        drives: &[Drive],
        i: usize,
        bname: &str,
        pspan: &Range<usize>,
    ) {
        if port_has_rate(port_text, "factory") {
            // factory-fresh drives share the factory address until
            // `commission --assign` / `replace` give them theirs: the
            // port must hold enough drives of each family
            self.check_factory_port(sim, drives, i, bname, pspan);
        } else {
            let on_bus = &sim.drives;
            for d in drives.iter().filter(|d| d.bus_index == i) {
                // The family the simulated bus has at the drive's address.
                let at = on_bus.iter().find(|(_, a)| *a == d.address);
                if let Some((fam, _)) = at
                    && !sim_family_matches(&fam.to_ascii_lowercase(), &d.schema)
                {
                    let (what, fix) = if sim.mixed {
                        (
                            format!("has a `{fam}` drive at address {}", d.address),
                            "on sim://lustbus give the address under the set's family (mc6000= or vf1000=)",
                        )
                    } else {
                        (
                            format!("holds `{fam}` drives"),
                            "a simulated bus holds one family (sim://lustbus?mc6000=..&vf1000=.. mixes LUSTBUS families); put the drive on a bus of its family",
                        )
                    };
                    let f = ManifestFinding::new(
                        "set-family",
                        d.location.clone(),
                        format!(
                            "drive `{}` has a `{}` set, but simulated bus `{bname}` {what}",
                            d.name, d.schema.id
                        ),
                        fix,
                    );
                    self.findings.push(f);
                }
                if at.is_none() {
                    self.push(
                        "unknown-bus",
                        pspan,
                        format!(
                            "drive `{}` is at address {}, which simulated bus `{bname}` does not have",
                            d.name, d.address
                        ),
                        if sim.mixed {
                            "add the address under its family (mc6000= / vf1000=), or write sim://lustbus without them to simulate the manifest's drives"
                        } else {
                            "add the address to addresses=, or leave addresses= out to simulate the manifest's drives"
                        },
                    );
                }
            }
        }
    }

    /// The bus's rate, given once (by key or in the port), and its port
    /// running at it.
    fn rate(
        &mut self,
        b: &RawBus,
        protocol: BusProtocol,
        mut spec: PortSpec,
        port_text: &str,
    ) -> Option<(u32, PortSpec)> {
        // rate
        let (given, key) = if protocol == BusProtocol::CanSdo {
            (b.bitrate.clone(), "bitrate")
        } else {
            (b.baud.clone(), "baud")
        };
        let wrong = if protocol == BusProtocol::CanSdo {
            &b.baud
        } else {
            &b.bitrate
        };
        if let Some((_, span)) = wrong {
            self.push(
                "unknown-key",
                span,
                format!(
                    "a {protocol} bus has no `{}`",
                    if key == "baud" { "bitrate" } else { "baud" }
                ),
                &format!("use `{key}`"),
            );
        }
        let port_rate = if protocol == BusProtocol::CanSdo {
            spec.can_bitrate()
        } else {
            spec.line_baud()
        };
        let rate = match (given, port_rate) {
            (Some((g, span)), Some(p)) if g != p && port_has_rate(port_text, key) => {
                self.push(
                    "rate-mismatch",
                    &span,
                    format!("{key} = {g}, but port `{port_text}` says {p}"),
                    "give the rate in one place",
                );
                return None;
            }
            (Some((g, _)), _) => {
                spec = self.set_rate(spec, g);
                g
            }
            (None, Some(p)) => p,
            (None, None) => 0,
        };
        Some((rate, spec))
    }

    /// `spec` running at `rate` (an opener's port through its opener:
    /// [`driveset_link::Openers::at_rate`]).
    fn set_rate(&self, spec: PortSpec, rate: u32) -> PortSpec {
        self.openers.at_rate(&spec, rate)
    }

    /// A `sim://` port with `factory=` drives: every family the manifest
    /// puts on bus `bname` (index `bi`) has at least as many drives on it.
    fn check_factory_port(
        &mut self,
        sim: &driveset_link::PortShape,
        drives: &[Drive],
        bi: usize,
        bname: &str,
        pspan: &Range<usize>,
    ) {
        let mut want: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for d in drives.iter().filter(|d| d.bus_index == bi) {
            want.entry(d.schema.family.name())
                .or_default()
                .push(d.name.as_str());
        }
        for (family, names) in want {
            let have = sim
                .drives
                .iter()
                .filter(|(f, _)| {
                    driveset_schema::Family::parse(&f.to_ascii_lowercase())
                        .is_ok_and(|x| x.name() == family)
                })
                .count();
            if names.len() > have {
                self.push(
                    "set-family",
                    pspan,
                    format!(
                        "simulated bus `{bname}` holds {have} factory-fresh {family} drive(s), but the manifest puts {} on it ({})",
                        names.len(),
                        names.join(", ")
                    ),
                    "give factory= one drive per manifest drive of the family, e.g. factory=mc6000*4,vf1000*3",
                );
            }
        }
    }
}

fn port_has_rate(port: &str, key: &str) -> bool {
    port.contains(&format!("{key}="))
}

/// Whether the family a simulated port names at an address (`fam`, as the
/// port spells it) is `schema`'s: the descriptor reads the name
/// ([`Family::from_port_name`]).
fn sim_family_matches(fam: &str, schema: &Schema) -> bool {
    Family::from_port_name(fam) == Some(schema.family)
}
