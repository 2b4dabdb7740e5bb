//! The seeded fault campaigns' rig: full sets and simulated buses
//! (`campaign_rig`, also included by the benches with `#[path]`), the
//! upload / recover campaign (`campaign_run`), the journal campaign
//! (`campaign_journal`), the in-memory fake drive of the transaction
//! tests (`fake`, with its fixture schemas in `fake::schemas`), and the
//! workspace's example sets as the tests load them (`sets`).

pub mod campaign_journal;
pub mod campaign_rig;
pub mod campaign_run;
pub mod fake;
pub mod sets;
