//! LUSTBUS codec: telegrams, value formats, SIOF/SERR, parameter descriptions,
//! PosMOD1 user data and streaming decoders for Lust SMARTDRIVE VF1000
//! inverters and MASTERCONTROL MC6000/7000 servocontrollers
//! (`lustbus-protocol.txt`, "LUSTBus Data Transmission Protocol", A040.22B.0-00).
//!
//! This module owns everything LUSTBUS-specific in `driveset-proto`; the
//! control characters, [`mask7`](crate::ascii::mask7) and the
//! [`bcc`](crate::ascii::bcc) come from [`crate::ascii`].
//!
//! Layout (tokio-modbus cut):
//!
//! - [`frame`]: plain telegram types ([`Address`], [`ParameterCode`],
//!   [`Enquiry`], [`Select`], [`ValueReply`], [`Request`], [`Reply`],
//!   [`Telegram`]) and [`ValueText`], the VALUE string.
//! - [`codec`]: bytes in, bytes out for one complete telegram
//!   ([`TelegramBytes`], [`decode_request`], [`decode_reply`], [`FrameError`]).
//! - [`value`]: the PT_* data types of both families (section 2.3).
//! - [`siof`]: the 85-SIOF/SERR error bits (section 9.2).
//! - [`description`]: parameter descriptions (sections 11.1, 11.2) and value
//!   substitution texts (section 11.3).
//! - [`posmod`]: PosMOD1 user data on CODE 49999 (section 11.6).
//! - [`stream`]: streaming decoders for the master, the slave and a bus
//!   sniffer (section 3: the receivers are state machines reset by EOT).
//! - [`timing`]: wire time of a telegram (section 10, corrected).
//!
//! Nothing here does IO, reads a clock or panics on any input. Where the spec
//! contradicts itself the choice made is documented on the item and recorded
//! in `docs/errata/lustbus.md`.
//!
//! Wire basics (section 2.1/2.2): 7 data bits, even parity, 1 stop bit. The
//! host frames every telegram with a leading EOT:
//!
//! ```text
//! ENQUIRY  EOT ADR CODE ENQ                      -> ADR STX CODE = VALUE ETX BCC | ADR NAK
//! SELECT   EOT ADR STX CODE = VALUE ETX BCC      -> ADR ACK | ADR NAK
//! end      EOT
//! ```

#[macro_use]
mod flags;

pub mod codec;
pub mod description;
pub mod frame;
#[doc(hidden)]
pub mod fuzzing;
pub mod posmod;
pub mod siof;
pub mod stream;
pub mod timing;
pub mod value;

pub use codec::{FrameError, TelegramBytes, decode_reply, decode_request};
pub use description::{DescriptionError, McDescription, VfDescription};
pub use frame::{
    Address, CodeMeaning, CompatibleParameter, Direction, Enquiry, ParameterCode, Reply, Request,
    Select, Telegram, ValueReply, ValueText,
};
pub use posmod::{PosModData, PosModError, PosModStatus};
pub use siof::{Siof, SiofAction, SiofCause};
pub use stream::{ReplyDecoder, RequestDecoder, Sniffer, StreamEvent};
pub use value::{Dialect, ParameterType, ParameterValue, ValueError};
