//! Owns `driveset sim`'s serving until stopped (docs/ports.md): the bus of
//! a configured [`SimConfig`] put on its [`Endpoint`] (a character line on
//! a new pseudo terminal or a TCP port, one client at a time; a CAN bus as
//! a simulated slcan adapter on a new pseudo terminal), what the command
//! says while it serves ([`Told`]: the one line for scripts, the rest for
//! people; the caller prints them), and the drives' state when serving
//! stops ([`Served`]). Nothing is printed here.

use std::net::TcpListener;
use std::sync::atomic::AtomicBool;

use super::{Endpoint, exposure, serving, tcp_options};
use crate::log::EventLog;
use crate::open::{SimConfig, SimOpenError, StateDump, is_can};
use crate::serve::{self, ServeError};
use crate::slcan_serve::{self, SlcanServeError};

/// What the command says while it serves, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Told {
    /// The one machine-readable line (`pty PATH`, `tcp IP:PORT`), for
    /// stdout.
    Endpoint(String),
    /// A line for people (what is served, how to connect, a warning, a
    /// client's coming and going), for stderr.
    Note(String),
}

/// Why serving could not start (an input error to the command).
#[derive(Debug, thiserror::Error)]
pub enum ServeSetupError {
    /// The drives could not be made (their state file, a twin, ...).
    #[error(transparent)]
    Open(#[from] SimOpenError),
    /// The pty or the TCP listener could not be had.
    #[error(transparent)]
    Serve(#[from] ServeError),
    /// The slcan adapter's pty could not be had.
    #[error(transparent)]
    Slcan(#[from] SlcanServeError),
    /// The listener's bound address could not be read.
    #[error("cannot read the bound port")]
    LocalAddr(#[source] std::io::Error),
}

/// Why serving ended other than by the stop flag (a bus failure).
#[derive(Debug, thiserror::Error)]
pub enum ServeFailure {
    /// The pty or TCP stream of a character line.
    #[error(transparent)]
    Line(#[from] ServeError),
    /// The slcan adapter's pty.
    #[error(transparent)]
    Slcan(#[from] SlcanServeError),
}

/// What serving gave: how it ended and the drives' state then.
#[derive(Debug)]
pub struct Served {
    /// `Ok` when the stop flag ended it.
    pub outcome: Result<(), ServeFailure>,
    /// The drives' state when it ended ([`super::save`] writes it).
    pub dump: StateDump,
}

/// Serve the drives of `config` on `endpoint` until `stop` is set: a CAN
/// family's as a simulated slcan adapter on a new pty (its endpoint is
/// always a pty: [`super::configure`] refuses `--tcp` for CAN), any other
/// on a new pty or a TCP listener (TCP clients idle for `idle_timeout`
/// seconds dropped, 0: never; [`tcp_options`]). `tell` is told what the
/// command says, in order.
///
/// # Errors
/// [`ServeSetupError`] when serving could not start; a failure while
/// serving is [`Served::outcome`].
pub fn serve(
    config: &SimConfig,
    endpoint: Endpoint,
    log: &EventLog,
    stop: &AtomicBool,
    idle_timeout: u64,
    tell: &mut dyn FnMut(Told),
) -> Result<Served, ServeSetupError> {
    if is_can(config.family) {
        serve_can(config, log, stop, tell)
    } else {
        serve_line(config, endpoint, log, stop, idle_timeout, tell)
    }
}

/// Serve CAN drives as a simulated slcan adapter on a new pty.
fn serve_can(
    config: &SimConfig,
    log: &EventLog,
    stop: &AtomicBool,
    tell: &mut dyn FnMut(Told),
) -> Result<Served, ServeSetupError> {
    let (mut line, drives) = config.frame_line_drives(log.clone())?;
    let on_line: Vec<u8> = line.drives().iter().map(|d| d.node_id()).collect();
    let mut pty = slcan_serve::SlcanPty::open()?;
    tell(Told::Endpoint(format!("pty {}", pty.path())));
    tell(Told::Note(serving(config, &on_line)));
    tell(Told::Note(format!(
        "a simulated slcan adapter: connect with --port slcan://{}?bitrate={} (python-can: interface='slcan', channel='{}'); Ctrl-C stops",
        pty.path(),
        config.bitrate,
        pty.path()
    )));
    let outcome = slcan_serve::serve_slcan(&mut pty, &mut line, stop, &mut |_| {})
        .map(|_| ())
        .map_err(ServeFailure::from);
    Ok(Served {
        outcome,
        dump: drives.frame_line_dump(config.bus_name(), &line),
    })
}

/// Serve the drives of a character line on a new pty or a TCP port.
fn serve_line(
    config: &SimConfig,
    endpoint: Endpoint,
    log: &EventLog,
    stop: &AtomicBool,
    idle_timeout: u64,
    tell: &mut dyn FnMut(Told),
) -> Result<Served, ServeSetupError> {
    let (mut line, drives) = config.byte_line_drives(log.clone())?;
    let on_line: Vec<u8> = line.drives().iter().map(|d| d.address()).collect();
    let outcome = match endpoint {
        Endpoint::Pty => {
            let serve::Pty {
                mut master,
                slave,
                path,
            } = serve::open_pty()?;
            tell(Told::Endpoint(format!("pty {path}")));
            tell(Told::Note(serving(config, &on_line)));
            tell(Told::Note(format!(
                "connect with --port {path}?baud={}; Ctrl-C stops",
                config.baud
            )));
            let r = serve::serve_pty(&mut line, &mut master, stop);
            drop(slave);
            r
        }
        Endpoint::Tcp(addr) => {
            let listener =
                TcpListener::bind(addr).map_err(|source| ServeError::Bind { addr, source })?;
            let local = listener.local_addr().map_err(ServeSetupError::LocalAddr)?;
            tell(Told::Endpoint(format!("tcp {local}")));
            tell(Told::Note(serving(config, &on_line)));
            if let Some(what) = exposure(addr) {
                tell(Told::Note(format!(
                    "warning: listening on {what} ({local}): anyone who can reach it can talk to the simulated drives"
                )));
            }
            let options = tcp_options(idle_timeout);
            let idle = match options.idle_timeout {
                Some(t) => format!("idle clients dropped after {} s", t.as_secs()),
                None => "idle clients never dropped".into(),
            };
            tell(Told::Note(format!(
                "connect with --port tcp://{local}?baud={} (one connection at a time, others wait; {idle}); Ctrl-C stops",
                config.baud
            )));
            serve::serve_tcp_with(&mut line, &listener, stop, &options, &mut |e| {
                if let Some(detail) = &e.detail {
                    tell(Told::Note(format!("sim: {detail}")));
                }
            })
        }
    };
    Ok(Served {
        outcome: outcome.map_err(ServeFailure::from),
        dump: drives.byte_line_dump(config.bus_name(), &line),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{SimOptions, configure};

    #[test]
    fn a_stopped_tcp_line_says_where_it_listened_what_it_served_and_leaves_its_state() {
        let o = SimOptions {
            family: Some("mc6000".into()),
            addresses: vec![1, 2],
            tcp: Some("127.0.0.1:0".into()),
            ..SimOptions::default()
        };
        let (config, endpoint) = configure(&o).expect("configure");
        let stop = AtomicBool::new(true);
        let mut told = Vec::new();
        let served = serve(&config, endpoint, &EventLog::off(), &stop, 0, &mut |t| {
            told.push(t);
        })
        .expect("serve");
        assert!(served.outcome.is_ok());
        let Told::Endpoint(first) = &told[0] else {
            panic!("the endpoint comes first: {told:?}");
        };
        assert!(first.starts_with("tcp 127.0.0.1:"), "{first}");
        assert_eq!(told[1], Told::Note(serving(&config, &[1, 2])));
        let Told::Note(connect) = &told[2] else {
            panic!("{told:?}");
        };
        assert!(
            connect.ends_with(
                "(one connection at a time, others wait; idle clients never dropped); Ctrl-C stops"
            ),
            "{connect}"
        );
        assert_eq!(told.len(), 3, "loopback: no warning");
        assert_eq!(served.dump.drives.len(), 2);
    }
}
