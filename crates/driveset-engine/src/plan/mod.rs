//! Upload planning: which writes a set needs on a drive, in which order, how
//! each one is stored, and how long the transaction should take. Pure: no
//! bus IO here (the upload runner reads the drive and hands the values in).
//!
//! # Refusals (before anything is sent)
//!
//! - a code the schema does not know, or a subcode it does not have;
//! - a read-only code (`access = "ro"` or a RAM actual value), a code whose
//!   reading clears it (85-SIOF/SERR) and, on MC6000/7000, 80-SLOAD itself
//!   (the runner drives the dataset handshake);
//! - with no override: a code of role `command` (PROG, SLOAD, STAT reset,
//!   Tmd C0002 / C0043), and a `control-word` value in any state but
//!   stopped / inhibited ([`driveset_schema::role::refusal`]): a set never
//!   starts a motor;
//! - each unless its named override ([`crate::overrides::Override`]): a set
//!   for another schema or a drive whose identity says it is of another
//!   protocol family or 91-TYPE (`--allow-family`), a running drive
//!   (`--allow-running`), a drive whose running state cannot be known
//!   (`--allow-running-unknown`), a change of the drive's bus address
//!   (`--allow-address-change`, see "link" below).
//!
//! Which code is a command, control word, setpoint, mode / control source,
//! bus address or baud rate comes from the schema's roles
//! (`driveset_schema::role`); this module names no code number.
//!
//! # Write order
//!
//! Writes go in five phases, each in code order except where noted:
//!
//! 1. **dataset** (MC6000/7000 only): `SLOAD = -1`, every CardWriteable
//!    value that differs, `SLOAD = -2`, poll SLOAD (LUSTBUS 11.4). The drive
//!    checks the staged values as one set, so values that depend on each
//!    other are never refused one by one, and a rejected set leaves the
//!    drive on its old set. Non-CardWriteable values must not be staged
//!    (the drive ACKs them but does not take them), so they all follow.
//! 2. **stored**: configuration values (EEPROM, and codes whose storage the
//!    schema does not give): they change how the drive will behave, not
//!    what it does right now.
//! 3. **control**: RAM control values and codes of role `control-word`,
//!    `setpoint` (LUSTBUS `ram-control` and FSEL/ISEL values, Tmd C0040
//!    controller inhibit, C0046/C0047/C0140 setpoints, C0135 control word;
//!    ECS C0135). They act at once, so they come after the configuration
//!    they act on is in place.
//! 4. **mode**: codes of role `operating-mode`, then `control-source`
//!    (Tmd C0014 operating mode, then C0001 setpoint and control
//!    source; VF1000 2-CSEL). On a Tmd, C0001 decides whether parameters may
//!    still be written over LECOM at all (manual §4e: 0/1 read only, 2 and 3
//!    write): written earlier, a change to 0/1 would lock the rest of the
//!    set out, and a control word or setpoint would take effect under the
//!    new control source before it is set. A roll back restores in the
//!    reverse order, so the control source is put back first.
//! 5. **link**: role `baud-rate` (LUSTBUS 81-SIOC/SBAUD, effective after a
//!    restart, 11.5; Tmd C0125), last, so the rest of the set lands over the
//!    link as it is. A change of the **bus address** (role `bus-address`:
//!    82-SIOA/SADDR, Tmd C0009) is refused without `--allow-address-change`: the drive would stop answering at the
//!    address the transaction talks to (found against the simulated VF1000,
//!    which takes a new 82-SIOA at once).
//!
//! # Rooms
//!
//! - this file: the plan's types and [`plan`], which orders the writes;
//! - `order`: how a code is stored and which phase its write is in;
//! - `problem`: the refusals and the checks that need no bus
//!   ([`check_set`]);
//! - `timing`: the spec's reaction and store times and the expected
//!   duration of a transaction ([`Plan::estimate`]);
//! - `render`: the `--dry-run` text ([`Plan::render`]).

mod order;
mod problem;
mod render;
mod timing;

use std::time::Duration;

use driveset_schema::validate::display_value;
use driveset_schema::{CodeKey, Family, RawValue, ResolvedSet, Role, Schema};

use crate::client::Identity;
use crate::overrides::{Override, Overrides};

pub use order::{Phase, Storage};
pub use problem::{Problem, check_set};
pub use timing::{
    DATASET_TIMEOUT, LECOM_MONITORING_FACTOR, LUSTBUS_MIN_REACTION, MC_MAX_REACTION,
    MC_MAX_REACTION_KEYPAD, SLOAD_POLL_INTERVAL, TMD_MAX_REACTION, TMD_MIN_REACTION, TimeEstimate,
    VF_MAX_REACTION, VF_MAX_REACTION_KEYPAD,
};

use order::{mode_rank, phase_of, storage_of};
pub(crate) use problem::running_unknown_why;

/// One write the plan needs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlannedWrite {
    /// Code.
    pub key: CodeKey,
    /// Code as humans spell it (`C0011 maximum_output_frequency`, `428-RSIO`).
    pub label: String,
    /// How the drive keeps it.
    pub storage: Storage,
    /// Byte width, where the schema gives it.
    pub width: Option<u8>,
    /// Phase.
    pub phase: Phase,
    /// A password (redacted in every text).
    pub secret: bool,
    /// Value the drive holds now.
    pub old: RawValue,
    /// Value the set gives.
    pub new: RawValue,
    /// Old value for humans (labels, units; `<redacted>` for passwords).
    pub old_text: String,
    /// New value for humans.
    pub new_text: String,
    /// MC6000/7000 EEPROM store time after the write (zero for RAM and staged values).
    pub store_time: Duration,
    /// VF1000 extra ACK delay for an EEPROM write.
    pub ack_delay: Duration,
}

/// What the drive says about its motor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Running {
    /// Not asked yet (the checks before the drive is identified).
    #[default]
    NotRead,
    /// The drive reports it (true: running).
    Known(bool),
    /// The drive cannot say (its schema names no running bit).
    Unknown,
}

impl From<Option<bool>> for Running {
    /// A client's `running()` answer.
    fn from(v: Option<bool>) -> Self {
        match v {
            Some(b) => Running::Known(b),
            None => Running::Unknown,
        }
    }
}

/// What the planner needs besides the schema and values.
#[derive(Debug, Clone, Default)]
pub struct PlanOptions {
    /// The named overrides given (each lifts one refusal).
    pub overrides: Overrides,
    /// Whether the client has the MC6000/7000 dataset handshake.
    pub dataset: bool,
    /// What the drive says about its motor.
    pub running: Running,
    /// What the drive said it is (family check), if identified.
    pub identity: Option<Identity>,
}

/// An upload plan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Plan {
    /// Schema id.
    pub schema: String,
    /// Fingerprint of the set being uploaded.
    pub set_fingerprint: String,
    /// Fingerprint of the drive's values of the set's codes now.
    pub fingerprint_before: String,
    /// Whether the dataset handshake is used (some write is in [`Phase::Dataset`]).
    pub dataset: bool,
    /// Writes, in order.
    pub writes: Vec<PlannedWrite>,
    /// Codes of the set the drive already holds.
    pub unchanged: Vec<CodeKey>,
    /// Notes for the user (forced refusals, assumptions).
    pub warnings: Vec<String>,
}

/// The `[schema] protocol` of `p`'s schema files (its descriptor's
/// `schema_protocol`), as findings name a family's protocol.
pub(crate) fn protocol_name(p: Family) -> &'static str {
    p.descriptor().schema_protocol
}

/// Code as humans spell it: Lenze `C0011 name`, Lust `428-RSIO`.
///
/// The one spelling the schema's diff uses too ([`Schema::code_label`]).
pub fn code_label(schema: &Schema, key: CodeKey) -> String {
    schema.code_label(key)
}

/// A value for humans (labels, units, `<redacted>` for passwords).
pub fn value_text(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    match schema.code(key.number) {
        Some(c) => display_value(schema, c, raw),
        None => "<unknown code>".into(),
    }
}

/// Whether a code holds a password.
pub fn is_secret(schema: &Schema, key: CodeKey) -> bool {
    schema
        .code(key.number)
        .is_some_and(|c| schema.is_password(c))
}

/// Plan the upload of `set` to a drive holding `current` (its values of the
/// set's codes). Refusals: see [`check_set`]; a code of the set missing from
/// `current` is refused too (the drive's value must be known for the backup).
pub fn plan(
    schema: &Schema,
    set: &ResolvedSet,
    current: &ResolvedSet,
    opts: &PlanOptions,
) -> Result<Plan, Vec<Problem>> {
    let mut problems = check_set(schema, set, opts);
    let mut writes = Vec::new();
    let mut unchanged = Vec::new();
    let mut warnings = Vec::new();
    if opts.overrides.allows(Override::AllowFamily) && set.schema != schema.id {
        warnings.push(format!(
            "{}: set for schema `{}` uploaded with schema `{}`",
            Override::AllowFamily,
            set.schema,
            schema.id
        ));
    }
    match opts.running {
        Running::Known(true) if opts.overrides.allows(Override::AllowRunning) => {
            warnings.push(format!(
                "{}: the drive reports a running motor",
                Override::AllowRunning
            ))
        }
        Running::Unknown if opts.overrides.allows(Override::AllowRunningUnknown) => {
            warnings.push(format!(
                "running state unknown ({}): {}",
                Override::AllowRunningUnknown,
                running_unknown_why(schema)
            ))
        }
        _ => {}
    }
    for (key, new) in &set.values {
        let Some(code) = schema.code(key.number) else {
            continue;
        };
        let Some(old) = current.values.get(key) else {
            problems.push(Problem::NotRead {
                code: code_label(schema, *key),
            });
            continue;
        };
        if old == new {
            unchanged.push(*key);
            continue;
        }
        if code.has_role(Role::BusAddress) {
            if opts.overrides.allows(Override::AllowAddressChange) {
                warnings.push(format!(
                    "{}: {} changes the drive's bus address; it will stop answering at its present address, so this write cannot be verified or rolled back",
                    Override::AllowAddressChange,
                    code_label(schema, *key)
                ));
            } else {
                problems.push(Problem::AddressChange {
                    code: code_label(schema, *key),
                    old: display_value(schema, code, old),
                    new: display_value(schema, code, new),
                });
                continue;
            }
        }
        if code.has_role(Role::BaudRate) {
            warnings.push(format!(
                "{} changes the baud rate: talk to the drive at the new rate after its next restart",
                code_label(schema, *key)
            ));
        }
        let storage = storage_of(code, opts.dataset);
        let phase = phase_of(schema, *key, storage);
        let family = schema.family.descriptor();
        let store_time = if storage == Storage::Eeprom {
            family.store_time(code)
        } else {
            Duration::ZERO
        };
        // The same rule the client uses for its answer timeout.
        let ack_delay = family.ack_delay(code, driveset_schema::family::ValueChange::Differs);
        writes.push(PlannedWrite {
            key: *key,
            label: code_label(schema, *key),
            storage,
            width: code.width,
            phase,
            secret: schema.is_password(code),
            old: old.clone(),
            new: new.clone(),
            old_text: display_value(schema, code, old),
            new_text: display_value(schema, code, new),
            store_time,
            ack_delay,
        });
    }
    if !problems.is_empty() {
        return Err(problems);
    }
    writes.sort_by_key(|w| (w.phase, mode_rank(schema, w.key.number), w.key));
    let mut drive_before = ResolvedSet::new(schema);
    for k in set.values.keys() {
        if let Some(v) = current.values.get(k) {
            drive_before.insert(*k, v.clone());
        }
    }
    let dataset = writes.iter().any(|w| w.phase == Phase::Dataset);
    Ok(Plan {
        schema: schema.id.clone(),
        set_fingerprint: set.fingerprint(),
        fingerprint_before: drive_before.fingerprint(),
        dataset,
        writes,
        unchanged,
        warnings,
    })
}

impl Plan {
    /// Whether there is nothing to write.
    pub fn is_empty(&self) -> bool {
        self.writes.is_empty()
    }
}
