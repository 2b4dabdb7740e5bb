//! Owns reaching a lone drive on its line for `driveset address`: the
//! line's rate, port, bus id and clock, and the single probes that hear
//! what answers at an address (a LUSTBUS ENQUIRY that reports garbage too,
//! `lustbus-protocol.txt` §4.2; a LECOM RECEIVE, `lecom-ab-tmd-manual.txt`
//! §4c), with answer timeouts that fit the line rate.

use std::time::Duration;

use driveset_link::mem::wire_time;
use driveset_link::{ByteLink, Link, LinkError};
use driveset_proto::lecom::ControllerAddress;
use driveset_proto::lustbus::{Address, ParameterCode};
use driveset_schema::{BusProtocol, CodeKey};

use super::AssignRefusal;
use super::refusal::{link_err, refuse};
use crate::client::BorrowedByteLink;
use crate::client::lecom::LecomLine;
use crate::client::lustbus::{Heard, LustLine};
use crate::error::EngineError;
use crate::scan::ScanOptions;

pub(super) fn bytes(
    link: &mut Link,
    protocol: BusProtocol,
) -> Result<&mut dyn ByteLink, EngineError> {
    match link {
        Link::Bytes(b) => Ok(b.as_mut()),
        Link::Frames(f) => Err(refuse(
            f.port(),
            0,
            AssignRefusal::NotSerial {
                protocol: protocol.title().to_string(),
            },
        )),
    }
}

pub(super) fn lust_timeout(link: &dyn ByteLink, opts: &ScanOptions) -> Duration {
    opts.timeout
        .unwrap_or_else(|| Duration::from_millis(65) + wire_time(14, link.baud()))
}

/// An ENQUIRY of `code` at `address`, reporting garbage too.
pub(super) fn lust_probe(
    link: &mut dyn ByteLink,
    address: Address,
    code: ParameterCode,
    opts: &ScanOptions,
) -> Result<Heard, LinkError> {
    let timeout = lust_timeout(link, opts);
    let mut line = LustLine::new(BorrowedByteLink(link));
    line.wait_late = false;
    let h =
        crate::client::lustbus::probe_heard(&mut line, address, code, timeout, opts.tries.max(2))?;
    line.finish()?;
    Ok(h)
}

pub(super) fn set_rate(link: &mut Link, baud: u32) -> Result<bool, EngineError> {
    let port = match link {
        Link::Bytes(b) => b.port().to_string(),
        Link::Frames(f) => f.port().to_string(),
    };
    let Link::Bytes(b) = link else {
        return Ok(false);
    };
    if b.baud() == baud {
        return Ok(true);
    }
    match b.set_baud(baud) {
        Ok(()) => Ok(true),
        Err(LinkError::UnsupportedBaud { .. }) => Ok(false),
        Err(e) => Err(link_err(&port, 0, e)),
    }
}

pub(super) fn baud_of(link: &Link) -> u32 {
    match link {
        Link::Bytes(b) => b.baud(),
        Link::Frames(f) => f.bitrate(),
    }
}

pub(super) fn now(link: &Link) -> driveset_link::Instant {
    match link {
        Link::Bytes(b) => b.clock().now(),
        Link::Frames(f) => f.clock().now(),
    }
}

pub(super) fn port_of(link: &Link) -> String {
    match link {
        Link::Bytes(b) => b.port().to_string(),
        Link::Frames(f) => f.port().to_string(),
    }
}

pub(super) fn bus_of(link: &Link) -> String {
    match link {
        Link::Bytes(b) => b.bus_id(),
        Link::Frames(f) => f.bus_id(),
    }
}

pub(super) fn lecom_timeout(link: &dyn ByteLink, opts: &ScanOptions) -> Duration {
    opts.timeout
        .unwrap_or_else(|| Duration::from_millis(40) + wire_time(24, link.baud()))
}

/// Whether anything answers a LECOM RECEIVE of `key` at `address`.
pub(super) fn lecom_probe(
    link: &mut dyn ByteLink,
    address: u8,
    key: CodeKey,
    opts: &ScanOptions,
) -> Result<Option<String>, LinkError> {
    let Some(ad) = ControllerAddress::new(address) else {
        return Ok(None);
    };
    let timeout = lecom_timeout(link, opts);
    let mut line = LecomLine::new(BorrowedByteLink(link));
    let got = crate::client::lecom::probe(&mut line, ad, key, timeout, opts.tries.max(1))?;
    line.finish()?;
    Ok(got)
}
