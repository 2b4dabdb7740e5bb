//! The canonical form of a port ([`PortSpec`]'s `Display`): defaults not
//! spelled out, options in a fixed order, IPv6 hosts in brackets.

use std::fmt;

use crate::echo::EchoMode;

use super::{OpaqueSpec, PortSpec};

/// Writes the canonical form: defaults not spelled out, options in a fixed
/// order (`addresses` or the per-family keys alphabetically, `baud`,
/// `bitrate`, then the rest alphabetically).
impl fmt::Display for PortSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut q = Query::default();
        match self {
            PortSpec::Serial {
                path,
                baud,
                echo,
                latency,
            } => {
                f.write_str(path)?;
                q.line(*baud, *echo, *latency);
            }
            PortSpec::Tcp {
                host,
                port,
                baud,
                echo,
                latency,
            }
            | PortSpec::Rfc2217 {
                host,
                port,
                baud,
                echo,
                latency,
            } => {
                let scheme = if matches!(self, PortSpec::Rfc2217 { .. }) {
                    "rfc2217"
                } else {
                    "tcp"
                };
                write_host_port(f, scheme, host, *port)?;
                q.line(*baud, *echo, *latency);
            }
            PortSpec::Slcan {
                path,
                bitrate,
                baud,
            } => {
                write!(f, "slcan://{path}")?;
                q.num("baud", *baud);
                q.num("bitrate", *bitrate);
            }
            PortSpec::SocketCan { interface, bitrate } => {
                write!(f, "can://{interface}")?;
                q.num("bitrate", *bitrate);
            }
            PortSpec::Sim(spec) => return write!(f, "{spec}"),
        }
        f.write_str(&q.0)
    }
}

fn write_host_port(f: &mut fmt::Formatter<'_>, scheme: &str, host: &str, port: u16) -> fmt::Result {
    if host.contains(':') {
        write!(f, "{scheme}://[{host}]:{port}")
    } else {
        write!(f, "{scheme}://{host}:{port}")
    }
}

/// Builds `?a=1&b=2`.
#[derive(Default)]
struct Query(String);

impl Query {
    fn text(&mut self, key: &str, value: &str) {
        self.0.push(if self.0.is_empty() { '?' } else { '&' });
        self.0.push_str(key);
        self.0.push('=');
        self.0.push_str(value);
    }
    /// `echo=`, left out when it is the default (`auto`).
    fn echo(&mut self, value: Option<EchoMode>) {
        match value {
            None | Some(EchoMode::Auto) => {}
            Some(mode) => self.text("echo", mode.name()),
        }
    }
    /// The options of a character line (serial, `tcp://`, `rfc2217://`):
    /// `baud=`, `echo=`, `latency=`, in that order.
    fn line(
        &mut self,
        baud: Option<u32>,
        echo: Option<EchoMode>,
        latency: Option<std::time::Duration>,
    ) {
        self.num("baud", baud);
        self.echo(echo);
        self.latency(latency);
    }
    fn num(&mut self, key: &str, value: Option<u32>) {
        if let Some(v) = value {
            self.text(key, &v.to_string());
        }
    }
    /// `latency=` in whole milliseconds, or microseconds when it has a
    /// fraction of a millisecond.
    fn latency(&mut self, value: Option<std::time::Duration>) {
        if let Some(d) = value {
            let text = if d.as_micros() % 1000 == 0 {
                format!("{}ms", d.as_millis())
            } else {
                format!("{}us", d.as_micros())
            };
            self.text("latency", &text);
        }
    }
}

/// `scheme://path?k=v&...`, the keys in alphabetical order.
impl fmt::Display for OpaqueSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}://{}", self.scheme, self.path)?;
        let mut q = Query::default();
        for (key, value) in &self.query {
            q.text(key, value);
        }
        f.write_str(&q.0)
    }
}
