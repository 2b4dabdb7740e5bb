//! Owns the CLI's one error convention. Every command's `run` returns
//! `Result<u8, Fail>`: `Ok` is the exit code of a command that ran to its
//! end (0, or 1 for findings and differences); `Err` is a failure with its
//! exit code (2 usage or input error, 3 bus or device failure) and its
//! message, which `main` prints on stderr, once, as `error: MESSAGE`. A
//! failure whose diagnostics were already rendered on stderr (findings with
//! their source snippets, [`Fail::reported`]) carries only its exit code.
//! `anyhow` errors (the binary's plumbing) become input errors.

use driveset_engine::error::{EngineError, ErrorKind};

use crate::{EXIT_BUS, EXIT_INPUT};

/// A failure and the exit code it ends the command with.
#[derive(Debug)]
pub struct Fail {
    /// Exit code (2 input/usage, 3 bus/device).
    pub code: u8,
    /// Message (without the `error: ` prefix); empty when the diagnostics
    /// are already on stderr ([`Fail::reported`]).
    pub msg: String,
}

impl Fail {
    /// Usage or input error (exit 2).
    pub fn input(msg: impl Into<String>) -> Self {
        Fail {
            code: EXIT_INPUT,
            msg: msg.into(),
        }
    }

    /// Bus or device failure (exit 3).
    pub fn bus(msg: impl Into<String>) -> Self {
        Fail {
            code: EXIT_BUS,
            msg: msg.into(),
        }
    }

    /// A failure whose diagnostics were already written to stderr.
    pub fn reported(code: u8) -> Self {
        Fail {
            code,
            msg: String::new(),
        }
    }

    /// Print the failure on stderr (nothing more for [`Fail::reported`])
    /// and give its exit code: `main`'s one place for errors.
    pub fn report(self) -> u8 {
        if !self.msg.is_empty() {
            eprintln!("error: {}", self.msg);
        }
        self.code
    }
}

/// The exit code of an engine error: refusals before anything was sent and
/// journal file problems are input errors (2); everything the bus or the
/// drive did is 3 (a rolled-back upload included: the drive holds its old
/// values, the set did not land).
pub fn engine_exit(e: &EngineError) -> u8 {
    match e.kind() {
        ErrorKind::Refused(_) | ErrorKind::Journal { .. } | ErrorKind::NotJournalDrive { .. } => {
            EXIT_INPUT
        }
        _ => EXIT_BUS,
    }
}

impl From<EngineError> for Fail {
    fn from(e: EngineError) -> Self {
        Fail {
            code: engine_exit(&e),
            msg: e.to_string(),
        }
    }
}

impl From<driveset_engine::session::SessionError> for Fail {
    fn from(e: driveset_engine::session::SessionError) -> Self {
        match e {
            driveset_engine::session::SessionError::Engine(e) => e.into(),
            driveset_engine::session::SessionError::Catalog(e) => {
                Fail::input(crate::port::catalog_error(&e))
            }
            e if e.is_input() => Fail::input(e.to_string()),
            e => Fail::bus(e.to_string()),
        }
    }
}

impl From<driveset_engine::session::PortError> for Fail {
    fn from(e: driveset_engine::session::PortError) -> Self {
        if e.is_input() {
            Fail::input(e.to_string())
        } else {
            Fail::bus(e.to_string())
        }
    }
}

impl From<anyhow::Error> for Fail {
    fn from(e: anyhow::Error) -> Self {
        Fail::input(format!("{e:#}"))
    }
}

/// A rehearsal refused before it starts: an input error (exit 2).
impl From<driveset_twin::rehearse::Refused> for Fail {
    fn from(e: driveset_twin::rehearse::Refused) -> Self {
        Fail::input(e.0)
    }
}

/// A rendered input error ([`crate::output::fail_input`]) as a failure.
impl From<&driveset_schema::InputError> for Fail {
    fn from(e: &driveset_schema::InputError) -> Self {
        Fail::reported(crate::output::fail_input(e))
    }
}

/// Errors of the binary's plumbing that end a command as input errors,
/// printed as `anyhow` prints them (the error and its causes).
macro_rules! input_errors {
    ($($t:ty),* $(,)?) => {$(
        impl From<$t> for Fail {
            fn from(e: $t) -> Self {
                anyhow::Error::from(e).into()
            }
        }
    )*};
}

input_errors!(
    std::io::Error,
    serde_json::Error,
    driveset_sim::open::SimOpenError,
    driveset_sim::serve::ServeError,
    driveset_sim::slcan_serve::SlcanServeError,
);
