//! Machine lines: a manifest of buses and drives (`manifest`), commissioning
//! every drive from its set (buses in parallel, drives on one bus in turn:
//! `commission`), the read-only drift check over the same loop (`status`),
//! a fresh line's addresses and rates before its commissioning
//! (`commission_assign`, `commission --assign`; the one-drive `driveset
//! address` is [`crate::assign`]), replacing a unit (`replace`), and the
//! commissioning report (`report`).

pub mod address_truth;
pub mod commission;
pub mod commission_assign;
pub mod factory;
pub mod manifest;
pub mod replace;
pub mod report;
pub mod status;
