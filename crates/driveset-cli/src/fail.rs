//! Owns the CLI's one error convention. Every command's `run` returns
//! `Result<u8, Fail>`: `Ok` is the exit code of a command that ran to its
//! end (0, or 1 for findings and differences); `Err` is a failure with its
//! exit code (2 usage or input error, 3 bus or device failure) and its
//! message, which `main` prints on stderr, once, as `error: MESSAGE`. A
//! failure whose diagnostics were already rendered on stderr (findings with
//! their source snippets, [`Fail::reported`]) carries only its exit code.
//! `anyhow` errors (the binary's plumbing) become input errors. The engine's
//! errors say their layer ([`Layer`]); [`exit_code`] is the one mapping
//! from a layer to an exit code, and the two places where a command reads
//! an engine error its own way (the family check before a read,
//! [`family_exit`]; a spare's set after its address, [`set_after_address_exit`])
//! live beside it, so no command computes an exit code from an error.

use driveset_engine::error::{EngineError, Layer, LinkFailure};

use crate::{EXIT_BUS, EXIT_FINDINGS, EXIT_INPUT};

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

/// The one mapping from failures to exit codes: what the command was
/// given or a rule refused before anything was sent is an input error (2);
/// whatever the link, the drive or a transaction did is 3 (a rolled-back
/// upload included: the drive holds its old values, the set did not land).
pub fn exit_code(layer: Layer) -> u8 {
    match layer {
        Layer::Input | Layer::Refusal => EXIT_INPUT,
        Layer::Link | Layer::Device | Layer::Transaction => EXIT_BUS,
    }
}

/// The exit code of an engine error ([`exit_code`] of its layer).
pub fn engine_exit(e: &EngineError) -> u8 {
    exit_code(e.layer())
}

/// The exit code of the family check (`identify::check_family`) before a
/// command reads a drive for a file: a drive of another family is a finding
/// (1, what `identify` says of it); its other failures as [`exit_code`].
pub fn family_exit(e: &EngineError) -> u8 {
    if e.is_refused() {
        EXIT_FINDINGS
    } else {
        engine_exit(e)
    }
}

/// The exit code of `replace` when the spare was given its address and
/// rate but its set's upload failed (`e`): 3 when the link failed or the
/// spare did not answer, else 1 (the spare answers at its new address; the
/// report says what it holds).
pub fn set_after_address_exit(e: &EngineError) -> u8 {
    match e.link_failure() {
        Some(LinkFailure::Transport(_) | LinkFailure::NoAnswer { .. }) => EXIT_BUS,
        _ => EXIT_FINDINGS,
    }
}

impl Fail {
    /// A failure of `layer` ([`exit_code`]) saying `msg`.
    pub fn of(layer: Layer, msg: impl Into<String>) -> Self {
        Fail {
            code: exit_code(layer),
            msg: msg.into(),
        }
    }
}

impl From<EngineError> for Fail {
    fn from(e: EngineError) -> Self {
        Fail::of(e.layer(), e.to_string())
    }
}

impl From<driveset_engine::session::SessionError> for Fail {
    fn from(e: driveset_engine::session::SessionError) -> Self {
        match e {
            driveset_engine::session::SessionError::Catalog(e) => {
                Fail::input(crate::port::catalog_error(&e))
            }
            e => Fail::of(e.layer(), e.to_string()),
        }
    }
}

impl From<driveset_engine::session::PortError> for Fail {
    fn from(e: driveset_engine::session::PortError) -> Self {
        Fail::of(e.layer(), e.to_string())
    }
}

impl From<&driveset_engine::line::replace::ReplaceError> for Fail {
    fn from(e: &driveset_engine::line::replace::ReplaceError) -> Self {
        Fail::of(e.layer(), e.to_string())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_one_mapping_gives_input_and_refusal_2_and_the_bus_3() {
        for (layer, code) in [
            (Layer::Input, 2),
            (Layer::Refusal, 2),
            (Layer::Link, 3),
            (Layer::Device, 3),
            (Layer::Transaction, 3),
        ] {
            assert_eq!(exit_code(layer), code, "{layer:?}");
            assert_eq!(Fail::of(layer, "x").code, code, "{layer:?}");
        }
    }
}
