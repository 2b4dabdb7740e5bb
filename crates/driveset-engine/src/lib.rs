//! driveset-engine: talks to drives. Protocol clients (LUSTBUS, LECOM-A/B,
//! CAN SDO) behind one [`client::DriveClient`] trait; on top of them
//! identify, scan, pull, live diff and the upload transaction (plan,
//! journal, pacing, verify, roll back, recover).
//!
//! The engine never touches a clock or a port directly: a client holds a
//! `driveset_link::ByteLink` / `FrameLink` and takes time from that link's
//! clock, so the same code runs in real time on a serial port and in
//! virtual time against the in-process simulator.
//!
//! Its other seams: [`env::Environment`] (wall-clock time, the git commit
//! of the sets, the line run's small files; implemented by the CLI) and
//! [`observe::Observer`] (the runners' phases and steps, for timelines and
//! progress bars). The one file IO the engine does itself is the journal
//! ([`journal`]), its durable store.

pub mod assign;
pub mod capture;
pub mod client;
pub mod connect;
pub mod decode;
pub mod doctor;
pub mod dry_run;
pub mod env;
pub mod error;
pub mod guard;
pub mod history;
pub mod identify;
pub mod journal;
pub mod learn;
pub mod line;
pub mod live;
pub mod observe;
pub mod overrides;
pub mod plan;
pub mod pull;
pub mod rate_report;
pub mod recover;
pub mod scan;
pub mod session;
pub mod transfer;
pub mod upload;
