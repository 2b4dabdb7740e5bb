//! Lenze system bus (CAN): SDO parameter access and slcan framing. Owns
//! everything CAN-side of the crate; pure, no IO, no clock, no panics on any
//! input.
//!
//! Source of truth: `lenze-system-bus-can-sdo.txt` (ECS manual EDBCSXA064
//! EN 3.2, page 454) and, for what that page leaves out (COB-IDs, segmented
//! transfer), CiA DS301 V4.02. Interpretations: `docs/errata/can.md`.
//!
//! - [`lenze`]: code number <-> index, [`Fix32`], bit-coded values.
//! - [`frame`]: plain types: [`CanFrame`], [`NodeId`], [`SdoRequest`],
//!   [`SdoResponse`].
//! - [`abort`]: DS301 abort codes, [`SdoAbort`] (device-reported errors).
//! - [`codec`]: SDO bytes in, bytes out; COB-IDs; response matching.
//! - [`transfer`]: client and server state machines (expedited and
//!   segmented).
//! - [`slcan`]: Lawicel ASCII framing for USB-CAN adapters, streaming
//!   decoders for both directions.
//! - [`timing`]: bit time of a CAN frame on the wire.

pub mod abort;
pub mod codec;
pub mod frame;
#[doc(hidden)]
pub mod fuzzing;
pub mod lenze;
pub mod slcan;
pub mod timing;
pub mod transfer;

pub use abort::{AbortCode, SdoAbort};
pub use codec::SdoCodecError;
pub use frame::{
    CanFrame, ExpeditedData, FrameError, NodeId, NodeIdError, SdoRequest, SdoResponse, SegmentData,
};
pub use lenze::{
    CodeNumber, Fix32, Fix32Error, Index, LenzeValue, MappingError, Subindex, ValueFormat,
};
pub use slcan::{
    Bitrate, CommandDecoder, ResponseDecoder, SlcanCommand, SlcanError, SlcanResponse,
};
pub use timing::Stuffing;
pub use transfer::{ClientEvent, Completed, ObjectDictionary, SdoClient, SdoServer, TransferError};
