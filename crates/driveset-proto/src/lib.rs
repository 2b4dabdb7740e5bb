//! Sans-IO codecs for the three bus protocols driveset speaks: bytes in,
//! telegrams out, and back. No IO, no clock; decoders are state machines fed
//! with bytes as they arrive.
//!
//! - [`lustbus`]: LUSTBUS (ISO 1745 fast select) for Lust SMARTDRIVE VF1000
//!   and MASTERCONTROL MC6000/7000 (`lustbus-protocol.txt`).
//! - [`lecom`]: Lenze LECOM-A/B for Tmd inverters
//!   (`lecom-ab-tmd-manual.txt` section 8).
//! - [`can`]: Lenze system bus (CAN) SDO parameter access and slcan framing
//!   (`lenze-system-bus-can-sdo.txt`).
//! - [`ascii`]: the control characters and the block check character that
//!   LUSTBUS and LECOM share (both follow ISO 1745 / DIN 66019).
//! - [`text`]: bytes as hex text and as escaped ASCII (`<EOT>@00112<ENQ>`),
//!   both ways, as `driveset decode` reads and `driveset encode` prints them.
//!
//! Feature `serde`: `Serialize` / `Deserialize` for the types journals and
//! reports carry, as the raw numbers on the wire (`serde_impls.rs`).

pub mod ascii;
pub mod can;
pub mod lecom;
pub mod lustbus;
#[cfg(feature = "serde")]
mod serde_impls;
pub mod text;
