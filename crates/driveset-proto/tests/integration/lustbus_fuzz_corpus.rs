//! Replays the seed corpus of the `lustbus_stream` fuzz target
//! (`fuzz/corpus/lustbus_stream/`) through the LUSTBUS decoders, so CI
//! checks it without cargo-fuzz, and checks what the clean captures hold.

use std::path::Path;

use driveset_test_support::files_in;

use driveset_proto::lustbus::fuzzing::lustbus_stream;
use driveset_proto::lustbus::{FrameError, Sniffer};

fn corpus() -> Vec<(String, Vec<u8>)> {
    files_in(&Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/lustbus_stream"))
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
        lustbus_stream(data);
        // Every prefix too: captures cut off anywhere.
        for end in 0..data.len() {
            lustbus_stream(&data[..end]);
        }
        eprintln!("{name}: {} bytes ok", data.len());
    }
}

#[test]
fn clean_captures_decode_without_errors() {
    for (name, data) in corpus() {
        if name.starts_with("garbage") {
            continue;
        }
        let mut s = Sniffer::new();
        let mut ev: Vec<_> = s.feed(&data).collect();
        ev.extend(s.finish());
        assert!(!ev.is_empty(), "{name}");
        for e in &ev {
            assert!(e.result.is_ok(), "{name}: {e:?}");
        }
    }
}

#[test]
fn garbage_capture_reports_each_fault() {
    let data = corpus()
        .into_iter()
        .find(|(n, _)| n == "garbage_bad_bcc_parity.bin")
        .unwrap()
        .1;
    let mut s = Sniffer::new();
    let mut ev: Vec<_> = s.feed(&data).collect();
    ev.extend(s.finish());
    let errors: Vec<_> = ev.iter().filter_map(|e| e.result.err()).collect();
    assert!(matches!(
        errors[0],
        FrameError::Garbage {
            len: 6,
            first: 0x7F
        }
    ));
    assert!(
        errors
            .iter()
            .any(|e| matches!(e, FrameError::BadBcc { received: 0, .. }))
    );
    assert!(
        errors
            .iter()
            .any(|e| matches!(e, FrameError::Unexpected { .. }))
    );
    // The parity-flagged ENQUIRY, two lone EOTs and the late ACK decode.
    assert_eq!(ev.iter().filter(|e| e.result.is_ok()).count(), 4);
}
