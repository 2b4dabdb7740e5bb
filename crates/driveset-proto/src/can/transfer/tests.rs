use super::*;
use std::collections::BTreeMap;

/// A tiny dictionary: 0x2000 read-write, 0x2001 read-only, nothing else.
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
            0x2000 => {
                self.0.insert((index.0, subindex.0), data.to_vec());
                Ok(())
            }
            0x2001 => Err(AbortCode::READ_ONLY),
            _ => Err(AbortCode::NO_SUCH_OBJECT),
        }
    }
}

/// (request bytes, response bytes) of one exchange.
type Exchange = ([u8; 8], [u8; 8]);

/// Runs a transfer to its end, returning the final event and the
/// frames exchanged (request bytes, response bytes).
fn run(
    client: &mut SdoClient,
    server: &mut SdoServer,
    od: &mut Od,
    first: SdoRequest,
) -> (ClientEvent, Vec<Exchange>) {
    let mut log = Vec::new();
    let mut q = first;
    for _ in 0..100_000 {
        let qb = q.encode();
        let r = server.on_frame_data(&qb, od).expect("server answers");
        let rb = r.encode();
        log.push((qb, rb));
        match client.on_frame_data(&rb) {
            ClientEvent::Send(next) => q = next,
            other => return (other, log),
        }
    }
    panic!("transfer did not end");
}

#[test]
fn segmented_download_exact_frames() {
    let (mut c, mut s, mut od) = (SdoClient::new(), SdoServer::new(), Od::default());
    let q = c
        .start_write(Index(0x2000), Subindex(1), b"ABCDEFGHIJ")
        .unwrap();
    let (ev, log) = run(&mut c, &mut s, &mut od, q);
    assert_eq!(
        ev,
        ClientEvent::Done(Completed::Written {
            index: Index(0x2000),
            subindex: Subindex(1)
        })
    );
    assert_eq!(
        log,
        vec![
            (
                [0x21, 0x00, 0x20, 0x01, 10, 0, 0, 0],
                [0x60, 0x00, 0x20, 0x01, 0, 0, 0, 0]
            ),
            (
                [0x00, b'A', b'B', b'C', b'D', b'E', b'F', b'G'],
                [0x20, 0, 0, 0, 0, 0, 0, 0]
            ),
            // t=1, n=4, c=1 -> 0x19
            (
                [0x19, b'H', b'I', b'J', 0, 0, 0, 0],
                [0x30, 0, 0, 0, 0, 0, 0, 0]
            ),
        ]
    );
    assert_eq!(od.0[&(0x2000, 1)], b"ABCDEFGHIJ");
    assert!(c.is_idle() && s.is_idle());
}

#[test]
fn segmented_upload_exact_frames() {
    let (mut c, mut s, mut od) = (SdoClient::new(), SdoServer::new(), Od::default());
    od.0.insert((0x2000, 0), b"0123456789ABCDE".to_vec());
    let q = c.start_read(Index(0x2000), Subindex(0)).unwrap();
    let (ev, log) = run(&mut c, &mut s, &mut od, q);
    assert_eq!(
        ev,
        ClientEvent::Done(Completed::Read {
            index: Index(0x2000),
            subindex: Subindex(0),
            data: b"0123456789ABCDE".to_vec()
        })
    );
    assert_eq!(
        log,
        vec![
            (
                [0x40, 0x00, 0x20, 0, 0, 0, 0, 0],
                [0x41, 0x00, 0x20, 0, 15, 0, 0, 0]
            ),
            (
                [0x60, 0, 0, 0, 0, 0, 0, 0],
                [0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']
            ),
            (
                [0x70, 0, 0, 0, 0, 0, 0, 0],
                [0x10, b'7', b'8', b'9', b'A', b'B', b'C', b'D']
            ),
            // t=0, n=6, c=1 -> 0x0D
            ([0x60, 0, 0, 0, 0, 0, 0, 0], [0x0D, b'E', 0, 0, 0, 0, 0, 0]),
        ]
    );
}

#[test]
fn round_trip_every_length() {
    for len in 0..=40usize {
        let value: Vec<u8> = (0..len as u8).map(|b| b.wrapping_mul(37)).collect();
        let (mut c, mut s, mut od) = (SdoClient::new(), SdoServer::new(), Od::default());
        let q = c.start_write(Index(0x2000), Subindex(0), &value).unwrap();
        let (ev, _) = run(&mut c, &mut s, &mut od, q);
        assert!(
            matches!(ev, ClientEvent::Done(Completed::Written { .. })),
            "{len}: {ev:?}"
        );
        let q = c.start_read(Index(0x2000), Subindex(0)).unwrap();
        let (ev, _) = run(&mut c, &mut s, &mut od, q);
        match ev {
            ClientEvent::Done(Completed::Read { data, .. }) => assert_eq!(data, value, "{len}"),
            other => panic!("{len}: {other:?}"),
        }
    }
}

#[test]
fn device_aborts_reach_the_client() {
    let (mut c, mut s, mut od) = (SdoClient::new(), SdoServer::new(), Od::default());
    let q = c
        .start_write(Index(0x2001), Subindex(0), &[1, 2, 3, 4])
        .unwrap();
    let (ev, log) = run(&mut c, &mut s, &mut od, q);
    assert_eq!(
        ev,
        ClientEvent::Aborted(SdoAbort::new(
            Index(0x2001),
            Subindex(0),
            AbortCode::READ_ONLY
        ))
    );
    assert_eq!(log[0].1, [0x80, 0x01, 0x20, 0x00, 0x02, 0x00, 0x01, 0x06]);
    let q = c.start_read(Index(0x5FF4), Subindex(0)).unwrap();
    let (_, log) = run(&mut c, &mut s, &mut od, q);
    assert_eq!(log[0].1, [0x80, 0xF4, 0x5F, 0x00, 0x00, 0x00, 0x02, 0x06]);
    // segmented write to a read-only object: aborted after the last segment
    let q = c.start_write(Index(0x2001), Subindex(0), &[0; 9]).unwrap();
    let (ev, log) = run(&mut c, &mut s, &mut od, q);
    assert!(matches!(ev, ClientEvent::Aborted(a) if a.code == AbortCode::READ_ONLY));
    assert_eq!(log.len(), 3);
    assert!(c.is_idle() && s.is_idle());
}

#[test]
fn server_aborts_on_toggle_error() {
    let (mut s, mut od) = (SdoServer::new(), Od::default());
    let init = SdoRequest::InitiateWrite {
        index: Index(0x2000),
        subindex: Subindex(0),
        size: Some(14),
    };
    assert!(matches!(
        s.on_request(init, &mut od),
        Some(SdoResponse::WriteAck { .. })
    ));
    let seg = |toggle| SdoRequest::WriteSegment {
        toggle,
        data: SegmentData::new(&[1; 7]).unwrap(),
        last: false,
    };
    assert_eq!(
        s.on_request(seg(false), &mut od),
        Some(SdoResponse::WriteSegmentAck { toggle: false })
    );
    // repeated toggle 0
    let r = s.on_request(seg(false), &mut od).unwrap();
    assert_eq!(r.encode(), [0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x03, 0x05]);
    assert!(s.is_idle());
    // a segment while idle: command not valid
    let r = s.on_request(seg(true), &mut od).unwrap();
    assert!(matches!(r, SdoResponse::Abort(a) if a.code == AbortCode::INVALID_COMMAND));
}

#[test]
fn client_aborts_on_toggle_error() {
    let mut c = SdoClient::new();
    c.start_read(Index(0x2000), Subindex(0)).unwrap();
    let ev = c.on_frame_data(&[0x41, 0x00, 0x20, 0, 20, 0, 0, 0]);
    assert_eq!(
        ev,
        ClientEvent::Send(SdoRequest::ReadSegment { toggle: false })
    );
    let ev = c.on_frame_data(&[0x10, 1, 2, 3, 4, 5, 6, 7]);
    match ev {
        ClientEvent::Failed { abort: Some(q), .. } => {
            assert_eq!(q.encode(), [0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x03, 0x05])
        }
        other => panic!("{other:?}"),
    }
    assert!(c.is_idle());
    // stray response while idle: ignored, no abort
    assert_eq!(
        c.on_frame_data(&[0x60, 0, 0, 0, 0, 0, 0, 0]),
        ClientEvent::Failed {
            error: TransferError::NotRunning,
            abort: None
        }
    );
}

#[test]
fn limits_and_size_checks() {
    let mut c = SdoClient::with_max_len(10);
    c.start_read(Index(0x2000), Subindex(0)).unwrap();
    let ev = c.on_frame_data(&[0x41, 0x00, 0x20, 0, 11, 0, 0, 0]);
    assert!(matches!(
        ev,
        ClientEvent::Failed { error: TransferError::TooLong { len: 11, max: 10 }, abort: Some(SdoRequest::Abort(a)) }
            if a.code == AbortCode::OUT_OF_MEMORY
    ));
    // size indicated 8, only 7 arrive with the last flag
    let mut c = SdoClient::new();
    c.start_read(Index(0x2000), Subindex(0)).unwrap();
    c.on_frame_data(&[0x41, 0x00, 0x20, 0, 8, 0, 0, 0]);
    let ev = c.on_frame_data(&[0x01, 1, 2, 3, 4, 5, 6, 7]);
    assert!(matches!(
        ev,
        ClientEvent::Failed {
            error: TransferError::SizeMismatch {
                indicated: 8,
                got: 7
            },
            ..
        }
    ));
    let mut s = SdoServer::with_max_len(8);
    let r = s.on_request(
        SdoRequest::InitiateWrite {
            index: Index(0x2000),
            subindex: Subindex(0),
            size: Some(9),
        },
        &mut Od::default(),
    );
    assert!(matches!(r, Some(SdoResponse::Abort(a)) if a.code == AbortCode::OUT_OF_MEMORY));
    assert_eq!(
        c.start_write(Index(0), Subindex(0), &[0; 5]).map(|_| ()),
        Ok(())
    );
    assert_eq!(
        c.start_read(Index(0), Subindex(0)),
        Err(TransferError::Busy)
    );
    assert_eq!(
        c.on_timeout().map(|q| q.encode()),
        Some([0x80, 0, 0, 0, 0x00, 0x00, 0x04, 0x05])
    );
    assert_eq!(c.on_timeout(), None);
}
