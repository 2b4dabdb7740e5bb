//! Seeded fault campaigns per family (see `support/campaign_run.rs`): uploads
//! with flipped bits, lost / truncated replies, noise, a power cycle at a
//! random telegram and pulled cables; `recover` where the run was cut; after
//! every run the drive holds exactly the old or exactly the new set, and every
//! failure names the target and its cause.
//!
//! CI runs [`CI_RUNS`] per family ([`CI_RUNS_MC`] for the MC6000); the full thousand per family is
//! `#[ignore]`d (TESTING.md, "Fault campaigns").
#![allow(clippy::result_large_err)]

mod support {
    pub mod campaign_rig;
    pub mod campaign_run;
}

use driveset_sim::catalog::Family;
use support::campaign_run::campaign;

/// Runs per family in the default `cargo test` (about 40 s of CPU in a
/// debug build; the MC6000 set is the largest, so it runs fewer).
const CI_RUNS: u64 = 60;
/// MC6000 runs in the default `cargo test`.
const CI_RUNS_MC: u64 = 40;
/// Runs per family in the full campaign.
const FULL_RUNS: u64 = 1000;

#[test]
fn campaign_mc6000() {
    campaign(Family::Mc6000, 1, CI_RUNS_MC);
}

#[test]
fn campaign_vf1000() {
    campaign(Family::Vf1000, 1, CI_RUNS);
}

#[test]
fn campaign_tmd() {
    campaign(Family::Tmd, 1, CI_RUNS);
}

#[test]
fn campaign_ecs() {
    campaign(Family::Ecs, 1, CI_RUNS);
}

#[test]
#[ignore = "full campaign, a thousand runs per family: see TESTING.md"]
fn campaign_full_thousand_per_family() {
    for f in Family::ALL {
        campaign(f, 1_000_000, FULL_RUNS);
    }
}
