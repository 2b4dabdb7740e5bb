//! Echo on the line (`?echo=auto|on|off`): `driveset sim --tcp` behind a
//! proxy that returns every byte the client sends, as a 2-wire RS-485
//! adapter without echo suppression does. The port's link strips it
//! (`auto` detects it from the first exchange), for LUSTBUS and LECOM.

use std::time::Duration;

use crate::doctor::{Sim, echo_proxy};
use driveset_test_support::{driveset, outcome};

fn identify(port: &str, protocol: &str, address: &str) -> (Option<i32>, String, String) {
    outcome(
        driveset()
            .args([
                "identify",
                "--port",
                port,
                "--protocol",
                protocol,
                "--address",
                address,
            ])
            .timeout(Duration::from_secs(60)),
    )
}

#[test]
fn identify_through_an_echoing_line_for_lustbus_and_lecom() {
    for (family, protocol, want) in [
        ("mc6000", "lustbus", "family:   lustbus-mc\n"),
        ("tmd", "lecom", "family:   lecom\n"),
    ] {
        let mut sim = Sim::start(&["--family", family, "--address", "1", "--tcp", "0"]);
        let upstream = sim
            .first
            .strip_prefix("tcp ")
            .expect("tcp line")
            .to_string();
        let proxy = echo_proxy(upstream, false);
        for opt in ["", "?echo=auto", "?echo=on"] {
            let port = format!("tcp://127.0.0.1:{proxy}{opt}");
            let (code, out, err) = identify(&port, protocol, "1");
            assert_eq!(code, Some(0), "{family} {port}: {out}\n{err}");
            assert!(out.contains(want), "{family} {port}: {out}");
        }
        // Without the proxy, echo=on expects an echo that never comes: the
        // first answer byte differs from it, so it is passed on and the
        // answer still decodes.
        let direct = format!(
            "tcp://{}?echo=on",
            sim.first.strip_prefix("tcp ").unwrap_or_default()
        );
        let (code, out, err) = identify(&direct, protocol, "1");
        assert_eq!(code, Some(0), "{family} {direct}: {out}\n{err}");
        sim.stop();
    }
}
