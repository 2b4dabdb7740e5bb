//! SDO transfer state machines, sans IO: owns [`SdoClient`] (master side)
//! and [`SdoServer`] (drive side). Feed a received frame in, get the frame
//! to send out. No clock: the caller decides when a response is overdue and
//! calls `on_timeout`, which yields the DS301 abort 0x05040000.
//!
//! Values of 1..=4 bytes go expedited (page 454 of the ECS manual: 0x23 /
//! 0x2B / 0x2F, read responses 0x43 / 0x4B / 0x4F). Longer (or empty)
//! values use the DS301 V4.02 segmented protocol (clause 9.2.2.2.2 ff.),
//! which page 454 only hints at in its "Block" column (0x21 / 0x41 = initiate
//! with size indicated):
//!
//! - download: `21 ii ii ss <size>` -> `60`; segments `000t nnnc` + 7 bytes ->
//!   `001t 0000` (0x20 / 0x30); the toggle bit starts at 0 and alternates.
//! - upload: `40` -> `41 ii ii ss <size>`; `011t 0000` (0x60 / 0x70) ->
//!   segments `000t nnnc` + 7 bytes.
//!
//! A toggle bit that did not alternate aborts with 0x05030000. Both sides
//! bound what they buffer (`max_len`, default [`DEFAULT_MAX_LEN`]) and abort
//! with 0x05040005 (out of memory) past it.
//!
//! DS301 block transfer (command specifiers 5 and 6) is not implemented:
//! Lenze's "Block" column is the segmented transfer (see
//! `docs/errata/can.md`).

use super::abort::{AbortCode, SdoAbort};
use super::codec::SdoCodecError;
use super::frame::{ExpeditedData, SdoRequest, SdoResponse, SegmentData};
use super::lenze::{Index, Subindex};

/// Default bound on a segmented value, in bytes.
pub const DEFAULT_MAX_LEN: usize = 64 * 1024;

/// A transfer failed on the protocol level (not a device abort).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TransferError {
    /// A transfer is already running.
    #[error("an SDO transfer is already running")]
    Busy,
    /// A response arrived while no transfer was running (e.g. a late reply
    /// after a timeout): ignore it.
    #[error("SDO response while no transfer is running")]
    NotRunning,
    /// The frame does not decode.
    #[error(transparent)]
    Codec(#[from] SdoCodecError),
    /// The value is longer than `max_len` (or than 2^32 - 1).
    #[error("value of {len} bytes exceeds the limit of {max} bytes")]
    TooLong {
        /// The length.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// The segments did not add up to the size the initiate frame indicated.
    #[error("segmented transfer indicated {indicated} bytes but carried {got}")]
    SizeMismatch {
        /// Size from the initiate frame.
        indicated: u32,
        /// Bytes received.
        got: usize,
    },
    /// No response in time (the caller's clock said so).
    #[error("SDO protocol timed out")]
    Timeout,
}

impl TransferError {
    /// The abort code to send for this error.
    pub const fn abort_code(&self) -> AbortCode {
        match self {
            TransferError::Codec(SdoCodecError::ToggleBit) => AbortCode::TOGGLE_BIT_NOT_ALTERNATED,
            TransferError::Codec(SdoCodecError::Mismatch { .. }) => AbortCode::GENERAL_ERROR,
            TransferError::Codec(_) | TransferError::NotRunning | TransferError::Busy => {
                AbortCode::INVALID_COMMAND
            }
            TransferError::TooLong { .. } => AbortCode::OUT_OF_MEMORY,
            TransferError::SizeMismatch { .. } => AbortCode::LENGTH_MISMATCH,
            TransferError::Timeout => AbortCode::TIMEOUT,
        }
    }
}

/// A finished transfer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Completed {
    /// The server acknowledged the whole value.
    Written {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
    },
    /// The value read.
    Read {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
        /// The bytes.
        data: Vec<u8>,
    },
}

/// What the client does after a response.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ClientEvent {
    /// Send this frame; the transfer continues.
    Send(SdoRequest),
    /// The transfer is complete.
    Done(Completed),
    /// The server aborted the transfer (device-reported error).
    Aborted(SdoAbort),
    /// A protocol error. If `abort` is set the transfer was running and is
    /// now abandoned: send `abort` to the server. With `abort: None` the
    /// frame was stray and the client state is unchanged.
    Failed {
        /// What went wrong.
        error: TransferError,
        /// The abort frame to send, if any.
        abort: Option<SdoRequest>,
    },
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum ClientState {
    Idle,
    Download {
        index: Index,
        subindex: Subindex,
        data: Vec<u8>,
        pos: usize,
        toggle: bool,
        sent: SdoRequest,
    },
    Upload {
        index: Index,
        subindex: Subindex,
        buf: Vec<u8>,
        size: Option<u32>,
        toggle: bool,
        sent: SdoRequest,
    },
}

/// The client (master) side of one SDO channel: one transfer at a time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SdoClient {
    state: ClientState,
    max_len: usize,
}

impl Default for SdoClient {
    fn default() -> Self {
        Self::new()
    }
}

impl SdoClient {
    /// A client bounding values to [`DEFAULT_MAX_LEN`].
    pub const fn new() -> Self {
        Self::with_max_len(DEFAULT_MAX_LEN)
    }

    /// A client bounding values to `max_len` bytes.
    pub const fn with_max_len(max_len: usize) -> Self {
        SdoClient {
            state: ClientState::Idle,
            max_len,
        }
    }

    /// No transfer running.
    pub fn is_idle(&self) -> bool {
        self.state == ClientState::Idle
    }

    /// Starts writing `data`: expedited for 1..=4 bytes, segmented with
    /// size indicated (0x21) otherwise. Returns the first frame to send.
    pub fn start_write(
        &mut self,
        index: Index,
        subindex: Subindex,
        data: &[u8],
    ) -> Result<SdoRequest, TransferError> {
        if !self.is_idle() {
            return Err(TransferError::Busy);
        }
        let sent = match ExpeditedData::new(data) {
            Some(d) => SdoRequest::Write {
                index,
                subindex,
                data: d,
            },
            None => {
                let size = u32::try_from(data.len())
                    .ok()
                    .filter(|_| data.len() <= self.max_len)
                    .ok_or(TransferError::TooLong {
                        len: data.len(),
                        max: self.max_len,
                    })?;
                SdoRequest::InitiateWrite {
                    index,
                    subindex,
                    size: Some(size),
                }
            }
        };
        self.state = ClientState::Download {
            index,
            subindex,
            data: data.to_vec(),
            pos: 0,
            toggle: false,
            sent,
        };
        Ok(sent)
    }

    /// Starts reading. Returns the frame to send (0x40).
    pub fn start_read(
        &mut self,
        index: Index,
        subindex: Subindex,
    ) -> Result<SdoRequest, TransferError> {
        if !self.is_idle() {
            return Err(TransferError::Busy);
        }
        let sent = SdoRequest::Read { index, subindex };
        self.state = ClientState::Upload {
            index,
            subindex,
            buf: Vec::new(),
            size: None,
            toggle: false,
            sent,
        };
        Ok(sent)
    }

    /// The caller's clock says the response is overdue: abandons the
    /// transfer and returns the abort (0x05040000) to send, or `None` if
    /// idle.
    pub fn on_timeout(&mut self) -> Option<SdoRequest> {
        let (index, subindex) = self.multiplexer()?;
        self.state = ClientState::Idle;
        Some(SdoRequest::Abort(SdoAbort::new(
            index,
            subindex,
            AbortCode::TIMEOUT,
        )))
    }

    /// The index/subindex of the running transfer.
    pub fn multiplexer(&self) -> Option<(Index, Subindex)> {
        match &self.state {
            ClientState::Idle => None,
            ClientState::Download {
                index, subindex, ..
            }
            | ClientState::Upload {
                index, subindex, ..
            } => Some((*index, *subindex)),
        }
    }

    /// Feeds the 8 data bytes of a frame from the server.
    pub fn on_frame_data(&mut self, data: &[u8]) -> ClientEvent {
        match SdoResponse::decode(data) {
            Ok(r) => self.on_response(r),
            Err(e) => self.fail(TransferError::Codec(e)),
        }
    }

    fn fail(&mut self, error: TransferError) -> ClientEvent {
        let abort = self.multiplexer().map(|(index, subindex)| {
            SdoRequest::Abort(SdoAbort::new(index, subindex, error.abort_code()))
        });
        self.state = ClientState::Idle;
        ClientEvent::Failed { error, abort }
    }

    /// Feeds a decoded response from the server.
    pub fn on_response(&mut self, response: SdoResponse) -> ClientEvent {
        let max_len = self.max_len;
        let (sent, index, subindex) = match &self.state {
            ClientState::Idle => {
                return ClientEvent::Failed {
                    error: TransferError::NotRunning,
                    abort: None,
                };
            }
            ClientState::Download {
                sent,
                index,
                subindex,
                ..
            }
            | ClientState::Upload {
                sent,
                index,
                subindex,
                ..
            } => (*sent, *index, *subindex),
        };
        if let SdoResponse::Abort(a) = response {
            self.state = ClientState::Idle;
            return ClientEvent::Aborted(a);
        }
        if let Err(e) = response.check_answers(&sent) {
            return self.fail(TransferError::Codec(e));
        }
        let next = match (&mut self.state, response) {
            (ClientState::Download { .. }, SdoResponse::WriteAck { .. })
                if matches!(sent, SdoRequest::Write { .. }) =>
            {
                None
            }
            (
                ClientState::Download {
                    data,
                    pos,
                    toggle,
                    sent,
                    ..
                },
                SdoResponse::WriteAck { .. } | SdoResponse::WriteSegmentAck { .. },
            ) => {
                if matches!(sent, SdoRequest::WriteSegment { last: true, .. }) {
                    None
                } else {
                    if matches!(sent, SdoRequest::WriteSegment { .. }) {
                        *toggle = !*toggle;
                    }
                    let rest = data.get(*pos..).unwrap_or(&[]);
                    let chunk = &rest[..rest.len().min(7)];
                    *pos += chunk.len();
                    *sent = SdoRequest::WriteSegment {
                        toggle: *toggle,
                        data: SegmentData::truncated(chunk),
                        last: *pos >= data.len(),
                    };
                    Some(*sent)
                }
            }
            (ClientState::Upload { .. }, SdoResponse::ReadValue { data, .. }) => {
                self.state = ClientState::Idle;
                return ClientEvent::Done(Completed::Read {
                    index,
                    subindex,
                    data: data.as_bytes().to_vec(),
                });
            }
            (
                ClientState::Upload {
                    size: sz,
                    sent,
                    toggle,
                    ..
                },
                SdoResponse::InitiateRead { size, .. },
            ) => {
                if let Some(s) = size
                    && usize::try_from(s).map_or(true, |s| s > max_len)
                {
                    return self.fail(TransferError::TooLong {
                        len: usize::try_from(s).unwrap_or(usize::MAX),
                        max: max_len,
                    });
                }
                *sz = size;
                *sent = SdoRequest::ReadSegment { toggle: *toggle };
                Some(*sent)
            }
            (
                ClientState::Upload {
                    buf,
                    size,
                    toggle,
                    sent,
                    ..
                },
                SdoResponse::ReadSegment { data, last, .. },
            ) => {
                if buf.len() + data.as_bytes().len() > max_len {
                    let len = buf.len() + data.as_bytes().len();
                    return self.fail(TransferError::TooLong { len, max: max_len });
                }
                buf.extend_from_slice(data.as_bytes());
                if last {
                    if let Some(s) = *size
                        && usize::try_from(s).ok() != Some(buf.len())
                    {
                        let got = buf.len();
                        return self.fail(TransferError::SizeMismatch { indicated: s, got });
                    }
                    let data = core::mem::take(buf);
                    self.state = ClientState::Idle;
                    return ClientEvent::Done(Completed::Read {
                        index,
                        subindex,
                        data,
                    });
                }
                *toggle = !*toggle;
                *sent = SdoRequest::ReadSegment { toggle: *toggle };
                Some(*sent)
            }
            _ => {
                return self.fail(TransferError::Codec(SdoCodecError::UnexpectedResponse(
                    "response kind does not answer the request kind",
                )));
            }
        };
        match next {
            Some(q) => ClientEvent::Send(q),
            None => {
                self.state = ClientState::Idle;
                ClientEvent::Done(Completed::Written { index, subindex })
            }
        }
    }
}

/// The drive's parameters as the server sees them. The simulator
/// implements it; errors are the abort codes to report (unknown index ->
/// 0x06020000, read-only -> 0x06010002, out of range -> 0x06090030, ...).
pub trait ObjectDictionary {
    /// The value's bytes (little-endian for numbers).
    fn read(&mut self, index: Index, subindex: Subindex) -> Result<Vec<u8>, AbortCode>;
    /// Stores a value (the whole of it, after the last segment).
    fn write(&mut self, index: Index, subindex: Subindex, data: &[u8]) -> Result<(), AbortCode>;
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum ServerState {
    Idle,
    Download {
        index: Index,
        subindex: Subindex,
        size: Option<u32>,
        buf: Vec<u8>,
        toggle: bool,
    },
    Upload {
        index: Index,
        subindex: Subindex,
        data: Vec<u8>,
        pos: usize,
        toggle: bool,
    },
}

/// The server (drive) side of one SDO channel.
///
/// A new initiate request while a segmented transfer runs abandons the old
/// one and starts the new one (DS301 does not say; a client that restarts
/// after its own timeout expects this). A segment while idle, or of the
/// wrong direction, aborts with 0x05040001.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SdoServer {
    state: ServerState,
    max_len: usize,
}

impl Default for SdoServer {
    fn default() -> Self {
        Self::new()
    }
}

impl SdoServer {
    /// A server bounding values to [`DEFAULT_MAX_LEN`].
    pub const fn new() -> Self {
        Self::with_max_len(DEFAULT_MAX_LEN)
    }

    /// A server bounding segmented downloads to `max_len` bytes.
    pub const fn with_max_len(max_len: usize) -> Self {
        SdoServer {
            state: ServerState::Idle,
            max_len,
        }
    }

    /// No transfer running.
    pub fn is_idle(&self) -> bool {
        self.state == ServerState::Idle
    }

    /// The caller's clock says the client went silent mid-transfer:
    /// abandons it and returns the abort (0x05040000), or `None` if idle.
    pub fn on_timeout(&mut self) -> Option<SdoResponse> {
        let (index, subindex) = match &self.state {
            ServerState::Idle => return None,
            ServerState::Download {
                index, subindex, ..
            }
            | ServerState::Upload {
                index, subindex, ..
            } => (*index, *subindex),
        };
        self.state = ServerState::Idle;
        Some(SdoResponse::Abort(SdoAbort::new(
            index,
            subindex,
            AbortCode::TIMEOUT,
        )))
    }

    /// Feeds the 8 data bytes of a frame from the client. An undecodable
    /// frame is answered with abort 0x05040001 (index/subindex from bytes
    /// 2-4 when present, else 0).
    pub fn on_frame_data(
        &mut self,
        data: &[u8],
        od: &mut impl ObjectDictionary,
    ) -> Option<SdoResponse> {
        match SdoRequest::decode(data) {
            Ok(q) => self.on_request(q, od),
            Err(_) => {
                self.state = ServerState::Idle;
                let (index, subindex) = match data {
                    [_, lo, hi, sub, ..] => (Index(u16::from_le_bytes([*lo, *hi])), Subindex(*sub)),
                    _ => (Index(0), Subindex(0)),
                };
                Some(abort(index, subindex, AbortCode::INVALID_COMMAND))
            }
        }
    }

    fn abort_here(&mut self, code: AbortCode) -> SdoResponse {
        let (index, subindex) = match &self.state {
            ServerState::Idle => (Index(0), Subindex(0)),
            ServerState::Download {
                index, subindex, ..
            }
            | ServerState::Upload {
                index, subindex, ..
            } => (*index, *subindex),
        };
        self.state = ServerState::Idle;
        abort(index, subindex, code)
    }

    /// Feeds a decoded request; returns the response to send (`None` after
    /// a client abort).
    pub fn on_request(
        &mut self,
        request: SdoRequest,
        od: &mut impl ObjectDictionary,
    ) -> Option<SdoResponse> {
        let max_len = self.max_len;
        Some(match request {
            SdoRequest::Abort(_) => {
                self.state = ServerState::Idle;
                return None;
            }
            SdoRequest::Write {
                index,
                subindex,
                data,
            } => {
                self.state = ServerState::Idle;
                match od.write(index, subindex, data.as_bytes()) {
                    Ok(()) => SdoResponse::WriteAck { index, subindex },
                    Err(code) => abort(index, subindex, code),
                }
            }
            SdoRequest::InitiateWrite {
                index,
                subindex,
                size,
            } => {
                self.state = ServerState::Idle;
                if size.is_some_and(|s| usize::try_from(s).map_or(true, |s| s > max_len)) {
                    return Some(abort(index, subindex, AbortCode::OUT_OF_MEMORY));
                }
                self.state = ServerState::Download {
                    index,
                    subindex,
                    size,
                    buf: Vec::new(),
                    toggle: false,
                };
                SdoResponse::WriteAck { index, subindex }
            }
            SdoRequest::WriteSegment {
                toggle: t,
                data,
                last,
            } => {
                let ServerState::Download {
                    index,
                    subindex,
                    size,
                    buf,
                    toggle,
                } = &mut self.state
                else {
                    return Some(self.abort_here(AbortCode::INVALID_COMMAND));
                };
                if t != *toggle {
                    return Some(self.abort_here(AbortCode::TOGGLE_BIT_NOT_ALTERNATED));
                }
                let len = buf.len() + data.as_bytes().len();
                if size.is_some_and(|s| usize::try_from(s).is_ok_and(|s| len > s)) {
                    return Some(self.abort_here(AbortCode::LENGTH_TOO_HIGH));
                }
                if len > max_len {
                    return Some(self.abort_here(AbortCode::OUT_OF_MEMORY));
                }
                buf.extend_from_slice(data.as_bytes());
                *toggle = !*toggle;
                if !last {
                    return Some(SdoResponse::WriteSegmentAck { toggle: t });
                }
                if size.is_some_and(|s| usize::try_from(s).is_ok_and(|s| len < s)) {
                    return Some(self.abort_here(AbortCode::LENGTH_TOO_LOW));
                }
                let (index, subindex) = (*index, *subindex);
                let data = core::mem::take(buf);
                self.state = ServerState::Idle;
                match od.write(index, subindex, &data) {
                    Ok(()) => SdoResponse::WriteSegmentAck { toggle: t },
                    Err(code) => abort(index, subindex, code),
                }
            }
            SdoRequest::Read { index, subindex } => {
                self.state = ServerState::Idle;
                let data = match od.read(index, subindex) {
                    Ok(d) => d,
                    Err(code) => return Some(abort(index, subindex, code)),
                };
                if let Some(d) = ExpeditedData::new(&data) {
                    return Some(SdoResponse::ReadValue {
                        index,
                        subindex,
                        data: d,
                    });
                }
                let Ok(size) = u32::try_from(data.len()) else {
                    return Some(abort(index, subindex, AbortCode::OUT_OF_MEMORY));
                };
                self.state = ServerState::Upload {
                    index,
                    subindex,
                    data,
                    pos: 0,
                    toggle: false,
                };
                SdoResponse::InitiateRead {
                    index,
                    subindex,
                    size: Some(size),
                }
            }
            SdoRequest::ReadSegment { toggle: t } => {
                let ServerState::Upload {
                    data, pos, toggle, ..
                } = &mut self.state
                else {
                    return Some(self.abort_here(AbortCode::INVALID_COMMAND));
                };
                if t != *toggle {
                    return Some(self.abort_here(AbortCode::TOGGLE_BIT_NOT_ALTERNATED));
                }
                let rest = data.get(*pos..).unwrap_or(&[]);
                let chunk = SegmentData::truncated(rest);
                *pos += chunk.as_bytes().len();
                let last = *pos >= data.len();
                *toggle = !*toggle;
                if last {
                    self.state = ServerState::Idle;
                }
                SdoResponse::ReadSegment {
                    toggle: t,
                    data: chunk,
                    last,
                }
            }
        })
    }
}

fn abort(index: Index, subindex: Subindex, code: AbortCode) -> SdoResponse {
    SdoResponse::Abort(SdoAbort::new(index, subindex, code))
}

#[cfg(test)]
mod tests;
