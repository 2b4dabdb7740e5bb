//! Owns the `sim://` port's query: its keys (the drives' addresses, a mixed
//! LUSTBUS's per-family keys, [`OPTION_KEYS`]), their checks and messages,
//! the port's canonical form ([`SimSpec`]), and the simulator's
//! [`PortOpener`] ([`SimOpener`]), which a program registers so that
//! `driveset_link::open_with` opens `sim://` ports in-process.
//!
//! `driveset-link` parses a `sim://` port only as far as scheme, path and
//! `key=value` items ([`OpaqueSpec`]); everything below is the simulator's.
//!
//! | key | value |
//! | --- | --- |
//! | `addresses` | drive addresses, `1,2,3` (not on `sim://lustbus`) |
//! | `mc6000`, `mc7000`, `vf1000` | a mixed LUSTBUS's drives per family ([`MIXED_LUSTBUS`]) |
//! | `baud` | the 7E1 line rate (one of `driveset_link::spec::ALLOWED_BAUDS`) |
//! | `bitrate` | the CAN bit rate |
//! | `factory` | factory-fresh drives: `3` (one-family bus), `mc6000*4,vf1000*3` ([`crate::factory`]; not on `sim://ecs`) |
//! | `bench` | `true`: the service bench, one factory drive on the bus per open ([`crate::factory`]) |
//! | `c0001`, `describe`, `faults`, `keypad`, `layout`, `seed`, `state`, `types` | [`OPTION_KEYS`], see [`crate::open`] |

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use driveset_link::spec::{ALLOWED_BAUDS, ALLOWED_BITRATES, take_number};
use driveset_link::{
    Link, LinkError, OpaqueSpec, OpenOptions, PortOpener, PortShape, PortSpec, PortSpecError,
    PortSpecErrorKind, VirtualClock,
};

use crate::factory::{FactoryBus, factory_text, parse_factory};
use crate::log::EventLog;
use crate::open::{SimConfig, SimOpenError, is_can, open_sim_with, parse_family};

/// Simulator options besides the drives, `baud` and `bitrate`, passed on to
/// [`SimConfig::from_spec`] as text (`seed` must be a whole number).
pub const OPTION_KEYS: &[&str] = &[
    "c0001", "describe", "dir", "faults", "file", "keypad", "layout", "refuse", "seed", "state",
    "types",
];

/// The keys of one run, not of the simulated bus: they are not part of
/// its bus id, and [`SimSpec::without_run_keys`] drops them.
pub const RUN_KEYS: &[&str] = &["faults", "seed"];

/// The bus name of a twin bus: `sim://twin?file=NAME.twin.toml` (one
/// twin) or `sim://twin?dir=DIR` (every `*.twin.toml` of DIR on one bus by
/// address), [`crate::twin`].
pub const TWIN_BUS: &str = "twin";

/// Every key a `sim://` port takes.
pub const KEYS: &[&str] = &[
    "addresses",
    "baud",
    "bench",
    "bitrate",
    "c0001",
    "describe",
    "dir",
    "factory",
    "faults",
    "file",
    "keypad",
    "layout",
    "mc6000",
    "mc7000",
    "refuse",
    "seed",
    "state",
    "types",
    "vf1000",
];

/// The bus name of a simulated LUSTBUS that holds drives of several
/// families: `sim://lustbus?mc6000=1,2&vf1000=5` (LUSTBUS protocol section
/// 1, joint operation of inverters and servocontrollers).
pub const MIXED_LUSTBUS: &str = "lustbus";

/// The per-family address keys of [`MIXED_LUSTBUS`]: the LUSTBUS families.
pub const FAMILY_KEYS: &[&str] = &["mc6000", "mc7000", "vf1000"];

/// A checked `sim://FAMILY?addresses=...` port (simulated drives of one
/// family), or a `sim://lustbus?mc6000=...&vf1000=...` port (a LUSTBUS
/// holding drives of several families, [`MIXED_LUSTBUS`]).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct SimSpec {
    /// Drive family (schema name), e.g. `lust-vf1000`, or `lustbus` for a
    /// mixed LUSTBUS.
    pub family: String,
    /// Bus addresses of the simulated drives, in the order given (empty on
    /// a mixed bus: see [`SimSpec::families`]).
    pub addresses: Vec<u8>,
    /// A mixed bus's drives: per family key ([`FAMILY_KEYS`]) the
    /// addresses, in the order given. Empty on a single-family bus.
    pub families: BTreeMap<String, Vec<u8>>,
    /// Factory-fresh drives (`factory=`, [`crate::factory`]): one family
    /// name per drive, in port order, after the drives named by address.
    pub factory: Vec<String>,
    /// The service bench (`bench=true`, [`crate::factory`]).
    pub bench: bool,
    /// Line rate for serial families.
    pub baud: Option<u32>,
    /// Bit rate for CAN families.
    pub bitrate: Option<u32>,
    /// Further simulator options ([`OPTION_KEYS`]), by key.
    pub options: BTreeMap<String, String>,
}

impl SimSpec {
    /// Parse a `sim://` port string; errors name `input` as given.
    pub fn parse(input: &str) -> Result<SimSpec, PortSpecError> {
        let err = |kind| PortSpecError {
            input: input.to_string(),
            kind,
        };
        match PortSpec::parse(input)? {
            PortSpec::Sim(o) if o.scheme == "sim" => from_opaque(&o).map_err(err),
            _ => Err(err(PortSpecErrorKind::UnknownScheme {
                scheme: input.split("://").next().unwrap_or(input).to_string(),
            })),
        }
    }

    /// Check the opaque port `driveset-link` parsed.
    pub fn from_opaque(spec: &OpaqueSpec) -> Result<SimSpec, PortSpecError> {
        from_opaque(spec).map_err(|kind| PortSpecError {
            input: spec.to_string(),
            kind,
        })
    }

    /// Whether this is a twin bus (`sim://twin?file=` / `?dir=`).
    pub fn is_twin(&self) -> bool {
        self.family.eq_ignore_ascii_case(TWIN_BUS)
    }

    /// Whether this is a data-sheet bus (`sim://eds?file=`, [`crate::eds`]).
    pub fn is_eds(&self) -> bool {
        self.family.eq_ignore_ascii_case(crate::eds::EDS_BUS)
    }

    /// Whether this is a mixed bus (`sim://lustbus?mc6000=...`, also
    /// `sim://lustbus?factory=...`).
    pub fn is_mixed(&self) -> bool {
        !self.families.is_empty() || self.family.eq_ignore_ascii_case(MIXED_LUSTBUS)
    }

    /// Every simulated drive as (family as given, address): the per-family
    /// keys' drives on a mixed bus, else `family` at each of `addresses`.
    pub fn drives(&self) -> Vec<(&str, u8)> {
        if self.is_mixed() {
            self.families
                .iter()
                .flat_map(|(f, list)| list.iter().map(move |&a| (f.as_str(), a)))
                .collect()
        } else {
            self.addresses
                .iter()
                .map(|&a| (self.family.as_str(), a))
                .collect()
        }
    }

    /// Every simulated drive's address.
    pub fn all_addresses(&self) -> Vec<u8> {
        self.drives().into_iter().map(|(_, a)| a).collect()
    }

    /// Whether the port names any drive itself (by address or as a
    /// factory drive): a command's `--address` then adds none.
    pub fn names_drives(&self) -> bool {
        !self.addresses.is_empty() || self.is_mixed() || !self.factory.is_empty()
    }

    /// The factory drives as (family as given, factory address), in port
    /// order ([`crate::factory::factory_address`]).
    pub fn factory_drives(&self) -> Vec<(&str, u8)> {
        self.factory
            .iter()
            .map(|f| {
                let a = parse_family(f)
                    .ok()
                    .and_then(crate::factory::factory_address)
                    .unwrap_or(1);
                (f.as_str(), a)
            })
            .collect()
    }

    /// The port as reports and journals name it: the canonical form, a
    /// `state=` file made absolute (`driveset_link::bus_id::canonical_file`),
    /// so that the name a journal records reaches the same simulated
    /// drives from any directory (`driveset recover J` needs no `--port`).
    pub fn name(&self) -> String {
        let mut s = self.clone();
        if let Some(f) = s.options.get_mut("state") {
            *f = driveset_link::bus_id::canonical_file(std::path::Path::new(f.as_str()));
        }
        s.to_string()
    }

    /// The same simulated bus without the keys that belong to one run
    /// ([`RUN_KEYS`]: the faults it injects and their seed): what a later
    /// command (`driveset recover` of a journal the faults cut) opens to
    /// reach the drives again, not cut again at the same telegram.
    pub fn without_run_keys(&self) -> SimSpec {
        let mut s = self.clone();
        for k in RUN_KEYS {
            s.options.remove(*k);
        }
        s
    }

    /// The opaque port `driveset-link` carries (what [`SimSpec::from_opaque`]
    /// reads back).
    pub fn to_opaque(&self) -> OpaqueSpec {
        match PortSpec::parse(&self.to_string()) {
            Ok(PortSpec::Sim(o)) => o,
            // The canonical form is a valid opaque port by construction.
            _ => OpaqueSpec {
                scheme: "sim".into(),
                path: self.family.clone(),
                query: BTreeMap::new(),
            },
        }
    }
}

/// Writes the canonical form: defaults not spelled out, options in a fixed
/// order (`addresses` or the per-family keys alphabetically, `factory`,
/// `bench`, `baud`, `bitrate`, then the rest alphabetically).
impl fmt::Display for SimSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "sim://{}", self.family)?;
        let mut items: Vec<(String, String)> = Vec::new();
        let list = |l: &[u8]| l.iter().map(u8::to_string).collect::<Vec<_>>().join(",");
        if !self.is_mixed() && !self.addresses.is_empty() {
            items.push(("addresses".into(), list(&self.addresses)));
        }
        for (key, l) in &self.families {
            items.push((key.clone(), list(l)));
        }
        if !self.factory.is_empty() {
            let bus = FactoryBus::of_path(&self.family);
            items.push(("factory".into(), factory_text(bus, &self.factory)));
        }
        if self.bench {
            items.push(("bench".into(), "true".into()));
        }
        if let Some(b) = self.baud {
            items.push(("baud".into(), b.to_string()));
        }
        if let Some(b) = self.bitrate {
            items.push(("bitrate".into(), b.to_string()));
        }
        for (key, value) in &self.options {
            items.push((key.clone(), value.clone()));
        }
        for (i, (k, v)) in items.iter().enumerate() {
            write!(f, "{}{k}={v}", if i == 0 { '?' } else { '&' })?;
        }
        Ok(())
    }
}

/// The family a `factory=` item names, if it names one.
fn family_named(name: &str) -> Option<driveset_schema::Family> {
    parse_family(name).ok()
}

fn from_opaque(spec: &OpaqueSpec) -> Result<SimSpec, PortSpecErrorKind> {
    const EXAMPLE: &str = "sim://lust-vf1000?addresses=1,2,3";
    let family = spec.path.as_str();
    if family.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "sim",
            what: "a drive family",
            example: EXAMPLE,
        });
    }
    if !family
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_'))
    {
        return Err(PortSpecErrorKind::BadFamily {
            family: family.into(),
        });
    }
    if let Some(key) = spec.query.keys().find(|k| !KEYS.contains(&k.as_str())) {
        return Err(PortSpecErrorKind::UnknownOption {
            key: key.clone(),
            scheme: "sim://",
            allowed: KEYS,
        });
    }
    let twin = family.eq_ignore_ascii_case(TWIN_BUS);
    let sources = ["file", "dir"]
        .iter()
        .filter(|k| spec.query.contains_key(**k))
        .count();
    if twin && sources != 1 {
        return Err(PortSpecErrorKind::Missing {
            scheme: "sim",
            what: "exactly one of file= (a twin) or dir= (a directory of twins)",
            example: "sim://twin?file=axis-1.twin.toml",
        });
    }
    let eds = family.eq_ignore_ascii_case(crate::eds::EDS_BUS);
    if eds && !spec.query.contains_key("file") {
        return Err(PortSpecErrorKind::Missing {
            scheme: "sim",
            what: "file= (the device's EDS or DCF)",
            example: "sim://eds?file=DEVICE.eds&addresses=1",
        });
    }
    if !twin
        && let Some(key) = ["file", "dir"]
            .iter()
            .find(|k| spec.query.contains_key(**k) && !(eds && **k == "file"))
    {
        return Err(PortSpecErrorKind::BadValue {
            key: key.to_string(),
            value: spec.query[*key].clone(),
            reason: "file= and dir= name twins; use sim://twin?file=NAME.twin.toml".into(),
        });
    }
    let mut map = spec.query.clone();
    let mut families = BTreeMap::new();
    for key in FAMILY_KEYS {
        if let Some(list) = map.remove(*key) {
            families.insert(key.to_string(), list);
        }
    }
    let mixed = family.eq_ignore_ascii_case(MIXED_LUSTBUS);
    let factory = match map.remove("factory") {
        None => Vec::new(),
        Some(value) => {
            let bad = |reason: String| PortSpecErrorKind::BadValue {
                key: "factory".into(),
                value: value.clone(),
                reason,
            };
            if twin {
                return Err(bad(
                    "a twin bus holds its twins only; put factory drives on sim://FAMILY?factory=N"
                        .into(),
                ));
            }
            if !mixed && parse_family(family).is_ok_and(|f| f == driveset_schema::Family::Ecs) {
                return Err(bad(crate::factory::ECS_REFUSAL.into()));
            }
            parse_factory(family, FactoryBus::of_path(family), &value, family_named).map_err(bad)?
        }
    };
    let bench = match map.remove("bench") {
        None => false,
        Some(value) => {
            let bad = |reason: &str| PortSpecErrorKind::BadValue {
                key: "bench".into(),
                value: value.clone(),
                reason: reason.into(),
            };
            let on = match value.as_str() {
                "true" | "1" | "yes" => true,
                "false" | "0" | "no" => false,
                _ => return Err(bad("use true or false")),
            };
            if on && factory.is_empty() {
                return Err(bad(
                    "the service bench connects factory-fresh drives one at a time; give them with factory=, e.g. sim://mc6000?factory=3&bench=true",
                ));
            }
            on
        }
    };
    let mut seen = Vec::new();
    let mut address_list = |list: &str| -> Result<Vec<u8>, PortSpecErrorKind> {
        let mut out = Vec::new();
        for item in list.split(',') {
            let address = item
                .trim()
                .parse::<u8>()
                .map_err(|_| PortSpecErrorKind::BadAddress { value: item.into() })?;
            if seen.contains(&address) {
                return Err(PortSpecErrorKind::DuplicateAddress { address });
            }
            seen.push(address);
            out.push(address);
        }
        Ok(out)
    };
    let mut addresses = Vec::new();
    let mut per_family = BTreeMap::new();
    if mixed {
        if map.contains_key("addresses") {
            return Err(PortSpecErrorKind::MixedBus {
                reason: format!(
                    "sim://{family} takes the addresses per family ({}=...), not addresses=; e.g. sim://lustbus?mc6000=1,2&vf1000=5",
                    FAMILY_KEYS.join("=..., ")
                ),
            });
        }
        if families.is_empty() && factory.is_empty() {
            return Err(PortSpecErrorKind::Missing {
                scheme: "sim",
                what: "the drives per family (mc6000=, mc7000=, vf1000=, or factory=) on a mixed LUSTBUS",
                example: "sim://lustbus?mc6000=1,2&vf1000=5",
            });
        }
        for (key, list) in &families {
            per_family.insert(key.clone(), address_list(list)?);
        }
    } else {
        if let Some(key) = families.keys().next() {
            return Err(PortSpecErrorKind::MixedBus {
                reason: format!(
                    "`{key}=` (drives per family) is for a mixed LUSTBUS, sim://lustbus?{key}=...; on sim://{family} give addresses="
                ),
            });
        }
        // Without addresses= the bus holds no drive yet: a command that
        // names one address (`pull --address 3`) simulates one drive there.
        if let Some(list) = map.remove("addresses") {
            addresses = address_list(&list)?;
        }
    }
    let baud = match take_number(&mut map, "baud")? {
        Some(baud) if !ALLOWED_BAUDS.contains(&baud) => {
            return Err(PortSpecErrorKind::UnsupportedBaud { baud });
        }
        other => other,
    };
    let bitrate = match take_number(&mut map, "bitrate")? {
        Some(bitrate) if !ALLOWED_BITRATES.contains(&bitrate) => {
            return Err(PortSpecErrorKind::UnsupportedBitrate { bitrate });
        }
        other => other,
    };
    if let Some(seed) = map.get("seed")
        && seed.parse::<u64>().is_err()
    {
        return Err(PortSpecErrorKind::BadValue {
            key: "seed".into(),
            value: seed.clone(),
            reason: "not a whole number in 0..=18446744073709551615".into(),
        });
    }
    Ok(SimSpec {
        family: family.into(),
        addresses,
        families: per_family,
        factory,
        bench,
        baud,
        bitrate,
        options: map,
    })
}

/// The simulator's [`PortOpener`] for `sim://`: opens the simulated bus in
/// virtual time (each port on a clock of its own). Its own options, which
/// are not part of the port string: a state file for every bus it opens
/// (used when the port gives no `state=`).
#[derive(Debug, Clone, Default)]
pub struct SimOpener {
    /// Where the drives' state persists when the port names no `state=`
    /// (else `DRIVESET_SIM_STATE_DIR`, see [`crate::open::STATE_DIR_ENV`]).
    pub state: Option<PathBuf>,
}

impl SimOpener {
    /// The settings of `spec` (this opener's state file applied).
    pub fn config(&self, spec: &SimSpec) -> Result<SimConfig, SimOpenError> {
        let mut config = SimConfig::from_spec(spec)?;
        if !spec.options.contains_key("state")
            && let Some(s) = &self.state
        {
            config.state = Some(s.clone());
        }
        Ok(config)
    }

    /// The simulated bus `spec` describes, named as its port
    /// ([`SimSpec::name`]), in virtual time on a clock of its own, without
    /// an event log: what a one-drive command's session opens as any port.
    pub fn open_bus(&self, spec: &SimSpec) -> Result<crate::open::SimLink, SimOpenError> {
        open_sim_with(
            &self.config(spec)?,
            &driveset_link::VirtualClock::new(),
            &spec.name(),
            EventLog::off(),
        )
    }

    /// The bus `port` reaches, before it is opened: a simulated bus with a
    /// state file is that file's bus ([`SimConfig::bus_id`]); one without
    /// lives in the process that opens it (`None`), as does a port that
    /// does not parse.
    pub fn bus_before_open(&self, port: &str) -> Option<String> {
        let config = self.config(&SimSpec::parse(port).ok()?).ok()?;
        config.state.is_some().then(|| config.bus_id())
    }
}

/// The twins a twin port names (`file=` or `dir=`), loaded.
pub fn twins_of(spec: &SimSpec) -> Result<Vec<crate::twin::Twin>, SimOpenError> {
    let twin = |e: crate::twin::TwinError| SimOpenError::Twin(e.to_string());
    match (spec.options.get("file"), spec.options.get("dir")) {
        (Some(f), _) => Ok(vec![
            crate::twin::load_file(std::path::Path::new(f)).map_err(twin)?,
        ]),
        (None, Some(d)) => crate::twin::load_dir(std::path::Path::new(d)).map_err(twin),
        (None, None) => Err(SimOpenError::Twin(
            "a twin port names file=NAME.twin.toml or dir=DIR".into(),
        )),
    }
}

impl PortOpener for SimOpener {
    fn scheme(&self) -> &str {
        "sim"
    }

    fn check(&self, spec: &OpaqueSpec) -> Result<PortShape, PortSpecError> {
        let sim = SimSpec::from_opaque(spec)?;
        if sim.is_twin() {
            let twins = twins_of(&sim).map_err(|e| PortSpecError {
                input: spec.to_string(),
                kind: PortSpecErrorKind::BadValue {
                    key: if sim.options.contains_key("file") {
                        "file"
                    } else {
                        "dir"
                    }
                    .into(),
                    value: sim
                        .options
                        .get("file")
                        .or(sim.options.get("dir"))
                        .cloned()
                        .unwrap_or_default(),
                    reason: e.to_string(),
                },
            })?;
            return Ok(PortShape {
                frames: twins.first().is_some_and(|t| is_can(t.family)),
                drives: twins
                    .iter()
                    .map(|t| (t.family.name().to_string(), t.address))
                    .collect(),
                mixed: twins.iter().any(|t| t.family != twins[0].family),
                name: sim.name(),
            });
        }
        let frames = sim.is_eds()
            || parse_family(sim.drives().first().map_or(&*sim.family, |d| d.0))
                .map(is_can)
                .unwrap_or(false);
        Ok(PortShape {
            frames,
            drives: sim
                .drives()
                .into_iter()
                .chain(sim.factory_drives())
                .map(|(f, a)| (f.to_string(), a))
                .collect(),
            mixed: sim.is_mixed(),
            name: sim.name(),
        })
    }

    fn with_drives(&self, spec: &OpaqueSpec, drives: &[(&str, u8)]) -> OpaqueSpec {
        let list = |mut a: Vec<u8>| {
            a.sort_unstable();
            a.iter().map(u8::to_string).collect::<Vec<_>>().join(",")
        };
        let mut out = spec.clone();
        if spec.query.contains_key("factory") {
            // the port names its drives (factory-fresh ones): keep it
            return out;
        }
        if spec.path.eq_ignore_ascii_case(MIXED_LUSTBUS) {
            if FAMILY_KEYS.iter().any(|k| spec.query.contains_key(*k)) {
                return out;
            }
            // each drive under the key of its family
            let mut per: BTreeMap<&str, Vec<u8>> = BTreeMap::new();
            for &(family, address) in drives {
                let key = match parse_family(family) {
                    Ok(driveset_schema::Family::Vf1000) => "vf1000",
                    _ => "mc6000",
                };
                per.entry(key).or_default().push(address);
            }
            for (key, addresses) in per {
                out.query.insert(key.to_string(), list(addresses));
            }
        } else if !spec.query.contains_key("addresses") && !drives.is_empty() {
            out.query.insert(
                "addresses".to_string(),
                list(drives.iter().map(|d| d.1).collect()),
            );
        }
        out
    }

    fn without_run_keys(&self, spec: &OpaqueSpec) -> OpaqueSpec {
        SimSpec::from_opaque(spec)
            .map_or_else(|_| spec.clone(), |s| s.without_run_keys().to_opaque())
    }

    fn with_rate(&self, spec: &OpaqueSpec, rate: u32) -> OpaqueSpec {
        let Ok(mut sim) = SimSpec::from_opaque(spec) else {
            return spec.clone();
        };
        if parse_family(&sim.family).is_ok_and(is_can) {
            sim.bitrate = Some(rate);
        } else {
            sim.baud = Some(rate);
        }
        sim.to_opaque()
    }

    fn open(&self, spec: &OpaqueSpec, _options: &OpenOptions) -> Result<Link, LinkError> {
        let bad = |detail: String| LinkError::Unsupported {
            port: spec.to_string(),
            what: detail,
        };
        let sim = SimSpec::from_opaque(spec).map_err(|e| bad(e.to_string()))?;
        let config = self.config(&sim).map_err(|e| bad(e.to_string()))?;
        let clock = VirtualClock::new();
        open_sim_with(&config, &clock, &sim.name(), EventLog::off())
            .map(|l| l.link())
            .map_err(|e| bad(e.to_string()))
    }
}

#[cfg(test)]
mod tests;
