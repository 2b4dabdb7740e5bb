//! Owns [`NotJournalDrive`]: `recover` refusing a journal for the drive it
//! reaches, and why ([`Mismatch`]): a journal is bound to its drive (the
//! bus, the address, the identity, the schema; docs/journals.md), and a
//! planned code that holds neither its old nor its new value makes the
//! journal stale ([`crate::recover`]). The refusal layer of an
//! [`EngineError`](crate::error::EngineError)
//! ([`Refused::NotJournalDrive`](crate::error::Refused::NotJournalDrive)).

use std::fmt;

/// `recover` refused a journal: the drive it reaches is not the drive the
/// journal was written for, or a planned code holds neither its old nor its
/// new value. Nothing was written (for [`Mismatch::Version`],
/// [`Mismatch::Schema`], [`Mismatch::Bus`] and [`Mismatch::Address`]
/// nothing was sent at all).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NotJournalDrive {
    /// The journal file.
    pub journal: String,
    /// What did not match.
    pub mismatch: Mismatch,
    /// What differs and what to do.
    pub detail: String,
}

impl fmt::Display for NotJournalDrive {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "refused to recover journal {}: {}",
            self.journal, self.detail
        )
    }
}

/// Why `recover` refused a journal ([`NotJournalDrive::mismatch`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Mismatch {
    /// A journal version that does not record the drive's bus (1).
    Version,
    /// The client's schema is not the journal's.
    Schema,
    /// The port reaches another bus.
    Bus,
    /// Another bus address.
    Address,
    /// The drive identifies differently (identify codes, family, software).
    Identity,
    /// These planned codes hold neither their old nor their new value.
    Stale {
        /// The codes, as humans spell them.
        codes: Vec<String>,
    },
}
