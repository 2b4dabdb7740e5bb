//! The optional capabilities of a [`DriveClient`], asked for rather than
//! refused by default: the MC6000/7000 dataset download
//! ([`DatasetDownload`], `lustbus-protocol.txt` §11.4, 80-SLOAD) through
//! [`DriveClient::dataset`], and a serial line whose host side rate can be
//! set ([`SerialLine`], §11.5 and §5.1) through [`DriveClient::line`]. A
//! client without one answers `None`; the callers that need it get the
//! refusal from [`dataset_or_refuse`] and [`set_line_rate`], in the words
//! the refusing defaults of the trait used to have.

use std::time::Duration;

use driveset_link::Instant;

use super::DriveClient;
use super::lustbus::LustbusRefusal;
use crate::error::{EngineError, Refusal};
use crate::transfer::TransferRefusal;

/// Outcome of an MC6000/7000 dataset download (SLOAD, LUSTBUS 11.4).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DatasetOutcome {
    /// SLOAD went to 0: the staged set is in EEPROM.
    Accepted,
    /// SLOAD went to a parameter number: the drive rejected the set at that
    /// parameter and reactivated its old set.
    Rejected {
        /// The first invalid parameter.
        parameter: u32,
    },
}

/// The dataset download handshake (MC6000/7000 80-SLOAD,
/// `lustbus-protocol.txt` §11.4): the drive stages the CardWriteable
/// writes between [`DatasetDownload::begin`] and [`DatasetDownload::end`],
/// checks them and stores them all or none.
pub trait DatasetDownload {
    /// SLOAD = -1: register a dataset download (standstill only). Writes of
    /// CardWriteable codes until [`DatasetDownload::commit`] (or
    /// [`DatasetDownload::end`]) are staged.
    fn begin(&mut self) -> Result<(), EngineError>;

    /// The first half of [`DatasetDownload::commit`]: SLOAD = -2 only (the
    /// drive starts checking and storing); returns when the drive ACKed
    /// it. [`DatasetDownload::await_outcome`] polls, through this or
    /// another client of the drive, so a runner can use the drive's check
    /// time for other drives of the bus.
    fn end(&mut self) -> Result<Instant, EngineError>;

    /// The second half of [`DatasetDownload::commit`]: poll SLOAD until it
    /// leaves -1, or until `timeout` after `ended` (the instant
    /// [`DatasetDownload::end`] returned) passes.
    fn await_outcome(
        &mut self,
        ended: Instant,
        timeout: Duration,
    ) -> Result<DatasetOutcome, EngineError>;

    /// SLOAD = -2, then poll SLOAD until it leaves -1 or `timeout` (10 s
    /// per §11.4) passes: [`DatasetDownload::end`], then
    /// [`DatasetDownload::await_outcome`].
    fn commit(&mut self, timeout: Duration) -> Result<DatasetOutcome, EngineError> {
        let ended = self.end()?;
        self.await_outcome(ended, timeout)
    }
}

/// The host side of a serial line whose rate the engine may change (the
/// transfer rate, `lustbus-protocol.txt` §11.5; the search over a family's
/// rates, §5.1).
pub trait SerialLine {
    /// The rate the host side runs at (baud).
    fn rate(&self) -> u32;

    /// Set the host side to `baud` (after the drive was told to change its
    /// rate: §11.5, [`crate::transfer`]). The drive is not told anything.
    fn set_rate(&mut self, baud: u32) -> Result<(), EngineError>;
}

/// The client's dataset download, or the refusal of a drive without one:
/// [`LustbusRefusal::Vf1000NoDataset`] on a LUSTBUS family (the VF1000: its
/// descriptor names a wire dialect but no handshake), else
/// [`Refusal::NoDatasetHandshake`].
pub fn dataset_or_refuse(
    client: &mut dyn DriveClient,
) -> Result<&mut dyn DatasetDownload, EngineError> {
    // The refusal is built before the borrow that `dataset()`'s answer
    // carries out of this function starts.
    let target = client.target().clone();
    let refusal = if client.schema().family.descriptor().dialect.is_some() {
        Refusal::Lustbus(LustbusRefusal::Vf1000NoDataset)
    } else {
        Refusal::NoDatasetHandshake
    };
    client
        .dataset()
        .ok_or_else(|| EngineError::refused(target, refusal))
}

/// Set the host side of the client's serial line to `baud`
/// ([`SerialLine::set_rate`]); a client without one is refused
/// ([`TransferRefusal::Rate`]).
pub fn set_line_rate(client: &mut dyn DriveClient, baud: u32) -> Result<(), EngineError> {
    if let Some(line) = client.line() {
        return line.set_rate(baud);
    }
    Err(EngineError::refused(
        client.target().clone(),
        TransferRefusal::Rate {
            detail: format!(
                "this client has no serial line whose rate could be set to {baud} baud"
            ),
        },
    ))
}
