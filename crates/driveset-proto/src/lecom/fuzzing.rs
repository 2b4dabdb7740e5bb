//! The body of the cargo-fuzz target `fuzz/fuzz_targets/lecom_stream.rs`,
//! kept in the library so `tests/integration/lecom_stream.rs` replays the seed corpus
//! (`fuzz/corpus/lecom_stream/`) without cargo-fuzz. Not part of the API.

use super::codec::MAX_TEXT;
use super::frame::{Response, Telegram};
use super::stream::{BusSniffer, Event, Frame, HostFrame, ResponseDecoder, TelegramDecoder};

/// Runs `data` through the three streaming decoders and the whole-frame
/// decoders and checks their invariants. Panics only when an invariant is
/// broken, i.e. on a bug:
///
/// - event ranges lie inside the input and start in stream order;
/// - feeding byte by byte gives the same events as feeding all at once;
/// - every decoded telegram and response encodes and decodes to itself.
pub fn lecom_stream(data: &[u8]) {
    let _ = Telegram::decode(data);
    let _ = Response::decode(data);

    let all = ResponseDecoder::decode_all(data);
    check(data, &all, roundtrip_response);
    let mut d = ResponseDecoder::new();
    let mut bytewise = Vec::new();
    for b in data {
        d.feed(core::slice::from_ref(b), |e| bytewise.push(e));
    }
    d.finish(|e| bytewise.push(e));
    assert_eq!(all, bytewise, "ResponseDecoder depends on chunking");

    let all = TelegramDecoder::decode_all(data);
    check(data, &all, roundtrip_host);
    let mut d = TelegramDecoder::new();
    let mut bytewise = Vec::new();
    for b in data {
        d.feed(core::slice::from_ref(b), |e| bytewise.push(e));
    }
    d.finish(|e| bytewise.push(e));
    assert_eq!(all, bytewise, "TelegramDecoder depends on chunking");

    let all = BusSniffer::decode_all(data);
    check(data, &all, |f| match f {
        Frame::Host(h) => roundtrip_host(h),
        Frame::Controller(r) => roundtrip_response(r),
    });
    let mut d = BusSniffer::new();
    let mut bytewise = Vec::new();
    for chunk in data.chunks(3) {
        d.feed(chunk, |e| bytewise.push(e));
    }
    d.finish(|e| bytewise.push(e));
    assert_eq!(all, bytewise, "BusSniffer depends on chunking");
}

fn check<T>(data: &[u8], events: &[Event<T>], roundtrip: impl Fn(&T)) {
    let n = data.len() as u64;
    let mut last_start = 0;
    for e in events {
        assert!(
            e.range.start <= e.range.end && e.range.end <= n,
            "range {:?} outside 0..{n}",
            e.range
        );
        assert!(e.range.start >= last_start, "events out of order");
        // One frame never spans more than its longest form.
        assert!(e.range.end - e.range.start <= (4 + MAX_TEXT + 2) as u64 || e.result.is_err());
        last_start = e.range.start;
        if let Ok(item) = &e.result {
            roundtrip(item);
        }
    }
}

fn roundtrip_host(h: &HostFrame) {
    if let HostFrame::Telegram(t) = h {
        let bytes = t.to_bytes().expect("a decoded telegram encodes");
        assert_eq!(Telegram::decode(&bytes).as_ref(), Ok(t));
    }
}

fn roundtrip_response(r: &Response) {
    assert_eq!(Response::decode(&r.to_bytes()).as_ref(), Ok(r));
}
