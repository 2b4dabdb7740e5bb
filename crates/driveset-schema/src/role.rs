//! Owns the code roles of a schema (docs/file-formats.md, "Code roles"):
//! which codes are not ordinary settings (control words, setpoints,
//! commands, operating mode and control source switches, the bus address
//! and baud rate, identify and status codes, passwords), what the bits of a
//! control word do (start, enable, release, inhibit, reset) and which status
//! bit says the motor is running. The planner, `pull`, the simulator and the
//! CLI read roles from here; no other place hard-codes what a code number
//! means.
//!
//! Roles are facts of the specs; every schema file cites the section per
//! code (LUSTBUS §7.1.1 3-CNTL, §7.2.1 416-SCTL1, §10 exception 1 PROG,
//! §11.4 SLOAD, §11.5 SBAUD / PROG 111; LECOM-A/B manual Table 1 C0002,
//! C0009, C0040, C0043, C0046, C0135, C0150 ...).

use std::fmt;

use crate::canonical::RawValue;
use crate::schema::{BitField, Code, Schema};

/// What a code is for, where it is not an ordinary setting (`role = "..."`
/// on `[[code]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Role {
    /// A control word: its bits start, enable or release the drive
    /// ([`BitRole`]). A set may hold it only in a stopped / inhibited state.
    ControlWord,
    /// A setpoint (frequency, speed, torque) that acts at once.
    Setpoint,
    /// A command: writing it makes the drive act (factory reset, dataset
    /// handshake, fault reset, baud activation). A set never holds one.
    Command,
    /// Switches the operating mode (Tmd C0014).
    OperatingMode,
    /// Selects where setpoints and control come from (Tmd C0001, VF1000
    /// 2-CSEL); on a Tmd it also decides whether LECOM may write at all.
    ControlSource,
    /// The drive's own bus address: a change cuts the transaction off.
    BusAddress,
    /// The drive's baud rate: effective after a restart.
    BaudRate,
    /// Read to identify the drive (`[schema.identify] codes`; not a key).
    Identify,
    /// A status word the drive reports.
    Status,
    /// A secret: never printed, never fingerprinted by value.
    Password,
}

impl Role {
    /// Every role, in the order the file format lists them.
    pub const ALL: [Role; 10] = [
        Role::ControlWord,
        Role::Setpoint,
        Role::Command,
        Role::OperatingMode,
        Role::ControlSource,
        Role::BusAddress,
        Role::BaudRate,
        Role::Identify,
        Role::Status,
        Role::Password,
    ];

    /// The name in schema files.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::ControlWord => "control-word",
            Role::Setpoint => "setpoint",
            Role::Command => "command",
            Role::OperatingMode => "operating-mode",
            Role::ControlSource => "control-source",
            Role::BusAddress => "bus-address",
            Role::BaudRate => "baud-rate",
            Role::Identify => "identify",
            Role::Status => "status",
            Role::Password => "password",
        }
    }

    /// Parse a schema file's `role` (identify is not accepted: it is
    /// `[schema.identify] codes`).
    pub fn parse(s: &str) -> Option<Role> {
        Role::ALL
            .into_iter()
            .find(|r| r.as_str() == s && *r != Role::Identify)
    }

    /// Whether `pull` leaves codes of this role out of a pulled set: a set
    /// must not hold commands or a control word (it could start a motor
    /// when uploaded back), and a password never lands in a file.
    pub fn left_out_of_pulled_sets(self) -> bool {
        matches!(self, Role::Command | Role::ControlWord | Role::Password)
    }

    /// Whether the code sets how the drive is reached on its bus (its
    /// address or its line rate): the line manifest owns these facts, so
    /// `pull` leaves such codes out of a pulled set unless asked, and
    /// `validate MANIFEST` reports a set whose value disagrees with the
    /// manifest (docs/file-formats.md, "The manifest's address is the truth").
    pub fn is_bus_link(self) -> bool {
        matches!(self, Role::BusAddress | Role::BaudRate)
    }
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What a one-bit member of a control word or status word does
/// (`role = "..."` on `[[code.bits]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BitRole {
    /// Control word: set = start the motor (VF1000 3-CNTL bit 7 "start
    /// clockwise", MC 416-SCTL1 bit 0 "start").
    Start,
    /// Control word: set = enable the controller (Tmd C0040 = 1).
    Enable,
    /// Control word: set = release (a brake, a hold).
    Release,
    /// Control word: set = the drive is inhibited or stopped whatever else
    /// is set (Tmd C0135 bit 9 controller inhibit, bit 3 quick stop).
    Inhibit,
    /// Control word: set = a command (fault reset edge: Tmd C0135 bit 11,
    /// MC 416-SCTL1 bit 7).
    Reset,
    /// Status word: set = the motor is powered / running (Tmd C0150 bit 1
    /// power stage energized).
    Running,
}

impl BitRole {
    /// Every bit role.
    pub const ALL: [BitRole; 6] = [
        BitRole::Start,
        BitRole::Enable,
        BitRole::Release,
        BitRole::Inhibit,
        BitRole::Reset,
        BitRole::Running,
    ];

    /// The name in schema files.
    pub fn as_str(self) -> &'static str {
        match self {
            BitRole::Start => "start",
            BitRole::Enable => "enable",
            BitRole::Release => "release",
            BitRole::Inhibit => "inhibit",
            BitRole::Reset => "reset",
            BitRole::Running => "running",
        }
    }

    /// Parse a bit field's `role`.
    pub fn parse(s: &str) -> Option<BitRole> {
        BitRole::ALL.into_iter().find(|r| r.as_str() == s)
    }

    /// The code role a bit of this role belongs to.
    pub fn code_role(self) -> Role {
        match self {
            BitRole::Running => Role::Status,
            _ => Role::ControlWord,
        }
    }

    /// Whether a set bit of this role lets the motor move.
    pub fn moves(self) -> bool {
        matches!(self, BitRole::Start | BitRole::Enable | BitRole::Release)
    }
}

impl fmt::Display for BitRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The state a control word value puts the drive in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ControlState {
    /// No start / enable / release bit is set: the motor stays stopped.
    Stopped,
    /// An inhibit bit is set (named): the drive is inhibited whatever else
    /// is set.
    Inhibited(String),
    /// These start / enable / release bits are set (member names).
    Moving(Vec<String>),
    /// The schema knows the inhibit bits and none is set: the drive is
    /// enabled and may follow its setpoint (the inhibit members' names).
    NotInhibited(Vec<String>),
    /// These reset bits are set: the value is a command (member names).
    Command(Vec<String>),
    /// The schema documents no start / enable / inhibit bits of this
    /// control word, so no value is known to be stopped.
    Unknown,
}

impl ControlState {
    /// Whether a set may hold this value.
    pub fn is_safe(&self) -> bool {
        matches!(self, ControlState::Stopped | ControlState::Inhibited(_))
    }
}

fn bit_set(b: &BitField, raw: i64) -> bool {
    b.extract(raw) != 0
}

/// Where a drive says whether its motor runs: a status bit with role
/// `running`, else a control word's `start` bit (LUSTBUS drives report
/// their control word).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunningIndicator {
    /// Code number.
    pub code: u32,
    /// Bit (0 = least significant).
    pub bit: u32,
    /// The role of the code read (status or control word).
    pub from: Role,
}

impl Code {
    /// The code's role, if it is not an ordinary setting.
    pub fn role(&self) -> Option<Role> {
        self.role
    }

    /// Whether the code has this role.
    pub fn has_role(&self, role: Role) -> bool {
        self.role == Some(role)
    }

    /// Bit fields with a role.
    pub fn bits_with_role(&self, role: BitRole) -> impl Iterator<Item = &BitField> {
        self.bits.iter().filter(move |b| b.role == Some(role))
    }

    /// The state a value of this control word puts the drive in (LUSTBUS
    /// §7.1.1 / §7.2.1, LECOM manual Table 1 C0040 / C0135). Resets come
    /// first (they are commands whatever the rest says), then inhibit bits,
    /// then start / enable / release bits.
    ///
    /// `stopped_raw` are the code's `stopped` values as raw values
    /// ([`Schema::control_state`] converts them): for a control word
    /// without bit roles, a value among them is inhibited, any other moves.
    pub fn control_state_with(&self, raw: &RawValue, stopped_raw: &[i64]) -> ControlState {
        let RawValue::Int(v) = raw else {
            return ControlState::Unknown;
        };
        let names = |role: BitRole| -> Vec<String> {
            self.bits_with_role(role)
                .filter(|b| bit_set(b, *v))
                .map(|b| b.name.clone())
                .collect()
        };
        let resets = names(BitRole::Reset);
        if !resets.is_empty() {
            return ControlState::Command(resets);
        }
        if !stopped_raw.is_empty() {
            // The stopped values decide, whatever bit roles the code has:
            // a value among them is inhibited, any other may move.
            return if stopped_raw.contains(v) {
                ControlState::Inhibited(self.name.clone())
            } else {
                ControlState::Moving(
                    names(BitRole::Start)
                        .into_iter()
                        .chain(names(BitRole::Enable))
                        .chain(names(BitRole::Release))
                        .collect(),
                )
            };
        }
        if let Some(b) = self
            .bits_with_role(BitRole::Inhibit)
            .find(|b| bit_set(b, *v))
        {
            return ControlState::Inhibited(b.name.clone());
        }
        let moving: Vec<String> = self
            .bits
            .iter()
            .filter(|b| b.role.is_some_and(BitRole::moves) && bit_set(b, *v))
            .map(|b| b.name.clone())
            .collect();
        if !moving.is_empty() {
            return ControlState::Moving(moving);
        }
        let has_moving = self.bits.iter().any(|b| b.role.is_some_and(BitRole::moves));
        let inhibits: Vec<String> = self
            .bits_with_role(BitRole::Inhibit)
            .map(|b| b.name.clone())
            .collect();
        if has_moving {
            ControlState::Stopped
        } else if !inhibits.is_empty() {
            ControlState::NotInhibited(inhibits)
        } else {
            ControlState::Unknown
        }
    }
}

impl Schema {
    /// The state a value of control word `code` puts the drive in (see
    /// [`Code::control_state_with`]; the `stopped` values are engineering
    /// integers, converted with the code's type).
    pub fn control_state(&self, code: &Code, raw: &RawValue) -> ControlState {
        let stopped: Vec<i64> = match self.type_of(code) {
            Some(ty) => code
                .stopped
                .iter()
                .filter_map(|v| {
                    crate::value::decimal_to_raw(
                        ty,
                        code.width,
                        &crate::Decimal::from_int(i128::from(*v)),
                    )
                    .ok()
                })
                .collect(),
            None => Vec::new(),
        };
        code.control_state_with(raw, &stopped)
    }

    /// Codes with a role, in file order.
    pub fn codes_with_role(&self, role: Role) -> impl Iterator<Item = &Code> {
        self.codes.iter().filter(move |c| c.role == Some(role))
    }

    /// Whether code `number` has `role`.
    pub fn has_role(&self, number: u32, role: Role) -> bool {
        self.code(number).is_some_and(|c| c.has_role(role))
    }

    /// The role of code `number`.
    pub fn role_of(&self, number: u32) -> Option<Role> {
        self.code(number).and_then(Code::role)
    }

    /// Where the drive reports a running motor: the first status code (file
    /// order) with a `running` bit, else the first control word with a
    /// `start` bit; `None` when the schema has neither (the running state
    /// cannot be known: Lenze ECS, whose excerpt documents no bits).
    pub fn running_indicator(&self) -> Option<RunningIndicator> {
        let find = |role: Role, bit: BitRole| {
            self.codes_with_role(role).find_map(|c| {
                c.bits_with_role(bit).next().map(|b| RunningIndicator {
                    code: c.number,
                    bit: b.lsb,
                    from: role,
                })
            })
        };
        find(Role::Status, BitRole::Running).or_else(|| find(Role::ControlWord, BitRole::Start))
    }
}

/// Why a set may not hold `raw` for `code`, as (kind, message, help): a
/// command, or a control word in a state other than stopped / inhibited.
/// `None` for every other code and for a safe control word value. The
/// message names the code and the bits; it never holds a secret (commands
/// and control words are not secrets).
pub fn refusal(
    schema: &Schema,
    code: &Code,
    key: crate::CodeKey,
    raw: &RawValue,
) -> Option<(crate::FindingKind, String, String)> {
    use crate::FindingKind;
    // every value of every set passes here: nothing is formatted for a
    // code without a role (the names and value text below cost more than
    // the whole check, issue 33's validate_many)
    let role = code.role?;
    let shown = || {
        (
            schema.display_code(key.number, key.subcode),
            crate::validate::display_value(schema, code, raw),
        )
    };
    let title = code.title.as_deref().unwrap_or(&code.name);
    match role {
        Role::Command => Some((
            FindingKind::Command,
            {
                let (shown, value) = shown();
                format!(
                    "{shown} = {value} is a command ({title}), not a setting; a set cannot hold it"
                )
            },
            "remove this line: run the command on the drive itself, never from a set".into(),
        )),
        Role::ControlWord => {
            let (why, help) = match schema.control_state(code, raw) {
                ControlState::Stopped | ControlState::Inhibited(_) => return None,
                ControlState::Moving(bits) if bits.is_empty() => {
                    let stopped: Vec<String> = code
                        .stopped
                        .iter()
                        .map(|v| match code
                            .values
                            .as_ref()
                            .and_then(|e| schema.enum_of(e))
                            .and_then(|e| e.label(*v))
                        {
                            Some(l) => format!("{v} \"{l}\""),
                            None => v.to_string(),
                        })
                        .collect();
                    (
                        format!(
                            "would enable the drive (the stopped values are {})",
                            stopped.join(", ")
                        ),
                        format!(
                            "write {} or remove this line; a set may hold a control word only in a stopped or inhibited state",
                            stopped.join(" or ")
                        ),
                    )
                }
                ControlState::Moving(bits) => (
                    format!("would start or enable the drive ({} set)", bits.join(", ")),
                    format!(
                        "clear {} or remove this line; a set may hold a control word only in a stopped or inhibited state",
                        bits.join(", ")
                    ),
                ),
                ControlState::NotInhibited(inhibits) => (
                    format!(
                        "leaves the drive enabled (none of {} set)",
                        inhibits.join(", ")
                    ),
                    format!(
                        "set {} or remove this line; a set may hold a control word only in a stopped or inhibited state",
                        inhibits.join(" or ")
                    ),
                ),
                ControlState::Command(bits) => (
                    format!("holds a command ({} set)", bits.join(", ")),
                    format!("clear {} or remove this line", bits.join(", ")),
                ),
                ControlState::Unknown => (
                    "is a control word whose start, enable and inhibit bits the schema does not name, so no value is known to keep the drive stopped".to_string(),
                    "remove this line; control the drive from the control system, not from a set".to_string(),
                ),
            };
            let (shown, value) = shown();
            Some((
                FindingKind::ControlWordNotStopped,
                format!("{shown} = {value} {why}"),
                help,
            ))
        }
        _ => None,
    }
}
