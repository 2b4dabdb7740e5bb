//! Lenze LECOM-A/B (section 8 of `lecom-ab-tmd-manual.txt`): the host
//! telegrams RECEIVE, SEND and BROADCAST / MULTICAST, the controller's
//! answers, code-number addressing, the value formats VD / VH / VS / VO, the
//! C0068 / C1962 error codes, and streaming decoders for both ends of the
//! line and for a bus sniffer. Sans-IO: bytes in, bytes out.
//!
//! - [`address`]: controller addresses AD1 AD2 (8.F, 8.J).
//! - [`code`]: C1 C2 (8.A), code banks (8.B), input selection (8.C),
//!   extended addressing (8.D).
//! - [`value`]: VD, VH, VS, VO (8.E).
//! - [`frame`]: the plain telegram and response types (8.H, 8.I, 8.J).
//! - [`codec`]: encoding and decoding of complete frames, BCC (8.G).
//! - [`stream`]: decoders fed with bytes as they arrive.
//! - [`status`]: C0068, C1962, and what a failed exchange means.
//! - [`error`]: the typed errors.
//!
//! Deviations from the manual are listed in `docs/errata/lecom.md`.

pub mod address;
pub mod code;
pub mod codec;
pub mod error;
pub mod frame;
#[doc(hidden)]
pub mod fuzzing;
pub mod status;
pub mod stream;
pub mod value;

pub use address::{AddressKind, ControllerAddress};
pub use code::{
    CodeAddress, CodeBank, CodeNumber, ExtendedAddress, LegacyAccess, StandardAddressing,
};
pub use error::{CodeError, EncodeError, FrameError, ValueError};
pub use frame::{Broadcast, Receive, Response, Send, Telegram};
pub use status::{
    Advice, CommunicationError, ExchangeFailure, ExtendedError, OperatingStatus, Rotation,
};
pub use stream::{
    BusSniffer, Direction, Event, Frame, HostFrame, ResponseDecoder, StreamError, TelegramDecoder,
};
pub use value::{Decimal, Hex, OctetString, Value, VisibleString};
