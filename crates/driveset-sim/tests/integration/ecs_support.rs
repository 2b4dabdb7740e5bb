//! Helpers shared by the ECS tests (`ecs_*.rs` and
//! `spec_examples_transports.rs`, used as `support`).
#![allow(dead_code)]

use std::time::Duration;

use driveset_proto::can::{CanFrame, NodeId};
use driveset_schema::error::SourceFile;
use driveset_sim::catalog;
use driveset_sim::drive::ReactionTime;
use driveset_sim::ecs::EcsDrive;
use driveset_sim::table::ParamTable;

/// FICTIONAL test schema: the simulator's ECS table plus a read-only code
/// (the ECS excerpt names none, and the demo fixture has only read-write
/// codes), to test the 0x06010002 abort.
pub const TEST_SCHEMA: &str = r#"
[schema]
id = "test-ecs-readonly"
title = "FICTIONAL test schema: fictional-ecs-demo plus a read-only actual value"
extends = "fictional-ecs-demo"
fictional = true

[[code]]
number = 5017
name = "actual_speed"
title = "Actual speed (fictional, tests only)"
spec = "fictional"
type = "FIX32"
unit = "rpm"
min = "-16000"
max = "16000"
access = "ro"
note = "fictional"
"#;

/// The table of [`TEST_SCHEMA`].
pub fn test_table() -> ParamTable {
    let mut r = catalog::registry().expect("catalog");
    r.add_source(SourceFile::new("tests/test-ecs-readonly.toml", TEST_SCHEMA))
        .expect("test schema loads");
    let schema = r.get("test-ecs-readonly").expect("test schema registered");
    ParamTable::from_schema(schema).expect("test table")
}

/// A drive at `node` with [`test_table`], reaction fixed at 1 ms.
pub fn test_drive(node: u8) -> EcsDrive {
    EcsDrive::with_table(NodeId::new(node).expect("node id"), test_table(), 1)
        .with_reaction(ReactionTime::fixed(Duration::from_millis(1)))
}

/// A standard data frame.
pub fn frame(id: u32, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).expect("valid frame")
}
