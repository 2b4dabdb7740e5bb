//! The body of the `lustbus_stream` fuzz target, here so that
//! `tests/integration/lustbus_fuzz_corpus.rs` replays the seed corpus in CI without
//! cargo-fuzz. It panics only when an invariant breaks.

use crate::ascii::mask7;

use super::codec::decode_telegram;
use super::frame::Telegram;
use super::stream::{ReplyDecoder, RequestDecoder, Sniffer, StreamEvent};

fn sniff(data: &[u8]) -> Vec<StreamEvent> {
    let mut s = Sniffer::new();
    let mut v: Vec<_> = s.feed(data).collect();
    v.extend(s.finish());
    v
}

/// Feeds `data` to every LUSTBUS decoder and checks:
///
/// - nothing panics;
/// - the sniffer's spans partition the input exactly, in order;
/// - every telegram re-encodes to the parity-masked bytes of its span, and
///   the whole-telegram decoder agrees on that span;
/// - byte-by-byte pushing and lazy feeding give the same events;
/// - the master and slave decoders report exactly the sniffer's events of
///   their direction plus the garbage.
pub fn lustbus_stream(data: &[u8]) {
    let events = sniff(data);

    let mut next = 0u64;
    for ev in &events {
        assert_eq!(ev.span.start, next, "spans must be contiguous: {ev:?}");
        assert!(ev.span.end > ev.span.start, "empty span: {ev:?}");
        next = ev.span.end;
        let bytes = &data[ev.span.start as usize..ev.span.end as usize];
        if let Ok(t) = &ev.result {
            let masked: Vec<u8> = bytes.iter().map(|&b| mask7(b)).collect();
            assert_eq!(t.encode().as_bytes(), &masked[..], "re-encoding differs");
            assert_eq!(decode_telegram(bytes).as_ref(), Ok(t));
            assert_eq!(ev.direction, Some(t.direction()));
        }
    }
    assert_eq!(next, data.len() as u64, "input not fully covered");

    let mut s = Sniffer::new();
    let mut pushed = Vec::new();
    for &b in data {
        pushed.extend(s.push(b));
    }
    pushed.extend(s.finish());
    assert_eq!(pushed, events);

    let mut m = ReplyDecoder::new();
    let mut replies: Vec<_> = m.feed(data).collect();
    replies.extend(m.finish());
    let expect: Vec<_> = events
        .iter()
        .filter(|e| {
            !matches!(e.result, Ok(Telegram::Request(_)))
                && e.direction != Some(super::Direction::Host)
        })
        .map(|e| e.span.clone())
        .collect();
    assert_eq!(
        replies.iter().map(|e| e.span.clone()).collect::<Vec<_>>(),
        expect
    );

    let mut d = RequestDecoder::new();
    let mut requests: Vec<_> = d.feed(data).collect();
    requests.extend(d.finish());
    let expect: Vec<_> = events
        .iter()
        .filter(|e| {
            !matches!(e.result, Ok(Telegram::Reply(_)))
                && e.direction != Some(super::Direction::Device)
        })
        .map(|e| e.span.clone())
        .collect();
    assert_eq!(
        requests.iter().map(|e| e.span.clone()).collect::<Vec<_>>(),
        expect
    );
}
