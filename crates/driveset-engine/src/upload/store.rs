//! The transaction's store step ([`Transaction::store`]): after every
//! written code read back equal, a drive whose schema keeps writes only on
//! command (`[schema.store] keeps = "on-command"`, docs/file-formats.md)
//! gets its store command, through the write guard's store permit
//! ([`crate::guard`]), with the acknowledgement wait the schema gives. The
//! journal says `storing` first, so a cut during the store is finished by
//! `recover` (which stores again: a store command is idempotent). After the
//! store every code of the set is read back once more: a drive that lost
//! power between the verification and the store comes back with its old
//! values and stores those, which no acknowledgement tells. What the
//! report says of it is [`Stored`].

use driveset_schema::Keeping;
use serde::Serialize;

use driveset_schema::ResolvedSet;

use super::{StepError, Transaction, read_observed};
use crate::client::DriveClient;
use crate::error::EngineError;
use crate::journal::TxnState;
use crate::observe::Phase as Step;
use crate::plan::value_text;

/// Whether the drive keeps the set over a power cycle, as the upload and
/// commission reports say it per drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stored {
    /// The store command was written and acknowledged.
    Stored,
    /// The drive stores every write itself (`keeps = "every-write"`).
    EveryWrite,
    /// No document gives a store step (`keeps = "unknown"`): what was
    /// written may be lost at power off.
    Unknown,
    /// The transaction did not get as far as its store step.
    NotReached,
}

impl Stored {
    /// `stored`, `stored (...)` or `not stored: lost at power off (...)`.
    pub fn text(self) -> &'static str {
        match self {
            Stored::Stored => "stored",
            Stored::EveryWrite => "stored (the drive stores every write)",
            Stored::Unknown => {
                "not stored: lost at power off (the schema gives no store step: [schema.store] keeps = \"unknown\")"
            }
            Stored::NotReached => "not stored: the transaction did not complete",
        }
    }
}

impl Transaction {
    /// Step 8: the store command, where the schema's drives keep writes
    /// only on command (state `storing` first); a no-op otherwise. Runs
    /// whether or not anything was written this time: values an earlier,
    /// cut run left in the drive's RAM are stored too.
    pub fn store(
        &mut self,
        client: &mut dyn DriveClient,
        set: &ResolvedSet,
    ) -> Result<(), StepError> {
        let schema = self.drive.schema.clone();
        let Keeping::OnCommand(command) = &schema.store.keeping else {
            return Ok(());
        };
        let key = driveset_schema::CodeKey::new(command.code);
        let shown = format!(
            "{} = {}",
            schema.code_label(key),
            value_text(&schema, key, &driveset_schema::RawValue::Int(command.value))
        );
        self.set_state(
            client,
            TxnState::Storing,
            Some(format!("verified; storing: {shown}")),
        )?;
        self.opts
            .observer
            .enter(client.clock(), Step::Store, Some(1));
        self.progress.store_sent = true;
        client.store(command).map_err(StepError::Error)?;
        self.opts.observer.step(client.clock(), Step::Store, 1, 1);
        // what was stored is what the drive holds now: a drive that lost
        // power between the last read-back and the store came back with
        // its old values and stored those, so every code is read again
        let now = read_observed(
            client,
            set.values.keys().copied(),
            &self.opts.observer,
            Step::Verify,
        )
        .map_err(StepError::Error)?;
        if let Some((key, want)) = set
            .values
            .iter()
            .find(|(k, v)| now.values.get(*k) != Some(*v))
        {
            let got = now
                .values
                .get(key)
                .map_or_else(|| "nothing".to_string(), |g| value_text(&schema, *key, g));
            return Err(StepError::Error(EngineError::protocol(
                self.drive.target.clone(),
                format!("read back {} after the store", schema.code_label(*key)),
                format!(
                    "reads back {got} instead of {}: the drive stored other values (did it restart before the store?)",
                    value_text(&schema, *key, want)
                ),
            )));
        }
        self.progress.stored = true;
        Ok(())
    }

    /// What the report says of keeping the set over a power cycle.
    pub(super) fn stored(&self, complete: bool) -> Stored {
        match (&self.drive.schema.store.keeping, complete) {
            (_, false) => Stored::NotReached,
            (Keeping::EveryWrite, true) => Stored::EveryWrite,
            (Keeping::Unknown, true) => Stored::Unknown,
            (Keeping::OnCommand(_), true) if self.progress.stored => Stored::Stored,
            (Keeping::OnCommand(_), true) => Stored::NotReached,
        }
    }
}
