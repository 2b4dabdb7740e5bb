//! The bridge between the engine and the simulator (docs/twins.md): owns
//! the twin made of what the engine read of a drive ([`capture`]: a
//! drive's capture, or a recorded bus session decoded by the engine), the
//! capture of one drive from an opened port ([`drive`]: described first
//! when its family describes, its family checked, every code read), twins
//! from a recorded session ([`recorded`]), the twin file written or kept
//! ([`file`](mod@file)), the plan of a line manifest's capture ([`line`](mod@line): each
//! drive's port, twin file, history slot and records), what the plant
//! history records of a capture ([`history`]),
//! and the buses of a rehearsal ([`rehearse`]: the twins of a line
//! manifest's drives found and checked, each bus a simulated bus of its
//! drives' twins in virtual time, the report's label). The twin file is
//! the simulator's ([`driveset_sim::twin`]); reading the drive is the
//! engine's ([`driveset_engine::capture`]). The CLI's `driveset twin` and
//! `commission --rehearse` parse, open the port, call and render.

pub mod capture;
pub mod drive;
pub mod file;
pub mod history;
pub mod line;
pub mod recorded;
pub mod rehearse;

/// The `command` of a rehearsal's report (report.json; the HTML title
/// then says rehearsal).
pub const REHEARSE_COMMAND: &str = "rehearse";
