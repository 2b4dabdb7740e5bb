//! Seeded fault campaigns per family (see `support/campaign_run.rs`): uploads
//! with flipped bits, lost / truncated replies, noise, a power cycle at a
//! random telegram and pulled cables; `recover` where the run was cut; after
//! every run the drive holds exactly the old or exactly the new set, and every
//! failure names the target and its cause.
//!
//! CI runs [`CI_RUNS`] per family ([`CI_RUNS_MC`] for the MC6000); the full thousand per family is
//! `#[ignore]`d (TESTING.md, "Fault campaigns").

use crate::support::campaign_journal::{
    Outcome, Scenario, commission_kills, journal_campaign, render,
};
use crate::support::campaign_run::campaign;
use driveset_sim::catalog::Family;

/// Seeds per family and journal scenario in the default `cargo test`.
const JOURNAL_RUNS: u64 = 6;

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

/// Journals bound to their drive (issue 10), every family: recover aimed at
/// another address, another bus and another spelling of the same bus; a
/// journal made stale by a later upload (see `support/campaign_journal.rs`).
fn journal_scenarios(family: Family) {
    let t = journal_campaign(family, 1, JOURNAL_RUNS);
    eprint!("{}", render(family, &t));
    for sc in [
        Scenario::OtherAddress,
        Scenario::OtherSpelling,
        Scenario::Stale,
    ] {
        let total: usize = t
            .iter()
            .filter(|((s, _), _)| *s == sc)
            .map(|(_, n)| n)
            .sum();
        assert_eq!(total as u64, JOURNAL_RUNS, "{sc:?}");
        let bound: usize = t
            .iter()
            .filter(|((s, o), _)| *s == sc && *o != Outcome::NoJournal)
            .map(|(_, n)| n)
            .sum();
        assert!(
            bound > 0,
            "{}: no {sc:?} run left a journal to recover",
            family.name()
        );
    }
}

#[test]
fn journal_campaign_mc6000() {
    journal_scenarios(Family::Mc6000);
}

#[test]
fn journal_campaign_vf1000() {
    journal_scenarios(Family::Vf1000);
}

#[test]
fn journal_campaign_tmd() {
    journal_scenarios(Family::Tmd);
}

#[test]
fn journal_campaign_ecs() {
    journal_scenarios(Family::Ecs);
}

/// A `commission` killed at the first, middle and last telegram of every
/// phase of a clean run, then `status`, an `upload` beside the journal, and
/// a rerun.
fn kills(family: Family) {
    let t = commission_kills(family);
    for (phase, n) in &t {
        eprintln!("commission kill {} phase {phase}: {n}", family.name());
    }
    // a kill mid-transaction leaves an unfinished journal: that phase was hit
    assert!(
        t.keys().any(|p| p.contains(":writing")),
        "{}: no kill in the writing phase: {t:?}",
        family.name()
    );
}

#[test]
fn commission_killed_at_every_phase_mc6000() {
    kills(Family::Mc6000);
}

#[test]
fn commission_killed_at_every_phase_vf1000() {
    kills(Family::Vf1000);
}

#[test]
fn commission_killed_at_every_phase_tmd() {
    kills(Family::Tmd);
}

#[test]
fn commission_killed_at_every_phase_ecs() {
    kills(Family::Ecs);
}
