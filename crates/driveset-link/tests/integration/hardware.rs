//! Tests against real hardware: built only with `--features hardware`, and
//! each runs only when its environment variable names a device (otherwise
//! it prints why it did nothing and passes). See TESTING.md.
//!
//! - `DRIVESET_TEST_SERIAL=/dev/ttyUSB0` (USB-RS485 adapter with one drive;
//!   `DRIVESET_TEST_SERIAL_BAUD`, default 9600;
//!   `DRIVESET_TEST_SERIAL_PROTOCOL=lustbus|lecom`, default lustbus).
//! - `DRIVESET_TEST_SLCAN=/dev/ttyACM0` (slcan USB-CAN adapter on a bus
//!   with one drive; `DRIVESET_TEST_CAN_BITRATE`, default 500000).
//! - `DRIVESET_TEST_CAN=can0` (SocketCAN interface, up, on a bus with one
//!   drive; needs `--features socketcan` too).
//! - `DRIVESET_TEST_CAN_NODE` (default 1): the CAN drive's node id.

use std::time::Duration;

use driveset_link::{ByteLink, CanFrame, FrameLink, Link, OpenOptions, PortSpec, open};

fn env(name: &str) -> Option<String> {
    match std::env::var(name) {
        Ok(v) if !v.trim().is_empty() => Some(v.trim().to_string()),
        _ => {
            eprintln!("skipped: set {name} to run this hardware test (see TESTING.md)");
            None
        }
    }
}

fn env_u32(name: &str, default: u32) -> u32 {
    std::env::var(name)
        .ok()
        .map(|v| {
            v.trim()
                .parse()
                .unwrap_or_else(|_| panic!("{name}={v} is not a number"))
        })
        .unwrap_or(default)
}

/// Read until `done` says the reply is complete or 1 s passes.
fn read_reply(link: &mut dyn ByteLink, done: impl Fn(&[u8]) -> bool) -> Vec<u8> {
    let deadline = link.clock().deadline_in(Duration::from_secs(1));
    let mut reply = Vec::new();
    let mut buf = [0u8; 64];
    while !done(&reply) {
        let n = link.recv(&mut buf, deadline).expect("receive");
        if n == 0 {
            break;
        }
        reply.extend(buf[..n].iter().map(|b| b & 0x7F));
    }
    reply
}

/// A drive on the RS-485 line answers an identification request: LUSTBUS
/// ENQUIRY of 91-TYPE at address 0 (every device answers), or LECOM read
/// of C0093 (device type) at address 01.
#[test]
fn serial_drive_answers_an_identification_request() {
    let Some(path) = env("DRIVESET_TEST_SERIAL") else {
        return;
    };
    let baud = env_u32("DRIVESET_TEST_SERIAL_BAUD", 9600);
    let protocol =
        std::env::var("DRIVESET_TEST_SERIAL_PROTOCOL").unwrap_or_else(|_| "lustbus".into());
    let request: &[u8] = match protocol.as_str() {
        "lustbus" => b"\x04@00091\x05",
        "lecom" => b"\x040193\x05",
        other => panic!("DRIVESET_TEST_SERIAL_PROTOCOL={other}: use lustbus or lecom"),
    };
    let spec = PortSpec::parse(&format!("{path}?baud={baud}")).expect("port string");
    let Link::Bytes(mut link) = open(&spec, &OpenOptions::default()).expect("open the port") else {
        panic!("a serial port opens a byte link");
    };
    link.discard_input().expect("discard");
    link.send(request).expect("send");
    link.flush().expect("flush");
    // Complete: NAK, or ETX followed by the BCC.
    let reply = read_reply(link.as_mut(), |r| {
        r.contains(&0x15)
            || r.iter()
                .rposition(|&b| b == 0x03)
                .is_some_and(|i| i + 1 < r.len())
    });
    link.send(b"\x04").expect("send EOT");
    assert!(
        reply.contains(&0x02) || reply.contains(&0x15),
        "no answer from the drive on {path} at {baud} baud ({protocol}): got {reply:02X?}; \
         check wiring (A/B), termination, the drive's address and baud rate"
    );
    eprintln!("{path}: drive answered {reply:02X?}");
}

/// SDO upload of C0093 (index 0x5FFF - 93 = 0x5FA2) from the CAN node.
fn sdo_identification(link: &mut dyn FrameLink) {
    let node = env_u32("DRIVESET_TEST_CAN_NODE", 1);
    assert!(
        (1..=127).contains(&node),
        "DRIVESET_TEST_CAN_NODE must be 1..=127"
    );
    let request =
        CanFrame::new(0x600 + node, &[0x40, 0xA2, 0x5F, 0x00, 0, 0, 0, 0]).expect("request frame");
    link.discard_input().expect("discard");
    link.send(&request).expect("send");
    let deadline = link.clock().deadline_in(Duration::from_secs(1));
    loop {
        let Some(frame) = link.recv(deadline).expect("receive") else {
            panic!(
                "no SDO answer from node {node} on {} within 1 s: check the bit rate, \
                 termination and the node id",
                link.port()
            );
        };
        if frame.id == 0x580 + node {
            let command = frame.data[0];
            assert!(
                command & 0xE0 == 0x40 || command == 0x80,
                "unexpected SDO answer {frame:?}"
            );
            eprintln!("{}: node {node} answered {frame:?}", link.port());
            return;
        }
    }
}

#[test]
fn slcan_adapter_opens_and_reaches_a_drive() {
    let Some(path) = env("DRIVESET_TEST_SLCAN") else {
        return;
    };
    let bitrate = env_u32("DRIVESET_TEST_CAN_BITRATE", 500_000);
    let spec = PortSpec::parse(&format!("slcan://{path}?bitrate={bitrate}")).expect("port");
    let Link::Frames(mut link) = open(&spec, &OpenOptions::default()).expect("open the adapter")
    else {
        panic!("slcan:// opens a frame link");
    };
    sdo_identification(link.as_mut());
}

#[cfg(all(feature = "socketcan", target_os = "linux"))]
#[test]
fn socketcan_interface_reaches_a_drive() {
    let Some(interface) = env("DRIVESET_TEST_CAN") else {
        return;
    };
    let bitrate = env_u32("DRIVESET_TEST_CAN_BITRATE", 500_000);
    let spec = PortSpec::parse(&format!("can://{interface}?bitrate={bitrate}")).expect("port");
    let Link::Frames(mut link) = open(&spec, &OpenOptions::default()).expect("open") else {
        panic!("can:// opens a frame link");
    };
    sdo_identification(link.as_mut());
}
