//! Opening `sim://` ports: owns [`open_sim`] (a [`SimSpec`] to a simulated
//! bus in virtual time, the way the engine commands use
//! `--port sim://mc6000?addresses=1,2`), [`SimConfig`] (the checked
//! settings of a simulated bus, shared with `driveset sim`, which serves the
//! same drives in real time), [`SimLink`] (the open bus: a byte link or a
//! frame link plus access to the drives) and the state dump format
//! ([`StateDump`], shared with `driveset sim --dump`).
//!
//! # Families and addresses
//!
//! `FAMILY` is a [`Family`] name (`mc6000`, `mc7000`, `vf1000`, `tmd`,
//! `ecs`) or a schema id naming one (`lust-mc6000`, `lust-vf1000`,
//! `lenze-tmd`, `lenze-ecs`, the fixtures' `fictional-...-demo`).
//! Addresses: LUSTBUS 1..=30 (section 4.2), LECOM 1..=99 except the group
//! addresses 10, 20, ... 90 (§4c), CAN node ids 1..=127.
//!
//! # Mixed LUSTBUS
//!
//! `sim://lustbus?mc6000=1,2&vf1000=5,6` puts MC6000/7000 servocontrollers
//! and VF1000 inverters on one simulated line, as the LUSTBUS protocol
//! allows (section 1, joint operation of inverters and servocontrollers):
//! one address space 1..=30 across the families. Its state file (from
//! [`STATE_DIR_ENV`]) is `DIR/sim-lustbus.json`, its dump's `family` is
//! `lustbus`, each drive entry carries its own family.
//!
//! # Factory-fresh drives and the bench
//!
//! `factory=3` (one family) or `factory=mc6000*4,vf1000*3` (on
//! `sim://lustbus`) adds factory-fresh drives after those of `addresses=`;
//! `bench=true` holds only the first one still waiting for its address on
//! the bus at each open ([`crate::factory`], which owns the factory address,
//! FICTIONAL 1 on LUSTBUS, the rate and the bench rule). Their drives may
//! share an address ([`ByteLine::sharing_addresses`]).
//!
//! # Options
//!
//! - `seed=N`: every random choice of the drives (reaction times) and of
//!   the fault generator (unless the plan has its own `seed=`) comes from
//!   it; default 0. The same seed and the same host traffic give the same
//!   bytes at the same virtual instants.
//! - `faults=PLAN`: the [`FaultPlan`] grammar (`crate::faults`).
//! - `c0001=N` (Tmd, 0..=11): C0001 as set at the drive's keypad before
//!   LECOM use (lecom-ab-tmd-manual.txt §4e). Default 0, Table 1's factory
//!   setting, in which LECOM may only read (and write C0040, C0043, C0248,
//!   C0249); `c0001=2` lets LECOM program the drive, `c0001=3` also control
//!   it (§4f).
//! - `refuse=KEY,...` (`11`, `17.2`): every drive of the bus refuses to
//!   read these codes, as a drive does that hides a code in its operating
//!   state: LUSTBUS `ADR NAK` to the ENQUIRY, LECOM `STX code EOT` to the
//!   RECEIVE (8.H), CAN SDO abort 0x06010001 "attempt to read a write-only
//!   object" (DS301 table 22). Writes are not affected.
//! - `keypad=true|false`: LUSTBUS families with a KEYPAD attached (slower
//!   reactions, section 10). Not (yet) a key `driveset-link` accepts in a
//!   port string; [`SimConfig::keypad`] is set by `driveset sim --keypad`.
//! - `layout=52|43|42|34` and `types=driveset|table|C=TYPE,...`:
//!   MC6000/7000 drives send their parameter descriptions (section 11.2)
//!   in that layout and with those type characters (the readings errata
//!   L22 and L23 discuss; default 52 and driveset's characters), so that
//!   `schema pull` and the learning `pull` can be tested against each.
//! - `describe=N:ITEM[:ITEM...][;N:...]` (LUSTBUS): parameter `N`'s own
//!   description says another kind, type, range or unit than the fixture
//!   (`11:actual:binary8`, `100:min=2:max=5`, `134:unit=rpm`; grammar in
//!   [`crate::describe`]), the way a real drive may contradict the spec;
//!   the parameter itself behaves as the fixture says.
//! - `state=FILE`: load the drives' state from a dump at open if the file
//!   exists, save it back when the link is dropped (or on
//!   [`SimLink::save`]). `driveset-link`'s port parser does not accept this
//!   key yet; until it does, set the environment variable
//!   [`STATE_DIR_ENV`] (`DRIVESET_SIM_STATE_DIR=DIR`): every `sim://` bus
//!   then keeps its state in `DIR/sim-FAMILY.json` (`sim-lustbus.json` for
//!   a mixed LUSTBUS), so a sequence of CLI
//!   invocations (`upload`, then `diff --port`) sees the same drives.
//!
//! # State dumps
//!
//! JSON, one object:
//!
//! ```text
//! {"format":"driveset-sim-state 1","family":"mc6000","baud":9600,
//!  "drives":[{"family":"mc6000","address":1,"schema":"fictional-mc6000-demo",
//!             "fingerprint":"sha256:...","canonical":"driveset-canonical 1\nschema ...\n...",
//!             "slot":"mc6000@1"}]}
//! ```
//!
//! `canonical` is the drive's whole state in the canonical form
//! (docs/file-formats.md), `fingerprint` its sha256. `baud` / `bitrate` /
//! `telegrams` are informative (written by `driveset sim`, ignored on
//! load). A drive's `rate` is written only when it runs at a rate its
//! 81-SBAUD does not say (an MC6000 left at a `--transfer-baud` rate,
//! LUSTBUS 11.5) and is restored on load, so the drive stays at that rate
//! between commands as a powered drive does (`identify`, `scan` and
//! `recover` then find it by the rate search, LUSTBUS 5.1).
//!
//! Each entry also carries its drive's `slot` ([`DriveSlot`]: `mc6000@5`,
//! the family and the address the port names; `mc6000#2`, the port's second
//! factory MC6000) and `assigned` when its address code was written over
//! the bus (the bench moves on). Loading matches a drive by its slot, so a
//! drive whose 82-SADDR / C0009 was written is found again at its new
//! address; an entry without a slot (an older dump) or of a slot this port
//! does not have matches by family and address. A drive of the bus
//! missing from the file keeps its factory state, a drive in the file that
//! is not on the bus is ignored (and not written back); the drives the
//! bench holds off the line are written back as they were.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use driveset_link::VirtualClock;
use driveset_link::spec::{ALLOWED_BAUDS, ALLOWED_BITRATES, DEFAULT_BAUD, DEFAULT_BITRATE};
use driveset_link::{ByteLink, CanFrame, Clock, FrameLink, Instant, Link, LinkError};
use driveset_proto::can::{AbortCode, NodeId};
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::canonical::{CodeKey, RawValue, ResolvedSet};
use serde::{Deserialize, Serialize};

use crate::bus::{BusError, ByteLine, SimByteBus, list};
use crate::can_bus::{FrameLine, SimCanBus};
use crate::catalog::Family;
use crate::drive::{ByteDrive, FrameDrive, ReadRefusal};
use crate::ecs::EcsDrive;
use crate::factory::{BenchView, DriveSlot, FACTORY_BAUD, bench_pick, factory_address};
use crate::faults::{FaultParseError, FaultPlan};
use crate::log::EventLog;
use crate::lustbus_drive::LustOptions;
use crate::mc6000::Mc6000;
use crate::rng::SimRng;
use crate::tmd::{TmdDrive, TmdOptions};
use crate::vf1000::Vf1000;

/// The environment variable naming a directory where every `sim://` bus
/// keeps its state (`DIR/sim-FAMILY.json`) when the port gives no
/// `state=`.
pub const STATE_DIR_ENV: &str = "DRIVESET_SIM_STATE_DIR";

/// The `format` value of a state dump.
pub const STATE_FORMAT: &str = "driveset-sim-state 1";

/// The option keys [`SimConfig::from_spec`] understands ([`crate::port`]
/// owns the `sim://` port's keys).
pub use crate::port::OPTION_KEYS;
pub use crate::port::{MIXED_LUSTBUS as SIM_MIXED_LUSTBUS, SimSpec};

/// Why a simulated bus could not be opened, loaded or saved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimOpenError {
    /// A family the simulator does not have.
    #[error("{0}")]
    Family(String),
    /// No address given.
    #[error("no drive address given; name at least one (e.g. addresses=1)")]
    NoAddresses,
    /// An address the family's bus does not allow.
    #[error("{family}: address {address} is not allowed: {rule}")]
    BadAddress {
        /// The family.
        family: &'static str,
        /// The address.
        address: u8,
        /// The rule.
        rule: &'static str,
    },
    /// The same address twice.
    #[error("address {0} is given twice; every drive needs its own address")]
    DuplicateAddress(u8),
    /// A mixed bus with a family that cannot share a LUSTBUS line.
    #[error(
        "{family} drives cannot be on a mixed LUSTBUS (sim://lustbus holds mc6000 / mc7000 and vf1000 drives only); put them on a sim://{family} bus of their own"
    )]
    NotLustbus {
        /// The family.
        family: &'static str,
    },
    /// A [`SimConfig`] whose per-drive families do not match its addresses.
    #[error("{families} drive families for {addresses} addresses; give one family per address")]
    FamilyCount {
        /// How many families.
        families: usize,
        /// How many addresses.
        addresses: usize,
    },
    /// A line rate the simulated line does not run at.
    #[error("{baud} baud is not supported; a 7E1 line runs at one of {allowed} baud")]
    BadBaud {
        /// The rate.
        baud: u32,
        /// The allowed rates.
        allowed: String,
    },
    /// A CAN bit rate the simulated bus does not run at.
    #[error("CAN bit rate {bitrate} is not supported; use one of {allowed} bit/s")]
    BadBitrate {
        /// The rate.
        bitrate: u32,
        /// The allowed rates.
        allowed: String,
    },
    /// An option with a bad value.
    #[error("`{key}={value}`: {reason}")]
    BadOption {
        /// The key.
        key: String,
        /// The value.
        value: String,
        /// What it should be.
        reason: String,
    },
    /// An option the simulator does not know.
    #[error("unknown simulator option `{key}`; known: {}", OPTION_KEYS.join(", "))]
    UnknownOption {
        /// The key.
        key: String,
    },
    /// The fault plan does not parse.
    #[error("faults: {0}")]
    Faults(#[from] FaultParseError),
    /// The bus refused its configuration.
    #[error(transparent)]
    Bus(#[from] BusError),
    /// A drive model could not be built.
    #[error("cannot build the simulated {family} drive at address {address}: {reason}")]
    Drive {
        /// The family.
        family: &'static str,
        /// The address.
        address: u8,
        /// Why.
        reason: String,
    },
    /// A twin file or directory that cannot be served ([`crate::twin`]).
    #[error("{0}")]
    Twin(String),
    /// Factory-fresh drives the bus cannot hold, or a bench without them
    /// ([`crate::factory`]).
    #[error("{0}")]
    Factory(String),
    /// The state file could not be read or written.
    #[error("simulator state file {}: cannot {op}: {source}", path.display())]
    StateIo {
        /// The file.
        path: PathBuf,
        /// What was being done.
        op: &'static str,
        /// The cause.
        #[source]
        source: io::Error,
    },
    /// The state file is not a usable dump.
    #[error(
        "simulator state file {}: {reason}; delete it to start from factory state",
        path.display()
    )]
    StateFormat {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// Parse a family as `sim://FAMILY` or `--family` gives it: a [`Family`]
/// name or a schema id naming one (`lust-mc6000`, `lenze_ecs`,
/// `fictional-vf1000-demo`).
pub fn parse_family(name: &str) -> Result<Family, SimOpenError> {
    let lower = name.trim().to_ascii_lowercase().replace('_', "-");
    let mut short = lower.as_str();
    for prefix in ["fictional-", "lust-", "lenze-"] {
        short = short.strip_prefix(prefix).unwrap_or(short);
    }
    short = short.strip_suffix("-demo").unwrap_or(short);
    Family::parse(short).map_err(|_| {
        SimOpenError::Family(format!(
            "unknown drive family `{name}`: use one of mc6000, vf1000, tmd, ecs (or a schema id such as lust-vf1000)"
        ))
    })
}

/// Whether `family` runs on CAN (frames) rather than a character line.
pub fn is_can(family: Family) -> bool {
    family == Family::Ecs
}

/// Check that `address` is a valid drive address on `family`'s bus.
pub fn check_address(family: Family, address: u8) -> Result<(), SimOpenError> {
    let (ok, rule) = match family {
        Family::Mc6000 | Family::Vf1000 => (
            (1..=30).contains(&address),
            "LUSTBUS drive addresses are 1..=30 (section 4.2; 0 is the group address)",
        ),
        Family::Tmd => (
            (1..=99).contains(&address) && !address.is_multiple_of(10),
            "LECOM station addresses are 1..=99 except the group addresses 10, 20, ... 90 (§4c)",
        ),
        Family::Ecs => ((1..=127).contains(&address), "CAN node ids are 1..=127"),
    };
    if ok {
        Ok(())
    } else {
        Err(SimOpenError::BadAddress {
            family: family.name(),
            address,
            rule,
        })
    }
}

/// The checked settings of a simulated bus: which drives, at which rate,
/// with which seed, faults and state file.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// The drive family; on a mixed LUSTBUS the family of the first drive
    /// (see [`SimConfig::drive_families`]).
    pub family: Family,
    /// The drives' addresses (node ids on CAN), in the order given.
    pub addresses: Vec<u8>,
    /// Empty: every drive is of `family`, the bus is named after it.
    /// Otherwise a mixed LUSTBUS (`sim://lustbus`): the family of each drive,
    /// in the order of `addresses`.
    pub drive_families: Vec<Family>,
    /// Line rate (LUSTBUS / LECOM families).
    pub baud: u32,
    /// CAN bit rate (ECS).
    pub bitrate: u32,
    /// The run's seed.
    pub seed: u64,
    /// The faults to inject.
    pub faults: FaultPlan,
    /// LUSTBUS: a KEYPAD is attached (slower reactions, section 10).
    pub keypad: bool,
    /// Where the drives' state is loaded from and saved to.
    pub state: Option<PathBuf>,
    /// MC6000/7000: the layout the drives send their parameter
    /// descriptions in (`layout=52|43|42|34`, errata L22).
    pub description_layout: McLayout,
    /// MC6000/7000: the type characters of their descriptions
    /// (`types=driveset|table|C=TYPE,...`, errata L23).
    pub type_chars: McTypeChars,
    /// Tmd: C0001 as set at the keypad (§4e); `None` = Table 1's 0.
    pub c0001: Option<u8>,
    /// LUSTBUS: parameters whose description says something other than
    /// the fixture (`describe=`, [`crate::describe`]).
    pub describe: BTreeMap<u32, crate::describe::DescribeAs>,
    /// A twin bus (`sim://twin?file=F`, `?dir=DIR`, [`crate::twin`]): one
    /// twin per drive, in the order of `addresses`; each drive is built with
    /// its twin's state and holds its captured values. Empty otherwise.
    pub twins: Vec<crate::twin::Twin>,
    /// Codes every drive refuses to read (`refuse=`, module docs).
    pub refuse: Vec<CodeKey>,
    /// Factory-fresh drives (`factory=`, [`crate::factory`]), in port
    /// order after the drives of `addresses`: each at its family's factory
    /// address and rate, with its whole factory table.
    pub factory: Vec<Family>,
    /// The service bench (`bench=true`, [`crate::factory`]): at each open
    /// the bus holds only the first factory drive still waiting for its
    /// address; once none waits, every drive.
    pub bench: bool,
    /// A mixed LUSTBUS (`sim://lustbus`) even when `drive_families` is
    /// empty (a bus of factory drives only).
    pub mixed_bus: bool,
}

impl SimConfig {
    /// `family` at `addresses`, default rates, seed 0, no faults, no
    /// KEYPAD, no state file. Not yet checked: see [`SimConfig::check`].
    pub fn new(family: Family, addresses: Vec<u8>) -> Self {
        SimConfig {
            family,
            addresses,
            drive_families: Vec::new(),
            baud: DEFAULT_BAUD,
            bitrate: DEFAULT_BITRATE,
            seed: 0,
            faults: FaultPlan::none(),
            keypad: false,
            state: None,
            description_layout: McLayout::Hex52,
            type_chars: McTypeChars::Driveset,
            c0001: None,
            describe: BTreeMap::new(),
            twins: Vec::new(),
            refuse: Vec::new(),
            factory: Vec::new(),
            bench: false,
            mixed_bus: false,
        }
    }

    /// The bus of `twins` ([`crate::twin`]): their families and addresses,
    /// the first twin's rate; not yet checked.
    pub fn of_twins(twins: Vec<crate::twin::Twin>) -> Result<Self, SimOpenError> {
        crate::twin::check_one_bus(&twins).map_err(|e| SimOpenError::Twin(e.to_string()))?;
        let drives: Vec<(Family, u8)> = twins.iter().map(|t| (t.family, t.address)).collect();
        let mixed = drives.iter().any(|d| d.0 != drives[0].0);
        let mut config = if mixed {
            SimConfig::mixed(&drives)
        } else {
            SimConfig::new(
                drives.first().map_or(Family::Mc6000, |d| d.0),
                drives.iter().map(|d| d.1).collect(),
            )
        };
        if let Some(rate) = twins.first().and_then(|t| t.rate) {
            if is_can(config.family) {
                config.bitrate = rate;
            } else {
                config.baud = rate;
            }
        }
        config.twins = twins;
        Ok(config)
    }

    /// The twin of the drive at `address`, on a twin bus.
    pub fn twin_at(&self, address: u8) -> Option<&crate::twin::Twin> {
        self.twins.iter().find(|t| t.address == address)
    }

    /// A mixed LUSTBUS (`sim://lustbus`): `drives` as (family, address),
    /// in bus order; otherwise as [`SimConfig::new`]. Not yet checked.
    pub fn mixed(drives: &[(Family, u8)]) -> Self {
        let family = drives.first().map_or(Family::Mc6000, |d| d.0);
        let mut config = SimConfig::new(family, drives.iter().map(|d| d.1).collect());
        config.drive_families = drives.iter().map(|d| d.0).collect();
        config.mixed_bus = true;
        config
    }

    /// Whether this is a mixed LUSTBUS.
    pub fn is_mixed(&self) -> bool {
        self.mixed_bus || !self.drive_families.is_empty()
    }

    /// The bus's name in state files and dumps: the family, or `lustbus`
    /// for a mixed LUSTBUS.
    pub fn bus_name(&self) -> &'static str {
        if self.is_mixed() {
            SIM_MIXED_LUSTBUS
        } else {
            self.family.name()
        }
    }

    /// Every drive the port names by address as (family, address), in bus
    /// order (the factory drives: [`SimConfig::all_drives`]).
    pub fn drives(&self) -> Vec<(Family, u8)> {
        self.addresses
            .iter()
            .enumerate()
            .map(|(i, &a)| (*self.drive_families.get(i).unwrap_or(&self.family), a))
            .collect()
    }

    /// Every drive of the port as (family, address it starts at, slot), in
    /// port order: the drives of `addresses`, then the factory drives at
    /// their factory address ([`crate::factory`]).
    pub fn all_drives(&self) -> Vec<(Family, u8, DriveSlot)> {
        let mut out: Vec<(Family, u8, DriveSlot)> = self
            .drives()
            .into_iter()
            .map(|(family, address)| (family, address, DriveSlot::Port { family, address }))
            .collect();
        let mut counts: BTreeMap<&'static str, usize> = BTreeMap::new();
        for &family in &self.factory {
            let n = counts.entry(family.name()).or_insert(0);
            *n += 1;
            let address = factory_address(family).unwrap_or(1);
            out.push((family, address, DriveSlot::Factory { family, n: *n }));
        }
        out
    }

    /// Every drive's slot, in port order ([`SimConfig::all_drives`]).
    pub fn slots(&self) -> Vec<DriveSlot> {
        self.all_drives().into_iter().map(|d| d.2).collect()
    }

    /// The simulated bus's identity ([`driveset_link::bus_id`]): `sim:` and
    /// the bus name ([`SimConfig::bus_name`]), plus `@` and the canonical
    /// state file when the drives' state persists in one. Seed, faults,
    /// keypad and rates are not part of it: `sim://mc6000?addresses=1&faults=..`
    /// and `sim://mc6000?addresses=1` with one state file are one bus.
    pub fn bus_id(&self) -> String {
        match &self.state {
            Some(p) => format!(
                "sim:{}@{}",
                self.bus_name(),
                driveset_link::bus_id::canonical_file(p)
            ),
            None => format!("sim:{}", self.bus_name()),
        }
    }

    /// The settings a `sim://` port gives; without `state=`, the state
    /// file comes from [`STATE_DIR_ENV`] if that is set.
    pub fn from_spec(spec: &SimSpec) -> Result<Self, SimOpenError> {
        let mut config = if spec.is_twin() {
            SimConfig::of_twins(crate::port::twins_of(spec)?)?
        } else if spec.is_mixed() {
            let mut drives = Vec::new();
            for (name, address) in spec.drives() {
                drives.push((parse_family(name)?, address));
            }
            SimConfig::mixed(&drives)
        } else {
            SimConfig::new(parse_family(&spec.family)?, spec.addresses.clone())
        };
        for name in &spec.factory {
            config.factory.push(parse_family(name)?);
        }
        if config.addresses.is_empty()
            && config.is_mixed()
            && let Some(&f) = config.factory.first()
        {
            config.family = f;
        }
        config.bench = spec.bench;
        config.baud = spec.baud.unwrap_or(DEFAULT_BAUD);
        config.bitrate = spec.bitrate.unwrap_or(DEFAULT_BITRATE);
        for (key, value) in &spec.options {
            let bad = |reason: &str| SimOpenError::BadOption {
                key: key.clone(),
                value: value.clone(),
                reason: reason.into(),
            };
            match key.as_str() {
                "seed" => {
                    config.seed = value
                        .parse()
                        .map_err(|_| bad("not a whole number in 0..=18446744073709551615"))?;
                }
                "faults" => config.faults = FaultPlan::parse(value)?,
                "keypad" => {
                    config.keypad = match value.as_str() {
                        "true" | "1" | "yes" => true,
                        "false" | "0" | "no" => false,
                        _ => return Err(bad("use true or false")),
                    }
                }
                "state" => config.state = Some(PathBuf::from(value)),
                "file" | "dir" => {}
                "layout" => {
                    config.description_layout = McLayout::from_name(value)
                        .ok_or_else(|| bad("use 52, 43, 42 or 34 (errata L22)"))?;
                }
                "types" => config.type_chars = McTypeChars::parse(value).map_err(|e| bad(&e))?,
                "describe" => {
                    config.describe = crate::describe::parse(value).map_err(|e| bad(&e))?
                }
                "c0001" => {
                    config.c0001 = Some(
                        value
                            .parse::<u8>()
                            .ok()
                            .filter(|v| *v <= 11)
                            .ok_or_else(|| bad("C0001 takes 0..=11 (Table 1; §4e)"))?,
                    );
                }
                "refuse" => {
                    config.refuse = value
                        .split(',')
                        .map(|k| crate::twin::parse_key(k.trim()))
                        .collect::<Option<Vec<_>>>()
                        .ok_or_else(|| {
                            bad("a list of codes: NUMBER or NUMBER.SUBCODE, `,` between")
                        })?;
                }
                _ => return Err(SimOpenError::UnknownOption { key: key.clone() }),
            }
        }
        if config.state.is_none() {
            config.state = state_file_for(config.bus_name());
        }
        config.check()?;
        Ok(config)
    }

    /// Check addresses (per family, no duplicates) and the rate.
    pub fn check(&self) -> Result<(), SimOpenError> {
        if self.addresses.is_empty() && self.factory.is_empty() {
            return Err(SimOpenError::NoAddresses);
        }
        for &f in &self.factory {
            if factory_address(f).is_none() {
                return Err(SimOpenError::Factory(crate::factory::ECS_REFUSAL.into()));
            }
            if self.is_mixed() && !matches!(f, Family::Mc6000 | Family::Vf1000) {
                return Err(SimOpenError::NotLustbus { family: f.name() });
            }
            if !self.is_mixed() && f != self.family {
                return Err(SimOpenError::Factory(format!(
                    "a factory-fresh {} drive cannot be on a sim://{} bus; put both families on sim://lustbus?factory=...",
                    f.name(),
                    self.family.name()
                )));
            }
        }
        if self.bench && self.factory.is_empty() {
            return Err(SimOpenError::Factory(
                "bench=true: the service bench connects factory-fresh drives one at a time; give them with factory=, e.g. sim://mc6000?factory=3&bench=true".into(),
            ));
        }
        if self.is_mixed() && self.drive_families.len() != self.addresses.len() {
            return Err(SimOpenError::FamilyCount {
                families: self.drive_families.len(),
                addresses: self.addresses.len(),
            });
        }
        for (i, (family, a)) in self.drives().into_iter().enumerate() {
            if self.is_mixed() && !matches!(family, Family::Mc6000 | Family::Vf1000) {
                return Err(SimOpenError::NotLustbus {
                    family: family.name(),
                });
            }
            check_address(family, a)?;
            if self.addresses[..i].contains(&a) {
                return Err(SimOpenError::DuplicateAddress(a));
            }
        }
        if is_can(self.family) {
            if !ALLOWED_BITRATES.contains(&self.bitrate) {
                return Err(SimOpenError::BadBitrate {
                    bitrate: self.bitrate,
                    allowed: list(ALLOWED_BITRATES),
                });
            }
        } else if !ALLOWED_BAUDS.contains(&self.baud) {
            return Err(SimOpenError::BadBaud {
                baud: self.baud,
                allowed: list(ALLOWED_BAUDS),
            });
        }
        Ok(())
    }

    /// The seed of the drive at `address`: derived from the run's seed so
    /// two drives do not draw the same reaction times.
    fn drive_seed(&self, address: u8) -> u64 {
        SimRng::derive(self.seed, 0x51_0000 + u64::from(address)).next_u64()
    }

    /// The drives of a LUSTBUS / LECOM family, at factory state.
    pub fn byte_drives(&self) -> Result<Vec<Box<dyn ByteDrive>>, SimOpenError> {
        self.check()?;
        let mut drives: Vec<Box<dyn ByteDrive>> = Vec::new();
        let mut factory_seen = 0usize;
        for (i, (family, address, slot)) in self.all_drives().into_iter().enumerate() {
            // Factory drives share an address: each draws from its place.
            let (seed, twin) = if slot.is_factory() {
                let seed = SimRng::derive(self.seed, 0x46_0000 + i as u64).next_u64();
                (seed, None)
            } else {
                (self.drive_seed(address), self.twin_at(address))
            };
            let mut lust = LustOptions::new(address).seed(seed).keypad(self.keypad);
            lust.description_layout = twin
                .and_then(|t| t.layout)
                .unwrap_or(self.description_layout);
            lust.type_chars = twin
                .and_then(|t| t.types.clone())
                .unwrap_or_else(|| self.type_chars.clone());
            lust.describe = self.describe.clone();
            lust.reaction = twin.and_then(|t| t.reaction_time());
            let mut tmd = TmdOptions {
                seed,
                control_source: twin.and_then(|t| t.c0001).or(self.c0001).unwrap_or(0),
                ..TmdOptions::at(address)
            };
            if let Some(r) = twin.and_then(|t| t.reaction_time()) {
                tmd.reaction = r;
            }
            if slot.is_factory() {
                let k = factory_seen;
                factory_seen += 1;
                let r = crate::factory::factory_reaction(family, self.keypad, k);
                lust.reaction = Some(r);
                tmd.reaction = r;
            }
            let built: Result<Box<dyn ByteDrive>, String> = match family {
                Family::Mc6000 => Mc6000::new(lust).map(|d| Box::new(d) as Box<dyn ByteDrive>),
                Family::Vf1000 => Vf1000::new(lust).map(|d| Box::new(d) as Box<dyn ByteDrive>),
                Family::Tmd => TmdDrive::new(tmd).map(|d| Box::new(d) as Box<dyn ByteDrive>),
                Family::Ecs => Err("ECS drives are on CAN, not on a character line".into()),
            };
            let mut drive = built.map_err(|reason| SimOpenError::Drive {
                family: family.name(),
                address,
                reason,
            })?;
            if let Some(t) = twin {
                t.apply_byte(drive.as_mut())
                    .map_err(|e| SimOpenError::Twin(e.to_string()))?;
            }
            let answer = match family {
                Family::Tmd => ReadRefusal::NoSuchCode,
                _ => ReadRefusal::Nak,
            };
            for k in &self.refuse {
                drive
                    .refuse_read(*k, answer)
                    .map_err(|reason| SimOpenError::Drive {
                        family: family.name(),
                        address,
                        reason,
                    })?;
            }
            drives.push(drive);
        }
        Ok(drives)
    }

    /// The nodes of a CAN family, at factory state.
    pub fn frame_drives(&self) -> Result<Vec<Box<dyn FrameDrive>>, SimOpenError> {
        self.check()?;
        let mut drives: Vec<Box<dyn FrameDrive>> = Vec::new();
        for &address in &self.addresses {
            let err = |reason: String| SimOpenError::Drive {
                family: self.family.name(),
                address,
                reason,
            };
            if self.family != Family::Ecs {
                return Err(err(format!(
                    "{} drives are on a character line, not on CAN",
                    self.family.name()
                )));
            }
            let node = NodeId::new(address).map_err(|_| err("not a node id 1..=127".into()))?;
            // EcsDrive derives its stream from the seed and the node id.
            let mut drive = EcsDrive::new(node, self.seed).map_err(err)?;
            if let Some(t) = self.twin_at(address) {
                if let Some(r) = t.reaction_time() {
                    drive = drive.with_reaction(r);
                }
                t.apply_frame(&mut drive)
                    .map_err(|e| SimOpenError::Twin(e.to_string()))?;
            }
            for k in &self.refuse {
                drive
                    .refuse_read(*k, ReadRefusal::SdoAbort(AbortCode::WRITE_ONLY.0))
                    .map_err(err)?;
            }
            drives.push(Box::new(drive));
        }
        Ok(drives)
    }

    /// The character line of a LUSTBUS / LECOM family with its drives
    /// (state loaded from [`SimConfig::state`] if the file exists), faults
    /// and `log`: the core `driveset sim` serves in real time. Which
    /// drives it holds: [`SimConfig::byte_line_drives`].
    pub fn byte_line(&self, log: EventLog) -> Result<ByteLine, SimOpenError> {
        self.byte_line_drives(log).map(|(line, _)| line)
    }

    /// [`SimConfig::byte_line`] and which of the port's drives it holds
    /// ([`LineDrives`]: with `bench=true` only the drive on the bench, the
    /// others kept aside with their state). A factory drive runs at the
    /// rate its rate code says (9600 from the factory), whatever rate the
    /// host opens the line at.
    pub fn byte_line_drives(&self, log: EventLog) -> Result<(ByteLine, LineDrives), SimOpenError> {
        let mut drives = self.byte_drives()?;
        let order = self.slots();
        if let Some(path) = &self.state {
            load_state_into(path, self.bus_name(), &mut drives, &order)?;
        }
        let pick = if self.bench {
            let views: Vec<BenchView> = drives
                .iter()
                .zip(&order)
                .map(|(d, slot)| BenchView {
                    factory: slot.is_factory(),
                    address: d.address(),
                    factory_address: factory_address(slot.family()),
                    assigned: d.address_assigned(),
                })
                .collect();
            bench_pick(&views)
        } else {
            None
        };
        let mut on_line = Vec::new();
        let mut slots = Vec::new();
        let mut detached = Vec::new();
        for (i, (d, slot)) in drives.into_iter().zip(order.iter().cloned()).enumerate() {
            if pick.is_none_or(|p| p == i) {
                on_line.push(d);
                slots.push(slot);
            } else {
                detached.push(entry_of(&d, Some(&slot)));
            }
        }
        let mut line = ByteLine::sharing_addresses(self.baud, on_line)?
            .with_faults(self.faults.clone(), self.seed)
            .with_log(log);
        for (j, slot) in slots.iter().enumerate() {
            let drive = &line.drives()[j];
            if slot.is_factory() && drive.active_rate().is_none() {
                let rate = drive.coded_rate().unwrap_or(FACTORY_BAUD);
                if ALLOWED_BAUDS.contains(&rate) {
                    line.set_drive_baud(j, rate);
                }
            }
        }
        Ok((
            line,
            LineDrives {
                slots,
                detached,
                order,
            },
        ))
    }

    /// The CAN bus of a CAN family, as [`SimConfig::byte_line`].
    pub fn frame_line(&self, log: EventLog) -> Result<FrameLine, SimOpenError> {
        self.frame_line_drives(log).map(|(line, _)| line)
    }

    /// [`SimConfig::frame_line`] and its drives' slots (no bench on CAN).
    pub fn frame_line_drives(
        &self,
        log: EventLog,
    ) -> Result<(FrameLine, LineDrives), SimOpenError> {
        let mut drives = self.frame_drives()?;
        let order = self.slots();
        if let Some(path) = &self.state {
            load_state_into(path, self.bus_name(), &mut drives, &order)?;
        }
        let line = FrameLine::new(self.bitrate, drives)?
            .with_faults(self.faults.clone(), self.seed)
            .with_log(log);
        Ok((
            line,
            LineDrives {
                slots: order.clone(),
                detached: Vec::new(),
                order,
            },
        ))
    }
}

/// Which of a port's drives a line holds, by slot ([`DriveSlot`]), and the
/// state of those it does not (the service bench, [`crate::factory`]):
/// what a state dump of the line is made of.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LineDrives {
    /// The slot of each drive on the line, in line order.
    pub slots: Vec<DriveSlot>,
    /// The drives off the line, with their state (`slot` set).
    pub detached: Vec<DriveDump>,
    /// Every slot of the port, in port order (the order of a dump).
    pub order: Vec<DriveSlot>,
}

impl LineDrives {
    fn dump<D: StateDrive>(&self, bus: &str, drives: &[D]) -> StateDump {
        let mut entries: Vec<DriveDump> = drives
            .iter()
            .enumerate()
            .map(|(j, d)| entry_of(d, self.slots.get(j)))
            .chain(self.detached.iter().cloned())
            .collect();
        let place = |e: &DriveDump| {
            e.slot
                .as_deref()
                .and_then(|s| self.order.iter().position(|o| o.to_string() == s))
                .unwrap_or(usize::MAX)
        };
        entries.sort_by_key(place);
        StateDump {
            format: STATE_FORMAT.into(),
            family: bus.into(),
            baud: None,
            bitrate: None,
            telegrams: None,
            drives: entries,
        }
    }

    /// The dump of `line` (named `bus`: a family or `lustbus`) and the
    /// drives off it, with rate and telegram count: what `driveset sim`
    /// writes to `--state` / `--dump`.
    pub fn byte_line_dump(&self, bus: &str, line: &ByteLine) -> StateDump {
        StateDump {
            baud: Some(line.baud()),
            telegrams: Some(line.telegrams()),
            ..self.dump(bus, line.drives())
        }
    }

    /// The dump of a CAN bus's nodes, as [`LineDrives::byte_line_dump`].
    pub fn frame_line_dump(&self, bus: &str, line: &FrameLine) -> StateDump {
        StateDump {
            bitrate: Some(line.bitrate()),
            telegrams: Some(line.telegrams()),
            ..self.dump(bus, line.drives())
        }
    }
}

/// The dump entry of `d`, in `slot`.
fn entry_of<D: StateDrive>(d: &D, slot: Option<&DriveSlot>) -> DriveDump {
    DriveDump {
        rate: d.dump_rate(),
        slot: slot.map(DriveSlot::to_string),
        assigned: d.dump_assigned(),
        ..DriveDump::new(d.dump_family(), d.dump_address(), &d.dump_state())
    }
}

/// The codes of a `refuse=` option (module docs): `11,17.2`.
pub fn parse_refuse(value: &str) -> Result<Vec<CodeKey>, String> {
    value
        .split(',')
        .map(|k| crate::twin::parse_key(k.trim()))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| "a list of codes: NUMBER or NUMBER.SUBCODE, `,` between".into())
}

/// `DIR/sim-FAMILY.json` if [`STATE_DIR_ENV`] is set and not empty.
pub fn state_file_from_env(family: Family) -> Option<PathBuf> {
    state_file_for(family.name())
}

/// `DIR/sim-BUS.json` (BUS a family name or `lustbus`) if
/// [`STATE_DIR_ENV`] is set and not empty.
fn state_file_for(bus: &str) -> Option<PathBuf> {
    let dir = std::env::var_os(STATE_DIR_ENV).filter(|d| !d.is_empty())?;
    Some(PathBuf::from(dir).join(format!("sim-{bus}.json")))
}

/// A state dump: every drive of one simulated bus (module docs).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateDump {
    /// [`STATE_FORMAT`].
    pub format: String,
    /// The bus's family ([`Family::name`]), or `lustbus` for a mixed
    /// LUSTBUS.
    pub family: String,
    /// The line rate (character lines), informative.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baud: Option<u32>,
    /// The bit rate (CAN), informative.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bitrate: Option<u32>,
    /// Host telegrams the bus saw in this run, informative.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub telegrams: Option<u64>,
    /// The drives, in bus order.
    pub drives: Vec<DriveDump>,
}

/// One drive in a [`StateDump`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriveDump {
    /// The drive's family.
    pub family: String,
    /// Its bus address (node id on CAN).
    pub address: u8,
    /// The schema its table comes from.
    pub schema: String,
    /// The fingerprint of `canonical`.
    pub fingerprint: String,
    /// Its whole state, canonical form.
    pub canonical: String,
    /// The rate the drive runs at, when its 81-SBAUD does not say it (an
    /// MC6000 left at a transfer rate, LUSTBUS 11.5): it stays there in
    /// the next command, as a powered drive does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate: Option<u32>,
    /// Its place in the port ([`DriveSlot`]: `mc6000@5`, `mc6000#2`): what
    /// loading matches it by, so that it is found again after its own
    /// address changed. Absent in dumps of older versions (matched by
    /// family and address).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slot: Option<String>,
    /// Its address code was written over the bus
    /// ([`ByteDrive::address_assigned`]; the bench moves on).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub assigned: bool,
}

impl DriveDump {
    /// The entry for a drive holding `state`.
    pub fn new(family: &str, address: u8, state: &ResolvedSet) -> Self {
        DriveDump {
            family: family.to_string(),
            address,
            schema: state.schema.clone(),
            fingerprint: state.fingerprint(),
            // the drive's memory, secrets included (a state file is as private as the drive)
            canonical: state.canonical_with_secrets(),
            rate: None,
            slot: None,
            assigned: false,
        }
    }
}

/// A drive whose state can be dumped and restored (both bus kinds).
trait StateDrive {
    fn dump_family(&self) -> &'static str;
    fn dump_address(&self) -> u8;
    fn dump_state(&self) -> ResolvedSet;
    fn restore(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String>;
    fn dump_rate(&self) -> Option<u32> {
        None
    }
    fn restore_rate(&mut self, baud: u32) {
        let _ = baud;
    }
    fn dump_assigned(&self) -> bool {
        false
    }
    fn restore_assigned(&mut self) {}
}

impl StateDrive for Box<dyn ByteDrive> {
    fn dump_family(&self) -> &'static str {
        self.family()
    }
    fn dump_address(&self) -> u8 {
        self.address()
    }
    fn dump_state(&self) -> ResolvedSet {
        self.state()
    }
    fn restore(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        self.poke(key, raw)
    }
    fn dump_rate(&self) -> Option<u32> {
        self.active_rate()
    }
    fn restore_rate(&mut self, baud: u32) {
        ByteDrive::restore_rate(self.as_mut(), baud);
    }
    fn dump_assigned(&self) -> bool {
        self.address_assigned()
    }
    fn restore_assigned(&mut self) {
        self.restore_address_assigned();
    }
}

impl StateDrive for Box<dyn FrameDrive> {
    fn dump_family(&self) -> &'static str {
        self.family()
    }
    fn dump_address(&self) -> u8 {
        self.node_id()
    }
    fn dump_state(&self) -> ResolvedSet {
        self.state()
    }
    fn restore(&mut self, key: CodeKey, raw: RawValue) -> Result<(), String> {
        self.poke(key, raw)
    }
}

fn dump_of<D: StateDrive>(bus: &str, drives: &[D]) -> StateDump {
    StateDump {
        format: STATE_FORMAT.into(),
        family: bus.into(),
        baud: None,
        bitrate: None,
        telegrams: None,
        drives: drives.iter().map(|d| entry_of(d, None)).collect(),
    }
}

/// The dump of a character line's drives, with rate and telegram count.
pub fn byte_line_dump(family: Family, line: &ByteLine) -> StateDump {
    named_byte_line_dump(family.name(), line)
}

/// [`byte_line_dump`] of a bus named `bus` (a family or `lustbus`).
fn named_byte_line_dump(bus: &str, line: &ByteLine) -> StateDump {
    StateDump {
        baud: Some(line.baud()),
        telegrams: Some(line.telegrams()),
        ..dump_of(bus, line.drives())
    }
}

/// The dump of a CAN bus's nodes, with bit rate and telegram count.
pub fn frame_line_dump(family: Family, line: &FrameLine) -> StateDump {
    StateDump {
        bitrate: Some(line.bitrate()),
        telegrams: Some(line.telegrams()),
        ..dump_of(family.name(), line.drives())
    }
}

impl StateDump {
    /// Read a dump file.
    pub fn read(path: &Path) -> Result<StateDump, SimOpenError> {
        use driveset_schema::input::{InputKind, read_input};
        let bytes = read_input(path, InputKind::SIM_STATE).map_err(|e| SimOpenError::StateIo {
            path: path.into(),
            op: "read it",
            source: io::Error::other(e.detail()),
        })?;
        let text = String::from_utf8_lossy(&bytes);
        let dump: StateDump =
            serde_json::from_str(&text).map_err(|e| SimOpenError::StateFormat {
                path: path.into(),
                reason: format!("not a simulator state dump ({e})"),
            })?;
        if dump.format != STATE_FORMAT {
            return Err(SimOpenError::StateFormat {
                path: path.into(),
                reason: format!(
                    "format `{}` is not `{STATE_FORMAT}` (written by another driveset version?)",
                    dump.format
                ),
            });
        }
        Ok(dump)
    }

    /// Write the dump as pretty JSON: to a temporary file (mode 0600) next
    /// to `path`, then renamed over it (a crash never leaves half a file).
    pub fn write(&self, path: &Path) -> Result<(), SimOpenError> {
        let io_err = |op, source| SimOpenError::StateIo {
            path: path.into(),
            op,
            source,
        };
        let mut text = serde_json::to_string_pretty(self)
            .map_err(|e| io_err("serialize it", io::Error::other(e)))?;
        text.push('\n');
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "state".into());
        let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
        // 0600: a drive's memory holds its passwords
        let mut opts = std::fs::OpenOptions::new();
        opts.write(true).create(true).truncate(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt as _;
            opts.mode(0o600);
        }
        opts.open(&tmp)
            .and_then(|mut f| io::Write::write_all(&mut f, text.as_bytes()))
            .map_err(|e| io_err("write it", e))?;
        std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            io_err("replace it", e)
        })
    }
}

/// Parse the canonical text of one drive back into values.
pub fn parse_canonical(text: &str) -> Result<(String, BTreeMap<CodeKey, RawValue>), String> {
    let mut lines = text.lines();
    if lines.next() != Some("driveset-canonical 1") {
        return Err("canonical text does not start with `driveset-canonical 1`".into());
    }
    let schema = lines
        .next()
        .and_then(|l| l.strip_prefix("schema "))
        .ok_or("canonical text has no `schema` line")?
        .to_string();
    let mut values = BTreeMap::new();
    for line in lines {
        let (code, value) = line
            .split_once(' ')
            .ok_or_else(|| format!("canonical line `{line}` is not `CODE VALUE`"))?;
        let bad = || format!("canonical line `{line}`: bad code");
        let digits = code.strip_prefix('C').unwrap_or(code);
        let key = match digits.split_once('/') {
            Some((n, s)) => {
                CodeKey::sub(n.parse().map_err(|_| bad())?, s.parse().map_err(|_| bad())?)
            }
            None => CodeKey::new(digits.parse().map_err(|_| bad())?),
        };
        let raw = if let Some(json) = value.strip_prefix('s') {
            RawValue::Text(
                serde_json::from_str(json)
                    .map_err(|e| format!("canonical line `{line}`: bad text ({e})"))?,
            )
        } else if let Some(hex) = value.strip_prefix('o') {
            let bytes = (0..hex.len())
                .step_by(2)
                .map(|i| {
                    hex.get(i..i + 2)
                        .and_then(|h| u8::from_str_radix(h, 16).ok())
                })
                .collect::<Option<Vec<u8>>>()
                .ok_or_else(|| format!("canonical line `{line}`: bad octets"))?;
            RawValue::Octets(bytes)
        } else {
            RawValue::Int(
                value
                    .parse()
                    .map_err(|_| format!("canonical line `{line}`: bad integer"))?,
            )
        };
        values.insert(key, raw);
    }
    Ok((schema, values))
}

/// Load the state file at `path` (if it exists) into `drives` of the bus
/// named `bus` (a family or `lustbus`).
fn load_state_into<D: StateDrive>(
    path: &Path,
    bus: &str,
    drives: &mut [D],
    slots: &[DriveSlot],
) -> Result<(), SimOpenError> {
    if !path.exists() {
        return Ok(());
    }
    let dump = StateDump::read(path)?;
    apply_dump(path, bus, &dump, drives, slots)
}

/// The entry of `dump` for the drive in `slot` now at `address`: the
/// entry of that slot; else (a dump of an older version, or of another
/// port of the same bus) an unused entry of the same family at that
/// address whose slot is none of this port's.
fn entry_for<'a>(
    dump: &'a StateDump,
    slot: &DriveSlot,
    address: u8,
    slots: &[String],
    used: &[usize],
) -> Option<(usize, &'a DriveDump)> {
    let own = slot.to_string();
    let family = slot.family().name();
    dump.drives
        .iter()
        .enumerate()
        .find(|(_, e)| e.slot.as_deref() == Some(own.as_str()))
        .or_else(|| {
            dump.drives.iter().enumerate().find(|(i, e)| {
                !used.contains(i)
                    && e.address == address
                    && bus_key(&e.family) == family
                    && e.slot.as_ref().is_none_or(|s| !slots.contains(s))
            })
        })
}

/// A family or bus name as dumps compare it (`lust-mc6000` is `mc6000`).
fn bus_key(name: &str) -> String {
    parse_family(name).map_or_else(|_| name.trim().to_ascii_lowercase(), |f| f.name().into())
}

fn apply_dump<D: StateDrive>(
    path: &Path,
    bus: &str,
    dump: &StateDump,
    drives: &mut [D],
    slots: &[DriveSlot],
) -> Result<(), SimOpenError> {
    let format_err = |reason: String| SimOpenError::StateFormat {
        path: path.into(),
        reason,
    };
    if bus_key(&dump.family) != bus_key(bus) {
        return Err(format_err(format!(
            "it holds {} drives, this bus has {bus} drives",
            dump.family
        )));
    }
    let slot_texts: Vec<String> = slots.iter().map(DriveSlot::to_string).collect();
    let mut used: Vec<usize> = Vec::new();
    for (i, drive) in drives.iter_mut().enumerate() {
        let address = drive.dump_address();
        let found = match slots.get(i) {
            Some(slot) => entry_for(dump, slot, address, &slot_texts, &used),
            None => {
                let family = bus_key(drive.dump_family());
                dump.drives
                    .iter()
                    .enumerate()
                    .find(|(_, e)| e.address == address && bus_key(&e.family) == family)
            }
        };
        let Some((at, entry)) = found else {
            continue;
        };
        used.push(at);
        let (schema, values) = parse_canonical(&entry.canonical)
            .map_err(|e| format_err(format!("drive {address}: {e}")))?;
        let current = drive.dump_state();
        if schema != current.schema {
            return Err(format_err(format!(
                "drive {address} was saved with schema `{schema}`, the simulator now uses `{}`",
                current.schema
            )));
        }
        // Poke what differs; codes derived from others (Tmd C0068, C0150)
        // refuse a poke and must come out equal once the rest is set.
        let mut refused = Vec::new();
        for (key, raw) in &values {
            if current.values.get(key) != Some(raw)
                && let Err(e) = drive.restore(*key, raw.clone())
            {
                refused.push((*key, e));
            }
        }
        if let Some(rate) = entry.rate {
            drive.restore_rate(rate);
        }
        if entry.assigned {
            drive.restore_assigned();
        }
        let now = drive.dump_state();
        if now.values != values {
            let differing: Vec<String> = values
                .keys()
                .chain(now.values.keys())
                .filter(|k| now.values.get(k) != values.get(k))
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .take(3)
                .map(|k| match refused.iter().find(|(r, _)| r == k) {
                    Some((_, e)) => e.clone(),
                    None => format!("{} differs after loading", k.canonical(now.code_style)),
                })
                .collect();
            return Err(format_err(format!(
                "drive {address}: its saved state cannot be restored ({})",
                differing.join("; ")
            )));
        }
    }
    Ok(())
}

/// The bus behind a [`SimLink`].
#[derive(Debug)]
pub enum SimBus {
    /// A character line (LUSTBUS, LECOM).
    Bytes(SimByteBus),
    /// A CAN bus.
    Frames(SimCanBus),
}

#[derive(Debug)]
struct Shared {
    bus: Mutex<SimBus>,
    /// The bus's family ([`SimConfig::family`]).
    family: Family,
    /// Which of the port's drives are on the line, by slot, and the
    /// state of those that are not.
    line: LineDrives,
    /// A family name, or `lustbus` for a mixed LUSTBUS.
    name: &'static str,
    state: Option<PathBuf>,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, SimBus> {
        self.bus.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn dump(&self) -> StateDump {
        match &*self.lock() {
            SimBus::Bytes(b) => self.line.byte_line_dump(self.name, b.line()),
            SimBus::Frames(b) => self.line.frame_line_dump(self.name, b.line()),
        }
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        if let Some(path) = &self.state
            && let Err(e) = self.dump().write(path)
        {
            // Nobody is left to return the error to.
            eprintln!("warning: {e}");
        }
    }
}

/// An open simulated bus in virtual time: the host side as a byte or frame
/// link ([`SimLink::link`], [`SimLink::byte_link`],
/// [`SimLink::frame_link`]; every handle drives the same bus), plus the
/// drives ([`SimLink::state`], [`SimLink::poke`], [`SimLink::dump`]).
///
/// With a state file, the drives' state is written back when the last of
/// the `SimLink` and its handles is dropped (a failure then is printed as
/// a warning on stderr), or at once with [`SimLink::save`].
#[derive(Debug, Clone)]
pub struct SimLink {
    shared: Arc<Shared>,
    clock: VirtualClock,
    port: String,
}

/// Open the simulated bus a `sim://` port names, on `clock`: drives of the
/// family at the addresses, seed and faults from the options, state from
/// `state=` or [`STATE_DIR_ENV`]. No event log.
pub fn open_sim(spec: &SimSpec, clock: &VirtualClock) -> Result<SimLink, SimOpenError> {
    let config = SimConfig::from_spec(spec)?;
    let port = spec.to_string();
    open_sim_with(&config, clock, &port, EventLog::off())
}

/// Open a simulated bus from checked settings, named `port`, logging to
/// `log`.
pub fn open_sim_with(
    config: &SimConfig,
    clock: &VirtualClock,
    port: &str,
    log: EventLog,
) -> Result<SimLink, SimOpenError> {
    config.check()?;
    let id = config.bus_id();
    let (bus, line) = if is_can(config.family) {
        let (frames, line) = config.frame_line_drives(log)?;
        (
            SimBus::Frames(
                SimCanBus::from_line(clock, frames)
                    .with_name(port)
                    .with_bus_id(id),
            ),
            line,
        )
    } else {
        let (bytes, line) = config.byte_line_drives(log)?;
        (
            SimBus::Bytes(
                SimByteBus::from_line(clock, bytes)
                    .with_name(port)
                    .with_bus_id(id),
            ),
            line,
        )
    };
    Ok(SimLink {
        shared: Arc::new(Shared {
            bus: Mutex::new(bus),
            family: config.family,
            line,
            name: config.bus_name(),
            state: config.state.clone(),
        }),
        clock: clock.clone(),
        port: port.to_string(),
    })
}

impl SimLink {
    /// The family of the drives; on a mixed LUSTBUS the family of the
    /// first drive (see [`SimLink::families`], [`SimLink::family_of`]).
    pub fn family(&self) -> Family {
        self.shared.family
    }

    /// Every family on the bus, each once, in bus order.
    pub fn families(&self) -> Vec<Family> {
        let mut out = Vec::new();
        for f in self.shared.line.slots.iter().map(DriveSlot::family) {
            if !out.contains(&f) {
                out.push(f);
            }
        }
        out
    }

    /// The family of the drive at `address` now (its own address code,
    /// which the host may have changed; the first such drive when several
    /// share it).
    pub fn family_of(&self, address: u8) -> Option<Family> {
        let j = self.index_of(address)?;
        self.shared.line.slots.get(j).map(DriveSlot::family)
    }

    /// The line index of the first drive at `address` now.
    fn index_of(&self, address: u8) -> Option<usize> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.drives().iter().position(|d| d.address() == address),
            SimBus::Frames(b) => b.drives().iter().position(|d| d.node_id() == address),
        })
    }

    /// The slots ([`DriveSlot`]) of the drives on the line, in line order
    /// (as [`SimLink::addresses`]).
    pub fn slots(&self) -> Vec<DriveSlot> {
        self.shared.line.slots.clone()
    }

    /// The slots of the port's drives the line does not hold (the service
    /// bench's waiting or finished drives, [`crate::factory`]); their
    /// state is in [`SimLink::dump`].
    pub fn detached(&self) -> Vec<DriveSlot> {
        self.shared
            .line
            .detached
            .iter()
            .filter_map(|d| d.slot.as_deref().and_then(DriveSlot::parse))
            .collect()
    }

    /// The address the drive in `slot` has now, if it is on the line.
    pub fn address_of(&self, slot: &DriveSlot) -> Option<u8> {
        let j = self.shared.line.slots.iter().position(|s| s == slot)?;
        self.addresses().get(j).copied()
    }

    /// The state of the drive in `slot`, if it is on the line.
    pub fn state_of(&self, slot: &DriveSlot) -> Option<ResolvedSet> {
        let j = self.shared.line.slots.iter().position(|s| s == slot)?;
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.drives().get(j).map(|d| d.state()),
            SimBus::Frames(b) => b.drives().get(j).map(|d| d.state()),
        })
    }

    /// Whether this is a mixed LUSTBUS (`sim://lustbus`).
    pub fn is_mixed(&self) -> bool {
        self.shared.name == SIM_MIXED_LUSTBUS
    }

    /// The bus's name in state files: a family name or `lustbus`.
    pub fn bus_name(&self) -> &'static str {
        self.shared.name
    }

    /// The port name (`sim://...`).
    pub fn port(&self) -> &str {
        &self.port
    }

    /// Whether this is a CAN bus (use [`SimLink::frame_link`]).
    pub fn is_can(&self) -> bool {
        is_can(self.family())
    }

    /// The virtual clock the bus runs on.
    pub fn clock(&self) -> &VirtualClock {
        &self.clock
    }

    /// The state file, if any.
    pub fn state_file(&self) -> Option<&Path> {
        self.shared.state.as_deref()
    }

    /// The host side as a byte link (`None` on CAN).
    pub fn byte_link(&self) -> Option<Box<dyn ByteLink>> {
        (!self.is_can()).then(|| Box::new(SimByteHandle(self.clone())) as Box<dyn ByteLink>)
    }

    /// The host side as a frame link (`None` on a character line).
    pub fn frame_link(&self) -> Option<Box<dyn FrameLink>> {
        self.is_can()
            .then(|| Box::new(SimFrameHandle(self.clone())) as Box<dyn FrameLink>)
    }

    /// The host side as `driveset-link` hands out real transports.
    pub fn link(&self) -> Link {
        if self.is_can() {
            Link::Frames(Box::new(SimFrameHandle(self.clone())))
        } else {
            Link::Bytes(Box::new(SimByteHandle(self.clone())))
        }
    }

    /// Work on the bus itself (drives, log, faults) under its lock.
    pub fn with_bus<R>(&self, f: impl FnOnce(&mut SimBus) -> R) -> R {
        f(&mut self.shared.lock())
    }

    /// The drives' addresses (node ids), in bus order.
    pub fn addresses(&self) -> Vec<u8> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.drives().iter().map(|d| d.address()).collect(),
            SimBus::Frames(b) => b.drives().iter().map(|d| d.node_id()).collect(),
        })
    }

    /// The state of the drive at `address`.
    pub fn state(&self, address: u8) -> Option<ResolvedSet> {
        self.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b
                .drives()
                .iter()
                .find(|d| d.address() == address)
                .map(|d| d.state()),
            SimBus::Frames(b) => b
                .drives()
                .iter()
                .find(|d| d.node_id() == address)
                .map(|d| d.state()),
        })
    }

    /// Set a value of the drive at `address` directly, bypassing the
    /// protocol (tests, drift demos).
    pub fn poke(&self, address: u8, key: CodeKey, raw: RawValue) -> Result<(), String> {
        self.with_bus(|bus| {
            let missing = || format!("no simulated drive at address {address}");
            match bus {
                SimBus::Bytes(b) => b.drive_mut(address).ok_or_else(missing)?.poke(key, raw),
                SimBus::Frames(b) => b.drive_mut(address).ok_or_else(missing)?.poke(key, raw),
            }
        })
    }

    /// Every drive's state (the `--dump` / state file content).
    pub fn dump(&self) -> StateDump {
        self.shared.dump()
    }

    /// Write the state file now. `Ok(false)` without a state file.
    pub fn save(&self) -> Result<bool, SimOpenError> {
        match &self.shared.state {
            Some(path) => self.dump().write(path).map(|()| true),
            None => Ok(false),
        }
    }

    /// Write the drives' state to `path` (any file, not the state file).
    pub fn save_to(&self, path: &Path) -> Result<(), SimOpenError> {
        self.dump().write(path)
    }
}

/// A [`SimLink`] as a [`ByteLink`].
#[derive(Debug)]
struct SimByteHandle(SimLink);

/// The error for a byte call on a CAN bus or the other way round (cannot
/// happen through [`SimLink`]'s constructors of handles).
fn wrong_kind(port: &str) -> LinkError {
    LinkError::Unsupported {
        port: port.into(),
        what: "the simulated bus is of the other kind (bytes / CAN frames)".into(),
    }
}

impl ByteLink for SimByteHandle {
    fn port(&self) -> &str {
        &self.0.port
    }
    fn bus_id(&self) -> String {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::bus_id(b),
            SimBus::Frames(b) => FrameLink::bus_id(b),
        })
    }
    fn baud(&self) -> u32 {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::baud(b),
            SimBus::Frames(_) => 0,
        })
    }
    fn clock(&self) -> &dyn Clock {
        &self.0.clock
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.send(bytes),
            SimBus::Frames(_) => Err(wrong_kind(&self.0.port)),
        })
    }
    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.recv(buf, deadline),
            SimBus::Frames(_) => Err(wrong_kind(&self.0.port)),
        })
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => b.discard_input(),
            SimBus::Frames(_) => Err(wrong_kind(&self.0.port)),
        })
    }
    fn flush(&mut self) -> Result<(), LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::flush(b),
            SimBus::Frames(_) => Err(wrong_kind(&self.0.port)),
        })
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::set_baud(b, baud),
            SimBus::Frames(_) => Err(wrong_kind(&self.0.port)),
        })
    }
}

/// A [`SimLink`] as a [`FrameLink`].
#[derive(Debug)]
struct SimFrameHandle(SimLink);

impl FrameLink for SimFrameHandle {
    fn port(&self) -> &str {
        &self.0.port
    }
    fn bus_id(&self) -> String {
        self.0.with_bus(|bus| match bus {
            SimBus::Bytes(b) => ByteLink::bus_id(b),
            SimBus::Frames(b) => FrameLink::bus_id(b),
        })
    }
    fn bitrate(&self) -> u32 {
        self.0.with_bus(|bus| match bus {
            SimBus::Frames(b) => b.bitrate(),
            SimBus::Bytes(_) => 0,
        })
    }
    fn clock(&self) -> &dyn Clock {
        &self.0.clock
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Frames(b) => b.send(frame),
            SimBus::Bytes(_) => Err(wrong_kind(&self.0.port)),
        })
    }
    fn recv(&mut self, deadline: Instant) -> Result<Option<CanFrame>, LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Frames(b) => b.recv(deadline),
            SimBus::Bytes(_) => Err(wrong_kind(&self.0.port)),
        })
    }
    fn discard_input(&mut self) -> Result<(), LinkError> {
        self.0.with_bus(|bus| match bus {
            SimBus::Frames(b) => b.discard_input(),
            SimBus::Bytes(_) => Err(wrong_kind(&self.0.port)),
        })
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use driveset_proto::lustbus::{Address, Enquiry, ParameterCode};

    use super::*;

    fn spec(s: &str) -> SimSpec {
        SimSpec::parse(s).unwrap_or_else(|e| panic!("not a sim port: {e}"))
    }

    /// A fresh file path in the temp dir (removed on drop).
    struct TempPath(PathBuf);
    impl TempPath {
        fn new(tag: &str) -> Self {
            use std::sync::atomic::{AtomicU32, Ordering};
            static N: AtomicU32 = AtomicU32::new(0);
            let n = N.fetch_add(1, Ordering::Relaxed);
            TempPath(std::env::temp_dir().join(format!(
                "driveset-sim-open-{}-{tag}-{n}.json",
                std::process::id()
            )))
        }
    }
    impl Drop for TempPath {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    fn config(family: Family, addresses: &[u8]) -> SimConfig {
        SimConfig::new(family, addresses.to_vec())
    }

    /// ENQUIRY of 85 to `a`, then everything the line returns until 100 ms
    /// of quiet; returns the bytes and the virtual instant at the end.
    fn enquire_85(link: &SimLink, a: u8) -> (Vec<u8>, Instant) {
        let mut l = link.byte_link().unwrap();
        let t = Enquiry::new(Address::new(a).unwrap(), ParameterCode::new(85).unwrap());
        l.send(&t.encode()).unwrap();
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        let mut last = l.clock().now();
        loop {
            let deadline = l.clock().deadline_in(Duration::from_millis(100));
            let n = l.recv(&mut buf, deadline).unwrap();
            if n == 0 {
                return (got, last);
            }
            last = l.clock().now();
            got.extend_from_slice(&buf[..n]);
        }
    }

    #[test]
    fn every_family_opens_with_its_drives() {
        for (family, addresses) in [
            (Family::Mc6000, vec![1, 2]),
            (Family::Vf1000, vec![30]),
            (Family::Tmd, vec![1, 99]),
            (Family::Ecs, vec![1, 127]),
        ] {
            let clock = VirtualClock::new();
            let link =
                open_sim_with(&config(family, &addresses), &clock, "sim", EventLog::off()).unwrap();
            assert_eq!(link.family(), family);
            assert_eq!(link.addresses(), addresses);
            assert_eq!(link.is_can(), family == Family::Ecs);
            assert_eq!(link.byte_link().is_some(), family != Family::Ecs);
            assert_eq!(link.frame_link().is_some(), family == Family::Ecs);
            match link.link() {
                Link::Bytes(b) => assert_eq!(b.baud(), 9600),
                Link::Frames(f) => assert_eq!(f.bitrate(), 500_000),
            }
            for &a in &addresses {
                let s = link.state(a).unwrap();
                assert_eq!(
                    s.schema,
                    crate::catalog::sim_schema_id(family),
                    "{}",
                    family.name()
                );
            }
            assert!(link.state(3).is_none());
            let dump = link.dump();
            assert_eq!(dump.format, STATE_FORMAT);
            assert_eq!(dump.family, family.name());
            assert_eq!(dump.drives.len(), addresses.len());
        }
    }

    #[test]
    fn spec_options_and_family_spellings() {
        let c = SimConfig::from_spec(&spec(
            "sim://lust-mc6000?addresses=2,1&baud=19200&seed=7&faults=lose=0.5",
        ))
        .unwrap();
        assert_eq!(c.family, Family::Mc6000);
        assert_eq!(c.addresses, [2, 1]);
        assert_eq!((c.baud, c.seed), (19200, 7));
        assert_eq!(c.faults.lose, 0.5);
        for (name, family) in [
            ("mc7000", Family::Mc6000),
            ("lust-vf1000", Family::Vf1000),
            ("fictional-vf1000-demo", Family::Vf1000),
            ("lenze-tmd", Family::Tmd),
            ("lenze_ecs", Family::Ecs),
            ("ECS", Family::Ecs),
        ] {
            assert_eq!(parse_family(name).unwrap(), family, "{name}");
        }
        let e = parse_family("s7-300").unwrap_err().to_string();
        assert!(e.contains("mc6000, vf1000, tmd, ecs"), "{e}");
        let e = SimConfig::from_spec(&spec("sim://tmd?addresses=1&faults=lose=2"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("faults: invalid fault item `lose=2`"), "{e}");
    }

    #[test]
    fn addresses_are_checked_per_family() {
        let bad = |f, a: &[u8]| config(f, a).check().unwrap_err().to_string();
        assert!(bad(Family::Mc6000, &[31]).contains("1..=30"));
        assert!(bad(Family::Vf1000, &[0]).contains("address 0 is not allowed"));
        assert!(bad(Family::Tmd, &[20]).contains("10, 20, ... 90"));
        assert!(bad(Family::Tmd, &[100]).contains("1..=99"));
        assert!(bad(Family::Ecs, &[128]).contains("1..=127"));
        assert!(bad(Family::Ecs, &[]).contains("no drive address"));
        assert!(bad(Family::Mc6000, &[3, 3]).contains("address 3 is given twice"));
        let mut c = config(Family::Tmd, &[1]);
        c.baud = 1000;
        assert!(c.check().unwrap_err().to_string().contains("1000 baud"));
        let mut c = config(Family::Ecs, &[1]);
        c.bitrate = 33_000;
        assert!(c.check().unwrap_err().to_string().contains("33000"));
        assert!(config(Family::Tmd, &[1, 11, 99]).check().is_ok());
    }

    #[test]
    fn first_enquiry_of_85_after_power_on_and_seed_reproducibility() {
        let run = |seed: u64| {
            let clock = VirtualClock::new();
            let link = open_sim(
                &spec(&format!("sim://mc6000?addresses=1,2&seed={seed}")),
                &clock,
            )
            .unwrap();
            let first = enquire_85(&link, 1);
            let second = enquire_85(&link, 1);
            (first, second)
        };
        let ((bytes, at), (again, _)) = run(7);
        // 6.1.1.2: A STX 00085 = 01 ETX BCC; power-on bit, then cleared.
        assert_eq!(bytes, b"A\x0200085=01\x03\x02");
        assert_eq!(again, b"A\x0200085=00\x03\x03");
        assert_eq!(run(7).0.1, at, "same seed, same instants");
        let other: Vec<Instant> = (8..12).map(|s| run(s).0.1).collect();
        assert!(other.iter().any(|t| *t != at), "{other:?} vs {at}");
    }

    #[test]
    fn poke_changes_the_fingerprint() {
        let clock = VirtualClock::new();
        let link = open_sim(&spec("sim://tmd?addresses=1"), &clock).unwrap();
        let before = link.state(1).unwrap().fingerprint();
        link.poke(1, CodeKey::new(11), RawValue::Int(600_000))
            .unwrap();
        let after = link.state(1).unwrap();
        assert_ne!(after.fingerprint(), before);
        assert_eq!(after.values[&CodeKey::new(11)], RawValue::Int(600_000));
        assert!(link.poke(2, CodeKey::new(11), RawValue::Int(1)).is_err());
    }

    /// Poke the first integer code the drive accepts a change of.
    fn poke_something(link: &SimLink, a: u8) -> CodeKey {
        let s = link.state(a).unwrap();
        for (k, v) in &s.values {
            if let RawValue::Int(v) = v
                && ![82, 85, 9].contains(&k.number)
                && link.poke(a, *k, RawValue::Int(v + 1)).is_ok()
                && link.state(a).unwrap().values[k] == RawValue::Int(v + 1)
            {
                return *k;
            }
        }
        panic!("nothing to poke");
    }

    #[test]
    fn state_round_trip_keeps_the_fingerprint() {
        for family in Family::ALL {
            let file = TempPath::new(family.name());
            let mut c = config(family, &[1, 3]);
            c.state = Some(file.0.clone());
            let clock = VirtualClock::new();
            let link = open_sim_with(&c, &clock, "sim", EventLog::off()).unwrap();
            let key = poke_something(&link, 3);
            let want = link.state(3).unwrap();
            assert!(link.save().unwrap());
            drop(link);
            let again = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
            let got = again.state(3).unwrap();
            assert_eq!(got.fingerprint(), want.fingerprint(), "{}", family.name());
            assert_eq!(got.values[&key], want.values[&key]);
            // A drive the file does not hold starts from factory state.
            let mut wider = c.clone();
            wider.addresses = vec![1, 3, 5];
            drop(again);
            let wide = open_sim_with(&wider, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
            let fresh = open_sim_with(
                &config(family, &[5]),
                &VirtualClock::new(),
                "sim",
                EventLog::off(),
            )
            .unwrap();
            assert_eq!(
                wide.state(5).unwrap().fingerprint(),
                fresh.state(5).unwrap().fingerprint()
            );
        }
    }

    #[test]
    fn the_state_is_saved_when_the_last_handle_drops() {
        let file = TempPath::new("drop");
        let mut c = config(Family::Mc6000, &[1]);
        c.state = Some(file.0.clone());
        let link = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        let handle = link.byte_link().unwrap();
        // The first read clears the power-on bit; that is state too.
        let (bytes, _) = enquire_85(&link, 1);
        assert!(bytes.starts_with(b"A\x0200085=01"));
        drop(link);
        assert!(!file.0.exists(), "a handle still holds the bus");
        drop(handle);
        let dump = StateDump::read(&file.0).unwrap();
        assert_eq!(dump.drives.len(), 1);
        assert_eq!(dump.drives[0].address, 1);
        assert!(dump.drives[0].fingerprint.starts_with("sha256:"));
        let again = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        assert_eq!(
            again.state(1).unwrap().fingerprint(),
            dump.drives[0].fingerprint
        );
        let (bytes, _) = enquire_85(&again, 1);
        assert!(bytes.starts_with(b"A\x0200085=00"), "{bytes:?}");
    }

    #[test]
    fn bad_state_files_are_refused_with_the_path() {
        let file = TempPath::new("bad");
        let mut c = config(Family::Vf1000, &[1]);
        c.state = Some(file.0.clone());
        std::fs::write(&file.0, "{}").unwrap();
        let e = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off())
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a simulator state dump"), "{e}");
        assert!(e.contains(&file.0.display().to_string()), "{e}");
        // A dump of another family.
        let tmd = open_sim_with(
            &config(Family::Tmd, &[1]),
            &VirtualClock::new(),
            "sim",
            EventLog::off(),
        )
        .unwrap();
        tmd.save_to(&file.0).unwrap();
        let e = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("it holds tmd drives, this bus has vf1000 drives"),
            "{e}"
        );
    }

    #[test]
    fn canonical_text_parses_back() {
        let mut s = ResolvedSet {
            schema: "lenze-tmd".into(),
            code_style: driveset_schema::schema::CodeStyle::Lenze,
            values: BTreeMap::new(),
            secrets: Default::default(),
        };
        s.insert(CodeKey::new(7), RawValue::Int(-17185));
        s.insert(CodeKey::sub(39, 1), RawValue::Int(200000));
        s.insert(CodeKey::new(39), RawValue::Octets(vec![0x0a, 0xff]));
        s.insert(CodeKey::new(200), RawValue::Text("33 \"TMD\"\n".into()));
        let (schema, values) = parse_canonical(&s.canonical()).unwrap();
        assert_eq!(schema, "lenze-tmd");
        assert_eq!(values, s.values);
        assert!(parse_canonical("hello").is_err());
        assert!(parse_canonical("driveset-canonical 1\nschema x\nC0001 o0").is_err());
    }

    #[test]
    fn a_mixed_lustbus_holds_servos_and_inverters_on_one_line() {
        let sim = spec("sim://lustbus?vf1000=5,6&mc6000=1,2&seed=3");
        let c = SimConfig::from_spec(&sim).unwrap();
        assert!(c.is_mixed());
        assert_eq!(c.bus_name(), "lustbus");
        assert_eq!(
            c.drives(),
            [
                (Family::Mc6000, 1),
                (Family::Mc6000, 2),
                (Family::Vf1000, 5),
                (Family::Vf1000, 6)
            ]
        );
        let link = open_sim(&sim, &VirtualClock::new()).unwrap();
        assert!(link.is_mixed() && !link.is_can());
        assert_eq!(link.families(), [Family::Mc6000, Family::Vf1000]);
        assert_eq!(link.family_of(5), Some(Family::Vf1000));
        assert_eq!(link.family_of(2), Some(Family::Mc6000));
        assert_eq!(link.family_of(3), None);
        assert_eq!(link.addresses(), [1, 2, 5, 6]);
        assert_eq!(
            link.state(1).unwrap().schema,
            crate::catalog::sim_schema_id(Family::Mc6000)
        );
        assert_eq!(
            link.state(6).unwrap().schema,
            crate::catalog::sim_schema_id(Family::Vf1000)
        );
        // Both families answer on the same byte link, each at its address.
        let (mc, _) = enquire_85(&link, 2);
        assert!(mc.starts_with(b"B\x0200085="), "{mc:?}");
        let (vf, _) = enquire_85(&link, 5);
        assert!(vf.starts_with(b"E\x0200085="), "{vf:?}");
        let dump = link.dump();
        assert_eq!(dump.family, "lustbus");
        let fams: Vec<(&str, u8)> = dump
            .drives
            .iter()
            .map(|d| (d.family.as_str(), d.address))
            .collect();
        assert_eq!(
            fams,
            [("mc6000", 1), ("mc6000", 2), ("vf1000", 5), ("vf1000", 6)]
        );
    }

    #[test]
    fn a_mixed_lustbus_keeps_its_state_per_family_and_address() {
        let file = TempPath::new("mixed");
        let mut c = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Vf1000, 3)]);
        c.state = Some(file.0.clone());
        let link = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        let mc_key = poke_something(&link, 1);
        let vf_key = poke_something(&link, 3);
        let (mc, vf) = (link.state(1).unwrap(), link.state(3).unwrap());
        assert!(link.save().unwrap());
        drop(link);
        let again = open_sim_with(&c, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        assert_eq!(again.state(1).unwrap().fingerprint(), mc.fingerprint());
        assert_eq!(again.state(3).unwrap().fingerprint(), vf.fingerprint());
        assert_eq!(again.state(1).unwrap().values[&mc_key], mc.values[&mc_key]);
        assert_eq!(again.state(3).unwrap().values[&vf_key], vf.values[&vf_key]);
        drop(again);
        // Same addresses, families swapped: nothing in the file matches,
        // every drive starts from factory state.
        let mut swapped = SimConfig::mixed(&[(Family::Vf1000, 1), (Family::Mc6000, 3)]);
        swapped.state = Some(file.0.clone());
        let fresh = open_sim_with(&swapped, &VirtualClock::new(), "sim", EventLog::off()).unwrap();
        let factory = open_sim_with(
            &SimConfig::mixed(&[(Family::Vf1000, 1), (Family::Mc6000, 3)]),
            &VirtualClock::new(),
            "sim",
            EventLog::off(),
        )
        .unwrap();
        for a in [1, 3] {
            assert_eq!(
                fresh.state(a).unwrap().fingerprint(),
                factory.state(a).unwrap().fingerprint()
            );
        }
        drop(fresh);
        // A single-family bus refuses the mixed bus's file.
        let mut single = config(Family::Mc6000, &[1]);
        single.state = Some(file.0.clone());
        let e = open_sim_with(&single, &VirtualClock::new(), "sim", EventLog::off())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("it holds lustbus drives, this bus has mc6000 drives"),
            "{e}"
        );
    }

    #[test]
    fn a_mixed_lustbus_refuses_what_cannot_share_the_line() {
        let e = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Tmd, 2)])
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("tmd drives cannot be on a mixed LUSTBUS"), "{e}");
        let e = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Vf1000, 31)])
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("vf1000: address 31 is not allowed"), "{e}");
        let mut c = SimConfig::mixed(&[(Family::Mc6000, 1), (Family::Vf1000, 2)]);
        c.addresses.push(3);
        let e = c.check().unwrap_err().to_string();
        assert!(e.contains("2 drive families for 3 addresses"), "{e}");
        let e = SimConfig::mixed(&[(Family::Mc6000, 4), (Family::Vf1000, 4)])
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("address 4 is given twice"), "{e}");
        // A single family through the per-family key is a mixed bus too
        // (named lustbus), and equal to itself on the wire.
        let c = SimConfig::from_spec(&spec("sim://lustbus?mc7000=1")).unwrap();
        assert_eq!(
            (c.bus_name(), c.drives()),
            ("lustbus", vec![(Family::Mc6000, 1)])
        );
    }

    #[test]
    fn ecs_answers_on_the_frame_link() {
        let clock = VirtualClock::new();
        let link = open_sim(&spec("sim://ecs?addresses=5&bitrate=125000"), &clock).unwrap();
        let mut l = link.frame_link().unwrap();
        assert_eq!(l.bitrate(), 125_000);
        // SDO upload request of index 0x5FFF - 1 (C0001), subindex 0.
        let req = CanFrame::new(0x605, &[0x40, 0xFE, 0x5F, 0, 0, 0, 0, 0]).unwrap();
        l.send(&req).unwrap();
        let deadline = l.clock().deadline_in(Duration::from_millis(100));
        let answer = l.recv(deadline).unwrap().expect("an answer");
        assert_eq!(answer.id, 0x585);
    }
}
