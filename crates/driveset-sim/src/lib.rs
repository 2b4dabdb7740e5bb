//! driveset-sim: simulated drives of all four families, on an in-process
//! bus with wire timing in virtual time, seeded fault injection and an event
//! log; and serving them on a pseudo terminal or a TCP port in real time.
//!
//! The cut:
//! - [`drive`]: the contract between a bus and a family model
//!   ([`drive::ByteDrive`] for LUSTBUS / LECOM, [`drive::FrameDrive`] for
//!   CAN), plus reaction-time settings; [`table`] and [`catalog`]: the
//!   parameter tables the models load from schemas.
//! - Family models: [`mc6000`] and [`vf1000`] (sharing [`lustbus_drive`]),
//!   [`tmd`], [`ecs`].
//! - Buses: [`bus`] (a 7E1 line, `ByteLink`) and [`can_bus`] (`FrameLink`)
//!   in virtual time, with [`faults`] and the [`log`]; [`open`] turns a
//!   `sim://` port into one; [`factory`]: factory-fresh drives and the
//!   service bench.
//! - Real time: [`serve`] (pty / TCP), [`slcan_serve`] (an slcan adapter on
//!   a pty), [`slcan_hub`] (two slcan hosts joined through two adapters);
//!   [`command`]: the work of `driveset sim` (its options checked into a
//!   bus and an endpoint, the power cycle of a state file, what is saved
//!   when serving stops).
//! - [`twin`]: twins, files that answer as one captured drive did, served
//!   on the family models (`sim://twin?file=` / `?dir=`).
//! - [`rng`]: the seeded generator every random choice comes from, so a run
//!   is reproducible from its seed.
//!
//! Family models answer exactly what the vendor specs describe; facts the
//! specs do not give (the simulator's parameter tables beyond the named
//! codes, reaction times of the Lenze families) come from fixture schemas
//! and settings that say they are fictional.

pub mod bus;
pub mod can_bus;
pub mod catalog;
pub mod command;
pub mod describe;
pub mod drive;
pub mod ecs;
pub mod eds;
pub mod factory;
pub mod faults;
pub mod log;
pub mod lustbus_drive;
pub mod mc6000;
pub mod open;
pub mod port;
pub mod rng;
pub mod serve;
pub mod slcan_hub;
pub mod slcan_serve;
pub mod table;
pub mod tmd;
pub mod twin;
pub mod vf1000;
