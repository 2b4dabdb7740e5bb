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

use std::fmt::Write as _;
use std::time::Duration;

use driveset_schema::schema::{Access, StorageKind};
use driveset_schema::validate::display_value;
use driveset_schema::{Code, CodeKey, CodeStyle, Family, RawValue, ResolvedSet, Schema};

use driveset_schema::Role;

use crate::client::{DriveClient, IdentValue, Identity};
use crate::overrides::{Override, Overrides};

/// The longest the MC6000/7000 dataset check may take before the upload
/// gives up (the family descriptor's SLOAD handshake, LUSTBUS 11.4).
pub const DATASET_TIMEOUT: Duration = driveset_schema::family::SLOAD.timeout;

/// The dataset handshake code of `schema`'s family (MC6000/7000 80-SLOAD).
fn dataset_code(schema: &Schema) -> Option<u32> {
    schema.family.descriptor().dataset.map(|d| d.code)
}

/// The shortest interval between two SLOAD polls while the drive checks a
/// staged dataset (not a spec figure: 11.4 gives only the 10 s timeout; a
/// poll at most every 50 ms, or one measured round trip when that is
/// longer, instead of back-to-back ENQUIRYs).
pub const SLOAD_POLL_INTERVAL: Duration = Duration::from_millis(50);

/// The longest reaction time of an MC6000/7000 with a KEYPAD attached
/// (the family descriptor: LUSTBUS 10, table: 1...30 ms).
pub const MC_MAX_REACTION_KEYPAD: Duration = reaction(Family::Mc6000, true);

/// The longest reaction time of an MC6000/7000 without KEYPAD (LUSTBUS 10:
/// 1...25 ms).
pub const MC_MAX_REACTION: Duration = reaction(Family::Mc6000, false);

/// The longest reaction time of a VF1000 with a KEYPAD attached (LUSTBUS
/// 10: 1...60 ms).
pub const VF_MAX_REACTION_KEYPAD: Duration = reaction(Family::Vf1000, true);

/// The longest reaction time of a VF1000 without KEYPAD (LUSTBUS 10:
/// 1...30 ms).
pub const VF_MAX_REACTION: Duration = reaction(Family::Vf1000, false);

/// The shortest reaction time of every LUSTBUS device (LUSTBUS 10: "1...").
pub const LUSTBUS_MIN_REACTION: Duration = Family::Mc6000.descriptor().reaction.min;

/// The longest reaction of `family` from its descriptor.
const fn reaction(family: Family, keypad: bool) -> Duration {
    let r = family.descriptor().reaction;
    match (keypad, r.max_with_keypad) {
        (true, Some(k)) => k,
        _ => r.max,
    }
}

/// LECOM 8.J b: "The monitoring time in the master should be approx. twice
/// as long as the maximum response time."
pub const LECOM_MONITORING_FACTOR: u32 = 2;

/// The Tmd's longest response time. FICTIONAL: the LECOM manual gives none;
/// the family descriptor assumes 20 ms, as the simulator's Tmd does.
pub const TMD_MAX_REACTION: Duration = Family::Tmd.descriptor().reaction.max;

/// The shortest response time assumed of a Tmd, for planning (FICTIONAL,
/// as [`TMD_MAX_REACTION`]).
pub const TMD_MIN_REACTION: Duration = Family::Tmd.descriptor().reaction.min;

/// How a code's value is kept by the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Storage {
    /// RAM (control value): taken at once, no store time.
    Ram,
    /// FSEL/ISEL variable: RAM at CSEL = 3, EEPROM otherwise (LUSTBUS 11.1).
    FselIsel,
    /// EEPROM: MC6000/7000 store it in the background (width x 15 ms),
    /// VF1000 delay the ACK.
    Eeprom,
    /// MC6000/7000 CardWriteable: taken by the SLOAD dataset download.
    CardWriteable,
    /// The schema does not say (Lenze families).
    Unspecified,
}

impl Storage {
    /// Name as in journals and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Storage::Ram => "ram",
            Storage::FselIsel => "fsel-isel",
            Storage::Eeprom => "eeprom",
            Storage::CardWriteable => "card-writeable",
            Storage::Unspecified => "unspecified",
        }
    }
}

/// Which part of the transaction a write belongs to (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// MC6000/7000 SLOAD dataset download.
    Dataset,
    /// Configuration values.
    Stored,
    /// RAM control values and commands.
    Control,
    /// Operating mode / control source switches.
    Mode,
    /// Bus address and baud rate of the drive's serial interface, last:
    /// the rest of the set must land while the link is as it was.
    Link,
}

impl Phase {
    /// Name as in journals and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Dataset => "dataset",
            Phase::Stored => "stored",
            Phase::Control => "control",
            Phase::Mode => "mode",
            Phase::Link => "link",
        }
    }
}

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

/// Expected duration of a transaction, from the client's wire times and the
/// spec's store times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct TimeEstimate {
    /// Reading back every code of the set.
    pub read_back: Duration,
    /// Write exchanges (SLOAD included, VF1000 ACK delays included).
    pub writes: Duration,
    /// Verification reads (interleaved ones included).
    pub verify: Duration,
    /// Waiting for the EEPROM beyond what reads filled.
    pub waits: Duration,
    /// Everything; plus the drive's dataset check when [`Plan::dataset`]
    /// (up to [`DATASET_TIMEOUT`], not included).
    pub total: Duration,
}

pub(crate) fn protocol_name(p: Family) -> &'static str {
    match p {
        Family::Tmd => "lecom",
        Family::Vf1000 => "lustbus-vf1000",
        Family::Mc6000 => "lustbus-mc",
        Family::Ecs => "lenze-can-sdo",
    }
}

/// Code as humans spell it: Lenze `C0011 name`, Lust `428-RSIO`.
pub fn code_label(schema: &Schema, key: CodeKey) -> String {
    let code = schema.display_code(key.number, key.subcode);
    match schema.code(key.number) {
        Some(c) if !c.name.is_empty() && schema.code_style == CodeStyle::Lenze => {
            // a schema file's name is shown to people: no raw control characters
            format!(
                "{code} {}",
                driveset_schema::error::escape_controls(&c.name)
            )
        }
        _ => code,
    }
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

/// Rank of a [`Phase::Mode`] write: the operating mode first, then the
/// control source (see the module docs, "mode").
fn mode_rank(schema: &Schema, number: u32) -> u8 {
    match schema.role_of(number) {
        Some(Role::OperatingMode) => 0,
        Some(Role::ControlSource) => 1,
        _ => 0,
    }
}

fn storage_of(code: &Code, dataset: bool) -> Storage {
    if dataset && code.card_writeable == Some(true) {
        return Storage::CardWriteable;
    }
    match code.kind {
        Some(StorageKind::RamControl) | Some(StorageKind::RamActual) => Storage::Ram,
        Some(StorageKind::FselIsel) => Storage::FselIsel,
        Some(StorageKind::Eeprom) => Storage::Eeprom,
        None if code.card_writeable == Some(true) => Storage::Eeprom,
        None => Storage::Unspecified,
    }
}

fn phase_of(schema: &Schema, key: CodeKey, storage: Storage) -> Phase {
    let role = schema.role_of(key.number);
    if storage == Storage::CardWriteable {
        Phase::Dataset
    } else if matches!(role, Some(Role::BusAddress | Role::BaudRate)) {
        Phase::Link
    } else if matches!(role, Some(Role::OperatingMode | Role::ControlSource)) {
        Phase::Mode
    } else if matches!(storage, Storage::Ram | Storage::FselIsel)
        || matches!(
            role,
            Some(Role::ControlWord | Role::Command | Role::Setpoint)
        )
    {
        Phase::Control
    } else {
        Phase::Stored
    }
}

/// Why the running state of a drive of `schema` cannot be known.
fn running_unknown_why(schema: &Schema) -> String {
    running_unknown_text(&schema.id)
}

fn running_unknown_text(schema: &str) -> String {
    format!(
        "schema `{schema}` names no status bit (role `running`) or control word start bit that says whether the motor runs"
    )
}

/// One reason the planner (or the set check) refuses an upload: a
/// [`crate::error::Refusal::Plan`] holds every one found. Codes are named
/// as [`code_label`] spells them, values as [`value_text`] shows them.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Problem {
    /// The set is for another schema (unless [`Override::AllowFamily`]).
    SetSchema {
        /// The set's schema.
        set: String,
        /// The client's schema.
        schema: String,
    },
    /// The drive identifies as another protocol family.
    ProtocolFamily {
        /// What the drive said.
        found: String,
        /// Schema id.
        schema: String,
        /// The schema's protocol family.
        want: String,
    },
    /// The drive's 91-TYPE is not one of the schema's.
    DriveType {
        /// The TYPE read.
        found: i64,
        /// Schema id.
        schema: String,
        /// The schema's TYPE values.
        expected: Vec<i64>,
    },
    /// A code the schema does not know.
    NotInSchema {
        /// The code.
        code: String,
        /// Schema id.
        schema: String,
    },
    /// A subcode out of the code's range.
    SubcodeRange {
        /// The code with its subcode.
        code: String,
        /// Its number.
        number: u32,
        /// How many subcodes it has.
        subcodes: u32,
    },
    /// A subcode of a code that has none.
    NoSubcodes {
        /// The code with its subcode.
        code: String,
        /// Its number.
        number: u32,
        /// Schema id.
        schema: String,
    },
    /// A read-only code (an actual value).
    ReadOnly {
        /// The code.
        code: String,
    },
    /// A status code that reading clears.
    ReadClears {
        /// The code.
        code: String,
    },
    /// The dataset handshake code (SLOAD).
    DatasetCode {
        /// The code.
        code: String,
    },
    /// A role's rule (a command, a control word that starts the motor ...):
    /// no override.
    Role {
        /// What the rule found.
        message: String,
        /// What to do.
        help: String,
    },
    /// The drive reports a running motor (unless [`Override::AllowRunning`]).
    Running,
    /// The running state cannot be known (unless
    /// [`Override::AllowRunningUnknown`]).
    RunningUnknown {
        /// Schema id.
        schema: String,
    },
    /// The drive's current value of a code was not read.
    NotRead {
        /// The code.
        code: String,
    },
    /// A write that changes the bus address of the drive being talked to
    /// (unless [`Override::AllowAddressChange`]).
    AddressChange {
        /// The code.
        code: String,
        /// The value it holds.
        old: String,
        /// The value the set gives.
        new: String,
    },
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Problem::SetSchema { set, schema } => write!(
                f,
                "the set is for schema `{set}` but the drive is handled with schema `{schema}`; upload a set for this drive family, or pass {} if they are compatible",
                Override::AllowFamily
            ),
            Problem::ProtocolFamily {
                found,
                schema,
                want,
            } => write!(
                f,
                "the drive identifies as protocol family `{found}`, schema `{schema}` is for `{want}`; check the address, or pass {}",
                Override::AllowFamily
            ),
            Problem::DriveType {
                found,
                schema,
                expected,
            } => write!(
                f,
                "the drive reports 91-TYPE {found}, schema `{schema}` is for TYPE {expected:?}; check the address, or pass {}",
                Override::AllowFamily
            ),
            Problem::NotInSchema { code, schema } => write!(
                f,
                "code {code} is not in schema `{schema}`; remove it from the set (or fix the number)"
            ),
            Problem::SubcodeRange {
                code,
                number,
                subcodes,
            } => write!(
                f,
                "{code}: code {number} has subcodes 1..={subcodes} only; fix the subcode"
            ),
            Problem::NoSubcodes {
                code,
                number,
                schema,
            } => write!(
                f,
                "{code}: code {number} has no subcodes in schema `{schema}`; drop the /subcode"
            ),
            Problem::ReadOnly { code } => {
                write!(
                    f,
                    "{code}: read-only (an actual value); remove it from the set"
                )
            }
            Problem::ReadClears { code } => write!(
                f,
                "{code}: a status code that reading clears; it cannot be part of a set, remove it"
            ),
            Problem::DatasetCode { code } => write!(
                f,
                "{code}: the dataset handshake code is driven by the upload itself; remove it from the set"
            ),
            Problem::Role { message, help } => write!(f, "{message}; {help}"),
            Problem::Running => write!(
                f,
                "the drive reports a running motor; stop it (standstill) before uploading, or pass {}",
                Override::AllowRunning
            ),
            Problem::RunningUnknown { schema } => write!(
                f,
                "running state unknown: {}; make sure the drive is at standstill, then pass {}",
                running_unknown_text(schema),
                Override::AllowRunningUnknown
            ),
            Problem::NotRead { code } => write!(
                f,
                "{code}: the drive's current value was not read; it cannot be backed up"
            ),
            Problem::AddressChange { code, old, new } => write!(
                f,
                "{code}: {old} -> {new} changes the bus address of the drive being talked to; it would stop answering mid-transaction. Upload the set to the drive at its new address after changing the address on its own (or pass {})",
                Override::AllowAddressChange
            ),
        }
    }
}

/// Checks that need no bus: every code known, writable, not a handshake or
/// status code, no command, no control word in a start / enable state; the
/// set is for this schema (unless [`Override::AllowFamily`]); and, once the
/// drive was asked ([`PlanOptions::running`]), not running (unless
/// [`Override::AllowRunning`]) and not of unknown running state (unless
/// [`Override::AllowRunningUnknown`]).
/// Returns every problem found (one line each), not just the first.
pub fn check_set(schema: &Schema, set: &ResolvedSet, opts: &PlanOptions) -> Vec<Problem> {
    let mut out = Vec::new();
    let family = !opts.overrides.allow_family;
    if set.schema != schema.id && family {
        out.push(Problem::SetSchema {
            set: set.schema.clone(),
            schema: schema.id.clone(),
        });
    }
    if let Some(id) = &opts.identity {
        let want = protocol_name(schema.family);
        let found = id.protocol.name();
        if !found.is_empty() && found != want && family {
            out.push(Problem::ProtocolFamily {
                found: found.to_string(),
                schema: schema.id.clone(),
                want: want.to_string(),
            });
        }
        if let Some(ident) = &schema.identify
            && !ident.type_values.is_empty()
            && family
            && let Some(ty) = id.value_of(91).and_then(IdentValue::as_int)
            && !ident.type_values.contains(&ty)
        {
            out.push(Problem::DriveType {
                found: ty,
                schema: schema.id.clone(),
                expected: ident.type_values.clone(),
            });
        }
    }
    for key in set.values.keys() {
        let shown = schema.display_code(key.number, key.subcode);
        let Some(code) = schema.code(key.number) else {
            out.push(Problem::NotInSchema {
                code: shown,
                schema: schema.id.clone(),
            });
            continue;
        };
        match (key.subcode, code.subcodes) {
            (Some(s), Some(n)) if s == 0 || s > n => out.push(Problem::SubcodeRange {
                code: shown,
                number: key.number,
                subcodes: n,
            }),
            (Some(_), None) => out.push(Problem::NoSubcodes {
                code: shown,
                number: key.number,
                schema: schema.id.clone(),
            }),
            _ => {}
        }
        if code.access == Some(Access::Ro) || code.kind == Some(StorageKind::RamActual) {
            out.push(Problem::ReadOnly {
                code: code_label(schema, *key),
            });
        } else if code.read_clears == Some(true) {
            out.push(Problem::ReadClears {
                code: code_label(schema, *key),
            });
        } else if opts.dataset && dataset_code(schema) == Some(key.number) {
            out.push(Problem::DatasetCode {
                code: code_label(schema, *key),
            });
        } else if let Some(value) = set.values.get(key)
            && let Some((_, message, help)) =
                driveset_schema::role::refusal(schema, code, *key, value)
        {
            // no override: a set never starts a motor or runs a command
            out.push(Problem::Role { message, help });
        }
    }
    match opts.running {
        Running::Known(true) if !opts.overrides.allow_running => out.push(Problem::Running),
        Running::Unknown if !opts.overrides.allow_running_unknown => {
            out.push(Problem::RunningUnknown {
                schema: schema.id.clone(),
            })
        }
        _ => {}
    }
    out
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
    if opts.overrides.allow_family && set.schema != schema.id {
        warnings.push(format!(
            "{}: set for schema `{}` uploaded with schema `{}`",
            Override::AllowFamily,
            set.schema,
            schema.id
        ));
    }
    match opts.running {
        Running::Known(true) if opts.overrides.allow_running => warnings.push(format!(
            "{}: the drive reports a running motor",
            Override::AllowRunning
        )),
        Running::Unknown if opts.overrides.allow_running_unknown => warnings.push(format!(
            "running state unknown ({}): {}",
            Override::AllowRunningUnknown,
            running_unknown_why(schema)
        )),
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
            if opts.overrides.allow_address_change {
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
        let ack_delay = family.ack_delay(code, true);
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

    /// Expected duration on `client`'s wire times, following the runner's
    /// schedule: read back the set's codes (`set_codes` of them), the
    /// dataset (SLOAD -1, staged writes, SLOAD -2, one poll), then the other
    /// writes; before an EEPROM write that would wait, verification reads
    /// of earlier writes that fit in the gap, then the rest of the gap;
    /// finally the verification reads left over.
    pub fn estimate(&self, set: &ResolvedSet, client: &dyn DriveClient) -> TimeEstimate {
        let mut est = TimeEstimate::default();
        for k in set.values.keys() {
            est.read_back += client.read_time(*k);
        }
        let mut t = est.read_back;
        let mut pending: std::collections::VecDeque<CodeKey> = Default::default();
        let sload = CodeKey::new(driveset_schema::family::SLOAD.code);
        if self.dataset {
            let mut d = client.write_time(sload);
            for w in self.writes.iter().filter(|w| w.phase == Phase::Dataset) {
                d += client.write_time(w.key);
                pending.push_back(w.key);
            }
            d += client.write_time(sload) + client.read_time(sload);
            est.writes += d;
            t += d;
        }
        let mut busy_until: Option<Duration> = None;
        for w in self.writes.iter().filter(|w| w.phase != Phase::Dataset) {
            if w.storage == Storage::Eeprom
                && let Some(ready) = busy_until
                && ready > t
            {
                while let Some(i) = pending
                    .iter()
                    .position(|k| t + client.read_time(*k) <= ready)
                {
                    if let Some(k) = pending.remove(i) {
                        let r = client.read_time(k);
                        est.verify += r;
                        t += r;
                    }
                }
                est.waits += ready.saturating_sub(t);
                t = t.max(ready);
            }
            let d = client.write_time(w.key) + w.ack_delay;
            est.writes += d;
            t += d;
            if !w.store_time.is_zero() {
                busy_until = Some(t + w.store_time);
            }
            pending.push_back(w.key);
        }
        for k in pending {
            let r = client.read_time(k);
            est.verify += r;
            t += r;
        }
        est.total = t;
        est
    }

    /// The `--dry-run` text: codes, old -> new (engineering units, labels;
    /// passwords redacted), storage, and the expected time.
    pub fn render(&self, estimate: Option<&TimeEstimate>) -> String {
        let mut out = String::new();
        let total = self.writes.len() + self.unchanged.len();
        let _ = writeln!(
            out,
            "plan: {} of {total} codes differ (schema {}, set {})",
            self.writes.len(),
            self.schema,
            self.set_fingerprint
        );
        for w in &self.warnings {
            let _ = writeln!(out, "warning: {w}");
        }
        let mut phase = None;
        for w in &self.writes {
            if phase != Some(w.phase) {
                phase = Some(w.phase);
                let head = match w.phase {
                    Phase::Dataset => {
                        "dataset download (SLOAD = -1, CardWriteable values, SLOAD = -2, drive checks the set):"
                    }
                    Phase::Stored => "configuration values:",
                    Phase::Control => "control values (act at once):",
                    Phase::Mode => "operating mode / control source:",
                    Phase::Link => {
                        "serial interface (last; baud rates take effect after a restart):"
                    }
                };
                let _ = writeln!(out, "  {head}");
            }
            let storage = match (w.storage, w.width) {
                (Storage::Ram, _) => "RAM".to_string(),
                (Storage::FselIsel, _) => "FSEL/ISEL (RAM at CSEL=3, else EEPROM)".to_string(),
                (Storage::Eeprom, Some(b)) => format!("EEPROM {b} B"),
                (Storage::Eeprom, None) => "EEPROM".to_string(),
                (Storage::CardWriteable, Some(b)) => format!("CardWriteable, EEPROM {b} B"),
                (Storage::CardWriteable, None) => "CardWriteable".to_string(),
                (Storage::Unspecified, _) => "stored by the drive".to_string(),
            };
            let mut extra = String::new();
            if !w.store_time.is_zero() {
                let _ = write!(extra, ", store {} ms", w.store_time.as_millis());
            }
            if !w.ack_delay.is_zero() {
                let _ = write!(extra, ", ACK delay {} ms", w.ack_delay.as_millis());
            }
            let _ = writeln!(
                out,
                "    {}: {} -> {}  [{storage}{extra}]",
                w.label, w.old_text, w.new_text
            );
        }
        if let Some(e) = estimate {
            let _ = write!(
                out,
                "expected time: {:.3} s (read back {:.3} s, writes {:.3} s, verify {:.3} s, EEPROM waits {:.3} s)",
                e.total.as_secs_f64(),
                e.read_back.as_secs_f64(),
                e.writes.as_secs_f64(),
                e.verify.as_secs_f64(),
                e.waits.as_secs_f64()
            );
            if self.dataset {
                let _ = write!(
                    out,
                    " plus the drive's dataset check (up to {} s)",
                    DATASET_TIMEOUT.as_secs()
                );
            }
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_problem_renders_its_message() {
        let s = |x: &str| x.to_string();
        let cases = vec![
            (
                Problem::SetSchema {
                    set: s("a"),
                    schema: s("b"),
                },
                "the set is for schema `a` but the drive is handled with schema `b`; upload a set for this drive family, or pass --allow-family if they are compatible",
            ),
            (
                Problem::ProtocolFamily {
                    found: s("lecom"),
                    schema: s("b"),
                    want: s("lustbus-mc"),
                },
                "the drive identifies as protocol family `lecom`, schema `b` is for `lustbus-mc`; check the address, or pass --allow-family",
            ),
            (
                Problem::DriveType {
                    found: 9999,
                    schema: s("b"),
                    expected: vec![1234],
                },
                "the drive reports 91-TYPE 9999, schema `b` is for TYPE [1234]; check the address, or pass --allow-family",
            ),
            (
                Problem::NotInSchema {
                    code: s("999"),
                    schema: s("b"),
                },
                "code 999 is not in schema `b`; remove it from the set (or fix the number)",
            ),
            (
                Problem::SubcodeRange {
                    code: s("C0039/9"),
                    number: 39,
                    subcodes: 8,
                },
                "C0039/9: code 39 has subcodes 1..=8 only; fix the subcode",
            ),
            (
                Problem::NoSubcodes {
                    code: s("C0011/1"),
                    number: 11,
                    schema: s("b"),
                },
                "C0011/1: code 11 has no subcodes in schema `b`; drop the /subcode",
            ),
            (
                Problem::ReadOnly { code: s("140-ACT") },
                "140-ACT: read-only (an actual value); remove it from the set",
            ),
            (
                Problem::ReadClears { code: s("85-SERR") },
                "85-SERR: a status code that reading clears; it cannot be part of a set, remove it",
            ),
            (
                Problem::DatasetCode {
                    code: s("80-SLOAD"),
                },
                "80-SLOAD: the dataset handshake code is driven by the upload itself; remove it from the set",
            ),
            (
                Problem::Role {
                    message: s("C0002 = 1 is a command"),
                    help: s("run it on the drive"),
                },
                "C0002 = 1 is a command; run it on the drive",
            ),
            (
                Problem::Running,
                "the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running",
            ),
            (
                Problem::RunningUnknown { schema: s("b") },
                "running state unknown: schema `b` names no status bit (role `running`) or control word start bit that says whether the motor runs; make sure the drive is at standstill, then pass --allow-running-unknown",
            ),
            (
                Problem::NotRead {
                    code: s("C0011 nmax"),
                },
                "C0011 nmax: the drive's current value was not read; it cannot be backed up",
            ),
            (
                Problem::AddressChange {
                    code: s("82-SADDR"),
                    old: s("1"),
                    new: s("4"),
                },
                "82-SADDR: 1 -> 4 changes the bus address of the drive being talked to; it would stop answering mid-transaction. Upload the set to the drive at its new address after changing the address on its own (or pass --allow-address-change)",
            ),
        ];
        for (p, want) in cases {
            assert_eq!(p.to_string(), want, "{p:?}");
        }
    }
}
