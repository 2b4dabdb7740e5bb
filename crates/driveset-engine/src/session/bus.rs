//! Owns the session of one drive on a link the caller keeps (a line's bus,
//! which goes from drive to drive over one link): the drive at an address,
//! its schema learned on the way as [`super::Session::open`] learns it
//! (the same implementation, `reach`), and a client that borrows the link
//! (docs/architecture.md, "One path from a port to a drive").

use std::sync::Arc;

use driveset_link::Link;
use driveset_schema::Schema;

use super::learning::LearnedReport;
use super::reach::{Reached, connected, reach};
use super::{SessionError, SessionPolicy};
use crate::client::DriveClient;
use crate::error::EngineError;

/// A drive reached over a link the caller keeps: the client speaking
/// `schema` borrows the link for `'l`, and what was learned on the way.
pub struct BusSession<'l> {
    /// The port as reports name it.
    pub port: String,
    /// The drive's address (node id on CAN).
    pub address: u8,
    /// The schema the client speaks (the learned one, after learning).
    pub schema: Arc<Schema>,
    /// The client.
    pub client: Box<dyn DriveClient + 'l>,
    /// What learning did, when it ran.
    pub learned: Option<LearnedReport>,
}

impl std::fmt::Debug for BusSession<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BusSession")
            .field("port", &self.port)
            .field("address", &self.address)
            .field("schema", &self.schema.id)
            .field("learned", &self.learned.as_ref().map(|l| &l.id))
            .finish_non_exhaustive()
    }
}

impl<'l> BusSession<'l> {
    /// The drive at `address` of `link` (the port `port`), speaking
    /// `schema`: learned from the drive first when `policy` says so and
    /// the schema lacks facts ([`crate::learn::needs_learning`]), as
    /// [`super::Session::open`] does; a schema whose protocol does not run
    /// on the link is refused before anything is sent. The clients are
    /// [`crate::connect::connect_on`]'s (the default connect options).
    pub fn open(
        link: &'l mut Link,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
        policy: &SessionPolicy<'_>,
    ) -> Result<BusSession<'l>, SessionError> {
        let reached = reach(link, port, schema, address, policy)?;
        Ok(BusSession::of(port, address, reached))
    }

    /// The drive at `address` of `link`, speaking `schema` as it is (no
    /// learning: [`SessionPolicy::default`]); only the bus or a refusal
    /// fails it.
    pub fn connect(
        link: &'l mut Link,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
    ) -> Result<BusSession<'l>, EngineError> {
        let reached = connected(link, schema, address)?;
        Ok(BusSession::of(port, address, reached))
    }

    fn of(port: &str, address: u8, reached: Reached<'l>) -> BusSession<'l> {
        BusSession {
            port: port.to_string(),
            address,
            schema: reached.schema,
            client: reached.client,
            learned: reached.learned,
        }
    }
}
