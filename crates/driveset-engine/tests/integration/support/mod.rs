//! The seeded fault campaigns' rig: full sets and simulated buses
//! (`campaign_rig`, also included by the benches with `#[path]`), the
//! upload / recover campaign (`campaign_run`), the journal campaign
//! (`campaign_journal`), and the in-memory fake drive of the transaction
//! tests (`fake`, with its fixture schemas in `fake::schemas`).

pub mod campaign_journal;
pub mod campaign_rig;
pub mod campaign_run;
pub mod fake;
