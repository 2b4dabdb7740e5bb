//! The body of the `slcan_sdo_stream` fuzz target, here so that a plain
//! unit test can replay the seed corpus without cargo-fuzz
//! (`tests/integration/can_fuzz_corpus.rs`). Not API.
//!
//! The input is one byte stream fed to both slcan decoders (host side and
//! adapter side). Every decoded message must re-encode to bytes that decode
//! to the same message; every 8-byte frame is fed to an SDO client and an
//! SDO server (with a small in-memory dictionary), whose answers must
//! encode too. Panics (the fuzzer's findings) are assertion failures only.

use std::collections::BTreeMap;

use super::abort::AbortCode;
use super::frame::{CanFrame, SdoRequest, SdoResponse};
use super::lenze::{Index, Subindex};
use super::slcan::{CommandDecoder, MAX_LINE, ResponseDecoder, SlcanCommand, SlcanResponse};
use super::transfer::{ClientEvent, ObjectDictionary, SdoClient, SdoServer};

/// A bounded dictionary: C0011 (index 0x5FF4) read-write, C0001 (0x5FFE)
/// read-only, anything else below 0x6000 created on write (up to 32
/// entries), the rest does not exist.
#[derive(Default)]
struct Od(BTreeMap<(u16, u8), Vec<u8>>);

impl ObjectDictionary for Od {
    fn read(&mut self, index: Index, subindex: Subindex) -> Result<Vec<u8>, AbortCode> {
        self.0
            .get(&(index.0, subindex.0))
            .cloned()
            .ok_or(AbortCode::NO_SUCH_OBJECT)
    }
    fn write(&mut self, index: Index, subindex: Subindex, data: &[u8]) -> Result<(), AbortCode> {
        match index.0 {
            0x5FFE => Err(AbortCode::READ_ONLY),
            0x6000.. => Err(AbortCode::NO_SUCH_OBJECT),
            _ if self.0.len() >= 32 => Err(AbortCode::OUT_OF_MEMORY),
            _ => {
                self.0.insert((index.0, subindex.0), data.to_vec());
                Ok(())
            }
        }
    }
}

fn check_frame_payload(frame: &CanFrame) {
    if let Ok(q) = SdoRequest::decode(frame.payload()) {
        assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
    }
    if let Ok(r) = SdoResponse::decode(frame.payload()) {
        assert_eq!(SdoResponse::decode(&r.encode()), Ok(r));
    }
}

/// Runs one fuzz input. Panics only on a broken invariant.
pub fn slcan_sdo_stream(data: &[u8]) {
    let mut host = ResponseDecoder::new();
    let mut adapter = CommandDecoder::new();
    let mut client = SdoClient::with_max_len(1024);
    let mut server = SdoServer::with_max_len(1024);
    let mut od = Od::default();
    let mut out = Vec::new();

    for &byte in data {
        // adapter side: host -> adapter commands drive the SDO server
        if let Some(Ok(cmd)) = adapter.push(byte) {
            out.clear();
            if cmd.encode(&mut out).is_ok() {
                let mut again = CommandDecoder::new();
                assert_eq!(again.feed(&out), vec![Ok(cmd)]);
            }
            if let SlcanCommand::Transmit(frame) = cmd {
                check_frame_payload(&frame);
                if let Some(r) = server.on_frame_data(frame.payload(), &mut od) {
                    assert_eq!(SdoResponse::decode(&r.encode()), Ok(r));
                }
            }
        }
        assert!(adapter.pending() <= MAX_LINE);

        // host side: adapter -> host responses drive the SDO client
        if let Some(Ok(resp)) = host.push(byte) {
            out.clear();
            if resp.encode(&mut out).is_ok() {
                let mut again = ResponseDecoder::new();
                assert_eq!(again.feed(&out), vec![Ok(resp)]);
            }
            if let SlcanResponse::Received { frame, .. } = resp {
                check_frame_payload(&frame);
                if client.is_idle() {
                    // start something from the frame's own bytes
                    let p = frame.payload();
                    let index = Index(u16::from_le_bytes([
                        p.first().copied().unwrap_or(0),
                        p.get(1).copied().unwrap_or(0),
                    ]));
                    let started = if frame.id & 1 == 0 {
                        client.start_read(index, Subindex(0))
                    } else {
                        client.start_write(index, Subindex(0), p)
                    };
                    assert!(started.is_ok());
                }
                match client.on_frame_data(frame.payload()) {
                    ClientEvent::Send(q) => {
                        assert_eq!(SdoRequest::decode(&q.encode()), Ok(q));
                    }
                    ClientEvent::Failed { abort: Some(q), .. } => {
                        assert!(matches!(q, SdoRequest::Abort(_)));
                        assert!(client.is_idle());
                    }
                    ClientEvent::Done(_) | ClientEvent::Aborted(_) => {
                        assert!(client.is_idle());
                    }
                    ClientEvent::Failed { abort: None, .. } => {}
                }
            }
        }
        assert!(host.pending() <= MAX_LINE);
    }
    // the clock runs out at the end of the input
    if let Some(q) = client.on_timeout() {
        assert!(matches!(q, SdoRequest::Abort(a) if a.code == AbortCode::TIMEOUT));
    }
    let _ = server.on_timeout();
    assert!(client.is_idle() && server.is_idle());
}
