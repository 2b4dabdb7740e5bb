//! Owns [`SimConfig`], the checked settings of a simulated bus (which
//! drives, rates, seed, faults, state file, factory drives and the bench),
//! and the drive models and lines it builds (module docs of [`crate::open`]).

use std::collections::BTreeMap;
use std::path::PathBuf;

use driveset_link::spec::{ALLOWED_BAUDS, ALLOWED_BITRATES, DEFAULT_BAUD, DEFAULT_BITRATE};
use driveset_proto::can::{AbortCode, NodeId};
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::canonical::CodeKey;
use driveset_schema::family::Keypad;

use super::state::*;
use super::{
    SIM_MIXED_LUSTBUS, STATE_DIR_ENV, SimOpenError, SimSpec, check_address, is_can, parse_family,
};
use crate::bus::{ByteLine, list};
use crate::can_bus::FrameLine;
use crate::catalog::Family;
use crate::drive::{ByteDrive, FrameDrive, ReadRefusal};
use crate::ecs::EcsDrive;
use crate::factory::FactoryBus;
use crate::factory::{BenchView, DriveSlot, FACTORY_BAUD, bench_pick, factory_address};
use crate::faults::FaultPlan;
use crate::log::EventLog;
use crate::lustbus_drive::LustOptions;
use crate::mc6000::Mc6000;
use crate::rng::SimRng;
use crate::tmd::{TmdDrive, TmdOptions};
use crate::vf1000::Vf1000;

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
    /// A data-sheet bus (`sim://eds?file=DEVICE.eds`, [`crate::eds`]):
    /// every node is the device the sheet describes. `None` otherwise.
    pub eds: Option<crate::eds::EdsDevice>,
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
            eds: None,
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

    /// [`SimConfig::is_mixed`] as a `factory=` value's bus kind.
    pub fn factory_bus(&self) -> FactoryBus {
        if self.is_mixed() {
            FactoryBus::Mixed
        } else {
            FactoryBus::OneFamily
        }
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
    /// state file when the drives' state persists in one; without a state
    /// file the drives live in this process only, and `~` and the process
    /// id say so (two processes' buses are two buses, each locked as any
    /// bus is). Seed, faults, keypad and rates are not part of it:
    /// `sim://mc6000?addresses=1&faults=..` and `sim://mc6000?addresses=1`
    /// with one state file are one bus.
    pub fn bus_id(&self) -> String {
        match &self.state {
            Some(p) => format!(
                "sim:{}@{}",
                self.bus_name(),
                driveset_link::bus_id::canonical_file(p)
            ),
            None => format!("sim:{}~{}", self.bus_name(), std::process::id()),
        }
    }

    /// The settings a `sim://` port gives; without `state=`, the state
    /// file comes from [`STATE_DIR_ENV`] if that is set.
    pub fn from_spec(spec: &SimSpec) -> Result<Self, SimOpenError> {
        let mut config = if spec.is_twin() {
            SimConfig::of_twins(crate::port::twins_of(spec)?)?
        } else if spec.is_eds() {
            let file = spec.options.get("file").ok_or_else(|| {
                SimOpenError::Eds(
                    "a data-sheet port names its EDS / DCF: sim://eds?file=DEVICE.eds&addresses=N"
                        .into(),
                )
            })?;
            let device = crate::eds::EdsDevice::load(std::path::Path::new(file))
                .map_err(SimOpenError::Eds)?;
            let mut c = SimConfig::new(Family::Ecs, spec.addresses.clone());
            c.eds = Some(device);
            c
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

    /// [`SimConfig::keypad`] as the drives' options take it.
    fn keypad_fitted(&self) -> Keypad {
        if self.keypad {
            Keypad::Fitted
        } else {
            Keypad::Absent
        }
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
            let mut lust = LustOptions::new(address)
                .seed(seed)
                .keypad(self.keypad_fitted());
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
                let r = crate::factory::factory_reaction(family, self.keypad_fitted(), k);
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
            let mut drive = match &self.eds {
                Some(device) => device.drive(node, self.seed).map_err(err)?,
                None => EcsDrive::new(node, self.seed).map_err(err)?,
            };
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
pub(super) fn state_file_for(bus: &str) -> Option<PathBuf> {
    let dir = std::env::var_os(STATE_DIR_ENV).filter(|d| !d.is_empty())?;
    Some(PathBuf::from(dir).join(format!("sim-{bus}.json")))
}
