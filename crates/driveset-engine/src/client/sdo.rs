//! [`CanClient`]: Lenze system bus (CAN) SDO parameter access
//! (`lenze-system-bus-can-sdo.txt`, ECS manual page 454) for Lenze ECS
//! axes, on a [`FrameLink`].
//!
//! - Addressing: `index = index_base - code` (the schema's
//!   `[schema.can] index_base`, else page 454's 24575), subindex = subcode
//!   (0 without; an assumption recorded in `docs/errata/can.md`).
//! - COB-IDs: DS301 predefined connection set, requests on `0x600 + node`,
//!   responses on `0x580 + node` (the codec's [`NodeId`]).
//! - Transfers run through the codec's [`SdoClient`] state machine:
//!   expedited for 1..=4 bytes, segmented otherwise (VS / VO codes).
//! - Values per the schema type: FIX32 a signed 32-bit raw (value x 10000),
//!   BITCODED an unsigned 32-bit field without factor (C0135 / C0150), both
//!   4 bytes little-endian; VS the text's bytes; VO the octets. A shorter
//!   numeric answer is zero- (BITCODED) or sign-extended (FIX32).
//! - An SDO abort from the drive is an [`DeviceFailure::Refused`](crate::error::DeviceFailure::Refused) with the
//!   DS301 text and the codec's hint; a protocol failure (bad frame, toggle
//!   bit) is answered with the codec's abort frame and repeated; no answer
//!   within [`CanOptions::answer_timeout`] (default 50 ms; the excerpt gives
//!   no response time) sends the timeout abort (0x05040000) and repeats the
//!   transfer, [`CanOptions::tries`] (3) times in all, then
//!   [`LinkFailure::NoAnswer`](crate::error::LinkFailure::NoAnswer).
//! - `running()`: the schema's running indicator
//!   (`Schema::running_indicator`, a C0150 bit of role `running`), read
//!   like any code. The excerpt documents no bits of C0150, so with the
//!   real `lenze-ecs` schema it is `None` ("running state unknown": an
//!   upload needs `--allow-running-unknown`); the FICTIONAL
//!   `fictional-ecs-demo` fixture (the simulator's) names bit 1.

use std::sync::Arc;
use std::time::Duration;

use driveset_link::mem::can_frame_time;
use driveset_link::{FrameLink, LinkError};
use driveset_proto::can::{
    ClientEvent, Completed, Index, NodeId, SdoClient, SdoRequest, SdoResponse, Subindex,
    lenze::INDEX_BASE,
};
use driveset_schema::{BusProtocol, Code, CodeKey, RawValue, Schema, ValueType};

use super::{
    ClientStats, Drive, Protocol, Target, client_address, code_name, device, link_error,
    refuse_read_only, schema_code, shown_value, write_what, wrong_client,
};
use crate::error::{DeviceCause, EngineError, Refusal};
use crate::guard::{self, Permit};

/// Options of a [`CanClient`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CanOptions {
    /// Transfers of one request before giving up. Default 3; 0 counts as 1.
    pub tries: u32,
    /// How long to wait for each SDO response. Default 50 ms.
    pub answer_timeout: Duration,
}

impl Default for CanOptions {
    fn default() -> Self {
        CanOptions {
            tries: 3,
            answer_timeout: Duration::from_millis(50),
        }
    }
}

/// What one transfer gave.
#[derive(Debug)]
enum Outcome {
    Done(Completed),
    Aborted(driveset_proto::can::SdoAbort),
    NoAnswer,
    Failed(String),
}

/// The bus side: link, SDO state machine, counters. Shared with scan.
#[derive(Debug)]
pub struct SdoLine<L> {
    pub(crate) link: L,
    sdo: SdoClient,
    pub(crate) stats: ClientStats,
}

impl<L: FrameLink> SdoLine<L> {
    pub(crate) fn new(link: L) -> Self {
        SdoLine {
            link,
            sdo: SdoClient::new(),
            stats: ClientStats::default(),
        }
    }

    fn send(&mut self, node: NodeId, req: &SdoRequest) -> Result<(), LinkError> {
        self.link.send(&req.to_can(node))?;
        self.stats.sent += 1;
        Ok(())
    }

    /// Runs one transfer started with `first` to its end.
    fn transfer(
        &mut self,
        node: NodeId,
        first: SdoRequest,
        timeout: Duration,
    ) -> Result<Outcome, LinkError> {
        self.link.discard_input()?;
        self.stats.telegrams += 1;
        self.send(node, &first)?;
        let mut deadline = self.link.clock().now() + timeout;
        loop {
            let Some(frame) = self.link.recv(deadline)? else {
                if let Some(abort) = self.sdo.on_timeout() {
                    self.send(node, &abort)?;
                }
                return Ok(Outcome::NoAnswer);
            };
            self.stats.received += 1;
            if frame.id != node.response_cob_id() || frame.extended || frame.rtr {
                continue;
            }
            let resp = match SdoResponse::from_can(&frame, node) {
                Ok(r) => r,
                Err(e) => {
                    let reason = e.to_string();
                    if let Some(abort) = self.sdo.on_timeout() {
                        // Abandon the transfer (the codec has no "abort with
                        // cause" entry for undecodable frames; the server
                        // only needs to drop its state).
                        self.send(node, &abort)?;
                    }
                    return Ok(Outcome::Failed(reason));
                }
            };
            match self.sdo.on_response(resp) {
                ClientEvent::Send(next) => {
                    self.send(node, &next)?;
                    deadline = self.link.clock().now() + timeout;
                }
                ClientEvent::Done(c) => return Ok(Outcome::Done(c)),
                ClientEvent::Aborted(a) => return Ok(Outcome::Aborted(a)),
                ClientEvent::Failed { error, abort } => {
                    if let Some(abort) = abort {
                        self.send(node, &abort)?;
                        return Ok(Outcome::Failed(error.to_string()));
                    }
                    // A stray frame (late answer to an earlier request):
                    // keep waiting for ours.
                }
            }
        }
    }
}

/// How a code's value travels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wire {
    Fix32,
    BitCoded,
    /// A CiA 301 basic integer type, little-endian, of its own width.
    Int {
        bytes: usize,
        signed: bool,
    },
    Text,
    Octets,
}

fn wire_of(schema: &Schema, code: &Code) -> Option<Wire> {
    Some(match schema.type_of(code) {
        Some(ValueType::FIX32) => Wire::Fix32,
        Some(ValueType::BITCODED) => Wire::BitCoded,
        Some(ValueType::VS) => Wire::Text,
        Some(ValueType::VO) => Wire::Octets,
        Some(ValueType::UNSIGNED8) => Wire::Int {
            bytes: 1,
            signed: false,
        },
        Some(ValueType::UNSIGNED16) => Wire::Int {
            bytes: 2,
            signed: false,
        },
        Some(ValueType::UNSIGNED32) => Wire::Int {
            bytes: 4,
            signed: false,
        },
        Some(ValueType::INTEGER8) => Wire::Int {
            bytes: 1,
            signed: true,
        },
        Some(ValueType::INTEGER16) => Wire::Int {
            bytes: 2,
            signed: true,
        },
        Some(ValueType::INTEGER32) => Wire::Int {
            bytes: 4,
            signed: true,
        },
        Some(_) => return None,
        None => match code.number {
            135 | 150 => Wire::BitCoded,
            _ => Wire::Fix32,
        },
    })
}

fn bytes_to_raw(wire: Wire, data: &[u8]) -> Option<RawValue> {
    Some(match wire {
        Wire::Fix32 | Wire::BitCoded => {
            if data.is_empty() || data.len() > 4 {
                return None;
            }
            let negative = wire == Wire::Fix32 && data.last().is_some_and(|b| b & 0x80 != 0);
            let mut b = if negative { [0xFF; 4] } else { [0; 4] };
            b[..data.len()].copy_from_slice(data);
            RawValue::Int(match wire {
                Wire::Fix32 => i64::from(i32::from_le_bytes(b)),
                _ => i64::from(u32::from_le_bytes(b)),
            })
        }
        Wire::Int { bytes, signed } => {
            if data.is_empty() || data.len() > bytes {
                return None;
            }
            let negative =
                signed && data.len() == bytes && data.last().is_some_and(|b| b & 0x80 != 0);
            let mut b = if negative { [0xFF; 8] } else { [0; 8] };
            b[..data.len()].copy_from_slice(data);
            RawValue::Int(i64::from_le_bytes(b))
        }
        Wire::Text => RawValue::Text(String::from_utf8_lossy(data).into_owned()),
        Wire::Octets => RawValue::Octets(data.to_vec()),
    })
}

fn raw_to_bytes(wire: Wire, raw: &RawValue) -> Option<Vec<u8>> {
    Some(match (wire, raw) {
        (Wire::Fix32, RawValue::Int(n)) => i32::try_from(*n).ok()?.to_le_bytes().to_vec(),
        (Wire::BitCoded, RawValue::Int(n)) => u32::try_from(*n).ok()?.to_le_bytes().to_vec(),
        (Wire::Int { bytes, signed }, RawValue::Int(n)) => {
            let bits = 8 * bytes as u32;
            let (lo, hi) = if signed {
                (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
            } else {
                (0, (1i64 << bits) - 1)
            };
            if *n < lo || *n > hi {
                return None;
            }
            n.to_le_bytes()[..bytes].to_vec()
        }
        (Wire::Text, RawValue::Text(t)) => t.as_bytes().to_vec(),
        (Wire::Octets, RawValue::Octets(o)) => o.clone(),
        _ => return None,
    })
}

/// A Lenze ECS axis (SDO server) at one node id.
#[derive(Debug)]
pub struct CanClient<L: FrameLink = Box<dyn FrameLink>> {
    drive: Drive<SdoLine<L>>,
    node: NodeId,
    opts: CanOptions,
}

impl<L: FrameLink> CanClient<L> {
    /// A client for node `node` (1..=127) with default options.
    pub fn new(link: L, schema: Arc<Schema>, node: u8) -> Result<Self, EngineError> {
        Self::with_options(link, schema, node, CanOptions::default())
    }

    /// As [`CanClient::new`] with `opts`.
    pub fn with_options(
        link: L,
        schema: Arc<Schema>,
        node: u8,
        opts: CanOptions,
    ) -> Result<Self, EngineError> {
        let target = Target {
            port: link.port().to_string(),
            address: node,
        };
        if !BusProtocol::CanSdo.carries(schema.family) {
            return Err(wrong_client(target, &schema, BusProtocol::CanSdo));
        }
        let node = client_address(&target, BusProtocol::CanSdo, |n| {
            NodeId::new(n).map_err(|e| e.to_string())
        })?;
        Ok(CanClient {
            drive: Drive::new(target, schema, SdoLine::new(link)),
            node,
            opts,
        })
    }

    /// The link.
    pub fn link(&self) -> &L {
        &self.drive.line.link
    }

    /// The link, mutably (tests, reopening).
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.drive.line.link
    }

    /// The link back (without sending what [`DriveClient::finish`]
    /// sends: call it first).
    ///
    /// [`DriveClient::finish`]: crate::client::DriveClient::finish
    pub fn into_link(self) -> L {
        self.drive.line.link
    }

    fn tries(&self) -> u32 {
        self.opts.tries.max(1)
    }

    fn refused(&self, refusal: Refusal) -> EngineError {
        EngineError::refused(self.drive.target.clone(), refusal)
    }

    fn mux(&self, key: CodeKey) -> Result<(Index, Subindex), EngineError> {
        mux_of(&self.drive.schema, key).ok_or_else(|| {
            self.refused(
                super::SdoRefusal::NoIndex {
                    code: code_name(&self.drive.schema, key),
                    base: self
                        .drive
                        .schema
                        .can_index_base
                        .unwrap_or(u32::from(INDEX_BASE)),
                }
                .into(),
            )
        })
    }

    /// Runs a transfer with retries; `start` builds its first frame.
    fn run(
        &mut self,
        what: &str,
        mut start: impl FnMut(&mut SdoClient) -> Result<SdoRequest, String>,
    ) -> Result<Completed, EngineError> {
        let mut last = String::new();
        for attempt in 0..self.tries() {
            if attempt > 0 {
                self.drive.line.stats.retries += 1;
            }
            if !self.drive.line.sdo.is_idle() {
                self.drive.line.sdo = SdoClient::new();
            }
            let first = start(&mut self.drive.line.sdo).map_err(|detail| {
                self.refused(Refusal::Encode {
                    what: Some(what.to_string()),
                    detail,
                })
            })?;
            let out = self
                .drive
                .line
                .transfer(self.node, first, self.opts.answer_timeout)
                .map_err(|e| link_error(&self.drive.target, e))?;
            match out {
                Outcome::Done(c) => return Ok(c),
                Outcome::Aborted(a) => {
                    return Err(device(
                        &self.drive.target,
                        what,
                        DeviceCause::SdoAbort {
                            code: a.code,
                            index: a.index,
                            subindex: a.subindex,
                        },
                    ));
                }
                Outcome::Failed(e) => last = e,
                Outcome::NoAnswer => last.clear(),
            }
        }
        let what = if last.is_empty() {
            what.to_string()
        } else {
            format!("{what} (last transfer failed: {last})")
        };
        Err(EngineError::no_answer(
            self.drive.target.clone(),
            what,
            self.tries(),
        ))
    }

    fn read_code(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        let wire = wire_of(&schema, code).ok_or_else(|| {
            self.refused(
                super::SdoRefusal::NotSdoType {
                    code: code_name(&schema, key),
                    ty: schema
                        .type_of(code)
                        .map_or("?", ValueType::name)
                        .to_string(),
                }
                .into(),
            )
        })?;
        let (index, subindex) = self.mux(key)?;
        let done = self.run(what, |c| {
            c.start_read(index, subindex).map_err(|e| e.to_string())
        })?;
        let Completed::Read { data, .. } = done else {
            return Err(EngineError::protocol(
                self.drive.target.clone(),
                what.to_string(),
                "a write acknowledgement to a read",
            ));
        };
        bytes_to_raw(wire, &data).ok_or_else(|| {
            EngineError::protocol(
                self.drive.target.clone(),
                what.to_string(),
                format!("{} data bytes for a 4-byte value", data.len()),
            )
        })
    }
}

/// Index and subindex of `key` under `schema`.
/// A CiA 301 object kept by index (`[[code]] index`) uses its own index,
/// and a single subindex kept as a code (`subindex`) its own subindex.
fn mux_of(schema: &Schema, key: CodeKey) -> Option<(Index, Subindex)> {
    let base = schema.can_index_base.unwrap_or(u32::from(INDEX_BASE));
    let code = schema.code(key.number);
    let index = match code.and_then(|c| c.index) {
        Some(i) => i,
        None => u16::try_from(base.checked_sub(key.number)?).ok()?,
    };
    // a code that is one subindex of a record (`subindex`) has no subcodes
    let sub = match code.and_then(|c| c.subindex) {
        Some(s) => s,
        None => u8::try_from(key.subcode.unwrap_or(0)).ok()?,
    };
    Some((Index(index), Subindex(sub)))
}

impl<L: FrameLink> Protocol for CanClient<L> {
    type Line = SdoLine<L>;

    fn drive(&self) -> &Drive<SdoLine<L>> {
        &self.drive
    }

    fn read_key(&mut self, key: CodeKey, what: &str) -> Result<RawValue, EngineError> {
        self.read_code(key, what)
    }

    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        permit: Permit,
    ) -> Result<(), EngineError> {
        let schema = Arc::clone(&self.drive.schema);
        let code = schema_code(&schema, &self.drive.target, key)?;
        refuse_read_only(&schema, &self.drive.target, key, code)?;
        let cleared = guard::check(&schema, &self.drive.target, key, raw, permit)?;
        let what = write_what(&schema, key, raw);
        let data = wire_of(&schema, code)
            .and_then(|w| raw_to_bytes(w, raw))
            .ok_or_else(|| {
                self.refused(
                    super::SdoRefusal::NotCanFormat {
                        code: code_name(&schema, key),
                        value: shown_value(&schema, key, raw),
                    }
                    .into(),
                )
            })?;
        let (index, subindex) = self.mux(key)?;
        self.run(&what, |c| {
            guard::sdo_download(&cleared, c, index, subindex, &data)
        })?;
        Ok(())
    }

    fn store(&mut self, command: &driveset_schema::StoreCommand) -> Result<(), EngineError> {
        // the store's acknowledgement comes once the device has stored:
        // wait the schema's store timeout for it, not a read's
        let usual = self.opts.answer_timeout;
        self.opts.answer_timeout = usual.max(command.timeout);
        let sent = self.drive.line.link.clock().now();
        let r = Protocol::write_named(
            self,
            CodeKey::new(command.code),
            &RawValue::Int(command.value),
            Permit::STORE,
        );
        self.opts.answer_timeout = usual;
        r?;
        // a device command reports its progress: read it until done
        crate::client::poll_store(self, command, sent)
    }

    fn read_time(&self, key: CodeKey) -> Duration {
        let frame = SdoRequest::Read {
            index: Index(0),
            subindex: Subindex(0),
        }
        .to_can(self.node);
        let _ = key;
        can_frame_time(&frame, self.drive.line.link.bitrate()).unwrap_or_default() * 2
    }

    fn write_time(&self, key: CodeKey) -> Duration {
        self.read_time(key)
    }

    fn running(&mut self) -> Result<Option<bool>, EngineError> {
        let Some(ind) = self.drive.schema.running_indicator() else {
            return Ok(None);
        };
        match super::DriveClient::read(self, CodeKey::new(ind.code))? {
            RawValue::Int(v) => Ok(Some(v >> ind.bit & 1 == 1)),
            _ => Ok(None),
        }
    }

    fn finish(&mut self) -> Result<(), EngineError> {
        Ok(())
    }
}

/// An SDO read of `key` at `node` on `line` (the scan probe): `Ok(None)`
/// when nothing answers, `Ok(Some(text))` for a value or an abort (a node
/// is there either way).
pub(crate) fn probe<L: FrameLink>(
    line: &mut SdoLine<L>,
    schema: &Schema,
    node: NodeId,
    key: CodeKey,
    timeout: Duration,
    tries: u32,
) -> Result<Option<String>, LinkError> {
    let Some((index, subindex)) = mux_of(schema, key) else {
        return Ok(None);
    };
    let wire = schema
        .code(key.number)
        .and_then(|c| wire_of(schema, c))
        .unwrap_or(Wire::Fix32);
    for attempt in 0..tries.max(1) {
        if attempt > 0 {
            line.stats.retries += 1;
        }
        line.sdo = SdoClient::new();
        let Ok(first) = line.sdo.start_read(index, subindex) else {
            return Ok(None);
        };
        match line.transfer(node, first, timeout)? {
            Outcome::Done(Completed::Read { data, .. }) => {
                return Ok(Some(match bytes_to_raw(wire, &data) {
                    Some(RawValue::Int(v)) => v.to_string(),
                    Some(RawValue::Text(t)) => t,
                    _ => format!("{} bytes", data.len()),
                }));
            }
            Outcome::Done(_) => return Ok(Some(String::new())),
            Outcome::Aborted(a) => return Ok(Some(format!("(abort {})", a.code))),
            Outcome::Failed(_) | Outcome::NoAnswer => {}
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lenze codes at 24575 - code, objects kept by index at their index,
    /// and a subindex kept as a code of its own (`subindex`) at its own
    /// subindex, whatever subcode the key carries.
    #[test]
    fn sdo_addresses_of_codes_objects_and_single_subindexes() {
        let text = "[schema]\nid = \"t\"\ntitle = \"T\"\nprotocol = \"lenze-can-sdo\"\ncode_style = \"lenze\"\n\
             [schema.can]\nindex_base = 24575\n\
             [[code]]\nnumber = 39\nname = \"jog\"\ntitle = \"t\"\nspec = \"s\"\ntype = \"FIX32\"\nsubcodes = 2\n\
             [[code]]\nindex = 0x1017\nname = \"hb\"\ntitle = \"t\"\nspec = \"s\"\ntype = \"UNSIGNED16\"\n\
             [[code]]\nindex = 0x1018\nsubindex = 2\nname = \"product\"\ntitle = \"t\"\nspec = \"s\"\ntype = \"UNSIGNED32\"\naccess = \"ro\"\n";
        let schema = driveset_schema::Registry::new()
            .add_source(driveset_schema::error::SourceFile::new("t.toml", text))
            .expect("schema");
        let at = |key: CodeKey| mux_of(&schema, key).map(|(i, s)| (i.0, s.0));
        assert_eq!(at(CodeKey::sub(39, 2)), Some((0x5FD8, 2)));
        assert_eq!(at(CodeKey::new(0x1_1017)), Some((0x1017, 0)));
        let product = 0x100_0000 + 0x1018 * 256 + 2;
        assert_eq!(at(CodeKey::new(product)), Some((0x1018, 2)));
    }

    /// CiA 301 integer objects travel in their own width (CiA 301 §7.1.4),
    /// little-endian, sign-extended only for INTEGERn.
    #[test]
    fn cia_integer_wires() {
        let i16w = Wire::Int {
            bytes: 2,
            signed: true,
        };
        let u16w = Wire::Int {
            bytes: 2,
            signed: false,
        };
        let u8w = Wire::Int {
            bytes: 1,
            signed: false,
        };
        assert_eq!(
            raw_to_bytes(i16w, &RawValue::Int(-2)),
            Some(vec![0xFE, 0xFF])
        );
        assert_eq!(raw_to_bytes(i16w, &RawValue::Int(32768)), None);
        assert_eq!(
            raw_to_bytes(u16w, &RawValue::Int(65535)),
            Some(vec![0xFF, 0xFF])
        );
        assert_eq!(raw_to_bytes(u16w, &RawValue::Int(-1)), None);
        assert_eq!(raw_to_bytes(u8w, &RawValue::Int(256)), None);
        assert_eq!(raw_to_bytes(u8w, &RawValue::Int(7)), Some(vec![7]));
        assert_eq!(bytes_to_raw(i16w, &[0xFE, 0xFF]), Some(RawValue::Int(-2)));
        assert_eq!(
            bytes_to_raw(u16w, &[0xFE, 0xFF]),
            Some(RawValue::Int(65534))
        );
        // a shorter answer is zero-extended; a longer one is refused
        assert_eq!(bytes_to_raw(i16w, &[0xFE]), Some(RawValue::Int(254)));
        assert_eq!(bytes_to_raw(u8w, &[1, 2]), None);
        assert_eq!(bytes_to_raw(u8w, &[]), None);
    }
}
