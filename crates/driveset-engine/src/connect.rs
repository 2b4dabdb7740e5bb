//! Owns the one way to reach a drive: a link, a schema (whose family's
//! descriptor names the bus protocol) and an address give the
//! [`DriveClient`] of that protocol. Every command and `commission` connect
//! through here (a drive's work through [`crate::session`]); nothing else
//! picks a client by family. A line's work on its bus that only one
//! protocol's client does (the two broadcasts) gets that client here too
//! ([`lustbus_on`], [`lecom_on`]).

use std::sync::Arc;
use std::time::Duration;

use driveset_link::Link;
use driveset_schema::{BusProtocol, Schema};

use crate::client::{
    BorrowedByteLink, BorrowedFrameLink, CanClient, DriveClient, LecomClient, LecomOptions,
    LustbusClient, LustbusOptions, Target,
};
use crate::error::{EngineError, LinkKind, Refusal};

/// What a port says about how to talk to its drives.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ConnectOptions {
    /// The round-trip delay the transport adds (the port's `latency=`),
    /// added to the serial clients' answer timeouts from the first telegram.
    pub latency: Option<Duration>,
}

impl ConnectOptions {
    /// What `spec` says (its `latency=`).
    pub fn of(spec: &driveset_link::PortSpec) -> Self {
        ConnectOptions {
            latency: spec.latency(),
        }
    }

    /// The LUSTBUS client's options.
    pub fn lustbus(&self) -> LustbusOptions {
        LustbusOptions {
            latency: self.latency,
            ..LustbusOptions::default()
        }
    }

    /// The LECOM client's options.
    pub fn lecom(&self) -> LecomOptions {
        LecomOptions {
            latency: self.latency,
            ..LecomOptions::default()
        }
    }
}

/// A client for the drive at `address` on `link`, speaking the protocol of
/// `schema`'s family. A schema whose protocol does not run on this kind of
/// link (CAN SDO on a character line, LUSTBUS / LECOM on a CAN bus) is
/// refused before anything is sent.
pub fn connect(
    link: Link,
    schema: Arc<Schema>,
    address: u8,
) -> Result<Box<dyn DriveClient>, EngineError> {
    connect_with(link, schema, address, &ConnectOptions::default())
}

/// As [`connect`], with the port's options.
pub fn connect_with(
    link: Link,
    schema: Arc<Schema>,
    address: u8,
    opts: &ConnectOptions,
) -> Result<Box<dyn DriveClient>, EngineError> {
    match (link, schema.family.bus()) {
        (Link::Bytes(b), BusProtocol::Lustbus) => Ok(Box::new(LustbusClient::with_options(
            b,
            schema,
            address,
            opts.lustbus(),
        )?)),
        (Link::Bytes(b), BusProtocol::Lecom) => Ok(Box::new(LecomClient::with_options(
            b,
            schema,
            address,
            opts.lecom(),
        )?)),
        (Link::Frames(f), BusProtocol::CanSdo) => Ok(Box::new(CanClient::new(f, schema, address)?)),
        (link, _) => Err(misfit(&link, &schema, address)),
    }
}

/// As [`connect_with`], on a link the caller keeps (a line's bus, a scan),
/// with its port's options (a line's bus: `ConnectOptions::of` its port).
pub fn connect_on<'l>(
    link: &'l mut Link,
    schema: Arc<Schema>,
    address: u8,
    opts: &ConnectOptions,
) -> Result<Box<dyn DriveClient + 'l>, EngineError> {
    if !fits(link, &schema) {
        return Err(misfit(link, &schema, address));
    }
    let bus = schema.family.bus();
    match link {
        Link::Bytes(b) => {
            let b = BorrowedByteLink(&mut **b);
            if bus == BusProtocol::Lecom {
                Ok(Box::new(LecomClient::with_options(
                    b,
                    schema,
                    address,
                    opts.lecom(),
                )?))
            } else {
                Ok(Box::new(LustbusClient::with_options(
                    b,
                    schema,
                    address,
                    opts.lustbus(),
                )?))
            }
        }
        Link::Frames(f) => Ok(Box::new(CanClient::new(
            BorrowedFrameLink(&mut **f),
            schema,
            address,
        )?)),
    }
}

/// The LUSTBUS client for the drive at `address` on a link the caller
/// keeps, for what only a LUSTBUS client does on a line's bus: its SELECT
/// to address 31 and the dataset download resumed around it (§4.2, §11.4). A CAN bus is
/// refused ([`Refusal::LustbusOnCan`]) before anything is sent.
pub fn lustbus_on<'l>(
    link: &'l mut Link,
    schema: Arc<Schema>,
    address: u8,
    opts: &ConnectOptions,
) -> Result<LustbusClient<BorrowedByteLink<'l>>, EngineError> {
    match link {
        Link::Bytes(b) => {
            LustbusClient::with_options(BorrowedByteLink(&mut **b), schema, address, opts.lustbus())
        }
        Link::Frames(f) => Err(EngineError::refused(
            Target {
                port: f.port().to_string(),
                address,
            },
            Refusal::LustbusOnCan,
        )),
    }
}

/// The LECOM client for the drive at `address` on a link the caller keeps,
/// for what only a LECOM client does: a line's MULTICAST to a group and
/// the running check of its members before it. A CAN bus is refused as a
/// misfit ([`Refusal::LinkMisfit`]) before anything is sent.
pub fn lecom_on<'l>(
    link: &'l mut Link,
    schema: Arc<Schema>,
    address: u8,
    opts: &ConnectOptions,
) -> Result<LecomClient<BorrowedByteLink<'l>>, EngineError> {
    match link {
        Link::Bytes(b) => {
            LecomClient::with_options(BorrowedByteLink(&mut **b), schema, address, opts.lecom())
        }
        Link::Frames(f) => Err(misfit_on(f.port(), LinkKind::CanBus, &schema, address)),
    }
}

/// A LUSTBUS client for the drive at `address` on a character line, for
/// what only LUSTBUS does (learning from the descriptions, schema pull, the
/// MC-or-VF1000 probe): a schema of another protocol is refused
/// (`Refusal::WrongClient`) before anything is sent.
pub fn lustbus<L: driveset_link::ByteLink>(
    line: L,
    schema: Arc<Schema>,
    address: u8,
    opts: &ConnectOptions,
) -> Result<LustbusClient<L>, EngineError> {
    LustbusClient::with_options(line, schema, address, opts.lustbus())
}

/// Whether `schema`'s protocol runs on this kind of link.
pub fn fits(link: &Link, schema: &Schema) -> bool {
    matches!(
        (link, schema.family.bus()),
        (Link::Bytes(_), BusProtocol::Lustbus | BusProtocol::Lecom)
            | (Link::Frames(_), BusProtocol::CanSdo)
    )
}

fn misfit(link: &Link, schema: &Schema, address: u8) -> EngineError {
    match link {
        Link::Bytes(b) => misfit_on(b.port(), LinkKind::CharacterLine, schema, address),
        Link::Frames(f) => misfit_on(f.port(), LinkKind::CanBus, schema, address),
    }
}

fn misfit_on(port: &str, link: LinkKind, schema: &Schema, address: u8) -> EngineError {
    EngineError::refused(
        Target {
            port: port.to_string(),
            address,
        },
        Refusal::LinkMisfit {
            schema: schema.id.clone(),
            family: schema.family.to_string(),
            bus: schema.family.bus().title().to_string(),
            link,
        },
    )
}
