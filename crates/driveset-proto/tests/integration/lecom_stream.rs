//! Replays the seed corpus of the `lecom_stream` fuzz target
//! (`fuzz/corpus/lecom_stream/`) through the LECOM-A/B decoders, so CI
//! checks it without cargo-fuzz, and checks what the clean captures hold.

use std::path::Path;

use driveset_test_support::files_in;

use driveset_proto::lecom::fuzzing::lecom_stream;
use driveset_proto::lecom::{BusSniffer, Frame, HostFrame, Response, Telegram};

fn corpus() -> Vec<(String, Vec<u8>)> {
    files_in(&Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/lecom_stream"))
}

#[test]
fn every_corpus_file_replays_without_breaking_an_invariant() {
    let files = corpus();
    assert!(
        files.len() >= 10,
        "seed corpus missing: {} files",
        files.len()
    );
    for (name, data) in &files {
        lecom_stream(data);
        // Also every prefix: captures cut off anywhere.
        for end in 0..data.len() {
            lecom_stream(&data[..end]);
        }
        eprintln!("{name}: {} bytes ok", data.len());
    }
}

#[test]
fn clean_captures_decode_completely() {
    for (name, data) in corpus() {
        if !(name.starts_with("spec_")
            || name.starts_with("extended")
            || name.starts_with("value")
            || name.starts_with("bcc_is_eot")
            || name.starts_with("no_such_code"))
        {
            continue;
        }
        let events = BusSniffer::decode_all(&data);
        for e in &events {
            assert!(e.result.is_ok(), "{name}: {e:?}");
        }
        // Every byte belongs to a frame (a "no such code" EOT may belong to
        // the next host telegram as well).
        let mut covered = vec![false; data.len()];
        for e in &events {
            for i in e.range.clone() {
                covered[i as usize] = true;
            }
        }
        assert!(covered.iter().all(|&c| c), "{name}: {covered:?}");
    }
}

#[test]
fn garbage_capture_keeps_its_telegrams() {
    let data = corpus()
        .into_iter()
        .find(|(n, _)| n == "garbage_resync.bin")
        .unwrap()
        .1;
    let frames: Vec<Frame> = BusSniffer::decode_all(&data)
        .into_iter()
        .filter_map(|e| e.result.ok())
        .collect();
    let receives = frames
        .iter()
        .filter(|f| matches!(f, Frame::Host(HostFrame::Telegram(Telegram::Receive(_)))))
        .count();
    assert_eq!(receives, 2);
    assert!(
        frames
            .iter()
            .any(|f| matches!(f, Frame::Controller(Response::Value { .. })))
    );
}
