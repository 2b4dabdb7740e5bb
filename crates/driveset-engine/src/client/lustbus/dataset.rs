//! The MC6000/7000 dataset download of a [`super::LustbusClient`]
//! (`lustbus-protocol.txt` section 11.4): 80-SLOAD = -1, the staged
//! writes, SLOAD = -2 and the polls, and going on with a download another
//! client of the drive opened.
//!
//! [`DatasetDownload::begin`] writes 80-SLOAD = -1 (a NAK with 0x40:
//! the drive is not at standstill). While the download is open, writes of
//! CardWriteable codes are staged by the drive (no EEPROM pacing); a write
//! of any other code is refused before sending, since the drive would ACK
//! it and silently not take it. [`DatasetDownload::commit`] writes
//! SLOAD = -2 and polls SLOAD until it leaves -1 / -2: 0 accepted, > 0
//! rejected at that parameter; still checking when the timeout passes is a
//! `Device` error (11.4: repeat the transfer or restart the drive). Polls
//! start at most every [`crate::plan::SLOAD_POLL_INTERVAL`] (50 ms) or one
//! measured round trip, whichever is longer, sleeping on the link's clock
//! in between; the count is [`crate::client::ClientStats::sload_polls`].

use std::time::Duration;

use driveset_link::{ByteLink, Instant};
use driveset_proto::lustbus::{Dialect, Siof};
use driveset_schema::{CodeKey, RawValue};

use super::{LustbusClient, LustbusRefusal};
use crate::client::{DatasetDownload, DatasetOutcome, device};
use crate::error::{DeviceCause, EngineError, SiofVerdict};
use crate::guard::Permit;
use crate::plan;

/// What [`crate::client::DriveClient::dataset`] hands out for an MC (a
/// VF1000 client gets `None` there; called directly, it is refused).
impl<L: ByteLink> DatasetDownload for LustbusClient<L> {
    /// SLOAD = -1.
    fn begin(&mut self) -> Result<(), EngineError> {
        if self.family != Dialect::Mc {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::Vf1000NoDataset,
            ));
        }
        // A download left open by a failed transfer (no answer, cable) is
        // started over: SLOAD = -1 again discards what the drive staged
        // (section 11.4), so a roll back or recover can stage the backup.
        self.dataset_open = false;
        let key = self.sload_present()?;
        self.select(
            key,
            &RawValue::Int(-1),
            "dataset download: write 80-SLOAD = -1",
            Some(SiofVerdict::NotAtStandstill),
            Permit::DATASET_BEGIN,
        )?;
        self.dataset_open = true;
        Ok(())
    }

    /// SLOAD = -2.
    fn end(&mut self) -> Result<Instant, EngineError> {
        if !self.dataset_open {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::NoDatasetOpen,
            ));
        }
        let key = self.sload_present()?;
        let what = "dataset download: write 80-SLOAD = -2";
        let r = self.select(key, &RawValue::Int(-2), what, None, Permit::DATASET_COMMIT);
        self.dataset_open = false;
        r?;
        Ok(self.now())
    }

    /// The SLOAD polls.
    fn await_outcome(
        &mut self,
        ended: Instant,
        timeout: Duration,
    ) -> Result<DatasetOutcome, EngineError> {
        let key = self.sload_present()?;
        let deadline = ended + timeout;
        loop {
            let poll_start = self.now();
            self.drive.line.stats.sload_polls += 1;
            let v = match self.read_code(key, "dataset download: poll 80-SLOAD")? {
                RawValue::Int(v) => v,
                _ => -1,
            };
            match v {
                0 => return Ok(DatasetOutcome::Accepted),
                p if p > 0 => {
                    return Ok(DatasetOutcome::Rejected {
                        parameter: u32::try_from(p).unwrap_or(u32::MAX),
                    });
                }
                -1 | -2 => {
                    // Still checking. The poll that started at the
                    // deadline (section 11.4: 10 s) was the last.
                    if poll_start >= deadline {
                        return Err(device(
                            &self.drive.target,
                            "dataset download: poll 80-SLOAD",
                            DeviceCause::DatasetStillChecking {
                                timeout_ms: u64::try_from(timeout.as_millis()).unwrap_or(u64::MAX),
                                sload: v,
                            },
                        ));
                    }
                    // The next poll at most every 50 ms or one measured
                    // round trip, whichever is longer, and not after the
                    // deadline.
                    let interval = self
                        .drive
                        .line
                        .latency
                        .round_trip()
                        .unwrap_or(Duration::ZERO)
                        .max(plan::SLOAD_POLL_INTERVAL);
                    let next = (poll_start + interval).min(deadline);
                    if next > self.now() {
                        self.drive.line.link.clock().sleep_until(next);
                    }
                }
                other => {
                    return Err(EngineError::protocol(
                        self.drive.target.clone(),
                        "dataset download: poll 80-SLOAD",
                        format!(
                            "SLOAD = {other}: section 11.4 knows only -1, 0 and parameter numbers"
                        ),
                    ));
                }
            }
        }
    }
}

impl<L: ByteLink> LustbusClient<L> {
    /// MC6000/7000: go on with a dataset download that this drive's
    /// transaction opened (SLOAD = -1 ACKed) through another client of the
    /// same drive, e.g. after the line runner's broadcast. Reads SERR first,
    /// as any session does (section 6: the read clears what a broadcast
    /// SELECT may have latched) and returns it; a power-on bit means the
    /// drive restarted and lost its staged values: [`DeviceFailure::Restarted`](crate::error::DeviceFailure::Restarted).
    pub fn resume_dataset(&mut self) -> Result<Siof, EngineError> {
        self.sload_present()?;
        if self.family != Dialect::Mc {
            return Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::Vf1000NoDataset,
            ));
        }
        let siof = self.read_siof("resuming the dataset download")?;
        if siof.contains(Siof::POWER_ON) {
            return Err(EngineError::restarted(
                self.drive.target.clone(),
                "the dataset download (SERR has the power-on bit)",
            ));
        }
        self.dataset_open = true;
        Ok(siof)
    }

    /// The dataset handshake's code (80-SLOAD), the family's
    /// ([`driveset_schema::family::Descriptor::dataset_code`]), when the
    /// schema has it; refused otherwise.
    fn sload_present(&self) -> Result<CodeKey, EngineError> {
        match self.drive.schema.family.descriptor().dataset_code() {
            Some(n) if self.drive.schema.code(n).is_some() => Ok(CodeKey::new(n)),
            _ => Err(EngineError::refused(
                self.drive.target.clone(),
                LustbusRefusal::NoSload {
                    schema: self.drive.schema.id.clone(),
                },
            )),
        }
    }
}
