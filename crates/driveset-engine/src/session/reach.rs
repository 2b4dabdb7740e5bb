//! Owns "learn if needed, then connect", the one implementation behind
//! both sessions: [`super::Session::open`] (a port the session owns) and
//! [`super::bus::BusSession::open`] (the drive at an address of a link the
//! caller keeps, a line's bus). A [`Way`] is what differs between them:
//! the link owned or borrowed, and its connect options
//! (docs/architecture.md, "One path from a port to a drive").

use std::sync::Arc;

use driveset_link::{ByteLink, Link};
use driveset_schema::Schema;

use super::learning::{LearnedReport, learn_on};
use super::{SessionError, SessionPolicy};
use crate::client::{BorrowedByteLink, DriveClient};
use crate::connect::{self, ConnectOptions};
use crate::error::EngineError;
use crate::learn::needs_learning;

/// A link a session reaches its drive over: what a client borrows (`'l`),
/// its character line when it is one, and the client of a schema's
/// protocol.
pub(super) trait Way<'l>: Sized {
    /// The character line a LUSTBUS client learns over.
    type Line: ByteLink + 'l;
    /// The port's connect options (`latency=` and the like).
    fn options(&self) -> ConnectOptions;
    /// The character line, or the link back when it is a CAN bus.
    fn line(self) -> Result<Self::Line, Self>;
    /// The client of `schema`'s protocol for the drive at `address`
    /// ([`connect`]): a misfit of schema and link is refused before
    /// anything is sent.
    fn client(
        self,
        schema: Arc<Schema>,
        address: u8,
    ) -> Result<Box<dyn DriveClient + 'l>, EngineError>;
}

/// A link the session owns, with its port's options.
pub(super) struct Owned {
    pub(super) link: Link,
    pub(super) options: ConnectOptions,
}

impl Way<'static> for Owned {
    type Line = Box<dyn ByteLink>;

    fn options(&self) -> ConnectOptions {
        self.options
    }

    fn line(self) -> Result<Self::Line, Self> {
        match self.link {
            Link::Bytes(line) => Ok(line),
            link => Err(Owned {
                link,
                options: self.options,
            }),
        }
    }

    fn client(self, schema: Arc<Schema>, address: u8) -> Result<Box<dyn DriveClient>, EngineError> {
        connect::connect_with(self.link, schema, address, &self.options)
    }
}

/// A link the caller keeps (a line's bus), with its port's options:
/// [`connect::connect_on`]'s clients.
pub(super) struct Kept<'l> {
    pub(super) link: &'l mut Link,
    pub(super) options: ConnectOptions,
}

impl<'l> Way<'l> for Kept<'l> {
    type Line = BorrowedByteLink<'l>;

    fn options(&self) -> ConnectOptions {
        self.options
    }

    fn line(self) -> Result<Self::Line, Self> {
        match self.link {
            Link::Bytes(line) => Ok(BorrowedByteLink(&mut **line)),
            link => Err(Kept {
                link,
                options: self.options,
            }),
        }
    }

    fn client(
        self,
        schema: Arc<Schema>,
        address: u8,
    ) -> Result<Box<dyn DriveClient + 'l>, EngineError> {
        connect::connect_on(self.link, schema, address, &self.options)
    }
}

/// A drive reached: the client, the schema it speaks, what was learned.
pub(super) struct Reached<'l> {
    pub(super) schema: Arc<Schema>,
    pub(super) client: Box<dyn DriveClient + 'l>,
    pub(super) learned: Option<LearnedReport>,
}

/// The drive at `address` over `way`, speaking `schema`: a schema that
/// lacks facts ([`needs_learning`]) is learned first when `policy` says
/// so and the link is a character line ([`learn_on`] over a LUSTBUS client
/// speaking `schema`, the learned schema's client then connected on the
/// same line); else [`connected`]. `port` names the drive in a learned
/// file.
pub(super) fn reach<'l, W: Way<'l>>(
    way: W,
    port: &str,
    schema: Arc<Schema>,
    address: u8,
    policy: &SessionPolicy<'_>,
) -> Result<Reached<'l>, SessionError> {
    let Some(learn) = policy.learn.as_ref().filter(|_| needs_learning(&schema)) else {
        return Ok(connected(way, schema, address)?);
    };
    let options = way.options();
    let line = match way.line() {
        Ok(line) => line,
        Err(way) => return Ok(connected(way, schema, address)?),
    };
    let mut base = connect::lustbus(line, schema.clone(), address, &options)?;
    let learned = learn_on(&mut base, &schema, port, learn)?;
    let client = connect::lustbus(base.into_link(), learned.schema.clone(), address, &options)?;
    Ok(Reached {
        schema: learned.schema.clone(),
        client: Box::new(client),
        learned: Some(learned),
    })
}

/// The drive at `address` over `way`, speaking `schema` as it is: no
/// learning.
pub(super) fn connected<'l, W: Way<'l>>(
    way: W,
    schema: Arc<Schema>,
    address: u8,
) -> Result<Reached<'l>, EngineError> {
    Ok(Reached {
        client: way.client(schema.clone(), address)?,
        schema,
        learned: None,
    })
}
