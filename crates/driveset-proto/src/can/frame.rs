//! Plain types of the CAN side: owns [`CanFrame`], [`NodeId`] and the SDO
//! messages [`SdoRequest`] (client -> server, "master -> drive") and
//! [`SdoResponse`] (server -> client). No encoding here: see
//! [`super::codec`].
//!
//! Command bytes follow the table on page 454 of the ECS manual and, for
//! what the page leaves out (segments, size-less variants), CiA DS301 V4.02
//! clause 9.2.2.2 (SDO protocols).

use super::abort::SdoAbort;
use super::lenze::{Index, Subindex};

/// Largest 11-bit identifier.
pub const MAX_STANDARD_ID: u32 = 0x7FF;
/// Largest 29-bit identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// A classic CAN 2.0 frame.
///
/// Fields are public for plain construction; [`CanFrame::validate`] tells
/// whether they make a frame (id within 11/29 bits, `len` 0..=8). Every
/// encoder validates first, so a bad frame is an error, never a panic.
/// For a remote frame (`rtr`) `len` is the requested DLC and `data` is
/// unused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct CanFrame {
    /// Identifier (11 or 29 bits).
    pub id: u32,
    /// Payload; bytes past `len` are ignored (and zero when decoded).
    pub data: [u8; 8],
    /// Data length code, 0..=8.
    pub len: u8,
    /// 29-bit identifier (CAN 2.0B) instead of 11-bit.
    pub extended: bool,
    /// Remote transmission request.
    pub rtr: bool,
}

/// Why a [`CanFrame`] is not a valid frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Identifier above 0x7FF (standard) or 0x1FFFFFFF (extended).
    #[error("CAN identifier 0x{id:X} does not fit {bits} bits")]
    IdOutOfRange {
        /// The identifier.
        id: u32,
        /// 11 or 29.
        bits: u8,
    },
    /// More than 8 data bytes.
    #[error("CAN data length {0} is above 8")]
    TooLong(usize),
}

impl CanFrame {
    /// A standard (11-bit) data frame.
    pub fn new(id: u32, data: &[u8]) -> Result<Self, FrameError> {
        Self::build(id, data, false)
    }

    /// An extended (29-bit) data frame.
    pub fn new_extended(id: u32, data: &[u8]) -> Result<Self, FrameError> {
        Self::build(id, data, true)
    }

    /// A standard (11-bit) remote frame requesting `len` bytes.
    pub fn new_remote(id: u32, len: u8) -> Result<Self, FrameError> {
        Self::remote(id, len, false)
    }

    /// An extended (29-bit) remote frame requesting `len` bytes.
    pub fn new_remote_extended(id: u32, len: u8) -> Result<Self, FrameError> {
        Self::remote(id, len, true)
    }

    fn remote(id: u32, len: u8, extended: bool) -> Result<Self, FrameError> {
        let f = CanFrame {
            id,
            data: [0; 8],
            len,
            extended,
            rtr: true,
        };
        f.validate()?;
        Ok(f)
    }

    fn build(id: u32, data: &[u8], extended: bool) -> Result<Self, FrameError> {
        if data.len() > 8 {
            return Err(FrameError::TooLong(data.len()));
        }
        let mut f = CanFrame {
            id,
            data: [0; 8],
            len: data.len() as u8,
            extended,
            rtr: false,
        };
        f.data[..data.len()].copy_from_slice(data);
        f.validate()?;
        Ok(f)
    }

    /// Checks the id range and the length.
    pub const fn validate(&self) -> Result<(), FrameError> {
        let (max, bits) = if self.extended {
            (MAX_EXTENDED_ID, 29)
        } else {
            (MAX_STANDARD_ID, 11)
        };
        if self.id > max {
            return Err(FrameError::IdOutOfRange { id: self.id, bits });
        }
        if self.len > 8 {
            return Err(FrameError::TooLong(self.len as usize));
        }
        Ok(())
    }

    /// The payload (`data[..len]`, empty for a remote frame; clamped to 8).
    pub fn payload(&self) -> &[u8] {
        if self.rtr {
            &[]
        } else {
            &self.data[..usize::from(self.len.min(8))]
        }
    }
}

/// A CANopen node id, 1..=127 (DS301 clause 7.4.2; 0 is reserved for
/// broadcast NMT and is no SDO server).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(u8);

/// DS301 predefined connection set: default SDO COB-ID base client ->
/// server (server's receive SDO).
pub const SDO_REQUEST_COB_BASE: u32 = 0x600;
/// DS301 predefined connection set: default SDO COB-ID base server ->
/// client (server's transmit SDO).
pub const SDO_RESPONSE_COB_BASE: u32 = 0x580;

/// A node id outside 1..=127.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("node id {0} is out of range 1..=127")]
pub struct NodeIdError(pub u32);

impl NodeId {
    /// A node id, 1..=127.
    pub const fn new(id: u8) -> Result<Self, NodeIdError> {
        if id >= 1 && id <= 127 {
            Ok(NodeId(id))
        } else {
            Err(NodeIdError(id as u32))
        }
    }

    /// The number.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// COB-ID of requests to this node: 0x600 + id (DS301 predefined
    /// connection set; the ECS excerpt gives no COB-IDs).
    pub const fn request_cob_id(self) -> u32 {
        SDO_REQUEST_COB_BASE + self.0 as u32
    }

    /// COB-ID of this node's responses: 0x580 + id.
    pub const fn response_cob_id(self) -> u32 {
        SDO_RESPONSE_COB_BASE + self.0 as u32
    }

    /// The node whose request COB-ID this is (0x601..=0x67F).
    pub const fn from_request_cob_id(id: u32) -> Option<NodeId> {
        Self::from_cob(id, SDO_REQUEST_COB_BASE)
    }

    /// The node whose response COB-ID this is (0x581..=0x5FF).
    pub const fn from_response_cob_id(id: u32) -> Option<NodeId> {
        Self::from_cob(id, SDO_RESPONSE_COB_BASE)
    }

    const fn from_cob(id: u32, base: u32) -> Option<NodeId> {
        if id > base && id < base + 128 {
            Some(NodeId((id - base) as u8))
        } else {
            None
        }
    }
}

impl TryFrom<u8> for NodeId {
    type Error = NodeIdError;
    fn try_from(id: u8) -> Result<Self, Self::Error> {
        NodeId::new(id)
    }
}

/// 1 to 4 bytes of an expedited transfer (bytes 5-8 of the frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ExpeditedData {
    bytes: [u8; 4],
    len: u8,
}

impl ExpeditedData {
    /// 1..=4 bytes, or `None`.
    pub fn new(data: &[u8]) -> Option<Self> {
        if data.is_empty() || data.len() > 4 {
            return None;
        }
        let mut bytes = [0; 4];
        bytes[..data.len()].copy_from_slice(data);
        Some(ExpeditedData {
            bytes,
            len: data.len() as u8,
        })
    }

    /// The first 1..=4 bytes of `data`, or 4 zero bytes if `data` is empty
    /// (infallible).
    pub(crate) fn truncated(data: &[u8]) -> Self {
        ExpeditedData::new(&data[..data.len().min(4)]).unwrap_or(ExpeditedData::four([0; 4]))
    }

    /// Four bytes: the FIX32 / bit-coded case.
    pub const fn four(bytes: [u8; 4]) -> Self {
        ExpeditedData { bytes, len: 4 }
    }

    /// The bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// The four data bytes, zero-padded.
    pub const fn padded(&self) -> [u8; 4] {
        self.bytes
    }

    /// The value as an unsigned little-endian number, zero-extended.
    pub const fn to_u32(&self) -> u32 {
        u32::from_le_bytes(self.bytes)
    }
}

/// 0 to 7 bytes of one segment (bytes 2-8 of the frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SegmentData {
    bytes: [u8; 7],
    len: u8,
}

impl SegmentData {
    /// 0..=7 bytes, or `None`.
    pub fn new(data: &[u8]) -> Option<Self> {
        if data.len() > 7 {
            return None;
        }
        let mut bytes = [0; 7];
        bytes[..data.len()].copy_from_slice(data);
        Some(SegmentData {
            bytes,
            len: data.len() as u8,
        })
    }

    /// The bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// The first 7 bytes of `data` (infallible).
    pub(crate) fn truncated(data: &[u8]) -> Self {
        let n = data.len().min(7);
        let mut bytes = [0; 7];
        bytes[..n].copy_from_slice(&data[..n]);
        SegmentData {
            bytes,
            len: n as u8,
        }
    }
}

/// An SDO frame from client (master) to server (drive).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SdoRequest {
    /// Expedited download, page 454 "Write request": 0x2F (1 byte), 0x2B
    /// (2), 0x27 (3, DS301 only), 0x23 (4); 0x22 (DS301: size not
    /// indicated, 4 bytes taken) decodes to a 4-byte write.
    Write {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
        /// The value bytes.
        data: ExpeditedData,
    },
    /// Initiate segmented download: page 454 "Block" write request 0x21 =
    /// DS301 "initiate download, size indicated" (size in bytes 5-8); 0x20
    /// without size.
    InitiateWrite {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
        /// Total length, if indicated.
        size: Option<u32>,
    },
    /// Download segment (DS301 ccs=0): `000t nnnc`.
    WriteSegment {
        /// Toggle bit, 0 on the first segment.
        toggle: bool,
        /// Segment bytes (the `n` unused-byte count follows from its length).
        data: SegmentData,
        /// `c`: no more segments.
        last: bool,
    },
    /// Initiate upload, page 454 "Read request": 0x40.
    Read {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
    },
    /// Upload segment request (DS301 ccs=3): 0x60 / 0x70 by toggle.
    ReadSegment {
        /// Toggle bit, 0 on the first segment.
        toggle: bool,
    },
    /// Abort transfer: 0x80.
    Abort(SdoAbort),
}

/// An SDO frame from server (drive) to client (master).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SdoResponse {
    /// Page 454 "Write response": 0x60 (DS301 initiate download response).
    WriteAck {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
    },
    /// Download segment response (DS301 scs=1): 0x20 / 0x30 by toggle.
    WriteSegmentAck {
        /// Toggle bit of the segment acknowledged.
        toggle: bool,
    },
    /// Expedited upload, page 454 "Read response": 0x4F (1 byte), 0x4B (2),
    /// 0x47 (3, DS301 only), 0x43 (4); 0x42 (size not indicated) decodes to
    /// 4 bytes.
    ReadValue {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
        /// The value bytes.
        data: ExpeditedData,
    },
    /// Initiate segmented upload: page 454 "Block" read response 0x41 =
    /// DS301 "initiate upload response, size indicated"; 0x40 without size.
    InitiateRead {
        /// Index.
        index: Index,
        /// Subindex.
        subindex: Subindex,
        /// Total length, if indicated.
        size: Option<u32>,
    },
    /// Upload segment response (DS301 scs=0): `000t nnnc`.
    ReadSegment {
        /// Toggle bit, equal to the request's.
        toggle: bool,
        /// Segment bytes.
        data: SegmentData,
        /// `c`: no more segments.
        last: bool,
    },
    /// Page 454 "Error response": 0x80 with the DS301 abort code.
    Abort(SdoAbort),
}

impl SdoRequest {
    /// The index/subindex the frame carries (segments carry none).
    pub const fn multiplexer(&self) -> Option<(Index, Subindex)> {
        match *self {
            SdoRequest::Write {
                index, subindex, ..
            }
            | SdoRequest::InitiateWrite {
                index, subindex, ..
            }
            | SdoRequest::Read { index, subindex } => Some((index, subindex)),
            SdoRequest::Abort(a) => Some((a.index, a.subindex)),
            SdoRequest::WriteSegment { .. } | SdoRequest::ReadSegment { .. } => None,
        }
    }
}

impl SdoResponse {
    /// The index/subindex the frame carries (segments carry none).
    pub const fn multiplexer(&self) -> Option<(Index, Subindex)> {
        match *self {
            SdoResponse::WriteAck { index, subindex }
            | SdoResponse::ReadValue {
                index, subindex, ..
            }
            | SdoResponse::InitiateRead {
                index, subindex, ..
            } => Some((index, subindex)),
            SdoResponse::Abort(a) => Some((a.index, a.subindex)),
            SdoResponse::WriteSegmentAck { .. } | SdoResponse::ReadSegment { .. } => None,
        }
    }
}
