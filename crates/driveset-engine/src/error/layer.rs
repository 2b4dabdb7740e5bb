//! Owns [`Layer`]: which layer of the stack a failure comes from (the
//! command's input, a rule's refusal, the link, the drive, a transaction's
//! outcome); an [`ErrorKind`]'s is its outer variant (`kind.rs`). Every
//! error type a front end sees from the engine
//! ([`EngineError`], `SessionError`, `PortError`, `ReplaceError`) says its
//! layer; a front end maps layers to exit codes in one place (the CLI's
//! `fail::exit_code`, docs/architecture.md "The data path of an upload").

use super::{EngineError, ErrorKind};

/// The layer a failure comes from ([`EngineError::layer`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layer {
    /// The command's input: a port string or its settings, a schema that
    /// does not fit the port, a file that cannot be read or written (a
    /// journal, a learned schema). Nothing reached a drive because of it.
    Input,
    /// A safety or input rule refused before anything was sent
    /// ([`super::Refused::Rule`], typed [`super::Refusal`]), or `recover`
    /// refused a journal for the drive it reaches
    /// ([`super::Refused::NotJournalDrive`]).
    Refusal,
    /// The link: the transport failed or its bus is held, nothing (valid)
    /// answered, an answer could not be understood.
    Link,
    /// The drive itself: it refused with a typed cause
    /// ([`super::DeviceCause`]), restarted, or described itself in a way
    /// that does not make a schema.
    Device,
    /// A transaction's outcome: rolled back, left as a mix, or failed on the
    /// way after it started writing.
    Transaction,
}

impl ErrorKind {
    /// The layer this failure comes from: its outer variant.
    pub fn layer(&self) -> Layer {
        match self {
            ErrorKind::Input(_) => Layer::Input,
            ErrorKind::Refusal(_) => Layer::Refusal,
            ErrorKind::Link(_) => Layer::Link,
            ErrorKind::Device(_) => Layer::Device,
            ErrorKind::Transaction(_) => Layer::Transaction,
        }
    }
}

impl EngineError {
    /// The layer this failure comes from ([`ErrorKind::layer`]).
    pub fn layer(&self) -> Layer {
        self.kind.layer()
    }
}

#[cfg(test)]
mod tests {
    use driveset_link::LinkError;

    use super::*;
    use crate::client::Target;
    use crate::error::{DeviceCause, Refusal};
    use crate::journal::Mismatch;

    #[test]
    fn every_kind_says_its_layer() {
        let t = || Target {
            port: "sim://line".into(),
            address: 1,
        };
        let closed = LinkError::ConnectionClosed {
            port: "tcp://x:1".into(),
        };
        for (e, layer) in [
            (EngineError::link(t(), closed), Layer::Link),
            (EngineError::no_answer(t(), "read C0011", 3), Layer::Link),
            (EngineError::protocol(t(), "read C0011", "?"), Layer::Link),
            (
                EngineError::device(t(), "write C0011", DeviceCause::SiofUnreadable),
                Layer::Device,
            ),
            (EngineError::restarted(t(), "write C0011"), Layer::Device),
            (
                EngineError::refused(t(), Refusal::NoDatasetHandshake),
                Layer::Refusal,
            ),
            (
                EngineError::not_journal_drive(t(), "j.json", Mismatch::Bus, "another bus"),
                Layer::Refusal,
            ),
            (EngineError::journal("j.json", "cannot write"), Layer::Input),
            (
                EngineError::rolled_back(
                    t(),
                    "j.json",
                    "C0011",
                    EngineError::restarted(t(), "write C0011"),
                ),
                Layer::Transaction,
            ),
            (
                EngineError::inconsistent(t(), "j.json", "C0011 new"),
                Layer::Transaction,
            ),
        ] {
            assert_eq!(e.layer(), layer, "{e}");
            assert_eq!(e.kind().layer(), layer, "{e}");
            // the layer is the outer variant, whatever the layer's own enum holds
            let outer = match e.kind() {
                ErrorKind::Input(_) => Layer::Input,
                ErrorKind::Refusal(_) => Layer::Refusal,
                ErrorKind::Link(_) => Layer::Link,
                ErrorKind::Device(_) => Layer::Device,
                ErrorKind::Transaction(_) => Layer::Transaction,
            };
            assert_eq!(outer, layer, "{e}");
        }
    }
}
