//! Owns the one write guard: every telegram that changes a drive (LUSTBUS
//! SELECT and broadcast, LECOM SEND, BROADCAST and MULTICAST, CAN SDO
//! download) is built here, after `check` cleared it, whatever command
//! or step asked for it (upload, rollback, recover, commission, broadcast,
//! the `--transfer-baud` switch, the MC dataset handshake, schema pull's
//! text selector). The clients call these builders on their write path;
//! nothing else in the engine constructs a writing telegram (a tidy test
//! holds the codecs' constructors to this module).
//!
//! The rules (docs/architecture.md, "The write guard"), on the schema's
//! roles, which hold at least the family's floor
//! (`driveset_schema::family::FloorRole`):
//!
//! - a control word is written only in a stopped or inhibited state
//!   (`driveset_schema::ControlState::is_safe`): never a value that sets a
//!   start, enable or release bit, a reset bit, or one the schema cannot
//!   show to be stopped; a stop writes the stopped state and nothing else;
//! - a command is never written, except the engine's own named operations,
//!   each with its [`Permit`], which covers exactly its code and values:
//!   the MC6000/7000 dataset handshake (80-SLOAD = -1 / -2, LUSTBUS §11.4),
//!   the online rate activation (4-PROG = 111, §11.5);
//! - the `--transfer-baud` switch writes the rate code only with one of the
//!   family's rates (permit `RATE_SWITCH`, §4, §11.5); schema pull's
//!   108-STEXT selector (permit `TEXT_SELECTOR`, §11.3) only on an MC;
//! - `driveset address` (`crate::assign`) writes the family's bus-address
//!   code only with a drive's own address (permit `BUS_ADDRESS`, §4.2,
//!   Tmd §4c) and its rate code only with a value coding one of the
//!   family's rates (permit `LINE_RATE`, §4, §11.5, Tmd C0125).
//!
//! - **No address, rate or rate activation to a running drive**
//!   (`standstill`): the permits of the writes that change how a drive
//!   is reached (`BUS_ADDRESS`, `LINE_RATE`, `ACTIVATE_RATE` as
//!   `driveset address`, `replace` and `commission --assign` send them,
//!   `crate::assign`) are made only from a `Standstill`, the proof that
//!   the drive was asked whether its motor runs and does not (a running
//!   drive is refused unless `--allow-running`, one whose running state
//!   cannot be read unless `--allow-running-unknown`: the upload's
//!   policy). The `--transfer-baud` switch asks the same question with no
//!   override.
//!
//! The upload's running check (`--allow-running`) and the other named
//! overrides stay with the planner: they decide whether a transaction may
//! start; the guard decides what may be sent, and no override widens it.

use driveset_proto::can::{Index, SdoClient, SdoRequest, Subindex};
use driveset_proto::lecom::{
    Broadcast, CodeAddress, ControllerAddress, EncodeError, Send, Telegram, Value,
};
use driveset_proto::lustbus::{Address, Dialect, ParameterCode, Select, TelegramBytes, ValueText};
use driveset_schema::{Code, CodeKey, ControlState, RawValue, Role, Schema};
use serde::{Deserialize, Serialize};

use crate::client::{Target, code_name, schema_code, shown_value};
use crate::error::{EngineError, Refusal};
use crate::overrides::{Override, Overrides};

/// Why a write is sent: an ordinary setting ([`Permit::SETTING`], the full
/// rules), or one of the engine's own named operations, which only the
/// engine can name (the other constants are crate-private).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Permit(Kind);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Setting,
    DatasetBegin,
    DatasetCommit,
    ActivateRate,
    RateSwitch,
    TextSelector,
    BusAddress,
    LineRate,
    Store,
}

impl Permit {
    /// An ordinary setting (a set's value, a rollback's or recover's old
    /// value, a broadcast value): commands and moving control word values
    /// are refused.
    pub const SETTING: Permit = Permit(Kind::Setting);
    /// MC6000/7000 80-SLOAD = -1 (LUSTBUS §11.4).
    pub(crate) const DATASET_BEGIN: Permit = Permit(Kind::DatasetBegin);
    /// MC6000/7000 80-SLOAD = -2 (LUSTBUS §11.4).
    pub(crate) const DATASET_COMMIT: Permit = Permit(Kind::DatasetCommit);
    /// MC6000/7000 4-PROG = 111: activate the rate 81-SBAUD holds (§11.5).
    pub(crate) const ACTIVATE_RATE: Permit = Permit(Kind::ActivateRate);
    /// The `--transfer-baud` switch: the rate code to one of the family's
    /// rates (§4, §11.5).
    pub(crate) const RATE_SWITCH: Permit = Permit(Kind::RateSwitch);
    /// MC6000/7000 108-STEXT, the RAM selector of substitution texts
    /// (§11.3, schema pull).
    pub(crate) const TEXT_SELECTOR: Permit = Permit(Kind::TextSelector);

    /// `driveset address`: the family's bus-address code (its floor role
    /// `bus-address`: LUSTBUS 82-SIOA/SADDR §4.2, Tmd C0009 §4c) to a
    /// drive's own address ([`driveset_schema::BusProtocol::check_address`]),
    /// only to a drive at `Standstill`.
    pub(crate) fn bus_address(_still: &Standstill) -> Permit {
        Permit(Kind::BusAddress)
    }

    /// `driveset address --baud`: the family's rate code (81-SIOC/SBAUD
    /// §4, §11.5; Tmd C0125) to a value that codes one of the family's
    /// rates, only to a drive at `Standstill`.
    pub(crate) fn line_rate(_still: &Standstill) -> Permit {
        Permit(Kind::LineRate)
    }

    /// [`Permit::ACTIVATE_RATE`] for `driveset address --baud`, only to a
    /// drive at `Standstill`.
    pub(crate) fn activate_rate(_still: &Standstill) -> Permit {
        Permit::ACTIVATE_RATE
    }

    /// The store step after a verified upload: the schema's store code to
    /// the one value that stores (`[schema.store]`, CiA 301 0x1010 sub 1
    /// = "save").
    pub(crate) const STORE: Permit = Permit(Kind::Store);

    /// The permit's name in messages.
    pub fn name(self) -> &'static str {
        match self.0 {
            Kind::Setting => "setting",
            Kind::DatasetBegin => "dataset-begin (80-SLOAD = -1)",
            Kind::DatasetCommit => "dataset-commit (80-SLOAD = -2)",
            Kind::ActivateRate => "activate-rate (4-PROG = 111)",
            Kind::RateSwitch => "rate-switch",
            Kind::TextSelector => "text-selector (108-STEXT)",
            Kind::BusAddress => "bus-address",
            Kind::LineRate => "line-rate",
            Kind::Store => "store",
        }
    }
}

/// Why the guard refused a write (`check`; gathered into [`Refusal`] as
/// `Refusal::Guard`, each with the JSON kind journals hold: `guard_command`,
/// `guard_control_word`, `guard_permit`). Nothing was sent.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind")]
pub enum GuardRefusal {
    /// A command, whatever asked for it (only the engine's own named
    /// operations pass, with their permit).
    #[error(
        "{code} = {value} is a command: driveset never writes one (only its own named steps: the SLOAD handshake, PROG = 111 activating a rate); run it on the drive itself"
    )]
    #[serde(rename = "guard_command")]
    Command {
        /// The code.
        code: String,
        /// The value (never a password's).
        value: String,
    },
    /// A control word value that is not a stopped or inhibited state (it
    /// would start, enable or release the drive, or is a reset command),
    /// whatever asked for it.
    #[error(
        "{code} = {value} {why}: driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control"
    )]
    #[serde(rename = "guard_control_word")]
    ControlWord {
        /// The code.
        code: String,
        /// The value.
        value: String,
        /// The state the value puts the drive in.
        why: String,
    },
    /// A permit used for a code or value it does not name (a caller's
    /// mistake; nothing is sent).
    #[error("the {permit} permit does not cover {code} = {value}; nothing was sent")]
    #[serde(rename = "guard_permit")]
    Permit {
        /// The permit's name.
        permit: String,
        /// The code.
        code: String,
        /// The value.
        value: String,
    },
    /// The drive reports a running motor, and its bus address or line rate
    /// would be written (`standstill`; lifted by `--allow-running`).
    #[error(
        "the drive reports a running motor; driveset changes a drive's bus address or line rate only at standstill: stop it (standstill), or pass {}",
        Override::AllowRunning
    )]
    #[serde(rename = "guard_running")]
    Running,
    /// The drive's running state cannot be read, and its bus address or
    /// line rate would be written (`standstill`; lifted by
    /// `--allow-running-unknown`).
    #[error(
        "running state unknown: {why}; driveset changes a drive's bus address or line rate only at standstill: make sure the drive is at standstill, then pass {}",
        Override::AllowRunningUnknown
    )]
    #[serde(rename = "guard_running_unknown")]
    RunningUnknown {
        /// Why it cannot be read.
        why: String,
    },
}

/// Proof that `standstill` let the writes that change how a drive is
/// reached through; [`Permit::bus_address`], [`Permit::line_rate`] and
/// [`Permit::activate_rate`] take it. Only `standstill` makes one.
#[derive(Debug)]
pub(crate) struct Standstill {
    _private: (),
}

/// The running rule of the bus address, the line rate and its activation
/// (module docs): the drive is asked (`DriveClient::running`) before
/// anything is sent; a running motor is refused unless `overrides` allow
/// [`Override::AllowRunning`], an unknown running state unless they allow
/// [`Override::AllowRunningUnknown`] (the upload's policy, its planner's
/// `Problem::Running`). `Err`: [`GuardRefusal::Running`] /
/// [`GuardRefusal::RunningUnknown`]; nothing was written.
pub(crate) fn standstill(
    client: &mut dyn crate::client::DriveClient,
    overrides: Overrides,
) -> Result<Standstill, EngineError> {
    let refusal = match client.running()? {
        Some(false) => None,
        Some(true) if overrides.allows(Override::AllowRunning) => None,
        Some(true) => Some(GuardRefusal::Running),
        None if overrides.allows(Override::AllowRunningUnknown) => None,
        None => Some(GuardRefusal::RunningUnknown {
            why: crate::plan::running_unknown_why(client.schema()),
        }),
    };
    match refusal {
        None => Ok(Standstill { _private: () }),
        Some(r) => Err(EngineError::refused(client.target().clone(), r)),
    }
}

/// Proof that [`check`] let one write through; the builders below take it.
/// Only [`check`] makes one.
#[derive(Debug)]
pub(crate) struct Cleared {
    _private: (),
}

/// The one gate: whether `raw` may be written to `key` of the drive
/// `target` (schema `schema`) under `permit`. `Err` is a typed
/// [`Refusal`]: a [`GuardRefusal`] (`Refusal::Guard`), or
/// `UnknownCode`; nothing is sent.
pub(crate) fn check(
    schema: &Schema,
    target: &Target,
    key: CodeKey,
    raw: &RawValue,
    permit: Permit,
) -> Result<Cleared, EngineError> {
    let refuse = |r: Refusal| Err(EngineError::refused(target.clone(), r));
    let guard = |r: GuardRefusal| Err(EngineError::refused(target.clone(), r));
    let code = match (permit.0, schema.code(key.number)) {
        (Kind::TextSelector, None) => None,
        _ => Some(schema_code(schema, target, key)?),
    };
    let d = schema.family.descriptor();
    let value = || match code {
        Some(c) if !schema.is_password(c) => {
            driveset_schema::validate::display_value(schema, c, raw)
        }
        _ => shown_value(schema, key, raw),
    };
    let int = match raw {
        RawValue::Int(v) => Some(*v),
        _ => None,
    };
    let named = match permit.0 {
        Kind::Setting => None,
        Kind::DatasetBegin => Some(d.dataset.is_some_and(|h| {
            key.number == h.code && key.subcode.is_none() && int == Some(h.begin)
        })),
        Kind::DatasetCommit => Some(d.dataset.is_some_and(|h| {
            key.number == h.code && key.subcode.is_none() && int == Some(h.commit)
        })),
        Kind::ActivateRate => Some(d.line_rates.online.is_some_and(|o| {
            key.number == o.command && key.subcode.is_none() && int == Some(o.activate)
        })),
        Kind::RateSwitch => Some(
            d.line_rates.code == Some(key.number)
                && key.subcode.is_none()
                && int.is_some_and(|v| {
                    u32::try_from(v).is_ok_and(|r| d.line_rates.rates.contains(&r))
                }),
        ),
        Kind::BusAddress => Some(
            crate::assign::address_code(schema.family) == Some(key)
                && crate::assign::address_of_raw(schema, key, raw)
                    .is_some_and(|a| schema.family.bus().check_address(a).is_ok()),
        ),
        Kind::LineRate => Some(
            d.line_rates.code == Some(key.number)
                && key.subcode.is_none()
                && crate::assign::rate_of_raw(schema, key, raw)
                    .is_some_and(|r| d.line_rates.rates.contains(&r)),
        ),
        Kind::Store => Some(schema.store.command().is_some_and(|c| {
            key.number == c.code && key.subcode.is_none() && int == Some(c.value)
        })),
        // §11.3: the substitution texts are read through MC dialect codes
        // (61ppp), so only the family that speaks it has the selector
        Kind::TextSelector => Some(
            d.dialect == Some(Dialect::Mc)
                && key.number == u32::from(driveset_proto::lustbus::description::STEXT)
                && key.subcode.is_none()
                && code.is_none_or(|c| !matches!(c.role, Some(Role::Command | Role::ControlWord))),
        ),
    };
    match named {
        Some(true) => return Ok(Cleared { _private: () }),
        Some(false) => {
            return guard(GuardRefusal::Permit {
                permit: permit.name().to_string(),
                code: code_name(schema, key),
                value: value(),
            });
        }
        None => {}
    }
    let Some(code) = code else {
        return refuse(Refusal::UnknownCode {
            schema: schema.id.clone(),
            code: key.canonical(schema.code_style),
        });
    };
    match code.role {
        Some(Role::Command) => guard(GuardRefusal::Command {
            code: code_name(schema, key),
            value: value(),
        }),
        Some(Role::ControlWord) => match control_why(schema, code, raw) {
            None => Ok(Cleared { _private: () }),
            Some(why) => guard(GuardRefusal::ControlWord {
                code: code_name(schema, key),
                value: value(),
                why,
            }),
        },
        _ => Ok(Cleared { _private: () }),
    }
}

/// Why a control word value is not a stopped state (`None`: it is).
fn control_why(schema: &Schema, code: &Code, raw: &RawValue) -> Option<String> {
    match schema.control_state(code, raw) {
        ControlState::Stopped | ControlState::Inhibited(_) => None,
        ControlState::Moving(bits) if bits.is_empty() => Some(format!(
            "would enable the drive (the stopped values are {})",
            stopped_list(code)
        )),
        ControlState::Moving(bits) => Some(format!(
            "would start or enable the drive ({} set)",
            bits.join(", ")
        )),
        ControlState::NotInhibited(inh) => Some(format!(
            "sets none of the inhibit bits ({}): the drive would follow its setpoint",
            inh.join(", ")
        )),
        ControlState::Command(bits) => Some(format!(
            "is a command ({} set)",
            bits.join(", ")
        )),
        ControlState::Unknown => Some(
            "cannot be shown to be stopped: the schema documents no start, enable or inhibit bit of it"
                .to_string(),
        ),
    }
}

fn stopped_list(code: &Code) -> String {
    code.stopped
        .iter()
        .map(i64::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The stopped state a rollback or recover writes instead of `old`, a
/// control word value that is not stopped (the motor was running before
/// the transaction): the transaction's `new` value where it is a stopped
/// state (the stop the set asked for stays), else `old` with its start /
/// enable / release and reset bits cleared, else the first of the code's
/// `stopped` values. `None`: the schema knows no stopped state of the code
/// (nothing is written then).
pub fn stopped_instead(
    schema: &Schema,
    code: &Code,
    old: &RawValue,
    new: Option<&RawValue>,
) -> Option<RawValue> {
    if let Some(n) = new
        && control_why(schema, code, n).is_none()
    {
        return Some(n.clone());
    }
    let RawValue::Int(v) = old else {
        return None;
    };
    let cleared = {
        let mut cleared = *v;
        for b in code.bits.iter().filter(|b| {
            b.role
                .is_some_and(|r| r.moves() || r == driveset_schema::BitRole::Reset)
        }) {
            for bit in b.lsb..=b.msb.min(62) {
                cleared &= !(1i64 << bit);
            }
        }
        RawValue::Int(cleared)
    };
    if control_why(schema, code, &cleared).is_none() {
        return Some(cleared);
    }
    let candidate = if let Some(first) = code.stopped.first() {
        let ty = schema.type_of(code)?;
        RawValue::Int(
            driveset_schema::value::decimal_to_raw(
                ty,
                code.width,
                &driveset_schema::Decimal::from_int(i128::from(*first)),
            )
            .ok()?,
        )
    } else {
        return None;
    };
    control_why(schema, code, &candidate)
        .is_none()
        .then_some(candidate)
}

/// Whether a control word value is a stopped or inhibited state (`true`
/// for every code that is not a control word).
pub fn is_stopped(schema: &Schema, code: &Code, raw: &RawValue) -> bool {
    !code.has_role(Role::ControlWord) || control_why(schema, code, raw).is_none()
}

/// LUSTBUS SELECT (§5.1), to a drive or to address 31 (broadcast, §4.2).
pub(crate) fn lustbus_select(
    _cleared: &Cleared,
    to: Address,
    code: ParameterCode,
    value: ValueText,
) -> TelegramBytes {
    Select::new(to, code, value).encode()
}

/// LECOM SEND (8.I) to one controller.
pub(crate) fn lecom_send(
    _cleared: &Cleared,
    to: ControllerAddress,
    field: CodeAddress,
    value: Value,
) -> Result<Telegram, EncodeError> {
    Send::new(to, field, value).map(Telegram::Send)
}

/// LECOM BROADCAST / MULTICAST (8.J) to address 00 or a group x0.
pub(crate) fn lecom_broadcast(
    _cleared: &Cleared,
    to: ControllerAddress,
    field: CodeAddress,
    value: Value,
) -> Result<Telegram, EncodeError> {
    Broadcast::new(to, field, value).map(Telegram::Broadcast)
}

/// CAN SDO download (CiA 301 initiate download): the first frame.
pub(crate) fn sdo_download(
    _cleared: &Cleared,
    sdo: &mut SdoClient,
    index: Index,
    subindex: Subindex,
    data: &[u8],
) -> Result<SdoRequest, String> {
    sdo.start_write(index, subindex, data)
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    /// The proof a test of the permits stands on.
    const STILL: super::Standstill = super::Standstill { _private: () };

    use std::sync::Arc;

    use driveset_schema::error::SourceFile;
    use driveset_schema::{CodeKey, Family, RawValue, Registry, Schema};

    use super::{GuardRefusal, Permit, check};
    use crate::client::Target;
    use crate::error::assert_refusal_json;

    fn builtin(f: Family) -> Arc<Schema> {
        Registry::builtin()
            .expect("built-in schemas")
            .get(f.descriptor().schema_id)
            .expect("schema")
    }

    fn target() -> Target {
        Target {
            port: "p".into(),
            address: 1,
        }
    }

    /// The refusal text, or "ok".
    fn verdict(s: &Schema, number: u32, raw: i64, permit: Permit) -> String {
        match check(
            s,
            &target(),
            CodeKey::new(number),
            &RawValue::Int(raw),
            permit,
        ) {
            Ok(_) => "ok".into(),
            Err(e) => match e.refusal() {
                Some(r) => r.to_string(),
                None => panic!("not a refusal: {:?}", e.kind),
            },
        }
    }

    /// A schema whose drives keep writes only on command: CiA 301 0x1010
    /// sub 1 = "save" (`[schema.store]`).
    fn storing_schema() -> Arc<Schema> {
        let mut reg = Registry::builtin().expect("built-in schemas");
        reg.add_source(SourceFile::new(
            "store.toml",
            "[schema]\nid = \"store-test\"\ntitle = \"t\"\nextends = \"lenze-ecs\"\n\n[schema.store]\nkeeps = \"on-command\"\ncode = \"store_parameters\"\nvalue = 0x65766173\n\n[[code]]\nindex = 0x1010\nsubindex = 1\nname = \"store_parameters\"\ntitle = \"Save all parameters\"\nspec = \"CiA 301\"\ntype = \"UNSIGNED32\"\nrole = \"command\"\n\n[[code]]\nnumber = 5001\nname = \"x\"\ntitle = \"x\"\nspec = \"t\"\n".to_string(),
        ))
        .expect("the schema loads")
    }

    #[test]
    fn the_store_permit_covers_the_store_code_with_its_value_only() {
        let s = storing_schema();
        let store = driveset_schema::schema::index_number(0x1010, Some(1));
        assert_eq!(verdict(&s, store, 0x6576_6173, Permit::STORE), "ok");
        // a set's write of the store code is a command
        assert_eq!(
            verdict(&s, store, 0x6576_6173, Permit::SETTING),
            "0x1010sub1 = 1702257011 is a command: driveset never writes one (only its own named steps: the SLOAD handshake, PROG = 111 activating a rate); run it on the drive itself"
        );
        assert_eq!(
            verdict(&s, store, 1, Permit::STORE),
            "the store permit does not cover 0x1010sub1 = 1; nothing was sent"
        );
        assert!(
            verdict(&s, 5001, 0x6576_6173, Permit::STORE)
                .starts_with("the store permit does not cover")
        );
        // a schema without a store step (and without the object): refused
        let ecs = builtin(Family::Ecs);
        assert_ne!(verdict(&ecs, store, 0x6576_6173, Permit::STORE), "ok");
        assert!(
            verdict(&ecs, 135, 0, Permit::STORE).starts_with("the store permit does not cover")
        );
    }

    #[test]
    fn mc6000_control_word_and_commands() {
        let s = builtin(Family::Mc6000);
        let w = |n, v| verdict(&s, n, v, Permit::SETTING);
        assert_eq!(w(416, 0), "ok");
        assert_eq!(
            w(416, 1),
            "416-SCTL1 = { start = 1, error_reset = 0 } would start or enable the drive (start set): driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control"
        );
        assert_eq!(
            w(416, 0x80),
            "416-SCTL1 = { start = 0, error_reset = 1 } is a command (error_reset set): driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control"
        );
        let prog = "4-PROG = \"Load factory settings\" is a command: driveset never writes one (only its own named steps: the SLOAD handshake, PROG = 111 activating a rate); run it on the drive itself";
        assert_eq!(w(4, 1), prog);
        assert!(w(4, 111).contains(" is a command: driveset never writes one"));
        assert!(w(80, -1).starts_with("80-SLOAD = ") && w(80, -1).contains(" is a command"));
        // settings pass, the rate code as a set's value too
        assert_eq!(w(428, 1000), "ok");
        assert_eq!(w(81, 19200), "ok");
    }

    #[test]
    fn each_permit_covers_exactly_its_code_and_values() {
        let s = builtin(Family::Mc6000);
        let p = |n, v, permit| verdict(&s, n, v, permit);
        assert_eq!(p(80, -1, Permit::DATASET_BEGIN), "ok");
        assert_eq!(p(80, -2, Permit::DATASET_COMMIT), "ok");
        assert_eq!(p(4, 111, Permit::ACTIVATE_RATE), "ok");
        assert_eq!(p(81, 57600, Permit::RATE_SWITCH), "ok");
        assert_eq!(p(108, 3, Permit::TEXT_SELECTOR), "ok");
        assert_eq!(
            p(80, -2, Permit::DATASET_BEGIN),
            "the dataset-begin (80-SLOAD = -1) permit does not cover 80-SLOAD = \"End upload\"; nothing was sent"
        );
        assert_eq!(
            p(4, 1, Permit::ACTIVATE_RATE),
            "the activate-rate (4-PROG = 111) permit does not cover 4-PROG = \"Load factory settings\"; nothing was sent"
        );
        assert_eq!(
            p(416, 1, Permit::ACTIVATE_RATE),
            "the activate-rate (4-PROG = 111) permit does not cover 416-SCTL1 = { start = 1, error_reset = 0 }; nothing was sent"
        );
        assert_eq!(
            p(81, 12345, Permit::RATE_SWITCH),
            "the rate-switch permit does not cover 81-SBAUD = 12345; nothing was sent"
        );
        assert_eq!(
            p(4, 111, Permit::RATE_SWITCH),
            "the rate-switch permit does not cover 4-PROG = \"Activate new baud rate\"; nothing was sent"
        );
        // no handshake, no online rate on a VF1000 or a Tmd
        let vf = builtin(Family::Vf1000);
        assert!(verdict(&vf, 71, 111, Permit::ACTIVATE_RATE).starts_with("the activate-rate"));
        assert_ne!(verdict(&vf, 80, -1, Permit::DATASET_BEGIN), "ok");
        assert!(verdict(&vf, 108, 1, Permit::TEXT_SELECTOR).contains("permit does not cover"));
        assert!(verdict(&vf, 81, 57600, Permit::RATE_SWITCH).contains("permit does not cover"));
        assert_eq!(verdict(&vf, 81, 9600, Permit::RATE_SWITCH), "ok");
    }

    #[test]
    fn bus_address_and_line_rate_permits_cover_exactly_their_code_and_values() {
        let mc = builtin(Family::Mc6000);
        let vf = builtin(Family::Vf1000);
        let tmd = builtin(Family::Tmd);
        // the built-in LUSTBUS schemas give 82 no type: the raw figure
        assert_eq!(verdict(&mc, 82, 5, Permit::bus_address(&STILL)), "ok");
        assert_eq!(verdict(&vf, 82, 30, Permit::bus_address(&STILL)), "ok");
        for bad in [0, 31, 99] {
            assert_eq!(
                verdict(&mc, 82, bad, Permit::bus_address(&STILL)),
                format!("the bus-address permit does not cover 82-SADDR = {bad}; nothing was sent")
            );
        }
        assert!(
            verdict(&mc, 81, 5, Permit::bus_address(&STILL)).starts_with("the bus-address permit")
        );
        assert!(
            verdict(&mc, 4, 111, Permit::bus_address(&STILL)).starts_with("the bus-address permit")
        );
        // Tmd C0009 is VD: raw = address x 10000; group addresses refused
        assert_eq!(verdict(&tmd, 9, 120_000, Permit::bus_address(&STILL)), "ok");
        assert!(
            verdict(&tmd, 9, 200_000, Permit::bus_address(&STILL))
                .contains("permit does not cover")
        );
        assert!(
            verdict(&tmd, 9, 125_000, Permit::bus_address(&STILL))
                .contains("permit does not cover")
        );
        // rates: LUSTBUS the figure, the family's rates only; Tmd C0125 by its label
        assert_eq!(verdict(&mc, 81, 38400, Permit::line_rate(&STILL)), "ok");
        assert!(
            verdict(&vf, 81, 38400, Permit::line_rate(&STILL)).starts_with("the line-rate permit")
        );
        assert_eq!(verdict(&vf, 81, 4800, Permit::line_rate(&STILL)), "ok");
        assert_eq!(verdict(&tmd, 125, 30_000, Permit::line_rate(&STILL)), "ok");
        assert!(
            verdict(&tmd, 125, 40_000, Permit::line_rate(&STILL))
                .starts_with("the line-rate permit")
        );
        assert!(
            verdict(&mc, 82, 9600, Permit::line_rate(&STILL)).starts_with("the line-rate permit")
        );
    }

    #[test]
    fn vf1000_and_tmd_control_words() {
        let vf = builtin(Family::Vf1000);
        assert_eq!(verdict(&vf, 3, 0, Permit::SETTING), "ok");
        assert!(
            verdict(&vf, 3, 128, Permit::SETTING)
                .contains("would start or enable the drive (start_clockwise set)")
        );
        assert!(verdict(&vf, 11, 15, Permit::SETTING).contains("is a command"));
        let tmd = builtin(Family::Tmd);
        // C0040: VD, raw = value x 10000
        assert_eq!(verdict(&tmd, 40, 0, Permit::SETTING), "ok");
        assert!(
            verdict(&tmd, 40, 10_000, Permit::SETTING)
                .contains("would enable the drive (the stopped values are 0)"),
        );
        // C0135: bit 3 quick stop, bit 9 controller inhibit, bit 11 TRIP reset
        assert_eq!(verdict(&tmd, 135, 0x0008, Permit::SETTING), "ok");
        assert_eq!(verdict(&tmd, 135, 0x0200, Permit::SETTING), "ok");
        assert!(verdict(&tmd, 135, 0, Permit::SETTING).contains("sets none of the inhibit bits"));
        assert!(
            verdict(&tmd, 135, 0x0808, Permit::SETTING).contains("is a command (trip_reset set)")
        );
        assert!(verdict(&tmd, 2, 1, Permit::SETTING).contains("is a command"));
        assert!(verdict(&tmd, 43, 1, Permit::SETTING).contains("is a command"));
    }

    #[test]
    fn a_schema_without_roles_gets_the_floor_and_cia_402_applies_to_ecs() {
        // a Tmd schema naming C0040 and C0002 without any role
        let mut r = Registry::new();
        let tmd = r
            .add_source(SourceFile::new(
                "t.toml",
                "[schema]\nid = \"t\"\ntitle = \"t\"\nprotocol = \"lecom\"\ncode_style = \"lenze\"\n\n[[code]]\nnumber = 40\nname = \"c40\"\ntype = \"VD\"\n\n[[code]]\nnumber = 2\nname = \"c2\"\ntype = \"VD\"\n",
            ))
            .expect("parses");
        assert!(verdict(&tmd, 40, 10_000, Permit::SETTING).contains("would enable the drive"));
        assert!(verdict(&tmd, 2, 10_000, Permit::SETTING).contains("is a command"));
        assert_eq!(verdict(&tmd, 40, 0, Permit::SETTING), "ok");
        // an ECS schema (as an EDS import writes it) with CiA 402 objects
        let ecs = r
            .add_source(SourceFile::new(
                "e.toml",
                "[schema]\nid = \"e\"\ntitle = \"e\"\nprotocol = \"lenze-can-sdo\"\ncode_style = \"lenze\"\n[schema.can]\nindex_base = 24575\n\n[[code]]\nindex = 0x6040\nname = \"controlword\"\ntype = \"UNSIGNED16\"\n\n[[code]]\nindex = 0x60FF\nname = \"target_velocity\"\ntype = \"INTEGER32\"\n",
            ))
            .expect("parses");
        let cw = driveset_schema::schema::CIA_NUMBER_BASE + 0x6040;
        assert_eq!(verdict(&ecs, cw, 0x06, Permit::SETTING), "ok");
        assert!(
            verdict(&ecs, cw, 0x0F, Permit::SETTING)
                .contains("would start or enable the drive (switch_on, enable_operation set)"),
        );
        assert!(
            verdict(&ecs, cw, 0x80, Permit::SETTING).contains("is a command (fault_reset set)")
        );
        assert_eq!(
            ecs.role_of(driveset_schema::schema::CIA_NUMBER_BASE + 0x60FF),
            Some(driveset_schema::Role::Setpoint)
        );
    }

    /// Each guard refusal renders today's message, is a `Refusal` whose
    /// JSON is the flat kind journals have always held, and reads back.
    #[test]
    fn guard_refusals_keep_their_messages_and_json_kinds() {
        let s = |x: &str| x.to_string();
        let cases = [
            (
                GuardRefusal::Command {
                    code: s("4-PROG"),
                    value: s("1"),
                },
                "4-PROG = 1 is a command: driveset never writes one (only its own named steps: the SLOAD handshake, PROG = 111 activating a rate); run it on the drive itself",
                r#"{"kind":"guard_command","code":"4-PROG","value":"1"}"#,
            ),
            (
                GuardRefusal::ControlWord {
                    code: s("416-SCTL1"),
                    value: s("1"),
                    why: s("would start the motor"),
                },
                "416-SCTL1 = 1 would start the motor: driveset writes a control word only in a stopped or inhibited state; start the motor from the machine's control",
                r#"{"kind":"guard_control_word","code":"416-SCTL1","value":"1","why":"would start the motor"}"#,
            ),
            (
                GuardRefusal::Permit {
                    permit: s("rate-switch"),
                    code: s("81-SBAUD"),
                    value: s("7"),
                },
                "the rate-switch permit does not cover 81-SBAUD = 7; nothing was sent",
                r#"{"kind":"guard_permit","permit":"rate-switch","code":"81-SBAUD","value":"7"}"#,
            ),
        ];
        for (refusal, message, json) in cases {
            assert_eq!(refusal.to_string(), message);
            assert_refusal_json(&refusal, json);
        }
    }
}
