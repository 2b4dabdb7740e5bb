//! Opening a transport from a [`PortSpec`]: [`open`], its [`OpenOptions`]
//! and the [`Link`] it returns (a byte line or a CAN bus).

use std::time::Duration;

use crate::ByteLink;
use crate::FrameLink;
use crate::echo::{EchoLink, EchoMode};
use crate::error::LinkError;
use crate::rfc2217::Rfc2217Link;
use crate::serial::SerialLink;
use crate::spec::{DEFAULT_BAUD, PortSpec};
use crate::tcp::TcpLink;

/// Settings for [`open`] that the port string does not carry.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct OpenOptions {
    /// How long to wait for a TCP device server to accept the connection
    /// (and, on `rfc2217://`, separately for the telnet negotiation).
    pub connect_timeout: Duration,
    /// How long an slcan adapter may take to answer each command of the
    /// open sequence.
    pub adapter_timeout: Duration,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions {
            connect_timeout: crate::tcp::DEFAULT_CONNECT_TIMEOUT,
            adapter_timeout: Duration::from_millis(500),
        }
    }
}

/// An open transport: a byte line (serial, TCP) or a CAN bus (slcan,
/// SocketCAN). Real transports run on [`crate::RealClock`].
#[derive(Debug)]
pub enum Link {
    /// A LUSTBUS / LECOM line.
    Bytes(Box<dyn ByteLink>),
    /// A CAN bus.
    Frames(Box<dyn FrameLink>),
}

impl Link {
    /// The port, as errors and reports name it.
    pub fn port(&self) -> &str {
        match self {
            Link::Bytes(link) => link.port(),
            Link::Frames(link) => link.port(),
        }
    }
}

/// A character line behind its [`EchoLink`] (`echo=`, default `auto`).
fn with_echo<L: ByteLink + 'static>(link: L, echo: Option<EchoMode>) -> Box<dyn ByteLink> {
    Box::new(EchoLink::new(link, echo.unwrap_or_default()))
}

/// Open the transport `spec` names. Character lines (serial, `tcp://`,
/// `rfc2217://`) come wrapped in an [`EchoLink`] with the port's `echo=`
/// mode (`echo=off` makes it a pass-through). `sim://` ports are refused with
/// [`LinkError::SimPort`]: the CLI opens them with the simulator.
pub fn open(spec: &PortSpec, options: &OpenOptions) -> Result<Link, LinkError> {
    match spec {
        PortSpec::Serial {
            path, baud, echo, ..
        } => {
            let link = SerialLink::open(path, baud.unwrap_or(DEFAULT_BAUD))?;
            Ok(Link::Bytes(with_echo(link, *echo)))
        }
        PortSpec::Tcp {
            host,
            port,
            baud,
            echo,
            ..
        } => {
            let link = TcpLink::connect(
                host,
                *port,
                baud.unwrap_or(DEFAULT_BAUD),
                options.connect_timeout,
            )?;
            Ok(Link::Bytes(with_echo(link, *echo)))
        }
        PortSpec::Rfc2217 {
            host,
            port,
            baud,
            echo,
            ..
        } => {
            let link = Rfc2217Link::connect(
                host,
                *port,
                baud.unwrap_or(DEFAULT_BAUD),
                options.connect_timeout,
            )?;
            Ok(Link::Bytes(with_echo(link, *echo)))
        }
        PortSpec::Sim(_) => Err(LinkError::SimPort {
            port: spec.to_string(),
        }),
        PortSpec::Slcan {
            path,
            bitrate,
            baud,
        } => {
            let link = crate::slcan::SlcanLink::open(
                path,
                bitrate.unwrap_or(crate::spec::DEFAULT_BITRATE),
                baud.unwrap_or(crate::spec::DEFAULT_SLCAN_BAUD),
                options.adapter_timeout,
            )?;
            Ok(Link::Frames(Box::new(link)))
        }
        #[cfg(all(feature = "socketcan", target_os = "linux"))]
        PortSpec::SocketCan { interface, bitrate } => {
            let link = crate::socketcan::SocketCanLink::open(
                interface,
                bitrate.unwrap_or(crate::spec::DEFAULT_BITRATE),
            )?;
            Ok(Link::Frames(Box::new(link)))
        }
        #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
        PortSpec::SocketCan { .. } => Err(LinkError::Unsupported {
            port: spec.to_string(),
            what: "SocketCAN needs Linux and driveset built with the cargo feature `socketcan`; \
                   or use an slcan adapter (slcan:///dev/ttyACM0)"
                .into(),
        }),
    }
}
