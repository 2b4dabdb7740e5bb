//! Parsing a port string (see the module docs of [`super`]): the scheme,
//! the path or host:port, and the options after `?`, each checked against
//! the keys and values its scheme takes.

use std::collections::BTreeMap;

use crate::echo::EchoMode;

use super::{
    ALLOWED_BAUDS, ALLOWED_BITRATES, CAN_KEYS, MAX_LATENCY, OPENER_SCHEMES, OpaqueSpec, PortSpec,
    PortSpecErrorKind, SERIAL_KEYS, SLCAN_KEYS, TCP_KEYS,
};

/// A whole-number option (`baud=`, `bitrate=`) taken out of a port's
/// `key=value` items: `None` where `key` is not given, else a positive
/// whole number or [`PortSpecErrorKind::BadValue`]. The simulator's
/// `sim://` keys read theirs with it too.
pub fn take_number(
    map: &mut BTreeMap<String, String>,
    key: &str,
) -> Result<Option<u32>, PortSpecErrorKind> {
    let Some(value) = map.remove(key) else {
        return Ok(None);
    };
    match value.parse::<u32>() {
        Ok(n) if n > 0 => Ok(Some(n)),
        _ => Err(PortSpecErrorKind::BadValue {
            key: key.into(),
            value,
            reason: "not a positive whole number".into(),
        }),
    }
}

/// A `latency=` value: a whole or decimal number with the unit `ms`, `s`
/// or `us` (`40ms`, `0.1s`, `16.5ms`), at most [`MAX_LATENCY`], to the
/// microsecond. `Err` says what is wrong.
pub fn parse_latency(text: &str) -> Result<std::time::Duration, String> {
    let (number, unit_us) = if let Some(n) = text.strip_suffix("ms") {
        (n, 1_000u64)
    } else if let Some(n) = text.strip_suffix("us") {
        (n, 1)
    } else if let Some(n) = text.strip_suffix('s') {
        (n, 1_000_000)
    } else {
        return Err("give a unit: e.g. latency=40ms or latency=0.1s".into());
    };
    let (whole, frac) = number.split_once('.').unwrap_or((number, ""));
    let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
    if !digits(whole) || (number.contains('.') && !digits(frac)) {
        return Err("not a number with a unit (ms, s, us), e.g. latency=40ms".into());
    }
    let too_long = || format!("at most {} s", MAX_LATENCY.as_secs());
    let whole: u64 = whole.parse().map_err(|_| too_long())?;
    let mut us = whole.checked_mul(unit_us).ok_or_else(too_long)?;
    // the fraction, to the microsecond
    let mut scale = unit_us;
    for b in frac.bytes() {
        scale /= 10;
        if scale == 0 {
            if b != b'0' {
                return Err("finer than a microsecond".into());
            }
            continue;
        }
        us += u64::from(b - b'0') * scale;
    }
    let d = std::time::Duration::from_micros(us);
    if d > MAX_LATENCY {
        return Err(too_long());
    }
    Ok(d)
}

/// The items of a query (`key=value&...`), checked for their form and, with
/// `allowed`, against the keys a scheme takes.
fn query_items(
    query: Option<&str>,
    allowed: Option<(&'static str, &'static [&'static str])>,
) -> Result<BTreeMap<String, String>, PortSpecErrorKind> {
    let mut map = BTreeMap::new();
    let Some(query) = query else {
        return Ok(map);
    };
    for item in query.split('&') {
        if item.is_empty() {
            return Err(PortSpecErrorKind::EmptyOption);
        }
        let Some((key, value)) = item.split_once('=') else {
            return Err(PortSpecErrorKind::MalformedOption { item: item.into() });
        };
        if let Some((scheme, allowed)) = allowed
            && !allowed.contains(&key)
        {
            return Err(PortSpecErrorKind::UnknownOption {
                key: key.into(),
                scheme,
                allowed,
            });
        }
        if value.is_empty() {
            return Err(PortSpecErrorKind::BadValue {
                key: key.into(),
                value: String::new(),
                reason: "empty value".into(),
            });
        }
        if map.insert(key.to_string(), value.to_string()).is_some() {
            return Err(PortSpecErrorKind::DuplicateOption { key: key.into() });
        }
    }
    Ok(map)
}

/// `baud=`, `echo=` and `latency=` of a character line.
type LineOptions = (Option<u32>, Option<EchoMode>, Option<std::time::Duration>);

/// The options after `?`, checked against the keys a scheme takes.
struct Options {
    map: BTreeMap<String, String>,
}

impl Options {
    fn parse(
        query: Option<&str>,
        scheme: &'static str,
        allowed: &'static [&'static str],
    ) -> Result<Options, PortSpecErrorKind> {
        query_items(query, Some((scheme, allowed))).map(|map| Options { map })
    }

    fn number(&mut self, key: &str) -> Result<Option<u32>, PortSpecErrorKind> {
        take_number(&mut self.map, key)
    }

    /// `baud=`, checked against [`ALLOWED_BAUDS`].
    fn line_baud(&mut self) -> Result<Option<u32>, PortSpecErrorKind> {
        match self.number("baud")? {
            Some(baud) if !ALLOWED_BAUDS.contains(&baud) => {
                Err(PortSpecErrorKind::UnsupportedBaud { baud })
            }
            other => Ok(other),
        }
    }

    /// `echo=auto|on|off`.
    fn echo(&mut self) -> Result<Option<EchoMode>, PortSpecErrorKind> {
        let Some(value) = self.map.remove("echo") else {
            return Ok(None);
        };
        match EchoMode::parse(&value) {
            // `auto` is the default: kept as `None` so that a port string
            // and its canonical form are the same spec.
            Some(EchoMode::Auto) => Ok(None),
            Some(mode) => Ok(Some(mode)),
            None => Err(PortSpecErrorKind::BadValue {
                key: "echo".into(),
                value,
                reason: "use auto (detect, the default), on (the line returns what driveset sends: strip it) or off".into(),
            }),
        }
    }

    /// `latency=` ([`parse_latency`]).
    fn latency(&mut self) -> Result<Option<std::time::Duration>, PortSpecErrorKind> {
        let Some(value) = self.map.remove("latency") else {
            return Ok(None);
        };
        parse_latency(&value)
            .map(Some)
            .map_err(|reason| PortSpecErrorKind::BadValue {
                key: "latency".into(),
                value,
                reason,
            })
    }

    /// The options of a character line (serial, `tcp://`, `rfc2217://`):
    /// `baud=`, `echo=` and `latency=`, checked in that order.
    fn line(&mut self) -> Result<LineOptions, PortSpecErrorKind> {
        Ok((self.line_baud()?, self.echo()?, self.latency()?))
    }

    /// `bitrate=`, checked against [`ALLOWED_BITRATES`].
    fn bitrate(&mut self) -> Result<Option<u32>, PortSpecErrorKind> {
        match self.number("bitrate")? {
            Some(bitrate) => check_bitrate(bitrate).map(Some),
            None => Ok(None),
        }
    }
}

/// `host:port/rest` or `can0/rest` at the first `/`: what the scheme
/// takes, and a trailing path (`/rest`, empty when there is none).
fn split_path(rest: &str) -> (&str, &str) {
    match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, ""),
    }
}

fn check_bitrate(bitrate: u32) -> Result<u32, PortSpecErrorKind> {
    if ALLOWED_BITRATES.contains(&bitrate) {
        Ok(bitrate)
    } else {
        Err(PortSpecErrorKind::UnsupportedBitrate { bitrate })
    }
}

pub(super) fn parse(input: &str) -> Result<PortSpec, PortSpecErrorKind> {
    let input = input.trim();
    if input.is_empty() {
        return Err(PortSpecErrorKind::Empty);
    }
    let (body, query) = match input.split_once('?') {
        Some((body, query)) => (body, Some(query)),
        None => (input, None),
    };
    if query == Some("") {
        return Err(PortSpecErrorKind::EmptyOption);
    }
    let Some((scheme, rest)) = body.split_once("://") else {
        return parse_serial(body, query);
    };
    match scheme {
        "tcp" => parse_tcp(rest, query, "tcp"),
        "rfc2217" => parse_tcp(rest, query, "rfc2217"),
        "slcan" => parse_slcan(rest, query),
        "can" => parse_can(rest, query),
        s if OPENER_SCHEMES.contains(&s) => Ok(PortSpec::Sim(OpaqueSpec {
            scheme: s.to_string(),
            path: rest.to_string(),
            query: query_items(query, None)?,
        })),
        _ => Err(PortSpecErrorKind::UnknownScheme {
            scheme: scheme.into(),
        }),
    }
}

fn parse_serial(path: &str, query: Option<&str>) -> Result<PortSpec, PortSpecErrorKind> {
    if path.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "serial",
            what: "a device path",
            example: "/dev/ttyUSB0?baud=9600 or COM3",
        });
    }
    let mut opts = Options::parse(query, "serial", SERIAL_KEYS)?;
    let (baud, echo, latency) = opts.line()?;
    Ok(PortSpec::Serial {
        path: path.into(),
        baud,
        echo,
        latency,
    })
}

/// `tcp://host:port` and `rfc2217://host:port` (`scheme`).
fn parse_tcp(
    rest: &str,
    query: Option<&str>,
    scheme: &'static str,
) -> Result<PortSpec, PortSpecErrorKind> {
    let rfc2217 = scheme == "rfc2217";
    let (example, example6): (&'static str, &'static str) = if rfc2217 {
        ("rfc2217://192.168.0.7:2217", "rfc2217://[fe80::1]:2217")
    } else {
        ("tcp://192.168.0.7:4001", "tcp://[fe80::1]:4001")
    };
    if rest.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme,
            what: "host:port",
            example,
        });
    }
    let (host_port, trailing) = split_path(rest);
    let (host, port_text) = if let Some(bracketed) = host_port.strip_prefix('[') {
        let Some((host, after)) = bracketed.split_once(']') else {
            return Err(PortSpecErrorKind::BadHost {
                host: host_port.into(),
                reason: "missing `]` after the IPv6 address",
            });
        };
        let Some(port) = after.strip_prefix(':') else {
            return Err(PortSpecErrorKind::Missing {
                scheme,
                what: "a port after the host",
                example: example6,
            });
        };
        (host, port)
    } else {
        let Some((host, port)) = host_port.rsplit_once(':') else {
            return Err(PortSpecErrorKind::Missing {
                scheme,
                what: "a port after the host",
                example,
            });
        };
        if host.contains(':') {
            return Err(PortSpecErrorKind::BadHost {
                host: host.into(),
                reason: if rfc2217 {
                    "write IPv6 addresses in brackets: rfc2217://[::1]:2217"
                } else {
                    "write IPv6 addresses in brackets: tcp://[::1]:4001"
                },
            });
        }
        (host, port)
    };
    if host.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme,
            what: "a host before the port",
            example,
        });
    }
    if host.chars().any(|c| c.is_whitespace() || c == '@') {
        return Err(PortSpecErrorKind::BadHost {
            host: host.into(),
            reason: "not a host name or IP address",
        });
    }
    let port = match port_text.parse::<u16>() {
        Ok(p) if p > 0 => p,
        _ => {
            return Err(PortSpecErrorKind::BadTcpPort {
                value: port_text.into(),
            });
        }
    };
    if !trailing.is_empty() {
        return Err(PortSpecErrorKind::TrailingPath {
            rest: trailing.into(),
            after: host_port.into(),
            scheme,
            takes: "host:port",
        });
    }
    let mut opts = Options::parse(
        query,
        if rfc2217 { "rfc2217://" } else { "tcp://" },
        TCP_KEYS,
    )?;
    let (baud, echo, latency) = opts.line()?;
    let host = host.to_string();
    Ok(if rfc2217 {
        PortSpec::Rfc2217 {
            host,
            port,
            baud,
            echo,
            latency,
        }
    } else {
        PortSpec::Tcp {
            host,
            port,
            baud,
            echo,
            latency,
        }
    })
}

fn parse_slcan(path: &str, query: Option<&str>) -> Result<PortSpec, PortSpecErrorKind> {
    if path.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "slcan",
            what: "the adapter's serial device",
            example: "slcan:///dev/ttyACM0?bitrate=500000",
        });
    }
    let mut opts = Options::parse(query, "slcan://", SLCAN_KEYS)?;
    let bitrate = opts.bitrate()?;
    let baud = opts.number("baud")?;
    Ok(PortSpec::Slcan {
        path: path.into(),
        bitrate,
        baud,
    })
}

fn parse_can(rest: &str, query: Option<&str>) -> Result<PortSpec, PortSpecErrorKind> {
    if rest.is_empty() {
        return Err(PortSpecErrorKind::Missing {
            scheme: "can",
            what: "a SocketCAN interface name",
            example: "can://can0",
        });
    }
    let (interface, trailing) = split_path(rest);
    if !trailing.is_empty() {
        return Err(PortSpecErrorKind::TrailingPath {
            rest: trailing.into(),
            after: interface.into(),
            scheme: "can",
            takes: "an interface name",
        });
    }
    if interface.len() > 15 {
        return Err(PortSpecErrorKind::BadInterface {
            name: interface.into(),
            reason: "longer than 15 characters (the kernel's limit)",
        });
    }
    if !interface
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err(PortSpecErrorKind::BadInterface {
            name: interface.into(),
            reason: "use letters, digits, `-`, `_` and `.` only",
        });
    }
    let mut opts = Options::parse(query, "can://", CAN_KEYS)?;
    let bitrate = opts.bitrate()?;
    let baud = opts.number("baud")?;
    let bitrate = match (baud, bitrate) {
        (Some(baud), Some(bitrate)) if baud != bitrate => {
            return Err(PortSpecErrorKind::ConflictingRates { baud, bitrate });
        }
        (Some(baud), None) => Some(check_bitrate(baud)?),
        (_, bitrate) => bitrate,
    };
    Ok(PortSpec::SocketCan {
        interface: interface.into(),
        bitrate,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_number_option_is_taken_out_and_must_be_a_positive_whole_number() {
        let mut map: BTreeMap<String, String> = [("baud", "9600"), ("bitrate", "0"), ("x", "y")]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        assert_eq!(take_number(&mut map, "baud"), Ok(Some(9600)));
        assert!(!map.contains_key("baud"), "taken out");
        assert_eq!(take_number(&mut map, "baud"), Ok(None));
        assert_eq!(
            take_number(&mut map, "bitrate"),
            Err(PortSpecErrorKind::BadValue {
                key: "bitrate".into(),
                value: "0".into(),
                reason: "not a positive whole number".into(),
            })
        );
        assert!(take_number(&mut map, "x").is_err());
    }
}
