//! SDO encoding and decoding: owns the 8 data bytes of an SDO frame, the
//! COB-IDs that carry it and the check that a response answers its request.
//!
//! Layout (page 454 of the ECS manual; DS301 V4.02 clause 9.2.2.2): byte 1
//! command, bytes 2-3 index little-endian, byte 4 subindex, bytes 5-8 data
//! little-endian ("Data1...Data4"). Segments use bytes 2-8 for 7 data bytes.
//! COB-IDs are not in the excerpt: the DS301 predefined connection set is
//! used (0x600 + node client -> server, 0x580 + node server -> client).
//!
//! The byte 0x60 means "write response" from a server but "upload segment
//! request, toggle 0" from a client, so requests and responses are decoded
//! by separate functions, each accepting only the command bytes valid in
//! its direction.

use super::abort::{AbortCode, SdoAbort};
use super::frame::{
    CanFrame, ExpeditedData, FrameError, NodeId, SdoRequest, SdoResponse, SegmentData,
};
use super::lenze::{CodeNumber, Index, LenzeValue, Subindex, ValueFormat};

/// Page 454 "Write request", 4-byte data.
pub const WRITE_REQUEST_4: u8 = 0x23;
/// DS301 expedited download, 3 bytes (not in the page 454 table).
pub const WRITE_REQUEST_3: u8 = 0x27;
/// Page 454 "Write request", 2-byte data.
pub const WRITE_REQUEST_2: u8 = 0x2B;
/// Page 454 "Write request", 1-byte data.
pub const WRITE_REQUEST_1: u8 = 0x2F;
/// Page 454 "Write request", "Block" = DS301 initiate segmented download
/// with size indicated.
pub const WRITE_REQUEST_BLOCK: u8 = 0x21;
/// Page 454 "Write response".
pub const WRITE_RESPONSE: u8 = 0x60;
/// Page 454 "Read request".
pub const READ_REQUEST: u8 = 0x40;
/// Page 454 "Read response", 4-byte data.
pub const READ_RESPONSE_4: u8 = 0x43;
/// DS301 expedited upload, 3 bytes (not in the page 454 table).
pub const READ_RESPONSE_3: u8 = 0x47;
/// Page 454 "Read response", 2-byte data.
pub const READ_RESPONSE_2: u8 = 0x4B;
/// Page 454 "Read response", 1-byte data.
pub const READ_RESPONSE_1: u8 = 0x4F;
/// Page 454 "Read response", "Block" = DS301 initiate segmented upload
/// response with size indicated.
pub const READ_RESPONSE_BLOCK: u8 = 0x41;
/// Page 454 "Error response" = DS301 abort transfer.
pub const ERROR_RESPONSE: u8 = 0x80;

/// A codec or transport error: the frame is not a valid SDO message. (What
/// the *device* reports is an [`SdoAbort`], kept apart.)
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SdoCodecError {
    /// SDO frames carry exactly 8 data bytes (DS301 9.2.2.2).
    #[error("SDO frame has {0} data bytes, expected 8")]
    WrongLength(usize),
    /// The command byte is not valid in this direction.
    #[error("command byte 0x{0:02X} is not a valid SDO {1} command")]
    InvalidCommand(u8, &'static str),
    /// The frame is extended or remote: SDOs are 11-bit data frames.
    #[error("not an SDO frame: extended or remote frame")]
    NotSdoFrame,
    /// The COB-ID is not the expected one for the node.
    #[error("COB-ID 0x{got:03X} is not the expected 0x{expected:03X}")]
    WrongCobId {
        /// The COB-ID for the node and direction.
        expected: u32,
        /// What arrived.
        got: u32,
    },
    /// The response answers another object.
    #[error(
        "response for index 0x{got_index:04X} subindex {got_subindex} does not match the request \
         for index 0x{index:04X} subindex {subindex}"
    )]
    Mismatch {
        /// The request's index.
        index: u16,
        /// The request's subindex.
        subindex: u8,
        /// The response's index.
        got_index: u16,
        /// The response's subindex.
        got_subindex: u8,
    },
    /// The response is of a kind that does not answer the request (e.g. a
    /// write acknowledge to a read, or a segment with the wrong toggle bit).
    #[error("response does not answer the request: {0}")]
    UnexpectedResponse(&'static str),
    /// A segment response carries the wrong toggle bit (DS301 abort
    /// 0x05030000).
    #[error("toggle bit not alternated")]
    ToggleBit,
    /// A frame built from the SDO is not a valid CAN frame (never for a
    /// valid [`NodeId`]).
    #[error(transparent)]
    Frame(#[from] FrameError),
}

fn mux_bytes(out: &mut [u8; 8], index: Index, subindex: Subindex) {
    out[1..3].copy_from_slice(&index.0.to_le_bytes());
    out[3] = subindex.0;
}

fn mux_of(b: &[u8; 8]) -> (Index, Subindex) {
    (Index(u16::from_le_bytes([b[1], b[2]])), Subindex(b[3]))
}

fn data4(b: &[u8; 8]) -> [u8; 4] {
    [b[4], b[5], b[6], b[7]]
}

fn eight(data: &[u8]) -> Result<&[u8; 8], SdoCodecError> {
    data.try_into()
        .map_err(|_| SdoCodecError::WrongLength(data.len()))
}

/// `n` (bits 3-2) for an expedited transfer of `len` 1..=4 bytes.
fn expedited_n(len: usize) -> u8 {
    ((4 - len as u8) & 3) << 2
}

fn segment_byte(toggle: bool, data: &SegmentData, last: bool) -> u8 {
    let n = 7 - data.as_bytes().len() as u8;
    (u8::from(toggle) << 4) | (n << 1) | u8::from(last)
}

fn segment_fields(b: &[u8; 8]) -> (bool, SegmentData, bool) {
    let toggle = b[0] & 0x10 != 0;
    let n = usize::from((b[0] >> 1) & 7);
    let last = b[0] & 1 != 0;
    let data = SegmentData::truncated(&b[1..8 - n]);
    (toggle, data, last)
}

/// An expedited transfer, either way (download request 0x23, upload
/// response 0x43): `cs` with the count of unused bytes, the multiplexer,
/// the value zero-padded to four bytes.
fn expedited_bytes(cs: u8, index: Index, subindex: Subindex, data: &ExpeditedData) -> [u8; 8] {
    let mut out = [0u8; 8];
    out[0] = cs | expedited_n(data.as_bytes().len());
    mux_bytes(&mut out, index, subindex);
    out[4..].copy_from_slice(&data.padded());
    out
}

/// The initiation of a segmented transfer, either way (download request
/// 0x20, upload response 0x40): `cs` with the size-indicated bit, the
/// multiplexer, the size (0 where none is indicated).
fn initiate_bytes(cs: u8, index: Index, subindex: Subindex, size: Option<u32>) -> [u8; 8] {
    let mut out = [0u8; 8];
    out[0] = cs | u8::from(size.is_some());
    mux_bytes(&mut out, index, subindex);
    out[4..].copy_from_slice(&size.unwrap_or(0).to_le_bytes());
    out
}

/// A segment, either way (download request, upload response): toggle,
/// count of unused bytes and last flag, then the data.
fn segment_bytes(toggle: bool, data: &SegmentData, last: bool) -> [u8; 8] {
    let mut out = [0u8; 8];
    out[0] = segment_byte(toggle, data, last);
    out[1..1 + data.as_bytes().len()].copy_from_slice(data.as_bytes());
    out
}

fn abort_bytes(a: &SdoAbort) -> [u8; 8] {
    let mut out = [0u8; 8];
    out[0] = ERROR_RESPONSE;
    mux_bytes(&mut out, a.index, a.subindex);
    out[4..].copy_from_slice(&a.code.to_le_bytes());
    out
}

fn abort_of(b: &[u8; 8]) -> SdoAbort {
    let (index, subindex) = mux_of(b);
    SdoAbort::new(index, subindex, AbortCode(u32::from_le_bytes(data4(b))))
}

impl SdoRequest {
    /// A page 454 write of a Lenze code: 4 bytes (0x23), FIX32 or bit-coded.
    pub fn write_code(code: CodeNumber, subindex: Subindex, value: LenzeValue) -> Self {
        SdoRequest::Write {
            index: code.index(),
            subindex,
            data: ExpeditedData::four(value.to_le_bytes()),
        }
    }

    /// A page 454 read of a Lenze code (0x40).
    pub fn read_code(code: CodeNumber, subindex: Subindex) -> Self {
        SdoRequest::Read {
            index: code.index(),
            subindex,
        }
    }

    /// The 8 data bytes.
    pub fn encode(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        match self {
            SdoRequest::Write {
                index,
                subindex,
                data,
            } => out = expedited_bytes(0x23, *index, *subindex, data),
            SdoRequest::InitiateWrite {
                index,
                subindex,
                size,
            } => out = initiate_bytes(0x20, *index, *subindex, *size),
            SdoRequest::WriteSegment { toggle, data, last } => {
                out = segment_bytes(*toggle, data, *last);
            }
            SdoRequest::Read { index, subindex } => {
                out[0] = READ_REQUEST;
                mux_bytes(&mut out, *index, *subindex);
            }
            SdoRequest::ReadSegment { toggle } => out[0] = 0x60 | (u8::from(*toggle) << 4),
            SdoRequest::Abort(a) => out = abort_bytes(a),
        }
        out
    }

    /// Decodes the 8 data bytes of a client -> server frame.
    ///
    /// Accepted command bytes: 0x00..=0x1F (segment), 0x20-0x23, 0x27, 0x2B,
    /// 0x2F (initiate download), 0x40 (initiate upload), 0x60/0x70 (upload
    /// segment), 0x80 (abort). Reserved bits set, block transfer (0xA0..,
    /// 0xC0..) and the rest are [`SdoCodecError::InvalidCommand`].
    pub fn decode(data: &[u8]) -> Result<Self, SdoCodecError> {
        let b = eight(data)?;
        let (index, subindex) = mux_of(b);
        Ok(match b[0] {
            0x00..=0x1F => {
                let (toggle, data, last) = segment_fields(b);
                SdoRequest::WriteSegment { toggle, data, last }
            }
            0x20 | 0x21 => SdoRequest::InitiateWrite {
                index,
                subindex,
                size: (b[0] == 0x21).then(|| u32::from_le_bytes(data4(b))),
            },
            c @ (0x22 | 0x23 | 0x27 | 0x2B | 0x2F) => {
                let len = if c == 0x22 {
                    4
                } else {
                    4 - usize::from((c >> 2) & 3)
                };
                SdoRequest::Write {
                    index,
                    subindex,
                    data: ExpeditedData::truncated(&b[4..4 + len]),
                }
            }
            0x40 => SdoRequest::Read { index, subindex },
            0x60 | 0x70 => SdoRequest::ReadSegment {
                toggle: b[0] == 0x70,
            },
            0x80 => SdoRequest::Abort(abort_of(b)),
            c => return Err(SdoCodecError::InvalidCommand(c, "request")),
        })
    }

    /// The CAN frame to `node` (COB-ID 0x600 + node, DS301 predefined
    /// connection set).
    pub fn to_can(&self, node: NodeId) -> CanFrame {
        sdo_frame(node.request_cob_id(), self.encode())
    }

    /// Decodes a frame that a server with id `node` receives.
    pub fn from_can(frame: &CanFrame, node: NodeId) -> Result<Self, SdoCodecError> {
        check_can(frame, node.request_cob_id())?;
        SdoRequest::decode(frame.payload())
    }
}

/// An SDO frame: 11-bit identifier, always 8 data bytes (DS301).
fn sdo_frame(id: u32, data: [u8; 8]) -> CanFrame {
    CanFrame {
        id,
        data,
        len: 8,
        extended: false,
        rtr: false,
    }
}

impl SdoResponse {
    /// The 8 data bytes.
    pub fn encode(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        match self {
            SdoResponse::WriteAck { index, subindex } => {
                out[0] = WRITE_RESPONSE;
                mux_bytes(&mut out, *index, *subindex);
            }
            SdoResponse::WriteSegmentAck { toggle } => out[0] = 0x20 | (u8::from(*toggle) << 4),
            SdoResponse::ReadValue {
                index,
                subindex,
                data,
            } => out = expedited_bytes(0x43, *index, *subindex, data),
            SdoResponse::InitiateRead {
                index,
                subindex,
                size,
            } => out = initiate_bytes(0x40, *index, *subindex, *size),
            SdoResponse::ReadSegment { toggle, data, last } => {
                out = segment_bytes(*toggle, data, *last);
            }
            SdoResponse::Abort(a) => out = abort_bytes(a),
        }
        out
    }

    /// Decodes the 8 data bytes of a server -> client frame.
    ///
    /// Accepted command bytes: 0x00..=0x1F (upload segment), 0x20/0x30
    /// (download segment response), 0x40-0x43, 0x47, 0x4B, 0x4F (initiate
    /// upload response), 0x60 (initiate download response), 0x80 (abort).
    pub fn decode(data: &[u8]) -> Result<Self, SdoCodecError> {
        let b = eight(data)?;
        let (index, subindex) = mux_of(b);
        Ok(match b[0] {
            0x00..=0x1F => {
                let (toggle, data, last) = segment_fields(b);
                SdoResponse::ReadSegment { toggle, data, last }
            }
            0x20 | 0x30 => SdoResponse::WriteSegmentAck {
                toggle: b[0] == 0x30,
            },
            0x40 | 0x41 => SdoResponse::InitiateRead {
                index,
                subindex,
                size: (b[0] == 0x41).then(|| u32::from_le_bytes(data4(b))),
            },
            c @ (0x42 | 0x43 | 0x47 | 0x4B | 0x4F) => {
                let len = if c == 0x42 {
                    4
                } else {
                    4 - usize::from((c >> 2) & 3)
                };
                SdoResponse::ReadValue {
                    index,
                    subindex,
                    data: ExpeditedData::truncated(&b[4..4 + len]),
                }
            }
            0x60 => SdoResponse::WriteAck { index, subindex },
            0x80 => SdoResponse::Abort(abort_of(b)),
            c => return Err(SdoCodecError::InvalidCommand(c, "response")),
        })
    }

    /// The CAN frame from `node` (COB-ID 0x580 + node).
    pub fn to_can(&self, node: NodeId) -> CanFrame {
        sdo_frame(node.response_cob_id(), self.encode())
    }

    /// Decodes a frame that the client receives from server `node`.
    pub fn from_can(frame: &CanFrame, node: NodeId) -> Result<Self, SdoCodecError> {
        check_can(frame, node.response_cob_id())?;
        SdoResponse::decode(frame.payload())
    }

    /// The Lenze value of a 4-byte expedited read response, in `format`.
    /// `None` for any other response (or fewer than 4 bytes).
    pub fn lenze_value(&self, format: ValueFormat) -> Option<LenzeValue> {
        match self {
            SdoResponse::ReadValue { data, .. } if data.as_bytes().len() == 4 => {
                Some(LenzeValue::from_le_bytes(format, data.padded()))
            }
            _ => None,
        }
    }

    /// Checks that this response answers `request`: the right kind, the same
    /// index/subindex for initiate responses, the same toggle bit for
    /// segments. An abort answers any request of a transfer; for initiate
    /// requests its index/subindex must match too. Nothing answers an abort.
    pub fn check_answers(&self, request: &SdoRequest) -> Result<(), SdoCodecError> {
        use SdoRequest as Q;
        use SdoResponse as R;
        let kind_ok = match (request, self) {
            (Q::Abort(_), _) => {
                return Err(SdoCodecError::UnexpectedResponse(
                    "an abort is not answered",
                ));
            }
            (Q::WriteSegment { toggle: t, .. }, R::WriteSegmentAck { toggle }) => {
                if t != toggle {
                    return Err(SdoCodecError::ToggleBit);
                }
                true
            }
            (Q::ReadSegment { toggle: t }, R::ReadSegment { toggle, .. }) => {
                if t != toggle {
                    return Err(SdoCodecError::ToggleBit);
                }
                true
            }
            (Q::WriteSegment { .. } | Q::ReadSegment { .. }, R::Abort(_)) => return Ok(()),
            (Q::Write { .. } | Q::InitiateWrite { .. }, R::WriteAck { .. })
            | (Q::Read { .. }, R::ReadValue { .. } | R::InitiateRead { .. })
            | (Q::Write { .. } | Q::InitiateWrite { .. } | Q::Read { .. }, R::Abort(_)) => true,
            _ => false,
        };
        if !kind_ok {
            return Err(SdoCodecError::UnexpectedResponse(
                "response kind does not answer the request kind",
            ));
        }
        if let (Some((qi, qs)), Some((ri, rs))) = (request.multiplexer(), self.multiplexer())
            && (qi, qs) != (ri, rs)
        {
            return Err(SdoCodecError::Mismatch {
                index: qi.0,
                subindex: qs.0,
                got_index: ri.0,
                got_subindex: rs.0,
            });
        }
        Ok(())
    }
}

fn check_can(frame: &CanFrame, expected: u32) -> Result<(), SdoCodecError> {
    if frame.extended || frame.rtr {
        return Err(SdoCodecError::NotSdoFrame);
    }
    if frame.id != expected {
        return Err(SdoCodecError::WrongCobId {
            expected,
            got: frame.id,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn code(n: u32) -> CodeNumber {
        CodeNumber::new(n).unwrap()
    }

    #[test]
    fn write_c0011_fix32_50() {
        let v = LenzeValue::Fix32("50.0".parse().unwrap());
        let q = SdoRequest::write_code(code(11), Subindex(0), v);
        assert_eq!(q.encode(), [0x23, 0xF4, 0x5F, 0x00, 0x20, 0xA1, 0x07, 0x00]);
        assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
    }

    #[test]
    fn write_c0135_bit_coded_without_factor() {
        let q = SdoRequest::write_code(code(135), Subindex(0), LenzeValue::BitCoded(0x0000_0401));
        // 24575 - 135 = 24440 = 0x5F78
        assert_eq!(q.encode(), [0x23, 0x78, 0x5F, 0x00, 0x01, 0x04, 0x00, 0x00]);
    }

    #[test]
    fn page_454_command_bytes_requests() {
        let ix = Index(0x5FF4);
        let s = Subindex(1);
        let w = |d: &[u8]| SdoRequest::Write {
            index: ix,
            subindex: s,
            data: ExpeditedData::new(d).unwrap(),
        };
        assert_eq!(w(&[1, 2, 3, 4]).encode(), [0x23, 0xF4, 0x5F, 1, 1, 2, 3, 4]);
        assert_eq!(w(&[1, 2]).encode(), [0x2B, 0xF4, 0x5F, 1, 1, 2, 0, 0]);
        assert_eq!(w(&[1]).encode(), [0x2F, 0xF4, 0x5F, 1, 1, 0, 0, 0]);
        assert_eq!(w(&[1, 2, 3]).encode(), [0x27, 0xF4, 0x5F, 1, 1, 2, 3, 0]);
        let block = SdoRequest::InitiateWrite {
            index: ix,
            subindex: s,
            size: Some(10),
        };
        assert_eq!(block.encode(), [0x21, 0xF4, 0x5F, 1, 10, 0, 0, 0]);
        assert_eq!(
            SdoRequest::Read {
                index: ix,
                subindex: s
            }
            .encode(),
            [0x40, 0xF4, 0x5F, 1, 0, 0, 0, 0]
        );
        for q in [w(&[1, 2, 3, 4]), w(&[1, 2]), w(&[1]), w(&[1, 2, 3]), block] {
            assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
        }
    }

    #[test]
    fn page_454_command_bytes_responses() {
        let ix = Index(0x5FF4);
        let s = Subindex(0);
        assert_eq!(
            SdoResponse::WriteAck {
                index: ix,
                subindex: s
            }
            .encode(),
            [0x60, 0xF4, 0x5F, 0, 0, 0, 0, 0]
        );
        let r = |d: &[u8]| SdoResponse::ReadValue {
            index: ix,
            subindex: s,
            data: ExpeditedData::new(d).unwrap(),
        };
        assert_eq!(r(&[0x20, 0xA1, 0x07, 0]).encode()[0], 0x43);
        assert_eq!(r(&[1, 2]).encode()[0], 0x4B);
        assert_eq!(r(&[1]).encode()[0], 0x4F);
        assert_eq!(
            SdoResponse::InitiateRead {
                index: ix,
                subindex: s,
                size: Some(300)
            }
            .encode(),
            [0x41, 0xF4, 0x5F, 0, 0x2C, 0x01, 0, 0]
        );
    }

    #[test]
    fn read_response_decodes_to_fix32() {
        let r = SdoResponse::decode(&[0x43, 0xF4, 0x5F, 0x00, 0x20, 0xA1, 0x07, 0x00]).unwrap();
        assert_eq!(
            r.lenze_value(ValueFormat::Fix32),
            Some(LenzeValue::Fix32(crate::can::Fix32(500_000)))
        );
        assert_eq!(r.multiplexer(), Some((Index(24564), Subindex(0))));
        // 2-byte response: only the low bytes count
        let r = SdoResponse::decode(&[0x4B, 0xF4, 0x5F, 0x00, 0x34, 0x12, 0xEE, 0xEE]).unwrap();
        match r {
            SdoResponse::ReadValue { data, .. } => {
                assert_eq!(data.as_bytes(), &[0x34, 0x12]);
                assert_eq!(data.to_u32(), 0x1234);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(r.lenze_value(ValueFormat::Fix32), None);
    }

    #[test]
    fn error_response_object_does_not_exist() {
        let a = SdoResponse::Abort(SdoAbort::new(
            Index(0x5FF4),
            Subindex(0),
            AbortCode::NO_SUCH_OBJECT,
        ));
        assert_eq!(a.encode(), [0x80, 0xF4, 0x5F, 0x00, 0x00, 0x00, 0x02, 0x06]);
        assert_eq!(SdoResponse::decode(&a.encode()), Ok(a));
        // the same frame from a client is an abort request
        assert!(matches!(
            SdoRequest::decode(&a.encode()),
            Ok(SdoRequest::Abort(x)) if x.code == AbortCode::NO_SUCH_OBJECT
        ));
    }

    #[test]
    fn direction_dependent_0x60() {
        let b = [0x60, 0xF4, 0x5F, 0, 0, 0, 0, 0];
        assert_eq!(
            SdoResponse::decode(&b),
            Ok(SdoResponse::WriteAck {
                index: Index(0x5FF4),
                subindex: Subindex(0)
            })
        );
        assert_eq!(
            SdoRequest::decode(&b),
            Ok(SdoRequest::ReadSegment { toggle: false })
        );
    }

    #[test]
    fn segments() {
        let q = SdoRequest::WriteSegment {
            toggle: true,
            data: SegmentData::new(&[1, 2, 3]).unwrap(),
            last: true,
        };
        // 000t nnnc: t=1, n=4, c=1 -> 0x19
        assert_eq!(q.encode(), [0x19, 1, 2, 3, 0, 0, 0, 0]);
        assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
        let r = SdoResponse::ReadSegment {
            toggle: false,
            data: SegmentData::new(&[9; 7]).unwrap(),
            last: false,
        };
        assert_eq!(r.encode(), [0x00, 9, 9, 9, 9, 9, 9, 9]);
        assert_eq!(SdoResponse::decode(&r.encode()), Ok(r));
        assert_eq!(SdoRequest::ReadSegment { toggle: true }.encode()[0], 0x70);
        assert_eq!(
            SdoResponse::WriteSegmentAck { toggle: true }.encode()[0],
            0x30
        );
    }

    #[test]
    fn invalid_commands_and_lengths() {
        for c in [0x24, 0x28, 0x30, 0x41, 0x50, 0x61, 0x71, 0xA0, 0xC0, 0xFF] {
            assert_eq!(
                SdoRequest::decode(&[c, 0, 0, 0, 0, 0, 0, 0]),
                Err(SdoCodecError::InvalidCommand(c, "request")),
                "{c:02X}"
            );
        }
        for c in [0x21, 0x44, 0x50, 0x61, 0x70, 0x81, 0xA0, 0xFF] {
            assert_eq!(
                SdoResponse::decode(&[c, 0, 0, 0, 0, 0, 0, 0]),
                Err(SdoCodecError::InvalidCommand(c, "response")),
                "{c:02X}"
            );
        }
        assert_eq!(
            SdoRequest::decode(&[0x40; 7]),
            Err(SdoCodecError::WrongLength(7))
        );
        assert_eq!(SdoResponse::decode(&[]), Err(SdoCodecError::WrongLength(0)));
    }

    #[test]
    fn cob_ids_predefined_connection_set() {
        let n = NodeId::new(5).unwrap();
        let q = SdoRequest::read_code(code(11), Subindex(0));
        let f = q.to_can(n);
        assert_eq!(f.id, 0x605);
        assert_eq!(SdoRequest::from_can(&f, n), Ok(q));
        assert_eq!(
            SdoRequest::from_can(&f, NodeId::new(6).unwrap()),
            Err(SdoCodecError::WrongCobId {
                expected: 0x606,
                got: 0x605
            })
        );
        let r = SdoResponse::WriteAck {
            index: Index(1),
            subindex: Subindex(2),
        };
        assert_eq!(r.to_can(n).id, 0x585);
        let mut ext = r.to_can(n);
        ext.extended = true;
        assert_eq!(
            SdoResponse::from_can(&ext, n),
            Err(SdoCodecError::NotSdoFrame)
        );
        assert_eq!(NodeId::new(0), Err(crate::can::NodeIdError(0)));
        assert_eq!(NodeId::new(128), Err(crate::can::NodeIdError(128)));
        assert_eq!(NodeId::from_response_cob_id(0x5FF), NodeId::new(127).ok());
        assert_eq!(NodeId::from_response_cob_id(0x580), None);
        assert_eq!(NodeId::from_request_cob_id(0x680), None);
    }

    #[test]
    fn response_matching() {
        let q = SdoRequest::read_code(code(11), Subindex(0));
        let ok = SdoResponse::decode(&[0x43, 0xF4, 0x5F, 0, 1, 0, 0, 0]).unwrap();
        assert_eq!(ok.check_answers(&q), Ok(()));
        let other = SdoResponse::decode(&[0x43, 0xF5, 0x5F, 0, 1, 0, 0, 0]).unwrap();
        assert_eq!(
            other.check_answers(&q),
            Err(SdoCodecError::Mismatch {
                index: 0x5FF4,
                subindex: 0,
                got_index: 0x5FF5,
                got_subindex: 0
            })
        );
        let ack = SdoResponse::WriteAck {
            index: Index(0x5FF4),
            subindex: Subindex(0),
        };
        assert!(matches!(
            ack.check_answers(&q),
            Err(SdoCodecError::UnexpectedResponse(_))
        ));
        let seg = SdoRequest::ReadSegment { toggle: true };
        let seg_r = SdoResponse::ReadSegment {
            toggle: false,
            data: SegmentData::new(&[1]).unwrap(),
            last: true,
        };
        assert_eq!(seg_r.check_answers(&seg), Err(SdoCodecError::ToggleBit));
        let abort = SdoResponse::Abort(SdoAbort::new(
            Index(0),
            Subindex(0),
            AbortCode::GENERAL_ERROR,
        ));
        assert_eq!(abort.check_answers(&seg), Ok(()));
        assert!(matches!(
            abort.check_answers(&q),
            Err(SdoCodecError::Mismatch { .. })
        ));
    }
}
