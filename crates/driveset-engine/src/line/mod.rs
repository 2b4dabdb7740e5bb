//! Machine lines: a manifest of buses and drives, commissioning every drive
//! from its set (buses in parallel, drives on one bus in turn), drift status,
//! and the commissioning report.

pub mod address_truth;
pub mod commission;
pub mod commission_assign;
pub mod factory;
pub mod manifest;
pub mod replace;
pub mod report;
pub mod status;
