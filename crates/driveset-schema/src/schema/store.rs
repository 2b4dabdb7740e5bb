//! Owns `[schema.store]`: how a schema's drives keep what is written over
//! a power cycle (docs/file-formats.md, "How a drive keeps what is
//! written"). Three answers, each with the document that gives it:
//!
//! - `every-write`: the drive stores every write itself (LUSTBUS EEPROM
//!   parameters, `lustbus-protocol.txt` §11.1, §11.2; Lenze Tmd, see
//!   docs/errata/lecom.md);
//! - `on-command`: writes live in RAM until a store command is written (a
//!   code of the schema, with role `command`, and the one value that
//!   stores: CiA 301 0x1010 sub 1 = 0x65766173 "save"; a Lenze device
//!   command such as the 8400 / 9400 C00002 "save start parameters",
//!   whose status is read back until it says done: `done`, `poll_ms`);
//! - `unknown`: no document says; the upload reports the set "not
//!   stored: lost at power off".
//!
//! A schema file without the table inherits its base's (`extends`); one
//! without a base is `unknown`.

use std::time::Duration;

use crate::error::{InputError, InputErrorKind, Location};

use super::reader::Reader;
use super::{Schema, parse_int_text};

/// How the drives of a schema keep what is written.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Keeping {
    /// Every write is stored by the drive itself.
    EveryWrite,
    /// Writes are kept over a power cycle only after the store command.
    OnCommand(StoreCommand),
    /// No document says.
    #[default]
    Unknown,
}

/// The write that stores (`code = value`), and how long the drive may take
/// to acknowledge it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoreCommand {
    /// The code written (a `[[code]]` of the schema, role `command`).
    pub code: u32,
    /// The value that stores (CiA 301: 0x65766173, "save").
    pub value: i64,
    /// How long the store may take (`timeout_ms`): the acknowledgement of
    /// the write and, with `done`, the polls until the code reads `done`.
    pub timeout: Duration,
    /// The value the store code reads once the store has finished, where
    /// the drive reports it (`done`; a Lenze device command reads 0, "off /
    /// ready", when executed): the store step polls the code for it. `None`
    /// (CiA 301 0x1010): the acknowledgement is the completion, nothing to
    /// poll.
    pub done: Option<i64>,
    /// How often the store code is read while the store runs (`poll_ms`).
    pub poll: Duration,
    /// Where `code` is written.
    pub loc: Location,
}

/// `[schema.store]`: how the drives keep what is written, and the source.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Store {
    /// The answer.
    pub keeping: Keeping,
    /// The document that gives it (`spec`).
    pub spec: Option<String>,
}

/// The acknowledgement wait a store command gets when the file gives none:
/// CiA 301 gives no figure; a store of a parameter memory takes seconds on
/// the devices whose manuals name one.
pub const DEFAULT_STORE_TIMEOUT: Duration = Duration::from_secs(5);

/// How often a store whose schema gives `done` is polled when the file gives
/// no `poll_ms`: a tenth of a second, small beside the seconds a store takes.
pub const DEFAULT_STORE_POLL: Duration = Duration::from_millis(100);

/// How `[schema.store]` was written, before its code is checked against
/// the schema's codes.
#[derive(Debug, Clone)]
pub(super) struct StoreTable {
    keeps: (String, Location),
    spec: Option<String>,
    code: Option<(CodeRef, Location)>,
    value: Option<(i128, Location)>,
    timeout_ms: Option<u64>,
    done: Option<(i128, Location)>,
    poll_ms: Option<u64>,
    at: Location,
}

#[derive(Debug, Clone)]
enum CodeRef {
    Number(u32),
    Name(String),
}

impl StoreTable {
    /// Read `[schema.store]` (every key checked, unknown keys refused).
    pub(super) fn read(mut r: Reader<'_>) -> Result<StoreTable, InputError> {
        let at = r.loc();
        let keeps = r.required_string("keeps")?;
        let spec = r.string("spec")?.map(|s| s.0);
        let code = match r.take("code") {
            None => None,
            Some(e) => {
                let loc = r.doc.loc(&e.value.span);
                match &e.value.kind {
                    crate::doc::NodeKind::Str(s) => Some((CodeRef::Name(s.clone()), loc)),
                    crate::doc::NodeKind::Num(t) => {
                        let n = parse_int_text(t)
                            .and_then(|n| u32::try_from(n).ok())
                            .ok_or_else(|| r.wrong(e, "a code number or a code's name"))?;
                        Some((CodeRef::Number(n), loc))
                    }
                    _ => return Err(r.wrong(e, "a code number or a code's name")),
                }
            }
        };
        let value = match r.take("value") {
            None => None,
            Some(e) => Some((r.int_node(e)?, r.doc.loc(&e.value.span))),
        };
        let timeout_ms = r.uint::<u64>("timeout_ms")?.map(|t| t.0);
        let done = match r.take("done") {
            None => None,
            Some(e) => Some((r.int_node(e)?, r.doc.loc(&e.value.span))),
        };
        let poll_ms = r.uint::<u64>("poll_ms")?.map(|t| t.0);
        r.finish()?;
        Ok(StoreTable {
            keeps,
            spec,
            code,
            value,
            timeout_ms,
            done,
            poll_ms,
            at,
        })
    }

    /// The table as a [`Store`], its code found among `schema`'s codes.
    pub(super) fn resolve(self, schema: &Schema) -> Result<Store, InputError> {
        let err = |loc: Location, what: String, help: &str| {
            InputError::new(InputErrorKind::Structure, loc, what, help)
        };
        let extra = |what: &str| -> Result<(), InputError> {
            Err(err(
                self.at.clone(),
                format!(
                    "[schema.store] keeps = \"{}\" takes no `{what}`",
                    self.keeps.0
                ),
                "only keeps = \"on-command\" names a store code, value, timeout_ms, done and poll_ms",
            ))
        };
        let keeping = match self.keeps.0.as_str() {
            "every-write" | "unknown" => {
                if self.code.is_some() {
                    extra("code")?;
                }
                if self.value.is_some() {
                    extra("value")?;
                }
                if self.timeout_ms.is_some() {
                    extra("timeout_ms")?;
                }
                if self.done.is_some() {
                    extra("done")?;
                }
                if self.poll_ms.is_some() {
                    extra("poll_ms")?;
                }
                if self.keeps.0 == "every-write" {
                    Keeping::EveryWrite
                } else {
                    Keeping::Unknown
                }
            }
            "on-command" => {
                let Some((code, loc)) = self.code else {
                    return Err(err(
                        self.at.clone(),
                        "[schema.store] keeps = \"on-command\" has no `code`".into(),
                        "name the code the store command is written to, e.g. code = \"store_parameters\"",
                    ));
                };
                let Some((value, vloc)) = self.value else {
                    return Err(err(
                        self.at.clone(),
                        "[schema.store] keeps = \"on-command\" has no `value`".into(),
                        "give the value that stores, e.g. value = 0x65766173 (CiA 301 \"save\")",
                    ));
                };
                let found = match &code {
                    CodeRef::Number(n) => schema.code(*n),
                    CodeRef::Name(n) => schema.code_by_name(n),
                };
                let shown = match &code {
                    CodeRef::Number(n) => n.to_string(),
                    CodeRef::Name(n) => format!("`{n}`"),
                };
                let Some(c) = found else {
                    return Err(err(
                        loc,
                        format!("[schema.store] code {shown} is not a code of the schema"),
                        "declare the store object as a [[code]] with role = \"command\" and name it here",
                    ));
                };
                if c.role != Some(crate::role::Role::Command) {
                    return Err(err(
                        loc,
                        format!(
                            "[schema.store] code {shown} has no role = \"command\": a set could write the store command as a setting"
                        ),
                        "give the store code role = \"command\"",
                    ));
                }
                let value = i64::try_from(value).map_err(|_| {
                    err(
                        vloc,
                        "[schema.store] value does not fit a 64-bit integer".into(),
                        "give the raw value that stores",
                    )
                })?;
                let done = match self.done {
                    None => None,
                    Some((d, dloc)) => Some(i64::try_from(d).map_err(|_| {
                        err(
                            dloc,
                            "[schema.store] done does not fit a 64-bit integer".into(),
                            "give the raw value the store code reads once stored",
                        )
                    })?),
                };
                if done.is_none() && self.poll_ms.is_some() {
                    return Err(err(
                        self.at.clone(),
                        "[schema.store] gives poll_ms but no `done`: nothing says when the store has finished".into(),
                        "give done = the value the store code reads once stored, or drop poll_ms",
                    ));
                }
                if self.poll_ms == Some(0) {
                    return Err(err(
                        self.at.clone(),
                        "[schema.store] poll_ms = 0 would read the store code without pause".into(),
                        "give the interval between reads in milliseconds, e.g. poll_ms = 100",
                    ));
                }
                Keeping::OnCommand(StoreCommand {
                    code: c.number,
                    value,
                    timeout: self
                        .timeout_ms
                        .map_or(DEFAULT_STORE_TIMEOUT, Duration::from_millis),
                    done,
                    poll: self
                        .poll_ms
                        .map_or(DEFAULT_STORE_POLL, Duration::from_millis),
                    loc,
                })
            }
            other => {
                return Err(err(
                    self.keeps.1.clone(),
                    format!("unknown keeps `{other}` in [schema.store]"),
                    "use every-write, on-command or unknown",
                ));
            }
        };
        Ok(Store {
            keeping,
            spec: self.spec,
        })
    }
}

impl Store {
    /// The store command, where the drives keep writes only on command.
    pub fn command(&self) -> Option<&StoreCommand> {
        match &self.keeping {
            Keeping::OnCommand(c) => Some(c),
            _ => None,
        }
    }

    /// `every-write`, `on-command` or `unknown`.
    pub fn keeps(&self) -> &'static str {
        match self.keeping {
            Keeping::EveryWrite => "every-write",
            Keeping::OnCommand(_) => "on-command",
            Keeping::Unknown => "unknown",
        }
    }
}

/// Why a set may not hold `code` (a validate finding, and why `pull`
/// leaves it out) when it is a RAM
/// control value (`kind = "ram-control"`) that is not a control word or a
/// setpoint: the drive loses it at power off. The message names the code,
/// the document its entry cites, and the section of the family's spec that
/// makes a value of its kind lost at power down (the descriptor's
/// `ram_loss`: `lustbus-protocol.txt` §11.1 for the VF1000, §11.2.1 for the
/// MC6000/7000). Control words and setpoints are the machine's run state (a
/// set preloads them), which the drive takes from its power-up state and
/// the machine's control again.
pub fn ram_note(schema: &Schema, code: &super::Code, key: crate::CodeKey) -> Option<String> {
    if code.kind != Some(super::StorageKind::RamControl)
        || matches!(
            code.role,
            Some(crate::role::Role::ControlWord | crate::role::Role::Setpoint)
        )
    {
        return None;
    }
    let shown = schema.display_code(key.number, key.subcode);
    let source = code
        .spec
        .as_deref()
        .or(schema.spec.as_deref())
        .unwrap_or("the schema");
    let why = schema
        .family
        .descriptor()
        .ram_loss
        .map_or_else(String::new, |r| format!(" ({r})"));
    Some(format!(
        "{shown} is a RAM control value (kind ram-control, {source}): the drive loses it at power off{why}"
    ))
}

#[cfg(test)]
mod tests {
    use crate::Registry;
    use crate::error::SourceFile;
    use std::time::Duration;

    /// A schema over `lenze-ecs` with a device-command store code C5990
    /// and `store` as its `[schema.store]` body.
    fn load(store: &str) -> Result<std::sync::Arc<crate::Schema>, String> {
        Registry::builtin()
            .unwrap()
            .add_source(SourceFile::new(
                "t.toml",
                format!(
                    "[schema]\nid = \"t\"\ntitle = \"t\"\nextends = \"lenze-ecs\"\n\n[schema.store]\n{store}\n[[code]]\nnumber = 5990\nname = \"save\"\ntitle = \"t\"\nspec = \"t\"\nrole = \"command\"\n"
                ),
            ))
            .map_err(|e| e.message.clone())
    }

    #[test]
    fn done_and_poll_ms_make_a_polled_store_step() {
        let s = load("keeps = \"on-command\"\ncode = \"save\"\nvalue = 10000\ndone = 0\npoll_ms = 250\ntimeout_ms = 7500\n").unwrap();
        let c = s.store.command().unwrap();
        assert_eq!(
            (c.code, c.value, c.done, c.poll, c.timeout),
            (
                5990,
                10000,
                Some(0),
                Duration::from_millis(250),
                Duration::from_millis(7500)
            )
        );
        // without them: the acknowledgement is the completion
        let s = load("keeps = \"on-command\"\ncode = 5990\nvalue = 10000\n").unwrap();
        let c = s.store.command().unwrap();
        assert_eq!(
            (c.done, c.poll, c.timeout),
            (
                None,
                super::DEFAULT_STORE_POLL,
                super::DEFAULT_STORE_TIMEOUT
            )
        );
    }

    #[test]
    fn a_poll_without_done_or_a_done_without_a_store_command_is_refused() {
        for (body, message) in [
            (
                "keeps = \"on-command\"\ncode = \"save\"\nvalue = 1\npoll_ms = 100\n",
                "[schema.store] gives poll_ms but no `done`: nothing says when the store has finished",
            ),
            (
                "keeps = \"on-command\"\ncode = \"save\"\nvalue = 1\ndone = 0\npoll_ms = 0\n",
                "[schema.store] poll_ms = 0 would read the store code without pause",
            ),
            (
                "keeps = \"every-write\"\ndone = 0\n",
                "[schema.store] keeps = \"every-write\" takes no `done`",
            ),
            (
                "keeps = \"unknown\"\npoll_ms = 100\n",
                "[schema.store] keeps = \"unknown\" takes no `poll_ms`",
            ),
        ] {
            assert_eq!(load(body).unwrap_err(), message, "{body}");
        }
    }
}
