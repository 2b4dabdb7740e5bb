//! Owns the two halves of a client: [`Drive`], what every client holds
//! alike (where the drive is, the schema its codes are converted with, the
//! line: link and counters, and through the link the bus id and clock), and
//! [`Protocol`], the small trait a protocol implements over it (read,
//! write, running, finish, the timings; the optional capabilities of
//! `capability.rs`). [`DriveClient`], the face the rest of the engine and
//! the CLI use, is implemented once here for every protocol.

use std::sync::Arc;
use std::time::Duration;

use driveset_link::{ByteLink, Clock, FrameLink, Instant};
use driveset_schema::{CodeKey, RawValue, Schema, StoreCommand};

use super::{
    ClientStats, DatasetDownload, DriveClient, Identity, SerialLine, Target, code_name, identify,
};
use crate::error::EngineError;
use crate::guard::Permit;

/// A drive as a client holds it: where it is, the schema its codes are
/// converted with, and the line it is reached through (`B`: the protocol's
/// link, answer decoder and counters, [`DriveLine`]).
#[derive(Debug)]
pub struct Drive<B> {
    /// Port and address.
    pub target: Target,
    /// The schema the client converts codes with.
    pub schema: Arc<Schema>,
    /// The line: link and counters.
    pub line: B,
}

impl<B: DriveLine> Drive<B> {
    /// The drive at `target` of `schema`, reached through `line`.
    pub fn new(target: Target, schema: Arc<Schema>, line: B) -> Self {
        Drive {
            target,
            schema,
            line,
        }
    }
}

/// The line side of a [`Drive`]: which bus its link reaches, the link's
/// clock, and what was sent so far.
pub trait DriveLine {
    /// The bus the link reaches ([`driveset_link::bus_id`]).
    fn bus_id(&self) -> String;

    /// The link's clock (real or virtual).
    fn clock(&self) -> &dyn Clock;

    /// Counters so far.
    fn stats(&self) -> ClientStats;
}

impl<L: ByteLink> DriveLine for super::lecom::LecomLine<L> {
    fn bus_id(&self) -> String {
        self.link.bus_id()
    }
    fn clock(&self) -> &dyn Clock {
        self.link.clock()
    }
    fn stats(&self) -> ClientStats {
        self.stats
    }
}

impl<L: ByteLink> DriveLine for super::lustbus::LustLine<L> {
    fn bus_id(&self) -> String {
        self.link.bus_id()
    }
    fn clock(&self) -> &dyn Clock {
        self.link.clock()
    }
    fn stats(&self) -> ClientStats {
        self.stats
    }
}

impl<L: FrameLink> DriveLine for super::sdo::SdoLine<L> {
    fn bus_id(&self) -> String {
        self.link.bus_id()
    }
    fn clock(&self) -> &dyn Clock {
        self.link.clock()
    }
    fn stats(&self) -> ClientStats {
        self.stats
    }
}

/// What a protocol adds to its [`Drive`]: reading and writing one code,
/// the running state, the end of a session and the wire times; optionally
/// its own identification, store step, write pacing, a serial line
/// whose rate can be set and the dataset download
/// (`capability.rs`). Every `Protocol` is a [`DriveClient`].
pub trait Protocol: Send {
    /// The line of its [`Drive`].
    type Line: DriveLine;

    /// The drive: target, schema, line.
    fn drive(&self) -> &Drive<Self::Line>;

    /// Read one code's raw value; `what` names the operation in errors
    /// (`read C0011`, `identify: read 91-TYPE`).
    fn read_key(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError>;

    /// [`DriveClient::write_named`].
    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        permit: Permit,
    ) -> Result<(), EngineError>;

    /// [`DriveClient::running`].
    fn running(&mut self) -> Result<Option<bool>, EngineError>;

    /// [`DriveClient::finish`].
    fn finish(&mut self) -> Result<(), EngineError>;

    /// [`DriveClient::read_time`].
    fn read_time(&self, key: CodeKey) -> Duration;

    /// [`DriveClient::write_time`].
    fn write_time(&self, key: CodeKey) -> Duration;

    /// [`DriveClient::identify`]: by default the one identify loop
    /// (`identify.rs`) over [`Protocol::read_key`], values shown as every
    /// client shows them.
    fn identify(&mut self) -> Result<Identity, EngineError>
    where
        Self: Sized,
    {
        let schema = Arc::clone(&self.drive().schema);
        identify::identify(
            &schema,
            |key, what| self.read_key(key, what),
            identify::shown,
        )
    }

    /// [`DriveClient::store`]: by default the store code written under the
    /// store permit, then polled for `done` ([`super::poll_store`]).
    fn store(&mut self, command: &StoreCommand) -> Result<(), EngineError>
    where
        Self: Sized,
    {
        let sent = self.drive().line.clock().now();
        self.write_named(
            CodeKey::new(command.code),
            &RawValue::Int(command.value),
            Permit::STORE,
        )?;
        super::poll_store(self, command, sent)
    }

    /// [`DriveClient::ready_for_write`]: by default now.
    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        let _ = key;
        None
    }

    /// [`DriveClient::line_rate`]: by default none.
    fn line_rate(&self) -> Option<u32> {
        None
    }

    /// [`DriveClient::line`]: by default none.
    fn line(&mut self) -> Option<&mut dyn SerialLine> {
        None
    }

    /// [`DriveClient::dataset`]: by default none.
    fn dataset(&mut self) -> Option<&mut dyn DatasetDownload> {
        None
    }
}

impl<P: Protocol> DriveClient for P {
    fn target(&self) -> &Target {
        &self.drive().target
    }

    fn bus_id(&self) -> String {
        self.drive().line.bus_id()
    }

    fn schema(&self) -> &Arc<Schema> {
        &self.drive().schema
    }

    fn clock(&self) -> &dyn Clock {
        self.drive().line.clock()
    }

    fn identify(&mut self) -> Result<Identity, EngineError> {
        Protocol::identify(self)
    }

    fn read(&mut self, key: CodeKey) -> Result<RawValue, EngineError> {
        let what = format!("read {}", code_name(&self.drive().schema, key));
        self.read_key(key, &what)
    }

    fn write(&mut self, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        Protocol::write_named(self, key, raw, Permit::SETTING)
    }

    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        permit: Permit,
    ) -> Result<(), EngineError> {
        Protocol::write_named(self, key, raw, permit)
    }

    fn store(&mut self, command: &StoreCommand) -> Result<(), EngineError> {
        Protocol::store(self, command)
    }

    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        Protocol::ready_for_write(self, key)
    }

    fn read_time(&self, key: CodeKey) -> Duration {
        Protocol::read_time(self, key)
    }

    fn write_time(&self, key: CodeKey) -> Duration {
        Protocol::write_time(self, key)
    }

    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        Protocol::running(self)
    }

    fn stats(&self) -> ClientStats {
        self.drive().line.stats()
    }

    fn finish(&mut self) -> Result<(), EngineError> {
        Protocol::finish(self)
    }

    fn line_rate(&self) -> Option<u32> {
        Protocol::line_rate(self)
    }

    fn line(&mut self) -> Option<&mut dyn SerialLine> {
        Protocol::line(self)
    }

    fn dataset(&mut self) -> Option<&mut dyn DatasetDownload> {
        Protocol::dataset(self)
    }
}
