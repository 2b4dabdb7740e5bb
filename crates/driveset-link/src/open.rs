//! Opening a transport from a [`PortSpec`]: [`open`], its [`OpenOptions`]
//! and the [`Link`] it returns (a byte line or a CAN bus); the
//! [`PortOpener`] trait for the schemes this crate does not open itself
//! (`sim://`: the simulator implements it) and the registry of openers a
//! program passes to [`open_with`] ([`Openers`]).

use std::sync::Arc;
use std::time::Duration;

use crate::ByteLink;
use crate::FrameLink;
use crate::echo::{EchoLink, EchoMode};
use crate::error::LinkError;
use crate::rfc2217::Rfc2217Link;
use crate::serial::SerialLink;
use crate::spec::{DEFAULT_BAUD, OpaqueSpec, PortSpec, PortSpecError};
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

    /// Which bus this is ([`ByteLink::bus_id`], [`FrameLink::bus_id`]).
    pub fn bus_id(&self) -> String {
        match self {
            Link::Bytes(link) => link.bus_id(),
            Link::Frames(link) => link.bus_id(),
        }
    }
}

/// What a [`PortOpener`]'s port holds, as far as a program checks a port
/// before it opens it (a line manifest, `driveset validate`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortShape {
    /// Whether the port carries CAN frames (else bytes).
    pub frames: bool,
    /// The drives on it, as (family as the port names it, address), in
    /// the port's order; empty when the port names none (a program that
    /// knows which drives it wants gives them with
    /// [`PortOpener::with_drives`]).
    pub drives: Vec<(String, u8)>,
    /// Whether it holds drives of several families (a mixed LUSTBUS).
    pub mixed: bool,
    /// The port as reports name it (canonical, without options that only
    /// say where the opener keeps its own state).
    pub name: String,
}

/// Opens the ports of one scheme this crate does not open itself
/// ([`crate::spec::OPENER_SCHEMES`]): the simulator implements it for
/// `sim://`. The opener owns the query's keys, their checks and their
/// error messages (what, where, what to write instead).
pub trait PortOpener: Send + Sync {
    /// The scheme it opens (`sim`).
    fn scheme(&self) -> &str;
    /// Check `spec` without opening it and say what it holds.
    fn check(&self, spec: &OpaqueSpec) -> Result<PortShape, PortSpecError>;
    /// `spec` with `drives` (family name, address) put on it when it names
    /// no drives itself (a line manifest's drives on `sim://FAMILY`);
    /// `spec` unchanged when it does.
    fn with_drives(&self, spec: &OpaqueSpec, drives: &[(&str, u8)]) -> OpaqueSpec;
    /// `spec` running at `rate` (baud on a character line, bit/s on CAN).
    fn with_rate(&self, spec: &OpaqueSpec, rate: u32) -> OpaqueSpec;
    /// `spec` without the keys that belong to one run of a command (the
    /// simulator's injected faults and their seed), as a later command
    /// (`recover` of a journal such a run cut) reaches the same drives:
    /// by default `spec` unchanged.
    fn without_run_keys(&self, spec: &OpaqueSpec) -> OpaqueSpec {
        spec.clone()
    }
    /// Open `spec`.
    fn open(&self, spec: &OpaqueSpec, options: &OpenOptions) -> Result<Link, LinkError>;
}

/// The openers a program registers, by scheme ([`open_with`]).
#[derive(Clone, Default)]
pub struct Openers(Vec<Arc<dyn PortOpener>>);

impl std::fmt::Debug for Openers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.0.iter().map(|o| o.scheme().to_string()))
            .finish()
    }
}

impl Openers {
    /// No openers: only the ports this crate opens itself.
    pub fn none() -> Self {
        Openers(Vec::new())
    }

    /// These openers plus `opener` (which replaces one of the same scheme).
    #[must_use]
    pub fn with(mut self, opener: Arc<dyn PortOpener>) -> Self {
        self.0.retain(|o| o.scheme() != opener.scheme());
        self.0.push(opener);
        self
    }

    /// The opener of `scheme`.
    pub fn get(&self, scheme: &str) -> Option<&dyn PortOpener> {
        self.0.iter().find(|o| o.scheme() == scheme).map(|o| &**o)
    }

    /// `spec` running at line rate `rate` (`baud=` on a character line,
    /// `bitrate=` on an slcan adapter; a SocketCAN interface's rate is the
    /// system's; an opaque port through its registered opener, unchanged
    /// without one).
    pub fn at_rate(&self, spec: &PortSpec, rate: u32) -> PortSpec {
        let mut s = spec.clone();
        match &mut s {
            PortSpec::Serial { baud, .. }
            | PortSpec::Tcp { baud, .. }
            | PortSpec::Rfc2217 { baud, .. } => *baud = Some(rate),
            PortSpec::Slcan { bitrate, .. } => *bitrate = Some(rate),
            PortSpec::Sim(o) => {
                if let Some(opener) = self.get(&o.scheme) {
                    *o = opener.with_rate(o, rate);
                }
            }
            PortSpec::SocketCan { .. } => {}
        }
        s
    }

    /// The opener of an opaque port, or the error that none is registered.
    pub fn opener(&self, spec: &OpaqueSpec) -> Result<&dyn PortOpener, LinkError> {
        self.get(&spec.scheme).ok_or_else(|| LinkError::SimPort {
            port: spec.to_string(),
        })
    }
}

/// Open `spec`: an opaque port ([`PortSpec::Sim`]) through its registered
/// opener, every other port as [`open`] does.
pub fn open_with(
    spec: &PortSpec,
    options: &OpenOptions,
    openers: &Openers,
) -> Result<Link, LinkError> {
    match spec {
        PortSpec::Sim(o) => openers.opener(o)?.open(o, options),
        _ => open(spec, options),
    }
}

/// A character line behind its [`EchoLink`] (`echo=`, default `auto`).
fn with_echo<L: ByteLink + 'static>(link: L, echo: Option<EchoMode>) -> Box<dyn ByteLink> {
    Box::new(EchoLink::new(link, echo.unwrap_or_default()))
}

/// Open the transport `spec` names. Character lines (serial, `tcp://`,
/// `rfc2217://`) come wrapped in an [`EchoLink`] with the port's `echo=`
/// mode (`echo=off` makes it a pass-through). `sim://` ports are refused with
/// [`LinkError::SimPort`]: [`open_with`] opens them with a registered
/// [`PortOpener`].
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_port_at_another_rate_keeps_the_rest_of_its_spelling() {
        let at = |p: &str, r| Openers::none().at_rate(&PortSpec::parse(p).unwrap(), r);
        assert_eq!(
            at("/dev/ttyUSB0?baud=9600", 19200),
            PortSpec::parse("/dev/ttyUSB0?baud=19200").unwrap()
        );
        assert_eq!(
            at("tcp://moxa:4001?latency=80ms", 38400),
            PortSpec::parse("tcp://moxa:4001?baud=38400&latency=80ms").unwrap()
        );
        assert_eq!(
            at("slcan:///dev/ttyACM0", 250000),
            PortSpec::parse("slcan:///dev/ttyACM0?bitrate=250000").unwrap()
        );
        assert_eq!(
            at("can://can0", 250000),
            PortSpec::parse("can://can0").unwrap()
        );
        // an opaque port without its opener stays as it is
        assert_eq!(
            at("sim://mc6000?addresses=1", 38400),
            PortSpec::parse("sim://mc6000?addresses=1").unwrap()
        );
    }
}
