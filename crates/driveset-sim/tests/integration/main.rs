//! The simulator's one integration-test binary (one binary per crate, fast
//! to link). Each module tests one area; `bus_support` (tiny fake drives),
//! `ecs_support` (ECS helpers) and `lust_support` (LUSTBUS telegrams) are
//! shared by its modules; the pty lock,
//! bounded reads and the interop skip come from `driveset-test-support`.
//! Unit tests live beside the code in `src/`.

mod bus;
mod bus_can;
mod bus_faults;
mod bus_log;
mod bus_serve;
mod bus_support;
#[cfg(unix)]
mod ecs_python_interop;
mod ecs_sdo;
mod ecs_sim_can_bus;
#[cfg(unix)]
mod ecs_slcan;
mod ecs_support;
mod factory;
mod lust_bus;
mod lust_models;
mod lust_support;
mod spec_examples_transports;
mod tmd;
